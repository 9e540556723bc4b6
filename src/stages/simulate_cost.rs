//! What a simulation is planned to cost, from its configuration alone: the
//! [`Work`] it does (disks, stored frames, collisions with the measured
//! collision rate over Enskog's and the bath's heating by a pulling force,
//! kicks of the drive and force kicks of an intruder), its CPU seconds at the
//! measured speeds and its memory. The `simulate` kind is registered with
//! [`planned`] as its cost model (`stages::register`): the executors' time
//! limits and memory requests, `repro plan` and the progress estimate read
//! it. The simulate kind's own code does not call it, so a recalibration is in
//! no key and reruns nothing.

use crate::pipeline::Planned;
use crate::sim::engine::Kicks;
use crate::sim::{Drive, ForceMode, SimConfig, enskog, run::drive};

/// What a simulation is planned to do: what its CPU seconds and memory are
/// computed from ([`simulation_seconds`], [`memory_bytes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Work {
    /// Disks.
    pub n: u64,
    /// Packing fraction (a collision costs more near jamming).
    pub phi: f64,
    /// Planned collisions (compression, relaxation and production), with the
    /// bath's heating by a pulling force.
    pub collisions: f64,
    /// The part of `collisions` that a pulling force adds by heating the bath:
    /// they happen in the hot, compacted layer around the intruder, where a
    /// collision costs what one at 0.65-0.805 does whatever the mean packing.
    pub forced_collisions: f64,
    /// The part of `forced_collisions` in a collapsing layer ahead of the
    /// intruder (inelastic baths): repeated collisions among a few disks, which
    /// cost half a dense collision.
    pub layer_collisions: f64,
    /// Kicks of the drive (single disks or pairs).
    pub drive_kicks: f64,
    /// Momentum kicks of a pulled intruder (`force_mode: kicks`).
    pub force_kicks: f64,
    /// Frames the trajectory keeps in memory until it is written.
    pub frames: u64,
}

/// The cost model of the `simulate` kind ([`crate::pipeline::Registry::register_planned`]).
pub fn planned(run: &super::run_length::Run) -> Planned {
    let w = planned_work(&run.config);
    Planned {
        cpu_seconds: simulation_seconds(&w),
        memory_bytes: memory_bytes(&w),
        output_bytes: trajectory_bytes(&w),
        counts: vec![
            ("N", w.n as f64),
            ("collisions", w.collisions),
            ("kicks", w.drive_kicks),
            ("force kicks", w.force_kicks),
        ],
    }
}

/// Engine memory per disk, measured at N = 10^4 to 4 x 10^6: 195-198 bytes
/// (docs/measurements.md, 2026-11-22).
pub const ENGINE_BYTES_PER_DISK: f64 = 198.0;
/// A stored frame holds x and y (f64) per disk; writing the Parquet holds a
/// second, encoded copy of about the same size.
pub const FRAME_BYTES_PER_DISK: f64 = 2.0 * 16.0;

/// Peak memory of a simulation doing `w` beyond the process's baseline: the
/// engine's and the frames it keeps until they are written.
pub fn memory_bytes(w: &Work) -> f64 {
    w.n as f64 * (ENGINE_BYTES_PER_DISK + w.frames as f64 * FRAME_BYTES_PER_DISK)
}

/// Bytes a simulation's trajectory is planned to hold: x and y (f64) per disk
/// and frame (what a stage reading it reads, before it exists).
pub fn trajectory_bytes(w: &Work) -> u64 {
    w.n * w.frames * 16
}

/// Measured driven collisions per CPU second at phi = 0.78 (docs/measurements.md,
/// `repro bench` at 10^4 disks and more, 2026-11-22 and 11-23, the lower end of
/// each range; 10^3: the recorded runs of N = 500-4000, 2026-11-26): (N, rate).
const SPEED: &[(f64, f64)] = &[
    (1e3, 1.3e6),
    (1e4, 1.0e6),
    (1e5, 0.75e6),
    (1e6, 0.46e6),
    (4e6, 0.40e6),
];

/// CPU seconds per kick of the drive and per force kick of an intruder, and per
/// disk of a stored frame (the Parquet encoding and write), fitted by least
/// squares to the recorded simulations of the ci profile (docs/measurements.md,
/// 2026-11-26): a kick draws random numbers and repredicts its disks' events; a
/// force kick repredicts the intruder's only.
pub const SECONDS_PER_DRIVE_KICK: f64 = 0.35e-6;
pub const SECONDS_PER_FORCE_KICK: f64 = 0.15e-6;
pub const SECONDS_PER_FRAME_DISK: f64 = 0.15e-6;

/// Collisions per CPU second at N disks: log-linear between the measured sizes,
/// the end values outside them.
pub fn collisions_per_second(n: f64) -> f64 {
    if n <= SPEED[0].0 {
        return SPEED[0].1;
    }
    for w in SPEED.windows(2) {
        let ((n0, r0), (n1, r1)) = (w[0], w[1]);
        if n <= n1 {
            let f = (n / n0).ln() / (n1 / n0).ln();
            return r0 + f * (r1 - r0);
        }
    }
    SPEED[SPEED.len() - 1].1
}

/// How much more a collision costs at packing fraction `phi` than at 0.65-0.805,
/// from the recorded runs of the small profile (docs/measurements.md,
/// 2026-11-26).
///
/// Near jamming a collision comes with more cell crossings and stale events:
/// 1 + 0.43 (phi - 0.805) / (0.845 - phi), about 1.3 at 0.82 and 4 at 0.84
/// (driven and elastic runs of N = 2000 at 0.84 took 3-7 times the collisions'
/// cost at 0.78).
///
/// In a dilute fluid a disk crosses cells and leaves its neighbour shell
/// several times between two collisions, the more the longer its free path,
/// ~ 1 / (phi g(phi)) with the contact value g of Henderson's equation of state:
/// 1 + 0.5 (r(phi) - r(0.65)), r the free path over its value at 0.7; about
/// 1.3 at 0.6, 2 at 0.5 and 5.4 at 0.3 (elastic runs of N = 4000-16000 at
/// 0.3 took 5-10 times the plan without it, and pulled intruders at eta = 0.3
/// 4-9 times).
pub fn density_factor(phi: f64) -> f64 {
    let p = phi.min(0.8425);
    let jamming = 1.0 + 0.43 * ((p - 0.805) / (0.845 - p)).max(0.0);
    let free_path = |f: f64| {
        let g = (1.0 - 7.0 * f / 16.0) / (1.0 - f).powi(2);
        1.0 / (f * g)
    };
    let dilute = if phi > 0.0 && phi < 0.65 {
        let r = |f: f64| free_path(f) / free_path(0.7);
        1.0 + 0.5 * (r(phi) - r(0.65))
    } else {
        1.0
    };
    jamming * dilute
}

/// What a collision of a pulled intruder's collapsing layer costs, in dense
/// collisions: the eps = 0.7 runs at F = 2048-8192 (N = 500), where most
/// collisions are the layer's, made 2.0-2.5 x 10^6 collisions per CPU s where
/// a dense collision's rate is 1.3 x 10^6 (docs/measurements.md, 2026-11-27).
const LAYER_COST: f64 = 0.5;

/// Planned CPU seconds of a simulation doing `w`. The collisions a pulling
/// force adds cost what a collision at 0.65-0.805 does, whatever the mean
/// packing: the recorded heated runs (N = 500-2000, F = 3 x 10^3 - 10^5) made
/// 0.8-2.1 x 10^6 collisions per CPU s at every phi from 0.3 to 0.8, where the
/// dilute factor would say 0.24 x 10^6 at 0.3 (docs/measurements.md).
pub fn simulation_seconds(w: &Work) -> f64 {
    let n = w.n as f64;
    let at_rest = w.collisions - w.forced_collisions;
    let forced = w.forced_collisions - w.layer_collisions + LAYER_COST * w.layer_collisions;
    (at_rest * density_factor(w.phi) + forced) / collisions_per_second(n)
        + w.drive_kicks * SECONDS_PER_DRIVE_KICK
        + w.force_kicks * SECONDS_PER_FORCE_KICK
        + n * w.frames as f64 * SECONDS_PER_FRAME_DISK
}

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

    #[test]
    fn speed_interpolates_between_measured_sizes() {
        assert_eq!(collisions_per_second(500.0), 1.3e6);
        assert_eq!(collisions_per_second(1e4), 1.0e6);
        assert_eq!(collisions_per_second(1e6), 0.46e6);
        assert_eq!(collisions_per_second(1e7), 0.40e6);
        let mid = collisions_per_second(10f64.powf(5.5));
        assert!((mid - 0.605e6).abs() < 1.0, "{mid}");
    }

    #[test]
    fn every_kind_of_work_adds_its_measured_cost() {
        let w = Work {
            n: 1_000_000,
            phi: 0.78,
            collisions: 0.46e6 * 3600.0,
            forced_collisions: 0.0,
            layer_collisions: 0.0,
            drive_kicks: 0.0,
            force_kicks: 0.0,
            frames: 0,
        };
        assert!((simulation_seconds(&w) - 3600.0).abs() < 1e-6);
        let more = Work {
            drive_kicks: 1e6,
            force_kicks: 1e6,
            frames: 10,
            ..w
        };
        let extra =
            1e6 * (SECONDS_PER_DRIVE_KICK + SECONDS_PER_FORCE_KICK) + 1e7 * SECONDS_PER_FRAME_DISK;
        assert!((simulation_seconds(&more) - 3600.0 - extra).abs() < 1e-6);
        // Near jamming and in a dilute fluid a collision costs more.
        let dense = Work { phi: 0.84, ..w };
        let f = simulation_seconds(&dense) / 3600.0;
        assert!((f - density_factor(0.84)).abs() < 1e-9);
        let dilute = Work { phi: 0.3, ..w };
        assert!((simulation_seconds(&dilute) / 3600.0 - density_factor(0.3)).abs() < 1e-9);
        // A force's collisions, in the compacted layer, cost a dense one's.
        let forced = Work {
            forced_collisions: w.collisions,
            ..dilute
        };
        assert!((simulation_seconds(&forced) - 3600.0).abs() < 1e-6);
        // Those of a collapsing layer cost half that.
        let layer = Work {
            layer_collisions: w.collisions,
            ..forced
        };
        assert!((simulation_seconds(&layer) - 1800.0).abs() < 1e-6);
    }

    #[test]
    fn a_collision_costs_most_near_jamming_and_in_a_dilute_fluid() {
        // One between 0.65 and 0.805, continuous at both ends.
        for phi in [0.65, 0.7, 0.78, 0.805] {
            assert!((density_factor(phi) - 1.0).abs() < 1e-12, "{phi}");
        }
        assert!((density_factor(0.6499999) - 1.0).abs() < 1e-5);
        // The measured excess: ~4 at 0.84, ~1.3 at 0.82; ~5 at 0.3, ~2 at 0.5.
        assert!(
            (3.5..4.5).contains(&density_factor(0.84)),
            "{}",
            density_factor(0.84)
        );
        assert!((1.2..1.4).contains(&density_factor(0.82)));
        assert!(
            (4.5..6.0).contains(&density_factor(0.3)),
            "{}",
            density_factor(0.3)
        );
        assert!(
            (1.7..2.3).contains(&density_factor(0.5)),
            "{}",
            density_factor(0.5)
        );
        // Rising away from the middle, finite past jamming.
        assert!(density_factor(0.4) > density_factor(0.5));
        assert!(density_factor(0.86).is_finite() && density_factor(0.86) >= density_factor(0.84));
    }
}
