//! What a running simulation reports to its caller.

use crate::sim::engine::Engine;
use serde::Serialize;
use std::time::Instant;

/// Which part of the run is going on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    Compress,
    Relax,
    Production,
}

/// Reported to the caller now and then (about every 10^6 events).
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub stage: Stage,
    /// Simulated time now and at the end of this stage.
    pub time: f64,
    pub end: f64,
    pub collisions: u64,
    /// Events (collisions, crossings, shell exits, kicks) per wall-clock second in this stage.
    pub events_per_second: f64,
    /// Fraction of the relaxation and production done (0 while compressing).
    pub fraction: f64,
}

impl Progress {
    pub(crate) fn new(stage: Stage, e: &Engine, end: f64, since: Instant) -> Progress {
        let s = e.stats();
        let events = s.collisions + s.cell_crossings + s.kicks + s.stale_events + s.shell_exits;
        Progress {
            stage,
            time: e.time(),
            end,
            collisions: s.collisions,
            events_per_second: events as f64 / since.elapsed().as_secs_f64().max(1e-9),
            fraction: 0.0,
        }
    }

    /// The same, with the fraction done of a run from `start` to `end`.
    pub(crate) fn of_run(self, start: f64, end: f64) -> Progress {
        Progress {
            fraction: ((self.time - start) / (end - start)).clamp(0.0, 1.0),
            ..self
        }
    }
}
