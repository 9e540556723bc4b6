//! Event-driven molecular dynamics of 2D hard disks (paper H, Sec. 2; paper I).
//!
//! - [`config`]: [`SimConfig`], every model parameter, validated.
//! - [`engine`]: the event loop (collisions, cell crossings, pair kicks).
//! - [`tree`]: a tournament tree over the event times (the reference queue
//!   in tests and benchmarks) and branch-free selects.
//! - [`calendar`]: the event calendar (O(1) calendar queue, same API).
//! - [`scan`]: the pair scan (scalar and SSE2, the same bits).
//! - [`init`]: random start and Lubachevsky-Stillinger compression.
//! - [`enskog`]: contact values and the Enskog collision frequency.
//! - [`run`](mod@run): one simulation from config to trajectory and [`RunSummary`].

pub mod calendar;
pub mod config;
mod disk;
pub mod engine;
pub mod enskog;
pub mod friction;
pub mod init;
pub mod kicks;
mod prefetch;
pub mod progress;
pub mod resources;
pub mod restitution;
pub mod run;
pub mod scan;
pub mod tree;

#[cfg(test)]
mod tests;

pub use config::{Drive, KickRate, Masses, SimConfig};
pub use progress::{Progress, Stage};
pub use run::{RunSummary, Sample, run};
