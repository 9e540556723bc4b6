//! What checkpoints cost (`repro bench --checkpoints`, docs/sim.md): the bytes
//! per particle, the CPU time to write one and to resume from it, and the
//! periodic synchronisation's share of a run, from paired runs with and
//! without it.

use std::time::Instant;

use anyhow::Result;
use serde::Serialize;

use super::checkpoint;
use super::resources::thread_cpu_seconds;
use crate::sim::engine::Engine;
use crate::sim::model::config::SimConfig;

/// The measured cost of checkpoints at one N.
#[derive(Debug, Serialize)]
pub struct CheckpointCost {
    pub n: usize,
    /// Bytes of one checkpoint of the engine (the run loop's state adds the
    /// frames recorded so far), per particle.
    pub bytes_per_particle: f64,
    /// Seconds (wall) to synchronise, encode and write one atomically (fsync
    /// included), and to read, check and restore it into a running engine.
    pub write_s: f64,
    pub resume_s: f64,
    /// Paired runs of `run_time` from the same state: CPU seconds with a
    /// synchronisation every `every` and without, and the CPU seconds one
    /// synchronisation costs from their difference.
    pub run_time: f64,
    pub every: f64,
    pub cpu_with: f64,
    pub cpu_without: f64,
    pub sync_cpu_s: f64,
    /// That cost over the default interval's planned CPU time
    /// ([`checkpoint::COLLISIONS_PER_CHECKPOINT`] at `collisions_per_second`).
    pub default_interval_cpu_s: f64,
    pub overhead_at_default_interval: f64,
}

/// The engine of a run of `cfg` ([`super::engine_for_run::build`]) after `relax` time units.
fn driven(cfg: &SimConfig, relax: f64) -> Result<Engine> {
    let (mut e, _) = super::engine_for_run::build(cfg, &|_| {})?;
    e.run_until(e.time() + relax, u64::MAX);
    Ok(e)
}

/// CPU seconds to run `e` for `time`, stopping every `every` and, with
/// `sync`, synchronising there.
fn timed_run(e: &mut Engine, time: f64, every: f64, sync: bool) -> f64 {
    let (t0, cpu0) = (e.time(), thread_cpu_seconds());
    let stops = (time / every).round() as u64;
    for k in 1..=stops {
        e.run_until(t0 + k as f64 * every, u64::MAX);
        if sync {
            e.checkpoint(false);
        }
    }
    thread_cpu_seconds() - cpu0
}

/// Measure checkpoints of `cfg`'s engine after `relax`; the paired runs last
/// `run_time` with a synchronisation every `every`. The checkpoint file goes
/// to a temporary directory in `dir`.
pub fn measure(
    cfg: &SimConfig,
    relax: f64,
    run_time: f64,
    every: f64,
    dir: &std::path::Path,
) -> Result<CheckpointCost> {
    let mut e = driven(cfg, relax)?;
    let tmp = tempfile::tempdir_in(dir)?;
    let path = tmp.path().join("t.ckpt");
    let t = Instant::now();
    let state = e.checkpoint(true).expect("asked for the state");
    let bytes = checkpoint::encode(cfg, state, ())?;
    crate::table::write_atomic(&path, &bytes)?;
    let write_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let c = checkpoint::decode::<()>(cfg, &std::fs::read(&path)?)?;
    let mut resumed = Engine::restore(c.engine)?;
    let resume_s = t.elapsed().as_secs_f64();
    // The pair: the resumed engine and the one that went on are the same bits.
    let collisions0 = e.stats().collisions;
    let cpu_with = timed_run(&mut e, run_time, every, true);
    let cpu_without = timed_run(&mut resumed, run_time, every, false);
    let syncs = (run_time / every).round();
    let sync_cpu_s = (cpu_with - cpu_without) / syncs;
    let collisions_per_second = (e.stats().collisions - collisions0) as f64 / cpu_without.max(1e-9);
    let default_interval_cpu_s = checkpoint::COLLISIONS_PER_CHECKPOINT / collisions_per_second;
    Ok(CheckpointCost {
        n: e.n(),
        bytes_per_particle: bytes.len() as f64 / e.n() as f64,
        write_s,
        resume_s,
        run_time,
        every,
        cpu_with,
        cpu_without,
        sync_cpu_s,
        default_interval_cpu_s,
        overhead_at_default_interval: sync_cpu_s / default_interval_cpu_s,
    })
}
