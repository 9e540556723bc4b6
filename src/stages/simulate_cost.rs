//! What a simulation is planned to do, from its configuration alone: disks,
//! stored frames, collisions (with the measured collision rate over Enskog's and
//! the bath's heating by a pulling force), kicks of the drive and force kicks of
//! an intruder; the executors turn it into CPU seconds
//! ([`crate::pipeline::cost`]) and resource requests (the `simulate` kind's
//! [`StageKind::plan`](crate::pipeline::StageKind::plan)).

use crate::pipeline::stage::Work;
use crate::sim::engine::Kicks;
use crate::sim::{Drive, ForceMode, SimConfig, enskog, run::drive};

/// Planned work of a `simulate` stage: N, the frames it keeps, its collisions
/// (N x (collision rate per disk) / 2 x (relaxation + production) x the heating
/// factor [`heating`], plus up to ~100 per disk for the compression), the
/// drive's kicks (its rate x the same time) and the intruder's force kicks (one
/// every 1 / (kick_rate_factor omega_E), as the run spaces them).
/// The rate per disk is the Enskog frequency at the drive's T times the measured
/// ratio of the real rate to it (docs/sim.md: 1.01 at phi = 0.60 up to 1.46 at 0.805).
pub fn planned_work(cfg: &SimConfig) -> Work {
    let nf = cfg.n as f64;
    let omega = bath_enskog(cfg, cfg.temperature);
    let frames = cfg.schedule.times().len() as u64;
    let time = cfg.relax_time + cfg.schedule.end();
    // omega counts collisions per disk; each collision involves two disks.
    // The compression from phi = 0.3 takes ~100 collisions per disk up to the
    // dense states (docs/sim.md), none at phi <= 0.3.
    let compression = 100.0 * ((cfg.phi - 0.3) / 0.5).clamp(0.0, 1.0);
    let at_t = nf * omega / 2.0 * enskog_ratio(cfg.phi) * time;
    let (collisions, forced_collisions, layer_collisions) = if cfg.drive == Drive::None {
        let c = at_t * haff(cfg, omega * time)
            + nf * compression
            + (at_t + nf * compression) * 4.0 * collapse(cfg);
        (c, 0.0, 0.0)
    } else {
        let c = 1.0 + 2.5 * collapse(cfg);
        let h = heating(cfg);
        let forced = at_t * (h - 1.0) * c;
        let layer = forced * (layer_collapse(cfg) - 1.0);
        (
            (at_t * h + nf * compression) * c + layer,
            forced + layer,
            layer,
        )
    };
    // An undriven or elastic run (zero kick amplitude) kicks nothing.
    let (kicks, kick_rate, _) = drive(cfg, omega);
    let kick_rate = if kicks == Kicks::Off { 0.0 } else { kick_rate };
    let force_kicks = match &cfg.intruder {
        Some(i) if i.force_mode == ForceMode::Kicks && i.force > 0.0 => {
            time * i.kick_rate_factor * omega
        }
        _ => 0.0,
    };
    Work {
        n: cfg.n as u64,
        phi: cfg.phi,
        collisions,
        forced_collisions,
        layer_collisions,
        drive_kicks: kick_rate * time,
        force_kicks,
        frames,
    }
}

/// The Enskog collision frequency per disk of the bath's two species at
/// temperature `t` (an intruder, species 2, is left out, as in the run).
fn bath_enskog(cfg: &SimConfig, t: f64) -> f64 {
    let large = cfg.n_large() as f64 / cfg.n as f64;
    enskog::collision_frequency(
        cfg.phi,
        &cfg.radii()[..2],
        &cfg.species_masses()[..2],
        &[1.0 - large, large],
        t,
    )
}

/// The factor by which a pulled intruder multiplies the bath's collisions: the
/// work F v heats the bath (T ~ 10^2 at F ~ 3 x 10^3, N = 500) and compacts the
/// disks ahead of it, where collisions come fast and carry little energy.
///
/// In linear response v = F / zeta, and the heating per disk F^2 / (zeta N)
/// over the bath's cooling rate gamma_eff reaches T when F ~ F_h =
/// C sqrt(N T gamma_eff): the collisions grow as (F / F_h)^2 from there, and
/// as (F / F_h)^(1/2) once the compacted layer ahead of the intruder sets the
/// rate, past x = F / F_h ~ 13. The cooling rate is the friction gamma plus the
/// collisions' share (1 - eps^2) omega_E / 4; without friction (paper I's
/// front, pushed into a closed box) only collisions cool, and those of the
/// compacted layer carry little energy: there the share is 50 times smaller
/// (measured: the front's bath makes 450 times its collisions at rest, at a
/// mean T of 1.07 against the drive's 0.1). The constants are fitted to the recorded runs of the ci
/// and small profiles (docs/measurements.md, 2026-11-26: x = 3 gives a factor
/// 10, x = 10 about 50, x = 172 (F = 10^4, T = 0.04) 580, the front (F = 500,
/// gamma = 0) about 450); `repro plan --check` compares every recorded
/// configuration with its plan.
///
/// With friction, in the steady state, a strong force meets a ceiling
/// [`forced_ceiling`]: the factor is (h^-2 + ceiling^-2)^(-1/2) of the growth
/// h above.
pub fn heating(cfg: &SimConfig) -> f64 {
    let Some(x) = pull(cfg) else { return 1.0 };
    let growth = |x_layer: f64| 1.0 + x * x / (1.0 + (x / x_layer).powf(1.5));
    // The ceiling is the steady state's: a run that starts the force at rest
    // and hardly relaxes (paper I's path, relax_tau = 10^-6) sees the layer
    // form, not jam (N = 2000, phi = 0.8: 660 times the rest rate).
    let steady = cfg.relax_time >= 0.1 * (cfg.relax_time + cfg.schedule.end());
    if cfg.gamma > 0.0 && steady {
        // In the steady state the layer sets the rate earlier in a denser bath:
        // x = 5 at phi = 0.8 (log-linear from 13 at 0.7). At eps = 0.9, phi =
        // 0.8 and T = 1 the collisions grew as F^(1/2) from F = 3162 (x ~ 9)
        // on: 22, 41, 73 and 129 times the rest rate at F = 3162-10^5
        // (docs/measurements.md, 2026-11-27). A cold bath's rest rate is
        // lower, so the layer takes over later: the shift scales with sqrt(T)
        // (T = 0.04 at 0.775 grew as before).
        let dense = ((cfg.phi - 0.7) / 0.1).clamp(0.0, 1.0) * cfg.temperature.sqrt().min(1.0);
        let h = growth(13.0 * (5.0f64 / 13.0).powf(dense));
        let c = forced_ceiling(cfg);
        (h.powi(-2) + c.powi(-2)).powf(-0.5)
    } else {
        growth(13.0)
    }
}

/// How hard a pulling force drives the bath: x = F / F_h of [`heating`], None
/// without a force.
fn pull(cfg: &SimConfig) -> Option<f64> {
    let i = cfg.intruder.as_ref().filter(|i| i.force > 0.0)?;
    let t = cfg.temperature;
    let share = if cfg.gamma > 0.0 { 1.0 } else { 1.0 / 50.0 };
    let gamma_eff = cfg.gamma + share * (1.0 - cfg.eps * cfg.eps) * bath_enskog(cfg, t) / 4.0;
    let f_h = 12.0 * (cfg.n as f64 * t * gamma_eff).sqrt();
    Some(i.force / f_h)
}

/// The factor by which the compacted layer ahead of a strongly pulled intruder
/// multiplies the force's collisions in a more inelastic bath: the layer
/// collapses (at eps = 0.7 and F = 8192, N = 500, the guard acts on 10-25% of
/// the collisions), and the collisions repeat among a few disks. Measured on
/// the small profile's eps = 0.7 runs (docs/measurements.md, 2026-11-27): the
/// geometric mean over phi 0.3-0.8 of measured over planned collisions was 0.9
/// at F = 512 (x ~ 1.4), 3.8 at 2048 (x ~ 6) and 6.8 at 8192 (x ~ 22),
/// scattered by 2-4 between phi; 1 + 1.7 ln(x / 1.4) from x = 1.4 on puts the
/// CPU time of the most phi within a factor 2. None at eps = 0.9, where the planned
/// collisions already match; linear in eps between, kept at 0.7's below it,
/// where nothing was measured.
fn layer_collapse(cfg: &SimConfig) -> f64 {
    let Some(x) = pull(cfg) else { return 1.0 };
    let inelastic = ((0.9 - cfg.eps) / 0.2).clamp(0.0, 1.0);
    1.0 + inelastic * 1.7 * (x / 1.4).ln().max(0.0)
}

/// The most a strong force multiplies the collisions of a bath with friction:
/// however hard it pulls (F = 3 x 10^4 - 10^5, the bath's T up to 10^4 times
/// the drive's), the collisions per disk and unit time level off, the lower
/// the denser: the layer ahead of the intruder jams. Measured on the small
/// profile's runs (N = 500, docs/measurements.md, 2026-11-26) at eps = 0.9
/// and the drive's T = 1: about 700-1000 times the rest rate up to phi = 0.7,
/// 140 at 0.775, 100 at 0.8; so 1000 up to 0.7, falling log-linearly to 100
/// at 0.8. The ceiling is on the rate, not on the factor: at the drive's T =
/// 0.04 (rest rate sqrt(0.04) = 0.2 of T = 1's) the factor at 0.775 reached
/// 550, i.e. 1 / sqrt(T). It grows with the dissipation as (1 - eps^2) / 0.19
/// (eps = 0.7 at 0.8 reached 280 where eps = 0.9 levels off at 100; one
/// configuration each), and is kept at eps = 0.9's for more elastic baths,
/// where nothing was measured.
fn forced_ceiling(cfg: &SimConfig) -> f64 {
    let dense = ((cfg.phi - 0.7) / 0.1).max(0.0);
    let at_eps09 = 1000.0 * 0.1f64.powf(dense);
    let dissipation = ((1.0 - cfg.eps * cfg.eps) / 0.19).max(1.0);
    at_eps09 * dissipation / cfg.temperature.max(1e-12).sqrt()
}

/// The fraction of an undriven run's collisions at the starting rate that
/// free cooling leaves: Haff's law T = T0 / (1 + t / t0)^2 with 1 / t0 = (1 -
/// eps^2) omega / 8 leaves ln(1 + x) / x of omega t, x = (1 - eps^2) omega t / 8.
fn haff(cfg: &SimConfig, omega_t: f64) -> f64 {
    let x = (1.0 - cfg.eps * cfg.eps) * omega_t / 8.0;
    if x > 1e-9 { x.ln_1p() / x } else { 1.0 }
}

/// Dense, very inelastic runs collapse into clusters whose collisions only the
/// guard (collapse_tc) bounds: log10(1e-4 / tc) at eps <= 0.1 and phi >= 0.8,
/// falling linearly to nothing at eps = 0.6 and at phi = 0.55. The extra
/// collisions are 4 times it of the plan without collapse when undriven, 2.5
/// times when driven. Fitted to the stability-collapse runs of the small
/// profile (N = 2000, eps 0.1-1, phi 0.3-0.8, tc 1e-7-1e-5; docs/measurements.md).
fn collapse(cfg: &SimConfig) -> f64 {
    let decades = if cfg.collapse_tc > 0.0 {
        (1e-4 / cfg.collapse_tc).log10().clamp(0.0, 4.0)
    } else {
        4.0
    };
    let inelastic = ((0.6 - cfg.eps) / 0.5).clamp(0.0, 1.0);
    let dense = ((cfg.phi - 0.55) / 0.25).clamp(0.0, 1.0);
    decades * inelastic * dense
}

/// Measured collision rate over the Enskog frequency at the measured T, by phi
/// (docs/sim.md, N = 4000, eps = 0.9); linear between, the end values outside.
fn enskog_ratio(phi: f64) -> f64 {
    const R: &[(f64, f64)] = &[
        (0.60, 1.007),
        (0.65, 1.012),
        (0.70, 1.033),
        (0.72, 1.048),
        (0.74, 1.067),
        (0.76, 1.105),
        (0.78, 1.18),
        (0.79, 1.24),
        (0.80, 1.36),
        (0.805, 1.46),
    ];
    if phi <= R[0].0 {
        return R[0].1;
    }
    for w in R.windows(2) {
        if phi <= w[1].0 {
            let f = (phi - w[0].0) / (w[1].0 - w[0].0);
            return w[0].1 + f * (w[1].1 - w[0].1);
        }
    }
    R[R.len() - 1].1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(drive: Drive, eps: f64, phi: f64, tc: f64) -> SimConfig {
        SimConfig {
            drive,
            eps,
            phi,
            collapse_tc: tc,
            ..SimConfig::default()
        }
    }

    /// Haff's law: no cooling without dissipation, and a cooled run makes
    /// ln(1 + x) / x of the collisions it would at the starting rate.
    #[test]
    fn free_cooling_follows_haffs_law() {
        assert_eq!(haff(&cfg(Drive::None, 1.0, 0.7, 1e-6), 1000.0), 1.0);
        let h = haff(&cfg(Drive::None, 0.6, 0.7, 1e-6), 100.0);
        let x: f64 = 0.64 * 100.0 / 8.0;
        assert!((h - (1.0 + x).ln() / x).abs() < 1e-12, "{h}");
        // Slow cooling (eps -> 1): the first-order loss x / 2.
        let slow = haff(&cfg(Drive::None, 0.9999, 0.7, 1e-6), 10.0);
        assert!(
            (1.0 - slow - 0.5 * 2e-4 * 10.0 / 8.0).abs() < 1e-6,
            "{slow}"
        );
    }

    /// Collapse adds collisions only to dense, very inelastic runs, more the
    /// later the guard steps in (smaller collapse_tc).
    #[test]
    fn collapse_needs_density_and_dissipation() {
        assert_eq!(collapse(&cfg(Drive::None, 0.7, 0.8, 1e-7)), 0.0);
        assert_eq!(collapse(&cfg(Drive::None, 0.1, 0.5, 1e-7)), 0.0);
        let (a, b) = (
            collapse(&cfg(Drive::None, 0.1, 0.8, 1e-5)),
            collapse(&cfg(Drive::None, 0.1, 0.8, 1e-7)),
        );
        assert!(
            (a - 1.0).abs() < 1e-12 && (b - 3.0).abs() < 1e-12,
            "{a} {b}"
        );
        let undriven = planned_work(&cfg(Drive::None, 0.1, 0.8, 1e-7)).collisions;
        let driven = planned_work(&cfg(Drive::NeighbourPairs, 0.1, 0.8, 1e-7)).collisions;
        assert!(undriven > 0.0 && driven > 0.0);
    }

    /// A strong force's collisions level off, lower the denser the bath, at a
    /// rate (not a factor) fixed by phi: a colder drive allows a larger factor.
    #[test]
    fn a_strong_force_meets_a_ceiling_lower_the_denser() {
        let ceiling = |eps: f64, phi: f64, t: f64| {
            forced_ceiling(&SimConfig {
                eps,
                phi,
                temperature: t,
                ..SimConfig::default()
            })
        };
        assert!((ceiling(0.9, 0.6, 1.0) - 1000.0).abs() < 1e-9);
        assert!((ceiling(0.9, 0.8, 1.0) - 100.0).abs() < 1e-9);
        assert!((ceiling(0.9, 0.8, 0.04) - 500.0).abs() < 1e-9);
        assert!(ceiling(0.7, 0.8, 1.0) > 250.0);
        assert!((ceiling(1.0, 0.8, 1.0) - 100.0).abs() < 1e-9);
        // Under the ceiling the growth is untouched; far above it, it is the ceiling.
        let pulled = |force: f64| SimConfig {
            eps: 0.9,
            phi: 0.8,
            gamma: 1.0,
            n: 500,
            intruder: Some(crate::sim::config::Intruder::paper(force)),
            ..SimConfig::default()
        };
        let weak = heating(&pulled(100.0));
        assert!(weak > 1.0 && weak < 1.5, "{weak}");
        let strong = heating(&pulled(1e7));
        assert!((strong / 100.0 - 1.0).abs() < 0.01, "{strong}");
        let w = planned_work(&pulled(1e5));
        assert!(w.forced_collisions > 0.9 * w.collisions && w.forced_collisions < w.collisions);
    }

    /// The layer ahead of a pulled intruder collapses only in an inelastic bath
    /// and under a strong force; its collisions are part of the force's.
    #[test]
    fn only_an_inelastic_bath_under_a_strong_force_collapses_ahead_of_the_intruder() {
        let pulled = |eps: f64, force: f64| SimConfig {
            eps,
            phi: 0.6,
            gamma: 1.0,
            n: 500,
            intruder: Some(crate::sim::config::Intruder::paper(force)),
            ..SimConfig::default()
        };
        assert_eq!(layer_collapse(&pulled(0.9, 1e5)), 1.0);
        assert_eq!(layer_collapse(&pulled(0.7, 10.0)), 1.0);
        let (weak, strong) = (
            layer_collapse(&pulled(0.7, 2048.0)),
            layer_collapse(&pulled(0.7, 8192.0)),
        );
        assert!(weak > 1.5 && strong > weak, "{weak} {strong}");
        // Four times the force adds 1.7 ln 4 to the factor.
        assert!((strong - weak - 1.7 * 4f64.ln()).abs() < 1e-9);
        let w = planned_work(&pulled(0.7, 8192.0));
        assert!(w.layer_collisions > 0.0 && w.layer_collisions < w.forced_collisions);
        assert_eq!(planned_work(&pulled(0.9, 8192.0)).layer_collisions, 0.0);
    }
}
