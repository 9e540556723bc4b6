//! The framework's own stage kind, `table` (concatenate per-point tables, adding
//! the point as columns), and the registry that holds it.

use std::collections::BTreeSet;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray};
use serde::Deserialize;
use serde_json::Value;

use super::registry::{Registry, typed};
use super::stage::{Artifact, Output, StageCtx, StageKind};
use crate::table::{read_parquet_bytes, to_parquet_bytes};

/// `table`: gather per-point Parquet tables into one, with one column per point
/// key (e.g. `phi`, `replica`, `N_sub`) so a single file holds the whole sweep.
pub struct Table;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableParams {
    /// Settings of the runs each input comes from ([`Artifact::run`]) to add
    /// as columns where its point lacks them: a parameter of one ensemble that
    /// is a grid key of the others (eps = 0.9 of eps09, which is not a grid key
    /// there, beside eps10, eps08, eps07), so one table holds all.
    #[serde(default)]
    from_runs: Vec<String>,
}

impl StageKind for Table {
    type Params = TableParams;
    fn name(&self) -> &str {
        "table"
    }
    fn describe(&self) -> &str {
        "concatenate per-point tables, adding the grid and sweep values as columns"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<TableParams> {
        typed("table", params)
    }
    fn reads_run(&self, p: &TableParams) -> Vec<String> {
        p.from_runs.clone()
    }
    fn run(&self, _ctx: &StageCtx, p: &TableParams, inputs: &[Artifact]) -> Result<Output> {
        let point_of = |a: &Artifact| -> Result<_> {
            let mut pt = a.point.clone();
            for k in &p.from_runs {
                let v = a.run.get(k).with_context(|| {
                    format!(
                        "table: `from_runs` names '{k}', which the runs of input {} do not share (they share: {})",
                        a.label,
                        a.run.keys().cloned().collect::<Vec<_>>().join(", ")
                    )
                })?;
                match pt.get(k) {
                    Some(own) if own.as_f64() != v.as_f64() || own.is_string() != v.is_string() => {
                        bail!(
                            "table: input {} has {k} = {own} in its point but {v} in its runs",
                            a.label
                        )
                    }
                    Some(_) => {}
                    None => {
                        pt.insert(k.clone(), v.clone());
                    }
                }
            }
            Ok(pt)
        };
        let first = point_of(inputs.first().context("table: no input")?)?;
        let keys: BTreeSet<&String> = first.keys().collect();
        let mut out: Vec<(String, RecordBatch)> = Vec::new();
        for a in inputs {
            let point = point_of(a)?;
            let k: BTreeSet<&String> = point.keys().collect();
            if k != keys {
                bail!(
                    "table: input {} has point keys {k:?} but the first input has {keys:?}; gather sources with the same grid, or take the missing keys from the runs with `from_runs: [KEY]`",
                    a.label
                );
            }
            let (batches, _) = read_parquet_bytes(a.read("parquet")?)
                .with_context(|| format!("table: reading {}", a.label))?;
            for b in batches {
                let mut cols: Vec<(String, ArrayRef)> = Vec::new();
                for (name, v) in &point {
                    if b.schema().column_with_name(name).is_some() {
                        bail!(
                            "table: input {} already has a column '{name}', which is also a point key",
                            a.label
                        );
                    }
                    let col: ArrayRef = match v {
                        Value::Number(x) => {
                            Arc::new(Float64Array::from(vec![
                                x.as_f64().unwrap_or(f64::NAN);
                                b.num_rows()
                            ]))
                        }
                        Value::String(s) => {
                            Arc::new(StringArray::from(vec![s.as_str(); b.num_rows()]))
                        }
                        other => bail!(
                            "table: point key '{name}' = {other} of {} is neither a number nor a string",
                            a.label
                        ),
                    };
                    cols.push((name.clone(), col));
                }
                for (f, c) in b.schema().fields().iter().zip(b.columns()) {
                    cols.push((f.name().clone(), c.clone()));
                }
                out.push((a.label.clone(), RecordBatch::try_from_iter(cols)?));
            }
        }
        // Instances may differ in their replica jackknife columns only.
        let labels: Vec<String> = out.iter().map(|(l, _)| l.clone()).collect();
        let out = crate::table::replicas::align(out.into_iter().map(|(_, b)| b).collect())?;
        for (label, b) in labels.iter().zip(&out) {
            if b.schema() != out[0].schema() {
                bail!(
                    "table: input {label} has columns {:?}, unlike the first input's {:?}",
                    b.schema().fields(),
                    out[0].schema().fields()
                );
            }
        }
        if out.is_empty() {
            bail!("table: the inputs hold no record batch");
        }
        Ok(Output::single("parquet", to_parquet_bytes(&out, &[])?))
    }
}

impl Registry {
    /// The framework's own kinds (`table`). The kinds of the library (simulate,
    /// analyses, fits, plots, compare) are added by whoever assembles the registry
    /// (`stages::registry()`): the framework does not know them.
    pub fn framework() -> Self {
        let mut r = Registry::new();
        r.register(Table);
        r
    }
}
