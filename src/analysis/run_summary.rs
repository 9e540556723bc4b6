//! What a simulation measured about itself, as one table row: the stability
//! maps of the simulator (docs/stability.md) read temperatures against their
//! target, collision rates against the Enskog estimate, collapse-guard
//! activations per collision, energy ledgers and overlaps from here.
//!
//! Inputs are a run's summary (the `simulate` stage's JSON, whose machine
//! timings are not in it), its configuration and its frames.

use anyhow::{Context, Result};
use serde_json::Value;

use crate::sim::SimConfig;
use crate::sim::enskog;
use crate::traj::Trajectory;

/// Paper H's collision frequency, omega = 2.59 phi G_c / sqrt(pi) sqrt(T) =
/// 1.46 phi G_c sqrt(T), with G_c taken as Henderson's one-species contact
/// value (1 - 7 phi / 16) / (1 - phi)^2 (the paper does not define it further).
pub fn paper_collision_rate(phi: f64, t: f64) -> f64 {
    let g = (1.0 - 7.0 * phi / 16.0) / (1.0 - phi).powi(2);
    2.59 / std::f64::consts::PI.sqrt() * phi * g * t.sqrt()
}

/// Enskog's compressibility factor of an inelastic disk mixture, Z_E = P A / (N T)
/// = 1 + (1 + eps)/2 (pi/2) n sum_ij x_i x_j sigma_ij^2 g_ij, with sigma_ij =
/// r_i + r_j, n the number density and g_ij the contact values of
/// [`enskog::contact_value`] (Jenkins-Mancini; Henderson's for one species,
/// where Z_E = 1 + (1 + eps) phi g(sigma)). The collisional virial of a pair at
/// contact carries (1 + eps)/2 of the elastic momentum transfer.
pub fn enskog_compressibility(phi: f64, eps: f64, radii: &[f64], fractions: &[f64]) -> f64 {
    let area: f64 = fractions
        .iter()
        .zip(radii)
        .map(|(x, r)| x * std::f64::consts::PI * r * r)
        .sum();
    let n = phi / area;
    let mut sum = 0.0;
    for i in 0..radii.len() {
        for j in 0..radii.len() {
            let sig = radii[i] + radii[j];
            sum += fractions[i]
                * fractions[j]
                * sig
                * sig
                * enskog::contact_value(phi, radii, fractions, i, j);
        }
    }
    1.0 + 0.5 * (1.0 + eps) * std::f64::consts::FRAC_PI_2 * n * sum
}

/// The closest approach of two disks in any frame, r_ij - sigma_ij (units of
/// the small radius; negative: the largest overlap), from a cell list of width
/// the largest contact distance.
pub fn closest_gap(traj: &Trajectory) -> f64 {
    let [lx, ly] = traj.box_size;
    let rmax = traj.radii.iter().copied().fold(0.0, f64::max);
    let w = 2.0 * rmax;
    let (ncx, ncy) = (
        ((lx / w).floor() as usize).max(1),
        ((ly / w).floor() as usize).max(1),
    );
    let image = |d: f64, l: f64, periodic: bool| {
        if periodic { d - l * (d / l).round() } else { d }
    };
    let mut worst = f64::INFINITY;
    for f in &traj.frames {
        let n = f.x.len();
        let wrap = |v: f64, l: f64| v - l * (v / l).floor();
        let pos: Vec<[f64; 2]> = (0..n)
            .map(|i| [wrap(f.x[i], lx), wrap(f.y[i], ly)])
            .collect();
        let mut cells: Vec<Vec<u32>> = vec![Vec::new(); ncx * ncy];
        let cell = |p: [f64; 2]| {
            (
                ((p[0] / lx * ncx as f64) as usize).min(ncx - 1),
                ((p[1] / ly * ncy as f64) as usize).min(ncy - 1),
            )
        };
        for (i, p) in pos.iter().enumerate() {
            let (cx, cy) = cell(*p);
            cells[cy * ncx + cx].push(i as u32);
        }
        for (i, p) in pos.iter().enumerate() {
            let (cx, cy) = cell(*p);
            let ri = traj.radii[traj.species[i] as usize];
            // Every neighbouring cell once, also when the box is under 3 cells wide.
            let mut seen = Vec::with_capacity(9);
            for dy in [ncy - 1, 0, 1] {
                for dx in [ncx - 1, 0, 1] {
                    let c = ((cy + dy) % ncy) * ncx + (cx + dx) % ncx;
                    if seen.contains(&c) {
                        continue;
                    }
                    seen.push(c);
                    for &j in &cells[c] {
                        let j = j as usize;
                        if j <= i {
                            continue;
                        }
                        let dx = image(p[0] - pos[j][0], lx, traj.periodic[0]);
                        let dy = image(p[1] - pos[j][1], ly, traj.periodic[1]);
                        let sigma = ri + traj.radii[traj.species[j] as usize];
                        worst = worst.min((dx * dx + dy * dy).sqrt() - sigma);
                    }
                }
            }
        }
    }
    worst
}

/// The run's samples of T and P as (time from the start of production,
/// negative during the relaxation; T; P).
fn run_samples(summary: &Value) -> Result<Vec<[f64; 3]>> {
    let series = summary
        .get("series")
        .and_then(Value::as_array)
        .context("the run summary has no `series` of samples")?;
    series
        .iter()
        .map(|s| {
            let n = |k: &str| {
                s.get(k)
                    .and_then(Value::as_f64)
                    .with_context(|| format!("a sample of the run summary has no number `{k}`"))
            };
            Ok([n("time")?, n("temperature")?, n("pressure")?])
        })
        .collect()
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, k) = v.fold((0.0, 0.0), |(s, k), x| (s + x, k + 1.0));
    s / k
}

/// Stationarity of T and P (column k of [`run_samples`]): the relative change
/// between the two halves of production, and how far the last tenth of the
/// relaxation lies from the production mean (relative): a relaxation that
/// reached the steady state ends at 0 within the noise.
fn stationarity(s: &[[f64; 3]], k: usize) -> (f64, f64, f64) {
    let prod: Vec<&[f64; 3]> = s.iter().filter(|x| x[0] >= 0.0).collect();
    let relax: Vec<&[f64; 3]> = s.iter().filter(|x| x[0] < 0.0).collect();
    let m = mean(prod.iter().map(|x| x[k]));
    let h = prod.len() / 2;
    let drift = (mean(prod[h..].iter().map(|x| x[k])) - mean(prod[..h].iter().map(|x| x[k]))) / m;
    let tail = relax.len() - relax.len() / 10;
    let end = mean(
        relax[tail.min(relax.len().saturating_sub(1))..]
            .iter()
            .map(|x| x[k]),
    ) / m
        - 1.0;
    (m, drift, end)
}

/// The run's samples over the whole run, relaxation included: time (from the
/// start of production), T, P and both relative to their production means.
pub fn series(summary: &Value) -> Result<Vec<(&'static str, Vec<f64>)>> {
    let s = run_samples(summary)?;
    let (tm, _, _) = stationarity(&s, 1);
    let (pm, _, _) = stationarity(&s, 2);
    Ok(vec![
        ("time", s.iter().map(|x| x[0]).collect()),
        ("T", s.iter().map(|x| x[1]).collect()),
        ("P", s.iter().map(|x| x[2]).collect()),
        ("T_rel", s.iter().map(|x| x[1] / tm).collect()),
        ("P_rel", s.iter().map(|x| x[2] / pm).collect()),
    ])
}

fn number(summary: &Value, key: &str) -> Result<f64> {
    summary
        .get(key)
        .and_then(Value::as_f64)
        .with_context(|| format!("the run summary has no number `{key}`"))
}

/// One run as named numbers. `tolerance` is the relative deviation of T from
/// its target that still counts as held (column `T_held`).
pub fn row(
    summary: &Value,
    cfg: &SimConfig,
    traj: &Trajectory,
    tolerance: f64,
) -> Result<Vec<(&'static str, f64)>> {
    let t = number(summary, "temperature")?;
    let collisions = number(summary, "collisions")?;
    let guard = number(summary, "guard_activations")?;
    let rate = number(summary, "collision_rate")?;
    let nb = cfg.n as f64;
    let fractions = [1.0 - cfg.n_large() as f64 / nb, cfg.n_large() as f64 / nb];
    let (radii, masses) = (cfg.radii(), cfg.species_masses());
    let enskog_at =
        |t: f64| enskog::collision_frequency(cfg.phi, &radii[..2], &masses[..2], &fractions, t);
    let halves = summary
        .get("temperature_halves")
        .and_then(Value::as_array)
        .context("the run summary has no `temperature_halves`")?;
    let half = |k: usize| halves.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN);
    let target = cfg.temperature;
    let deviation = t / target - 1.0;
    let guard_fraction = guard / collisions.max(1.0);
    let warn = cfg.guard_warning(guard as u64, collisions as u64).is_some();
    let [lx, ly] = cfg.box_size();
    let s = run_samples(summary)?;
    let production = s.iter().filter(|x| x[0] >= 0.0).count().max(1) as f64;
    let (_, _, t_end) = stationarity(&s, 1);
    let (p_mean, p_drift, p_end) = stationarity(&s, 2);
    let z = number(summary, "z")?;
    let z_enskog = enskog_compressibility(cfg.phi, cfg.eps, &radii[..2], &fractions);
    Ok(vec![
        ("T", t),
        // The error of this run's mean T over its production samples, taken
        // as independent: once each run's kick rate is accounted for, runs
        // scatter as these errors say (stability-collapse's fit t_kick).
        // Runs of one state point differ by more: the balanced rule fixes each
        // run's kick rate from a short window of the relaxation, and T follows
        // it, so a comparison across runs needs replicas.
        (
            "T_err",
            number(summary, "temperature_std")? / production.sqrt(),
        ),
        ("T_target", target),
        ("T_over_target", t / target),
        ("T_deviation", deviation),
        ("T_held", f64::from(u8::from(deviation.abs() <= tolerance))),
        ("T_drift", half(1) - half(0)),
        ("T_relax_end", t_end),
        ("P", p_mean),
        ("P_drift", p_drift),
        ("P_relax_end", p_end),
        ("collision_rate", rate),
        ("enskog_rate", enskog_at(t)),
        ("rate_over_enskog", rate / enskog_at(t)),
        ("paper_rate", paper_collision_rate(cfg.phi, t)),
        ("rate_over_paper", rate / paper_collision_rate(cfg.phi, t)),
        ("kick_rate", number(summary, "kick_rate")?),
        (
            "kick_over_enskog_target",
            number(summary, "kick_rate")? / enskog_at(target),
        ),
        // Collisions per particle per unit time at unit temperature (they scale
        // as sqrt(T)): with Z, the equation of state of the driven fluid.
        ("rate_reduced", rate / t.sqrt()),
        ("z", z),
        ("z_enskog", z_enskog),
        ("z_over_enskog", z / z_enskog),
        ("collisions", collisions),
        ("guard_activations", guard),
        ("guard_fraction", guard_fraction),
        ("guard_warning", f64::from(u8::from(warn))),
        ("energy_drift", number(summary, "energy_balance_error")?),
        ("closest_gap", closest_gap(traj)),
        ("box_side", lx.max(ly)),
        ("box_precision", cfg.box_precision()),
        ("clock_precision", cfg.clock_precision()),
        ("last_time", cfg.last_time()),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::Frame;

    fn pair(dx: f64) -> Trajectory {
        Trajectory {
            box_size: [10.0, 10.0],
            periodic: [true, true],
            species: vec![0, 1],
            radii: vec![1.0, 1.5],
            masses: vec![1.0, 2.25],
            frames: vec![Frame {
                time: 0.0,
                // Across the periodic boundary: 0.2 and 10 - dx + 0.2.
                x: vec![0.2, 10.2 - dx],
                y: vec![5.0, 5.0],
                vx: vec![],
                vy: vec![],
            }],
            schedule: None,
        }
    }

    /// One species: Z_E = 1 + (1 + eps) phi g(sigma) with Henderson's contact
    /// value; elastic and dilute: the ideal gas.
    #[test]
    fn enskog_compressibility_is_hendersons_for_one_species() {
        let (phi, eps): (f64, f64) = (0.5, 0.9);
        let g = (1.0 - 7.0 * phi / 16.0) / (1.0 - phi).powi(2);
        let z = enskog_compressibility(phi, eps, &[1.0], &[1.0]);
        assert!((z - (1.0 + (1.0 + eps) * phi * g)).abs() < 1e-12, "{z}");
        assert!((enskog_compressibility(1e-9, 1.0, &[1.0, 1.4], &[0.5, 0.5]) - 1.0).abs() < 1e-8);
        // Two species of one size are one species.
        let two = enskog_compressibility(phi, eps, &[1.0, 1.0], &[0.3, 0.7]);
        assert!((two - z).abs() < 1e-12, "{two} {z}");
    }

    /// Production from t = 0 with P rising linearly from 1 to 1.2 (relative
    /// drift between the halves: 0.1 / 1.1) after a relaxation whose last
    /// tenth sits at 0.9, 2/11 below the production mean 1.1.
    #[test]
    fn stationarity_reads_the_drift_and_the_end_of_the_relaxation() {
        let mut s = Vec::new();
        for k in 0..100 {
            let t = -100.0 + k as f64;
            s.push([t, 1.0, if t < -10.0 { 0.5 } else { 0.9 }]);
        }
        for k in 0..1000 {
            let t = k as f64 / 1000.0;
            s.push([t * 100.0, 1.0, 1.0 + 0.2 * t]);
        }
        let (m, drift, end) = stationarity(&s, 2);
        assert!((m - 1.1).abs() < 1e-3, "{m}");
        assert!((drift - 0.1 / 1.1).abs() < 1e-3, "{drift}");
        assert!((end - (0.9 / m - 1.0)).abs() < 1e-12, "{end}");
        let (_, t_drift, t_end) = stationarity(&s, 1);
        assert!(t_drift.abs() < 1e-12 && t_end.abs() < 1e-12);
    }

    #[test]
    fn overlap_is_found_across_the_periodic_boundary() {
        // Contact distance 2.5: at 2.4 they overlap by 0.1, at 3 the gap is 0.5.
        assert!((closest_gap(&pair(2.4)) + 0.1).abs() < 1e-12);
        assert!((closest_gap(&pair(3.0)) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn the_paper_rate_is_the_enskog_rate_of_one_species_within_its_prefactor() {
        // One species of radius 1: omega_E = 2 n sigma g sqrt(pi T) with
        // n = phi/pi, sigma = 2: 4 phi g / sqrt(pi), against the paper's 2.59.
        let phi = 0.3;
        let one = enskog::collision_frequency(phi, &[1.0], &[1.0], &[1.0], 1.0);
        assert!((paper_collision_rate(phi, 1.0) / one - 2.59 / 4.0).abs() < 1e-12);
    }
}

#[cfg(test)]
mod limits {
    use super::*;
    use crate::sim::{KickRate, run};
    use crate::traj::Schedule;

    /// The dilute limit of the drive map: kicking at the Enskog rate holds
    /// T = 1 within 2%, and the measured collision rate is Enskog's.
    #[test]
    fn dilute_driven_disks_hold_the_target_at_the_enskog_rate() {
        let cfg = SimConfig {
            n: 1000,
            phi: 0.3,
            eps: 0.9,
            kick_rate: KickRate::Enskog { prefactor: 1.0 },
            relax_time: 30.0,
            schedule: Schedule {
                start: 0.0,
                origins: 1,
                origin_spacing: 1.0,
                lags: vec![100.0],
            },
            seed: 11,
            ..SimConfig::default()
        };
        let (traj, summary) = run(&cfg, &|_| {}).unwrap();
        let json = serde_json::to_value(&summary).unwrap();
        let row: std::collections::BTreeMap<_, _> =
            row(&json, &cfg, &traj, 0.02).unwrap().into_iter().collect();
        assert!((row["T_over_target"] - 1.0).abs() < 0.02, "{row:?}");
        assert_eq!(row["T_held"], 1.0);
        assert!((row["rate_over_enskog"] - 1.0).abs() < 0.03, "{row:?}");
        assert!(row["closest_gap"] > -1e-10, "{row:?}");
        assert_eq!(row["guard_warning"], 0.0);
        // T is the production mean: its error counts the production samples,
        // not the relaxation's.
        let production = summary.series.iter().filter(|s| s.time >= 0.0).count();
        assert!(production < summary.series.len());
        let expect = summary.temperature_std / (production as f64).sqrt();
        assert!((row["T_err"] - expect).abs() < 1e-12 * expect, "{row:?}");
    }
}

/// The clock after a long run: the time origin moves at each checkpoint.
#[cfg(test)]
mod late_clock {
    use super::closest_gap;
    use crate::sim::config::CONTACT_PRECISION;
    use crate::sim::engine::Engine;
    use crate::sim::{SimConfig, initial_state, run};
    use crate::traj::{Frame, Trajectory};

    fn quiet(_: crate::sim::Progress) {}

    /// The clock at t ~ 10^7: a driven dense fluid whose time origin is moved to
    /// 10^7 at a checkpoint runs on, checkpointing every 2 time units, with no
    /// pair closer than the contact precision in any frame (the exactness map's
    /// closest-gap check).
    #[test]
    fn the_clock_keeps_its_precision_at_ten_million() {
        let c = SimConfig {
            n: 2000,
            phi: 0.8,
            ..SimConfig::default()
        };
        let mut e = initial_state::prepare(&c, &quiet).unwrap();
        e.set_restitution(c.eps, c.collapse_tc);
        let (kicks, rate, p_dr) = run::drive(&c, 6.0);
        e.set_kicks(kicks, rate, p_dr);
        e.run_until(e.time() + 1.0, u64::MAX);
        let mut state = e.checkpoint(true).unwrap();
        state.shift_time(1e7);
        let mut e = Engine::restore(state).unwrap();
        let t0 = e.time();
        assert!(t0 > 1e7);
        let mut frames = Vec::new();
        for k in 1..=40 {
            let t = t0 + 0.25 * k as f64;
            assert!(e.run_until(t, u64::MAX));
            if k % 8 == 0 {
                e.checkpoint(false);
            }
            let (x, y) = e.unwrapped_positions();
            frames.push(Frame {
                time: t,
                x,
                y,
                vx: vec![],
                vy: vec![],
            });
        }
        assert!(e.stats().collisions > 100_000, "{:?}", e.stats());
        let traj = Trajectory {
            box_size: c.box_size(),
            periodic: [true, true],
            species: e.species().to_vec(),
            radii: c.radii(),
            masses: c.species_masses(),
            frames,
            schedule: None,
        };
        let gap = closest_gap(&traj);
        assert!(gap >= -CONTACT_PRECISION, "closest gap {gap:e} at t ~ 1e7");
    }
}
