//! The engine at a checkpoint: every particle synchronised, the time origin
//! moved to the checkpoint, the state ([`EngineState`], one value) written
//! out and everything derived from it rebuilt from it alone. A run restored
//! from the state ([`Engine::restore`]) rebuilds the same way
//! ([`Engine::from_state`]), so it continues bit for bit like a run that
//! passed the checkpoint without stopping.
//!
//! The rebuild reads nothing of the history: pending event times are
//! forgotten first (the pair scan skips partners by them) and the calendar
//! starts new (its heap's capacity counts in [`Engine::bytes`]).

use super::Engine;
use super::parts::NO_INTRUDER;
use super::state::EngineState;
use crate::sim::big_vec::big_vec_from;
use crate::sim::events::calendar::EventCalendar;

impl Engine {
    /// Synchronise every particle, move the time origin here (clock reading 0
    /// at the current time, positions and event times relative to it) and
    /// predict every event anew from the synchronised state alone. With
    /// `save`, also return that state. Call it at a stop time of
    /// [`Engine::run_until`] (where the time is exact).
    pub fn checkpoint(&mut self, save: bool) -> Option<EngineState> {
        self.move_origin(self.state.clock.gamma, self.state.time);
        self.forget_events();
        let state = save.then(|| self.state.clone());
        self.derived.calendar = EventCalendar::new(self.n());
        self.reschedule_all();
        state
    }

    /// The engine of a checkpoint, ready to go on from it; fails on a state
    /// that does not hold together.
    pub fn restore(mut s: EngineState) -> anyhow::Result<Engine> {
        // Deserialised disks are on ordinary pages: move them to a big array.
        let d = std::mem::take(&mut s.d);
        s.d = big_vec_from(d.len(), d);
        Engine::from_state(s).map_err(|e| e.context("checkpoint"))
    }

    /// The state: everything that determines the run's future.
    pub fn state(&self) -> &EngineState {
        &self.state
    }

    /// Every pending event unknown, as before the first prediction (the
    /// pulled intruder's reads minus infinity: the bath's scan never pairs
    /// with it).
    pub(super) fn forget_events(&mut self) {
        for d in &mut self.state.d {
            d.te = f64::INFINITY;
        }
        self.state.pulling.intruder_te = f64::INFINITY;
        if self.state.pulling.pulled != NO_INTRUDER {
            self.state.d[self.state.pulling.pulled].te = f64::NEG_INFINITY;
        }
    }
}
