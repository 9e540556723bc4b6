//! Validation of the simulator: each test fails if the physics is wrong.
//!
//! - [`paper_h`]: conservation laws, exact relations and equations of state
//!   of paper H's model; configs and reproducibility.
//! - [`walls`], [`friction`]: hard walls and viscous friction against exact
//!   results.
//! - [`intruder`], [`intruder_contact`], [`intruder_walls`], [`force_kicks`]:
//!   paper I's pulled intruder (exact force, resting contact, walls in x, the
//!   force as kicks).
//! - [`checkpoint`]: a run stopped at a checkpoint and resumed is the same
//!   bits; the clock's precision at a late time.

mod checkpoint;
mod force_kicks;
mod friction;
pub(crate) mod intruder;
mod intruder_contact;
mod intruder_walls;
mod paper_h;
mod walls;
