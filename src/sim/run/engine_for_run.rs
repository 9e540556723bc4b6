//! The engine of a run, built from its configuration in one place: the
//! compressed start, then restitution, collapse guard, temperature, friction,
//! drive and pulling force, in that order. Every run starts here, and so do
//! the measurements of what a run costs ([`super::checkpoint_cost`]), so that
//! they time the engine a run has.

use anyhow::Result;

use super::initial_state;
use super::progress::Progress;
use crate::sim::engine::{Engine, Kicks};
use crate::sim::model::config::{Drive, ForceMode, KickRate, SimConfig};
use crate::sim::model::{enskog, kicks};

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

/// The driving of `cfg`: which particles, how many kicks per unit time in the
/// whole system (starting value for the balanced rule), and the amplitude p_dr
/// of Eq. (7) of paper I (paper H's sqrt((1 - eps^2) m1 m2 / (m1 + m2)) at
/// gamma = 0, T = 1). `enskog` is the Enskog collision frequency per particle
/// at `cfg.temperature`. No kicks when the amplitude is 0 (eps = 1 without friction).
pub fn drive(cfg: &SimConfig, enskog: f64) -> (Kicks, f64, f64) {
    let masses = cfg.species_masses();
    let nf = cfg.n as f64;
    let p_dr = kicks::amplitude(
        cfg.eps,
        cfg.gamma,
        cfg.temperature,
        enskog,
        masses[0],
        masses[1],
    );
    let kicks = match cfg.drive {
        _ if p_dr == 0.0 => Kicks::Off,
        Drive::None => Kicks::Off,
        Drive::NeighbourPairs => Kicks::NeighbourPairs,
        Drive::RandomPairs => Kicks::RandomPairs,
        Drive::Single => Kicks::Single,
    };
    // Each pair kick (like each collision) involves two particles.
    let per_kick = if kicks == Kicks::Single { 1.0 } else { 2.0 };
    let rate = match cfg.kick_rate {
        KickRate::Balanced => enskog * nf / per_kick,
        KickRate::Enskog { prefactor } => prefactor * enskog * nf / per_kick,
        KickRate::PerParticle(r) => r * nf / per_kick,
    };
    (kicks, rate, p_dr)
}

/// The engine of a run of `cfg`, compressed to its packing fraction and set
/// up to relax: returns it with the time the compression took.
pub fn build(cfg: &SimConfig, progress: &dyn Fn(Progress)) -> Result<(Engine, f64)> {
    let mut e = initial_state::prepare(cfg, progress)?;
    let compress_time = e.time();
    e.set_restitution(cfg.eps, cfg.collapse_tc);
    if cfg.temperature != 1.0 {
        initial_state::set_temperature(&mut e, cfg.temperature);
    }
    if cfg.gamma > 0.0 {
        e.set_friction(cfg.gamma);
    }
    let rate = bath_collision_rate(cfg, cfg.temperature);
    let (kicks, kick_rate, p_dr) = drive(cfg, rate);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Paper I's bath with its intruder, at a temperature, restitution and
    /// collapse guard of its own, so that each setting is seen to arrive.
    fn cfg(gamma: f64) -> SimConfig {
        SimConfig {
            eps: 0.85,
            collapse_tc: 1e-5,
            temperature: 0.5,
            ..crate::sim::tests::intruder::bath(300, 0.6, gamma, 3.0)
        }
    }

    #[test]
    fn the_engine_of_a_run_carries_every_setting_of_its_configuration() {
        for gamma in [0.0, 0.2] {
            let c = cfg(gamma);
            let (e, compress_time) = build(&c, &|_| {}).unwrap();
            assert!(compress_time > 0.0 && e.time() == compress_time);
            assert_eq!((e.eps(), e.tc()), (0.85, 1e-5));
            assert_eq!(e.force(), 3.0);
            let t = e.kinetic_energy() / e.n() as f64;
            assert!((t - 0.5).abs() < 1e-9, "T = {t}");
            // The drive's rate from the bath's Enskog frequency at T = 0.5
            // (single disks with friction, pairs without).
            let (_, rate, _) = drive(&c, bath_collision_rate(&c, 0.5));
            assert_eq!(e.kick_rate(), rate);
            let per_kick = if gamma > 0.0 { 1.0 } else { 2.0 };
            assert!((rate - bath_collision_rate(&c, 0.5) * 300.0 / per_kick).abs() < 1e-9 * rate);
        }
    }
}
