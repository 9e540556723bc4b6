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

/// The sources as build.rs read them ([`pipeline::fingerprint::Sources`]): what
/// every stage kind's code fingerprint is derived from.
pub mod fingerprints {
    use std::sync::OnceLock;

    use crate::pipeline::fingerprint::Sources;

    /// The compiler that built this binary (`rustc --version`).
    pub const RUSTC_VERSION: &str = env!("REPRO_RUSTC_VERSION");

    /// The sources of this build, parsed once.
    pub fn sources() -> &'static Sources {
        static SOURCES: OnceLock<Sources> = OnceLock::new();
        SOURCES.get_or_init(|| {
            Sources::from_text(include_str!(concat!(env!("OUT_DIR"), "/sources.txt")))
        })
    }
}
