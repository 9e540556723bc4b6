//! A running stage's checkpoints and progress, in its own directory of the
//! store (`checkpoints/<key>/`, beside its cache entry): not part of its
//! output or its content hash, removed when the stage is done.
//!
//! - `t<time>.ckpt`: a checkpoint taken at simulation time `time`, written
//!   atomically; the newest [`KEEP`] are kept. Their content is the stage
//!   kind's (the framework only moves files).
//! - `progress.json`: where the run is ([`RunProgress`]); with the newest
//!   checkpoint, what `repro status` shows ([`Status`]).
//!
//! A checkpoint the stage cannot use (truncated, damaged) is moved to the
//! store's `quarantine/` (never deleted) and the next older one is tried.

use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::table::write_atomic;

/// Checkpoints kept: the newest, and the one before in case it is damaged.
pub const KEEP: usize = 2;

const PROGRESS: &str = "progress.json";

/// Where a running stage is, as `repro status` shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunProgress {
    /// What it is doing (e.g. `relax`, `production`).
    pub stage: String,
    /// Simulation time now, and the fraction of the planned run done.
    pub time: f64,
    pub fraction: f64,
    /// When this was written (Unix seconds) and by which host and process.
    pub updated: u64,
    pub host: String,
    pub pid: u32,
}

/// A running (or stopped) stage as `repro status` shows it: its last
/// progress report and its newest checkpoint (simulation time, when written
/// in Unix seconds).
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    pub progress: Option<RunProgress>,
    pub checkpoint: Option<(f64, u64)>,
}

/// Seconds since the Unix epoch now.
pub fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// The checkpoint directory of one stage.
#[derive(Clone, Debug)]
pub struct Checkpoints {
    dir: PathBuf,
    quarantine: PathBuf,
}

impl Checkpoints {
    /// Checkpoints in `dir`; unusable ones go to `quarantine`.
    pub fn new(dir: PathBuf, quarantine: PathBuf) -> Checkpoints {
        Checkpoints { dir, quarantine }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The saved checkpoints, newest first: (file name, simulation time).
    pub fn saved(&self) -> Vec<(String, f64)> {
        let mut v: Vec<(String, f64)> = std::fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().into_string().ok()?;
                let t = name
                    .strip_prefix('t')?
                    .strip_suffix(".ckpt")?
                    .parse()
                    .ok()?;
                Some((name, t))
            })
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1));
        v
    }

    /// The bytes of checkpoint `name`.
    pub fn read(&self, name: &str) -> Result<Vec<u8>> {
        let p = self.dir.join(name);
        std::fs::read(&p).with_context(|| format!("reading {}", p.display()))
    }

    /// Write the checkpoint of simulation time `time` atomically, then drop
    /// all but the newest [`KEEP`].
    pub fn save(&self, time: f64, bytes: &[u8]) -> Result<PathBuf> {
        let p = self.dir.join(format!("t{time}.ckpt"));
        write_atomic(&p, bytes).with_context(|| format!("writing {}", p.display()))?;
        for (old, _) in self.saved().into_iter().skip(KEEP) {
            let _ = std::fs::remove_file(self.dir.join(old));
        }
        Ok(p)
    }

    /// Move checkpoint `name` to the quarantine; returns where it went.
    pub fn quarantine(&self, name: &str) -> Result<PathBuf> {
        let stage = self
            .dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        std::fs::create_dir_all(&self.quarantine)?;
        let base = self.quarantine.join(format!("checkpoint-{stage}-{name}"));
        let mut to = base.clone();
        let mut k = 1;
        while to.exists() {
            to = PathBuf::from(format!("{}.{k}", base.display()));
            k += 1;
        }
        let from = self.dir.join(name);
        std::fs::rename(&from, &to)
            .with_context(|| format!("moving {} to {}", from.display(), to.display()))?;
        Ok(to)
    }

    /// Record where the run is (atomically).
    pub fn set_progress(&self, p: &RunProgress) -> Result<()> {
        write_atomic(&self.dir.join(PROGRESS), &serde_json::to_vec_pretty(p)?)
    }

    /// Where the run of this directory was last, if it said.
    pub fn progress(&self) -> Option<RunProgress> {
        serde_json::from_slice(&std::fs::read(self.dir.join(PROGRESS)).ok()?).ok()
    }

    /// Where the stage of this directory is, if it has begun to say.
    pub fn status(&self) -> Option<Status> {
        let checkpoint = self.saved().into_iter().next().and_then(|(name, t)| {
            let written = std::fs::metadata(self.dir.join(name))
                .ok()?
                .modified()
                .ok()?;
            Some((t, written.duration_since(UNIX_EPOCH).ok()?.as_secs()))
        });
        let progress = self.progress();
        (progress.is_some() || checkpoint.is_some()).then_some(Status {
            progress,
            checkpoint,
        })
    }

    /// The stage is done: remove its checkpoints and progress.
    pub fn remove(&self) -> Result<()> {
        match std::fs::remove_dir_all(&self.dir) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(e).with_context(|| format!("removing {}", self.dir.display()))
            }
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_newest_two_are_kept_and_a_quarantined_one_is_moved_aside() {
        let tmp = tempfile::tempdir().unwrap();
        let c = Checkpoints::new(tmp.path().join("k1"), tmp.path().join("q"));
        assert!(c.saved().is_empty());
        for t in [8.0, 16.0, 24.0] {
            c.save(t, format!("at {t}").as_bytes()).unwrap();
        }
        let names: Vec<f64> = c.saved().iter().map(|s| s.1).collect();
        assert_eq!(names, [24.0, 16.0]);
        assert_eq!(c.read("t16.ckpt").unwrap(), b"at 16");
        let to = c.quarantine("t24.ckpt").unwrap();
        assert!(to.ends_with("checkpoint-k1-t24.ckpt") && to.exists());
        assert_eq!(c.saved().len(), 1);
        c.remove().unwrap();
        assert!(!tmp.path().join("k1").exists());
        c.remove().unwrap();
    }
}
