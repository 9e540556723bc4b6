//! Checkpoints of a long simulation: when they are taken, where the run keeps
//! them ([`Keeper`]), and their file format.
//!
//! A run checkpoints at fixed simulation times, every [`interval`] from the
//! start of the relaxation, so an uninterrupted run and a resumed one do the
//! same work: at each checkpoint both synchronise every particle and rebuild
//! the event calendar ([`Engine::checkpoint`](crate::sim::engine::Engine::checkpoint)),
//! whether or not they stop there. The compression (a small share of a long
//! run) is not checkpointed.
//!
//! File: the magic `REPROCKP`, the format version (u32), the blake3 hash of
//! the payload, its length (u64), then the payload (postcard): the run's
//! configuration as JSON (a checkpoint of another configuration is refused),
//! the engine's state and the run loop's. Integers are little-endian.

use anyhow::{Context, Result, bail, ensure};
use serde::{Deserialize, Serialize};

use crate::sim::engine::state::EngineState;
use crate::sim::model::config::SimConfig;

/// Collisions between two checkpoints by default: about 10 minutes of CPU
/// time at the measured 0.5 x 10^6 collisions per CPU second (docs/sim.md).
pub const COLLISIONS_PER_CHECKPOINT: f64 = 3e8;

const MAGIC: &[u8; 8] = b"REPROCKP";
/// Bumped whenever the payload's layout changes.
const VERSION: u32 = 2;
const HEADER: usize = 8 + 4 + 32 + 8;

/// Simulation time between checkpoints: `cfg.checkpoint_every` if given, else
/// [`COLLISIONS_PER_CHECKPOINT`] over the planned collisions per unit time
/// (`collisions_per_time`, the whole system's), rounded down to a power of
/// two. `None`: the run (relaxation and production) is shorter than one
/// interval and takes no checkpoint. A function of the configuration only, so
/// every build of a stage checkpoints at the same times.
pub fn interval(cfg: &SimConfig, collisions_per_time: f64) -> Option<f64> {
    let every = cfg.checkpoint_every.unwrap_or_else(|| {
        (COLLISIONS_PER_CHECKPOINT / collisions_per_time)
            .log2()
            .floor()
            .exp2()
    });
    (every.is_finite() && every > 0.0 && every < cfg.relax_time + cfg.schedule.end())
        .then_some(every)
}

/// Where a run keeps its checkpoints (the pipeline's store, a test's memory).
pub trait Keeper {
    /// Names of the saved checkpoints, newest first.
    fn saved(&mut self) -> Vec<String>;
    /// The bytes of checkpoint `name`.
    fn read(&mut self, name: &str) -> Result<Vec<u8>>;
    /// Checkpoint `name` cannot be used (`why`): set it aside.
    fn reject(&mut self, name: &str, why: &str);
    /// The run goes on from checkpoint `name`, taken at simulation time `time`.
    fn resumed(&mut self, name: &str, time: f64);
    /// Keep a checkpoint taken at simulation time `time`. An error stops the
    /// run (a keeper that can go on without the checkpoint says so and returns Ok).
    fn save(&mut self, time: f64, bytes: &[u8]) -> Result<()>;
}

/// A checkpoint's content: the engine's state and the run loop's (`R`).
#[derive(Serialize, Deserialize)]
pub struct Checkpoint<R> {
    config: String,
    pub engine: EngineState,
    pub run: R,
}

/// The run's configuration as a checkpoint records it.
fn config_text(cfg: &SimConfig) -> String {
    serde_json::to_string(cfg).expect("a SimConfig serialises")
}

/// The bytes of a checkpoint of `cfg`'s run.
pub fn encode<R: Serialize>(cfg: &SimConfig, engine: EngineState, run: R) -> Result<Vec<u8>> {
    let c = Checkpoint {
        config: config_text(cfg),
        engine,
        run,
    };
    let payload = postcard::to_stdvec(&c).context("encoding a checkpoint")?;
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(blake3::hash(&payload).as_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    Ok(out)
}

/// A checkpoint of `cfg`'s run from its bytes; the error says what is wrong
/// (not a checkpoint, another version, truncated, damaged, another configuration).
pub fn decode<R: for<'de> Deserialize<'de>>(
    cfg: &SimConfig,
    bytes: &[u8],
) -> Result<Checkpoint<R>> {
    ensure!(
        bytes.len() >= HEADER && &bytes[..8] == MAGIC,
        "not a checkpoint (no REPROCKP header; {} bytes)",
        bytes.len()
    );
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    ensure!(
        version == VERSION,
        "checkpoint format version {version}, this build reads version {VERSION}"
    );
    let len = u64::from_le_bytes(bytes[44..52].try_into().expect("8 bytes")) as usize;
    let payload = &bytes[HEADER..];
    ensure!(
        payload.len() == len,
        "truncated or extended: the payload has {} bytes, the header says {len}",
        payload.len()
    );
    if blake3::hash(payload).as_bytes() != &bytes[12..44] {
        bail!("damaged: the payload does not match its blake3 hash");
    }
    let c: Checkpoint<R> = postcard::from_bytes(payload).context("decoding the payload")?;
    ensure!(
        c.config == config_text(cfg),
        "taken by a run of another configuration"
    );
    Ok(c)
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn the_default_interval_is_a_power_of_two_and_short_runs_have_none() {
        let mut cfg = SimConfig {
            relax_time: 1000.0,
            ..SimConfig::default()
        };
        // 3e8 / 1e6 = 300 -> 256.
        assert_eq!(interval(&cfg, 1e6), Some(256.0));
        assert_eq!(interval(&cfg, 1e5), None, "longer than the run");
        cfg.checkpoint_every = Some(10.0);
        assert_eq!(interval(&cfg, 1e6), Some(10.0));
    }
}
