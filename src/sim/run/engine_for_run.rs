//! The engine of a run, built from its configuration in one place: the
//! compressed start, then restitution, collapse guard, temperature, friction,
//! drive and pulling force, in that order. Every run starts here, and so do
//! the measurements of what a run costs ([`super::checkpoint_cost`]), so that
//! they time the engine a run has.

use anyhow::Result;

use super::initial_state;
use super::progress::Progress;
use crate::sim::engine::Engine;
use crate::sim::model::config::{ForceMode, SimConfig};
use crate::sim::model::enskog;

/// The bath's Enskog collision frequency per disk at temperature `t` (the
/// intruder, species 2, left out): what the drive and the force kicks are
/// paced by.
pub fn bath_collision_rate(cfg: &SimConfig, t: f64) -> f64 {
    let n_bath = cfg.n as f64;
    let fractions = [
        1.0 - cfg.n_large() as f64 / n_bath,
        cfg.n_large() as f64 / n_bath,
    ];
    let radii = cfg.radii();
    let masses = cfg.species_masses();
    enskog::collision_frequency(cfg.phi, &radii[..2], &masses[..2], &fractions, t)
}

impl Engine {
    /// The engine of a run of `cfg`, compressed to its packing fraction and set
    /// up to relax: returns it with the time the compression took.
    pub fn for_run(cfg: &SimConfig, progress: &dyn Fn(Progress)) -> Result<(Engine, f64)> {
        let mut e = initial_state::prepare(cfg, progress)?;
        let compress_time = e.time();
        e.eps = cfg.eps;
        e.tc = cfg.collapse_tc;
        if cfg.temperature != 1.0 {
            initial_state::set_temperature(&mut e, cfg.temperature);
        }
        if cfg.gamma > 0.0 {
            e.set_friction(cfg.gamma);
        }
        let rate = bath_collision_rate(cfg, cfg.temperature);
        let (kicks, kick_rate, p_dr) = super::drive(cfg, rate);
        e.set_kicks(kicks, kick_rate, p_dr);
        if let Some(intr) = &cfg.intruder {
            // The force is on from here: the relaxation holds the intruder's transient.
            match intr.force_mode {
                ForceMode::Exact => e.set_force(intr.force)?,
                ForceMode::Kicks => {
                    e.set_force_kicks(intr.force, 1.0 / (intr.kick_rate_factor * rate))?
                }
            }
        }
        Ok((e, compress_time))
    }
}
