//! Event-driven molecular dynamics of 2D hard disks: the driven granular fluid
//! of paper H (Sec. 2: inelastic bidisperse disks, collapse guard, pair kicks)
//! and paper I's additions (viscous friction, single kicks at the amplitude of
//! Eq. 7, hard walls, an intruder pulled by a constant force).
//!
//! - [`model`]: the physics, one rule per file: [`SimConfig`] and its
//!   validation, the collision rule (Eqs. 1-3 of paper H, Eq. 1 of paper I),
//!   the friction clock (Eqs. 8-9 of paper I), the kicks (Eq. 4 of paper H,
//!   Eqs. 2 and 7 of paper I), the walls, the intruder's path (Eqs. 3-4 of
//!   paper I) and the Enskog collision frequency.
//! - [`events`]: the event machinery: the calendar, one disk's hot state and
//!   the partner codes, the pair scan, cache hints.
//! - [`engine`]: the state and the event loop (collisions, cell and shell
//!   crossings, kicks, walls, the pulled intruder), each part in a submodule.
//! - [`big_vec`](mod@big_vec): the large arrays of the engine and the calendar,
//!   on huge pages where the kernel gives them.
//! - [`run`](mod@run): one simulation: initial state and compression, relax,
//!   produce and measure ([`RunSummary`]), progress, CPU time and memory.

pub mod big_vec;
pub mod engine;
pub mod events;
pub mod model;
pub mod run;

#[cfg(test)]
mod tests;

pub use model::config::{Drive, ForceMode, KickRate, Masses, SimConfig};
pub use model::{config, enskog, kicks};
pub use run::initial_state;
pub use run::progress::{Progress, Stage};
pub use run::simulation::{RunSummary, Sample, run};
