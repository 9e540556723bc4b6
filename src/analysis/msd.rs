//! Mean squared displacement Delta(t) (paper H, Eq. 9) for all particles, per species,
//! and for the fastest / slowest fraction selected per time interval (Fig. 7).

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::lags;
use super::stats::Blocks;
use super::{check_trajectory, default_rel_tol, squared_displacements};
use crate::table::f64_batch;
use crate::traj::Trajectory;

/// Parameters of the MSD.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Lags t; every lag the trajectory realises if absent.
    #[serde(default)]
    pub lags: Option<Vec<f64>>,
    /// Fractions f in (0, 1): also report the MSD of the fastest and slowest f of
    /// each group, ranked by their displacement over each interval.
    #[serde(default)]
    pub fractions: Vec<f64>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            lags: None,
            fractions: vec![],
            rel_tol: default_rel_tol(),
        }
    }
}

/// Which particles a row describes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Subset {
    /// Species, or None for all particles.
    pub species: Option<u8>,
    /// +1 fastest, -1 slowest, 0 every particle of the group.
    pub select: i8,
    /// Fraction selected (1 when select = 0).
    pub fraction: f64,
}

/// Mean of the fastest (`select` > 0) or slowest (< 0) `fraction` of `d2`, or of all.
fn subset_mean(d2: &mut [f64], select: i8, fraction: f64) -> f64 {
    if select == 0 {
        return d2.iter().sum::<f64>() / d2.len() as f64;
    }
    let k = ((fraction * d2.len() as f64).round() as usize).clamp(1, d2.len());
    let part: &[f64] = if select > 0 {
        let cut = d2.len() - k;
        if cut > 0 {
            d2.select_nth_unstable_by(cut, f64::total_cmp);
        }
        &d2[cut..]
    } else {
        if k < d2.len() {
            d2.select_nth_unstable_by(k, f64::total_cmp);
        }
        &d2[..k]
    };
    part.iter().sum::<f64>() / k as f64
}

/// Table `t, species, select, fraction, msd, msd_err, n_origins`: species -1 = all
/// particles; select 0 = whole group, +1 = fastest fraction, -1 = slowest fraction;
/// msd_err is the standard error over time origins.
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    if let Some(f) = p.fractions.iter().find(|f| !(**f > 0.0 && **f < 1.0)) {
        bail!("parameter `fractions` must hold values in (0, 1), got {f}");
    }
    let lags = lags::select(&[traj], p.lags.as_deref(), p.rel_tol)?;
    let mut species: Vec<u8> = traj.species.clone();
    species.sort_unstable();
    species.dedup();
    let groups: Vec<Option<u8>> = std::iter::once(None)
        .chain(species.iter().map(|&s| Some(s)))
        .collect();
    let mut subsets = Vec::new();
    for &g in &groups {
        subsets.push(Subset {
            species: g,
            select: 0,
            fraction: 1.0,
        });
        for &f in &p.fractions {
            for select in [1, -1] {
                subsets.push(Subset {
                    species: g,
                    select,
                    fraction: f,
                });
            }
        }
    }
    let mut cols: [Vec<f64>; 7] = Default::default();
    for lag in &lags {
        let mut blocks = vec![Blocks::default(); subsets.len()];
        for pair in &lag.pairs {
            let d2 = squared_displacements(&traj.frames[pair.1], &traj.frames[pair.2]);
            for (s, b) in subsets.iter().zip(&mut blocks) {
                let mut group: Vec<f64> = match s.species {
                    None => d2.clone(),
                    Some(sp) => d2
                        .iter()
                        .zip(&traj.species)
                        .filter(|(_, k)| **k == sp)
                        .map(|(d, _)| *d)
                        .collect(),
                };
                let m = subset_mean(&mut group, s.select, s.fraction);
                b.add(lags::Lag::block(pair), &[1.0, m, m * m]);
            }
        }
        for (s, b) in subsets.iter().zip(&blocks) {
            let tot = b.total();
            let n = tot[0];
            let mean = tot[1] / n;
            let var = (tot[2] / n - mean * mean).max(0.0) * n / (n - 1.0);
            cols[0].push(lag.t);
            cols[1].push(s.species.map_or(-1.0, f64::from));
            cols[2].push(f64::from(s.select));
            cols[3].push(s.fraction);
            cols[4].push(mean);
            cols[5].push(if n > 1.0 { (var / n).sqrt() } else { f64::NAN });
            cols[6].push(n);
        }
    }
    let [t, sp, sel, fr, msd, err, no] = cols;
    f64_batch(&[
        ("t", t),
        ("species", sp),
        ("select", sel),
        ("fraction", fr),
        ("msd", msd),
        ("msd_err", err),
        ("n_origins", no),
    ])
}

fn default_fit_min_tau() -> f64 {
    1.0
}

/// Parameters of [`diffusion`].
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DiffusionParams {
    /// Mobility cut-off a of the overlap that defines tau_alpha (units r1).
    #[serde(default = "super::default_a")]
    pub a: f64,
    /// The fit range starts at this multiple of tau_alpha.
    #[serde(default = "default_fit_min_tau")]
    pub fit_min_tau: f64,
    /// The fit range ends at this multiple of tau_alpha; the longest lag if absent.
    #[serde(default)]
    pub fit_max_tau: Option<f64>,
    /// Only this species; every particle if absent.
    #[serde(default)]
    pub species: Option<u8>,
    /// Lags t; every lag the trajectory realises if absent.
    #[serde(default)]
    pub lags: Option<Vec<f64>>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
}

/// Slope of the least-squares line through (t, y).
fn slope(t: &[f64], y: &[f64]) -> f64 {
    let n = t.len() as f64;
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = t.iter().zip(y).map(|(a, b)| (a - mt) * (b - my)).sum();
    let sxx: f64 = t.iter().map(|a| (a - mt) * (a - mt)).sum();
    sxy / sxx
}

/// Diffusion coefficient from the long-time MSD (Fig. 9): D = slope / 4 of the
/// line through Delta(t) over lags in [fit_min_tau, fit_max_tau] x tau_alpha (2D:
/// Delta = 4 D t + const at long times; the intercept absorbs the cage plateau),
/// replicas pooled, with a jackknife error over (replica, origin bin) blocks
/// (bins tau_alpha long).
/// Table (one row) `D, D_err, tau_alpha, tau_alpha_err, t_fit_min, t_fit_max, points`.
pub fn diffusion(trajs: &[&Trajectory], p: &DiffusionParams) -> Result<RecordBatch> {
    let lag_list = lags::every_origin(trajs, p.lags.clone(), p.rel_tol)?;
    let op = super::overlap::Params {
        a: p.a,
        n: None,
        lags: lag_list.clone(),
        rel_tol: p.rel_tol,
        ..Default::default()
    };
    let tau = super::overlap::tau_alpha(trajs, &op)?;
    let lo = p.fit_min_tau * tau.value;
    let hi = p.fit_max_tau.map_or(f64::INFINITY, |m| m * tau.value);
    let all = lags::select(trajs, lag_list.as_deref(), p.rel_tol)?;
    let longest = all.last().map_or(f64::NAN, |l| l.t);
    let used: Vec<&lags::Lag> = all
        .iter()
        .filter(|l| l.t >= lo * (1.0 - 1e-9) && l.t <= hi * (1.0 + 1e-9))
        .collect();
    if used.len() < 2 {
        bail!(
            "D needs at least two lags in [{lo:.4}, {hi:.4}] ({} to {:?} x tau_alpha = {:.4}); \
             the trajectory has {} there (longest lag {longest:.4}): record longer lags or lower `fit_min_tau`",
            p.fit_min_tau,
            p.fit_max_tau,
            tau.value,
            used.len()
        );
    }
    let mut blocks = vec![Blocks::default(); used.len()];
    for (lag, b) in used.iter().zip(&mut blocks) {
        for pair in &lag.pairs {
            let tr = trajs[pair.0];
            let d2 = squared_displacements(&tr.frames[pair.1], &tr.frames[pair.2]);
            let (mut s, mut k) = (0.0, 0.0);
            for (d, sp) in d2.iter().zip(&tr.species) {
                if p.species.is_none_or(|want| want == *sp) {
                    s += d;
                    k += 1.0;
                }
            }
            if k == 0.0 {
                bail!(
                    "parameter `species` = {:?}: no particle of that species",
                    p.species
                );
            }
            b.add(lags::Lag::block(pair), &[1.0, s / k]);
        }
    }
    let t: Vec<f64> = used.iter().map(|l| l.t).collect();
    let blocks = super::overlap::rebin(&blocks, lags::origin_bins(trajs, tau.value));
    let totals: Vec<Vec<f64>> = blocks.iter().map(Blocks::total).collect();
    let msd: Vec<f64> = totals.iter().map(|s| s[1] / s[0]).collect();
    let d = slope(&t, &msd) / 4.0;
    let keys = super::overlap::block_keys(&blocks);
    let loo: Vec<f64> = keys
        .iter()
        .map(|k| {
            let m: Vec<f64> = blocks
                .iter()
                .zip(&totals)
                .map(|(b, tot)| {
                    let s = b.total_without(tot, k);
                    s[1] / s[0]
                })
                .collect();
            slope(&t, &m) / 4.0
        })
        .collect();
    f64_batch(&[
        ("D", vec![d]),
        ("D_err", vec![super::stats::jackknife_err(loo)]),
        ("tau_alpha", vec![tau.value]),
        ("tau_alpha_err", vec![tau.err]),
        ("t_fit_min", vec![t[0]]),
        ("t_fit_max", vec![t[t.len() - 1]]),
        ("points", vec![t.len() as f64]),
    ])
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;
    use crate::analysis::synthetic::{ballistic, random_walk};
    use crate::analysis::test_support::{col, first, schedule_times};
    use crate::analysis::van_hove;
    use crate::traj::Schedule;

    /// Twelve origins 60 apart, each followed by lags from 0.1 to 60.
    fn times() -> Vec<f64> {
        schedule_times(12, 60.0, 0.1, 60.0)
    }

    #[test]
    fn diffusion_of_a_random_walk_is_its_d() {
        for d in [0.02, 0.1] {
            let traj = random_walk(2000, [60.0, 60.0], &times(), d, 9);
            let p = DiffusionParams {
                a: 0.6,
                fit_min_tau: 1.0,
                fit_max_tau: None,
                species: None,
                lags: Some(Schedule::log_lags(0.1, 60.0, 8)),
                rel_tol: 1e-6,
            };
            let b = diffusion(&[&traj], &p).unwrap();
            let get = |n: &str| first(&b, n);
            let (dd, err, tau) = (get("D"), get("D_err"), get("tau_alpha"));
            // Q = 1 - exp(-a^2 / 4 D t) = 1/e: tau_alpha = a^2 / (4 D ln(e / (e - 1))).
            let exact_tau =
                0.36 / (4.0 * d * (std::f64::consts::E / (std::f64::consts::E - 1.0)).ln());
            assert!(
                (tau - exact_tau).abs() < 0.05 * exact_tau,
                "tau {tau} vs {exact_tau}"
            );
            assert!(
                get("t_fit_min") >= tau * (1.0 - 1e-9),
                "fit starts at tau_alpha"
            );
            assert!(err > 0.0 && err < 0.05 * d, "D_err {err}");
            assert!(
                (dd - d).abs() < 4.0 * err.max(0.01 * d),
                "D {dd} +- {err} vs {d}"
            );
        }
    }

    #[test]
    fn diffusion_without_lags_in_the_fit_range_names_the_numbers() {
        let traj = random_walk(200, [30.0, 30.0], &times(), 0.05, 3);
        let p = DiffusionParams {
            a: 0.6,
            fit_min_tau: 1000.0,
            fit_max_tau: None,
            species: None,
            lags: None,
            rel_tol: 1e-6,
        };
        let e = format!("{:#}", diffusion(&[&traj], &p).unwrap_err());
        assert!(
            e.contains("at least two lags") && e.contains("longest lag"),
            "{e}"
        );
    }

    #[test]
    fn random_walk_msd_is_4dt_and_van_hove_is_gaussian() {
        let d = 0.25;
        let times = schedule_times(10, 20.0, 0.1, 10.0);
        let traj = random_walk(20_000, [140.0, 140.0], &times, d, 5);
        let b = compute(
            &traj,
            &Params {
                lags: Some(vec![0.1, 1.0, 10.0]),
                fractions: vec![0.1],
                rel_tol: 1e-6,
            },
        )
        .unwrap();
        let (t, sp, sel, m) = (
            col(&b, "t"),
            col(&b, "species"),
            col(&b, "select"),
            col(&b, "msd"),
        );
        for k in 0..t.len() {
            let exact = 4.0 * d * t[k];
            // |dr|^2 / 4Dt is Exp(1): fastest 10 % average 1 + ln 10, slowest 10 %
            // 1 - q e^-q / (1 - e^-q) with q = ln(10/9).
            let qs = (10f64 / 9.0).ln();
            let factor = match sel[k] as i8 {
                0 => 1.0,
                1 => 1.0 + 10f64.ln(),
                _ => 1.0 - qs * (-qs).exp() / (1.0 - (-qs).exp()),
            };
            let tol = if sel[k] == 0.0 { 0.02 } else { 0.04 };
            assert!(
                (m[k] / (exact * factor) - 1.0).abs() < tol,
                "t = {} species {} select {}: {} vs {}",
                t[k],
                sp[k],
                sel[k],
                m[k],
                exact * factor
            );
        }

        let h = van_hove::compute(
            &traj,
            &van_hove::Params {
                lags: vec![1.0],
                bin: 0.05,
                range: 5.0,
                species: None,
                rel_tol: 1e-6,
            },
        )
        .unwrap();
        let (dx, pdx) = (col(&h, "dx"), col(&h, "P"));
        let var = 2.0 * d;
        let bin = dx[1] - dx[0];
        let norm: f64 = pdx.iter().sum::<f64>() * bin;
        let second: f64 = dx.iter().zip(&pdx).map(|(x, p)| x * x * p).sum::<f64>() * bin;
        assert!((norm - 1.0).abs() < 1e-3, "normalisation {norm}");
        assert!(
            (second / var - 1.0).abs() < 0.03,
            "<dx^2> = {second}, expected {var}"
        );
        let centre = pdx[dx.len() / 2 - 1..dx.len() / 2 + 1].iter().sum::<f64>() / 2.0;
        let gauss0 = 1.0 / (2.0 * PI * var).sqrt();
        assert!(
            (centre / gauss0 - 1.0).abs() < 0.03,
            "P(0) = {centre}, Gaussian {gauss0}"
        );
    }

    #[test]
    fn ballistic_msd_is_v2_t2() {
        let times = schedule_times(3, 5.0, 0.01, 3.0);
        let traj = ballistic(500, [40.0, 40.0], &times, 9);
        let f = &traj.frames[0];
        let v2: f64 =
            f.vx.iter()
                .zip(&f.vy)
                .map(|(a, b)| a * a + b * b)
                .sum::<f64>()
                / 500.0;
        let b = compute(
            &traj,
            &Params {
                lags: Some(vec![0.01, 3.0]),
                ..Default::default()
            },
        )
        .unwrap();
        for ((t, s), m) in col(&b, "t")
            .iter()
            .zip(col(&b, "species"))
            .zip(col(&b, "msd"))
        {
            if s < 0.0 {
                assert!(
                    (m / (v2 * t * t) - 1.0).abs() < 1e-9,
                    "t = {t}: {m} vs {}",
                    v2 * t * t
                );
            }
        }
    }
}
