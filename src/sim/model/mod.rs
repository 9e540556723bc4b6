//! The physics of the simulator, one rule per file, as pure functions and
//! types (the engine applies them):
//!
//! - [`config`]: [`SimConfig`](config::SimConfig), every model parameter, validated.
//! - [`restitution`]: the collision rule, Eqs. (1)-(3) of paper H (Eq. 1 of
//!   paper I), and the collapse guard.
//! - [`friction`]: viscous friction as an exact clock, Eqs. (8)-(9) of paper I.
//! - [`kicks`]: pair kicks (Eq. 4 of paper H), single kicks (Eq. 2 of paper I)
//!   and their amplitude, Eq. (7) of paper I.
//! - [`walls`]: hard walls per axis (wall times, reflection, padding).
//! - [`intruder_path`]: the intruder's exact path under force and friction
//!   (Eqs. 3-4 of paper I) and its root finders.
//! - [`enskog`]: contact values and the Enskog collision frequency.

pub mod config;
pub mod enskog;
pub mod friction;
pub mod intruder_path;
pub mod kicks;
pub mod restitution;
pub mod walls;
