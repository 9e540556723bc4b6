//! Test fixtures the stage kinds' tests share: tables and stage outputs as
//! input artifacts, parameters from YAML, fit tables read back.

use std::path::Path;

use arrow_array::RecordBatch;
use serde_json::Value;

use super::fit::JACKKNIFE_FILE;
use super::tables::Columns;
use crate::pipeline::graph::StageId;
use crate::pipeline::{Artifact, Output};
use crate::table::results::{NOTE, QUANTITY, VALUE};
use crate::table::{f64_batch, to_parquet_bytes};

/// A table artifact of stage `stage`, written under `dir`.
pub(crate) fn artifact(dir: &Path, stage: &str, b: RecordBatch) -> Artifact {
    let path = dir.join(format!("{stage}.parquet"));
    std::fs::write(&path, to_parquet_bytes(&[b], &[]).unwrap()).unwrap();
    Artifact {
        label: stage.into(),
        ids: vec![StageId {
            figure: Some("test".into()),
            stage: stage.into(),
            point: Default::default(),
        }],
        kind: "table".into(),
        point: Default::default(),
        params: Value::Null,
        run: Default::default(),
        digest: String::new(),
        files: [("parquet".to_string(), (String::new(), path))].into(),
    }
}

/// Stage parameters from YAML.
pub(crate) fn yaml(s: &str) -> Value {
    serde_saphyr::from_str(s).unwrap()
}

/// (quantity, value) pairs and notes of one table.
pub(crate) fn quantities(bytes: &[u8]) -> (Vec<(String, f64)>, Vec<String>) {
    let (b, _) = crate::table::read_parquet_bytes(bytes.to_vec()).unwrap();
    let c = Columns::from_batch(&b[0]).unwrap();
    let q = c.str[QUANTITY].clone();
    let v = c.col(VALUE).unwrap().to_vec();
    (q.into_iter().zip(v).collect(), c.str[NOTE].clone())
}

/// The output of a stage as an input artifact of stage `stage`; `skip`: a
/// file left out.
pub(crate) fn output_artifact(dir: &Path, stage: &str, out: &Output, skip: &str) -> Artifact {
    let mut a = artifact(dir, stage, f64_batch(&[("x", vec![0.0])]).unwrap());
    a.files.clear();
    for (ext, bytes) in out.files.iter().filter(|(e, _)| *e != skip) {
        let path = dir.join(format!("{stage}.{ext}"));
        std::fs::write(&path, bytes).unwrap();
        a.files.insert(ext.clone(), (String::new(), path));
    }
    a
}

/// The fitted numbers of a fit's output: (quantity, value, error) by name.
pub(crate) fn fitted(dir: &Path, out: &Output) -> Columns {
    Columns::read_file(&[&artifact_of(dir, out)], "parquet").unwrap()
}

/// The main table of an output, as an artifact.
pub(crate) fn artifact_of(dir: &Path, out: &Output) -> Artifact {
    output_artifact(dir, "out", out, JACKKNIFE_FILE)
}
