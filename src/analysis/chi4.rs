//! Dynamic susceptibility chi4(t) = N [<Q_r^2> - <Q_r>^2] (paper H, Eq. 14) for one or
//! many sub-box sizes N (the scans of Fig. 19 and 24), and its peak chi4P at tau4.

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::overlap::{Moments, moments};
use super::stats::{Blocks, Estimate, interp_log_t, jackknife_err, peak_log_t};
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

/// Table `N, t, Q, chi4, chi4_err, n_origins` of one trajectory (errors: jackknife
/// over time origins).
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    compute_pooled(&[traj], p)
}

/// As [`compute`], pooling the time origins of several replicas (jackknife over
/// (replica, origin bin) blocks).
pub fn compute_pooled(trajs: &[&Trajectory], p: &Params) -> Result<RecordBatch> {
    let m = run(trajs, p)?;
    let mut cols: [Vec<f64>; 6] = Default::default();
    for (s, (b, per_lag)) in m.boxes.iter().zip(&m.blocks).enumerate() {
        for ((lag, origins), blocks) in m.lags.iter().zip(per_lag).zip(m.error_blocks(trajs, s)) {
            let c = blocks.jackknife(chi4_of(b.n_mean));
            cols[0].push(b.n_mean);
            cols[1].push(lag.t);
            cols[2].push(super::overlap::q_of(&blocks.total()));
            cols[3].push(c.value);
            cols[4].push(c.err);
            cols[5].push(origins.len() as f64);
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
/// its neighbours; errors by leaving out one (replica, origin bin) block at a time).
pub fn peaks(trajs: &[&Trajectory], p: &Params) -> Result<Vec<Peak>> {
    let m = run(trajs, p)?;
    let t: Vec<f64> = m.lags.iter().map(|l| l.t).collect();
    let mut out = Vec::new();
    for (s, b) in m.boxes.iter().enumerate() {
        let per_lag = &m.error_blocks(trajs, s);
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

/// Sub-box sizes that fit in a system of `n_particles`: a request above it becomes
/// the whole system (so one spec serves every profile's N).
pub fn clamp_sizes(p: &mut Params, n_particles: usize) {
    for n in &mut p.n {
        *n = n.min(n_particles as f64);
    }
    p.n.dedup();
}

/// Per sub-box size N (Fig. 15 inset, Fig. 19): the peak (tau4, chi4P) with
/// jackknife errors, tau_alpha of the whole system (Q = 1/e) and chi4 at tau_alpha,
/// interpolated in ln t between the two bracketing lags. Table `N, tau4, tau4_err,
/// chi4P, chi4P_err, tau_alpha, tau_alpha_err, chi4_tau_alpha, chi4_tau_alpha_err`;
/// tau_alpha and chi4(tau_alpha) are NaN when Q never reaches 1/e over the lags (a
/// short run), never extrapolated.
pub fn peaks_table(trajs: &[&Trajectory], p: &Params) -> Result<RecordBatch> {
    let peaks = peaks(trajs, p)?;
    let op = super::overlap::Params {
        a: p.a,
        n: None,
        lags: p.lags.clone(),
        rel_tol: p.rel_tol,
    };
    let tau = super::overlap::tau_alpha(trajs, &op).ok();
    let ta = tau.map(|x| x.value).unwrap_or(f64::NAN);
    let table = compute_pooled(trajs, p)?;
    let col = |name: &str| -> Vec<f64> {
        table
            .column_by_name(name)
            .and_then(|c| c.as_any().downcast_ref::<arrow_array::Float64Array>())
            .map(|a| a.values().to_vec())
            .expect("column written by compute_pooled")
    };
    let (n_col, t_col, c_col, e_col) = (col("N"), col("t"), col("chi4"), col("chi4_err"));
    let (mut at_tau, mut at_tau_err) = (Vec::new(), Vec::new());
    for pk in &peaks {
        let rows: Vec<usize> = (0..n_col.len()).filter(|&i| n_col[i] == pk.n).collect();
        let pick = |v: &[f64]| -> Vec<f64> { rows.iter().map(|&i| v[i]).collect() };
        let t = pick(&t_col);
        at_tau.push(interp_log_t(&t, &pick(&c_col), ta).unwrap_or(f64::NAN));
        at_tau_err.push(interp_log_t(&t, &pick(&e_col), ta).unwrap_or(f64::NAN));
    }
    let k = peaks.len();
    f64_batch(&[
        ("N", peaks.iter().map(|x| x.n).collect()),
        ("tau4", peaks.iter().map(|x| x.tau4.value).collect()),
        ("tau4_err", peaks.iter().map(|x| x.tau4.err).collect()),
        ("chi4P", peaks.iter().map(|x| x.chi4p.value).collect()),
        ("chi4P_err", peaks.iter().map(|x| x.chi4p.err).collect()),
        ("tau_alpha", vec![ta; k]),
        (
            "tau_alpha_err",
            vec![tau.map(|x| x.err).unwrap_or(f64::NAN); k],
        ),
        ("chi4_tau_alpha", at_tau),
        ("chi4_tau_alpha_err", at_tau_err),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::lags;
    use crate::analysis::synthetic::random_walk;
    use crate::analysis::test_support::{col, schedule_times};

    #[test]
    fn chi4_peaks_table_reports_chi4_at_tau_alpha_inside_the_lags() {
        let times = schedule_times(10, 60.0, 0.1, 50.0);
        let traj = random_walk(800, [40.0, 40.0], &times, 0.05, 5);
        let mut p = Params {
            a: 0.6,
            n: vec![100.0, 5000.0],
            lags: None,
            rel_tol: 1e-6,
        };
        clamp_sizes(&mut p, traj.n());
        assert_eq!(p.n, vec![100.0, 800.0]);
        p.lags = lags::every_origin(&[&traj], None, 1e-6).unwrap();
        let b = peaks_table(&[&traj], &p).unwrap();
        let ta = col(&b, "tau_alpha");
        assert!(ta[0].is_finite() && ta[0] > 0.0);
        let c = compute_pooled(&[&traj], &p).unwrap();
        let (n, t, chi) = (col(&c, "N"), col(&c, "t"), col(&c, "chi4"));
        let rows: Vec<usize> = (0..n.len()).filter(|&i| n[i] == 100.0).collect();
        let ts: Vec<f64> = rows.iter().map(|&i| t[i]).collect();
        let cs: Vec<f64> = rows.iter().map(|&i| chi[i]).collect();
        let k = ts.partition_point(|&x| x <= ta[0]);
        let (lo, hi) = (cs[k - 1].min(cs[k]), cs[k - 1].max(cs[k]));
        let at = col(&b, "chi4_tau_alpha")[0];
        assert!(
            at >= lo - 1e-12 && at <= hi + 1e-12,
            "{at} not in [{lo}, {hi}]"
        );
    }
}
