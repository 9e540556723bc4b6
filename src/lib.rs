//! repro: regenerates the figures of two papers on dense driven granular fluids
//! (paper H: dynamical heterogeneities in a 2D driven granular fluid; paper I: an
//! intruder in a dense granular fluid) from declarative YAML specs.
//!
//! Data flows one way: experiment spec -> [`sim`] -> [`traj::Trajectory`] ->
//! [`analysis`] -> Arrow tables ([`table`]) -> [`fit`] -> comparison and [`plot`],
//! orchestrated and cached by [`pipeline`].

pub mod analysis;
pub mod cli;
pub mod fit;
pub mod pipeline;
pub mod plot;
pub mod sim;
pub mod stages;
pub mod study;
pub mod table;
pub mod traj;

/// Blake3 fingerprints of each source module folder, computed at build time.
pub mod fingerprints {
    include!(concat!(env!("OUT_DIR"), "/fingerprints.rs"));

    /// The fingerprint of one module folder or file under src/ (e.g. "sim",
    /// "stages/simulate"), if it exists.
    pub fn of(module: &str) -> Option<&'static str> {
        FINGERPRINTS
            .iter()
            .find(|(m, _)| *m == module)
            .map(|(_, h)| *h)
    }
}
