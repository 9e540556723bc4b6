//! The state each part of the engine keeps (the drive, the force's train of
//! kicks, the neighbour lists, the prefetch pipeline, the intruder), below the
//! [`Engine`](super::Engine) that holds it: each part's code (`impl Engine` in
//! its own file) builds on the engine, the engine only on this state.

use crate::sim::model::friction::Clock;
use crate::sim::model::intruder_path::Pull;
use crate::sim::model::kicks::Kicks;

/// First disks of kicks drawn ahead of the pending one: each is fetched from
/// memory in stages over the kicks before it (docs/sim.md, "Prefetch pipeline").
pub(super) const KICKS_AHEAD: usize = 3;

/// The driving's state ([`super::driving`]).
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub(super) struct Driving {
    pub(super) kicks: Kicks,
    /// Pair kicks per unit time, whole system.
    pub(super) kick_rate: f64,
    /// Clock reading of the driving's next kick.
    pub(super) next_drive: f64,
    /// The first disk of the next kick, drawn [`KICKS_AHEAD`] kicks before it so
    /// that its data is fetched from memory while the events before it run.
    pub(super) kick_next: usize,
    /// The first disks of the kicks after `kick_next`: the `m`-th next one
    /// (from 0) is `kick_ring[(kick_pos + m) % KICKS_AHEAD]`; empty (`None`)
    /// until driving starts.
    pub(super) kick_ring: Option<[u32; KICKS_AHEAD]>,
    pub(super) kick_pos: usize,
    /// Kick amplitude p_dr.
    pub(super) p_dr: f64,
}

impl Driving {
    /// No driving.
    pub(super) const OFF: Driving = Driving {
        kicks: Kicks::Off,
        kick_rate: 0.0,
        next_drive: f64::INFINITY,
        kick_next: 0,
        kick_ring: None,
        kick_pos: 0,
        p_dr: 0.0,
    };
}

/// A regular train of force kicks ([`super::force_kicks`]).
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub(super) struct Train {
    /// Real time between kicks (infinity: off).
    pub(super) dt: f64,
    /// Real time the train starts.
    pub(super) t0: f64,
    /// Kicks given so far.
    pub(super) k: u64,
    /// Clock reading of the next kick (infinity: off).
    pub(super) next: f64,
}

impl Train {
    pub(super) const OFF: Train = Train {
        dt: f64::INFINITY,
        t0: 0.0,
        k: 0,
        next: f64::INFINITY,
    };

    /// Clock reading of the next kick on `clock` (infinity when off).
    pub(super) fn reading(&self, clock: &Clock) -> f64 {
        if self.dt.is_finite() {
            clock.s(self.t0 + (self.k as f64 + 0.5) * self.dt)
        } else {
            f64::INFINITY
        }
    }
}

/// The neighbour lists ([`super::neighbour_lists`]).
pub(super) struct Lists {
    /// Neighbour lists are used (radii fixed and a box of at least 5x5 cells);
    /// otherwise every prediction scans the 3x3 cells.
    pub(super) on: bool,
    /// Shell half-width: how far a disk may move from its list centre.
    pub(super) shell: f64,
    /// List capacity per disk; it doubles when a list overflows, up to `cap_max`.
    pub(super) cap: usize,
    /// A packing bound on the list length: lists never exceed it.
    pub(super) cap_max: usize,
    /// A list was full when a disk had to be added: grow and rebuild.
    pub(super) overflow: bool,
    /// Neighbour list of disk `i`: `nb[i cap .. i cap + bk[i].nn]`.
    pub(super) nb: Vec<u32>,
}

/// The prefetch pipeline's state ([`super::prefetch_pipeline`]).
pub(super) struct Pipeline {
    /// The calendar bucket up to which the pipeline has run.
    pub(super) bucket: u64,
    /// The pipeline is on (lists in use, arrays over `min_bytes`).
    pub(super) on: bool,
    /// [`super::PREFETCH_MIN_BYTES`] (a test forces the pipeline on in small systems).
    pub(super) min_bytes: usize,
}

/// The intruder's state ([`super::pulled_intruder`]).
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub(super) struct Pulling {
    /// The intruder's index ([`NO_INTRUDER`] if none), and the same while a
    /// force pulls it (its events then come from the root finder).
    pub(super) intruder: usize,
    pub(super) pulled: usize,
    /// The force on the intruder and its motion law.
    pub(super) force: f64,
    pub(super) pull: Pull,
    /// The pulled intruder's pending event (its `Disk::te` reads minus
    /// infinity so that the bath's pair scan skips it).
    pub(super) intruder_te: f64,
    /// The pulled intruder rests on the x wall the force presses it on (the
    /// wall holds F; see the module doc).
    pub(super) resting: bool,
}

impl Pulling {
    /// No intruder.
    pub(super) const NONE: Pulling = Pulling {
        intruder: NO_INTRUDER,
        pulled: NO_INTRUDER,
        force: 0.0,
        pull: Pull {
            gamma: 0.0,
            accel: 0.0,
        },
        intruder_te: f64::INFINITY,
        resting: false,
    };
}

/// No intruder (or one the force does not pull): its index.
pub(super) const NO_INTRUDER: usize = usize::MAX;
