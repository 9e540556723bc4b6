//! Building an engine: the box, species and particles it starts from
//! ([`Setup`]), made into a state at time 0 and everything derived from it.

use rand_chacha::ChaCha8Rng;

use super::derived::Geometry;
use super::state::EngineState;
use super::{Engine, LIST_CAPACITY, Stats, driving, force_kicks, pulled_intruder};
use crate::sim::big_vec::{big_vec, big_vec_from};
use crate::sim::events::disk::{Disk, NONE};
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
            drive: driving::Driving::OFF,
            next_kick: f64::INFINITY,
            train: force_kicks::Train::OFF,
            pulling: pulled_intruder::Pulling::NONE,
            rng,
            stats: Stats::default(),
        })
    }
}
