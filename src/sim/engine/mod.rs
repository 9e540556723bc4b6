//! The event loop: hard disks moving ballistically between collisions, cell
//! crossings and pair kicks.
//!
//! Design (after Smallenburg's EDMD): one pending event per particle in an O(1)
//! calendar queue ([`EventCalendar`]), invalidated by per-particle collision counters
//! (an event with partner `j` is stale once `j` has changed velocity); a cell list
//! with doubly linked cells; lazy positions (each particle stores the time its
//! position refers to); structure-of-arrays storage; nothing is allocated inside
//! the loop. Radii may grow linearly in time (Lubachevsky-Stillinger compression).
//!
//! Once radii are fixed, collisions are predicted from neighbour lists with a
//! shell (Smallenburg): disk `i` stays within `shell` of its list centre `o_i`, and
//! its list holds every `j` with `|o_i - o_j| < sigma_ij + 2 shell`, so a pair can
//! only touch while it is in both lists. Leaving the shell is an event that
//! rebuilds that one disk's list (from the cell list). The cell list stays for
//! the rebuilds and for choosing kick partners.
//!
//! The engine is two values: its state ([`state::EngineState`], everything that
//! determines the run's future, serialised whole at a checkpoint) and what is
//! derived from it (cells, neighbour lists, pending events and their calendar,
//! prefetch state), rebuilt from the state alone. One `impl Engine` per
//! mechanism, one file each:
//!
//! - this file: the event loop (events in order, collisions, cell crossings,
//!   predictions, the cell list, velocity and radius scaling, friction clock);
//! - `parts.rs`: the constants and data types the state and the derived part
//!   are made of (counters, per-disk bookkeeping, the drive's, the force's,
//!   the lists', the pipeline's and the intruder's state), below the engine;
//! - `state.rs`: the state; `derived.rs`: what is rebuilt from it;
//!   `setup.rs`: a new engine from a [`Setup`], and how the derived part is
//!   rebuilt from a state (`Engine::from_state`); `snapshot.rs`: checkpoints
//!   and resuming from one;
//! - `neighbour_lists.rs`: the lists and their shell; `driving.rs`: the kicks
//!   of the drive; `force_kicks.rs`: the force on the intruder as kicks;
//!   `pulled_intruder.rs`: the intruder's curved path, walls and rebounds;
//!   `prefetch_pipeline.rs`: memory hints; `observables.rs`: what the engine
//!   reports (time, velocities, energies, parameters) without changing it.

mod derived;
mod driving;
mod force_kicks;
mod neighbour_lists;
mod observables;
mod parts;
mod prefetch_pipeline;
mod pulled_intruder;
mod setup;
mod snapshot;
pub mod state;

pub use parts::Stats;
pub use setup::Setup;

use parts::NO_INTRUDER;

use crate::sim::events::disk::{CROSS, Disk, NONE, REPREDICT, SHELL, WALL};
use crate::sim::events::pair_scan::{earliest_pair, nearest_image};
use crate::sim::model::friction::Clock;
pub use crate::sim::model::kicks::Kicks;
use crate::sim::model::restitution;
use crate::sim::model::walls;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The event-driven engine: its state (one value, everything that determines
/// the run's future: what a checkpoint saves) and what is derived from it
/// (rebuilt from the state alone at a resume).
pub struct Engine {
    state: state::EngineState,
    derived: derived::Derived,
}

impl Engine {
    pub fn n(&self) -> usize {
        self.state.species.len()
    }

    fn rebuild_cells(&mut self) {
        self.derived.head.fill(NONE);
        self.derived.occupancy.fill(0);
        for i in 0..self.n() {
            let c = self.cell_of(self.state.d[i].x, self.state.d[i].y);
            self.insert(i, c);
        }
    }

    /// Renumber the particles in cell order, so that neighbours sit close in
    /// memory. Changes particle identities: call before anything is recorded.
    pub fn sort_by_cell(&mut self) {
        self.sync_all();
        let mut order: Vec<u32> = (0..self.n() as u32).collect();
        if self.state.pulling.intruder == NO_INTRUDER {
            order.sort_by_key(|&i| self.derived.cell[i as usize]);
        } else {
            // The intruder keeps its index (the first).
            order.sort_by_key(|&i| {
                (
                    i as usize != self.state.pulling.intruder,
                    self.derived.cell[i as usize],
                )
            });
            assert_eq!(
                self.state.pulling.intruder, 0,
                "the intruder is placed first"
            );
        }
        // In place, array by array: a copy of the disks would be the peak memory
        // of a 4 x 10^6 disk run.
        let mut done = vec![false; self.n()];
        permute(&mut self.state.d, &order, &mut done);
        permute(&mut self.state.imx, &order, &mut done);
        permute(&mut self.state.imy, &order, &mut done);
        permute(&mut self.state.species, &order, &mut done);
        permute(&mut self.state.last_collision, &order, &mut done);
        self.reschedule_all();
    }

    /// Collide with normal restitution `eps` from now on, elastically within
    /// `tc` of a particle's previous collision (the collapse guard). Pending
    /// events stay valid: they do not depend on either.
    pub fn set_restitution(&mut self, eps: f64, tc: f64) {
        self.state.eps = eps;
        self.state.tc = tc;
    }

    /// Let the radii grow: contact distance sigma_ij (scale0 + rate (t - now)).
    pub fn set_growth(&mut self, scale0: f64, rate: f64) {
        self.sync_all();
        self.state.scale0 = scale0;
        self.state.scale_t0 = self.state.now;
        self.state.growth = rate;
        self.reschedule_all();
    }

    /// Current radius scale factor (1 once compression is over).
    pub fn scale(&self) -> f64 {
        self.state.scale0 + self.state.growth * (self.state.now - self.state.scale_t0)
    }

    /// Multiply every velocity by `f` (e.g. to restore T = 1 during compression).
    pub fn scale_velocities(&mut self, f: f64) {
        self.sync_all();
        self.account_friction();
        self.state.ke_u *= f * f;
        for d in &mut self.state.d {
            d.vx *= f;
            d.vy *= f;
        }
        self.reschedule_all();
    }

    /// lambda = v / u now (1 without friction).
    #[inline]
    pub(super) fn lambda(&self) -> f64 {
        self.state.clock.lambda(self.state.now)
    }

    /// Switch viscous friction -gamma m v on (or off, gamma = 0) from now on:
    /// anchors the friction clock here.
    pub fn set_friction(&mut self, gamma: f64) {
        self.anchor(gamma);
    }

    /// Anchor the clock at the current time with friction rate `gamma`: s = 0
    /// and u = v now (Eqs. 8-9 of paper I restart from here). Every event is
    /// predicted anew.
    fn anchor(&mut self, gamma: f64) {
        let t = self.state.clock.t(self.state.now);
        self.move_origin(gamma, t);
        self.reschedule_all();
    }

    /// [`Self::anchor`] without predicting the events: every particle brought
    /// to now, which becomes clock reading 0 at time `t` (the current time),
    /// with friction rate `gamma` from here.
    fn move_origin(&mut self, gamma: f64, t: f64) {
        self.sync_all();
        self.account_friction();
        let lam = self.lambda();
        let t_kick = self.state.clock.t(self.state.drive.next_drive);
        for d in &mut self.state.d {
            d.vx *= lam;
            d.vy *= lam;
            d.t = 0.0;
        }
        self.state.kick_momentum_u = self.state.kick_momentum_u.map(|p| p * lam);
        self.state.clock = Clock { gamma, t0: t };
        self.state.pulling.pull.gamma = gamma;
        self.state.now = 0.0;
        self.state.time = t;
        self.state.drive.next_drive = self.state.clock.s(t_kick);
        self.state.train.next = self.state.train.reading(&self.state.clock);
        self.state.next_kick = self.state.drive.next_drive.min(self.state.train.next);
        self.state.ke_u = (0..self.n()).map(|i| self.kinetic_energy_of(i)).sum();
        self.state.lam2 = 1.0;
    }

    /// Add the energy friction removed since the last call (the kinetic energy
    /// in u is constant between events, so the loss is ke_u (lambda_a^2 - lambda_b^2)).
    #[inline]
    pub(super) fn account_friction(&mut self) {
        if self.state.clock.gamma > 0.0 {
            let l = self.lambda();
            let l2 = l * l;
            self.state.stats.friction += self.state.ke_u * (self.state.lam2 - l2);
            self.state.lam2 = l2;
        }
    }

    #[inline]
    fn mass(&self, i: usize) -> f64 {
        self.state.masses[self.state.species[i] as usize]
    }

    #[inline]
    fn kinetic_energy_of(&self, i: usize) -> f64 {
        let d = &self.state.d[i];
        0.5 * self.mass(i) * (d.vx * d.vx + d.vy * d.vy)
    }

    /// Process events until the next one would be later than `t_stop` (then the
    /// clock is set to `t_stop`) or `max_events` were processed. True if `t_stop`
    /// was reached.
    pub fn run_until(&mut self, t_stop: f64, max_events: u64) -> bool {
        self.derived.pipeline.on =
            self.derived.lists.on && self.bytes() > self.derived.pipeline.min_bytes;
        if self.plain() {
            self.run_events::<true>(t_stop, max_events)
        } else {
            self.run_events::<false>(t_stop, max_events)
        }
    }

    /// Paper H's model: no pulled intruder, no walls, no friction. The event
    /// loop then runs without the per-event checks for them (paper I's
    /// additions stay off paper H's hot path); the answers are the same bits
    /// either way.
    #[inline]
    fn plain(&self) -> bool {
        self.state.pulling.pulled == NO_INTRUDER
            && !self.derived.has_walls
            && self.state.clock.gamma == 0.0
    }

    /// [`Self::run_until`]'s loop; `PLAIN`: [`Self::plain`] holds.
    #[inline(never)]
    fn run_events<const PLAIN: bool>(&mut self, t_stop: f64, max_events: u64) -> bool {
        let mut s_stop = self.state.clock.s(t_stop);
        let s_max = self.state.clock.s_max();
        for _ in 0..max_events {
            let (i, te) = self.derived.calendar.min();
            if !PLAIN && te.min(self.state.next_kick).min(s_stop) > s_max {
                // Friction: nothing happens before lambda = 1/8; re-anchor there.
                self.state.now = s_max;
                self.anchor(self.state.clock.gamma);
                self.state.stats.reanchors += 1;
                s_stop = self.state.clock.s(t_stop);
                continue;
            }
            if self.state.next_kick <= te {
                if self.state.next_kick > s_stop {
                    self.stop_at(s_stop, t_stop);
                    return true;
                }
                self.state.now = self.state.next_kick;
                if self.state.next_kick == self.state.train.next {
                    self.force_kick();
                } else {
                    self.kick::<PLAIN>();
                    self.schedule_kick();
                }
                continue;
            }
            if te > s_stop {
                self.stop_at(s_stop, t_stop);
                return true;
            }
            self.state.now = te;
            if self.derived.pipeline.on {
                self.look_ahead();
            }
            let p = self.derived.bk[i].ev_p;
            if p == SHELL {
                self.shell_exit(i);
            } else if !PLAIN && p >= WALL {
                if p == REPREDICT {
                    self.state.stats.repredicts += 1;
                    self.advance(i);
                    self.predict(i);
                } else {
                    self.hit_wall(i, (p - WALL) as usize);
                }
            } else if p >= CROSS {
                self.cross(i, p - CROSS);
            } else if self.state.d[p as usize].count != self.derived.bk[i].ev_c {
                self.state.stats.stale_events += 1;
                self.advance_in::<PLAIN>(i);
                self.predict_in::<PLAIN>(i);
            } else {
                self.collide::<PLAIN>(i, p as usize);
            }
        }
        self.state.time = self.state.clock.t(self.state.now);
        self.sync_pulled();
        self.account_friction();
        false
    }

    /// Move the clock on to `t` without processing events: only to absorb the
    /// round-off between stop times that should coincide.
    pub fn skip_to(&mut self, t: f64) {
        self.stop_at(self.state.clock.s(t), t);
    }

    /// Set the clock to `s` at time `t` (the same reading) with nothing happening between.
    #[inline]
    fn stop_at(&mut self, s: f64, t: f64) {
        self.state.now = s;
        self.state.time = t;
        self.sync_pulled();
        self.account_friction();
    }

    /// Bring the pulled intruder to now (its state and the work and friction
    /// ledgers are then current for the readers).
    #[inline]
    fn sync_pulled(&mut self) {
        if self.state.pulling.pulled != NO_INTRUDER {
            self.advance_pulled();
        }
    }

    #[inline]
    fn advance(&mut self, i: usize) {
        self.advance_in::<false>(i)
    }

    /// Bring disk `i` to now; `PLAIN`: there is no pulled intruder.
    #[inline]
    fn advance_in<const PLAIN: bool>(&mut self, i: usize) {
        if !PLAIN && i == self.state.pulling.pulled {
            self.advance_pulled();
            return;
        }
        let now = self.state.now;
        let d = &mut self.state.d[i];
        let dt = now - d.t;
        d.x += d.vx * dt;
        d.y += d.vy * dt;
        d.t = now;
    }

    fn sync_all(&mut self) {
        for i in 0..self.n() {
            self.advance(i);
        }
    }

    /// Bring disk `i`'s position into [0, L) and count the images crossed (with
    /// lists, positions run up to `shell` outside the box between list rebuilds).
    fn wrap_into_box(&mut self, i: usize) {
        let d = &mut self.state.d[i];
        let (kx, ky) = (
            (d.x / self.derived.lx).floor(),
            (d.y / self.derived.ly).floor(),
        );
        if kx != 0.0 || ky != 0.0 {
            d.x -= kx * self.derived.lx;
            d.y -= ky * self.derived.ly;
            // Round-off can leave x == L after subtracting: that is cell ncx - 1.
            self.state.imx[i] += kx as i32;
            self.state.imy[i] += ky as i32;
        }
    }

    /// Predict every event anew (after all velocities or radii changed).
    fn reschedule_all(&mut self) {
        self.sync_all();
        for d in &mut self.state.d {
            d.count = d.count.wrapping_add(1);
        }
        for i in 0..self.n() {
            self.wrap_into_box(i);
        }
        self.rebuild_cells();
        self.derived.lists.on =
            !self.derived.lists.nb.is_empty() && self.state.growth == 0.0 && self.scale() == 1.0;
        if self.derived.lists.on {
            self.build_all_lists();
        }
        for i in 0..self.n() {
            let t = self.find_event(i);
            self.set_te(i, t);
            self.derived.calendar.set_lazy(i, t);
        }
        self.derived.calendar.rebuild();
    }

    fn cell_of(&self, x: f64, y: f64) -> usize {
        let cx = ((x / self.derived.wx) as usize).min(self.derived.ncx - 1);
        let cy = ((y / self.derived.wy) as usize).min(self.derived.ncy - 1);
        cy * self.derived.ncx + cx
    }

    fn insert(&mut self, i: usize, c: usize) {
        let h = self.derived.head[c];
        self.state.d[i].next = h;
        self.derived.prev[i] = NONE;
        if h != NONE {
            self.derived.prev[h as usize] = i as u32;
        }
        self.derived.head[c] = i as u32;
        self.derived.cell[i] = c as u32;
        self.derived.occupancy[c] += 1;
    }

    fn remove(&mut self, i: usize) {
        let (p, nx) = (self.derived.prev[i], self.state.d[i].next);
        self.derived.occupancy[self.derived.cell[i] as usize] -= 1;
        if p != NONE {
            self.state.d[p as usize].next = nx;
        } else {
            self.derived.head[self.derived.cell[i] as usize] = nx;
        }
        if nx != NONE {
            self.derived.prev[nx as usize] = p;
        }
    }

    /// Neighbouring cell `c + d` (|d| <= nc) along one axis with its periodic shift.
    #[inline]
    fn wrap(c: usize, d: isize, nc: usize, l: f64) -> (usize, f64) {
        let k = c as isize + d;
        if k < 0 {
            ((k + nc as isize) as usize, -l)
        } else if k as usize >= nc {
            (k as usize - nc, l)
        } else {
            (k as usize, 0.0)
        }
    }

    /// Time from now until disks `a` (at the current time) and `b` (shifted by a
    /// periodic image) touch, or infinity. Solves |dr + dv s| = sigma (scale +
    /// growth s): the same quadratic serves fixed and growing radii.
    #[inline]
    fn pair_time(&self, a: &Disk, b: &Disk, sx: f64, sy: f64, scale: f64) -> f64 {
        let dtj = self.state.now - b.t;
        let dvx = b.vx - a.vx;
        let dvy = b.vy - a.vy;
        let dx = b.x + b.vx * dtj + sx - a.x;
        let dy = b.y + b.vy * dtj + sy - a.y;
        let sig = a.radius + b.radius;
        let g = sig * self.state.growth;
        let s = sig * scale;
        let bb = dx * dvx + dy * dvy - s * g;
        let aa = dvx * dvx + dvy * dvy - g * g;
        if bb >= 0.0 && aa >= 0.0 {
            return f64::INFINITY;
        }
        let c = dx * dx + dy * dy - s * s;
        if c <= 0.0 {
            // Touching within round-off: collide now if approaching.
            return if bb < 0.0 { 0.0 } else { f64::INFINITY };
        }
        let disc = bb * bb - aa * c;
        if disc < 0.0 {
            return f64::INFINITY;
        }
        let den = -bb + disc.sqrt();
        if den <= 0.0 { f64::INFINITY } else { c / den }
    }

    /// Earliest event of `i` (which must be at the current time): sets its partner
    /// and returns its time, without updating the calendar.
    fn find_event(&mut self, i: usize) -> f64 {
        self.find_event_in::<false>(i)
    }

    /// [`Self::find_event`]; `PLAIN`: [`Self::plain`] holds.
    #[inline]
    fn find_event_in<const PLAIN: bool>(&mut self, i: usize) -> f64 {
        if self.derived.lists.on {
            return self.find_event_listed::<PLAIN>(i);
        }
        let a = self.state.d[i];
        let c = self.derived.cell[i] as usize;
        let (cx, cy) = (c % self.derived.ncx, c / self.derived.ncx);
        // Cell crossing.
        let tx = exit_time(a.x, a.vx, cx, self.derived.wx);
        let ty = exit_time(a.y, a.vy, cy, self.derived.wy);
        let (mut best, mut partner) = if tx < ty {
            (tx, CROSS + if a.vx > 0.0 { 0 } else { 1 })
        } else {
            (ty, CROSS + if a.vy > 0.0 { 2 } else { 3 })
        };
        best = best.max(0.0);
        let scale = self.scale();
        self.for_neighbour_cells(cx, cy, 1, |e, j, sx, sy| {
            if j != i {
                let b = &e.state.d[j];
                let tt = e.pair_time(&a, b, sx, sy, scale);
                // Skip j if it has an earlier event: it will rescan then (every
                // event ends in a prediction) and find i itself (Smallenburg's
                // rule; spares the stale event this one would become).
                if tt < best && e.state.now + tt <= b.te {
                    best = tt;
                    partner = j as u32;
                }
            }
        });
        if !PLAIN && self.derived.has_walls {
            self.earlier_wall(&a, scale, &mut best, &mut partner);
        }
        self.set_partner(i, partner);
        self.state.now + best
    }

    /// Replace the event (`best`, `partner`) of disk `a` by a wall collision if
    /// that comes first.
    #[inline]
    fn earlier_wall(&self, a: &Disk, scale: f64, best: &mut f64, partner: &mut u32) {
        for (k, (x, v)) in [(a.x, a.vx), (a.y, a.vy)].into_iter().enumerate() {
            let l = self.derived.wall_len[k];
            if l.is_finite() {
                let (t, _) = walls::wall_time(x, v, a.radius, scale, self.state.growth, l);
                if t < *best {
                    *best = t;
                    *partner = WALL + k as u32;
                }
            }
        }
    }

    /// Disk `i` hits a wall of `axis`: elastic reflection (in the frame of its
    /// growing surface during compression), the momentum given to the wall
    /// counted for the wall pressure.
    fn hit_wall(&mut self, i: usize, axis: usize) {
        self.advance(i);
        let (m, lam, d) = (self.mass(i), self.lambda(), self.state.d[i]);
        let (pos, old) = if axis == 0 { (d.x, d.vx) } else { (d.y, d.vy) };
        let upper = pos > 0.5 * self.derived.wall_len[axis];
        let mut new = walls::reflect(old, d.radius, self.state.growth, upper);
        if axis == 0 && upper && i == self.state.pulling.pulled {
            new = self.settle_on_wall(i, new);
        }
        let dm = &mut self.state.d[i];
        if axis == 0 {
            dm.vx = new;
        } else {
            dm.vy = new;
        }
        dm.count = dm.count.wrapping_add(1);
        if self.state.clock.gamma > 0.0 {
            self.account_friction();
            self.state.ke_u += 0.5 * m * (new * new - old * old);
        }
        let dp = m * (new - old) * lam;
        self.state.stats.wall_collisions += 1;
        self.state.stats.wall_impulse[axis] += dp.abs();
        self.state.stats.wall_virial += pos * dp;
        self.predict(i);
    }

    /// [`Self::find_event`] from the neighbour list: the shell exit or the
    /// earliest collision with a listed disk.
    #[inline]
    fn find_event_listed<const PLAIN: bool>(&mut self, i: usize) -> f64 {
        if !PLAIN && i == self.state.pulling.pulled {
            return self.find_pulled_event(i);
        }
        let a = self.state.d[i];
        let shell = self.shell_time(i, &a);
        let base = i * self.state.list_capacity;
        let list = &self.derived.lists.nb[base..base + self.derived.bk[i].nn as usize];
        let (mut best, mut partner) = earliest_pair(
            &self.state.d,
            list,
            &a,
            self.state.now,
            self.derived.lx,
            self.derived.ly,
            shell,
        );
        if !PLAIN
            && self.state.pulling.pulled != NO_INTRUDER
            && list.contains(&(self.state.pulling.pulled as u32))
        {
            self.earlier_intruder(&a, &mut best, &mut partner);
        }
        if !PLAIN && self.derived.has_walls {
            self.earlier_wall(&a, 1.0, &mut best, &mut partner);
        }
        self.set_partner(i, partner);
        self.state.now + best
    }

    #[inline]
    fn set_partner(&mut self, i: usize, partner: u32) {
        self.derived.bk[i].ev_p = partner;
        self.derived.bk[i].ev_c = if partner < CROSS {
            self.state.d[partner as usize].count
        } else {
            0
        };
    }

    #[inline]
    fn predict(&mut self, i: usize) {
        self.predict_in::<false>(i)
    }

    /// Predict disk `i`'s next event; `PLAIN`: [`Self::plain`] holds.
    #[inline]
    fn predict_in<const PLAIN: bool>(&mut self, i: usize) {
        let t = self.find_event_in::<PLAIN>(i);
        if PLAIN {
            self.state.d[i].te = t;
        } else {
            self.set_te(i, t);
        }
        self.derived.calendar.update(i, t);
    }

    /// Record disk `i`'s pending event time `t` where its neighbours' scans read it.
    #[inline]
    fn set_te(&mut self, i: usize, t: f64) {
        if i == self.state.pulling.pulled {
            self.state.pulling.intruder_te = t;
            self.state.d[i].te = f64::NEG_INFINITY;
        } else {
            self.state.d[i].te = t;
        }
    }

    fn cross(&mut self, i: usize, dir: u32) {
        self.state.stats.cell_crossings += 1;
        self.advance(i);
        let c = self.derived.cell[i] as usize;
        let (mut cx, mut cy) = (c % self.derived.ncx, c / self.derived.ncx);
        let d = &mut self.state.d[i];
        match dir {
            0 => step_cell(
                &mut cx,
                true,
                self.derived.ncx,
                &mut d.x,
                self.derived.lx,
                &mut self.state.imx[i],
            ),
            1 => step_cell(
                &mut cx,
                false,
                self.derived.ncx,
                &mut d.x,
                self.derived.lx,
                &mut self.state.imx[i],
            ),
            2 => step_cell(
                &mut cy,
                true,
                self.derived.ncy,
                &mut d.y,
                self.derived.ly,
                &mut self.state.imy[i],
            ),
            _ => step_cell(
                &mut cy,
                false,
                self.derived.ncy,
                &mut d.y,
                self.derived.ly,
                &mut self.state.imy[i],
            ),
        }
        self.remove(i);
        self.insert(i, cy * self.derived.ncx + cx);
        self.predict(i);
    }

    /// Eqs. (1)-(3) of paper H: normal restitution eps, or 1 when the collapse
    /// guard acts (or while radii grow, when the collision must also outrun the
    /// growth of the contact distance).
    fn collide<const PLAIN: bool>(&mut self, i: usize, j: usize) {
        self.advance_in::<PLAIN>(i);
        self.advance_in::<PLAIN>(j);
        let (a, b) = (self.state.d[i], self.state.d[j]);
        let (ma, mb) = (self.mass(i), self.mass(j));
        // Minimum image: touching disks are closer than half a box.
        let dx = nearest_image(a.x - b.x, self.derived.lx);
        let dy = nearest_image(a.y - b.y, self.derived.ly);
        let r = (dx * dx + dy * dy).sqrt();
        let (nx, ny) = (dx / r, dy / r);
        let gn = (a.vx - b.vx) * nx + (a.vy - b.vy) * ny;
        let mu = ma * mb / (ma + mb);
        // The guard counts real time (the clock reading without friction).
        let t = self.state.clock.t(self.state.now);
        let (e, guarded) = restitution::coefficient(
            self.state.eps,
            self.state.growth != 0.0,
            t - self.state.last_collision[i],
            t - self.state.last_collision[j],
            self.state.tc,
        );
        self.state.stats.guard_activations += u64::from(guarded);
        // Approach speed of the surfaces (-gn when radii are fixed).
        let g = gn - (a.radius + b.radius) * self.state.growth;
        let mut imp = restitution::normal_impulse(mu, e, g);
        let mut lift = 0.0;
        if !PLAIN && (i == self.state.pulling.pulled || j == self.state.pulling.pulled) {
            // The force may press the pair back together at once: the rebound
            // speed -e g is lifted so that it returns no sooner than WALL_REST_TIME.
            let s = self.lift_rebound(i == self.state.pulling.pulled, nx, -e * g);
            if s != -e * g {
                imp = mu * (g - s);
                lift = 0.5 * mu * (s * s - e * e * g * g);
            }
        }
        let da = &mut self.state.d[i];
        da.vx -= imp / ma * nx;
        da.vy -= imp / ma * ny;
        da.count = da.count.wrapping_add(1);
        let db = &mut self.state.d[j];
        db.vx += imp / mb * nx;
        db.vy += imp / mb * ny;
        db.count = db.count.wrapping_add(1);
        // Velocities are u = v / lambda: energies scale by lambda^2, momenta by lambda.
        let loss = restitution::energy_loss(mu, e, g);
        let lam = self.lambda();
        if !PLAIN && self.state.clock.gamma > 0.0 {
            self.account_friction();
            self.state.ke_u += lift - loss;
        }
        self.state.stats.dissipated += loss * (lam * lam);
        if !PLAIN && lift > 0.0 {
            self.state.stats.lifts += 1;
            self.state.stats.lifted += lift * (lam * lam);
        }
        self.state.stats.virial += -imp * r * lam;
        self.state.stats.collisions += 1;
        self.state.last_collision[i] = t;
        self.state.last_collision[j] = t;
        self.prefetch_around(j);
        self.predict_in::<PLAIN>(i);
        self.predict_in::<PLAIN>(j);
    }

    /// The 3x3 cells around cell `c`, in the order [`Self::for_neighbour_cells`]
    /// visits them.
    fn neighbour_cells(&self, c: usize) -> [usize; 9] {
        let (cx, cy) = (c % self.derived.ncx, c / self.derived.ncx);
        let mut out = [0; 9];
        for (k, o) in out.iter_mut().enumerate() {
            let (ny, _) = Self::wrap(cy, k as isize / 3 - 1, self.derived.ncy, self.derived.ly);
            let (nx, _) = Self::wrap(cx, k as isize % 3 - 1, self.derived.ncx, self.derived.lx);
            *o = ny * self.derived.ncx + nx;
        }
        out
    }

    /// Call `f(self, j, shift_x, shift_y)` for every disk `j` of the cells within
    /// `reach` cells of (cx, cy) (3x3 for reach 1), with the periodic shift that
    /// brings it next to them.
    #[inline]
    fn for_neighbour_cells(
        &self,
        cx: usize,
        cy: usize,
        reach: isize,
        mut f: impl FnMut(&Self, usize, f64, f64),
    ) {
        for dy in -reach..=reach {
            let (ny, sy) = Self::wrap(cy, dy, self.derived.ncy, self.derived.ly);
            for dx in -reach..=reach {
                let (nx, sx) = Self::wrap(cx, dx, self.derived.ncx, self.derived.lx);
                let mut j = self.derived.head[ny * self.derived.ncx + nx];
                while j != NONE {
                    f(self, j as usize, sx, sy);
                    j = self.state.d[j as usize].next;
                }
            }
        }
    }
}

/// Reorder `v` so that `v[k]` becomes the old `v[order[k]]`, following the
/// permutation's cycles (no copy of `v`); `done` is scratch of the same length.
fn permute<T: Copy>(v: &mut [T], order: &[u32], done: &mut [bool]) {
    done.fill(false);
    for start in 0..v.len() {
        if done[start] {
            continue;
        }
        let first = v[start];
        let mut k = start;
        loop {
            done[k] = true;
            let from = order[k] as usize;
            if from == start {
                v[k] = first;
                break;
            }
            v[k] = v[from];
            k = from;
        }
    }
}

/// Time until coordinate `x` moving at `v` leaves cell `c` of width `w`.
#[inline]
fn exit_time(x: f64, v: f64, c: usize, w: f64) -> f64 {
    if v > 0.0 {
        ((c + 1) as f64 * w - x) / v
    } else if v < 0.0 {
        (c as f64 * w - x) / v
    } else {
        f64::INFINITY
    }
}

/// Move cell coordinate `c` one step up or down among `nc` cells; on wrapping
/// round the periodic box of length `l`, shift the coordinate and count the image.
#[inline]
fn step_cell(c: &mut usize, up: bool, nc: usize, x: &mut f64, l: f64, image: &mut i32) {
    if up {
        *c += 1;
        if *c == nc {
            *c = 0;
            *x -= l;
            *image += 1;
        }
    } else if *c == 0 {
        *c = nc - 1;
        *x += l;
        *image -= 1;
    } else {
        *c -= 1;
    }
}

/// A seeded engine RNG (ChaCha8, one stream per simulation).
pub fn rng_from_seed(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

#[cfg(test)]
mod unit {
    use super::permute;

    /// The prefetch pipeline is only a hint: forced on in a small driven system
    /// (where it is off by default), the run is bit-identical to one without.
    #[test]
    fn prefetch_pipeline_changes_nothing() {
        let c = crate::sim::SimConfig {
            n: 2000,
            phi: 0.78,
            eps: 0.9,
            ..Default::default()
        };
        let run = |min_bytes: usize| {
            let mut e = crate::sim::initial_state::prepare(&c, &|_| {}).unwrap();
            let (kicks, rate, p_dr) = crate::sim::run::drive(&c, 15.0);
            e.set_restitution(c.eps, c.collapse_tc);
            e.set_kicks(kicks, rate, p_dr);
            e.derived.pipeline.min_bytes = min_bytes;
            e.run_until(f64::INFINITY, 200_000);
            assert_eq!(e.derived.pipeline.on, min_bytes == 0, "pipeline on/off");
            let ((x, y), (vx, vy)) = (e.unwrapped_positions(), e.velocities());
            let bits: Vec<u64> = [x, y, vx, vy]
                .concat()
                .iter()
                .map(|v| v.to_bits())
                .collect();
            (e.state.stats, bits)
        };
        let (on, off) = (run(0), run(usize::MAX));
        assert!(
            on.0.collisions > 50_000 && on.0.kicks > 50_000,
            "{:?}",
            on.0
        );
        assert_eq!(on.0, off.0);
        assert!(on.1 == off.1, "positions or velocities differ");
    }

    #[test]
    fn permute_in_place_equals_gather() {
        let n = 1000usize;
        // A permutation with cycles of many lengths (multiplication by a unit mod n).
        let order: Vec<u32> = (0..n).map(|k| ((k * 7 + 3) % n) as u32).collect();
        let old: Vec<f64> = (0..n).map(|k| k as f64 * 1.5).collect();
        let want: Vec<f64> = order.iter().map(|&k| old[k as usize]).collect();
        let mut v = old.clone();
        permute(&mut v, &order, &mut vec![false; n]);
        assert_eq!(v, want);
    }
}
