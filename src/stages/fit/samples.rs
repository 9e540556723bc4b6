//! The replica jackknife of a fit: its refits with one replica of one unit left
//! out, the numbers taken from other fits refitted on the same replicas, and
//! how the errors were estimated.

use std::collections::BTreeMap;

use anyhow::Result;
use arrow_array::RecordBatch;

use super::fitting::{fit_form, reported};
use super::group::Points;
use super::params::{FitParams, FromQuantity, Refits};
use crate::analysis::pool;
use crate::stages::tables::{Columns, pick};
use crate::table::results::{Refit, UnitSamples, jackknife_batch};

/// The units (with their replica counts) whose refits move the numbers taken
/// from other fits.
pub(super) fn also_units(shifted: &[(String, Refits)]) -> Vec<(f64, usize)> {
    let mut n: BTreeMap<u64, usize> = BTreeMap::new();
    for (_, r) in shifted {
        for &(u, k) in r.keys() {
            let e = n.entry(u).or_default();
            *e = (*e).max(k + 1);
        }
    }
    n.into_iter().map(|(u, r)| (f64::from_bits(u), r)).collect()
}

/// "phi_c of power_law, ...": the numbers taken from other fits.
pub(super) fn from_names(from: &BTreeMap<String, FromQuantity>) -> String {
    from.values()
        .map(|f| format!("{} of {}", f.quantity, f.stage))
        .collect::<Vec<_>>()
        .join(", ")
}

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

/// Appended to the error method when the replica jackknife could not be done.
pub(super) const JK_IMPOSSIBLE: &str = " (the replica jackknife was not possible: a refit failed or a state point has fewer than two complete replica samples)";

pub(super) fn covariance_method(p: &FitParams) -> String {
    match &p.y_err {
        Some(e) => format!("fit covariance with the per-point errors {e}"),
        None => "fit covariance scaled to the scatter of the points".to_string(),
    }
}

pub(super) fn jackknife_method(refits: usize, note: &str) -> String {
    format!(
        "delete-one jackknife over replicas: refit with each replica of each state point left out ({refits} refits){note}"
    )
}

/// How a collapse treats the measured xi it rescales with.
pub(super) const HELD: &str = "; numbers taken from other fits held at their values";
pub(super) const XI_REFITTED: &str =
    "; the measured xi of the state point refitted with the same replica left out";

/// What the jackknife of a fit did with the numbers it takes from other fits.
pub(super) fn from_note(
    from: &BTreeMap<String, FromQuantity>,
    shifted: &[(String, Refits)],
) -> String {
    let held: BTreeMap<String, FromQuantity> = from
        .iter()
        .filter(|(n, _)| !shifted.iter().any(|(m, _)| m == *n))
        .map(|(n, f)| (n.clone(), f.clone()))
        .collect();
    let mut s = String::new();
    if held.len() < from.len() {
        s.push_str("; numbers taken from other fits refitted with the same replica left out");
    }
    if !held.is_empty() {
        s.push_str(&format!(
            "; {} held at its value (no replica jackknife there)",
            from_names(&held)
        ));
    }
    s
}

/// The replica jackknife inputs of `rows` (`pool::with_replica_samples`): unit
/// per row, and the leave-one-out columns of x (empty when x is a key such as
/// phi) and y. None unless y has them. Rows of one state point (a curve over
/// lags, bins or q) count too: R replicas give only R - 1 degrees of freedom,
/// but the per-point errors of such a curve's correlated points make a fit
/// covariance 3 to 30 times too small (docs/accuracy.md).
pub(super) type Replicas = (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>);
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

/// What the replica jackknife of one group's fit gives besides the errors it
/// writes into the quantity rows.
pub(super) struct Replicated {
    /// Every refit: the replica left out and the reported numbers.
    pub(super) refits: Option<Vec<(pool::LeftOut, Vec<f64>)>>,
    /// Per fitted number (covariance error, jackknife error) of a fit on one
    /// unit's rows, for [`super::pooling::pool_one_unit_errors`].
    pub(super) pooled: Option<Vec<(f64, f64)>>,
    /// The numbers of a fit on one unit's rows refitted with each replica left out.
    pub(super) samples: Option<UnitSamples>,
}

/// The errors of a fit's quantity `rows` from its replicas, where the points
/// have replica samples or numbers taken from other fits with refits (else the
/// fit covariance's stay), and `method` saying how.
pub(super) fn replica_errors(
    pts: &Points<'_>,
    rows: &mut [(String, f64, f64)],
    method: &mut String,
) -> Replicated {
    let Points {
        p,
        c,
        fixed,
        shifted,
        used_rows,
        jk,
        one_unit,
        raw,
        x,
        y,
        s,
        m_scatter,
    } = pts;
    let widen = |e: f64, v: f64| e.hypot(m_scatter * v.abs());
    let mut refits = None;
    let mut pooled = None;
    // Errors from independent replicas where the rows span several units;
    // numbers taken from other fits (`fixed_from`) are refitted on the same
    // replicas, so that their share of the variance is counted.
    let also = also_units(shifted);
    let fixed_at = |left: pool::LeftOut| -> Vec<(String, f64)> {
        fixed
            .iter()
            .map(|(n, v)| {
                let at = shifted
                    .iter()
                    .find(|(m, _)| m == n)
                    .and_then(|(_, r)| r.get(&(left.unit.to_bits(), left.replica)));
                (n.clone(), at.copied().unwrap_or(*v))
            })
            .collect()
    };
    // One refit with replica `left.replica` of unit `left.unit` left out,
    // the numbers taken from other fits at the same replica.
    let (rx, ry, rs) = &raw;
    // Only where every row comes from the one unit: all weights then
    // change together. Across units the sample's larger errors would
    // down-weight the unit left out and damp its refit's shift.
    let s_jk: Vec<Vec<f64>> = match (&p.y_err, &jk) {
        (Some(e), Some((_, _, y_jk))) if one_unit.is_some() => {
            let v = jk_samples(c, &used_rows, e);
            if v.len() == y_jk.len() { v } else { Vec::new() }
        }
        _ => Vec::new(),
    };
    // A replica sample passes the same `where` on x and y as the pooled
    // data (e.g. P > 0 of a tail: a bin one replica never reached).
    let passes = |col: &str, v: f64| p.filter.get(col).is_none_or(|c| c.accepts(v));
    let refit = |left: pool::LeftOut, xs: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
        let keep: Vec<usize> = (0..xs.len())
            .filter(|&i| {
                xs[i].is_finite() && ys[i].is_finite() && passes(&p.x, xs[i]) && passes(&p.y, ys[i])
            })
            .collect();
        let (xk, yk) = (pick(xs, &keep), pick(ys, &keep));
        let fill = s.iter().cloned().fold(0.0, f64::max);
        // The rows of the unit left out carry the per-point errors of
        // that sample, so that each refit is the whole estimator (its
        // weights included) applied to the data without the replica.
        let own = s_jk.get(left.replica);
        let err = |i: usize| match (own, &jk) {
            (Some(e), Some((units, _, _))) if units[i].to_bits() == left.unit.to_bits() => e[i],
            _ => rs[i],
        };
        let sk: Vec<f64> = keep
            .iter()
            .map(|&i| {
                let e = err(i);
                widen(if e.is_finite() && e > 0.0 { e } else { fill }, ys[i])
            })
            .collect();
        let fixed = fixed_at(left);
        let fixed: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let g = fit_form(p, &xk, &yk, &sk, &fixed).ok()?;
        Some(reported(p, &xk, &yk, &g))
    };
    if let Some((units, x_jk, y_jk)) = &jk {
        match pool::replica_jackknife_with(units, rx, ry, x_jk, y_jk, &also, &refit) {
            Some(j) => {
                if one_unit.is_some() && also.is_empty() {
                    pooled = Some(rows.iter().map(|r| r.2).zip(j.errors.clone()).collect());
                }
                for (row, e) in rows.iter_mut().zip(&j.errors) {
                    row.2 = *e;
                }
                *method = jackknife_method(j.refits.len(), &from_note(&p.fixed_from, shifted));
                refits = Some(j.refits);
            }
            None => {
                method.push_str(JK_IMPOSSIBLE);
            }
        }
    } else if !also.is_empty() {
        // Data without replica columns (e.g. xi from a fit per state
        // point): their errors from the fit covariance, plus in quadrature
        // the variance that the numbers taken from other fits bring.
        let refit = |left: pool::LeftOut, xs: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
            let fixed = fixed_at(left);
            let fixed: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
            let g = fit_form(p, xs, ys, &s, &fixed).ok()?;
            Some(reported(p, xs, ys, &g))
        };
        match pool::replica_jackknife_with(&[], &x, &y, &[], &[], &also, refit) {
            Some(j) => {
                for (row, e) in rows.iter_mut().zip(&j.errors) {
                    row.2 = row.2.hypot(*e);
                }
                method.push_str(&format!(
                    ", plus in quadrature the replica jackknife of {} ({} refits with the same replica left out there)",
                    from_names(&p.fixed_from),
                    j.refits.len()
                ));
                refits = Some(j.refits);
            }
            None => method.push_str(JK_IMPOSSIBLE),
        }
    } else if let Some(replica) = object_replicas(c, &used_rows) {
        // One row per object (cluster) of every replica: refit with the
        // rows of each replica left out. Objects of one replica share
        // its frames, so they are not independent points.
        let mut labels = replica.clone();
        labels.sort_by(f64::total_cmp);
        labels.dedup();
        let thetas: Option<Vec<Vec<f64>>> = labels
            .iter()
            .map(|&r| {
                let ys: Vec<f64> = ry
                    .iter()
                    .zip(&replica)
                    .map(|(&y, &k)| if k == r { f64::NAN } else { y })
                    .collect();
                let left = pool::LeftOut {
                    unit: f64::NAN,
                    replica: 0,
                };
                refit(left, rx, &ys)
            })
            .collect();
        match thetas {
            Some(t) => {
                let n = t.len() as f64;
                let errors: Vec<f64> = (0..t[0].len())
                    .map(|q| {
                        let mean = t.iter().map(|v| v[q]).sum::<f64>() / n;
                        ((n - 1.0) / n * t.iter().map(|v| (v[q] - mean).powi(2)).sum::<f64>())
                            .sqrt()
                    })
                    .collect();
                if also.is_empty() {
                    pooled = Some(rows.iter().map(|r| r.2).zip(errors.clone()).collect());
                }
                for (row, e) in rows.iter_mut().zip(&errors) {
                    row.2 = *e;
                }
                *method = format!(
                    "delete-one jackknife over replicas: refit with the rows of each of {} replicas left out",
                    labels.len()
                );
            }
            None => method.push_str(
                " (the jackknife over the rows' replicas was not possible: a refit failed)",
            ),
        }
    }
    // A fit on one unit's rows (the OZ fit of one state point's S4
    // over q) takes no error from two replicas, but carries its numbers
    // refitted with each replica left out, so that a fit across state
    // points (xi against phi, the collapse) refits them on the same
    // replicas instead of holding them at their values.
    let samples = one_unit.as_ref().map(|(unit, y_jk)| {
        let per_replica = y_jk
            .iter()
            .enumerate()
            .map(|(k, ys)| {
                let left = pool::LeftOut {
                    unit: *unit,
                    replica: k,
                };
                let xs = match &jk {
                    Some((_, x_jk, _)) if x_jk.len() == y_jk.len() => &x_jk[k],
                    _ => rx,
                };
                refit(left, xs, ys).unwrap_or_default()
            })
            .collect();
        (*unit, per_replica)
    });
    Replicated {
        refits,
        pooled,
        samples,
    }
}
