//! Driving: when the next kick comes, which particles it moves, and the
//! momentum it gives them (the amplitude rule is in [`crate::sim::kicks`]).

use super::Engine;
use super::parts::KICKS_AHEAD;
use crate::sim::model::kicks::Kicks;
use rand::RngExt;
use rand_distr::{Distribution, Exp, StandardNormal};

impl Engine {
    /// Start (or stop) driving: `rate` kicks per unit time in the whole
    /// system, each of momentum `p_dr` times a unit 2D Gaussian vector.
    pub fn set_kicks(&mut self, kicks: Kicks, rate: f64, p_dr: f64) {
        self.state.drive.kicks = kicks;
        self.state.drive.kick_rate = rate;
        self.state.drive.p_dr = p_dr;
        self.schedule_kick();
    }

    /// Draw the time of the next kick and the first disk of the kick
    /// [`KICKS_AHEAD`] kicks after it, and move the fetching of the disks in
    /// between one stage on.
    pub(super) fn schedule_kick(&mut self) {
        let wait = self.kick_wait();
        // Kicks come at a constant rate in time, not in the friction clock.
        self.state.drive.next_drive = if self.state.clock.gamma == 0.0 {
            self.state.now + wait
        } else {
            self.state
                .clock
                .s(self.state.clock.t(self.state.now) + wait)
        };
        self.state.next_kick = self.state.drive.next_drive.min(self.state.train.next);
        if self.state.drive.next_drive < f64::INFINITY {
            let n = self.n();
            let rng = &mut self.state.rng;
            let ring = self
                .state
                .drive
                .kick_ring
                .get_or_insert_with(|| std::array::from_fn(|_| rng.random_range(0..n) as u32));
            let pos = self.state.drive.kick_pos;
            self.state.drive.kick_next = ring[pos] as usize;
            ring[pos] = self.state.rng.random_range(0..n) as u32;
            self.state.drive.kick_pos = (pos + 1) % KICKS_AHEAD;
            self.prefetch_kicks();
        }
    }

    pub fn kick_rate(&self) -> f64 {
        self.state.drive.kick_rate
    }

    fn kick_wait(&mut self) -> f64 {
        if self.state.drive.kicks == Kicks::Off || self.state.drive.kick_rate <= 0.0 {
            return f64::INFINITY;
        }
        Exp::new(self.state.drive.kick_rate)
            .expect("kick rate is positive and finite")
            .sample(&mut self.state.rng)
    }

    /// A kick: one particle (Eq. 2 of paper I) or a pair with equal and
    /// opposite Gaussian momenta (Eq. 4 of paper H). With friction the
    /// velocities are u = v / lambda, so a momentum p changes u by p / (m lambda).
    /// `PLAIN`: [`Self::plain`] holds.
    pub(super) fn kick<const PLAIN: bool>(&mut self) {
        let n = self.n();
        let i = self.state.drive.kick_next;
        let lam = self.lambda();
        if self.state.drive.kicks == Kicks::Single {
            self.advance(i);
            let kx: f64 = StandardNormal.sample(&mut self.state.rng);
            let ky: f64 = StandardNormal.sample(&mut self.state.rng);
            let before = self.kinetic_energy_of(i);
            let m = self.mass(i) * lam;
            let d = &mut self.state.d[i];
            d.vx += self.state.drive.p_dr * kx / m;
            d.vy += self.state.drive.p_dr * ky / m;
            d.count = d.count.wrapping_add(1);
            self.state.kick_momentum_u[0] += self.state.drive.p_dr * kx / lam;
            self.state.kick_momentum_u[1] += self.state.drive.p_dr * ky / lam;
            self.account_injection(self.kinetic_energy_of(i) - before, lam);
            self.predict(i);
            return;
        }
        let j = match self.state.drive.kicks {
            Kicks::NeighbourPairs => self.random_neighbour(i),
            _ => None,
        }
        .unwrap_or_else(|| {
            let k = self.state.rng.random_range(0..n - 1);
            if k >= i { k + 1 } else { k }
        });
        self.advance_in::<PLAIN>(i);
        self.advance_in::<PLAIN>(j);
        let kx: f64 = StandardNormal.sample(&mut self.state.rng);
        let ky: f64 = StandardNormal.sample(&mut self.state.rng);
        let (px, py) = (self.state.drive.p_dr * kx, self.state.drive.p_dr * ky);
        let before = self.kinetic_energy_of(i) + self.kinetic_energy_of(j);
        for (k, s) in [(i, 1.0), (j, -1.0)] {
            let m = self.mass(k) * lam;
            let d = &mut self.state.d[k];
            d.vx += s * px / m;
            d.vy += s * py / m;
            d.count = d.count.wrapping_add(1);
        }
        self.account_injection(
            self.kinetic_energy_of(i) + self.kinetic_energy_of(j) - before,
            lam,
        );
        self.prefetch_around(j);
        self.predict_in::<PLAIN>(i);
        self.predict_in::<PLAIN>(j);
    }

    /// Count a kick that changed the kinetic energy in u by `du` at `lam`.
    #[inline]
    fn account_injection(&mut self, du: f64, lam: f64) {
        if self.state.clock.gamma > 0.0 {
            self.account_friction();
            self.state.ke_u += du;
        }
        self.state.stats.injected += du * (lam * lam);
        self.state.stats.kicks += 1;
    }

    /// A uniformly chosen other particle from the 3x3 cells around `i`, if any
    /// (with lists, cells hold list centres, within `shell` of the disks). The
    /// cell occupancies give the total and the cell of the chosen disk, so only
    /// that cell is walked. (Partners from the neighbour list instead, i.e. disks
    /// in contact, were tried: kicked contact pairs collide at once and dissipate
    /// more, and the balanced rate left T at 0.94 at phi = 0.7.)
    fn random_neighbour(&mut self, i: usize) -> Option<usize> {
        let c = self.derived.cell[i] as usize;
        let cells = self.neighbour_cells(c);
        // `i` itself is in its own cell and never chosen.
        let total = cells
            .iter()
            .map(|&k| self.derived.occupancy[k] as usize)
            .sum::<usize>()
            - 1;
        if total == 0 {
            return None;
        }
        let mut k = self.state.rng.random_range(0..total);
        for cell in cells {
            let m = self.derived.occupancy[cell] as usize - usize::from(cell == c);
            if k >= m {
                k -= m;
                continue;
            }
            let mut j = self.derived.head[cell];
            loop {
                if j as usize != i {
                    if k == 0 {
                        return Some(j as usize);
                    }
                    k -= 1;
                }
                j = self.state.d[j as usize].next;
            }
        }
        unreachable!("the draw is below the number of neighbours")
    }
}
