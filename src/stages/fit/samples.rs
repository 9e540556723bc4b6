//! The replica samples of a table's columns as the replica jackknife of a fit
//! takes them ([`crate::fit::uncertainty::replicas`]), and the table of its
//! refits.

use anyhow::Result;
use arrow_array::RecordBatch;

use crate::analysis::pool;
use crate::fit::uncertainty::replicas::Replicas;
use crate::stages::tables::{Columns, pick};
use crate::table::results::{Refit, jackknife_batch};

/// [`super::JACKKNIFE_FILE`]: one row per refit and reported number.
pub(super) fn jackknife_table(
    group: &[(String, f64)],
    rows: &[(String, f64, f64)],
    refits: &[(pool::LeftOut, Vec<f64>)],
) -> Result<RecordBatch> {
    let mut out = Vec::new();
    for (left, theta) in refits {
        for (row, v) in rows.iter().zip(theta) {
            out.push(Refit {
                unit: left.unit,
                replica: left.replica,
                quantity: row.0.clone(),
                value: *v,
            });
        }
    }
    jackknife_batch(group, &out)
}

/// The replica jackknife inputs of `rows` (`pool::with_replica_samples`): unit
/// per row, and the leave-one-out columns of x (empty when x is a key such as
/// phi) and y. None unless y has them. Rows of one state point (a curve over
/// lags, bins or q) count too: R replicas give only R - 1 degrees of freedom,
/// but the per-point errors of such a curve's correlated points make a fit
/// covariance 3 to 30 times too small (docs/accuracy.md).
pub(super) fn replica_columns(c: &Columns, rows: &[usize], x: &str, y: &str) -> Option<Replicas> {
    let units = pick(c.col(pool::JK_UNIT).ok()?, rows);
    if units.is_empty() || units.iter().any(|u| !u.is_finite()) {
        return None;
    }
    let (x_jk, y_jk) = (jk_samples(c, rows, x), jk_samples(c, rows, y));
    if y_jk.len() < 2 || !(x_jk.is_empty() || x_jk.len() == y_jk.len()) {
        return None;
    }
    Some((units, x_jk, y_jk))
}

/// The `replica` of rows that are objects of several replicas (clusters of
/// every replica, `Errors::Rows`), when there are at least two replicas among
/// them; None for tables without the column.
pub(super) fn object_replicas(c: &Columns, rows: &[usize]) -> Option<Vec<f64>> {
    let r = pick(c.col("replica").ok()?, rows);
    let mut d = r.clone();
    d.sort_by(f64::total_cmp);
    d.dedup();
    (d.len() >= 2 && d.iter().all(|v| v.is_finite())).then_some(r)
}

/// The entries `at` of a list of row indices.
pub(super) fn pick_rows(rows: &[usize], at: &[usize]) -> Vec<usize> {
    at.iter().map(|&i| rows[i]).collect()
}

/// The replica samples of rows that all come from one unit (one state point's
/// S4 over q): that unit and the leave-one-out columns of y. None unless every
/// row has the same finite unit and y has at least two samples (x may have its
/// own: the lags of `at` in units of a time measured without the replica).
pub(super) fn unit_columns(c: &Columns, rows: &[usize], y: &str) -> Option<(f64, Vec<Vec<f64>>)> {
    let units = pick(c.col(pool::JK_UNIT).ok()?, rows);
    let unit = *units.first()?;
    if !unit.is_finite() || units.iter().any(|u| u.to_bits() != unit.to_bits()) {
        return None;
    }
    let y_jk = jk_samples(c, rows, y);
    (y_jk.len() >= 2).then_some((unit, y_jk))
}

/// The replica samples `NAME_jk0 ..` of column `name` at `rows` (none if absent).
pub(super) fn jk_samples(c: &Columns, rows: &[usize], name: &str) -> Vec<Vec<f64>> {
    (0..pool::MAX_JK_REPLICAS)
        .map_while(|k| c.col(&pool::jk_column(name, k)).ok().map(|v| pick(v, rows)))
        .collect()
}
