//! One simulation from config to trajectory: compress, relax under driving,
//! then record frames and measure temperature, pressure and rates.

use super::checkpoint::{self, Keeper};
use super::engine_for_run::{self, bath_collision_rate, drive};
use super::progress::{Progress, Stage};
use super::resources;
use crate::sim::engine::{Engine, Kicks, Stats};
use crate::sim::model::config::{ForceMode, KickRate, SimConfig};
use crate::traj::{Frame, Trajectory};
use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Temperature and pressure at one time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Time from the end of relaxation (negative during relaxation).
    pub time: f64,
    /// Kinetic energy per particle at this time.
    pub temperature: f64,
    /// Pressure over the interval ending here: (N T + virial / (2 dt)) / A.
    pub pressure: f64,
    /// Compressibility factor P A / (N T) over that interval.
    pub z: f64,
}

/// What a run measured. Counts and averages refer to the production stage
/// (after relaxation) unless named otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    pub n: usize,
    pub phi: f64,
    pub eps: f64,
    pub seed: u64,
    /// Length of the production stage (simulated time).
    pub sim_time: f64,
    pub relax_time: f64,
    /// Simulated time spent compressing to phi.
    pub compress_time: f64,
    pub collisions: u64,
    pub kicks: u64,
    pub guard_activations: u64,
    pub cell_crossings: u64,
    pub stale_events: u64,
    /// Neighbour-list rebuilds (a disk left its shell).
    pub shell_exits: u64,
    /// Re-anchorings of the friction clock (each predicts every event anew).
    pub reanchors: u64,
    pub wall_collisions: u64,
    /// Pressure on the walls of each axis [x, y]: momentum given to them per
    /// unit time and length (0 on a periodic axis).
    pub wall_pressure: [f64; 2],
    /// Time-averaged kinetic energy per particle.
    pub temperature: f64,
    /// Standard deviation of the sampled temperature (its fluctuation).
    pub temperature_std: f64,
    /// Mean temperature over the first and the second half of production (drift check).
    pub temperature_halves: [f64; 2],
    /// Compressibility factor P A / (N T) from the collisional virial.
    pub z: f64,
    /// Standard error of z from the spread of the per-sample values.
    pub z_err: f64,
    /// Collisions each particle undergoes per unit time: 2 collisions / (N time).
    pub collision_rate: f64,
    /// The Enskog estimate of collision_rate at the measured temperature.
    pub enskog_collision_rate: f64,
    /// Kicks each particle receives per unit time (2 kick rate / N with pairs).
    pub kick_rate: f64,
    pub energy_injected: f64,
    pub energy_dissipated: f64,
    /// Energy removed by viscous friction over production (exact, per event).
    pub energy_friction: f64,
    /// |dE - (injected - dissipated - friction + work + lifted)| / E over production
    /// (work and lifted: the intruder's, see [`IntruderSummary`]).
    pub energy_balance_error: f64,
    /// Viscous friction rate gamma.
    pub gamma: f64,
    /// Kick amplitude p_dr (Eq. 7 of paper I).
    pub kick_amplitude: f64,
    /// Time-averaged kinetic energy per particle of each species (small, large).
    pub species_temperature: Vec<f64>,
    /// Time-averaged centre-of-mass velocity [vx, vy] (the bath's drift).
    pub drift: [f64; 2],
    /// CPU seconds of the simulating thread, whole run.
    pub cpu_seconds: f64,
    /// Production collisions per CPU second of production.
    pub collisions_per_second: f64,
    /// All events (collisions, crossings, shell exits, kicks, stale, wall
    /// collisions, re-predictions, force kicks) per CPU second of production.
    pub events_per_second: f64,
    pub peak_rss_bytes: u64,
    /// Bytes of simulator state per particle.
    pub bytes_per_particle: f64,
    /// Temperature and pressure over relaxation and production.
    pub series: Vec<Sample>,
    /// The intruder's motion and the bath's response (paper I), if there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intruder: Option<IntruderSummary>,
}

/// What the intruder did over production. The force is on from the start of
/// the relaxation, so the relaxation holds the transient and production is
/// the stationary part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IntruderSummary {
    pub force: f64,
    pub radius: f64,
    pub mass: f64,
    /// Mean velocity over production: its exact displacement over the production time.
    pub velocity: [f64; 2],
    /// F / (gamma m_0), the terminal velocity of a lone intruder (infinite at gamma = 0).
    pub terminal_velocity: f64,
    /// F / (gamma M), M the total mass: the centre-of-mass velocity Eq. (11) of
    /// paper I tends to (infinite at gamma = 0).
    pub predicted_drift: f64,
    /// Time-averaged centre-of-mass velocity of the bath alone (without the intruder).
    pub bath_drift: [f64; 2],
    /// Work of the force over production (in the energy ledger).
    pub energy_work: f64,
    /// Calls of the intruder's root finder over production and its mean steps per call.
    pub root_calls: u64,
    pub root_steps_per_call: f64,
    /// Re-predictions (the root finder gave up, or its horizon passed) over production.
    pub repredicts: u64,
    /// How F acted, and with `kicks` the force kicks over production and their interval.
    #[serde(default)]
    pub force_mode: ForceMode,
    #[serde(default)]
    pub force_kicks: u64,
    #[serde(default)]
    pub force_kick_interval: f64,
    /// Intruder-disk rebounds lifted to the minimum separation speed (the
    /// exact force's resting-contact rule) over production, and the kinetic
    /// energy they added (in the energy ledger).
    #[serde(default)]
    pub lifts: u64,
    #[serde(default)]
    pub energy_lifted: f64,
}

/// Takes samples of T and P at regular times while the engine advances.
#[derive(Serialize, Deserialize)]
struct Sampler {
    dt: f64,
    next: f64,
    t0: f64,
    last_time: f64,
    last_virial: f64,
    last_t: f64,
    area: f64,
    samples: Vec<Sample>,
    /// Per-species temperature at each sample.
    species: Vec<Vec<f64>>,
    /// Centre-of-mass velocity at each sample.
    drift: Vec<[f64; 2]>,
    /// The bath's centre-of-mass velocity (without the intruder) at each
    /// sample; empty without an intruder.
    bath_drift: Vec<[f64; 2]>,
}

/// Kinetic energy per bath particle (the intruder, if any, left out).
fn bath_temperature(e: &Engine) -> f64 {
    match e.intruder() {
        None => e.kinetic_energy() / e.n() as f64,
        Some(k) => (e.kinetic_energy() - e.particle_kinetic_energy(k)) / (e.n() - 1) as f64,
    }
}

impl Sampler {
    fn take(&mut self, e: &Engine) {
        let t = bath_temperature(e);
        let n = e.n() as f64 - if e.intruder().is_some() { 1.0 } else { 0.0 };
        let now = e.time();
        let dt = now - self.last_time;
        let tm = 0.5 * (t + self.last_t);
        let pv = (e.stats().virial - self.last_virial) / (2.0 * dt);
        let pressure = (n * tm + pv) / self.area;
        self.samples.push(Sample {
            time: now - self.t0,
            temperature: t,
            pressure,
            z: pressure * self.area / (n * tm),
        });
        self.species.push(e.temperature_by_species());
        let p = e.momentum();
        let m = e.total_mass();
        self.drift.push([p[0] / m, p[1] / m]);
        if let Some(k) = e.intruder() {
            let (_, v) = e.particle(k);
            let m0 = e.masses()[e.species()[k] as usize];
            self.bath_drift
                .push([0, 1].map(|a| (p[a] - m0 * v[a]) / (m - m0)));
        }
        self.last_time = now;
        self.last_virial = e.stats().virial;
        self.last_t = t;
    }
}

/// Sub-windows of each balancing window of the relaxation.
const BALANCE_SUB: usize = 8;

/// One step of a run: advance to a time, then act. A run is the list of its
/// steps ([`steps`]) and the index of the one under way, so that it can stop
/// at a checkpoint and go on from there.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Step {
    /// Relax until `to`; `measure`: then add the bath temperature to the
    /// window's sum; `correct`: then correct the kick rate by the window's mean.
    Relax {
        to: f64,
        measure: bool,
        correct: bool,
    },
    /// Production starts: the counters it is measured against are read.
    Produce,
    /// Record the frame at production time `at`.
    Frame { at: f64 },
    /// Production ends.
    End,
}

/// The steps of `cfg`'s run from the start of relaxation `t_relax0`. With
/// the balanced rule (`balance`), the first 80% of the relaxation is cut in
/// windows after each of which the rate is corrected by T^(-3/2) (T scales as
/// rate^(2/3) because the collision rate grows as sqrt(T)); T is averaged over
/// the second half of each window, after the response to the previous correction.
fn steps(cfg: &SimConfig, t_relax0: f64, balance: bool) -> Vec<Step> {
    let windows = 10;
    let sub = BALANCE_SUB;
    let w = cfg.relax_time / windows as f64;
    let mut v = Vec::new();
    for k in 0..windows {
        let start = t_relax0 + k as f64 * w;
        if balance && k < windows * 4 / 5 {
            v.extend((1..=sub).map(|m| Step::Relax {
                to: start + w * m as f64 / sub as f64,
                measure: m > sub / 2,
                correct: m == sub,
            }));
        } else {
            v.push(Step::Relax {
                to: start + w,
                measure: false,
                correct: false,
            });
        }
    }
    v.push(Step::Produce);
    v.extend(
        cfg.schedule
            .times()
            .into_iter()
            .map(|at| Step::Frame { at }),
    );
    v.push(Step::End);
    v
}

/// The run loop's state: with the engine's, what a checkpoint holds.
#[derive(Serialize, Deserialize)]
struct RunState {
    compress_time: f64,
    t_relax0: f64,
    /// The kick rate (the balanced rule corrects it during relaxation).
    rate: f64,
    /// The step under way, and the bath temperatures summed so far in the
    /// current balancing window.
    step: usize,
    tsum: f64,
    sampler: Sampler,
    frames: Vec<Frame>,
    production: Option<ProductionStart>,
    /// Checkpoints taken so far.
    checkpoints: u64,
    /// CPU seconds of the run when the state was saved.
    cpu_seconds: f64,
}

/// What production is measured against, read when it starts.
#[derive(Clone, Serialize, Deserialize)]
struct ProductionStart {
    stats: Stats,
    kinetic_energy: f64,
    intruder: Option<[f64; 2]>,
    force_kicks: u64,
    relax_samples: usize,
    cpu_seconds: f64,
}

/// CPU seconds of a run, across the processes that ran it.
struct Cpu {
    offset: f64,
}

impl Cpu {
    /// A clock that reads `spent` now.
    fn reading(spent: f64) -> Cpu {
        Cpu {
            offset: spent - resources::thread_cpu_seconds(),
        }
    }

    fn now(&self) -> f64 {
        resources::thread_cpu_seconds() + self.offset
    }
}

/// When a run checkpoints and where the checkpoints go.
struct Checkpointing<'a, 'k> {
    cfg: &'a SimConfig,
    /// Checkpoint k (from 0) is at `origin + (k + 1) every`, before `end`.
    origin: f64,
    every: Option<f64>,
    end: f64,
    keeper: Option<&'k mut dyn Keeper>,
    cpu: Cpu,
}

impl Checkpointing<'_, '_> {
    /// Time of the checkpoint after `taken` ones (infinity: none).
    fn time(&self, taken: u64) -> f64 {
        match self.every {
            Some(every) => {
                let t = self.origin + (taken + 1) as f64 * every;
                if t < self.end { t } else { f64::INFINITY }
            }
            None => f64::INFINITY,
        }
    }
}

/// Advance to `t`, taking the samples and checkpoints that fall on the way.
#[allow(clippy::too_many_arguments)]
fn advance(
    e: &mut Engine,
    t: f64,
    st: &mut RunState,
    ck: &mut Checkpointing,
    stage: Stage,
    end: f64,
    clock: Instant,
    progress: &dyn Fn(Progress),
) -> Result<()> {
    loop {
        let at = ck.time(st.checkpoints);
        let stop = t.min(st.sampler.next).min(at);
        while !e.run_until(stop, 1 << 20) {
            progress(Progress::new(stage, e, end, clock).of_run(ck.origin, ck.end));
        }
        if stop == st.sampler.next {
            st.sampler.take(e);
            st.sampler.next += st.sampler.dt;
        }
        if stop == at {
            st.checkpoints += 1;
            let state = e.checkpoint(ck.keeper.is_some());
            if let (Some(keeper), Some(state)) = (ck.keeper.as_deref_mut(), state) {
                st.cpu_seconds = ck.cpu.now();
                keeper.save(at, &checkpoint::encode(ck.cfg, state, &*st)?)?;
            }
            // Round the loop again, also when `t` is reached: a run resumed
            // from this checkpoint starts there.
            continue;
        }
        if stop == t {
            // Small systems finish a window in fewer than 2^20 events: report at
            // every window's end too, or the bar stays at the previous stage.
            progress(Progress::new(stage, e, end, clock).of_run(ck.origin, ck.end));
            return Ok(());
        }
    }
}

/// The engine and run state of the newest usable checkpoint in `keeper`
/// (unusable ones are rejected, newest first); `None` if there is none.
fn resume(cfg: &SimConfig, keeper: &mut dyn Keeper, n_steps: usize) -> Option<(Engine, RunState)> {
    for name in keeper.saved() {
        let restored = keeper.read(&name).and_then(|bytes| {
            let c = checkpoint::decode::<RunState>(cfg, &bytes)?;
            anyhow::ensure!(
                c.run.step < n_steps,
                "its run is at step {} of {n_steps}",
                c.run.step
            );
            let time = c.engine.time();
            Ok((Engine::restore(c.engine)?, c.run, time))
        });
        match restored {
            Ok((e, run, time)) => {
                keeper.resumed(&name, time);
                return Some((e, run));
            }
            Err(err) => keeper.reject(&name, &format!("{err:#}")),
        }
    }
    None
}

/// Run one simulation: returns the frames of `cfg.schedule` and the summary.
pub fn run(cfg: &SimConfig, progress: &dyn Fn(Progress)) -> Result<(Trajectory, RunSummary)> {
    run_kept(cfg, progress, None)
}

/// What the configuration fixes about driving before the run starts.
struct DriveSettings {
    kicks: Kicks,
    /// Starting kick rate (whole system) and the kick amplitude p_dr.
    rate0: f64,
    p_dr: f64,
    /// The force kicks' interval: kick_rate_factor times the bath's collision rate.
    force_dt: f64,
    /// The kick rate is tuned during relaxation (the balanced rule).
    balance: bool,
}

impl DriveSettings {
    fn of(cfg: &SimConfig) -> DriveSettings {
        let rate = bath_collision_rate(cfg, cfg.temperature);
        let (kicks, rate0, p_dr) = drive(cfg, rate);
        DriveSettings {
            kicks,
            rate0,
            p_dr,
            force_dt: cfg
                .intruder
                .as_ref()
                .map_or(0.0, |i| 1.0 / (i.kick_rate_factor * rate)),
            balance: cfg.kick_rate == KickRate::Balanced && kicks != Kicks::Off,
        }
    }
}

/// [`run`], checkpointing into `keeper` (when the run is longer than one
/// [`checkpoint::interval`]) and going on from its newest usable checkpoint.
/// The results are the same bits whether or not the run stopped and resumed.
pub fn run_kept(
    cfg: &SimConfig,
    progress: &dyn Fn(Progress),
    mut keeper: Option<&mut dyn Keeper>,
) -> Result<(Trajectory, RunSummary)> {
    cfg.validate()?;
    // A new run's CPU time counts its compression.
    let cpu = Cpu::reading(0.0);
    let drv = DriveSettings::of(cfg);
    // The steps do not depend on where the relaxation starts.
    let n_steps = steps(cfg, 0.0, drv.balance).len();
    let resumed = keeper.as_deref_mut().and_then(|k| resume(cfg, k, n_steps));
    let (mut e, mut st, cpu) = match resumed {
        Some((e, st)) => {
            let cpu = Cpu::reading(st.cpu_seconds);
            (e, st, cpu)
        }
        None => {
            let (e, compress_time) = engine_for_run::build(cfg, progress)?;
            let st = RunState::new(cfg, &e, compress_time, drv.rate0);
            (e, st, cpu)
        }
    };
    let end = st.t_relax0 + cfg.relax_time + cfg.schedule.end();
    let mut ck = Checkpointing {
        cfg,
        origin: st.t_relax0,
        every: checkpoint::interval(
            cfg,
            bath_collision_rate(cfg, cfg.temperature) * cfg.n as f64 / 2.0,
        ),
        end,
        keeper,
        cpu,
    };
    carry_out(cfg, &drv, &mut e, &mut st, &mut ck, progress)?;
    Ok(summarise(cfg, &drv, &e, st, &ck.cpu))
}

impl RunState {
    /// The run state of a new run whose engine `e` has just been compressed
    /// (in `compress_time`) and starts relaxing, at kick rate `rate0`.
    fn new(cfg: &SimConfig, e: &Engine, compress_time: f64, rate0: f64) -> RunState {
        let t_relax0 = e.time();
        let dt = (cfg.relax_time + cfg.schedule.end()) / cfg.samples as f64;
        let sampler = Sampler {
            dt,
            next: t_relax0 + dt,
            t0: t_relax0 + cfg.relax_time,
            last_time: e.time(),
            last_virial: e.stats().virial,
            last_t: bath_temperature(e),
            area: cfg.box_size()[0] * cfg.box_size()[1],
            samples: Vec::with_capacity(cfg.samples + 1),
            species: Vec::with_capacity(cfg.samples + 1),
            drift: Vec::with_capacity(cfg.samples + 1),
            bath_drift: Vec::new(),
        };
        RunState {
            compress_time,
            t_relax0,
            rate: rate0,
            step: 0,
            tsum: 0.0,
            sampler,
            frames: Vec::new(),
            production: None,
            checkpoints: 0,
            cpu_seconds: 0.0,
        }
    }
}

/// Carry out the run's steps from `st.step` on: relaxation (balancing the
/// kick rate), the start of production, the frames, the end.
fn carry_out(
    cfg: &SimConfig,
    drv: &DriveSettings,
    e: &mut Engine,
    st: &mut RunState,
    ck: &mut Checkpointing,
    progress: &dyn Fn(Progress),
) -> Result<()> {
    let t0 = st.t_relax0 + cfg.relax_time;
    let end = t0 + cfg.schedule.end();
    let plan = steps(cfg, st.t_relax0, drv.balance);
    let mut clock = Instant::now();
    while st.step < plan.len() {
        match plan[st.step] {
            Step::Relax {
                to,
                measure,
                correct,
            } => {
                advance(e, to, st, ck, Stage::Relax, t0, clock, progress)?;
                if measure {
                    st.tsum += bath_temperature(e);
                }
                if correct {
                    let tmean = st.tsum / (BALANCE_SUB / 2) as f64;
                    st.tsum = 0.0;
                    if tmean > 0.0 {
                        st.rate *= tmean.powf(-1.5);
                        e.set_kicks(drv.kicks, st.rate, drv.p_dr);
                    }
                }
            }
            Step::Produce => {
                if e.time() < t0 {
                    e.skip_to(t0);
                }
                st.production = Some(ProductionStart {
                    stats: *e.stats(),
                    kinetic_energy: e.kinetic_energy(),
                    intruder: e.intruder().map(|k| e.particle(k).0),
                    force_kicks: e.force_kicks(),
                    relax_samples: st.sampler.samples.len(),
                    cpu_seconds: ck.cpu.now(),
                });
                clock = Instant::now();
            }
            Step::Frame { at } => {
                advance(e, t0 + at, st, ck, Stage::Production, end, clock, progress)?;
                let (x, y) = e.unwrapped_positions();
                let (vx, vy) = if cfg.record_velocities {
                    e.velocities()
                } else {
                    (vec![], vec![])
                };
                st.frames.push(Frame {
                    time: at,
                    x,
                    y,
                    vx,
                    vy,
                });
            }
            Step::End => {
                advance(e, end, st, ck, Stage::Production, end, clock, progress)?;
            }
        }
        st.step += 1;
    }
    Ok(())
}

/// Mean of `v` (0 if empty).
fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Mean of each component over the rows of `rows`.
fn mean_of<const K: usize>(rows: &[[f64; K]]) -> [f64; K] {
    std::array::from_fn(|k| mean(&rows.iter().map(|v| v[k]).collect::<Vec<_>>()))
}

/// The trajectory and summary of a finished run.
fn summarise(
    cfg: &SimConfig,
    drv: &DriveSettings,
    e: &Engine,
    st: RunState,
    cpu: &Cpu,
) -> (Trajectory, RunSummary) {
    let n = e.n();
    let nf = n as f64;
    let prod = cfg.schedule.end();
    let start = st
        .production
        .clone()
        .expect("the production step comes before the end");
    let before = start.stats;
    let (s, frames, compress_time) = (st.sampler, st.frames, st.compress_time);
    let [lx, ly] = cfg.box_size();
    let cpu_prod = cpu.now() - start.cpu_seconds;
    let st = *e.stats();
    let collisions = st.collisions - before.collisions;

    let prod_samples = &s.samples[start.relax_samples..];
    let temps: Vec<f64> = prod_samples.iter().map(|x| x.temperature).collect();
    let temperature = mean(&temps);
    let temperature_std = (temps.iter().map(|t| (t - temperature).powi(2)).sum::<f64>()
        / temps.len().max(1) as f64)
        .sqrt();
    let half = temps.len() / 2;
    let zs: Vec<f64> = prod_samples.iter().map(|x| x.z).collect();
    let z = 1.0 + (st.virial - before.virial) / (2.0 * prod * nf * temperature);
    let zm = mean(&zs);
    let z_err = (zs.iter().map(|v| (v - zm).powi(2)).sum::<f64>()
        / (zs.len().max(2) - 1) as f64
        / zs.len().max(1) as f64)
        .sqrt();
    let ke1 = e.kinetic_energy();
    let injected = st.injected - before.injected;
    let dissipated = st.dissipated - before.dissipated;
    let friction = st.friction - before.friction;
    let work = st.work - before.work;
    let lifted = st.lifted - before.lifted;
    let masses = cfg.species_masses();
    let species_prod = &s.species[start.relax_samples..];
    let species_temperature = (0..masses.len())
        .map(|k| mean(&species_prod.iter().map(|v| v[k]).collect::<Vec<_>>()))
        .collect();
    let drift = mean_of(&s.drift[start.relax_samples..]);
    let intruder = intruder_summary(cfg, drv, e, &start, &s.bath_drift);
    let force_kicks = e.force_kicks() - start.force_kicks;
    let summary = RunSummary {
        n,
        phi: cfg.phi,
        eps: cfg.eps,
        seed: cfg.seed,
        sim_time: prod,
        relax_time: cfg.relax_time,
        compress_time,
        collisions,
        kicks: st.kicks - before.kicks,
        guard_activations: st.guard_activations - before.guard_activations,
        cell_crossings: st.cell_crossings - before.cell_crossings,
        stale_events: st.stale_events - before.stale_events,
        shell_exits: st.shell_exits - before.shell_exits,
        reanchors: st.reanchors - before.reanchors,
        wall_collisions: st.wall_collisions - before.wall_collisions,
        wall_pressure: [0, 1]
            .map(|k| (st.wall_impulse[k] - before.wall_impulse[k]) / (2.0 * [ly, lx][k] * prod)),
        temperature,
        temperature_std,
        temperature_halves: [mean(&temps[..half]), mean(&temps[half..])],
        z,
        z_err,
        collision_rate: 2.0 * collisions as f64 / (nf * prod),
        enskog_collision_rate: bath_collision_rate(cfg, temperature),
        kick_rate: if drv.kicks == Kicks::Single { 1.0 } else { 2.0 } * e.kick_rate() / nf,
        energy_injected: injected,
        energy_dissipated: dissipated,
        energy_friction: friction,
        energy_balance_error: ((ke1 - start.kinetic_energy)
            - (injected - dissipated - friction + work + lifted))
            .abs()
            / ke1,
        gamma: cfg.gamma,
        kick_amplitude: drv.p_dr,
        species_temperature,
        drift,
        cpu_seconds: cpu.now(),
        collisions_per_second: collisions as f64 / cpu_prod.max(1e-9),
        events_per_second: [
            collisions,
            st.kicks - before.kicks,
            st.cell_crossings - before.cell_crossings,
            st.stale_events - before.stale_events,
            st.shell_exits - before.shell_exits,
            st.wall_collisions - before.wall_collisions,
            st.repredicts - before.repredicts,
            force_kicks,
        ]
        .iter()
        .sum::<u64>() as f64
            / cpu_prod.max(1e-9),
        peak_rss_bytes: resources::peak_rss_bytes(),
        bytes_per_particle: e.bytes() as f64 / nf,
        series: s.samples,
        intruder,
    };
    let traj = Trajectory {
        box_size: [lx, ly],
        periodic: cfg.walls.map(|w| !w),
        species: e.species().to_vec(),
        radii: cfg.radii(),
        masses,
        frames,
        schedule: Some(cfg.schedule.clone()),
    };
    (traj, summary)
}

/// The pulled intruder's part of the summary (none without one): its
/// velocity over production, the bath's mean drift over production (from
/// the samples of `bath_drift`), the ledgers and counters of its force.
fn intruder_summary(
    cfg: &SimConfig,
    drv: &DriveSettings,
    e: &Engine,
    start: &ProductionStart,
    bath_drift: &[[f64; 2]],
) -> Option<IntruderSummary> {
    let (intr, k, x0) = match (&cfg.intruder, e.intruder(), start.intruder) {
        (Some(intr), Some(k), Some(x0)) => (intr, k, x0),
        _ => return None,
    };
    let (before, st) = (&start.stats, e.stats());
    let prod = cfg.schedule.end();
    let x1 = e.particle(k).0;
    let calls = st.root_calls - before.root_calls;
    Some(IntruderSummary {
        force: intr.force,
        radius: intr.radius,
        mass: intr.mass,
        velocity: [0, 1].map(|a| (x1[a] - x0[a]) / prod),
        terminal_velocity: intr.force / (cfg.gamma * intr.mass),
        predicted_drift: intr.force / (cfg.gamma * e.total_mass()),
        bath_drift: mean_of(&bath_drift[start.relax_samples..]),
        energy_work: st.work - before.work,
        root_calls: calls,
        root_steps_per_call: (st.root_steps - before.root_steps) as f64 / calls.max(1) as f64,
        repredicts: st.repredicts - before.repredicts,
        force_mode: intr.force_mode,
        force_kicks: e.force_kicks() - start.force_kicks,
        force_kick_interval: if intr.force_mode == ForceMode::Kicks {
            drv.force_dt
        } else {
            0.0
        },
        lifts: st.lifts - before.lifts,
        energy_lifted: st.lifted - before.lifted,
    })
}
