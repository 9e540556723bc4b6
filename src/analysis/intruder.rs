//! Intruder observables (paper I): stationary velocity along the pulling force (x),
//! the intruder path x(t), v(t), mobility from the linear regime, and the momentum
//! profile Px(x) averaged across the channel.

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::check_trajectory;
use super::drive::DriveParams;
use super::stats::Estimate;
use crate::table::f64_batch;
use crate::traj::{Frame, Trajectory};

fn default_species() -> u8 {
    2
}

fn default_blocks() -> usize {
    10
}

/// Parameters of the stationary intruder velocity.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VelocityParams {
    /// Species of the intruder.
    #[serde(default = "default_species")]
    pub species: u8,
    /// Frames before this time (transient) are discarded.
    #[serde(default)]
    pub t_start: f64,
    /// Number of equal time blocks for the error estimate.
    #[serde(default = "default_blocks")]
    pub blocks: usize,
    /// The driving of the bath (eps, gamma, T of the simulation): adds the drive
    /// velocity v_dr = p_dr / m_eff of Eq. (7) of paper I at the measured packing
    /// fraction, and the scaled columns of Fig. 5.
    #[serde(default)]
    pub drive: Option<DriveParams>,
    /// With the force as kicks (`force_mode: kicks`): their rate in units of the
    /// bath's Enskog rate, as in the simulation. Adds the kick interval `kick_dt`
    /// and `collision_momentum` (needs `drive` for T), from which a join derives
    /// how much of a collision's momentum one kick carries.
    #[serde(default)]
    pub kick_rate_factor: Option<f64>,
}

fn intruders(traj: &Trajectory, species: u8) -> Result<Vec<usize>> {
    let idx: Vec<usize> = (0..traj.n())
        .filter(|&i| traj.species[i] == species)
        .collect();
    if idx.is_empty() {
        bail!("no intruder: no particle of species {species} in the trajectory");
    }
    Ok(idx)
}

fn mean_of(v: &[f64], idx: &[usize]) -> f64 {
    idx.iter().map(|&i| v[i]).sum::<f64>() / idx.len() as f64
}

/// One time block: the intruder's velocity along x and the bath's centre-of-mass
/// velocity along x (mass-weighted, the intruder left out).
struct Block {
    v: f64,
    bath: f64,
}

/// Block velocities of one trajectory: mean recorded vx over the frames of each block
/// if velocities are recorded, else the x displacement across the block over its
/// duration (positions are unwrapped); the same for the bath's centre of mass.
fn block_velocities(traj: &Trajectory, p: &VelocityParams) -> Result<Vec<Block>> {
    check_trajectory(traj)?;
    let idx = intruders(traj, p.species)?;
    let bath: Vec<usize> = (0..traj.n())
        .filter(|&i| traj.species[i] != p.species)
        .collect();
    let mass = |i: &usize| traj.masses[traj.species[*i] as usize];
    let m_bath: f64 = bath.iter().map(mass).sum();
    let com = |v: &[f64]| bath.iter().map(|i| mass(i) * v[*i]).sum::<f64>() / m_bath;
    let frames: Vec<&Frame> = traj.frames.iter().filter(|f| f.time >= p.t_start).collect();
    if p.blocks == 0 {
        bail!("parameter `blocks` must be at least 1");
    }
    if frames.len() < 2 * p.blocks {
        bail!(
            "{} frames after t_start = {} cannot make {} blocks of at least two frames",
            frames.len(),
            p.t_start,
            p.blocks
        );
    }
    let with_v = frames.iter().all(|f| f.vx.len() == traj.n());
    let (t0, t1) = (frames[0].time, frames[frames.len() - 1].time);
    let mut out = Vec::with_capacity(p.blocks);
    for b in 0..p.blocks {
        let lo = t0 + (t1 - t0) * b as f64 / p.blocks as f64;
        let hi = t0 + (t1 - t0) * (b + 1) as f64 / p.blocks as f64;
        let inb: Vec<&&Frame> = frames
            .iter()
            .filter(|f| f.time >= lo && (f.time < hi || (b + 1 == p.blocks && f.time <= hi)))
            .collect();
        if inb.len() < 2 {
            bail!("time block [{lo}, {hi}) holds fewer than two frames: use fewer blocks");
        }
        out.push(if with_v {
            let k = inb.len() as f64;
            Block {
                v: inb.iter().map(|f| mean_of(&f.vx, &idx)).sum::<f64>() / k,
                bath: inb.iter().map(|f| com(&f.vx)).sum::<f64>() / k,
            }
        } else {
            let (fa, fb) = (inb[0], inb[inb.len() - 1]);
            let dt = fb.time - fa.time;
            Block {
                v: (mean_of(&fb.x, &idx) - mean_of(&fa.x, &idx)) / dt,
                bath: (com(&fb.x) - com(&fa.x)) / dt,
            }
        });
    }
    Ok(out)
}

/// Mean and standard error of independent samples (NaN error for one sample).
fn mean_err(v: &[f64]) -> Estimate {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    Estimate {
        value: m,
        err: if v.len() > 1 {
            (var / n).sqrt()
        } else {
            f64::NAN
        },
    }
}

/// Blocks of every replica, each replica's in time order.
fn all_blocks(trajs: &[&Trajectory], p: &VelocityParams) -> Result<Vec<Vec<Block>>> {
    trajs.iter().map(|t| block_velocities(t, p)).collect()
}

/// Stationary velocity along x: mean over time blocks of every replica, with the
/// standard error of the block means.
pub fn stationary_velocity(trajs: &[&Trajectory], p: &VelocityParams) -> Result<Estimate> {
    let v: Vec<f64> = all_blocks(trajs, p)?
        .iter()
        .flatten()
        .map(|b| b.v)
        .collect();
    Ok(mean_err(&v))
}

/// Whether the first and second halves of the measurement agree: the block means
/// of the first half (every replica) and of the second half differ by less than
/// three standard errors of the difference. A transient still running when the
/// measurement starts shows as a difference of the halves.
pub fn halves_agree(first: &Estimate, second: &Estimate) -> bool {
    let d = (first.value - second.value).abs();
    let e = first.err.hypot(second.err);
    d <= 3.0 * e
}

/// The drive velocity v_dr = p_dr / m_eff of paper I (Eq. 7 with the Enskog rate
/// of the bath at packing fraction `phi`; m_eff = m_s m_b / (m_s + m_b)).
pub fn drive_velocity(traj: &Trajectory, phi: f64, d: &DriveParams) -> f64 {
    let masses = &traj.masses[..2];
    let omega = bath_collision_rate(traj, phi, d.temperature);
    let p_dr =
        crate::sim::kicks::amplitude(d.eps, d.gamma, d.temperature, omega, masses[0], masses[1]);
    p_dr * (masses[0] + masses[1]) / (masses[0] * masses[1])
}

/// The bath's Enskog collision frequency per particle at packing fraction `phi`
/// and temperature `t` (the intruder left out, as the simulation's driving and
/// force kicks use it).
fn bath_collision_rate(traj: &Trajectory, phi: f64, t: f64) -> f64 {
    crate::sim::enskog::collision_frequency(
        phi,
        &traj.radii[..2],
        &traj.masses[..2],
        &bath_fractions(traj),
        t,
    )
}

/// The momentum one collision exchanges with the intruder, as a scale: the
/// reduced mass of the intruder and a mean bath disk times their relative speed,
/// (v^2 + 2 T / m_red)^(1/2) (its drift v and the thermal speed at T).
fn collision_momentum(traj: &Trajectory, species: u8, v: f64, t: f64) -> f64 {
    let x = bath_fractions(traj);
    let m_bath = x[0] * traj.masses[0] + x[1] * traj.masses[1];
    let m0 = traj.masses[species as usize];
    let m_red = m0 * m_bath / (m0 + m_bath);
    m_red * (v * v + 2.0 * t / m_red).sqrt()
}

fn bath_fractions(traj: &Trajectory) -> [f64; 2] {
    let n = traj.species.iter().filter(|&&s| s < 2).count() as f64;
    let large = traj.species.iter().filter(|&&s| s == 1).count() as f64;
    [1.0 - large / n, large / n]
}

/// Packing fraction of the box: every disk's area (the intruder's too) over Lx Ly.
pub fn packing_fraction(traj: &Trajectory) -> f64 {
    let area: f64 = traj
        .species
        .iter()
        .map(|&s| std::f64::consts::PI * traj.radii[s as usize].powi(2))
        .sum();
    area / (traj.box_size[0] * traj.box_size[1])
}

/// Table of the stationary velocity (one row): `v, v_err` over the time blocks of
/// every replica; `v_first, v_second` (+ `_err`) over the first and second halves
/// and `stationary` (1 if they agree within three errors, else 0: such a point is
/// kept but flagged, never silently averaged); `snr = v / v_err`; the bath's
/// centre-of-mass velocity `v_bath` (+ `_err`) and `v_rel = v - v_bath`;
/// `mass_total` (the drift of Eq. 11 is F / (gamma mass_total)); `n_blocks`; with
/// `drive`, `v_dr`, `v_over_vdr` and `vdr2_sqrt_eta = v_dr^2 eta^(1/2)` (Fig. 5).
pub fn velocity_table(trajs: &[&Trajectory], p: &VelocityParams) -> Result<RecordBatch> {
    let blocks = all_blocks(trajs, p)?;
    let pick = |half: Option<bool>, f: fn(&Block) -> f64| -> Vec<f64> {
        blocks
            .iter()
            .flat_map(|r| {
                let h = r.len() / 2;
                r.iter()
                    .enumerate()
                    .filter(move |(k, _)| half.is_none_or(|second| (*k >= h) == second))
                    .map(move |(_, b)| f(b))
            })
            .collect()
    };
    let v = mean_err(&pick(None, |b| b.v));
    let bath = mean_err(&pick(None, |b| b.bath));
    let rel = mean_err(&pick(None, |b| b.v - b.bath));
    if p.blocks < 2 {
        bail!("parameter `blocks` must be at least 2 to compare the halves of the measurement");
    }
    let (first, second) = (
        mean_err(&pick(Some(false), |b| b.v)),
        mean_err(&pick(Some(true), |b| b.v)),
    );
    let t = trajs[0];
    let mass_total: f64 = t.species.iter().map(|&s| t.masses[s as usize]).sum();
    let mut cols = vec![
        ("v", vec![v.value]),
        ("v_err", vec![v.err]),
        ("v_first", vec![first.value]),
        ("v_first_err", vec![first.err]),
        ("v_second", vec![second.value]),
        ("v_second_err", vec![second.err]),
        (
            "stationary",
            vec![f64::from(u8::from(halves_agree(&first, &second)))],
        ),
        ("snr", vec![v.value / v.err]),
        ("v_bath", vec![bath.value]),
        ("v_bath_err", vec![bath.err]),
        ("v_rel", vec![rel.value]),
        ("v_rel_err", vec![rel.err]),
        ("mass_total", vec![mass_total]),
        ("n_blocks", vec![(p.blocks * trajs.len()) as f64]),
    ];
    if let Some(d) = &p.drive {
        let eta = packing_fraction(t);
        let v_dr = drive_velocity(t, eta, d);
        cols.push(("v_dr", vec![v_dr]));
        cols.push(("v_over_vdr", vec![v.value / v_dr]));
        cols.push(("v_over_vdr_err", vec![v.err / v_dr]));
        cols.push(("vdr2_sqrt_eta", vec![v_dr * v_dr * eta.sqrt()]));
    }
    if let Some(k) = p.kick_rate_factor {
        let Some(d) = &p.drive else {
            bail!(
                "parameter `kick_rate_factor` needs `drive: {{eps, gamma, temperature}}` (the kicks' interval is set by the bath's Enskog rate at T)"
            );
        };
        if !(k.is_finite() && k > 0.0) {
            bail!("parameter `kick_rate_factor` = {k} must be positive");
        }
        let omega = bath_collision_rate(t, packing_fraction(t), d.temperature);
        cols.push(("kick_dt", vec![1.0 / (k * omega)]));
        cols.push((
            "collision_momentum",
            vec![collision_momentum(t, p.species, v.value, d.temperature)],
        ));
    }
    f64_batch(&cols)
}

/// Table `t, x, v` of the intruder path (Fig. 4 inset of paper I): v is the recorded
/// vx, or the x displacement to the next frame over the time step (NaN for the last).
pub fn compute_path(traj: &Trajectory, p: &VelocityParams) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    let idx = intruders(traj, p.species)?;
    let fr = &traj.frames;
    let x: Vec<f64> = fr.iter().map(|f| mean_of(&f.x, &idx)).collect();
    let v: Vec<f64> = (0..fr.len())
        .map(|k| {
            if fr[k].vx.len() == traj.n() {
                mean_of(&fr[k].vx, &idx)
            } else if k + 1 < fr.len() {
                (x[k + 1] - x[k]) / (fr[k + 1].time - fr[k].time)
            } else {
                f64::NAN
            }
        })
        .collect();
    f64_batch(&[("t", traj.times()), ("x", x), ("v", v)])
}

/// Mobility mu = v / F in the linear regime: weighted least-squares slope through the
/// origin of v(F) over the points with F <= f_max, from (F, v, v_err) triples.
pub fn mobility(points: &[(f64, f64, f64)], f_max: f64) -> Result<Estimate> {
    let lin: Vec<&(f64, f64, f64)> = points
        .iter()
        .filter(|p| p.0 > 0.0 && p.0 <= f_max)
        .collect();
    if lin.is_empty() {
        bail!("no (F, v) point with 0 < F <= f_max = {f_max}: raise f_max");
    }
    if let Some(p) = lin.iter().find(|p| !(p.2 > 0.0 && p.2.is_finite())) {
        bail!(
            "velocity error at F = {} must be finite and > 0, got {}",
            p.0,
            p.2
        );
    }
    let (mut sfv, mut sff) = (0.0, 0.0);
    for (f, v, e) in lin {
        let w = 1.0 / (e * e);
        sfv += w * f * v;
        sff += w * f * f;
    }
    Ok(Estimate {
        value: sfv / sff,
        err: 1.0 / sff.sqrt(),
    })
}

fn default_bins() -> usize {
    50
}

/// Parameters of the momentum profile.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProfileParams {
    /// Times at which to take the profile (the nearest frame to each).
    pub times: Vec<f64>,
    /// Number of bins along x.
    #[serde(default = "default_bins")]
    pub bins: usize,
    /// Species left out of the profile (the intruder); none if absent.
    #[serde(default = "intruder_default")]
    pub exclude_species: Option<u8>,
}

fn intruder_default() -> Option<u8> {
    Some(2)
}

/// Table `t, x, Px`: momentum density along x, Px(x) = sum_i m_i vx_i over the bin
/// divided by its area (bin width x Ly), i.e. averaged across the channel.
pub fn compute_profile(traj: &Trajectory, p: &ProfileParams) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    if p.bins == 0 {
        bail!("parameter `bins` must be at least 1");
    }
    if p.times.is_empty() {
        bail!("parameter `times` is empty: give at least one time");
    }
    let [lx, ly] = traj.box_size;
    let dx = lx / p.bins as f64;
    let mut cols: [Vec<f64>; 3] = Default::default();
    for &t in &p.times {
        let f = super::frame_with_velocities(traj, t)?;
        let mut px = vec![0.0; p.bins];
        for i in 0..traj.n() {
            let s = traj.species[i];
            if p.exclude_species == Some(s) {
                continue;
            }
            let x = super::fold(f.x[i], lx, traj.periodic[0]);
            let b = ((x / dx).floor().max(0.0) as usize).min(p.bins - 1);
            px[b] += traj.masses[s as usize] * f.vx[i];
        }
        for (b, v) in px.into_iter().enumerate() {
            cols[0].push(f.time);
            cols[1].push((b as f64 + 0.5) * dx);
            cols[2].push(v / (dx * ly));
        }
    }
    let [t, x, px] = cols;
    f64_batch(&[("t", t), ("x", x), ("Px", px)])
}

fn default_lag_min() -> f64 {
    2.0
}

fn default_lag_max() -> f64 {
    20.0
}

/// Parameters of the intruder's diffusion (at F = 0).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DiffusionParams {
    /// Species of the intruder.
    #[serde(default = "default_species")]
    pub species: u8,
    /// Frame pairs this far apart and more enter the fit (beyond the velocity
    /// relaxation, ~1/gamma).
    #[serde(default = "default_lag_min")]
    pub lag_min: f64,
    /// Frame pairs at most this far apart enter the fit.
    #[serde(default = "default_lag_max")]
    pub lag_max: f64,
}

/// D and T of one replica: D from the line <dx^2> = 2 D t + c fitted to every pair
/// of frames with lag in [lag_min, lag_max] (x is periodic and unwrapped); T = m0
/// <vx^2> over the frames (NaN without recorded velocities).
fn replica_diffusion(traj: &Trajectory, p: &DiffusionParams) -> Result<(f64, f64)> {
    check_trajectory(traj)?;
    let idx = intruders(traj, p.species)?;
    if !(p.lag_min >= 0.0 && p.lag_max > p.lag_min) {
        bail!(
            "parameters need 0 <= lag_min < lag_max, got lag_min = {}, lag_max = {}",
            p.lag_min,
            p.lag_max
        );
    }
    let fr = &traj.frames;
    let x: Vec<f64> = fr.iter().map(|f| mean_of(&f.x, &idx)).collect();
    let (mut n, mut st, mut sy, mut stt, mut sty) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for a in 0..fr.len() {
        for b in a + 1..fr.len() {
            let t = fr[b].time - fr[a].time;
            if t < p.lag_min || t > p.lag_max {
                continue;
            }
            let y = (x[b] - x[a]).powi(2);
            n += 1.0;
            st += t;
            sy += y;
            stt += t * t;
            sty += t * y;
        }
    }
    let det = n * stt - st * st;
    if n < 3.0 || det <= 1e-12 * n * stt {
        bail!(
            "fewer than three frame pairs with distinct lags in [{}, {}]: record longer or widen the window",
            p.lag_min,
            p.lag_max
        );
    }
    let slope = (n * sty - st * sy) / det;
    let with_v: Vec<&Frame> = fr.iter().filter(|f| f.vx.len() == traj.n()).collect();
    let m0 = traj.masses[p.species as usize];
    let temp = with_v
        .iter()
        .map(|f| m0 * idx.iter().map(|&i| f.vx[i].powi(2)).sum::<f64>() / idx.len() as f64)
        .sum::<f64>()
        / with_v.len() as f64;
    Ok((slope / 2.0, temp))
}

/// Table (one row) `D, D_err, T_x, T_x_err, mu_einstein, mu_einstein_err, replicas`:
/// the intruder's diffusion coefficient along x, its kinetic temperature along x and
/// the mobility the Einstein relation predicts, mu = D / T_x (errors over replicas).
pub fn diffusion_table(trajs: &[&Trajectory], p: &DiffusionParams) -> Result<RecordBatch> {
    let per: Vec<(f64, f64)> = trajs
        .iter()
        .map(|t| replica_diffusion(t, p))
        .collect::<Result<_>>()?;
    let d = mean_err(&per.iter().map(|r| r.0).collect::<Vec<_>>());
    let t = mean_err(&per.iter().map(|r| r.1).collect::<Vec<_>>());
    let mu = mean_err(&per.iter().map(|r| r.0 / r.1).collect::<Vec<_>>());
    f64_batch(&[
        ("D", vec![d.value]),
        ("D_err", vec![d.err]),
        ("T_x", vec![t.value]),
        ("T_x_err", vec![t.err]),
        ("mu_einstein", vec![mu.value]),
        ("mu_einstein_err", vec![mu.err]),
        ("replicas", vec![trajs.len() as f64]),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::{ballistic, random_walk};
    use crate::analysis::test_support::{col, err_text, first};

    #[test]
    fn intruder_velocity_and_mobility() {
        // An intruder drifting at v = 0.7 with small Brownian noise among bath particles.
        let times: Vec<f64> = (0..=200).map(|k| k as f64 * 0.5).collect();
        let mut traj = random_walk(50, [30.0, 30.0], &times, 0.01, 4);
        traj.species[0] = 2;
        traj.radii.push(2.0);
        traj.masses.push(4.0);
        for f in &mut traj.frames {
            f.x[0] += 0.7 * f.time;
        }
        let p = VelocityParams {
            species: 2,
            t_start: 10.0,
            blocks: 10,
            drive: None,
            kick_rate_factor: None,
        };
        let v = stationary_velocity(&[&traj], &p).unwrap();
        assert!((v.value - 0.7).abs() < 4.0 * v.err && v.err < 0.02, "{v:?}");
        let mu = mobility(&[(1.0, 0.5, 0.1), (2.0, 1.0, 0.1), (1e4, 3.0, 0.1)], 10.0).unwrap();
        assert!((mu.value - 0.5).abs() < 1e-12);
        assert!((mu.err - 0.1 / 5f64.sqrt()).abs() < 1e-12);
        let e = err_text(compute_profile(
            &traj,
            &ProfileParams {
                times: vec![1.0],
                bins: 5,
                exclude_species: Some(2),
            },
        ));
        assert!(e.contains("no velocities"), "{e}");
    }

    #[test]
    fn momentum_profile_of_uniform_flow() {
        // Every particle moving at vx = 1: Px = total mass / area in every bin (on average),
        // exactly total mass / area summed over bins times bin width.
        let times = [0.0];
        let mut traj = ballistic(1000, [20.0, 10.0], &times, 3);
        for f in &mut traj.frames {
            f.vx.iter_mut().for_each(|v| *v = 1.0);
        }
        let b = compute_profile(
            &traj,
            &ProfileParams {
                times: vec![0.0],
                bins: 4,
                exclude_species: None,
            },
        )
        .unwrap();
        let px = col(&b, "Px");
        let mass: f64 = traj.species.iter().map(|&s| traj.masses[s as usize]).sum();
        let total: f64 = px.iter().sum::<f64>() * 5.0 * 10.0;
        assert!((total - mass).abs() < 1e-9 * mass);
    }

    /// An intruder (species 2) drifting at `v(t)` with weak noise among random
    /// walkers of paper I's bath species (radii 1 : 1.25, masses 1 : 25/16, 50:50).
    fn drifting_intruder(v: impl Fn(f64) -> f64, seed: u64) -> Trajectory {
        let times: Vec<f64> = (0..=400).map(|k| k as f64 * 0.25).collect();
        let mut traj = random_walk(61, [30.0, 30.0], &times, 0.01, seed);
        traj.radii = vec![1.0, 1.25, 2.0];
        traj.masses = vec![1.0, 25.0 / 16.0, 4.0];
        traj.species[0] = 2;
        // x(t) = integral of v from 0 to t (trapezoids on a fine grid).
        for f in &mut traj.frames {
            let k = 1000;
            let h = f.time / k as f64;
            let x: f64 = (0..k)
                .map(|j| 0.5 * h * (v(j as f64 * h) + v((j + 1) as f64 * h)))
                .sum();
            f.x[0] += x;
        }
        traj
    }

    fn velocity_row(traj: &Trajectory, drive: Option<DriveParams>) -> RecordBatch {
        let p = VelocityParams {
            species: 2,
            t_start: 0.0,
            blocks: 10,
            drive,
            kick_rate_factor: None,
        };
        velocity_table(&[traj], &p).unwrap()
    }

    #[test]
    fn intruder_stationarity_flags_a_transient_and_reports_the_bath() {
        // Steady drift: the halves agree, flagged stationary; the bath (random
        // walkers) does not drift, so v_rel = v.
        let steady = velocity_row(&drifting_intruder(|_| 0.5, 7), None);
        assert_eq!(first(&steady, "stationary"), 1.0);
        assert!((first(&steady, "v") - 0.5).abs() < 4.0 * first(&steady, "v_err"));
        assert!(first(&steady, "v_bath").abs() < 4.0 * first(&steady, "v_bath_err"));
        assert!((first(&steady, "v_rel") - first(&steady, "v")).abs() < 0.02);
        assert!(
            (first(&steady, "snr") - first(&steady, "v") / first(&steady, "v_err")).abs() < 1e-12
        );
        // 30 small, 30 large, the intruder (disk 0 was small).
        let m = 30.0 + 30.0 * 25.0 / 16.0 + 4.0;
        assert!(
            (first(&steady, "mass_total") - m).abs() < 1e-9,
            "{}",
            first(&steady, "mass_total")
        );
        // A transient still running (v relaxing from 0 to 0.5 with time constant 30):
        // the halves differ and the point is flagged, not silently averaged.
        let relaxing = velocity_row(
            &drifting_intruder(|t| 0.5 * (1.0 - (-t / 30.0).exp()), 7),
            None,
        );
        assert_eq!(first(&relaxing, "stationary"), 0.0);
        assert!(first(&relaxing, "v_second") > first(&relaxing, "v_first"));
    }

    #[test]
    fn intruder_drive_velocity_is_eq7_of_paper_i() {
        // v_dr = p_dr / m_eff with the golden p_dr of eps = 0.9, T = gamma = 1 at
        // eta = 0.3, 0.6, 0.8 (Enskog rates 0.9423, 4.876, 22.82), m_eff = 25/41.
        let traj = drifting_intruder(|_| 0.0, 1);
        let d = DriveParams {
            eps: 0.9,
            gamma: 1.0,
            temperature: 1.0,
        };
        for (eta, v) in [(0.3, 2.697), (0.6, 1.287), (0.8, 0.774)] {
            let got = drive_velocity(&traj, eta, &d);
            assert!((got - v).abs() < 2e-3, "eta {eta}: v_dr {got} vs {v}");
        }
        // The table's scaled columns of Fig. 5 at the box's own packing fraction.
        let row = velocity_row(&traj, Some(d.clone()));
        let eta = packing_fraction(&traj);
        let v_dr = drive_velocity(&traj, eta, &d);
        assert!((first(&row, "v_dr") - v_dr).abs() < 1e-12);
        assert!((first(&row, "vdr2_sqrt_eta") - v_dr * v_dr * eta.sqrt()).abs() < 1e-12);
        assert!((first(&row, "v_over_vdr") - first(&row, "v") / v_dr).abs() < 1e-12);
    }

    #[test]
    fn intruder_kick_columns_follow_the_enskog_rate_and_the_drift() {
        // The force-kick interval is 1 / (factor x the bath's Enskog rate) at the
        // drive's T (the simulation's rule), and the collision momentum is the
        // reduced mass times the relative speed: thermal at rest, ~ m_red v at speed.
        let d = DriveParams {
            eps: 0.9,
            gamma: 1.0,
            temperature: 1.0,
        };
        let p = |k: Option<f64>, drive: Option<DriveParams>| VelocityParams {
            species: 2,
            t_start: 0.0,
            blocks: 10,
            drive,
            kick_rate_factor: k,
        };
        let (slow, fast) = (
            drifting_intruder(|_| 0.0, 3),
            drifting_intruder(|_| 50.0, 3),
        );
        let row =
            |t: &Trajectory, k: f64| velocity_table(&[t], &p(Some(k), Some(d.clone()))).unwrap();
        let (a, b) = (row(&slow, 1e4), row(&slow, 1e2));
        // Rate factor 100 times smaller: interval 100 times longer.
        assert!((first(&b, "kick_dt") / first(&a, "kick_dt") - 100.0).abs() < 1e-9);
        let v_dr = first(&a, "v_dr");
        let eta = packing_fraction(&slow);
        let omega = crate::sim::enskog::collision_frequency(
            eta,
            &[1.0, 1.25],
            &[1.0, 25.0 / 16.0],
            &[0.5, 0.5],
            1.0,
        );
        assert!((first(&a, "kick_dt") * 1e4 * omega - 1.0).abs() < 1e-12);
        assert!(v_dr > 0.0);
        // 30 small and 30 large disks: mean bath mass (1 + 25/16) / 2, intruder 4.
        let mb = (1.0 + 25.0 / 16.0) / 2.0;
        let m_red = 4.0 * mb / (4.0 + mb);
        let v0 = first(&a, "v");
        let want = m_red * (v0 * v0 + 2.0 / m_red).sqrt();
        assert!((first(&a, "collision_momentum") - want).abs() < 1e-12);
        let c = row(&fast, 1e4);
        let ratio = first(&c, "collision_momentum") / (m_red * 50.0);
        assert!((ratio - 1.0).abs() < 0.01, "{ratio}");
        // Without the drive's T there is no Enskog rate: a clear error.
        let e = velocity_table(&[&slow], &p(Some(1e4), None)).unwrap_err();
        assert!(
            e.to_string().contains("`kick_rate_factor` needs `drive"),
            "{e}"
        );
        let e = velocity_table(&[&slow], &p(Some(0.0), Some(d.clone()))).unwrap_err();
        assert!(e.to_string().contains("must be positive"), "{e}");
    }

    #[test]
    fn intruder_diffusion_recovers_d_and_needs_a_lag_window() {
        // A Brownian intruder with D = 0.3 (random-walk frames, no velocities: T_x NaN).
        let times: Vec<f64> = (0..=600).map(|k| k as f64 * 0.5).collect();
        let trajs: Vec<_> = (0..4)
            .map(|s| {
                let mut t = random_walk(20, [40.0, 40.0], &times, 0.3, 10 + s);
                t.radii.push(2.0);
                t.masses.push(4.0);
                t.species[0] = 2;
                t
            })
            .collect();
        let refs: Vec<&Trajectory> = trajs.iter().collect();
        let p = DiffusionParams {
            species: 2,
            lag_min: 1.0,
            lag_max: 10.0,
        };
        let b = diffusion_table(&refs, &p).unwrap();
        let get = |n: &str| first(&b, n);
        let (d, e) = (get("D"), get("D_err"));
        assert!((d - 0.3).abs() < 4.0 * e && e < 0.05, "D = {d} +- {e}");
        assert!(get("T_x").is_nan());
        let bad = DiffusionParams {
            lag_min: 5.0,
            lag_max: 5.0,
            ..p.clone()
        };
        let msg = err_text(diffusion_table(&refs, &bad));
        assert!(msg.contains("lag_min < lag_max"), "{msg}");
        let none = DiffusionParams {
            lag_min: 1000.0,
            lag_max: 2000.0,
            ..p
        };
        let msg = err_text(diffusion_table(&refs, &none));
        assert!(msg.contains("fewer than three frame pairs"), "{msg}");
    }

    /// Every column paper I's intruder analyses write, and every column the intruder
    /// pipelines derive in their joins (`derive: - {name: ...}`), has a unit and a
    /// description in src/table/columns.rs.
    #[test]
    fn every_intruder_column_is_described() {
        let d = DriveParams {
            eps: 0.9,
            gamma: 1.0,
            temperature: 1.0,
        };
        let traj = drifting_intruder(|_| 0.5, 3);
        let p = VelocityParams {
            species: 2,
            t_start: 0.0,
            blocks: 10,
            drive: Some(d),
            kick_rate_factor: Some(1e4),
        };
        let mut tables = vec![
            velocity_table(&[&traj], &p).unwrap(),
            compute_path(&traj, &p).unwrap(),
            diffusion_table(
                &[&traj, &traj],
                &DiffusionParams {
                    species: 2,
                    lag_min: 1.0,
                    lag_max: 10.0,
                },
            )
            .unwrap(),
        ];
        let mut moving = ballistic(200, [20.0, 10.0], &[0.0], 3);
        moving.frames[0].vx.iter_mut().for_each(|v| *v = 1.0);
        tables.push(
            compute_profile(
                &moving,
                &ProfileParams {
                    times: vec![0.0],
                    bins: 4,
                    exclude_species: None,
                },
            )
            .unwrap(),
        );
        let mut names: Vec<String> = tables
            .iter()
            .flat_map(|b| {
                b.schema()
                    .fields()
                    .iter()
                    .map(|f| f.name().clone())
                    .collect::<Vec<_>>()
            })
            .collect();
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
        for k in 1..=6 {
            let text = std::fs::read_to_string(dir.join(format!("intruder-fig{k}.yaml"))).unwrap();
            let spec: serde_json::Value = serde_saphyr::from_str(&text).unwrap();
            for stage in spec["stages"].as_array().unwrap() {
                // A derived column described in its YAML (`describe`) carries
                // its meaning itself.
                for dv in stage["params"]["derive"].as_array().into_iter().flatten() {
                    if dv["describe"].as_str().is_none_or(str::is_empty) {
                        names.push(dv["name"].as_str().unwrap().to_string());
                    }
                }
            }
        }
        assert!(
            names.iter().any(|n| n == "kick_over_collision"),
            "{names:?}"
        );
        for n in &names {
            assert!(
                crate::table::columns::describe(n).is_some(),
                "column `{n}` has no row in src/table/columns.rs"
            );
        }
    }
}
