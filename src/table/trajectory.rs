//! A [`Trajectory`] as a Parquet artifact, read back bit for bit.
//!
//! Layout: one long table, one row per (frame, particle), particles in id order within
//! a frame, frames in time order:
//!
//! | column    | type | meaning                                        |
//! |-----------|------|------------------------------------------------|
//! | `frame`   | u32  | frame index                                    |
//! | `t`       | f64  | simulated time of the frame                    |
//! | `id`      | u32  | particle index                                 |
//! | `species` | u8   | species of the particle (same in every frame)  |
//! | `x`, `y`  | f64  | unwrapped position                             |
//! | `vx`, `vy`| f64  | velocity, only when the run recorded it        |
//!
//! The static data (box, periodicity, radii, masses, a format version and a blake3
//! checksum of the content) is JSON under the key-value metadata key
//! [`METADATA_KEY`], so pandas/pyarrow read the file as it is.
//!
//! Positions stay f64: they are unwrapped, so after a long run |x| reaches the box
//! size (~2000 r1 for 4e6 particles) while short-lag displacements are ~1e-3 r1; f32
//! (24-bit mantissa, resolution 1.2e-4 at 2000) would lose 10% of them. f64 also makes
//! an analysis of the stored file identical to one of the in-memory run, which the
//! cache relies on. Byte-stream-split encoding makes zstd compress the f64 columns.
//!
//! Row groups hold whole frames (about [`ROWS_PER_GROUP`] rows), so a reader can
//! fetch a few frames without decoding the rest.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result, bail, ensure};
use arrow_array::types::{Float64Type, UInt8Type, UInt32Type};
use arrow_array::{
    Array, ArrayRef, ArrowPrimitiveType, Float64Array, PrimitiveArray, RecordBatch, UInt8Array,
    UInt32Array,
};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::Encoding;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;
use serde::{Deserialize, Serialize};

use crate::traj::{Frame, Schedule, Trajectory};

/// Key of the JSON header in the Parquet key-value metadata.
pub const METADATA_KEY: &str = "repro.trajectory";
/// The layout version this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;
/// Target rows per row group; a group always holds whole frames (at least one).
pub const ROWS_PER_GROUP: usize = 1 << 17;

const FORMAT_NAME: &str = "repro-trajectory";

/// The static part of a trajectory, stored as JSON in the file metadata.
#[derive(Serialize, Deserialize)]
struct Header {
    format: String,
    version: u32,
    particles: usize,
    frames: usize,
    box_size: [f64; 2],
    periodic: [bool; 2],
    radii: Vec<f64>,
    masses: Vec<f64>,
    velocities: bool,
    /// blake3 of every value (static data and frames), so a damaged file is refused
    /// instead of silently giving other positions.
    blake3: String,
    /// The recording schedule (which frames are time origins), when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    schedule: Option<Schedule>,
}

/// Serialise a trajectory to Parquet bytes (zstd). Deterministic: the same trajectory
/// gives the same bytes.
pub fn to_parquet_bytes(traj: &Trajectory) -> Result<Vec<u8>> {
    let velocities = check_shape(traj)?;
    let n = traj.n();
    let header = Header {
        format: FORMAT_NAME.to_string(),
        version: FORMAT_VERSION,
        particles: n,
        frames: traj.frames.len(),
        box_size: traj.box_size,
        periodic: traj.periodic,
        radii: traj.radii.clone(),
        masses: traj.masses.clone(),
        velocities,
        blake3: content_hash(traj),
        schedule: traj.schedule.clone(),
    };
    let schema = Arc::new(schema(velocities));
    let mut buf = Vec::new();
    let mut w = ArrowWriter::try_new(&mut buf, schema.clone(), Some(properties(n, &header)?))?;
    let ids = Arc::new(UInt32Array::from_iter_values(0..n as u32)) as ArrayRef;
    let species = Arc::new(UInt8Array::from(traj.species.clone())) as ArrayRef;
    for (k, f) in traj.frames.iter().enumerate() {
        let frame = u32::try_from(k).context("more than 2^32 frames")?;
        let mut cols: Vec<ArrayRef> = vec![
            Arc::new(UInt32Array::from(vec![frame; n])),
            Arc::new(Float64Array::from(vec![f.time; n])),
            ids.clone(),
            species.clone(),
            Arc::new(Float64Array::from(f.x.clone())),
            Arc::new(Float64Array::from(f.y.clone())),
        ];
        if velocities {
            cols.push(Arc::new(Float64Array::from(f.vx.clone())));
            cols.push(Arc::new(Float64Array::from(f.vy.clone())));
        }
        w.write(&RecordBatch::try_new(schema.clone(), cols)?)
            .with_context(|| format!("writing frame {k}"))?;
    }
    w.close()?;
    Ok(buf)
}

/// Parse Parquet bytes written by [`to_parquet_bytes`]. Refuses, with a reason, data
/// that is not a trajectory, of another format version, truncated or damaged.
pub fn from_parquet_bytes(bytes: Vec<u8>) -> Result<Trajectory> {
    let (batches, kv) = super::read_parquet_bytes(bytes)
        .context("corrupt or truncated Parquet data (or not Parquet at all)")?;
    let json = kv
        .iter()
        .find(|(k, _)| k == METADATA_KEY)
        .map(|(_, v)| v)
        .with_context(|| {
            format!("Parquet data without the '{METADATA_KEY}' metadata: not a repro trajectory")
        })?;
    let header = parse_header(json)?;
    let n = header.particles;
    let rows: usize = batches.iter().map(|b| b.num_rows()).sum();
    ensure!(
        n > 0 && Some(rows) == n.checked_mul(header.frames),
        "corrupt trajectory: {rows} rows, but the header announces {} frames x {n} particles",
        header.frames
    );
    let col = |name: &str| column::<Float64Type>(&batches, name);
    let t = col("t")?;
    let (x, y) = (col("x")?, col("y")?);
    let (vx, vy) = if header.velocities {
        (col("vx")?, col("vy")?)
    } else {
        (Vec::new(), Vec::new())
    };
    let frame = column::<UInt32Type>(&batches, "frame")?;
    let id = column::<UInt32Type>(&batches, "id")?;
    let species = column::<UInt8Type>(&batches, "species")?;
    for (r, (&f, &i)) in frame.iter().zip(&id).enumerate() {
        let (want_f, want_i) = (r / n, r % n);
        ensure!(
            f as usize == want_f && i as usize == want_i,
            "corrupt trajectory: row {r} holds (frame {f}, id {i}), expected (frame {want_f}, id {want_i})"
        );
    }
    let frames = (0..header.frames)
        .map(|k| {
            let rows = k * n..(k + 1) * n;
            let part = |v: &[f64]| {
                if v.is_empty() {
                    Vec::new()
                } else {
                    v[rows.clone()].to_vec()
                }
            };
            Frame {
                time: t[k * n],
                x: part(&x),
                y: part(&y),
                vx: part(&vx),
                vy: part(&vy),
            }
        })
        .collect();
    let traj = Trajectory {
        box_size: header.box_size,
        periodic: header.periodic,
        species: species[..n].to_vec(),
        radii: header.radii,
        masses: header.masses,
        frames,
        schedule: header.schedule,
    };
    // Static columns must repeat exactly; the checksum covers the rest.
    for (r, &s) in species.iter().enumerate() {
        ensure!(
            s == traj.species[r % n],
            "corrupt trajectory: particle {} has species {s} in frame {}, {} in frame 0",
            r % n,
            r / n,
            traj.species[r % n]
        );
    }
    for (k, f) in traj.frames.iter().enumerate() {
        ensure!(
            t[k * n..(k + 1) * n]
                .iter()
                .all(|&v| v.to_bits() == f.time.to_bits()),
            "corrupt trajectory: column t is not constant within frame {k}"
        );
    }
    ensure!(
        content_hash(&traj) == header.blake3,
        "corrupt trajectory: content checksum mismatch (the file was damaged after writing)"
    );
    Ok(traj)
}

/// Write a trajectory to `path` atomically (temporary file, fsync, rename).
pub fn write(path: &Path, traj: &Trajectory) -> Result<()> {
    let bytes = to_parquet_bytes(traj)
        .with_context(|| format!("encoding trajectory for {}", path.display()))?;
    super::write_atomic(path, &bytes).with_context(|| format!("writing {}", path.display()))
}

/// Read a trajectory written by [`write`].
pub fn read(path: &Path) -> Result<Trajectory> {
    let bytes = std::fs::read(path).with_context(|| format!("opening {}", path.display()))?;
    from_parquet_bytes(bytes).with_context(|| format!("reading trajectory file {}", path.display()))
}

/// Every frame must hold one value per particle; velocities in all frames or none.
/// Returns whether velocities are recorded.
fn check_shape(traj: &Trajectory) -> Result<bool> {
    let n = traj.n();
    ensure!(n > 0, "a trajectory needs at least one particle");
    u32::try_from(n).context("more than 2^32 particles")?;
    if let Some(&s) = traj
        .species
        .iter()
        .find(|&&s| s as usize >= traj.radii.len())
    {
        bail!(
            "species {s} has no radius: radii are given for species 0..{}",
            traj.radii.len()
        );
    }
    ensure!(
        traj.radii.len() == traj.masses.len(),
        "{} radii but {} masses: give one of each per species",
        traj.radii.len(),
        traj.masses.len()
    );
    let velocities = traj.frames.first().is_some_and(|f| !f.vx.is_empty());
    for (k, f) in traj.frames.iter().enumerate() {
        let want_v = if velocities { n } else { 0 };
        ensure!(
            f.x.len() == n && f.y.len() == n && f.vx.len() == want_v && f.vy.len() == want_v,
            "frame {k} has {} x, {} y, {} vx, {} vy values; expected {n} positions and {want_v} \
             velocities (velocities are recorded in every frame or in none)",
            f.x.len(),
            f.y.len(),
            f.vx.len(),
            f.vy.len()
        );
    }
    Ok(velocities)
}

fn schema(velocities: bool) -> Schema {
    let mut fields = vec![
        Field::new("frame", DataType::UInt32, false),
        Field::new("t", DataType::Float64, false),
        Field::new("id", DataType::UInt32, false),
        Field::new("species", DataType::UInt8, false),
        Field::new("x", DataType::Float64, false),
        Field::new("y", DataType::Float64, false),
    ];
    if velocities {
        fields.push(Field::new("vx", DataType::Float64, false));
        fields.push(Field::new("vy", DataType::Float64, false));
    }
    Schema::new(fields)
}

/// zstd like every table of the project; byte-stream-split f64 columns (zstd then sees
/// the slowly varying exponent bytes together) and delta-coded ids.
fn properties(n: usize, header: &Header) -> Result<WriterProperties> {
    let frames_per_group = (ROWS_PER_GROUP / n).max(1);
    let mut p = super::writer_properties()?
        .set_max_row_group_row_count(Some(frames_per_group * n))
        .set_key_value_metadata(Some(vec![KeyValue::new(
            METADATA_KEY.to_string(),
            serde_json::to_string(header)?,
        )]));
    for c in ["x", "y", "vx", "vy"] {
        let path = ColumnPath::from(c);
        p = p
            .set_column_dictionary_enabled(path.clone(), false)
            .set_column_encoding(path, Encoding::BYTE_STREAM_SPLIT);
    }
    let id = ColumnPath::from("id");
    p = p
        .set_column_dictionary_enabled(id.clone(), false)
        .set_column_encoding(id, Encoding::DELTA_BINARY_PACKED);
    Ok(p.build())
}

fn parse_header(json: &str) -> Result<Header> {
    // Read the version first, so a newer layout is refused for what it is.
    #[derive(Deserialize)]
    struct Version {
        format: String,
        version: u32,
    }
    let v: Version = serde_json::from_str(json)
        .with_context(|| format!("corrupt trajectory: unreadable '{METADATA_KEY}' metadata"))?;
    ensure!(
        v.format == FORMAT_NAME,
        "metadata says format '{}', expected '{FORMAT_NAME}': not a repro trajectory",
        v.format
    );
    ensure!(
        v.version == FORMAT_VERSION,
        "trajectory format version {} is not supported: this build reads version {FORMAT_VERSION} \
         only; rerun the simulation stage (or use the repro version that wrote it)",
        v.version
    );
    serde_json::from_str(json)
        .with_context(|| format!("corrupt trajectory: invalid '{METADATA_KEY}' metadata"))
}

/// One non-null primitive column concatenated over all batches, type checked.
fn column<T: ArrowPrimitiveType>(batches: &[RecordBatch], name: &str) -> Result<Vec<T::Native>> {
    let mut out = Vec::new();
    for b in batches {
        let c = b
            .column_by_name(name)
            .with_context(|| format!("not a repro trajectory: no column '{name}'"))?;
        ensure!(
            c.null_count() == 0,
            "corrupt trajectory: nulls in column '{name}'"
        );
        let a = c
            .as_any()
            .downcast_ref::<PrimitiveArray<T>>()
            .with_context(|| {
                format!(
                    "column '{name}' is {}, expected {}",
                    c.data_type(),
                    T::DATA_TYPE
                )
            })?;
        out.extend_from_slice(a.values());
    }
    Ok(out)
}

/// blake3 over every value, little-endian, in a fixed order.
fn content_hash(traj: &Trajectory) -> String {
    let mut h = blake3::Hasher::new();
    let mut f64s = |v: &[f64]| {
        h.update(&(v.len() as u64).to_le_bytes());
        for chunk in v.chunks(1024) {
            let mut buf = [0u8; 8 * 1024];
            for (b, x) in buf.chunks_exact_mut(8).zip(chunk) {
                b.copy_from_slice(&x.to_le_bytes());
            }
            h.update(&buf[..8 * chunk.len()]);
        }
    };
    f64s(&traj.box_size);
    f64s(&traj.radii);
    f64s(&traj.masses);
    for f in &traj.frames {
        f64s(&[f.time]);
        f64s(&f.x);
        f64s(&f.y);
        f64s(&f.vx);
        f64s(&f.vy);
    }
    h.update(&[traj.periodic[0] as u8, traj.periodic[1] as u8]);
    h.update(&traj.species);
    h.finalize().to_hex().to_string()
}

/// A synthetic trajectory for tests and benchmarks: `n` bidisperse disks (species 0
/// and 1 at random, radii 1 and 1.43) at packing fraction 0.7, uniform random start,
/// then independent Gaussian steps (sigma 0.1 r1) between `frames` frames at
/// t = 0, 1, 2, ... Velocities are the last step, when asked for.
pub fn random_walk(n: usize, frames: usize, velocities: bool, seed: u64) -> Trajectory {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let step = rand_distr::Normal::new(0.0, 0.1).expect("valid normal");
    let radii = vec![1.0, 1.43];
    let species: Vec<u8> = (0..n).map(|_| rng.random_range(0..2u8)).collect();
    let disk_area: f64 = species
        .iter()
        .map(|&s| std::f64::consts::PI * radii[s as usize] * radii[s as usize])
        .sum();
    let side = (disk_area / 0.7).sqrt();
    let mut x: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * side).collect();
    let mut y: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * side).collect();
    let mut out = Vec::with_capacity(frames);
    for k in 0..frames {
        let (dx, dy): (Vec<f64>, Vec<f64>) =
            (0..n).map(|_| (rng.sample(step), rng.sample(step))).unzip();
        if k > 0 {
            x.iter_mut().zip(&dx).for_each(|(x, d)| *x += d);
            y.iter_mut().zip(&dy).for_each(|(y, d)| *y += d);
        }
        let (vx, vy) = if velocities {
            (dx, dy)
        } else {
            (Vec::new(), Vec::new())
        };
        out.push(Frame {
            time: k as f64,
            x: x.clone(),
            y: y.clone(),
            vx,
            vy,
        });
    }
    Trajectory {
        box_size: [side, side],
        periodic: [true, true],
        species,
        radii,
        masses: vec![1.0, 1.43f64.powi(2)],
        frames: out,
        schedule: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equality of every f64 bit (PartialEq would let -0.0 == 0.0 and NaN != NaN).
    fn assert_bit_identical(a: &Trajectory, b: &Trajectory) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.box_size), bits(&b.box_size));
        assert_eq!(a.periodic, b.periodic);
        assert_eq!(a.species, b.species);
        assert_eq!(bits(&a.radii), bits(&b.radii));
        assert_eq!(bits(&a.masses), bits(&b.masses));
        assert_eq!(a.frames.len(), b.frames.len());
        for (f, g) in a.frames.iter().zip(&b.frames) {
            assert_eq!(f.time.to_bits(), g.time.to_bits());
            for (u, v) in [(&f.x, &g.x), (&f.y, &g.y), (&f.vx, &g.vx), (&f.vy, &g.vy)] {
                assert_eq!(bits(u), bits(v));
            }
        }
    }

    /// Values a lossy path would change: signed zero, subnormals, extremes, NaN,
    /// non-terminating decimals in the static data.
    fn awkward() -> Trajectory {
        let mut t = random_walk(5, 3, true, 7);
        t.box_size = [0.1 + 0.2, 1.0 / 3.0];
        t.periodic = [true, false];
        t.radii = vec![1.0, 1.43, std::f64::consts::PI];
        t.masses = vec![1.0, 1.43f64 * 1.43, 1e-300];
        t.species[4] = 2;
        let f = &mut t.frames[1];
        f.x[..4].copy_from_slice(&[-0.0, f64::MIN_POSITIVE / 3.0, f64::MAX, 1e-310]);
        f.vy[0] = f64::NAN;
        f.time = 0.1 + 0.2;
        t
    }

    #[test]
    fn roundtrip_is_bit_identical_with_and_without_velocities() {
        for t in [awkward(), random_walk(300, 4, false, 1)] {
            let back = from_parquet_bytes(to_parquet_bytes(&t).unwrap()).unwrap();
            assert_bit_identical(&t, &back);
        }
    }

    #[test]
    fn bytes_are_deterministic() {
        let t = random_walk(200, 3, true, 2);
        assert_eq!(
            to_parquet_bytes(&t).unwrap(),
            to_parquet_bytes(&t.clone()).unwrap()
        );
    }

    #[test]
    fn file_roundtrip_and_row_groups_hold_whole_frames() {
        let n = ROWS_PER_GROUP / 2 + 1; // one frame per group
        let t = random_walk(n, 3, false, 3);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("traj.parquet");
        write(&p, &t).unwrap();
        assert_bit_identical(&t, &read(&p).unwrap());
        let f = std::fs::File::open(&p).unwrap();
        let meta = parquet::file::reader::FileReader::metadata(
            &parquet::file::reader::SerializedFileReader::new(f).unwrap(),
        )
        .clone();
        let groups: Vec<i64> = meta.row_groups().iter().map(|g| g.num_rows()).collect();
        assert_eq!(groups, vec![n as i64; 3]);
        // Small frames share a group: 1000 particles -> 131 frames per group.
        let small = to_parquet_bytes(&random_walk(1000, 140, false, 4)).unwrap();
        let r =
            parquet::file::reader::SerializedFileReader::new(bytes::Bytes::from(small)).unwrap();
        let groups: Vec<i64> = parquet::file::reader::FileReader::metadata(&r)
            .row_groups()
            .iter()
            .map(|g| g.num_rows())
            .collect();
        assert_eq!(groups, vec![131_000, 9_000]);
    }

    #[test]
    fn truncated_file_is_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cut.parquet");
        let bytes = to_parquet_bytes(&random_walk(100, 2, false, 5)).unwrap();
        for keep in [0, 3, bytes.len() / 2, bytes.len() - 1] {
            std::fs::write(&p, &bytes[..keep]).unwrap();
            let e = format!("{:#}", read(&p).unwrap_err());
            assert!(
                e.contains("cut.parquet") && e.contains("corrupt"),
                "{keep}: {e}"
            );
        }
    }

    #[test]
    fn damaged_bytes_never_give_other_data_silently() {
        let t = random_walk(100, 3, true, 6);
        let bytes = to_parquet_bytes(&t).unwrap();
        let mut refused = 0;
        // Flip one byte at offsets spread over pages, page headers and the footer.
        for k in 1..200 {
            let mut b = bytes.clone();
            let at = k * (b.len() - 1) / 200;
            b[at] ^= 0x5a;
            match from_parquet_bytes(b) {
                Ok(back) => assert_bit_identical(&t, &back),
                Err(e) => {
                    refused += 1;
                    let e = format!("{e:#}");
                    assert!(
                        e.contains("corrupt") || e.contains("not a repro"),
                        "{at}: {e}"
                    );
                }
            }
        }
        // Most bytes carry data; only statistics and padding may be flipped harmlessly.
        assert!(
            refused > 150,
            "only {refused} of 199 damaged copies refused"
        );
    }

    #[test]
    fn other_format_versions_are_refused() {
        let bytes = to_parquet_bytes(&random_walk(10, 2, false, 8)).unwrap();
        let (from, to) = (b"\"version\":1,".as_slice(), b"\"version\":7,".as_slice());
        let at = bytes.windows(from.len()).position(|w| w == from).unwrap();
        let mut b = bytes.clone();
        b[at..at + to.len()].copy_from_slice(to);
        let e = format!("{:#}", from_parquet_bytes(b).unwrap_err());
        assert!(
            e.contains("version 7 is not supported") && e.contains("reads version 1"),
            "{e}"
        );
    }

    #[test]
    fn a_plain_table_is_not_a_trajectory() {
        let batch = crate::table::f64_batch(&[("t", vec![1.0]), ("Q", vec![0.5])]).unwrap();
        let bytes = crate::table::to_parquet_bytes(&[batch], &[]).unwrap();
        let e = format!("{:#}", from_parquet_bytes(bytes).unwrap_err());
        assert!(e.contains("not a repro trajectory"), "{e}");
    }

    #[test]
    fn ragged_frames_are_refused_on_write() {
        let mut t = random_walk(10, 2, true, 9);
        t.frames[1].vx.clear();
        let e = format!("{:#}", to_parquet_bytes(&t).unwrap_err());
        assert!(
            e.contains("frame 1") && e.contains("every frame or in none"),
            "{e}"
        );
        let mut t = random_walk(10, 1, false, 9);
        t.species[3] = 5;
        let e = format!("{:#}", to_parquet_bytes(&t).unwrap_err());
        assert!(e.contains("species 5 has no radius"), "{e}");
    }
}
