//! Parquet in and out: Arrow record batches written with zstd, atomically.
//!
//! Every table the project writes goes through [`write_parquet`], so all of them are
//! readable by pandas, polars and pyarrow as they are, and a killed process never
//! leaves a truncated file under the final name (write to a temporary file in the
//! same directory, fsync, rename).

pub mod columns;
pub mod references;
pub mod replicas;
pub mod results;
pub mod runs;
pub mod trajectory;

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use arrow_array::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::{WriterProperties, WriterPropertiesBuilder};

/// What a Parquet file holds for us: its record batches and its key-value metadata.
pub type ParquetContents = (Vec<RecordBatch>, Vec<(String, String)>);

/// The writer settings every Parquet file of the project starts from: zstd level 3
/// and a `created_by` naming this crate (no timestamps, so bytes are deterministic).
/// Callers add column-specific settings (encodings, row-group sizes) on top.
pub fn writer_properties() -> Result<WriterPropertiesBuilder> {
    Ok(WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::try_new(3)?))
        .set_created_by(format!("repro {}", env!("CARGO_PKG_VERSION"))))
}

/// `b` with the float columns `which` selects as Int64: every value must be a whole
/// number (NaN becomes null), else an error naming the column and the value.
pub fn integer_columns(b: &RecordBatch, which: impl Fn(&str) -> bool) -> Result<RecordBatch> {
    use arrow_array::{Array, ArrayRef, Float64Array, Int64Array};
    let mut changed = false;
    let mut cols: Vec<(String, ArrayRef)> = Vec::with_capacity(b.num_columns());
    for (f, c) in b.schema().fields().iter().zip(b.columns()) {
        let name = f.name();
        let col = match c.as_any().downcast_ref::<Float64Array>() {
            Some(x) if which(name) => {
                let mut v: Vec<Option<i64>> = Vec::with_capacity(x.len());
                for i in 0..x.len() {
                    let y = x.value(i);
                    v.push(if x.is_null(i) || y.is_nan() {
                        None
                    } else if y.fract() == 0.0 && y.abs() < 9.0e15 {
                        Some(y as i64)
                    } else {
                        anyhow::bail!(
                            "column '{name}' counts something but row {i} holds {y}, not a whole number"
                        )
                    });
                }
                changed = true;
                Arc::new(Int64Array::from(v)) as ArrayRef
            }
            _ => c.clone(),
        };
        cols.push((name.clone(), col));
    }
    if !changed {
        return Ok(b.clone());
    }
    let schema = Arc::new(arrow_schema::Schema::new_with_metadata(
        cols.iter()
            .zip(b.schema().fields())
            .map(|((n, c), f)| {
                arrow_schema::Field::new(n, c.data_type().clone(), true)
                    .with_metadata(f.metadata().clone())
            })
            .collect::<Vec<_>>(),
        b.schema().metadata().clone(),
    ));
    Ok(RecordBatch::try_new(
        schema,
        cols.into_iter().map(|(_, c)| c).collect(),
    )?)
}

/// `b` with its count columns ([`columns::is_count`]) as Int64.
pub fn counts_as_integers(b: &RecordBatch) -> Result<RecordBatch> {
    integer_columns(b, columns::is_count)
}

/// Serialise `batches` (all with the same schema) to Parquet bytes with zstd.
/// Deterministic: the same batches give the same bytes (no timestamps written).
/// Count columns ([`columns::is_count`]) are written as Int64.
pub fn to_parquet_bytes(batches: &[RecordBatch], metadata: &[(&str, &str)]) -> Result<Vec<u8>> {
    let batches = batches
        .iter()
        .map(counts_as_integers)
        .collect::<Result<Vec<_>>>()?;
    let batches = batches.as_slice();
    let first = batches.first().context("no record batch to write")?;
    let mut props = writer_properties()?;
    let kv: Vec<parquet::file::metadata::KeyValue> = metadata
        .iter()
        .map(|(k, v)| parquet::file::metadata::KeyValue::new(k.to_string(), v.to_string()))
        .collect();
    if !kv.is_empty() {
        props = props.set_key_value_metadata(Some(kv));
    }
    // Every known column carries its unit and meaning in the field metadata.
    let schema = Arc::new(arrow_schema::Schema::new_with_metadata(
        first
            .schema()
            .fields()
            .iter()
            .map(|f| match columns::describe(f.name()) {
                Some((unit, description)) => f.as_ref().clone().with_metadata(
                    [
                        ("unit".to_string(), unit),
                        ("description".to_string(), description),
                    ]
                    .into_iter()
                    .collect::<std::collections::HashMap<String, String>>(),
                ),
                None => f.as_ref().clone(),
            })
            .collect::<Vec<_>>(),
        first.schema().metadata().clone(),
    ));
    let mut buf = Vec::new();
    let mut w = ArrowWriter::try_new(&mut buf, schema.clone(), Some(props.build()))?;
    for b in batches {
        let b = RecordBatch::try_new(schema.clone(), b.columns().to_vec())
            .context("record batches of one table must share their columns")?;
        w.write(&b).context("writing record batch")?;
    }
    w.close()?;
    Ok(buf)
}

/// Write bytes to `path` atomically: temporary file in the same directory, fsync, rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)
        .with_context(|| format!("creating directory {}", dir.display()))?;
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    tmp.write_all(bytes)?;
    // NamedTempFile is created 0600; results are meant to be shared (0644).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(path)
        .with_context(|| format!("renaming into {}", path.display()))?;
    Ok(())
}

/// Write `batches` to a Parquet file (zstd), atomically.
pub fn write_parquet(
    path: &Path,
    batches: &[RecordBatch],
    metadata: &[(&str, &str)],
) -> Result<()> {
    let bytes = to_parquet_bytes(batches, metadata)?;
    write_atomic(path, &bytes).with_context(|| format!("writing {}", path.display()))
}

/// Read every record batch of a Parquet file, with its key-value metadata.
pub fn read_parquet(path: &Path) -> Result<ParquetContents> {
    let f = File::open(path).with_context(|| format!("opening {}", path.display()))?;
    read_parquet_from(f).with_context(|| {
        format!(
            "reading Parquet file {} (corrupt or not Parquet?)",
            path.display()
        )
    })
}

/// Read every record batch of Parquet bytes, with its key-value metadata.
pub fn read_parquet_bytes(bytes: Vec<u8>) -> Result<ParquetContents> {
    read_parquet_from(bytes::Bytes::from(bytes))
}

fn read_parquet_from<R: parquet::file::reader::ChunkReader + 'static>(
    r: R,
) -> Result<ParquetContents> {
    let builder = ParquetRecordBatchReaderBuilder::try_new(r)?;
    let kv = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|v| {
            v.iter()
                // The Arrow schema is parquet's own bookkeeping, not the caller's metadata.
                .filter(|k| k.key != "ARROW:schema")
                .map(|k| (k.key.clone(), k.value.clone().unwrap_or_default()))
                .collect()
        })
        .unwrap_or_default();
    let batches = builder
        .build()?
        .collect::<std::result::Result<Vec<_>, _>>()?;
    Ok((batches, kv))
}

/// Build a record batch of f64 columns, the common case for analysis tables.
pub fn f64_batch(columns: &[(&str, Vec<f64>)]) -> Result<RecordBatch> {
    use arrow_array::{ArrayRef, Float64Array};
    let cols: Vec<(&str, ArrayRef)> = columns
        .iter()
        .map(|(n, v)| (*n, Arc::new(Float64Array::from(v.clone())) as ArrayRef))
        .collect();
    Ok(RecordBatch::try_from_iter(cols)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{Array, Float64Array};

    #[test]
    fn roundtrip_is_lossless_and_deterministic() {
        let b = f64_batch(&[("t", vec![0.1, 1.0, 10.0]), ("Q", vec![0.9, 0.5, 1e-300])]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.parquet");
        write_parquet(&p, std::slice::from_ref(&b), &[("phi", "0.78")]).unwrap();
        let (back, kv) = read_parquet(&p).unwrap();
        assert_eq!(back.len(), 1);
        assert_eq!(back[0].columns(), b.columns());
        // Known columns gain their unit and meaning; the data are unchanged.
        let f = back[0].schema().field(0).clone();
        assert_eq!(f.name(), "t");
        assert_eq!(f.metadata()["unit"], "r1 sqrt(m1/T)");
        assert!(f.metadata()["description"].contains("lag"));
        assert_eq!(kv, vec![("phi".to_string(), "0.78".to_string())]);
        let q = back[0]
            .column(1)
            .as_any()
            .downcast_ref::<Float64Array>()
            .unwrap();
        assert_eq!(q.value(2), 1e-300);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(
                std::fs::metadata(&p).unwrap().permissions().mode() & 0o777,
                0o644
            );
        }
        assert_eq!(
            to_parquet_bytes(std::slice::from_ref(&b), &[]).unwrap(),
            to_parquet_bytes(&[b], &[]).unwrap()
        );
    }

    #[test]
    fn counts_are_written_as_integers() {
        use arrow_array::Int64Array;
        let b = f64_batch(&[
            ("t", vec![0.5, 1.0]),
            ("n_origins", vec![12.0, f64::NAN]),
            ("replicas", vec![3.0, 3.0]),
        ])
        .unwrap();
        let (back, _) = read_parquet_bytes(to_parquet_bytes(&[b], &[]).unwrap()).unwrap();
        let s = back[0].schema();
        assert_eq!(s.field(0).data_type(), &arrow_schema::DataType::Float64);
        let n = back[0]
            .column(1)
            .as_any()
            .downcast_ref::<Int64Array>()
            .expect("n_origins is Int64");
        assert_eq!((n.value(0), n.is_null(1)), (12, true));
        assert!(back[0].column(2).as_any().is::<Int64Array>());
        // A count that is not a whole number is a bug upstream, not rounded away.
        let bad = f64_batch(&[("n_vectors", vec![2.5])]).unwrap();
        let e = format!("{:#}", to_parquet_bytes(&[bad], &[]).unwrap_err());
        assert!(e.contains("n_vectors") && e.contains("2.5"), "{e}");
    }

    #[test]
    fn corrupt_file_names_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.parquet");
        std::fs::write(&p, b"not parquet at all").unwrap();
        let e = format!("{:#}", read_parquet(&p).unwrap_err());
        assert!(e.contains("bad.parquet") && e.contains("corrupt"), "{e}");
    }
}
