//! The table of built runs: one row per simulation with its grid point, its
//! resolved settings, its seed and the path of its trajectory (Parquet). What
//! `repro runs` lists and exports, and what a `script` stage receives as its
//! input runs; pyarrow, pandas and polars read it without repro.

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Result;
use arrow_array::{
    ArrayRef, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray, UInt64Array,
};
use serde_json::{Map, Value};

/// One built simulation.
#[derive(Debug, Clone)]
pub struct Run {
    /// The experiment that declares it (`eps09`).
    pub experiment: String,
    /// Its grid point and replica (`phi`, `replica`).
    pub point: Map<String, Value>,
    /// Its resolved settings (`n`, `eps`, ...); objects and lists are left out.
    pub settings: Map<String, Value>,
    pub seed: u64,
    /// Its trajectory.
    pub path: PathBuf,
}

impl Run {
    /// A file name made of its parameters: `eps09_phi=0.78_replica=2.parquet`.
    pub fn file_name(&self) -> String {
        let mut name = self.experiment.clone();
        for (k, v) in &self.point {
            let v = match v {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            name.push_str(&format!("_{k}={v}"));
        }
        name.replace(['/', '\\'], "-") + ".parquet"
    }
}

/// The runs as one table: `experiment`, the point's columns, the settings'
/// columns (those not in the point), `seed`, `path`. A column is integer,
/// float, boolean or text as its values are; a run without the key is null there.
pub fn batch(runs: &[Run]) -> Result<RecordBatch> {
    let point: BTreeSet<&String> = runs.iter().flat_map(|r| r.point.keys()).collect();
    let settings: BTreeSet<&String> = runs
        .iter()
        .flat_map(|r| r.settings.iter())
        .filter(|(k, v)| !point.contains(k) && *k != "seed" && !v.is_object() && !v.is_array())
        .map(|(k, _)| k)
        .collect();
    let mut cols: Vec<(String, ArrayRef)> = vec![(
        "experiment".into(),
        Arc::new(StringArray::from_iter_values(
            runs.iter().map(|r| r.experiment.as_str()),
        )),
    )];
    for k in &point {
        cols.push(((*k).clone(), column(runs.iter().map(|r| r.point.get(*k)))));
    }
    for k in &settings {
        cols.push((
            (*k).clone(),
            column(runs.iter().map(|r| r.settings.get(*k))),
        ));
    }
    cols.push((
        "seed".into(),
        Arc::new(UInt64Array::from_iter_values(runs.iter().map(|r| r.seed))),
    ));
    cols.push((
        "path".into(),
        Arc::new(StringArray::from_iter_values(
            runs.iter().map(|r| r.path.to_string_lossy().into_owned()),
        )),
    ));
    Ok(RecordBatch::try_from_iter(cols)?)
}

/// One column of JSON values: integers, floats, booleans, else text.
fn column<'a>(values: impl Iterator<Item = Option<&'a Value>> + Clone) -> ArrayRef {
    let present = || values.clone().flatten();
    if present().all(|v| v.is_boolean()) {
        Arc::new(BooleanArray::from_iter(
            values.map(|v| v.and_then(Value::as_bool)),
        ))
    } else if present().all(|v| v.is_i64()) {
        Arc::new(Int64Array::from_iter(
            values.map(|v| v.and_then(Value::as_i64)),
        ))
    } else if present().all(|v| v.is_number()) {
        Arc::new(Float64Array::from_iter(
            values.map(|v| v.and_then(Value::as_f64)),
        ))
    } else {
        Arc::new(StringArray::from_iter(values.map(|v| {
            v.map(|v| match v {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            })
        })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::Array;
    use serde_json::json;

    fn run(phi: Value, replica: u64, seed: u64) -> Run {
        Run {
            experiment: "eps09".into(),
            point: json!({"phi": phi, "replica": replica})
                .as_object()
                .unwrap()
                .clone(),
            settings: json!({"n": 1000, "eps": 0.9, "phi": 0.5, "tau_guess": {"A": 1}, "seed": 3})
                .as_object()
                .unwrap()
                .clone(),
            seed,
            path: PathBuf::from(format!("/store/{seed}")),
        }
    }

    /// Each value lands in its row under its name, with the type its values
    /// have; the point wins over a setting of the same name, objects are left out.
    #[test]
    fn rows_carry_their_parameters_seed_and_path() {
        let runs = [run(json!(0.78), 2, 11), run(json!(0.8), 0, 12)];
        let b = batch(&runs).unwrap();
        let names: Vec<String> = b
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        assert_eq!(
            names,
            ["experiment", "phi", "replica", "eps", "n", "seed", "path"]
        );
        let phi = b.column(1).as_any().downcast_ref::<Float64Array>().unwrap();
        assert_eq!((phi.value(0), phi.value(1)), (0.78, 0.8));
        let replica = b.column(2).as_any().downcast_ref::<Int64Array>().unwrap();
        assert_eq!((replica.value(0), replica.value(1)), (2, 0));
        let seed = b.column(5).as_any().downcast_ref::<UInt64Array>().unwrap();
        assert_eq!(seed.value(1), 12);
        let path = b.column(6).as_any().downcast_ref::<StringArray>().unwrap();
        assert_eq!(path.value(0), "/store/11");
        assert_eq!(runs[0].file_name(), "eps09_phi=0.78_replica=2.parquet");
    }

    /// A key some runs lack is null there; mixed values become text.
    #[test]
    fn missing_keys_are_null_and_mixed_values_text() {
        let mut a = run(json!(0.78), 0, 1);
        a.settings.insert("schedule".into(), json!("overlap"));
        let b = run(json!("dense"), 1, 2);
        let t = batch(&[a, b]).unwrap();
        let s = t.schema();
        let (i, _) = s.column_with_name("schedule").unwrap();
        assert!(t.column(i).is_null(1));
        let (i, _) = s.column_with_name("phi").unwrap();
        let phi = t.column(i).as_any().downcast_ref::<StringArray>().unwrap();
        assert_eq!((phi.value(0), phi.value(1)), ("0.78", "dense"));
    }
}
