//! Initial states: random disks at low density, Maxwellian velocities, then
//! Lubachevsky-Stillinger compression (radii grow while the disks collide
//! elastically) up to the requested packing fraction, without overlaps.

use super::progress::{Progress, Stage};
use crate::sim::engine::{Engine, Setup, rng_from_seed};
use crate::sim::events::pair_scan::nearest_image;
use crate::sim::model::config::SimConfig;
use anyhow::{Result, bail};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Packing fraction of the random start; random sequential addition reaches it
/// quickly (it jams only near 0.547).
const START_PHI: f64 = 0.3;

/// Place disks of radius `scale * radii[s]` at random without overlaps
/// (disk 0 at `first`, if given).
fn random_disks(
    box_size: [f64; 2],
    walls: [bool; 2],
    radii: &[f64],
    species: &[u8],
    scale: f64,
    first: Option<[f64; 2]>,
    rng: &mut ChaCha8Rng,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let w = 2.0 * radii.iter().copied().fold(0.0, f64::max) * scale;
    let ncx = ((box_size[0] / w).floor() as usize).max(1);
    let ncy = ((box_size[1] / w).floor() as usize).max(1);
    let (wx, wy) = (box_size[0] / ncx as f64, box_size[1] / ncy as f64);
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); ncx * ncy];
    let n = species.len();
    let (mut x, mut y) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let ri = radii[species[i] as usize] * scale;
        let mut placed = false;
        for _ in 0..100_000 {
            // Between walls the centres stay a radius away from them.
            let (px, py) = match first {
                Some(p) if i == 0 => (p[0], p[1]),
                _ => (
                    place(rng.random::<f64>(), box_size[0], walls[0], ri),
                    place(rng.random::<f64>(), box_size[1], walls[1], ri),
                ),
            };
            let cx = ((px / wx) as usize).min(ncx - 1);
            let cy = ((py / wy) as usize).min(ncy - 1);
            let mut free = true;
            'cells: for dy in [ncy - 1, 0, 1] {
                for dx in [ncx - 1, 0, 1] {
                    let c = ((cy + dy) % ncy) * ncx + (cx + dx) % ncx;
                    for &j in &grid[c] {
                        let j = j as usize;
                        let ddx = nearest_image(px - x[j], box_size[0]);
                        let ddy = nearest_image(py - y[j], box_size[1]);
                        let s = ri + radii[species[j] as usize] * scale;
                        if ddx * ddx + ddy * ddy < s * s {
                            free = false;
                            break 'cells;
                        }
                    }
                }
            }
            if free {
                x[i] = px;
                y[i] = py;
                grid[cy * ncx + cx].push(i as u32);
                placed = true;
                break;
            }
        }
        if !placed {
            bail!("could not place disk {i} at random at packing fraction {START_PHI}");
        }
    }
    Ok((x, y))
}

/// A coordinate from a uniform draw `u`: anywhere in [0, l) on a periodic
/// axis, in [r, l - r] between walls. (Overlap checks use the nearest image
/// on both kinds: across the walls it only rejects more placements.)
#[inline]
fn place(u: f64, l: f64, wall: bool, r: f64) -> f64 {
    if wall { r + u * (l - 2.0 * r) } else { u * l }
}

/// Gaussian velocities with zero total momentum and kinetic energy 1 per particle.
fn maxwell_velocities(
    masses: &[f64],
    species: &[u8],
    rng: &mut ChaCha8Rng,
) -> (Vec<f64>, Vec<f64>) {
    let n = species.len();
    let mut vx = Vec::with_capacity(n);
    let mut vy = Vec::with_capacity(n);
    for &s in species {
        let sd = 1.0 / masses[s as usize].sqrt();
        let (gx, gy): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
        vx.push(sd * gx);
        vy.push(sd * gy);
    }
    let mtot: f64 = species.iter().map(|&s| masses[s as usize]).sum();
    let (mut px, mut py) = (0.0, 0.0);
    for i in 0..n {
        px += masses[species[i] as usize] * vx[i];
        py += masses[species[i] as usize] * vy[i];
    }
    for i in 0..n {
        vx[i] -= px / mtot;
        vy[i] -= py / mtot;
    }
    let ke: f64 = (0..n)
        .map(|i| 0.5 * masses[species[i] as usize] * (vx[i] * vx[i] + vy[i] * vy[i]))
        .sum();
    let f = (n as f64 / ke).sqrt();
    for i in 0..n {
        vx[i] *= f;
        vy[i] *= f;
    }
    (vx, vy)
}

/// Rescale velocities so that the kinetic energy per particle is `t`.
pub fn set_temperature(e: &mut Engine, t: f64) {
    let ke = e.kinetic_energy();
    if ke > 0.0 {
        e.scale_velocities((t * e.n() as f64 / ke).sqrt());
    }
}

/// A held intruder's mass during the compression, in units of its own: the
/// disks bounce off it and it moves by ~1e-12 of their displacement.
const HOLD_MASS: f64 = 1e12;

/// An engine at `cfg.phi` with T = 1, no overlaps, elastic and undriven; its
/// clock reads the time spent compressing. An intruder with a chosen start is
/// held there (a huge mass) during the compression and left at rest.
pub fn prepare(cfg: &SimConfig, progress: &dyn Fn(Progress)) -> Result<Engine> {
    let (mut e, s0, first_at) = random_start(cfg)?;
    let masses = cfg.species_masses();
    if s0 < 1.0
        && let Some(phi) = compress(&mut e, cfg, s0, progress)?
    {
        bail!(
            "compression jammed at phi = {phi:.4} before reaching phi = {} (n = {}, compression_rate = {}): the Lubachevsky-Stillinger compression cannot reach it at this rate; lower compression_rate or phi",
            cfg.phi,
            cfg.n,
            cfg.compression_rate
        );
    }
    if let Some(p) = first_at {
        debug_assert!(p[0].is_finite());
        e.release_intruder(masses[2]);
    }
    e.sort_by_cell();
    Ok(e)
}

/// How far a Lubachevsky-Stillinger compression towards `cfg.phi` got.
#[derive(Clone, Debug, PartialEq)]
pub struct Compression {
    /// The packing fraction reached (`cfg.phi` unless it jammed).
    pub reached: f64,
    pub jammed: bool,
    /// Simulated time spent compressing and collisions on the way.
    pub time: f64,
    pub collisions: u64,
}

/// Compress towards `cfg.phi` as [`prepare`] does, but report where a jam
/// stopped it instead of failing: the compression limit of this rate and N.
pub fn compression_limit(cfg: &SimConfig, progress: &dyn Fn(Progress)) -> Result<Compression> {
    cfg.validate()?;
    let (mut e, s0, _) = random_start(cfg)?;
    let jam = if s0 < 1.0 {
        compress(&mut e, cfg, s0, progress)?
    } else {
        None
    };
    Ok(Compression {
        reached: jam.unwrap_or(cfg.phi),
        jammed: jam.is_some(),
        time: e.time(),
        collisions: e.stats().collisions,
    })
}

/// Random disks at min(phi, 0.3), scaled by s0 (returned) and Maxwellian
/// velocities; an intruder with a chosen start held there.
#[allow(clippy::type_complexity)]
fn random_start(cfg: &SimConfig) -> Result<(Engine, f64, Option<[f64; 2]>)> {
    let mut rng = rng_from_seed(cfg.seed);
    let radii = cfg.radii();
    let masses = cfg.species_masses();
    let nl = cfg.n_large();
    // The intruder, if any, is particle 0 (species 2), placed first.
    let first = usize::from(cfg.intruder.is_some());
    let species: Vec<u8> = (0..first)
        .map(|_| 2)
        .chain((0..cfg.n).map(|i| u8::from(i < nl)))
        .collect();
    let box_size = cfg.box_size();
    let phi0 = cfg.phi.min(START_PHI);
    let s0 = (phi0 / cfg.phi).sqrt();
    let start = cfg.intruder.as_ref().and_then(|i| i.start);
    let first_at = start.map(|f| [f[0] * box_size[0], f[1] * box_size[1]]);
    let (x, y) = random_disks(
        box_size, cfg.walls, &radii, &species, s0, first_at, &mut rng,
    )?;
    let (mut vx, mut vy) = maxwell_velocities(&masses, &species, &mut rng);
    let mut held = masses.clone();
    if start.is_some() {
        held[2] *= HOLD_MASS;
        (vx[0], vy[0]) = (0.0, 0.0);
    }
    let setup = Setup {
        lx: box_size[0],
        ly: box_size[1],
        walls: cfg.walls,
        radii,
        masses: held,
        species,
        x,
        y,
        vx,
        vy,
    };
    let mut e = Engine::new(setup, 1.0, 0.0, rng)?;
    if first == 1 {
        e.set_intruder(0);
    }
    Ok((e, s0, first_at))
}

/// Grow the radii from `s0` to 1 at `compression_rate`; `Some(phi)` when the
/// disks jammed at phi first (collisions pile up without the radii growing).
fn compress(
    e: &mut Engine,
    cfg: &SimConfig,
    s0: f64,
    progress: &dyn Fn(Progress),
) -> Result<Option<f64>> {
    let rate = cfg.compression_rate;
    e.set_growth(s0, rate);
    let t_end = e.time() + (1.0 - s0) / rate;
    let n = e.n() as u64;
    let clock = std::time::Instant::now();
    while e.time() < t_end {
        let stop = (e.time() + 1.0).min(t_end);
        let c0 = e.stats().collisions;
        while !e.run_until(stop, 1 << 20) {
            progress(Progress::new(Stage::Compress, e, t_end, clock));
            if e.stats().collisions - c0 > 20_000 * n {
                let phi_now = cfg.phi * e.scale().powi(2);
                return Ok(Some(phi_now));
            }
        }
        // Collisions with growing radii heat the system: hold T = 1.
        set_temperature(e, 1.0);
    }
    e.set_growth(1.0, 0.0);
    set_temperature(e, 1.0);
    progress(Progress::new(Stage::Compress, e, t_end, clock));
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Beyond the jam: `prepare` fails with the reached fraction (not a hang),
    /// and `compression_limit` reports the same fraction.
    #[test]
    fn compressing_past_the_jam_fails_with_the_reached_fraction() {
        let cfg = SimConfig {
            n: 100,
            phi: 0.85,
            compression_rate: 0.1,
            seed: 3,
            ..SimConfig::default()
        };
        let e = format!("{:#}", prepare(&cfg, &|_| {}).err().unwrap());
        assert!(e.contains("compression jammed at phi = 0.8"), "{e}");
        let limit = compression_limit(&cfg, &|_| {}).unwrap();
        assert!(
            limit.jammed && limit.reached > 0.8 && limit.reached < 0.85,
            "{limit:?}"
        );
        assert!(e.contains(&format!("{:.4}", limit.reached)), "{e}");
        // Below the jam the limit is the request itself.
        let easy = SimConfig { phi: 0.7, ..cfg };
        let limit = compression_limit(&easy, &|_| {}).unwrap();
        assert!(!limit.jammed && limit.reached == 0.7, "{limit:?}");
    }
}
