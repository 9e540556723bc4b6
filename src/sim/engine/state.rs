//! The engine's state: one value holding everything that determines the
//! future of a run. A checkpoint serialises it whole and a resume rebuilds
//! everything else from it ([`super::derived`]), so a field added here is
//! saved without further code.

use serde::{Deserialize, Serialize};

use super::parts::{Driving, Pulling, Stats, Train};
use crate::sim::events::disk::Disk;
use crate::sim::model::friction::Clock;
use rand_chacha::ChaCha8Rng;

/// Everything a run needs to go on: particles, clock, model parameters,
/// driving and intruder, random numbers, ledgers.
#[derive(Clone, Serialize, Deserialize)]
pub struct EngineState {
    /// The physical box and its walls (the engine pads walled axes itself).
    pub(super) box_size: [f64; 2],
    pub(super) walls: [bool; 2],
    pub(super) species: Vec<u8>,
    /// Radius of each species (final radius if the radii grow).
    pub(super) radii: Vec<f64>,
    pub(super) masses: Vec<f64>,
    /// Positions (wrapped, up to a shell outside the box with lists),
    /// velocities in clock units, the time they refer to and the
    /// velocity-change counters. A disk's radius, pending event time and cell
    /// link are not saved: they are rebuilt.
    pub(super) d: Vec<Disk>,
    /// Periodic images crossed, to unwrap positions.
    pub(super) imx: Vec<i32>,
    pub(super) imy: Vec<i32>,
    /// Time of each particle's last collision (the collapse guard).
    pub(super) last_collision: Vec<f64>,
    /// Neighbour-list capacity per disk: it only grows during a run, and its
    /// growth rebuilds every list.
    pub(super) list_capacity: usize,
    /// Current clock reading: the time without friction, the friction clock s
    /// with it (velocities are then u = v / lambda, see [`crate::sim::model::friction`]).
    pub(super) now: f64,
    /// Current time (`clock.t(now)`, exact at the stop times of
    /// [`super::Engine::run_until`]).
    pub(super) time: f64,
    pub(super) clock: Clock,
    /// With friction: the kinetic energy in u (sum of m u^2 / 2) and lambda^2
    /// when friction was last accounted for (the friction ledger).
    pub(super) ke_u: f64,
    pub(super) lam2: f64,
    /// Momentum brought by single kicks, each decayed by friction since
    /// (sum dp_k exp(-gamma (t - t_k))), in u units (divided by lambda).
    pub(super) kick_momentum_u: [f64; 2],
    /// Normal restitution.
    pub(super) eps: f64,
    /// Collapse guard: a collision within `tc` of a particle's previous one is elastic.
    pub(super) tc: f64,
    /// Radii are `radii * (scale0 + growth * (t - scale_t0))`.
    pub(super) scale0: f64,
    pub(super) scale_t0: f64,
    pub(super) growth: f64,
    /// The driving's state: its kicks, their rate and amplitude, the next one.
    pub(super) drive: Driving,
    /// Clock reading of the next kick of either train: the driving's
    /// (`next_drive`) or the force's (`train.next`).
    pub(super) next_kick: f64,
    /// The force on the intruder as a train of momentum kicks (off: never).
    pub(super) train: Train,
    /// The intruder's state (paper I).
    pub(super) pulling: Pulling,
    pub(super) rng: ChaCha8Rng,
    pub(super) stats: Stats,
}

impl EngineState {
    /// Number of particles.
    pub fn n(&self) -> usize {
        self.species.len()
    }

    /// Simulation time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The state's bytes (postcard): what a checkpoint stores, and what two
    /// runs that must agree bit for bit are compared by.
    pub fn to_bytes(&self) -> anyhow::Result<Vec<u8>> {
        Ok(postcard::to_stdvec(self)?)
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
