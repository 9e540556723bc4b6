//! Pooling the tables of replicas (independent seeds at one state point) into one
//! table with statistical errors, and saying how the errors were estimated.
//!
//! Observables that accumulate blocks ([`super::stats::Blocks`]) pool replicas
//! themselves: every (replica, origin bin) is one block of a delete-one jackknife,
//! bins about tau_alpha long so that overlapping origins share a block.
//! The others are computed per replica and pooled here, seed to seed: the mean over
//! replicas with the standard error of that mean.

use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::{Array, ArrayRef, Float64Array, Int64Array, RecordBatch};

/// How a table's error columns (`X_err`) were estimated; written into its metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Errors {
    /// Delete-one jackknife over blocks: time origins of every replica, binned
    /// tau_alpha long.
    Jackknife { replicas: usize },
    /// Standard error of the mean over time blocks of every replica.
    TimeBlocks { replicas: usize },
    /// Standard error of the mean over replicas (seed to seed).
    SeedToSeed { replicas: usize },
    /// One replica: the observable's own errors over its time origins.
    OneReplica,
    /// Delete-one jackknife over replicas of the whole chain (e.g. profile,
    /// moments, slopes), computed by the observable.
    ReplicaJackknife { replicas: usize },
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
                format!(
                    "delete-one jackknife over (replica, origin bin) blocks of {replicas} replica(s), bins tau_alpha long"
                )
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
            Errors::ReplicaJackknife { replicas } => {
                format!("delete-one jackknife over {replicas} replicas")
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

use crate::table::columns::is_count;
pub use crate::table::replicas::{JK_UNIT, jk_column};

/// Pool per-replica tables of identical shape. A column equal in every replica is a
/// key (t, species, bin centres, ...) and kept; a count column (`n_*`, float or
/// integer) is summed; any
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
        let ints: Option<Vec<&Int64Array>> =
            cols.iter().map(|c| c.as_any().downcast_ref()).collect();
        if let (Some(ints), true, false) = (ints, is_count(name), same) {
            // Counts stay integers: summed over replicas.
            let sum: Vec<i64> = (0..first.num_rows())
                .map(|j| ints.iter().map(|v| v.value(j)).sum())
                .collect();
            out.push((name.clone(), Arc::new(Int64Array::from(sum))));
            continue;
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

/// At most this many replicas get leave-one-out columns (each costs one more
/// analysis of the other replicas).
pub const MAX_JK_REPLICAS: usize = 8;

/// `full` with the replica jackknife columns: `jk_unit` = `unit`, and for every
/// float column X that some sample changes (not keys such as t or N, not `X_err`,
/// not counts `n_*`), `X_jk0 .. X_jk{R-1}` from `samples[k]`, the same table
/// computed with replica k left out, and `X_err_jkK` where X has an error column. None when a sample's shape differs from
/// `full` (e.g. a replica realising other lags): then no fit can use them.
pub fn with_replica_samples(
    full: &RecordBatch,
    samples: &[RecordBatch],
    unit: f64,
) -> Result<Option<RecordBatch>> {
    let schema = full.schema();
    if samples
        .iter()
        .any(|s| s.schema() != schema || s.num_rows() != full.num_rows())
    {
        return Ok(None);
    }
    let mut out: Vec<(String, ArrayRef)> = schema
        .fields()
        .iter()
        .zip(full.columns())
        .map(|(f, c)| (f.name().clone(), c.clone()))
        .collect();
    out.push((
        JK_UNIT.into(),
        Arc::new(Float64Array::from(vec![unit; full.num_rows()])),
    ));
    for (i, f) in schema.fields().iter().enumerate() {
        let name = f.name();
        if name.ends_with("_err") || is_count(name) || floats(full.column(i)).is_none() {
            continue;
        }
        if samples
            .iter()
            .all(|s| s.column(i).to_data() == full.column(i).to_data())
        {
            continue; // A key: the same whatever replica is left out.
        }
        for (k, s) in samples.iter().enumerate() {
            out.push((jk_column(name, k), s.column(i).clone()));
        }
        // The sample's own per-point errors: a fit weighting by `X_err` refits
        // each sample with its own weights (`X_err_jkK`).
        let err = format!("{name}_err");
        if let Some((j, _)) = schema.column_with_name(&err) {
            for (k, s) in samples.iter().enumerate() {
                out.push((jk_column(&err, k), s.column(j).clone()));
            }
        }
    }
    Ok(Some(RecordBatch::try_from_iter(out)?))
}

/// Delete-one jackknife over replicas of a number computed from rows of several
/// independent units (state points): `fit(x, y)` is recomputed with the rows of
/// one unit replaced by their values with one replica left out (`x_jk[k]`,
/// `y_jk[k]`; x unchanged when `x_jk` is empty), and the variance is the sum over
/// units of (R - 1)/R sum_k (theta_k - mean)^2. Returns the standard error of
/// every component of `fit`'s result and the number of refits; None when a unit
/// has fewer than two complete samples or a refit fails.
pub fn replica_jackknife(
    units: &[f64],
    x: &[f64],
    y: &[f64],
    x_jk: &[Vec<f64>],
    y_jk: &[Vec<f64>],
    mut fit: impl FnMut(&[f64], &[f64]) -> Option<Vec<f64>>,
) -> Option<(Vec<f64>, usize)> {
    let j = replica_jackknife_with(units, x, y, x_jk, y_jk, &[], |_, x, y| fit(x, y))?;
    Some((j.errors, j.refits.len()))
}

/// One refit of a replica jackknife: replica `replica` of unit `unit` left out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeftOut {
    pub unit: f64,
    pub replica: usize,
}

/// The delete-one jackknife variance of one unit's refits of a number:
/// (r - 1)/r times their sum of squares about their mean (0 under two).
pub fn jackknife_variance(thetas: &[f64]) -> f64 {
    let r = thetas.len() as f64;
    if thetas.len() < 2 {
        return 0.0;
    }
    let mean = thetas.iter().sum::<f64>() / r;
    (r - 1.0) / r * thetas.iter().map(|t| (t - mean).powi(2)).sum::<f64>()
}

/// A replica jackknife: the standard errors and every refit's numbers.
#[derive(Clone, Debug)]
pub struct Jackknife {
    pub errors: Vec<f64>,
    pub refits: Vec<(LeftOut, Vec<f64>)>,
}

/// [`replica_jackknife`] for a number that also depends on numbers measured on
/// the same replicas elsewhere (phi_c of the tau_alpha fit in a fit of chi4 or
/// xi): `fit` learns which replica of which unit is left out, to use those
/// numbers with the same replica left out, and `also` lists (unit, replicas) of
/// units outside the rows that change them (refit with the rows unchanged).
/// Holding such a number at its value would drop its share of the variance.
pub fn replica_jackknife_with(
    units: &[f64],
    x: &[f64],
    y: &[f64],
    x_jk: &[Vec<f64>],
    y_jk: &[Vec<f64>],
    also: &[(f64, usize)],
    mut fit: impl FnMut(LeftOut, &[f64], &[f64]) -> Option<Vec<f64>>,
) -> Option<Jackknife> {
    let mut distinct: Vec<f64> = units.to_vec();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let mut var: Vec<f64> = Vec::new();
    let mut refits = Vec::new();
    let add = |thetas: &[Vec<f64>], var: &mut Vec<f64>| -> Option<()> {
        let r = thetas.len();
        if r < 2 {
            return None;
        }
        var.resize(thetas[0].len(), 0.0);
        for (p, v) in var.iter_mut().enumerate() {
            let column: Vec<f64> = thetas.iter().map(|t| t[p]).collect();
            *v += jackknife_variance(&column);
        }
        Some(())
    };
    for &u in &distinct {
        let rows: Vec<usize> = (0..units.len()).filter(|&i| units[i] == u).collect();
        let mut thetas: Vec<Vec<f64>> = Vec::new();
        for k in 0..y_jk.len() {
            let complete = rows
                .iter()
                .all(|&i| y_jk[k][i].is_finite() && (x_jk.is_empty() || x_jk[k][i].is_finite()));
            if !complete {
                continue;
            }
            let (mut xs, mut ys) = (x.to_vec(), y.to_vec());
            for &i in &rows {
                ys[i] = y_jk[k][i];
                if !x_jk.is_empty() {
                    xs[i] = x_jk[k][i];
                }
            }
            let left = LeftOut {
                unit: u,
                replica: k,
            };
            let theta = fit(left, &xs, &ys)?;
            refits.push((left, theta.clone()));
            thetas.push(theta);
        }
        add(&thetas, &mut var)?;
    }
    for &(u, replicas) in also.iter().filter(|(u, _)| !distinct.contains(u)) {
        let mut thetas: Vec<Vec<f64>> = Vec::new();
        for k in 0..replicas {
            let left = LeftOut {
                unit: u,
                replica: k,
            };
            let theta = fit(left, x, y)?;
            refits.push((left, theta.clone()));
            thetas.push(theta);
        }
        add(&thetas, &mut var)?;
    }
    if refits.is_empty() {
        return None;
    }
    Some(Jackknife {
        errors: var.into_iter().map(f64::sqrt).collect(),
        refits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_stay_integers_and_are_summed() {
        let rep = |n: i64, q: f64| {
            RecordBatch::try_from_iter([
                ("t", Arc::new(Float64Array::from(vec![1.0])) as ArrayRef),
                ("Q", Arc::new(Float64Array::from(vec![q])) as ArrayRef),
                ("n_origins", Arc::new(Int64Array::from(vec![n])) as ArrayRef),
            ])
            .unwrap()
        };
        let (b, e) = seed_to_seed(&[rep(3, 0.4), rep(5, 0.6)]).unwrap();
        assert_eq!(e, Errors::SeedToSeed { replicas: 2 });
        let n = b.column_by_name("n_origins").unwrap();
        let n = n
            .as_any()
            .downcast_ref::<Int64Array>()
            .expect("still Int64");
        assert_eq!(n.value(0), 8);
        let q = b.column_by_name("Q").unwrap();
        let q = q.as_any().downcast_ref::<Float64Array>().unwrap();
        assert!((q.value(0) - 0.5).abs() < 1e-15);
    }

    /// The jackknife of a mean over replicas is the standard error of that
    /// mean; a unit whose replicas agree adds nothing; a number made of two
    /// units' values carries each unit's variance with its weight.
    #[test]
    fn replica_jackknife_of_a_mean_is_its_standard_error() {
        // Rows: unit 1 (replica values 1, 2, 3: pooled 2), unit 2 (5, 5, 5).
        let units = [1.0, 2.0];
        let y = [2.0, 5.0];
        let left_out = |v: [f64; 3]| -> Vec<f64> {
            (0..3)
                .map(|k| (v.iter().sum::<f64>() - v[k]) / 2.0)
                .collect()
        };
        let (a, b) = (left_out([1.0, 2.0, 3.0]), left_out([5.0; 3]));
        let y_jk: Vec<Vec<f64>> = (0..3).map(|k| vec![a[k], b[k]]).collect();
        let mean = |_: &[f64], y: &[f64]| Some(vec![(y[0] + y[1]) / 2.0]);
        let (err, refits) = replica_jackknife(&units, &[0.0, 0.0], &y, &[], &y_jk, mean).unwrap();
        assert_eq!(refits, 6);
        // Unit 1: s^2 / R = 1/3; halved in the mean of two rows: var 1/12.
        assert!((err[0] - (1.0f64 / 12.0).sqrt()).abs() < 1e-12, "{err:?}");
        // A failed refit gives no error at all (never a partial one).
        let fails = |_: &[f64], y: &[f64]| (y[0] < 2.4).then_some(vec![y[0]]);
        assert!(replica_jackknife(&units, &[0.0, 0.0], &y, &[], &y_jk, fails).is_none());
    }

    #[test]
    fn replica_columns_skip_keys_and_counts_and_carry_each_samples_errors() {
        let t = |q: f64| {
            crate::table::f64_batch(&[
                ("t", vec![1.0, 2.0]),
                ("Q", vec![q, q / 2.0]),
                ("Q_err", vec![0.1, 0.1]),
                ("n_origins", vec![4.0, 4.0]),
            ])
            .unwrap()
        };
        let b = with_replica_samples(&t(0.8), &[t(0.7), t(0.9)], 7.0)
            .unwrap()
            .unwrap();
        let names: Vec<String> = b
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        assert_eq!(
            names,
            [
                "t",
                "Q",
                "Q_err",
                "n_origins",
                JK_UNIT,
                "Q_jk0",
                "Q_jk1",
                "Q_err_jk0",
                "Q_err_jk1"
            ]
        );
        let short = crate::table::f64_batch(&[("t", vec![1.0])]).unwrap();
        assert!(
            with_replica_samples(&t(0.8), &[short.clone(), short], 7.0)
                .unwrap()
                .is_none()
        );
    }
}
