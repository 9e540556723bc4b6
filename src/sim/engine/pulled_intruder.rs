//! The intruder in the event loop (paper I, Eqs. 3-4): one particle pulled
//! along +x by a constant force F. Its path is not straight in any clock, so
//! every pair involving it is timed by the root finder of
//! [`crate::sim::intruder`]; bath-bath pairs keep the straight-line scan.
//!
//! - The intruder's `Disk` holds its position and its velocity in clock units
//!   (u = v / lambda, like every disk) at its own time `t`; [`Engine::advance`]
//!   moves it along the exact path, and adds the work of F and its exact
//!   friction loss to the ledgers.
//! - Its `te` reads minus infinity, so the bath's pair scan (which skips a
//!   partner whose own event is earlier) never pairs a disk with it; a disk
//!   that lists the intruder calls the root finder instead, with the horizon
//!   cut at the intruder's pending event (Smallenburg's rule, kept here in
//!   `intruder_te`): the intruder re-predicts then and finds the pair itself.
//! - The intruder predicts from its own neighbour list, with the horizon cut
//!   at each disk's pending event. When the root finder gives up, or nothing
//!   happens within the horizon, the event is a re-prediction ([`REPREDICT`]).
//! - Between walls in x, its wall times come from the 1D root finder
//!   ([`Pull::wall_time`]). The wall F presses it on reflects it elastically,
//!   but with friction the bounces shrink without end (their number grows
//!   exponentially in time), so a rebound that would return within
//!   [`WALL_REST_TIME`] is absorbed instead: the intruder rests on the wall
//!   (the wall holds F; its kinetic energy along x goes to the dissipation
//!   ledger, F's share to the wall pressure) until a collision or kick gives
//!   it a velocity along x. The same rule as the collapse guard of pair
//!   collisions, on the wall: the bounce is given up when the next one would
//!   come within a fixed short time.
//! - The same time bounds the intruder's rebounds off a disk it presses on
//!   ([`Engine::lift_rebound`]): without it the rebounds shrink until the
//!   collapse guard makes them elastic at ~1e-11 and the pair collides every
//!   ~1e-10 time units, so the run stops advancing. A rebound the force would
//!   bring back within [`WALL_REST_TIME`] leaves at the speed that returns
//!   then; the energy this adds is booked in `Stats::lifted`.

use super::Engine;
use super::parts::NO_INTRUDER;
use crate::sim::events::disk::{Disk, REPREDICT, SHELL, WALL};
use crate::sim::events::pair_scan::nearest_image;
use crate::sim::model::intruder_path::{Pull, Root};
use crate::sim::model::walls;

/// A rebound off the wall F presses on that would return within this time
/// (2 v / (F/m0)) leaves the intruder resting on the wall.
pub const WALL_REST_TIME: f64 = 1e-3;

/// The intruder's prediction horizon, in shells of motion at its speed bound:
/// long enough that it usually leaves its shell first, short enough that
/// the root finder's speed bound stays tight.
const HORIZON_SHELLS: f64 = 4.0;

impl Engine {
    /// Particle `i` is the intruder: kept first when disks are renumbered.
    pub fn set_intruder(&mut self, i: usize) {
        self.state.pulling.intruder = i;
    }

    /// The intruder's index, if there is one.
    pub fn intruder(&self) -> Option<usize> {
        (self.state.pulling.intruder != NO_INTRUDER).then_some(self.state.pulling.intruder)
    }

    /// Left at rest after the compression with its mass `mass` (it was held
    /// in place by a huge one).
    pub fn release_intruder(&mut self, mass: f64) {
        let k = self.state.pulling.intruder;
        self.advance(k);
        self.state.masses[self.state.species[k] as usize] = mass;
        let d = &mut self.state.d[k];
        (d.vx, d.vy) = (0.0, 0.0);
        d.count = d.count.wrapping_add(1);
        self.reschedule_all();
    }

    /// The pulled intruder rests on the x wall (it touches it and has no
    /// velocity along x): then the wall holds F.
    pub fn intruder_resting(&self) -> bool {
        self.state.pulling.resting && self.state.d[self.state.pulling.pulled].vx == 0.0
    }

    /// The intruder's motion law now: no acceleration while it rests on the wall.
    #[inline]
    fn path(&self) -> Pull {
        if self.intruder_resting() {
            Pull {
                gamma: self.state.pulling.pull.gamma,
                accel: 0.0,
            }
        } else {
            self.state.pulling.pull
        }
    }

    /// A rebound `u` (clock units) off the x wall F presses on: kept, or 0
    /// with the intruder resting when it would return within [`WALL_REST_TIME`].
    pub(super) fn settle_on_wall(&mut self, i: usize, u: f64) -> f64 {
        let v = u.abs() * self.lambda();
        if i != self.state.pulling.pulled
            || 2.0 * v >= self.state.pulling.pull.accel * WALL_REST_TIME
        {
            return u;
        }
        self.state.pulling.resting = true;
        self.state.stats.dissipated += 0.5 * self.mass(i) * v * v;
        0.0
    }

    /// The separation speed (clock units) after the pulled intruder hits a
    /// disk, from `s` (its rebound, -e g): the force presses the pair back
    /// together at the rate a = -(F/m0) n_x (n the unit vector from the disk
    /// to the intruder, `nx` its x part from the first of the pair, the
    /// intruder when `first`), so a rebound that would return within
    /// [`WALL_REST_TIME`] (2 s / a) is lifted to s = a WALL_REST_TIME / 2:
    /// the pair then meets at most once per WALL_REST_TIME under the force.
    #[inline]
    pub(super) fn lift_rebound(&self, first: bool, nx: f64, s: f64) -> f64 {
        let a = (if first { -nx } else { nx }) * self.state.pulling.pull.accel;
        let lam = self.lambda();
        if a > 0.0 && 2.0 * s * lam < a * WALL_REST_TIME {
            0.5 * a * WALL_REST_TIME / lam
        } else {
            s
        }
    }

    /// Pull the intruder with force `force` along +x from now on (0: a
    /// passive disk). Needs the neighbour lists (radii fixed, 5 x 5 cells).
    pub fn set_force(&mut self, force: f64) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.state.pulling.intruder != NO_INTRUDER,
            "no intruder to pull"
        );
        anyhow::ensure!(
            force.is_finite() && force >= 0.0,
            "intruder force {force} is invalid: F must be finite and >= 0"
        );
        anyhow::ensure!(
            force == 0.0
                || (!self.derived.lists.nb.is_empty()
                    && self.state.growth == 0.0
                    && self.scale() == 1.0),
            "the pulled intruder needs neighbour lists: radii fixed (compression over) and a box of 5 x 5 cells of {:.3}; use more disks",
            2.0 * self.derived.rmax
        );
        self.sync_all();
        self.state.pulling.force = force;
        self.state.pulling.resting = false;
        self.state.pulling.pulled = if force > 0.0 {
            self.state.pulling.intruder
        } else {
            NO_INTRUDER
        };
        self.state.pulling.pull = Pull {
            gamma: self.state.clock.gamma,
            accel: force / self.mass(self.state.pulling.intruder),
        };
        self.reschedule_all();
        Ok(())
    }

    /// The force on the intruder.
    pub fn force(&self) -> f64 {
        self.state.pulling.force
    }

    /// Real time from clock reading `s0` to `s1` (the inverse of Eq. 9 between two readings).
    #[inline]
    fn real_interval(&self, s0: f64, s1: f64) -> f64 {
        let g = self.state.clock.gamma;
        if g == 0.0 {
            return s1 - s0;
        }
        let x = g * (s1 - s0) / self.state.clock.lambda(s0);
        if x >= 1.0 {
            f64::INFINITY
        } else {
            -(-x).ln_1p() / g
        }
    }

    /// Clock interval from now to real time `tau` later (Eq. 8's factor).
    #[inline]
    fn clock_interval(&self, tau: f64) -> f64 {
        self.lambda() * self.state.pulling.pull.e(tau)
    }

    /// The pulled intruder's position (in the frame of its stored one) and
    /// real velocity now, without moving it.
    fn intruder_now(&self) -> ([f64; 2], [f64; 2]) {
        let d = &self.state.d[self.state.pulling.pulled];
        let lam0 = self.state.clock.lambda(d.t);
        let tau = self.real_interval(d.t, self.state.now);
        let v0 = [d.vx * lam0, d.vy * lam0];
        let p = self.path();
        let dx = p.displacement(v0, tau);
        ([d.x + dx[0], d.y + dx[1]], p.velocity(v0, tau))
    }

    /// Move the pulled intruder to now along its exact path; the work of F
    /// and the friction it suffered go to the ledgers.
    pub(super) fn advance_pulled(&mut self) {
        let k = self.state.pulling.pulled;
        let d = self.state.d[k];
        if d.t == self.state.now {
            return;
        }
        let (lam0, lam1) = (self.state.clock.lambda(d.t), self.lambda());
        let tau = self.real_interval(d.t, self.state.now);
        let ([x, y], v) = self.intruder_now();
        let m = self.mass(k);
        self.state.stats.work += self.state.pulling.force * (x - d.x);
        if self.intruder_resting() {
            // The wall holds F meanwhile.
            self.state.stats.wall_impulse[0] += self.state.pulling.force * tau;
            self.state.stats.wall_virial += x * self.state.pulling.force * tau;
        }
        let u1 = [v[0] / lam1, v[1] / lam1];
        if self.state.clock.gamma > 0.0 {
            // The kinetic energy in u holds the intruder's at its last update,
            // and the friction ledger charged it as if u had stayed constant:
            // replace that charge by the exact friction loss.
            self.account_friction();
            let u0sq = d.vx * d.vx + d.vy * d.vy;
            let charged = 0.5 * m * u0sq * (lam0 * lam0 - lam1 * lam1);
            self.state.stats.friction +=
                self.intruder_friction(m, [d.vx * lam0, d.vy * lam0], tau) - charged;
            self.state.ke_u += 0.5 * m * (u1[0] * u1[0] + u1[1] * u1[1] - u0sq);
        }
        let dm = &mut self.state.d[k];
        (dm.x, dm.y, dm.vx, dm.vy, dm.t) = (x, y, u1[0], u1[1], self.state.now);
    }

    /// The energy friction -gamma m v takes from the intruder over tau from
    /// velocity v0: gamma m times the integral of |v|^2, with
    /// v_x = V + (v0_x - V) exp(-gamma t), V = F / (gamma m), v_y = v0_y exp(-gamma t).
    fn intruder_friction(&self, m: f64, v0: [f64; 2], tau: f64) -> f64 {
        let g = self.state.clock.gamma;
        let vt = self.path().accel / g;
        let c = v0[0] - vt;
        let e1 = self.state.pulling.pull.e(tau);
        let e2 = Pull {
            gamma: 2.0 * g,
            accel: 0.0,
        }
        .e(tau);
        g * m * (vt * vt * tau + 2.0 * vt * c * e1 + (c * c + v0[1] * v0[1]) * e2)
    }

    /// The pulled intruder's next event (it is at the current time): its shell
    /// exit, a contact with a listed disk, a wall in y, or a re-prediction.
    /// Sets its partner and returns the event's clock reading.
    pub(super) fn find_pulled_event(&mut self, i: usize) -> f64 {
        let a = self.state.d[i];
        let lam = self.lambda();
        let v = [a.vx * lam, a.vy * lam];
        if self.state.pulling.resting && a.vx != 0.0 {
            // A collision or kick moved it off the wall: the force acts again.
            self.state.pulling.resting = false;
        }
        let p = self.path();
        // Horizon: the bound |v| + |F/m0| h allows HORIZON_SHELLS shells of
        // motion. (Not cut at the clock's re-anchoring: an event past it
        // re-anchors the clock, which predicts everything anew.)
        let (wn, acc, reach) = (
            v[0].hypot(v[1]),
            p.accel.abs(),
            HORIZON_SHELLS * self.derived.lists.shell,
        );
        let h = 2.0 * reach / (wn + (wn * wn + 4.0 * acc * reach).sqrt());
        let centre = [a.x - self.derived.bk[i].ox, a.y - self.derived.bk[i].oy];
        let (root, steps) = p.exit_time(centre, v, self.derived.lists.shell, h);
        self.state.stats.root_calls += 1;
        self.state.stats.root_steps += u64::from(steps);
        let (mut best, mut partner) = match root {
            Root::At(t) => (t, SHELL),
            Root::Never => (h, REPREDICT),
            Root::GaveUp(t) => (t, REPREDICT),
        };
        let base = i * self.state.list_capacity;
        for k in 0..self.derived.bk[i].nn as usize {
            let j = self.derived.lists.nb[base + k] as usize;
            let b = self.state.d[j];
            // Skip beyond j's own event: j predicts anew then and finds the intruder.
            let hj = best.min(self.real_interval(self.state.now, b.te));
            if hj <= 0.0 {
                continue;
            }
            let dt = self.state.now - b.t;
            let sep = [
                nearest_image(a.x - (b.x + b.vx * dt), self.derived.lx),
                nearest_image(a.y - (b.y + b.vy * dt), self.derived.ly),
            ];
            let w = [v[0] - b.vx * lam, v[1] - b.vy * lam];
            let (root, steps) = p.contact_time(sep, w, a.radius + b.radius, hj);
            self.state.stats.root_calls += 1;
            self.state.stats.root_steps += u64::from(steps);
            match root {
                Root::At(t) if t < best => (best, partner) = (t, j as u32),
                Root::GaveUp(t) if t < best => (best, partner) = (t, REPREDICT),
                _ => {}
            }
        }
        let lx = self.derived.wall_len[0];
        if lx.is_finite() {
            let (root, steps) = p.wall_time(a.x, v[0], a.radius, lx - a.radius, best);
            self.state.stats.root_calls += 1;
            self.state.stats.root_steps += u64::from(steps);
            match root {
                Root::At(t) if t < best => (best, partner) = (t, WALL),
                Root::GaveUp(t) if t < best => (best, partner) = (t, REPREDICT),
                _ => {}
            }
        }
        let mut ds = self.clock_interval(best);
        // Across y the intruder moves as any disk: straight in the clock.
        let l = self.derived.wall_len[1];
        if l.is_finite() {
            let (t, _) = walls::wall_time(a.y, a.vy, a.radius, 1.0, 0.0, l);
            if t < ds {
                (ds, partner) = (t, WALL + 1);
            }
        }
        self.set_partner(i, partner);
        self.state.now + ds
    }

    /// Replace the event (`best`, from now, and `partner`) of disk `a` (which
    /// lists the pulled intruder) by its contact with the intruder if that
    /// comes first and before the intruder's own event.
    pub(super) fn earlier_intruder(&mut self, a: &Disk, best: &mut f64, partner: &mut u32) {
        let k = self.state.pulling.pulled;
        let s_h = (self.state.now + *best).min(self.state.pulling.intruder_te);
        if s_h <= self.state.now {
            return;
        }
        let h = self.real_interval(self.state.now, s_h);
        let (pos, v) = self.intruder_now();
        let lam = self.lambda();
        let sep = [
            nearest_image(pos[0] - a.x, self.derived.lx),
            nearest_image(pos[1] - a.y, self.derived.ly),
        ];
        let w = [v[0] - a.vx * lam, v[1] - a.vy * lam];
        let (root, steps) = self
            .path()
            .contact_time(sep, w, a.radius + self.state.d[k].radius, h);
        self.state.stats.root_calls += 1;
        self.state.stats.root_steps += u64::from(steps);
        match root {
            Root::At(t) => (*best, *partner) = (self.clock_interval(t), k as u32),
            Root::GaveUp(t) => (*best, *partner) = (self.clock_interval(t), REPREDICT),
            Root::Never => {}
        }
    }
}
