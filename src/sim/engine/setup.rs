//! Building an engine: the box, species and particles it starts from
//! ([`Setup`]), the cell list, the neighbour-list shell, and every particle's
//! first predicted event.

use rand_chacha::ChaCha8Rng;

use super::{Book, Engine, LIST_CAPACITY, PREFETCH_MIN_BYTES, SHELL_FRACTION, Stats, parts};
use crate::sim::big_vec::{big_vec, big_vec_from};
use crate::sim::events::calendar::EventCalendar;
use crate::sim::events::disk::{CROSS, Disk, NONE};
use crate::sim::model::friction::Clock;
use crate::sim::model::walls;

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
    /// Build the cell list and predict every particle's first event. Positions are
    /// wrapped into the box. Fails if the box is too small for a 3x3 cell list.
    pub fn new(s: Setup, eps: f64, tc: f64, rng: ChaCha8Rng) -> anyhow::Result<Engine> {
        let n = s.species.len();
        anyhow::ensure!(
            [&s.x, &s.y, &s.vx, &s.vy].iter().all(|v| v.len() == n),
            "particle arrays have different lengths"
        );
        anyhow::ensure!(n >= 2, "need at least 2 particles, got {n}");
        anyhow::ensure!(n < CROSS as usize, "too many particles: {n}");
        let rmax = s.radii.iter().copied().fold(0.0, f64::max);
        let rmin = s.radii.iter().copied().fold(f64::INFINITY, f64::min);
        let shell = SHELL_FRACTION * rmin;
        let pad = walls::padding(rmax, shell);
        let wall_len = [0, 1].map(|k| {
            if s.walls[k] {
                [s.lx, s.ly][k]
            } else {
                f64::INFINITY
            }
        });
        let lx = if s.walls[0] { s.lx + pad } else { s.lx };
        let ly = if s.walls[1] { s.ly + pad } else { s.ly };
        let ncx = (lx / (2.0 * rmax)).floor() as usize;
        let ncy = (ly / (2.0 * rmax)).floor() as usize;
        anyhow::ensure!(
            ncx >= 3 && ncy >= 3,
            "box {:.3} x {:.3} is smaller than 3 cells of one large-disk diameter ({:.3}); use more particles",
            s.lx,
            s.ly,
            2.0 * rmax
        );
        for k in 0..2 {
            anyhow::ensure!(
                wall_len[k] > 4.0 * rmax,
                "walls: the box ({:.3} between the walls of axis {}) must be wider than two large-disk diameters ({:.3})",
                wall_len[k],
                ["x", "y"][k],
                4.0 * rmax
            );
        }
        // Disks of radius r - shell around the list centres never overlap, and those
        // in a list lie within r_i + 2 r_max + shell of the centre: an area bound.
        let cap_max = (((rmax + 2.0 * rmax + shell) / (rmin - shell))
            .powi(2)
            .floor() as usize
            + 4)
        .min(u8::MAX as usize);
        let cap = LIST_CAPACITY.min(cap_max);
        let lists_fit = ncx >= 5 && ncy >= 5;
        let d = big_vec_from(
            n,
            (0..n).map(|i| Disk {
                x: s.x[i].rem_euclid(lx),
                y: s.y[i].rem_euclid(ly),
                vx: s.vx[i],
                vy: s.vy[i],
                t: 0.0,
                radius: s.radii[s.species[i] as usize],
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
            ..
        } = s;
        drop((x, y, vx, vy));
        let mut e = Engine {
            lx,
            ly,
            wall_len,
            has_walls: wall_len.iter().any(|l| l.is_finite()),
            ncx,
            ncy,
            wx: lx / ncx as f64,
            wy: ly / ncy as f64,
            head: big_vec(ncx * ncy, NONE),
            occupancy: big_vec(ncx * ncy, 0),
            d,
            prev: big_vec(n, NONE),
            cell: big_vec(n, 0),
            imx: big_vec(n, 0),
            imy: big_vec(n, 0),
            species,
            radii,
            masses,
            last_collision: big_vec(n, f64::NEG_INFINITY),
            bk: big_vec(n, Book::default()),
            calendar: EventCalendar::new(n),
            lists: parts::Lists {
                on: false,
                shell,
                cap,
                cap_max,
                overflow: false,
                nb: if lists_fit {
                    big_vec(n * cap, NONE)
                } else {
                    Vec::new()
                },
            },
            rmax,
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
            next_kick: f64::INFINITY,
            train: parts::Train::OFF,
            drive: parts::Driving::OFF,
            pipeline: parts::Pipeline {
                bucket: 0,
                on: false,
                min_bytes: PREFETCH_MIN_BYTES,
            },
            pulling: parts::Pulling::NONE,
            rng,
            stats: Stats::default(),
        };
        e.reschedule_all();
        Ok(e)
    }
}
