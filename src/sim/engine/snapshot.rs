//! The engine at a checkpoint: every particle synchronised, the time origin
//! moved to the checkpoint, the state written out ([`EngineState`]) and the
//! event calendar and neighbour lists rebuilt from it. A run restored from the
//! state ([`Engine::restore`]) rebuilds them the same way, so it continues bit
//! for bit like a run that passed the checkpoint without stopping.
//!
//! What is rebuilt rather than saved: cells, neighbour lists, pending events
//! and the calendar. Their rebuild reads nothing of the history: pending event
//! times are forgotten first (the pair scan skips partners by them) and the
//! calendar starts new (its heap's capacity counts in [`Engine::bytes`]).

use serde::{Deserialize, Serialize};

use super::{Engine, Setup, Stats, parts};
use crate::sim::big_vec::big_vec;
use crate::sim::events::calendar::EventCalendar;
use crate::sim::events::disk::NONE;
use crate::sim::model::friction::Clock;
use rand_chacha::ChaCha8Rng;

/// Everything a run needs to go on from a checkpoint.
#[derive(Clone, Serialize, Deserialize)]
pub struct EngineState {
    /// The physical box and its walls (the engine pads walled axes itself).
    box_size: [f64; 2],
    walls: [bool; 2],
    radii: Vec<f64>,
    masses: Vec<f64>,
    species: Vec<u8>,
    /// Positions (as the engine holds them: wrapped, up to a shell outside the
    /// box with lists), velocities in clock units, all at clock reading 0.
    x: Vec<f64>,
    y: Vec<f64>,
    vx: Vec<f64>,
    vy: Vec<f64>,
    /// Velocity-change counters (stale-event checks compare them).
    count: Vec<u32>,
    imx: Vec<i32>,
    imy: Vec<i32>,
    last_collision: Vec<f64>,
    /// Neighbour-list capacity: it only grows during a run, and its growth
    /// rebuilds every list.
    list_capacity: usize,
    time: f64,
    clock: Clock,
    ke_u: f64,
    lam2: f64,
    kick_momentum_u: [f64; 2],
    eps: f64,
    tc: f64,
    scale0: f64,
    scale_t0: f64,
    growth: f64,
    drive: parts::Driving,
    next_kick: f64,
    train: parts::Train,
    pulling: parts::Pulling,
    rng: ChaCha8Rng,
    stats: Stats,
}

impl EngineState {
    /// Number of particles.
    pub fn n(&self) -> usize {
        self.species.len()
    }

    /// Simulation time of the checkpoint.
    pub fn time(&self) -> f64 {
        self.time
    }
}

#[cfg(test)]
impl EngineState {
    /// The same state `by` later in time (a run at a late time, for tests).
    pub(crate) fn shift_time(&mut self, by: f64) {
        self.time += by;
        self.clock.t0 += by;
        for t in &mut self.last_collision {
            *t += by;
        }
    }
}

impl Engine {
    /// Synchronise every particle, move the time origin here (clock reading 0
    /// at the current time, positions and event times relative to it) and
    /// predict every event anew from the synchronised state alone. With
    /// `save`, also return that state. Call it at a stop time of
    /// [`Engine::run_until`] (where the time is exact).
    pub fn checkpoint(&mut self, save: bool) -> Option<EngineState> {
        self.move_origin(self.clock.gamma, self.time);
        self.forget_events();
        let state = save.then(|| self.state());
        self.calendar = EventCalendar::new(self.n());
        self.reschedule_all();
        state
    }

    /// The engine of a checkpoint, ready to go on from it.
    pub fn restore(s: EngineState) -> anyhow::Result<Engine> {
        let n = s.n();
        anyhow::ensure!(
            [&s.x, &s.y, &s.vx, &s.vy, &s.last_collision]
                .iter()
                .all(|v| v.len() == n)
                && [&s.imx, &s.imy].iter().all(|v| v.len() == n)
                && s.count.len() == n,
            "checkpoint: particle arrays of different lengths"
        );
        anyhow::ensure!(
            s.species.iter().all(|&k| (k as usize) < s.radii.len()),
            "checkpoint: a species without a radius"
        );
        let setup = Setup {
            lx: s.box_size[0],
            ly: s.box_size[1],
            walls: s.walls,
            radii: s.radii.clone(),
            masses: s.masses.clone(),
            species: s.species.clone(),
            x: s.x.clone(),
            y: s.y.clone(),
            vx: s.vx.clone(),
            vy: s.vy.clone(),
        };
        let mut e = Engine::new(setup, s.eps, s.tc, s.rng.clone())?;
        for (i, d) in e.d.iter_mut().enumerate() {
            (d.x, d.y, d.vx, d.vy, d.t, d.count) =
                (s.x[i], s.y[i], s.vx[i], s.vy[i], 0.0, s.count[i]);
        }
        e.imx = s.imx;
        e.imy = s.imy;
        e.last_collision = s.last_collision;
        if !e.lists.nb.is_empty() {
            e.lists.cap = s.list_capacity;
            e.lists.nb = big_vec(n * s.list_capacity, NONE);
        }
        e.now = 0.0;
        e.time = s.time;
        e.clock = s.clock;
        e.ke_u = s.ke_u;
        e.lam2 = s.lam2;
        e.kick_momentum_u = s.kick_momentum_u;
        e.scale0 = s.scale0;
        e.scale_t0 = s.scale_t0;
        e.growth = s.growth;
        e.drive = s.drive;
        e.next_kick = s.next_kick;
        e.train = s.train;
        e.pulling = s.pulling;
        e.stats = s.stats;
        e.forget_events();
        e.calendar = EventCalendar::new(n);
        e.reschedule_all();
        Ok(e)
    }

    /// Every pending event unknown, as before the first prediction (the
    /// pulled intruder's reads minus infinity: the bath's scan never pairs
    /// with it).
    fn forget_events(&mut self) {
        for d in &mut self.d {
            d.te = f64::INFINITY;
        }
        self.pulling.intruder_te = f64::INFINITY;
        if self.pulling.pulled != parts::NO_INTRUDER {
            self.d[self.pulling.pulled].te = f64::NEG_INFINITY;
        }
    }

    /// The synchronised state (after [`Self::move_origin`]).
    fn state(&self) -> EngineState {
        let physical = |k: usize| {
            if self.wall_len[k].is_finite() {
                self.wall_len[k]
            } else {
                [self.lx, self.ly][k]
            }
        };
        EngineState {
            box_size: [physical(0), physical(1)],
            walls: self.wall_len.map(|l| l.is_finite()),
            radii: self.radii.clone(),
            masses: self.masses.clone(),
            species: self.species.clone(),
            x: self.d.iter().map(|d| d.x).collect(),
            y: self.d.iter().map(|d| d.y).collect(),
            vx: self.d.iter().map(|d| d.vx).collect(),
            vy: self.d.iter().map(|d| d.vy).collect(),
            count: self.d.iter().map(|d| d.count).collect(),
            imx: self.imx.clone(),
            imy: self.imy.clone(),
            last_collision: self.last_collision.clone(),
            list_capacity: self.lists.cap,
            time: self.time,
            clock: self.clock,
            ke_u: self.ke_u,
            lam2: self.lam2,
            kick_momentum_u: self.kick_momentum_u,
            eps: self.eps,
            tc: self.tc,
            scale0: self.scale0,
            scale_t0: self.scale_t0,
            growth: self.growth,
            drive: self.drive.clone(),
            next_kick: self.next_kick,
            train: self.train,
            pulling: self.pulling.clone(),
            rng: self.rng.clone(),
            stats: self.stats,
        }
    }
}
