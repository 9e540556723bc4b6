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
