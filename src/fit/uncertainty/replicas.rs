//! The replica jackknife of a fit: its refits with one replica of one unit (a
//! state point) left out, the numbers it takes from other fits refitted on the
//! same replicas, and the account of how its errors were estimated.
//!
//! Works on plain numbers: the points, their replica samples (the same
//! observable computed with each replica left out), the units they come from,
//! and a `refit` that fits any set of points with given errors and numbers held
//! fixed.

use std::collections::BTreeMap;

use crate::analysis::pool::{self, LeftOut};

/// A number's jackknife refits by (unit bits, replica left out).
pub type Refits = BTreeMap<(u64, usize), f64>;

/// The variance a number's replica refits carry: the delete-one jackknife
/// variance summed over the units left out, as the fit that made them
/// combines them.
pub fn refits_variance(refits: &Refits) -> f64 {
    let mut by_unit: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for (&(unit, _), &v) in refits {
        by_unit.entry(unit).or_default().push(v);
    }
    by_unit.values().map(|t| pool::jackknife_variance(t)).sum()
}

/// Replica jackknife inputs of a fit's points: the unit of every point, and the
/// leave-one-out samples of x (empty when x is a key such as phi) and of y.
pub type Replicas = (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>);

/// The units (with their replica counts) whose refits move the numbers taken
/// from other fits.
pub fn also_units(shifted: &[(String, Refits)]) -> Vec<(f64, usize)> {
    let mut n: BTreeMap<u64, usize> = BTreeMap::new();
    for (_, r) in shifted {
        for &(u, k) in r.keys() {
            let e = n.entry(u).or_default();
            *e = (*e).max(k + 1);
        }
    }
    n.into_iter().map(|(u, r)| (f64::from_bits(u), r)).collect()
}

/// Appended to the error method when the replica jackknife could not be done.
pub const JK_IMPOSSIBLE: &str = " (the replica jackknife was not possible: a refit failed or a state point has fewer than two complete replica samples)";

/// How a collapse treats the measured xi it rescales with.
pub const HELD: &str = "; numbers taken from other fits held at their values";
pub const XI_REFITTED: &str =
    "; the measured xi of the state point refitted with the same replica left out";

/// The error method of a fit's covariance, with or without per-point errors
/// (named by their column `y_err`).
pub fn covariance_method(y_err: Option<&str>) -> String {
    match y_err {
        Some(e) => format!("fit covariance with the per-point errors {e}"),
        None => "fit covariance scaled to the scatter of the points".to_string(),
    }
}

/// The error method of a replica jackknife of `refits` refits, with `note`.
pub fn jackknife_method(refits: usize, note: &str) -> String {
    format!(
        "delete-one jackknife over replicas: refit with each replica of each state point left out ({refits} refits){note}"
    )
}

/// A number a fit takes from another fit: the parameter it sets, and what it
/// is ("phi_c of power_law").
pub struct TakenFrom {
    pub param: String,
    pub what: String,
}

fn names(from: &[&TakenFrom]) -> String {
    from.iter()
        .map(|f| f.what.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// What the jackknife of a fit did with the numbers it takes from other fits
/// (refitted where `shifted` has their refits, else held).
fn from_note(from: &[TakenFrom], shifted: &[(String, Refits)]) -> String {
    let held: Vec<&TakenFrom> = from
        .iter()
        .filter(|f| !shifted.iter().any(|(m, _)| *m == f.param))
        .collect();
    let mut s = String::new();
    if held.len() < from.len() {
        s.push_str("; numbers taken from other fits refitted with the same replica left out");
    }
    if !held.is_empty() {
        s.push_str(&format!(
            "; {} held at its value (no replica jackknife there)",
            names(&held)
        ));
    }
    s
}

/// One group's points as the fit and its refits see them.
pub struct FitPoints<'a> {
    /// The used points before cleaning: x, y and errors.
    pub raw: (&'a [f64], &'a [f64], &'a [f64]),
    /// The cleaned points, their errors widened by the model scatter.
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub s: &'a [f64],
    /// The relative model scatter (0 without one).
    pub m_scatter: f64,
    /// The replica jackknife inputs of the used points, if y has them.
    pub jk: Option<&'a Replicas>,
    /// Their unit and the replica samples of y, when they all come from one unit.
    pub one_unit: Option<&'a (f64, Vec<Vec<f64>>)>,
    /// The per-point errors of each replica sample, where every point comes from
    /// one unit (empty otherwise): each refit then weights by its own sample's.
    pub s_jk: &'a [Vec<f64>],
    /// The replica of each point, for points that are objects (clusters) of
    /// several replicas; None otherwise.
    pub object_replicas: Option<Vec<f64>>,
    /// The numbers held fixed, and the refits of those taken from other fits.
    pub fixed: &'a [(String, f64)],
    pub shifted: &'a [(String, Refits)],
    /// The numbers taken from other fits, for the account of the method.
    pub taken: &'a [TakenFrom],
}

/// What the replica jackknife of one fit gives besides the errors it writes
/// into the quantity rows.
pub struct Replicated {
    /// Every refit: the replica left out and the reported numbers.
    pub refits: Option<Vec<(LeftOut, Vec<f64>)>>,
    /// Per fitted number (covariance error, jackknife error) of a fit on one
    /// unit's rows, for [`super::pooling::pooled_errors`].
    pub pooled: Option<Vec<(f64, f64)>>,
    /// The numbers of a fit on one unit's rows refitted with each replica left out.
    pub samples: Option<(f64, Vec<Vec<f64>>)>,
}

/// The errors of a fit's quantity `rows` (name, value, error) from its
/// replicas, where the points have replica samples or numbers taken from other
/// fits with refits (else the fit covariance's stay), and `method` saying how.
/// `refit(x, y, s, fixed)` fits the points and returns the reported numbers;
/// `passes(x, y)` says whether a replica sample's point passes the filter the
/// pooled data passed.
pub fn replica_errors(
    pts: &FitPoints<'_>,
    rows: &mut [(String, f64, f64)],
    method: &mut String,
    passes: impl Fn(f64, f64) -> bool,
    refit: impl Fn(&[f64], &[f64], &[f64], &[(&str, f64)]) -> Option<Vec<f64>>,
) -> Replicated {
    let FitPoints {
        raw,
        x,
        y,
        s,
        m_scatter,
        jk,
        one_unit,
        s_jk,
        object_replicas,
        fixed,
        shifted,
        taken,
    } = pts;
    let widen = |e: f64, v: f64| e.hypot(m_scatter * v.abs());
    let mut refits = None;
    let mut pooled = None;
    // Errors from independent replicas where the rows span several units;
    // numbers taken from other fits (`fixed_from`) are refitted on the same
    // replicas, so that their share of the variance is counted.
    let also = also_units(shifted);
    let fixed_at = |left: LeftOut| -> Vec<(String, f64)> {
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
    let (rx, ry, rs) = *raw;
    let sample_refit = |left: LeftOut, xs: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
        let keep: Vec<usize> = (0..xs.len())
            .filter(|&i| xs[i].is_finite() && ys[i].is_finite() && passes(xs[i], ys[i]))
            .collect();
        let xk: Vec<f64> = keep.iter().map(|&i| xs[i]).collect();
        let yk: Vec<f64> = keep.iter().map(|&i| ys[i]).collect();
        let fill = s.iter().cloned().fold(0.0, f64::max);
        // The rows of the unit left out carry the per-point errors of
        // that sample, so that each refit is the whole estimator (its
        // weights included) applied to the data without the replica.
        let own = s_jk.get(left.replica);
        let err = |i: usize| match (own, jk) {
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
        refit(&xk, &yk, &sk, &fixed)
    };
    if let Some((units, x_jk, y_jk)) = jk {
        match pool::replica_jackknife_with(units, rx, ry, x_jk, y_jk, &also, &sample_refit) {
            Some(j) => {
                if one_unit.is_some() && also.is_empty() {
                    pooled = Some(rows.iter().map(|r| r.2).zip(j.errors.clone()).collect());
                }
                for (row, e) in rows.iter_mut().zip(&j.errors) {
                    row.2 = *e;
                }
                *method = jackknife_method(j.refits.len(), &from_note(taken, shifted));
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
        let shifted_refit = |left: LeftOut, xs: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
            let fixed = fixed_at(left);
            let fixed: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
            refit(xs, ys, s, &fixed)
        };
        match pool::replica_jackknife_with(&[], x, y, &[], &[], &also, shifted_refit) {
            Some(j) => {
                for (row, e) in rows.iter_mut().zip(&j.errors) {
                    row.2 = row.2.hypot(*e);
                }
                let all: Vec<&TakenFrom> = taken.iter().collect();
                method.push_str(&format!(
                    ", plus in quadrature the replica jackknife of {} ({} refits with the same replica left out there)",
                    names(&all),
                    j.refits.len()
                ));
                refits = Some(j.refits);
            }
            None => method.push_str(JK_IMPOSSIBLE),
        }
    } else if let Some(replica) = object_replicas {
        match object_jackknife(replica, rx, ry, &sample_refit) {
            Some((errors, replicas)) => {
                if also.is_empty() {
                    pooled = Some(rows.iter().map(|r| r.2).zip(errors.clone()).collect());
                }
                for (row, e) in rows.iter_mut().zip(&errors) {
                    row.2 = *e;
                }
                *method = format!(
                    "delete-one jackknife over replicas: refit with the rows of each of {replicas} replicas left out"
                );
            }
            None => method.push_str(
                " (the jackknife over the rows' replicas was not possible: a refit failed)",
            ),
        }
    }
    let samples = one_unit.map(|u| unit_samples(u, *jk, rx, &sample_refit));
    Replicated {
        refits,
        pooled,
        samples,
    }
}

/// A refit of the points with one replica left out: (the replica, its x, its y).
type SampleRefit<'a> = dyn Fn(LeftOut, &[f64], &[f64]) -> Option<Vec<f64>> + 'a;

/// The delete-one jackknife errors of a fit whose rows are objects (clusters)
/// of several replicas, refitted with the rows of each replica left out
/// (objects of one replica share its frames, so they are not independent
/// points), and the number of replicas; None when a refit fails.
fn object_jackknife(
    replica: &[f64],
    rx: &[f64],
    ry: &[f64],
    sample_refit: &SampleRefit<'_>,
) -> Option<(Vec<f64>, usize)> {
    let mut labels = replica.to_vec();
    labels.sort_by(f64::total_cmp);
    labels.dedup();
    let t: Vec<Vec<f64>> = labels
        .iter()
        .map(|&r| {
            let ys: Vec<f64> = ry
                .iter()
                .zip(replica)
                .map(|(&y, &k)| if k == r { f64::NAN } else { y })
                .collect();
            let left = LeftOut {
                unit: f64::NAN,
                replica: 0,
            };
            sample_refit(left, rx, &ys)
        })
        .collect::<Option<_>>()?;
    let n = t.len() as f64;
    let errors = (0..t[0].len())
        .map(|q| {
            let mean = t.iter().map(|v| v[q]).sum::<f64>() / n;
            ((n - 1.0) / n * t.iter().map(|v| (v[q] - mean).powi(2)).sum::<f64>()).sqrt()
        })
        .collect();
    Some((errors, labels.len()))
}

/// A fit on one unit's rows (the OZ fit of one state point's S4 over q) takes
/// no error from two replicas, but carries its numbers refitted with each
/// replica left out, so that a fit across state points (xi against phi, the
/// collapse) refits them on the same replicas instead of holding them at
/// their values.
fn unit_samples(
    (unit, y_jk): &(f64, Vec<Vec<f64>>),
    jk: Option<&Replicas>,
    rx: &[f64],
    sample_refit: &SampleRefit<'_>,
) -> (f64, Vec<Vec<f64>>) {
    let per_replica = y_jk
        .iter()
        .enumerate()
        .map(|(k, ys)| {
            let left = LeftOut {
                unit: *unit,
                replica: k,
            };
            let xs = match jk {
                Some((_, x_jk, _)) if x_jk.len() == y_jk.len() => &x_jk[k],
                _ => rx,
            };
            sample_refit(left, xs, ys).unwrap_or_default()
        })
        .collect();
    (*unit, per_replica)
}

/// The delete-one jackknife error over replicas of the mean of y, from the
/// replica samples of y (each sample's finite points averaged); NaN when it
/// cannot be formed.
pub fn mean_jackknife(y_jk: &[Vec<f64>]) -> f64 {
    let per: Vec<f64> = y_jk
        .iter()
        .map(|v| {
            let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
            f.iter().sum::<f64>() / f.len() as f64
        })
        .collect();
    let r = per.len() as f64;
    let m = per.iter().sum::<f64>() / r;
    ((r - 1.0) / r * per.iter().map(|v| (v - m).powi(2)).sum::<f64>()).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight line through points of two units, each with two replica
    /// samples: the jackknife refits every (unit, replica) once, replaces the
    /// covariance error and says so.
    #[test]
    fn the_replica_jackknife_refits_each_replica_of_each_unit() {
        let x = [1.0, 2.0, 3.0, 4.0];
        let y = [2.0, 4.0, 6.0, 8.0];
        let s = [0.1; 4];
        let units = vec![1.0, 1.0, 2.0, 2.0];
        let y_jk = vec![vec![2.1, 4.1, 6.0, 8.0], vec![1.9, 3.9, 6.2, 8.2]];
        let jk: Replicas = (units, Vec::new(), y_jk);
        let pts = FitPoints {
            raw: (&x, &y, &s),
            x: &x,
            y: &y,
            s: &s,
            m_scatter: 0.0,
            jk: Some(&jk),
            one_unit: None,
            s_jk: &[],
            object_replicas: None,
            fixed: &[],
            shifted: &[],
            taken: &[],
        };
        // The mean of y as the "fit".
        let mean = |_: &[f64], y: &[f64], _: &[f64], _: &[(&str, f64)]| {
            Some(vec![y.iter().sum::<f64>() / y.len() as f64])
        };
        let mut rows = vec![("m".to_string(), 5.0, 0.01)];
        let mut method = covariance_method(Some("y_err"));
        let r = replica_errors(&pts, &mut rows, &mut method, |_, _| true, mean);
        assert_eq!(r.refits.as_ref().map(Vec::len), Some(4));
        // Unit 1: means 5.05, 4.95; unit 2: 5.0, 5.1 -> variance 0.0025 + 0.0025.
        assert!((rows[0].2 - 0.005f64.sqrt()).abs() < 1e-12, "{}", rows[0].2);
        assert!(
            method.starts_with("delete-one jackknife over replicas"),
            "{method}"
        );
        assert!(r.pooled.is_none() && r.samples.is_none());
        // One sample short of two: impossible, the covariance error stays.
        let short: Replicas = (jk.0.clone(), Vec::new(), vec![jk.2[0].clone()]);
        let pts = FitPoints {
            jk: Some(&short),
            ..pts
        };
        let mut rows = vec![("m".to_string(), 5.0, 0.01)];
        let mut method = String::new();
        replica_errors(&pts, &mut rows, &mut method, |_, _| true, mean);
        assert_eq!(rows[0].2, 0.01);
        assert_eq!(method, JK_IMPOSSIBLE);
    }

    #[test]
    fn the_jackknife_of_a_mean_over_replicas() {
        assert!((mean_jackknife(&[vec![1.0, f64::NAN], vec![3.0, 3.0]]) - 1.0).abs() < 1e-12);
        assert!(mean_jackknife(&[]).is_nan());
    }
}
