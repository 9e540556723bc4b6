//! Building an engine: the box, species and particles it starts from
//! ([`Setup`]), made into a state at time 0, and the engine of a state
//! ([`Engine::from_state`], for a new engine and a resumed one alike):
//! everything derived from it ([`Derived`]) built from the state alone.

use rand_chacha::ChaCha8Rng;

use super::Engine;
use super::derived::{Derived, Geometry};
use super::parts::{
    Book, Driving, LIST_CAPACITY, Lists, PREFETCH_MIN_BYTES, Pipeline, Pulling, Stats, Train,
};
use super::state::EngineState;
use crate::sim::big_vec::{big_vec, big_vec_from};
use crate::sim::events::calendar::EventCalendar;
use crate::sim::events::disk::{CROSS, Disk, NONE};
use crate::sim::model::friction::Clock;

/// Everything the engine needs to start: box, species table, particles.
pub struct Setup {
    pub lx: f64,
    pub ly: f64,
    /// Hard walls at 0 and L instead of periodic boundaries, per axis.
    pub walls: [bool; 2],
    /// Radius of each species (final radius if the radii grow).
    pub radii: Vec<f64>,
    pub masses: Vec<f64>,
    pub species: Vec<u8>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub vx: Vec<f64>,
    pub vy: Vec<f64>,
}

impl Engine {
    /// An engine at time 0 with normal restitution `eps` and collapse guard
    /// `tc`: positions wrapped into the box, the cell list built and every
    /// particle's first event predicted. Fails if the box is too small for a
    /// 3x3 cell list.
    pub fn new(s: Setup, eps: f64, tc: f64, rng: ChaCha8Rng) -> anyhow::Result<Engine> {
        let n = s.species.len();
        anyhow::ensure!(
            [&s.x, &s.y, &s.vx, &s.vy].iter().all(|v| v.len() == n),
            "particle arrays have different lengths"
        );
        let box_size = [s.lx, s.ly];
        let g = Geometry::of(box_size, s.walls, &s.radii)?;
        let d = big_vec_from(
            n,
            (0..n).map(|i| Disk {
                x: s.x[i].rem_euclid(g.lx),
                y: s.y[i].rem_euclid(g.ly),
                vx: s.vx[i],
                vy: s.vy[i],
                t: 0.0,
                radius: 0.0,
                te: f64::INFINITY,
                next: NONE,
                count: 0,
            }),
        );
        // The setup's coordinates are in `d` now: free them before the other
        // arrays are made (they would add 32 bytes per disk to the peak).
        let Setup {
            radii,
            masses,
            species,
            x,
            y,
            vx,
            vy,
            walls,
            ..
        } = s;
        drop((x, y, vx, vy));
        Engine::from_state(EngineState {
            box_size,
            walls,
            species,
            radii,
            masses,
            d,
            imx: big_vec(n, 0),
            imy: big_vec(n, 0),
            last_collision: big_vec(n, f64::NEG_INFINITY),
            list_capacity: LIST_CAPACITY.min(g.cap_max),
            now: 0.0,
            time: 0.0,
            clock: Clock::NONE,
            ke_u: 0.0,
            lam2: 1.0,
            kick_momentum_u: [0.0; 2],
            eps,
            tc,
            scale0: 1.0,
            scale_t0: 0.0,
            growth: 0.0,
            drive: Driving::OFF,
            next_kick: f64::INFINITY,
            train: Train::OFF,
            pulling: Pulling::NONE,
            rng,
            stats: Stats::default(),
        })
    }
}

impl Engine {
    /// The engine of state `s`: radii of the disks from their species, the
    /// cell list, the neighbour lists and every pending event built anew.
    /// Fails on a state that does not hold together (arrays of different
    /// lengths, a species without radius or mass, a box too small).
    pub(super) fn from_state(mut s: EngineState) -> anyhow::Result<Engine> {
        let n = s.n();
        anyhow::ensure!(n >= 2, "need at least 2 particles, got {n}");
        anyhow::ensure!(n < CROSS as usize, "too many particles: {n}");
        anyhow::ensure!(
            [s.d.len(), s.imx.len(), s.imy.len(), s.last_collision.len()]
                .iter()
                .all(|&len| len == n),
            "particle arrays of different lengths ({n} species for {} disks)",
            s.d.len()
        );
        anyhow::ensure!(
            s.species
                .iter()
                .all(|&k| (k as usize) < s.radii.len().min(s.masses.len())),
            "a species without a radius or mass ({} radii, {} masses)",
            s.radii.len(),
            s.masses.len()
        );
        let g = Geometry::of(s.box_size, s.walls, &s.radii)?;
        for (d, &k) in s.d.iter_mut().zip(&s.species) {
            d.radius = s.radii[k as usize];
        }
        let nb = if g.lists_fit {
            big_vec(n * s.list_capacity, NONE)
        } else {
            Vec::new()
        };
        let derived = Derived {
            lx: g.lx,
            ly: g.ly,
            wall_len: g.wall_len,
            has_walls: g.wall_len.iter().any(|l| l.is_finite()),
            ncx: g.ncx,
            ncy: g.ncy,
            wx: g.lx / g.ncx as f64,
            wy: g.ly / g.ncy as f64,
            rmax: g.rmax,
            head: big_vec(g.ncx * g.ncy, NONE),
            occupancy: big_vec(g.ncx * g.ncy, 0),
            prev: big_vec(n, NONE),
            cell: big_vec(n, 0),
            bk: big_vec(n, Book::default()),
            calendar: EventCalendar::new(n),
            lists: Lists {
                on: false,
                shell: g.shell,
                cap_max: g.cap_max,
                overflow: false,
                nb,
            },
            pipeline: Pipeline {
                bucket: 0,
                on: false,
                min_bytes: PREFETCH_MIN_BYTES,
            },
        };
        let mut e = Engine { state: s, derived };
        e.forget_events();
        e.reschedule_all();
        Ok(e)
    }
}
