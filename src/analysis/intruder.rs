//! Intruder observables (paper I): stationary velocity along the pulling force (x),
//! the intruder path x(t), v(t), mobility from the linear regime, and the momentum
//! profile Px(x) averaged across the channel.

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::check_trajectory;
use super::stats::Estimate;
use crate::table::f64_batch;
use crate::traj::{Frame, Trajectory};

fn default_species() -> u8 {
    2
}

fn default_blocks() -> usize {
    10
}

/// Parameters of the stationary intruder velocity.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VelocityParams {
    /// Species of the intruder.
    #[serde(default = "default_species")]
    pub species: u8,
    /// Frames before this time (transient) are discarded.
    #[serde(default)]
    pub t_start: f64,
    /// Number of equal time blocks for the error estimate.
    #[serde(default = "default_blocks")]
    pub blocks: usize,
}

fn intruders(traj: &Trajectory, species: u8) -> Result<Vec<usize>> {
    let idx: Vec<usize> = (0..traj.n())
        .filter(|&i| traj.species[i] == species)
        .collect();
    if idx.is_empty() {
        bail!("no intruder: no particle of species {species} in the trajectory");
    }
    Ok(idx)
}

fn mean_of(v: &[f64], idx: &[usize]) -> f64 {
    idx.iter().map(|&i| v[i]).sum::<f64>() / idx.len() as f64
}

/// Block velocities of one trajectory: mean recorded vx over the frames of each block
/// if velocities are recorded, else the x displacement across the block over its duration.
fn block_velocities(traj: &Trajectory, p: &VelocityParams) -> Result<Vec<f64>> {
    check_trajectory(traj)?;
    let idx = intruders(traj, p.species)?;
    let frames: Vec<&Frame> = traj.frames.iter().filter(|f| f.time >= p.t_start).collect();
    if p.blocks == 0 {
        bail!("parameter `blocks` must be at least 1");
    }
    if frames.len() < 2 * p.blocks {
        bail!(
            "{} frames after t_start = {} cannot make {} blocks of at least two frames",
            frames.len(),
            p.t_start,
            p.blocks
        );
    }
    let with_v = frames.iter().all(|f| f.vx.len() == traj.n());
    let (t0, t1) = (frames[0].time, frames[frames.len() - 1].time);
    let mut out = Vec::with_capacity(p.blocks);
    for b in 0..p.blocks {
        let lo = t0 + (t1 - t0) * b as f64 / p.blocks as f64;
        let hi = t0 + (t1 - t0) * (b + 1) as f64 / p.blocks as f64;
        let inb: Vec<&&Frame> = frames
            .iter()
            .filter(|f| f.time >= lo && (f.time < hi || (b + 1 == p.blocks && f.time <= hi)))
            .collect();
        if inb.len() < 2 {
            bail!("time block [{lo}, {hi}) holds fewer than two frames: use fewer blocks");
        }
        let v = if with_v {
            inb.iter().map(|f| mean_of(&f.vx, &idx)).sum::<f64>() / inb.len() as f64
        } else {
            let (fa, fb) = (inb[0], inb[inb.len() - 1]);
            (mean_of(&fb.x, &idx) - mean_of(&fa.x, &idx)) / (fb.time - fa.time)
        };
        out.push(v);
    }
    Ok(out)
}

/// Stationary velocity along x: mean over time blocks of every replica, with the
/// standard error of the block means.
pub fn stationary_velocity(trajs: &[&Trajectory], p: &VelocityParams) -> Result<Estimate> {
    let mut v = Vec::new();
    for t in trajs {
        v.extend(block_velocities(t, p)?);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    Ok(Estimate {
        value: m,
        err: if v.len() > 1 {
            (var / n).sqrt()
        } else {
            f64::NAN
        },
    })
}

/// Table `v, v_err, n_blocks` from the time blocks of every replica.
pub fn velocity_table(trajs: &[&Trajectory], p: &VelocityParams) -> Result<RecordBatch> {
    let e = stationary_velocity(trajs, p)?;
    f64_batch(&[
        ("v", vec![e.value]),
        ("v_err", vec![e.err]),
        ("n_blocks", vec![(p.blocks * trajs.len()) as f64]),
    ])
}

/// Table `t, x, v` of the intruder path (Fig. 4 inset of paper I): v is the recorded
/// vx, or the x displacement to the next frame over the time step (NaN for the last).
pub fn compute_path(traj: &Trajectory, p: &VelocityParams) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    let idx = intruders(traj, p.species)?;
    let fr = &traj.frames;
    let x: Vec<f64> = fr.iter().map(|f| mean_of(&f.x, &idx)).collect();
    let v: Vec<f64> = (0..fr.len())
        .map(|k| {
            if fr[k].vx.len() == traj.n() {
                mean_of(&fr[k].vx, &idx)
            } else if k + 1 < fr.len() {
                (x[k + 1] - x[k]) / (fr[k + 1].time - fr[k].time)
            } else {
                f64::NAN
            }
        })
        .collect();
    f64_batch(&[("t", traj.times()), ("x", x), ("v", v)])
}

/// Mobility mu = v / F in the linear regime: weighted least-squares slope through the
/// origin of v(F) over the points with F <= f_max, from (F, v, v_err) triples.
pub fn mobility(points: &[(f64, f64, f64)], f_max: f64) -> Result<Estimate> {
    let lin: Vec<&(f64, f64, f64)> = points
        .iter()
        .filter(|p| p.0 > 0.0 && p.0 <= f_max)
        .collect();
    if lin.is_empty() {
        bail!("no (F, v) point with 0 < F <= f_max = {f_max}: raise f_max");
    }
    if let Some(p) = lin.iter().find(|p| !(p.2 > 0.0 && p.2.is_finite())) {
        bail!(
            "velocity error at F = {} must be finite and > 0, got {}",
            p.0,
            p.2
        );
    }
    let (mut sfv, mut sff) = (0.0, 0.0);
    for (f, v, e) in lin {
        let w = 1.0 / (e * e);
        sfv += w * f * v;
        sff += w * f * f;
    }
    Ok(Estimate {
        value: sfv / sff,
        err: 1.0 / sff.sqrt(),
    })
}

fn default_bins() -> usize {
    50
}

/// Parameters of the momentum profile.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProfileParams {
    /// Times at which to take the profile (the nearest frame to each).
    pub times: Vec<f64>,
    /// Number of bins along x.
    #[serde(default = "default_bins")]
    pub bins: usize,
    /// Species left out of the profile (the intruder); none if absent.
    #[serde(default = "intruder_default")]
    pub exclude_species: Option<u8>,
}

fn intruder_default() -> Option<u8> {
    Some(2)
}

/// Table `t, x, Px`: momentum density along x, Px(x) = sum_i m_i vx_i over the bin
/// divided by its area (bin width x Ly), i.e. averaged across the channel.
pub fn compute_profile(traj: &Trajectory, p: &ProfileParams) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    if p.bins == 0 {
        bail!("parameter `bins` must be at least 1");
    }
    if p.times.is_empty() {
        bail!("parameter `times` is empty: give at least one time");
    }
    let [lx, ly] = traj.box_size;
    let dx = lx / p.bins as f64;
    let mut cols: [Vec<f64>; 3] = Default::default();
    for &t in &p.times {
        let f = traj
            .frames
            .iter()
            .min_by(|a, b| (a.time - t).abs().total_cmp(&(b.time - t).abs()))
            .expect("checked non-empty");
        if f.vx.len() != traj.n() {
            bail!(
                "the frame at t = {} has no velocities: record velocities to get Px(x)",
                f.time
            );
        }
        let mut px = vec![0.0; p.bins];
        for i in 0..traj.n() {
            let s = traj.species[i];
            if p.exclude_species == Some(s) {
                continue;
            }
            let x = super::fold(f.x[i], lx, traj.periodic[0]);
            let b = ((x / dx).floor().max(0.0) as usize).min(p.bins - 1);
            px[b] += traj.masses[s as usize] * f.vx[i];
        }
        for (b, v) in px.into_iter().enumerate() {
            cols[0].push(f.time);
            cols[1].push((b as f64 + 0.5) * dx);
            cols[2].push(v / (dx * ly));
        }
    }
    let [t, x, px] = cols;
    f64_batch(&[("t", t), ("x", x), ("Px", px)])
}
