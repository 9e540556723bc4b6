//! Self part of the van Hove function P(dx, t) (Fig. 8): the distribution of one
//! Cartesian displacement component over a lag, x and y pooled (isotropy).

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::{check_trajectory, default_rel_tol, ensure_positive, lags};
use crate::table::f64_batch;
use crate::traj::Trajectory;

fn default_bin() -> f64 {
    0.05
}

fn default_range() -> f64 {
    10.0
}

/// Parameters of P(dx, t).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Lags t (e.g. fractions of tau_alpha); required, here or by the analysis
    /// stage's `at:` (the parse checks it).
    #[serde(default)]
    pub lags: Vec<f64>,
    /// Histogram bin width in dx (units r1).
    #[serde(default = "default_bin")]
    pub bin: f64,
    /// Histogram covers dx in [-range, range].
    #[serde(default = "default_range")]
    pub range: f64,
    /// Only this species; all particles if absent.
    #[serde(default)]
    pub species: Option<u8>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
}

/// Table `t, dx, P, P_err`: P is a probability density (normalised over all
/// displacements, including any beyond the range); P_err is the Poisson error.
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    ensure_positive("bin", p.bin)?;
    ensure_positive("range", p.range)?;
    if p.lags.is_empty() {
        bail!("parameter `lags` is empty: give at least one lag");
    }
    if let Some(s) = p.species
        && !traj.species.contains(&s)
    {
        bail!("parameter `species` = {s}: no particle of that species in the trajectory");
    }
    let nb = (2.0 * p.range / p.bin).round().max(1.0) as usize;
    let bin = 2.0 * p.range / nb as f64;
    let lags = lags::select(&[traj], Some(&p.lags), p.rel_tol)?;
    let mut cols: [Vec<f64>; 4] = Default::default();
    for lag in &lags {
        let mut hist = vec![0u64; nb];
        let mut total = 0u64;
        for &(_, i, j) in &lag.pairs {
            let (f0, f1) = (&traj.frames[i], &traj.frames[j]);
            for k in 0..traj.n() {
                if p.species.is_some_and(|s| traj.species[k] != s) {
                    continue;
                }
                for d in [f1.x[k] - f0.x[k], f1.y[k] - f0.y[k]] {
                    total += 1;
                    let b = ((d + p.range) / bin).floor();
                    if b >= 0.0 && (b as usize) < nb {
                        hist[b as usize] += 1;
                    }
                }
            }
        }
        let norm = 1.0 / (total as f64 * bin);
        for (b, &c) in hist.iter().enumerate() {
            cols[0].push(lag.t);
            cols[1].push(-p.range + (b as f64 + 0.5) * bin);
            cols[2].push(c as f64 * norm);
            cols[3].push((c as f64).sqrt() * norm);
        }
    }
    let [t, dx, pp, e] = cols;
    f64_batch(&[("t", t), ("dx", dx), ("P", pp), ("P_err", e)])
}
