//! Dynamic susceptibility chi4(t) = N [<Q_r^2> - <Q_r>^2] (paper H, Eq. 14) for one or
//! many sub-box sizes N (the scans of Fig. 19 and 24), and its peak chi4P at tau4.

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::overlap::{Moments, moments};
use super::stats::{Blocks, Estimate, jackknife_err, peak_log_t};
use super::{default_a, default_rel_tol};
use crate::table::f64_batch;
use crate::traj::Trajectory;

/// Parameters of chi4(t).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Mobility cut-off a (units r1).
    #[serde(default = "default_a")]
    pub a: f64,
    /// Mean particle numbers N of the sub-boxes (one chi4 curve each).
    pub n: Vec<f64>,
    /// Lags t to evaluate; every lag the trajectory realises if absent.
    #[serde(default)]
    pub lags: Option<Vec<f64>>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
}

/// chi4 from the sums [sum Q_r, sum Q_r^2, boxes] for sub-boxes of mean number n.
fn chi4_of(n: f64) -> impl Fn(&[f64]) -> f64 {
    move |s: &[f64]| n * (s[1] / s[2] - (s[0] / s[2]).powi(2))
}

fn run(trajs: &[&Trajectory], p: &Params) -> Result<Moments> {
    if p.n.is_empty() {
        bail!("parameter `n` (sub-box particle numbers) is empty: give at least one");
    }
    let sizes: Vec<Option<f64>> = p.n.iter().map(|&n| Some(n)).collect();
    moments(trajs, p.a, &sizes, p.lags.as_deref(), p.rel_tol)
}

/// Table `N, t, Q, chi4, chi4_err, n_origins` (errors: jackknife over time origins).
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    compute_pooled(&[traj], p)
}

/// As [`compute`], pooling the time origins of several replicas.
pub fn compute_pooled(trajs: &[&Trajectory], p: &Params) -> Result<RecordBatch> {
    let m = run(trajs, p)?;
    let mut cols: [Vec<f64>; 6] = Default::default();
    for (b, per_lag) in m.boxes.iter().zip(&m.blocks) {
        for (lag, blocks) in m.lags.iter().zip(per_lag) {
            let c = blocks.jackknife(chi4_of(b.n_mean));
            cols[0].push(b.n_mean);
            cols[1].push(lag.t);
            cols[2].push(super::overlap::q_of(&blocks.total()));
            cols[3].push(c.value);
            cols[4].push(c.err);
            cols[5].push(blocks.len() as f64);
        }
    }
    let [n, t, q, chi, err, no] = cols;
    f64_batch(&[
        ("N", n),
        ("t", t),
        ("Q", q),
        ("chi4", chi),
        ("chi4_err", err),
        ("n_origins", no),
    ])
}

/// The peak of chi4(t): height chi4P at time tau4, each with a jackknife error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    pub n: f64,
    pub tau4: Estimate,
    pub chi4p: Estimate,
}

/// chi4 peak for each sub-box size (parabola in ln t through the largest sample and
/// its neighbours; errors by leaving out one time origin at a time).
pub fn peaks(trajs: &[&Trajectory], p: &Params) -> Result<Vec<Peak>> {
    let m = run(trajs, p)?;
    let t: Vec<f64> = m.lags.iter().map(|l| l.t).collect();
    let mut out = Vec::new();
    for (b, per_lag) in m.boxes.iter().zip(&m.blocks) {
        let f = chi4_of(b.n_mean);
        let totals: Vec<Vec<f64>> = per_lag.iter().map(Blocks::total).collect();
        let curve: Vec<f64> = totals.iter().map(|s| f(s)).collect();
        let (tp, cp) = peak_log_t(&t, &curve).expect("at least one lag");
        let mut keys: Vec<(usize, usize)> =
            per_lag.iter().flat_map(|b| b.keys().copied()).collect();
        keys.sort_unstable();
        keys.dedup();
        let loo: Vec<(f64, f64)> = keys
            .iter()
            .map(|k| {
                let c: Vec<f64> = per_lag
                    .iter()
                    .zip(&totals)
                    .map(|(bl, tot)| f(&bl.total_without(tot, k)))
                    .collect();
                peak_log_t(&t, &c).unwrap_or((f64::NAN, f64::NAN))
            })
            .collect();
        out.push(Peak {
            n: b.n_mean,
            tau4: Estimate {
                value: tp,
                err: jackknife_err(loo.iter().map(|x| x.0).collect()),
            },
            chi4p: Estimate {
                value: cp,
                err: jackknife_err(loo.iter().map(|x| x.1).collect()),
            },
        });
    }
    Ok(out)
}

/// Table `N, tau4, tau4_err, chi4P, chi4P_err`, one row per sub-box size.
pub fn compute_peaks(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    let pk = peaks(&[traj], p)?;
    f64_batch(&[
        ("N", pk.iter().map(|x| x.n).collect()),
        ("tau4", pk.iter().map(|x| x.tau4.value).collect()),
        ("tau4_err", pk.iter().map(|x| x.tau4.err).collect()),
        ("chi4P", pk.iter().map(|x| x.chi4p.value).collect()),
        ("chi4P_err", pk.iter().map(|x| x.chi4p.err).collect()),
    ])
}
