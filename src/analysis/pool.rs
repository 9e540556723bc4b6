//! Pooling the tables of replicas (independent seeds at one state point) into one
//! table with statistical errors, and saying how the errors were estimated.
//!
//! Observables that accumulate blocks ([`super::stats::Blocks`]) pool replicas
//! themselves: every (replica, time origin) is one block of a delete-one jackknife.
//! The others are computed per replica and pooled here, seed to seed: the mean over
//! replicas with the standard error of that mean.

use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch};

/// How a table's error columns (`X_err`) were estimated; written into its metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Errors {
    /// Delete-one jackknife over blocks: every time origin of every replica.
    Jackknife { replicas: usize },
    /// Standard error of the mean over time blocks of every replica.
    TimeBlocks { replicas: usize },
    /// Standard error of the mean over replicas (seed to seed).
    SeedToSeed { replicas: usize },
    /// One replica: the observable's own errors over its time origins.
    OneReplica,
    /// No error columns: a plain mean over replicas.
    Mean { replicas: usize },
    /// No error columns: one row per object (cluster, path point) of every replica.
    Rows { replicas: usize },
}

impl Errors {
    /// One line for the table's metadata (`errors`).
    pub fn describe(&self) -> String {
        match self {
            Errors::Jackknife { replicas } => {
                format!("delete-one jackknife over time-origin blocks of {replicas} replica(s)")
            }
            Errors::TimeBlocks { replicas } => {
                format!("standard error of the mean over time blocks of {replicas} replica(s)")
            }
            Errors::SeedToSeed { replicas } => {
                format!("seed to seed: standard error of the mean over {replicas} replicas")
            }
            Errors::Mean { replicas } => {
                format!("no error columns: the mean over {replicas} replica(s)")
            }
            Errors::Rows { replicas } => {
                format!("no error columns: one row per object of each of {replicas} replica(s)")
            }
            Errors::OneReplica => {
                "one replica: errors over its time origins, as the observable defines them"
                    .to_string()
            }
        }
    }
}

fn floats(c: &ArrayRef) -> Option<&Float64Array> {
    c.as_any().downcast_ref::<Float64Array>()
}

/// Whether a column counts something (summed over replicas, not averaged).
fn is_count(name: &str) -> bool {
    name.starts_with("n_")
}

/// Pool per-replica tables of identical shape. A column equal in every replica is a
/// key (t, species, bin centres, ...) and kept; a count column (`n_*`) is summed; any
/// other float column X becomes its mean over replicas, followed by `X_err`, the
/// standard error of that mean (the replicas' own `X_err` columns are replaced).
/// One table is returned as it is.
pub fn seed_to_seed(tables: &[RecordBatch]) -> Result<(RecordBatch, Errors)> {
    let Some(first) = tables.first() else {
        bail!("no replica to pool");
    };
    if tables.len() == 1 {
        return Ok((first.clone(), Errors::OneReplica));
    }
    let r = tables.len() as f64;
    let schema = first.schema();
    for (k, t) in tables.iter().enumerate() {
        if t.schema() != schema || t.num_rows() != first.num_rows() {
            bail!(
                "replica {k} gives {} rows with columns {:?}, replica 0 gives {} rows with {:?}: \
                 per-replica tables must have one shape to be pooled (fix the lags or bins in the parameters)",
                t.num_rows(),
                t.schema()
                    .fields()
                    .iter()
                    .map(|f| f.name())
                    .collect::<Vec<_>>(),
                first.num_rows(),
                schema.fields().iter().map(|f| f.name()).collect::<Vec<_>>()
            );
        }
    }
    let mut out: Vec<(String, ArrayRef)> = Vec::new();
    for (i, f) in schema.fields().iter().enumerate() {
        let name = f.name();
        let cols: Vec<&ArrayRef> = tables.iter().map(|t| t.column(i)).collect();
        let same = cols.iter().all(|c| c.to_data() == cols[0].to_data());
        if let Some(base) = name.strip_suffix("_err")
            && schema.column_with_name(base).is_some()
        {
            continue; // Recomputed next to its base column.
        }
        let vals: Option<Vec<&Float64Array>> = cols.iter().map(|c| floats(c)).collect();
        let (Some(vals), false) = (vals, same) else {
            if !same {
                bail!(
                    "column '{name}' differs between replicas but is not a float column: cannot pool it"
                );
            }
            out.push((name.clone(), cols[0].clone()));
            continue;
        };
        let n = first.num_rows();
        if is_count(name) {
            let sum: Vec<f64> = (0..n)
                .map(|j| vals.iter().map(|v| v.value(j)).sum())
                .collect();
            out.push((name.clone(), Arc::new(Float64Array::from(sum))));
            continue;
        }
        let mut mean = Vec::with_capacity(n);
        let mut err = Vec::with_capacity(n);
        for j in 0..n {
            let m = vals.iter().map(|v| v.value(j)).sum::<f64>() / r;
            let var = vals.iter().map(|v| (v.value(j) - m).powi(2)).sum::<f64>() / (r - 1.0);
            mean.push(m);
            err.push((var / r).sqrt());
        }
        out.push((name.clone(), Arc::new(Float64Array::from(mean))));
        out.push((format!("{name}_err"), Arc::new(Float64Array::from(err))));
    }
    Ok((
        RecordBatch::try_from_iter(out)?,
        Errors::SeedToSeed {
            replicas: tables.len(),
        },
    ))
}
