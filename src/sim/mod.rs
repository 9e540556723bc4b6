//! Event-driven molecular dynamics of 2D hard disks (paper H, Sec. 2; paper I).
//!
//! - [`config`]: [`SimConfig`], every model parameter, validated.
//! - [`engine`]: the event loop (collisions, cell and shell crossings, kicks),
//!   with its neighbour lists, driving and prefetch pipeline in submodules.
//! - [`restitution`]: the collision rule and the collapse guard (Eq. 1).
//! - [`friction`]: the friction clock (Eqs. 8-9 of paper I).
//! - [`kicks`]: single and pair kicks, the amplitude of Eq. (7) of paper I.
//! - [`intruder`]: the intruder's path under force and friction, its root finder.
//! - [`walls`]: hard walls per axis (wall times, reflection, padding).
//! - [`tree`]: a tournament tree over the event times (the reference queue
//!   in tests and benchmarks) and branch-free selects.
//! - [`calendar`]: the event calendar (O(1) calendar queue, same API).
//! - [`scan`]: the pair scan (scalar and SSE2, the same bits).
//! - [`init`]: random start and Lubachevsky-Stillinger compression.
//! - [`enskog`]: contact values and the Enskog collision frequency.
//! - [`run`](mod@run): one simulation from config to trajectory and [`RunSummary`].
//! - [`progress`]: what a running simulation reports.

pub mod calendar;
pub mod config;
mod disk;
pub mod engine;
pub mod enskog;
pub mod friction;
pub mod init;
pub mod intruder;
pub mod kicks;
mod prefetch;
pub mod progress;
pub mod resources;
pub mod restitution;
pub mod run;
pub mod scan;
pub mod tree;
pub mod walls;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_force_kicks;
#[cfg(test)]
mod tests_friction;
#[cfg(test)]
mod tests_intruder;
#[cfg(test)]
mod tests_intruder_contact;
#[cfg(test)]
mod tests_intruder_walls;
#[cfg(test)]
mod tests_walls;

pub use config::{Drive, ForceMode, KickRate, Masses, SimConfig};
pub use progress::{Progress, Stage};
pub use run::{RunSummary, Sample, run};
