//! Partial radial distribution functions g_ab(r) and the position of their first
//! minimum, the nearest-neighbour cut-off r_ab^min of the cluster analysis (paper H,
//! Sec. 3.3).

use std::f64::consts::PI;

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::{check_trajectory, ensure_positive, neighbours};
use crate::table::f64_batch;
use crate::traj::Trajectory;

fn default_r_max() -> f64 {
    6.0
}

fn default_bin() -> f64 {
    0.02
}

fn default_max_frames() -> usize {
    10
}

/// Parameters of g_ab(r).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Largest r (units r1).
    #[serde(default = "default_r_max")]
    pub r_max: f64,
    /// Bin width in r.
    #[serde(default = "default_bin")]
    pub bin: f64,
    /// At most this many frames, evenly spread over the trajectory, are averaged.
    #[serde(default = "default_max_frames")]
    pub max_frames: usize,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            r_max: default_r_max(),
            bin: default_bin(),
            max_frames: default_max_frames(),
        }
    }
}

/// g_ab(r) for one species pair a <= b.
#[derive(Clone, Debug, PartialEq)]
pub struct Partial {
    pub a: u8,
    pub b: u8,
    /// Bin centres.
    pub r: Vec<f64>,
    pub g: Vec<f64>,
    /// First minimum after the main peak (NaN if none within r_max).
    pub r_min: f64,
}

/// Every partial g_ab(r), a <= b over the species present.
pub fn partials(traj: &Trajectory, p: &Params) -> Result<Vec<Partial>> {
    check_trajectory(traj)?;
    ensure_positive("r_max", p.r_max)?;
    ensure_positive("bin", p.bin)?;
    if p.max_frames == 0 {
        bail!("parameter `max_frames` must be at least 1");
    }
    if traj.periodic != [true, true] {
        bail!(
            "g_ab(r) is normalised for a box periodic in x and y (got periodic = {:?})",
            traj.periodic
        );
    }
    let ns = traj.species.iter().copied().max().unwrap_or(0) as usize + 1;
    let nb = (p.r_max / p.bin).ceil() as usize;
    let bin = p.r_max / nb as f64;
    let nf = traj.frames.len();
    let take = p.max_frames.min(nf);
    let frames: Vec<usize> = (0..take).map(|k| k * nf / take).collect();
    let mut hist = vec![vec![0u64; nb]; ns * ns];
    for &fi in &frames {
        let f = &traj.frames[fi];
        neighbours::for_each_pair(
            &f.x,
            &f.y,
            traj.box_size,
            traj.periodic,
            p.r_max,
            |i, j, dx, dy| {
                let (a, b) = (traj.species[i] as usize, traj.species[j] as usize);
                let k = ((dx * dx + dy * dy).sqrt() / bin) as usize;
                if k < nb {
                    hist[a.min(b) * ns + a.max(b)][k] += 1;
                }
            },
        )?;
    }
    let mut count = vec![0f64; ns];
    for &s in &traj.species {
        count[s as usize] += 1.0;
    }
    let area = traj.box_size[0] * traj.box_size[1];
    let mut out = Vec::new();
    for a in 0..ns {
        for b in a..ns {
            if count[a] == 0.0 || count[b] == 0.0 || (a == b && count[a] < 2.0) {
                continue;
            }
            // Unordered pairs expected in an annulus for an ideal gas.
            let pairs = if a == b {
                count[a] * (count[a] - 1.0) / 2.0
            } else {
                count[a] * count[b]
            };
            let r: Vec<f64> = (0..nb).map(|k| (k as f64 + 0.5) * bin).collect();
            let g: Vec<f64> = (0..nb)
                .map(|k| {
                    let shell = PI * (((k + 1) as f64 * bin).powi(2) - (k as f64 * bin).powi(2));
                    hist[a * ns + b][k] as f64 / (frames.len() as f64 * pairs * shell / area)
                })
                .collect();
            let r_min = first_minimum(&r, &g).unwrap_or(f64::NAN);
            out.push(Partial {
                a: a as u8,
                b: b as u8,
                r,
                g,
                r_min,
            });
        }
    }
    Ok(out)
}

/// First minimum of g(r) after its main (highest) peak, on a 5-bin running mean to
/// ride over histogram noise. None if g rises to the end.
pub fn first_minimum(r: &[f64], g: &[f64]) -> Option<f64> {
    let n = g.len();
    let smooth: Vec<f64> = (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(2), (k + 3).min(n));
            g[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect();
    let peak = (0..n).max_by(|&a, &b| smooth[a].total_cmp(&smooth[b]))?;
    (peak + 1..n.saturating_sub(1))
        .find(|&k| smooth[k] <= smooth[k - 1] && smooth[k] < smooth[k + 1])
        .map(|k| r[k])
}

/// Neighbour cut-offs r_ab^min as a species x species matrix (symmetric).
pub fn cutoffs(traj: &Trajectory, p: &Params) -> Result<Vec<Vec<f64>>> {
    let parts = partials(traj, p)?;
    let ns = traj.species.iter().copied().max().unwrap_or(0) as usize + 1;
    let mut m = vec![vec![f64::NAN; ns]; ns];
    for pt in parts {
        if !pt.r_min.is_finite() {
            bail!(
                "g_{}{}(r) has no first minimum below r_max = {}: increase r_max or give \
                 the cluster cut-offs explicitly",
                pt.a,
                pt.b,
                p.r_max
            );
        }
        m[pt.a as usize][pt.b as usize] = pt.r_min;
        m[pt.b as usize][pt.a as usize] = pt.r_min;
    }
    Ok(m)
}

/// Table `a, b, r, g, r_min` (one block of rows per species pair a <= b).
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    let mut cols: [Vec<f64>; 5] = Default::default();
    for pt in partials(traj, p)? {
        let n = pt.r.len();
        cols[0].extend(std::iter::repeat_n(pt.a as f64, n));
        cols[1].extend(std::iter::repeat_n(pt.b as f64, n));
        cols[2].extend(pt.r);
        cols[3].extend(pt.g);
        cols[4].extend(std::iter::repeat_n(pt.r_min, n));
    }
    let [a, b, r, g, rm] = cols;
    f64_batch(&[("a", a), ("b", b), ("r", r), ("g", g), ("r_min", rm)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::independent_slow;

    #[test]
    fn ideal_gas_g_is_one_and_minimum_is_found() {
        let traj = independent_slow(3000, [50.0, 50.0], 5, 0.5, 1.0, 2);
        let parts = partials(
            &traj,
            &Params {
                r_max: 5.0,
                bin: 0.1,
                max_frames: 10,
            },
        )
        .unwrap();
        assert_eq!(parts.len(), 3);
        for p in &parts {
            let mean = p.g[10..].iter().sum::<f64>() / (p.g.len() - 10) as f64;
            assert!((mean - 1.0).abs() < 0.02, "g_{}{} mean {mean}", p.a, p.b);
        }
        // A liquid-like g(r): main peak at 1, first minimum at 1.5 exactly.
        let r: Vec<f64> = (0..400).map(|k| 0.5 + k as f64 * 0.01).collect();
        let g: Vec<f64> = r
            .iter()
            .map(|&x| 1.0 + (-(x - 1.0)).exp() * (2.0 * PI * (x - 1.0)).cos())
            .collect();
        let m = first_minimum(&r, &g).unwrap();
        // d/dr [e^-u cos 2 pi u] = 0 at tan(2 pi u) = -1 / (2 pi): u = 0.5 - atan(1/2pi)/2pi.
        let u = 0.5 - (1.0 / (2.0 * PI)).atan() / (2.0 * PI);
        assert!((m - (1.0 + u)).abs() < 0.011, "{m} vs {}", 1.0 + u);
    }
}
