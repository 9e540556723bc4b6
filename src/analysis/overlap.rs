//! The overlap Q(t) (paper H, Eq. 5-7), tau_alpha where Q = 1/e, and the aging check
//! Q(t; t0) of Fig. 2.
//!
//! A particle is slow over [t0, t0 + t] if it moved less than `a`. Q_r is the number
//! of slow particles in sub-box B_r (by position at t0) over the mean number N per
//! sub-box; Q(t) averages Q_r over sub-boxes and time origins.

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::lags::{self, Lag};
use super::stats::{Blocks, Estimate, at_least, crossing_resolution, crossing_time};
use super::subbox::SubBoxes;
use super::{check_trajectory, default_a, default_rel_tol, ensure_positive, squared_displacements};
use crate::table::f64_batch;
use crate::traj::Trajectory;

/// Parameters of the overlap Q(t).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Mobility cut-off a (units r1): slow means |dr| < a.
    #[serde(default = "default_a")]
    pub a: f64,
    /// Mean particle number per sub-box; the whole system if absent.
    #[serde(default)]
    pub n: Option<f64>,
    /// Lags t to evaluate; every lag the trajectory realises if absent.
    #[serde(default)]
    pub lags: Option<Vec<f64>>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
    /// Which displacement is compared with `a` (default: from the fixed origin,
    /// paper H's).
    #[serde(default)]
    pub displacement: Displacement,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            a: default_a(),
            n: None,
            lags: None,
            rel_tol: default_rel_tol(),
            displacement: Displacement::default(),
        }
    }
}

fn default_cage_cutoff() -> f64 {
    1.4
}

/// The displacement a disk's mobility is judged by.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Displacement {
    /// r_i(t0 + t) - r_i(t0), paper H's.
    #[default]
    Absolute,
    /// Relative to the mean displacement of its neighbours at t0, closer than
    /// `cutoff` contact distances ([`super::cage`]): a diagnostic of
    /// long-wavelength collective motion, not paper H's method.
    CageRelative {
        #[serde(default = "default_cage_cutoff")]
        cutoff: f64,
    },
}

/// Per lag and per sub-box size: blocked sums [sum Q_r, sum Q_r^2, number of boxes].
pub struct Moments {
    pub lags: Vec<Lag>,
    pub boxes: Vec<SubBoxes>,
    /// `blocks[size][lag]`.
    pub blocks: Vec<Vec<Blocks>>,
}

/// One displacement pass per frame pair, shared by every sub-box size.
pub fn moments(
    trajs: &[&Trajectory],
    a: f64,
    displacement: Displacement,
    sizes: &[Option<f64>],
    lags: Option<&[f64]>,
    rel_tol: f64,
) -> Result<Moments> {
    ensure_positive("a", a)?;
    let Some(first) = trajs.first() else {
        bail!("no trajectory given");
    };
    for t in trajs {
        check_trajectory(t)?;
        if t.n() != first.n() || t.box_size != first.box_size {
            bail!("replicas differ in particle number or box size; pool only identical systems");
        }
    }
    let lags = lags::select(trajs, lags, rel_tol)?;
    let boxes: Vec<SubBoxes> = sizes
        .iter()
        .map(|n| SubBoxes::new(first, n.unwrap_or(first.n() as f64)))
        .collect::<Result<_>>()?;
    let mut blocks = vec![vec![Blocks::default(); lags.len()]; boxes.len()];
    let a2 = a * a;
    for (li, lag) in lags.iter().enumerate() {
        for pair in &lag.pairs {
            let tr = trajs[pair.0];
            let (f0, f1) = (&tr.frames[pair.1], &tr.frames[pair.2]);
            let d2 = match displacement {
                Displacement::Absolute => squared_displacements(f0, f1),
                Displacement::CageRelative { cutoff } => {
                    super::cage::squared_displacements(tr, f0, f1, cutoff)?
                }
            };
            let slow: Vec<bool> = d2.into_iter().map(|d2| d2 < a2).collect();
            for (bi, b) in boxes.iter().enumerate() {
                let m = b.overlap_moments(&f0.x, &f0.y, &slow);
                blocks[bi][li].add(Lag::block(pair), &m);
            }
        }
    }
    Ok(Moments {
        lags,
        boxes,
        blocks,
    })
}

impl Moments {
    /// Length of the error bins: tau_alpha of the pooled Q (the mean of Q_r is the
    /// same whatever the sub-box size), or the longest lag when Q never reaches 1/e
    /// (then tau_alpha is longer still).
    pub fn bin_length(&self) -> f64 {
        let t: Vec<f64> = self.lags.iter().map(|l| l.t).collect();
        let q: Vec<f64> = self.blocks[0].iter().map(|b| q_of(&b.total())).collect();
        crossing_time(&t, &q, (-1f64).exp())
            .or(t.last().copied())
            .unwrap_or(f64::NAN)
    }

    /// The blocks of sub-box size `size` regrouped for errors into (replica, origin
    /// bin) blocks [`lags::origin_bins`] of [`Self::bin_length`].
    pub fn error_blocks(&self, trajs: &[&Trajectory], size: usize) -> Vec<Blocks> {
        rebin(
            &self.blocks[size],
            lags::origin_bins(trajs, self.bin_length()),
        )
    }
}

/// `blocks` with their keys mapped by `bin` and the sums of keys that share a bin
/// added: the per-origin blocks of one lag become the error's units.
pub(crate) fn rebin(
    blocks: &[Blocks],
    bin: impl Fn(&(usize, usize)) -> (usize, usize),
) -> Vec<Blocks> {
    blocks
        .iter()
        .map(|b| {
            let mut out = Blocks::default();
            for k in b.keys() {
                out.add(bin(k), b.get(k).expect("key from this block set"));
            }
            out
        })
        .collect()
}

/// Every (replica, origin) block that any lag saw, sorted: the jackknife's units.
pub(crate) fn block_keys(blocks: &[Blocks]) -> Vec<(usize, usize)> {
    let mut keys: Vec<(usize, usize)> = blocks.iter().flat_map(|b| b.keys().copied()).collect();
    keys.sort_unstable();
    keys.dedup();
    keys
}

/// Q = mean of Q_r from the sums [sum Q, sum Q^2, boxes].
pub(crate) fn q_of(s: &[f64]) -> f64 {
    s[0] / s[2]
}

/// [`moments`] with the overlap's parameters, one sub-box size.
fn moments_of(trajs: &[&Trajectory], p: &Params) -> Result<Moments> {
    moments(
        trajs,
        p.a,
        p.displacement,
        &[p.n],
        p.lags.as_deref(),
        p.rel_tol,
    )
}

/// Q(t) with jackknife errors over (replica, origin bin) blocks, pooling replicas,
/// and the number of time origins at each lag.
pub fn q_curve(trajs: &[&Trajectory], p: &Params) -> Result<(Vec<f64>, Vec<Estimate>, Vec<usize>)> {
    let m = moments_of(trajs, p)?;
    let t = m.lags.iter().map(|l| l.t).collect();
    let q = m
        .error_blocks(trajs, 0)
        .iter()
        .map(|b| b.jackknife(q_of))
        .collect();
    let n = m.blocks[0].iter().map(Blocks::len).collect();
    Ok((t, q, n))
}

/// Table `t, Q, Q_err, n_origins`.
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    let (t, q, n) = q_curve(&[traj], p)?;
    f64_batch(&[
        ("t", t),
        ("Q", q.iter().map(|e| e.value).collect()),
        ("Q_err", q.iter().map(|e| e.err).collect()),
        ("n_origins", n.iter().map(|&k| k as f64).collect()),
    ])
}

/// tau_alpha where Q(tau_alpha) = 1/e (linear interpolation in ln t), with a
/// jackknife error over (replica, origin bin) blocks. Errors if Q never reaches 1/e.
pub fn tau_alpha(trajs: &[&Trajectory], p: &Params) -> Result<Estimate> {
    let m = moments_of(trajs, p)?;
    let t: Vec<f64> = m.lags.iter().map(|l| l.t).collect();
    crossing_estimate(&t, &m.error_blocks(trajs, 0))
}

/// Where Q, summed in `blocks` (one per lag `t`), crosses 1/e, with a delete-one
/// jackknife over the blocks' keys.
fn crossing_estimate(t: &[f64], blocks: &[Blocks]) -> Result<Estimate> {
    let level = (-1f64).exp();
    let totals: Vec<Vec<f64>> = blocks.iter().map(Blocks::total).collect();
    let q: Vec<f64> = totals.iter().map(|s| q_of(s)).collect();
    let Some(value) = crossing_time(t, &q, level) else {
        bail!(
            "Q(t) never falls to 1/e over the lags analysed (last lag {}, Q = {}): record \
             longer lags to measure tau_alpha",
            t.last().copied().unwrap_or(f64::NAN),
            q.last().copied().unwrap_or(f64::NAN)
        );
    };
    let keys = block_keys(blocks);
    let loo: Vec<f64> = keys
        .iter()
        .map(|k| {
            let qk: Vec<f64> = blocks
                .iter()
                .zip(&totals)
                .map(|(b, tot)| q_of(&b.total_without(tot, k)))
                .collect();
            crossing_time(t, &qk, level).unwrap_or(f64::NAN)
        })
        .collect();
    let res = crossing_resolution(t, &q, level).unwrap_or(0.0);
    Ok(Estimate {
        value,
        err: at_least(super::stats::jackknife_err(loo), res),
    })
}

/// Parameters of [`q_levels`]: the overlap's, plus the levels Q crosses.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LevelParams {
    /// Mobility cut-off a (units r1): slow means |dr| < a.
    #[serde(default = "default_a")]
    pub a: f64,
    /// Levels of Q (in (0, 1)) whose crossing times are measured.
    pub levels: Vec<f64>,
    /// Lags t to evaluate; every lag the trajectory realises if absent.
    #[serde(default)]
    pub lags: Option<Vec<f64>>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
}

/// Time-density superposition test (Fig. 5): for each level q, the time t_q where
/// Q(t_q) = q and its ratio to tau_alpha (Q = 1/e). Superposition means t_q / tau_alpha
/// is the same at every phi. Both come from one jackknife over (replica, origin
/// bin) blocks, so the ratio's error accounts for their correlation.
/// Table `level, t, t_err, tau_alpha, t_over_tau_alpha, t_over_tau_alpha_err`.
pub fn q_levels(trajs: &[&Trajectory], p: &LevelParams) -> Result<RecordBatch> {
    if let Some(l) = p.levels.iter().find(|l| !(**l > 0.0 && **l < 1.0)) {
        bail!("parameter `levels` must hold values in (0, 1), got {l}");
    }
    if p.levels.is_empty() {
        bail!("parameter `levels` is empty: give at least one level, e.g. levels: [0.6]");
    }
    let m = moments(
        trajs,
        p.a,
        Displacement::Absolute,
        &[None],
        p.lags.as_deref(),
        p.rel_tol,
    )?;
    let t: Vec<f64> = m.lags.iter().map(|l| l.t).collect();
    let alpha = (-1f64).exp();
    let blocks = &m.error_blocks(trajs, 0);
    let totals: Vec<Vec<f64>> = blocks.iter().map(Blocks::total).collect();
    let q: Vec<f64> = totals.iter().map(|s| q_of(s)).collect();
    let keys = block_keys(blocks);
    let loo_q: Vec<Vec<f64>> = keys
        .iter()
        .map(|k| {
            blocks
                .iter()
                .zip(&totals)
                .map(|(b, tot)| q_of(&b.total_without(tot, k)))
                .collect()
        })
        .collect();
    let cross = |q: &[f64], level: f64| crossing_time(&t, q, level).unwrap_or(f64::NAN);
    let tau = cross(&q, alpha);
    if !tau.is_finite() {
        bail!(
            "Q(t) never falls to 1/e over the lags analysed (last lag {}): record longer lags",
            t.last().copied().unwrap_or(f64::NAN)
        );
    }
    let mut cols: [Vec<f64>; 6] = Default::default();
    for &level in &p.levels {
        let tq = cross(&q, level);
        let res = |level: f64| crossing_resolution(&t, &q, level).unwrap_or(0.0);
        // The ratio's resolution: both crossings' in quadrature, relative.
        let r_res = tq / tau * ((res(level) / tq).powi(2) + (res(alpha) / tau).powi(2)).sqrt();
        let loo_t: Vec<f64> = loo_q.iter().map(|qk| cross(qk, level)).collect();
        let loo_r: Vec<f64> = loo_q
            .iter()
            .zip(&loo_t)
            .map(|(qk, tk)| tk / cross(qk, alpha))
            .collect();
        cols[0].push(level);
        cols[1].push(tq);
        cols[2].push(at_least(super::stats::jackknife_err(loo_t), res(level)));
        cols[3].push(tau);
        cols[4].push(tq / tau);
        cols[5].push(at_least(super::stats::jackknife_err(loo_r), r_res));
    }
    let [level, tq, tq_err, tau, r, r_err] = cols;
    f64_batch(&[
        ("level", level),
        ("t", tq),
        ("t_err", tq_err),
        ("tau_alpha", tau),
        ("t_over_tau_alpha", r),
        ("t_over_tau_alpha_err", r_err),
    ])
}

/// (t0, lags, Q) of one time origin.
pub type OriginCurve = (f64, Vec<f64>, Vec<f64>);

/// Q(t; t0) for each time origin t0 separately (no origin average), t0 measured
/// from the first frame: `(t0, lags, Q)` per origin, lags ascending.
pub fn per_origin(traj: &Trajectory, p: &Params) -> Result<Vec<OriginCurve>> {
    let m = moments_of(&[traj], p)?;
    let start = traj.frames[0].time;
    let mut by_origin: std::collections::BTreeMap<usize, (Vec<f64>, Vec<f64>)> = Default::default();
    for (lag, b) in m.lags.iter().zip(&m.blocks[0]) {
        for k in b.keys() {
            let e = by_origin.entry(k.1).or_default();
            e.0.push(lag.t);
            e.1.push(q_of(b.get(k).expect("key from this block set")));
        }
    }
    Ok(by_origin
        .into_iter()
        .map(|(i, (t, q))| (traj.frames[i].time - start, t, q))
        .collect())
}

/// One waiting time t0: its lags, Q(t; t0) averaged over replicas, and each
/// replica's own Q(t; t0) (for the replica jackknife of tau_alpha(t0)).
pub type AgingCurve = (f64, Vec<f64>, Vec<f64>, Vec<Vec<f64>>);

/// Aging check (Fig. 2): Q(t; t0) per waiting time t0, averaged over replicas that
/// share one schedule. Only true time origins count: the frames from which the
/// shortest lag is realised (the schedule's lags are log-spaced, so no frame inside
/// a block is that close to another); frames pairing only with other origins'
/// frames are not waiting times.
pub fn aging_curves(trajs: &[&Trajectory], p: &Params) -> Result<Vec<AgingCurve>> {
    // Per waiting time: (t0, lags, each replica's Q).
    type PerReplica = (f64, Vec<f64>, Vec<Vec<f64>>);
    let mut acc: std::collections::BTreeMap<u64, PerReplica> = Default::default();
    for tr in trajs {
        for (t0, t, q) in per_origin(tr, p)? {
            // Waiting times agree across replicas up to rounding: key them on 1e-9.
            let key = (t0 * 1e9).round() as u64;
            let e = acc
                .entry(key)
                .or_insert_with(|| (t0, t.clone(), Vec::new()));
            if e.1 == t {
                e.2.push(q);
            }
        }
    }
    let shortest = acc
        .values()
        .filter_map(|e| e.1.first().copied())
        .fold(f64::INFINITY, f64::min);
    Ok(acc
        .into_values()
        .filter(|e| {
            e.1.first()
                .is_some_and(|&t| (t - shortest).abs() <= 1e-9 * shortest)
        })
        .map(|(t0, t, per)| {
            let mean = (0..t.len())
                .map(|i| per.iter().map(|q| q[i]).sum::<f64>() / per.len() as f64)
                .collect();
            (t0, t, mean, per)
        })
        .collect())
}

/// The aging tables: `t0, t, Q` (Q(t; t0), Fig. 2) and `t0, tau_alpha,
/// tau_alpha_err` (Fig. 2 inset, NaN where Q(t; t0) never reaches 1/e), from
/// [`aging_curves`]. One waiting time is one time origin per replica, so its error
/// is the delete-one jackknife over replicas (NaN with one replica).
pub fn aging(trajs: &[&Trajectory], p: &Params) -> Result<(RecordBatch, RecordBatch)> {
    let level = (-1f64).exp();
    let mut cols: [Vec<f64>; 3] = Default::default();
    let (mut t0s, mut taus, mut errs) = (Vec::new(), Vec::new(), Vec::new());
    for (t0, t, q, per) in aging_curves(trajs, p)? {
        t0s.push(t0);
        taus.push(crossing_time(&t, &q, level).unwrap_or(f64::NAN));
        let r = per.len() as f64;
        let loo = per.iter().map(|qk| {
            let q_without: Vec<f64> = q
                .iter()
                .zip(qk)
                .map(|(m, v)| (m * r - v) / (r - 1.0))
                .collect();
            crossing_time(&t, &q_without, level).unwrap_or(f64::NAN)
        });
        let res = crossing_resolution(&t, &q, level).unwrap_or(0.0);
        errs.push(at_least(super::stats::jackknife_err(loo.collect()), res));
        cols[0].extend(std::iter::repeat_n(t0, t.len()));
        cols[1].extend(t);
        cols[2].extend(q);
    }
    let [t0, t, q] = cols;
    Ok((
        f64_batch(&[("t0", t0), ("t", t), ("Q", q)])?,
        f64_batch(&[("t0", t0s), ("tau_alpha", taus), ("tau_alpha_err", errs)])?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::random_walk;
    use crate::analysis::test_support::{col, first, schedule_times};
    use crate::traj::Schedule;

    /// A random walk obeys superposition exactly: Q = 1 - exp(-a^2 / 4 D t), so
    /// t_q / tau_alpha = ln(e / (e - 1)) / ln(1 / (1 - q)) whatever D is.
    #[test]
    fn random_walks_obey_time_superposition_at_every_d() {
        let lags = Schedule::log_lags(0.05, 40.0, 10);
        let times = Schedule {
            start: 0.0,
            origins: 12,
            origin_spacing: 40.0,
            lags: lags.clone(),
        }
        .times();
        let exact = (std::f64::consts::E / (std::f64::consts::E - 1.0)).ln() / (1.0f64 / 0.4).ln();
        for d in [0.02, 0.2] {
            let traj = random_walk(3000, [60.0, 60.0], &times, d, 11);
            let p = LevelParams {
                a: 0.6,
                levels: vec![0.6],
                lags: Some(lags.clone()),
                rel_tol: 1e-6,
            };
            let b = q_levels(&[&traj], &p).unwrap();
            let get = |n: &str| first(&b, n);
            let (r, err) = (get("t_over_tau_alpha"), get("t_over_tau_alpha_err"));
            assert!(err > 0.0 && err < 0.05 * exact, "error {err}");
            assert!(
                (r - exact).abs() < 0.03 * exact,
                "D = {d}: ratio {r} +- {err}, exact {exact}"
            );
        }
        let bad = LevelParams {
            a: 0.6,
            levels: vec![1.2],
            lags: None,
            rel_tol: 1e-6,
        };
        let traj = random_walk(10, [10.0, 10.0], &times, 0.1, 1);
        let e = format!("{:#}", q_levels(&[&traj], &bad).unwrap_err());
        assert!(e.contains("levels") && e.contains("1.2"), "{e}");
    }

    /// Overlapping origins (every tau_alpha / 8) see overlapping stretches of the
    /// same walk: a jackknife over single origins quotes far too small an error on
    /// tau_alpha, one over origin bins tau_alpha long about the seed-to-seed spread.
    #[test]
    fn origin_bins_keep_tau_alpha_errors_honest_with_overlapping_origins() {
        // Q = 1 - exp(-a^2 / 4 D t) = 1/e at tau = a^2 / (4 D ln(e / (e - 1))).
        let (a, d) = (0.6, 0.1);
        let tau = a * a / (4.0 * d * (std::f64::consts::E / (std::f64::consts::E - 1.0)).ln());
        let lags = Schedule::log_lags(0.05 * tau, 10.0 * tau, 8);
        let times = Schedule {
            start: 0.0,
            origins: 4,
            origin_spacing: 2.0 * tau,
            lags: lags.clone(),
        }
        .overlapping(0.125 * tau)
        .times();
        let p = Params {
            a,
            n: None,
            lags: Some(lags),
            rel_tol: 1e-6,
            ..Default::default()
        };
        let (mut values, mut per_origin, mut binned) = (Vec::new(), Vec::new(), Vec::new());
        for seed in 0..40 {
            let traj = random_walk(300, [40.0, 40.0], &times, d, 100 + seed);
            let m = moments(
                &[&traj],
                a,
                Displacement::Absolute,
                &[None],
                p.lags.as_deref(),
                p.rel_tol,
            )
            .unwrap();
            let t: Vec<f64> = m.lags.iter().map(|l| l.t).collect();
            let old = crossing_estimate(&t, &m.blocks[0]).unwrap();
            let new = tau_alpha(&[&traj], &p).unwrap();
            assert!(
                (old.value - new.value).abs() < 1e-12 * new.value,
                "binning changes errors, not values"
            );
            assert!(
                (m.bin_length() / tau - 1.0).abs() < 0.2,
                "bin {}",
                m.bin_length()
            );
            values.push(new.value);
            per_origin.push(old.err);
            binned.push(new.err);
        }
        let (mean, spread) = crate::analysis::stats::mean_std(&values);
        let rms = |e: &[f64]| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
        let (r_old, r_new) = (rms(&per_origin) / spread, rms(&binned) / spread);
        eprintln!("tau {tau} mean {mean} spread {spread} ratio per origin {r_old} binned {r_new}");
        assert!((mean / tau - 1.0).abs() < 0.05, "tau_alpha {mean} vs {tau}");
        assert!(r_old < 0.7, "per-origin errors / spread = {r_old}");
        assert!(
            (0.75..1.5).contains(&r_new),
            "binned errors / spread = {r_new}"
        );
    }

    #[test]
    fn tau_alpha_matches_the_random_walk_overlap() {
        // Q(t) = P(|dr| < a) = 1 - exp(-a^2 / 4Dt): Q = 1/e at a^2 / (4 D ln(e / (e - 1))).
        let (d, a) = (0.05, 0.6);
        let exact = a * a / (4.0 * d * (std::f64::consts::E / (std::f64::consts::E - 1.0)).ln());
        let times = schedule_times(20, 40.0, 0.1, 30.0);
        let traj = random_walk(3000, [60.0, 60.0], &times, d, 21);
        let p = Params {
            a,
            ..Default::default()
        };
        let lags = Schedule::log_lags(0.1, 30.0, 8);
        let p = Params {
            lags: Some(lags),
            ..p
        };
        let tau = tau_alpha(&[&traj], &p).unwrap();
        eprintln!("tau_alpha = {} +- {}, exact {exact}", tau.value, tau.err);
        assert!(tau.err > 0.0 && tau.err < 0.02 * exact);
        assert!((tau.value - exact).abs() < 0.03 * exact);

        // Aging check: every origin gives its own curve; the stationary walk shows none.
        let (_, ag) = aging(&[&traj], &p).unwrap();
        let per_origin = col(&ag, "tau_alpha");
        let finite: Vec<f64> = per_origin
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        assert!(finite.len() >= 20);
        assert!(
            finite.iter().all(|v| (v - exact).abs() < 0.1 * exact),
            "{finite:?}"
        );
    }

    #[test]
    fn aging_of_identical_replicas_is_the_single_replica_curve() {
        // Averaging a replica with itself changes nothing; only true origins are kept.
        let times = schedule_times(5, 40.0, 0.1, 30.0);
        let traj = random_walk(500, [30.0, 30.0], &times, 0.05, 3);
        let p = Params::default();
        let one = aging_curves(&[&traj], &p).unwrap();
        let two = aging_curves(&[&traj, &traj], &p).unwrap();
        assert_eq!(one.len(), 5, "one curve per time origin");
        for (a, b) in one.iter().zip(&two) {
            assert_eq!(a.0, b.0);
            assert_eq!(a.1, b.1);
            for (x, y) in a.2.iter().zip(&b.2) {
                assert!((x - y).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn aging_tau_alpha_error_is_the_replica_jackknife() {
        // One waiting time is one origin per replica: leaving one of two replicas out
        // leaves the other, so the jackknife error is half the two replicas' difference.
        let times = schedule_times(5, 40.0, 0.1, 30.0);
        let slow = random_walk(2000, [50.0, 50.0], &times, 0.05, 3);
        let fast = random_walk(2000, [50.0, 50.0], &times, 0.1, 4);
        let p = Params {
            lags: Some(Schedule::log_lags(0.1, 30.0, 8)),
            ..Default::default()
        };
        let tau_of = |trajs: &[&Trajectory]| {
            let (_, ag) = aging(trajs, &p).unwrap();
            (col(&ag, "tau_alpha"), col(&ag, "tau_alpha_err"))
        };
        let (ts, es) = tau_of(&[&slow]);
        let (tf, _) = tau_of(&[&fast]);
        let (tb, eb) = tau_of(&[&slow, &fast]);
        assert!(
            es.iter().all(|e| e.is_nan()),
            "one replica has no error: {es:?}"
        );
        let mut checked = 0;
        for i in 0..tb.len() {
            if !(ts[i].is_finite() && tf[i].is_finite()) {
                continue;
            }
            let want = (ts[i] - tf[i]).abs() / 2.0;
            assert!(
                want > 0.0 && (eb[i] - want).abs() < 1e-9 * want,
                "{} vs {want}",
                eb[i]
            );
            // The slower walk relaxes later; the pooled tau lies between the two.
            assert!(ts[i] > tf[i] && tb[i] < ts[i] && tb[i] > tf[i]);
            checked += 1;
        }
        assert_eq!(checked, 5);
        // Identical replicas: the jackknife says 0, the quoted error is the
        // interpolation's resolution, small against tau_alpha.
        let (_, same) = tau_of(&[&slow, &slow]);
        assert!(
            same.iter()
                .zip(&ts)
                .all(|(&e, &t)| !t.is_finite() || (e > 0.0 && e < 0.02 * t)),
            "identical replicas: {same:?}"
        );
    }
}
