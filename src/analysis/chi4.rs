//! Dynamic susceptibility chi4(t) = N [<Q_r^2> - <Q_r>^2] (paper H, Eq. 14) for one or
//! many sub-box sizes N (the scans of Fig. 19 and 24), and its peak chi4P at tau4.
//!
//! Paper H has one simulation per state point: <.> runs over its sub-boxes and
//! the overbars over its time origins t0. With several replicas the variance is
//! therefore taken within each replica, about that replica's own mean, and then
//! averaged ([`Variance::PerReplica`]): pooling replicas about one grand mean adds
//! N times the variance of the replicas' mean overlaps, a term that grows with
//! the sub-box N and is no fluctuation of one system. Where the overbars sit in
//! Eq. 14 is not legible in the paper; the two other readings are options
//! (docs/figures.md, "Method").

use std::collections::BTreeMap;

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::overlap::{Displacement, Moments, moments};
use super::stats::{
    Blocks, Estimate, at_least, interp_log_t, jackknife_err, peak_log_t, peak_resolution,
};
use super::{default_a, default_rel_tol};
use crate::table::f64_batch;
use crate::traj::Trajectory;

/// About which mean the variance of Q_r is taken.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Variance {
    /// Per replica, about its mean over sub-boxes and time origins, then averaged
    /// over replicas (weighted by samples): N [mean_t0 <Q_r^2> - (mean_t0 <Q_r>)^2]
    /// of each simulation, as paper H with its one simulation per phi.
    #[default]
    PerReplica,
    /// Per time origin, about that frame's mean over sub-boxes, then averaged:
    /// N mean_t0 [<Q_r^2> - <Q_r>^2]. Blind to the drift of the mean and to
    /// fluctuations of the whole box (zero with one sub-box).
    PerOrigin,
    /// About one grand mean over replicas, origins and sub-boxes.
    Pooled,
}

/// Parameters of chi4(t).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Mobility cut-off a (units r1).
    #[serde(default = "default_a")]
    pub a: f64,
    /// Mean particle numbers N of the sub-boxes (one chi4 curve each).
    #[serde(default)]
    pub n: Vec<f64>,
    /// Sub-boxes as fractions of the system's particle number (N = f N_total, one
    /// curve each): a sweep in the total N reads a fixed fraction of every box.
    #[serde(default)]
    pub fractions: Vec<f64>,
    /// Lags t to evaluate; every lag the trajectory realises if absent.
    #[serde(default)]
    pub lags: Option<Vec<f64>>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
    /// About which mean the variance is taken (default: per replica).
    #[serde(default)]
    pub variance: Variance,
}

/// chi4 of sub-boxes of mean number `n` from the (replica, origin) blocks of one
/// lag, each holding [sum Q_r, sum Q_r^2, boxes, (sum Q_r)^2 / boxes per frame],
/// with block `skip` left out (the jackknife's delete-one estimate).
pub fn chi4_of(n: f64, v: Variance, blocks: &Blocks, skip: Option<&(usize, usize)>) -> f64 {
    let mut tot = [0.0; 4];
    let mut per_replica: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for k in blocks.keys() {
        if Some(k) == skip {
            continue;
        }
        let s = blocks.get(k).expect("key from this block set");
        for (t, x) in tot.iter_mut().zip(s) {
            *t += x;
        }
        let r = per_replica.entry(k.0).or_default();
        r.0 += s[0];
        r.1 += s[2];
    }
    let [s1, s2, b, s4] = tot;
    match v {
        Variance::Pooled => n * (s2 / b - (s1 / b).powi(2)),
        Variance::PerOrigin => n * (s2 - s4) / b,
        Variance::PerReplica => {
            let between: f64 = per_replica.values().map(|(q, m)| q * q / m).sum();
            n * (s2 - between) / b
        }
    }
}

/// [`chi4_of`] over all blocks, with its delete-one jackknife error.
fn chi4_estimate(n: f64, v: Variance, blocks: &Blocks) -> Estimate {
    Estimate {
        value: chi4_of(n, v, blocks, None),
        err: jackknife_err(
            blocks
                .keys()
                .map(|k| chi4_of(n, v, blocks, Some(k)))
                .collect(),
        ),
    }
}

fn run(trajs: &[&Trajectory], p: &Params) -> Result<Moments> {
    if p.n.is_empty() {
        bail!("parameter `n` (sub-box particle numbers) is empty: give at least one");
    }
    let sizes: Vec<Option<f64>> = p.n.iter().map(|&n| Some(n)).collect();
    moments(
        trajs,
        p.a,
        Displacement::Absolute,
        &sizes,
        p.lags.as_deref(),
        p.rel_tol,
    )
}

/// Table `N, t, Q, chi4, chi4_err, n_origins` of one trajectory (errors: jackknife
/// over time origins).
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    compute_pooled(&[traj], p)
}

/// As [`compute`], pooling the time origins of several replicas (jackknife over
/// (replica, origin bin) blocks).
pub fn compute_pooled(trajs: &[&Trajectory], p: &Params) -> Result<RecordBatch> {
    table_of(&run(trajs, p)?, trajs, p.variance)
}

/// The table of [`compute_pooled`] from the moments.
fn table_of(m: &Moments, trajs: &[&Trajectory], v: Variance) -> Result<RecordBatch> {
    let mut cols: [Vec<f64>; 6] = Default::default();
    for (s, (b, per_lag)) in m.boxes.iter().zip(&m.blocks).enumerate() {
        for ((lag, origins), blocks) in m.lags.iter().zip(per_lag).zip(m.error_blocks(trajs, s)) {
            let c = chi4_estimate(b.n_mean, v, &blocks);
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

/// chi4 peak for each sub-box size (parabola in ln t through the top of the curve,
/// [`peak_log_t`]; errors by leaving out one (replica, origin bin) block at a time,
/// never below the lag grid's resolution, [`peak_resolution`]).
pub fn peaks(trajs: &[&Trajectory], p: &Params) -> Result<Vec<Peak>> {
    Ok(peaks_of(&run(trajs, p)?, trajs, p.variance))
}

/// The peaks of [`peaks`] from the moments.
fn peaks_of(m: &Moments, trajs: &[&Trajectory], v: Variance) -> Vec<Peak> {
    let t: Vec<f64> = m.lags.iter().map(|l| l.t).collect();
    let mut out = Vec::new();
    for (s, b) in m.boxes.iter().enumerate() {
        let per_lag = &m.error_blocks(trajs, s);
        let curve_without = |skip: Option<&(usize, usize)>| -> Vec<f64> {
            per_lag
                .iter()
                .map(|bl| chi4_of(b.n_mean, v, bl, skip))
                .collect()
        };
        let curve = curve_without(None);
        let (tp, cp) = peak_log_t(&t, &curve).expect("at least one lag");
        let (t_res, c_res) = peak_resolution(&t, &curve).expect("at least one lag");
        let mut keys: Vec<(usize, usize)> =
            per_lag.iter().flat_map(|b| b.keys().copied()).collect();
        keys.sort_unstable();
        keys.dedup();
        let loo: Vec<(f64, f64)> = keys
            .iter()
            .map(|k| peak_log_t(&t, &curve_without(Some(k))).unwrap_or((f64::NAN, f64::NAN)))
            .collect();
        out.push(Peak {
            n: b.n_mean,
            tau4: Estimate {
                value: tp,
                err: at_least(jackknife_err(loo.iter().map(|x| x.0).collect()), t_res),
            },
            chi4p: Estimate {
                value: cp,
                err: at_least(jackknife_err(loo.iter().map(|x| x.1).collect()), c_res),
            },
        });
    }
    out
}

/// The sub-box sizes for a system of `n_particles`: `n` and the `fractions` of it,
/// ascending, each once; a request above the system becomes the whole system (so
/// one spec serves every profile's N). The parse has checked that there is a size
/// and that each fraction is in (0, 1] (`ObservableParams::check`).
pub fn resolve_sizes(p: &mut Params, n_particles: usize) {
    let total = n_particles as f64;
    let mut sizes: Vec<f64> = p.n.iter().map(|n| n.min(total)).collect();
    sizes.extend(p.fractions.iter().map(|f| f * total));
    sizes.sort_by(f64::total_cmp);
    sizes.dedup();
    p.n = sizes;
    p.fractions.clear();
}

/// Per sub-box size N (Fig. 15 inset, Fig. 19): the peak (tau4, chi4P) with
/// jackknife errors, tau_alpha of the whole system (Q = 1/e) and chi4 at tau_alpha,
/// interpolated in ln t between the two bracketing lags. Table `N, tau4, tau4_err,
/// chi4P, chi4P_err, tau_alpha, tau_alpha_err, chi4_tau_alpha, chi4_tau_alpha_err`;
/// tau_alpha and chi4(tau_alpha) are NaN when Q never reaches 1/e over the lags (a
/// short run), never extrapolated.
pub fn peaks_table(trajs: &[&Trajectory], p: &Params) -> Result<RecordBatch> {
    // One pass over the frame pairs serves the peaks and the curves.
    let m = run(trajs, p)?;
    let peaks = peaks_of(&m, trajs, p.variance);
    let op = super::overlap::Params {
        a: p.a,
        n: None,
        lags: p.lags.clone(),
        rel_tol: p.rel_tol,
        ..Default::default()
    };
    let tau = super::overlap::tau_alpha(trajs, &op).ok();
    let ta = tau.map(|x| x.value).unwrap_or(f64::NAN);
    let table = table_of(&m, trajs, p.variance)?;
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
    /// The three readings of Eq. 14 against their definitions, from sub-box
    /// overlaps made up by hand: two replicas whose mean overlaps differ (0.5 and
    /// 0.7), two frames each, three sub-boxes per frame.
    #[test]
    fn the_variance_readings_of_eq_14_match_their_definitions() {
        let q: [[[f64; 3]; 2]; 2] = [
            [[0.4, 0.5, 0.6], [0.45, 0.5, 0.55]],
            [[0.6, 0.7, 0.8], [0.7, 0.75, 0.65]],
        ];
        let n = 100.0;
        let mut blocks = Blocks::default();
        for (r, frames) in q.iter().enumerate() {
            for (f, boxes) in frames.iter().enumerate() {
                let s1: f64 = boxes.iter().sum();
                let s2: f64 = boxes.iter().map(|x| x * x).sum();
                blocks.add((r, f), &[s1, s2, 3.0, s1 * s1 / 3.0]);
            }
        }
        let var = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64
        };
        let all: Vec<f64> = q.iter().flatten().flatten().copied().collect();
        let per_rep: Vec<f64> = q
            .iter()
            .map(|r| var(&r.iter().flatten().copied().collect::<Vec<_>>()))
            .collect();
        let per_origin: Vec<f64> = q.iter().flatten().map(|b| var(b)).collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b.abs().max(1.0);
        assert!(close(
            chi4_of(n, Variance::Pooled, &blocks, None),
            n * var(&all)
        ));
        assert!(close(
            chi4_of(n, Variance::PerReplica, &blocks, None),
            n * mean(&per_rep)
        ));
        assert!(close(
            chi4_of(n, Variance::PerOrigin, &blocks, None),
            n * mean(&per_origin)
        ));
        // The replicas' offset (0.5 against 0.7) is in the pooled reading only.
        assert!(
            chi4_of(n, Variance::Pooled, &blocks, None)
                > 2.0 * chi4_of(n, Variance::PerReplica, &blocks, None)
        );
        // Leaving a block out is leaving its frame out.
        let rest: Vec<f64> = q[0][1].iter().copied().collect();
        let with_r0 = var(&rest);
        let expect = n * (3.0 * with_r0 + 6.0 * per_rep[1]) / 9.0;
        assert!(close(
            chi4_of(n, Variance::PerReplica, &blocks, Some(&(0, 0))),
            expect
        ));
    }

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
            fractions: vec![0.25],
            lags: None,
            rel_tol: 1e-6,
            variance: Variance::default(),
        };
        resolve_sizes(&mut p, traj.n());
        assert_eq!(p.n, vec![100.0, 200.0, 800.0]);
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

    /// Q(t), chi4(t) and tau_alpha from the analysis equal a brute-force computation
    /// over the schedule: every lag of the schedule and no other, each from every
    /// origin once (the blocks overlap, and lags that are multiples of the origin
    /// spacing would otherwise pair frames of two origins), chi4 = N var(Q) over
    /// the origins of the whole system, tau_alpha where Q crosses 1/e, linearly
    /// in ln t.
    #[test]
    fn q_chi4_and_tau_alpha_match_a_brute_force_over_the_schedule() {
        use crate::traj::Schedule;
        let s = Schedule {
            start: 1.0,
            origins: 9,
            origin_spacing: 0.5,
            lags: Schedule::log_lags(0.1, 8.0, 6),
        };
        let mut traj = random_walk(300, [30.0, 30.0], &s.times(), 0.04, 11);
        traj.schedule = Some(s.clone());
        let (a, n) = (0.6, traj.n() as f64);
        // Brute force, straight from the definitions.
        let frame = |time: f64| {
            traj.frames
                .iter()
                .find(|f| (f.time - time).abs() < 1e-9)
                .expect("a frame of the schedule")
        };
        let mut want = Vec::new();
        for &lag in &s.lags {
            let qs: Vec<f64> = (0..s.origins)
                .map(|k| {
                    let t0 = s.start + k as f64 * s.origin_spacing;
                    let (f0, f1) = (frame(t0), frame(t0 + lag));
                    let slow = (0..traj.n())
                        .filter(|&i| {
                            let (dx, dy) = (f1.x[i] - f0.x[i], f1.y[i] - f0.y[i]);
                            (dx * dx + dy * dy).sqrt() < a
                        })
                        .count();
                    slow as f64 / n
                })
                .collect();
            let m = qs.iter().sum::<f64>() / qs.len() as f64;
            let m2 = qs.iter().map(|q| q * q).sum::<f64>() / qs.len() as f64;
            want.push((lag, m, n * (m2 - m * m)));
        }
        let level = (-1f64).exp();
        let k = want
            .iter()
            .position(|w| w.1 <= level)
            .expect("Q falls below 1/e");
        let ((t0, q0, _), (t1, q1, _)) = (want[k - 1], want[k]);
        let tau_want = (t0.ln() + (q0 - level) / (q0 - q1) * (t1.ln() - t0.ln())).exp();
        // The analysis, as the observables call it.
        let lags_used = lags::every_origin(&[&traj], None, 1e-6).unwrap();
        let p = Params {
            a,
            n: vec![n],
            fractions: Vec::new(),
            lags: lags_used,
            rel_tol: 1e-6,
            variance: Variance::default(),
        };
        let c = compute_pooled(&[&traj], &p).unwrap();
        let (t, q, chi, no) = (
            col(&c, "t"),
            col(&c, "Q"),
            col(&c, "chi4"),
            col(&c, "n_origins"),
        );
        assert_eq!(t.len(), s.lags.len(), "lags {t:?}");
        for (i, &(lag, qw, cw)) in want.iter().enumerate() {
            assert!((t[i] - lag).abs() < 1e-12 * lag, "lag {} vs {lag}", t[i]);
            assert!((q[i] - qw).abs() < 1e-12, "Q({lag}) = {} vs {qw}", q[i]);
            assert!(
                (chi[i] - cw).abs() < 1e-9,
                "chi4({lag}) = {} vs {cw}",
                chi[i]
            );
            assert_eq!(no[i], s.origins as f64, "lag {lag}");
        }
        let op = crate::analysis::overlap::Params {
            a,
            n: None,
            lags: p.lags.clone(),
            rel_tol: 1e-6,
            ..Default::default()
        };
        let tau = crate::analysis::overlap::tau_alpha(&[&traj], &op).unwrap();
        assert!(
            (tau.value - tau_want).abs() < 1e-9 * tau_want,
            "{} vs {tau_want}",
            tau.value
        );
    }
}
