//! Sub-boxes B_r of a chosen mean particle number N (paper H, Eq. 5): square boxes of
//! side l = sqrt(N / rho) centred on a regular grid, never overlapping. Particles are
//! assigned by their position at the time origin t0, folded into the periodic box.

use anyhow::{Result, bail};

use super::fold;
use crate::traj::Trajectory;

/// The sub-box tiling for one mean particle number.
#[derive(Clone, Debug, PartialEq)]
pub struct SubBoxes {
    /// Requested mean number of particles per sub-box, N = rho l^2.
    pub n_mean: f64,
    /// Side l of each sub-box.
    pub side: f64,
    /// Number of sub-boxes along x and y.
    pub count: [usize; 2],
    pitch: [f64; 2],
    box_size: [f64; 2],
    periodic: [bool; 2],
}

impl SubBoxes {
    /// Sub-boxes holding `n_mean` particles on average (the whole box if `n_mean`
    /// equals the particle number). Errors if `n_mean` is not in (0, N_total].
    pub fn new(traj: &Trajectory, n_mean: f64) -> Result<Self> {
        let n_tot = traj.n() as f64;
        if !(n_mean.is_finite() && n_mean > 0.0 && n_mean <= n_tot * (1.0 + 1e-12)) {
            bail!(
                "sub-box particle number N = {n_mean} must be in (0, {n_tot}] (the number of \
                 particles in the trajectory)"
            );
        }
        let [lx, ly] = traj.box_size;
        let rho = n_tot / (lx * ly);
        let side = (n_mean / rho).sqrt();
        if side > lx.min(ly) * (1.0 + 1e-12) {
            bail!(
                "sub-box of N = {n_mean} particles has side {side:.4}, larger than the short \
                 side {:.4} of the box",
                lx.min(ly)
            );
        }
        let count = [
            ((lx / side) * (1.0 + 1e-12)).floor().max(1.0) as usize,
            ((ly / side) * (1.0 + 1e-12)).floor().max(1.0) as usize,
        ];
        Ok(Self {
            n_mean,
            side: side.min(lx).min(ly),
            count,
            pitch: [lx / count[0] as f64, ly / count[1] as f64],
            box_size: traj.box_size,
            periodic: traj.periodic,
        })
    }

    /// Number of sub-boxes.
    pub fn len(&self) -> usize {
        self.count[0] * self.count[1]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index of the sub-box holding (x, y) (unwrapped), or None if it lies between boxes.
    #[inline]
    pub fn locate(&self, x: f64, y: f64) -> Option<usize> {
        self.locate_within(x, y).map(|(b, _)| b)
    }

    /// As [`Self::locate`], with the position relative to the sub-box's lower-left
    /// corner (in [0, l) per axis): the coordinates of Eq. 16 within B_r.
    #[inline]
    pub fn locate_within(&self, x: f64, y: f64) -> Option<(usize, [f64; 2])> {
        let half = 0.5 * self.side;
        let mut idx = [0usize; 2];
        let mut rel = [0.0; 2];
        for (d, v) in [x, y].into_iter().enumerate() {
            let f = fold(v, self.box_size[d], self.periodic[d]);
            let c = ((f / self.pitch[d]).floor().max(0.0) as usize).min(self.count[d] - 1);
            let centre = (c as f64 + 0.5) * self.pitch[d];
            // Half-open [centre - l/2, centre + l/2) so touching boxes never share a particle.
            if !(f >= centre - half && f < centre + half) {
                return None;
            }
            idx[d] = c;
            rel[d] = f - (centre - half);
        }
        Some((idx[1] * self.count[0] + idx[0], rel))
    }

    /// For one frame pair: (sum over sub-boxes of Q_r, of Q_r^2, number of sub-boxes,
    /// (sum of Q_r)^2 / number of sub-boxes), with Q_r = (number of slow particles in
    /// B_r at t0) / N. The last is the frame's squared sub-box mean times its boxes:
    /// what the per-origin variance of chi4 subtracts.
    pub fn overlap_moments(&self, x0: &[f64], y0: &[f64], slow: &[bool]) -> [f64; 4] {
        let mut slow_count = vec![0u32; self.len()];
        for ((x, y), s) in x0.iter().zip(y0).zip(slow) {
            if *s && let Some(b) = self.locate(*x, *y) {
                slow_count[b] += 1;
            }
        }
        let (mut s1, mut s2) = (0.0, 0.0);
        for c in slow_count {
            let q = c as f64 / self.n_mean;
            s1 += q;
            s2 += q * q;
        }
        let b = self.len() as f64;
        [s1, s2, b, s1 * s1 / b]
    }
}
