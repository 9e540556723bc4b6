//! What the engine reports without changing it: the time, velocities and
//! unwrapped positions, kinetic energies and temperatures per species, momenta
//! (with the single kicks' share of paper I's Eq. (11)), its memory, and the
//! worst overlap of two disks (the exactness checks).

use super::Engine;
use super::parts::{Book, Stats};
use crate::sim::events::disk::Disk;
use crate::sim::events::pair_scan::nearest_image;

impl Engine {
    /// Bytes held by the engine's arrays (the per-particle memory cost).
    pub fn bytes(&self) -> usize {
        let n = self.n();
        // Disk (64) + Book (32) + prev, cell (u32) + imx, imy (i32) + last_collision
        // (f64) + species (u8); per cell, head and occupancy (u32).
        n * (std::mem::size_of::<Disk>() + std::mem::size_of::<Book>() + 2 * 4 + 2 * 4 + 8 + 1)
            + self.derived.lists.nb.len() * 4
            + self.derived.head.len() * 8
            + self.derived.calendar.bytes()
    }

    /// Velocities [vx, vy] of every particle.
    pub fn velocities(&self) -> (Vec<f64>, Vec<f64>) {
        let lam = self.lambda();
        (
            self.state.d.iter().map(|d| d.vx * lam).collect(),
            self.state.d.iter().map(|d| d.vy * lam).collect(),
        )
    }

    /// Total kinetic energy.
    pub fn kinetic_energy(&self) -> f64 {
        let lam = self.lambda();
        (0..self.n())
            .map(|i| self.kinetic_energy_of(i))
            .sum::<f64>()
            * (lam * lam)
    }

    /// Kinetic energy per particle of each species.
    pub fn temperature_by_species(&self) -> Vec<f64> {
        let lam = self.lambda();
        let mut sum = vec![0.0; self.state.masses.len()];
        let mut count = vec![0usize; self.state.masses.len()];
        for i in 0..self.n() {
            sum[self.state.species[i] as usize] += self.kinetic_energy_of(i);
            count[self.state.species[i] as usize] += 1;
        }
        sum.iter()
            .zip(&count)
            .map(|(s, &c)| s * (lam * lam) / c.max(1) as f64)
            .collect()
    }

    /// The current time.
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Counters of everything the loop did, and the energy and virial ledgers.
    pub fn stats(&self) -> &Stats {
        &self.state.stats
    }

    /// Species of each particle, and the radius and mass of each species.
    pub fn species(&self) -> &[u8] {
        &self.state.species
    }
    pub fn radii(&self) -> &[f64] {
        &self.state.radii
    }
    pub fn masses(&self) -> &[f64] {
        &self.state.masses
    }

    /// Normal restitution, and the collapse guard's time (see [`Self::set_restitution`]).
    pub fn eps(&self) -> f64 {
        self.state.eps
    }
    pub fn tc(&self) -> f64 {
        self.state.tc
    }

    /// Kinetic energy of particle `i`.
    pub fn particle_kinetic_energy(&self, i: usize) -> f64 {
        let lam = self.lambda();
        self.kinetic_energy_of(i) * (lam * lam)
    }

    /// Unwrapped position and velocity of particle `i` now.
    pub fn particle(&self, i: usize) -> ([f64; 2], [f64; 2]) {
        let (d, lam) = (&self.state.d[i], self.lambda());
        let dt = self.state.now - d.t;
        (
            [
                d.x + d.vx * dt + self.state.imx[i] as f64 * self.derived.lx,
                d.y + d.vy * dt + self.state.imy[i] as f64 * self.derived.ly,
            ],
            [d.vx * lam, d.vy * lam],
        )
    }

    /// Total momentum.
    pub fn momentum(&self) -> [f64; 2] {
        let lam = self.lambda();
        let p = (0..self.n()).fold([0.0; 2], |p, i| {
            let (m, d) = (self.mass(i), &self.state.d[i]);
            [p[0] + m * d.vx, p[1] + m * d.vy]
        });
        [p[0] * lam, p[1] * lam]
    }

    /// The momentum single kicks brought, each decayed by friction since:
    /// sum over kicks of dp_k exp(-gamma (t - t_k)) (the kicks' part of Eq. (11)
    /// of paper I; pair kicks bring none).
    pub fn kick_momentum(&self) -> [f64; 2] {
        let lam = self.lambda();
        self.state.kick_momentum_u.map(|p| p * lam)
    }

    /// Total mass.
    pub fn total_mass(&self) -> f64 {
        (0..self.n()).map(|i| self.mass(i)).sum()
    }

    /// Sum of |m v|, the scale against which momentum conservation is judged.
    pub fn momentum_scale(&self) -> f64 {
        (0..self.n())
            .map(|i| self.mass(i) * self.state.d[i].vx.hypot(self.state.d[i].vy))
            .sum::<f64>()
            * self.lambda()
    }

    /// Unwrapped positions at the current time (does not move the particles).
    pub fn unwrapped_positions(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.n();
        let mut ux = Vec::with_capacity(n);
        let mut uy = Vec::with_capacity(n);
        for (i, d) in self.state.d.iter().enumerate() {
            let dt = self.state.now - d.t;
            ux.push(d.x + d.vx * dt + self.state.imx[i] as f64 * self.derived.lx);
            uy.push(d.y + d.vy * dt + self.state.imy[i] as f64 * self.derived.ly);
        }
        (ux, uy)
    }

    /// The largest overlap (sigma_ij - r_ij)/sigma_ij among all pairs at the
    /// current time, with the pair, if any pair overlaps by more than `tol`.
    pub fn worst_overlap(&self, tol: f64) -> Option<(usize, usize, f64)> {
        let (ux, uy) = self.unwrapped_positions();
        let scale = self.scale();
        let mut worst: Option<(usize, usize, f64)> = None;
        for i in 0..self.n() {
            let c = self.derived.cell[i] as usize;
            // With lists, cells hold list centres, up to `shell` from the disks.
            let reach = if self.derived.lists.on { 2 } else { 1 };
            self.for_neighbour_cells(
                c % self.derived.ncx,
                c / self.derived.ncx,
                reach,
                |e, j, _, _| {
                    if j <= i {
                        return;
                    }
                    let dx = nearest_image(ux[i] - ux[j], e.derived.lx);
                    let dy = nearest_image(uy[i] - uy[j], e.derived.ly);
                    let sig = (e.state.d[i].radius + e.state.d[j].radius) * scale;
                    let ov = (sig - (dx * dx + dy * dy).sqrt()) / sig;
                    if ov > tol && worst.is_none_or(|w| ov > w.2) {
                        worst = Some((i, j, ov));
                    }
                },
            );
        }
        worst
    }
}
