//! Observables computed from stored trajectories (overlap, chi4, S4, MSD, clusters, ...).
//!
//! Every observable has a `Params` struct (serde, `deny_unknown_fields`, validated)
//! and a `compute(traj, params) -> anyhow::Result<RecordBatch>`; column names and
//! units are listed in docs/analysis.md. Typed results (tau_alpha, chi4 peak,
//! g_ab first minima, clusters) are public for other Rust code.
//!
//! Time-origin averaging: at each lag the frame pairs come from
//! [`Trajectory::pairs_at_lag`]; each time origin of each replica is one block,
//! and errors use a jackknife over (replica, origin bin) blocks with bins about
//! tau_alpha long ([`lags::origin_bins`]), since closer origins are correlated.

pub mod cage;
pub mod chi4;
pub mod clusters;
pub mod drive;
pub mod front;
pub mod gr;
pub mod intruder;
pub mod lags;
pub mod msd;
pub mod neighbours;
pub mod observable_params;
pub mod observables;
pub mod order;
pub mod overlap;
pub mod pool;
pub mod run_summary;
pub mod s4;
pub mod stats;
pub mod subbox;
pub mod synthetic;
#[cfg(test)]
pub(crate) mod test_support;
pub mod van_hove;
pub mod window;

use anyhow::{Result, bail};

use crate::traj::{Frame, Trajectory};

/// Default relative tolerance when matching a requested lag to frame time differences.
pub const DEFAULT_REL_TOL: f64 = 1e-6;

pub(crate) fn default_rel_tol() -> f64 {
    DEFAULT_REL_TOL
}

/// The paper's mobility cut-off a = 0.6 r1 (paper H, Eq. 5).
pub(crate) fn default_a() -> f64 {
    0.6
}

/// Fails unless `value` is finite and > 0, naming the parameter.
pub(crate) fn ensure_positive(name: &str, value: f64) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        bail!("parameter `{name}` must be a finite number > 0, got {value}");
    }
    Ok(())
}

/// Fails on an empty trajectory or frames whose arrays disagree with the particle count.
pub(crate) fn check_trajectory(traj: &Trajectory) -> Result<()> {
    let n = traj.n();
    if n == 0 {
        bail!("the trajectory has no particles");
    }
    if traj.frames.is_empty() {
        bail!("the trajectory has no frames");
    }
    for (k, f) in traj.frames.iter().enumerate() {
        if f.x.len() != n || f.y.len() != n {
            bail!(
                "frame {k} (t = {}) has {} x and {} y positions for {n} particles",
                f.time,
                f.x.len(),
                f.y.len()
            );
        }
    }
    if let Some(&s) = traj
        .species
        .iter()
        .find(|&&s| s as usize >= traj.radii.len())
    {
        bail!(
            "species {s} has no radius (the trajectory lists {} radii)",
            traj.radii.len()
        );
    }
    Ok(())
}

/// Squared displacement of every particle between two frames (positions are unwrapped).
pub fn squared_displacements(f0: &Frame, f1: &Frame) -> Vec<f64> {
    f0.x.iter()
        .zip(&f0.y)
        .zip(f1.x.iter().zip(&f1.y))
        .map(|((x0, y0), (x1, y1))| (x1 - x0).powi(2) + (y1 - y0).powi(2))
        .collect()
}

/// The frame of `traj` nearest to time `t`, which must hold velocities
/// (profiles and fields of momentum); `traj` has frames (checked).
pub fn frame_with_velocities(traj: &Trajectory, t: f64) -> Result<&Frame> {
    let f = traj
        .frames
        .iter()
        .min_by(|a, b| (a.time - t).abs().total_cmp(&(b.time - t).abs()))
        .expect("checked non-empty");
    if f.vx.len() != traj.n() {
        bail!(
            "the frame at t = {} has no velocities: set `record_velocities: true` in the experiment",
            f.time
        );
    }
    Ok(f)
}

/// Position folded into the box [0, L) along a periodic axis; unchanged otherwise.
#[inline]
pub fn fold(x: f64, l: f64, periodic: bool) -> f64 {
    if periodic {
        let r = x.rem_euclid(l);
        // rem_euclid can round up to exactly l for tiny negative x.
        if r >= l { 0.0 } else { r }
    } else {
        x
    }
}
