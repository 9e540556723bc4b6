//! One simulation from config to results:
//!
//! - [`initial_state`]: random start and Lubachevsky-Stillinger compression;
//!   [`engine_for_run`]: the engine of a run from its configuration
//!   ([`engine_for_run::build`]), the one place a run's engine is set up.
//! - [`simulation`]: relax under driving, record frames, measure
//!   ([`RunSummary`](simulation::RunSummary)).
//! - [`checkpoint`]: when a run checkpoints, where it keeps them, their format;
//!   [`checkpoint_cost`]: what they cost (`repro bench --checkpoints`).
//! - [`progress`]: what a running simulation reports.
//! - [`resources`]: CPU time and memory, allocation of the big arrays.

pub mod checkpoint;
pub mod checkpoint_cost;
pub mod engine_for_run;
pub mod initial_state;
pub mod progress;
pub mod resources;
pub mod simulation;

pub use engine_for_run::drive;
