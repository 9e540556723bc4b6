//! The parts the engine is made of, below the [`Engine`](super::Engine) that
//! holds them: the constants and data types of its state
//! ([`super::state::EngineState`]) and of what is derived from it
//! ([`super::derived::Derived`]): counters, per-disk bookkeeping, the drive,
//! the force's train of kicks, the neighbour lists, the prefetch pipeline, the
//! intruder. Each part's code (`impl Engine` in its own file) builds on the
//! engine, the engine only on these types, so this file imports nothing of
//! the engine.

use crate::sim::events::disk::NONE;
use crate::sim::model::friction::Clock;
use crate::sim::model::intruder_path::Pull;
use crate::sim::model::kicks::Kicks;

/// Starting list capacity per disk: lists hold 5-6 disks on average at
/// phi = 0.78-0.84 and at most 8 were seen; a longer list doubles the capacity.
pub(super) const LIST_CAPACITY: usize = 12;
/// Shell half-width as a fraction of the smallest radius: wider shells mean fewer
/// list rebuilds but longer lists (measured in docs/sim.md).
pub(super) const SHELL_FRACTION: f64 = 0.3;
/// First disks of kicks drawn ahead of the pending one: each is fetched from
/// memory in stages over the kicks before it (docs/sim.md, "Prefetch pipeline").
pub(super) const KICKS_AHEAD: usize = 3;
/// At most this many events of one calendar bucket are fetched ahead (a bucket
/// holds ~2 on average).
pub(super) const BUCKET_PREFETCH_MAX: usize = 8;
/// The prefetch pipeline runs when the engine's arrays exceed this (~200 bytes
/// per disk): below, they are served fast enough by the caches (L2 512 KiB per
/// core, L3 32 MiB here) that its instructions and mispredicted loop exits cost
/// more than they save (measured in docs/sim.md: -8% at N = 10^4, +7% at
/// 2 x 10^4).
pub(super) const PREFETCH_MIN_BYTES: usize = 3 << 20;

/// Counters of everything the loop did, and the energy and virial ledgers.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    pub collisions: u64,
    pub kicks: u64,
    /// Collisions made elastic by the collapse guard.
    pub guard_activations: u64,
    pub cell_crossings: u64,
    /// Events popped whose partner had changed velocity meanwhile.
    pub stale_events: u64,
    /// Kinetic energy added by kicks (exact, summed per kick).
    pub injected: f64,
    /// Kinetic energy removed by inelastic collisions (exact, summed per collision).
    pub dissipated: f64,
    /// Collisional virial sum over collisions of r_ij . dp_i (for the pressure).
    pub virial: f64,
    /// Neighbour lists rebuilt because a disk left its shell.
    pub shell_exits: u64,
    /// Kinetic energy removed by viscous friction (exact, summed between events).
    pub friction: f64,
    /// Re-anchorings of the friction clock.
    pub reanchors: u64,
    /// Collisions with the walls.
    pub wall_collisions: u64,
    /// Momentum transferred to the walls of each axis (sum of |dp|).
    pub wall_impulse: [f64; 2],
    /// Virial of the wall forces, sum of r . dp at each wall collision.
    pub wall_virial: f64,
    /// Work done by the force pulling the intruder (exact, per advance).
    pub work: f64,
    /// Calls of the intruder's root finder and the steps they took.
    pub root_calls: u64,
    pub root_steps: u64,
    /// Re-prediction events (the root finder gave up, or nothing happened
    /// within the intruder's horizon).
    pub repredicts: u64,
    /// Intruder-disk rebounds lifted to the minimum separation speed
    /// ([`super::pulled_intruder::WALL_REST_TIME`]'s rule on disks) and the kinetic energy
    /// the lifts added (exact, summed per lift).
    pub lifts: u64,
    pub lifted: f64,
}

/// A disk's pending event partner and its neighbour-list bookkeeping.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Book {
    /// List centre (the wrapped position at the last rebuild).
    pub(super) ox: f64,
    pub(super) oy: f64,
    /// Partner of the pending event (a disk, or a CROSS/SHELL code).
    pub(super) ev_p: u32,
    /// The partner's velocity-change counter when the event was predicted.
    pub(super) ev_c: u32,
    /// Length of the neighbour list.
    pub(super) nn: u32,
}

impl Default for Book {
    fn default() -> Self {
        Book {
            ox: 0.0,
            oy: 0.0,
            ev_p: NONE,
            ev_c: 0,
            nn: 0,
        }
    }
}

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
    /// A packing bound on the list length: lists never exceed it. (The
    /// capacity per disk, which doubles when a list overflows up to this, is
    /// state: `EngineState::list_capacity`.)
    pub(super) cap_max: usize,
    /// A list was full when a disk had to be added: grow and rebuild.
    pub(super) overflow: bool,
    /// Neighbour list of disk `i`: `nb[i cap .. i cap + bk[i].nn]` (cap: the list capacity).
    pub(super) nb: Vec<u32>,
}

/// The prefetch pipeline's state ([`super::prefetch_pipeline`]).
pub(super) struct Pipeline {
    /// The calendar bucket up to which the pipeline has run.
    pub(super) bucket: u64,
    /// The pipeline is on (lists in use, arrays over `min_bytes`).
    pub(super) on: bool,
    /// [`PREFETCH_MIN_BYTES`] (a test forces the pipeline on in small systems).
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
    /// infinity so that the bath's pair scan skips it); rebuilt, not saved.
    #[serde(skip, default = "unknown_event")]
    pub(super) intruder_te: f64,
    /// The pulled intruder rests on the x wall the force presses it on (the
    /// wall holds F; see [`super::pulled_intruder`]'s module doc).
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

/// A pending event not yet predicted.
fn unknown_event() -> f64 {
    f64::INFINITY
}

/// No intruder (or one the force does not pull): its index.
pub(super) const NO_INTRUDER: usize = usize::MAX;
