//! Job records in the store and what Slurm says about the jobs.
//!
//! `jobs/KEY.json` records, for a stage submitted to Slurm, what the worker needs
//! to find it again (project root, figures, profile, the node's recipe, the keys
//! of its inputs) and where the job is (job id, log). Slurm is asked with
//! `squeue --me --states=all` (no accounting database needed) and, for a job that
//! ended badly, `scontrol show job` (its exit code and reason).

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};

use super::super::store::Store;
use super::plan::{Resources, Settings};

/// One stage handed to Slurm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    pub key: String,
    pub label: String,
    pub kind: String,
    /// The node's recipe (identity before anything runs): the worker finds the
    /// node by it in its own plan.
    pub recipe: String,
    pub root: PathBuf,
    pub profile: String,
    pub figures: Vec<String>,
    /// Cache keys of the inputs, in the node's input order.
    pub inputs: Vec<String>,
    /// Recompute even if cached (`--force KIND`).
    pub force: bool,
    /// `123` or, for a task of an array, `123_4`.
    pub job_id: String,
    pub log: PathBuf,
    pub resources: Resources,
    /// Unix seconds.
    pub submitted: u64,
}

pub fn jobs_dir(store: &Store) -> PathBuf {
    store.dir.join("jobs")
}

fn record_path(store: &Store, key: &str) -> PathBuf {
    jobs_dir(store).join(format!("{key}.json"))
}

pub fn read(store: &Store, key: &str) -> Option<JobRecord> {
    let b = std::fs::read(record_path(store, key)).ok()?;
    serde_json::from_slice(&b).ok()
}

pub fn write(store: &Store, r: &JobRecord) -> Result<()> {
    crate::table::write_atomic(&record_path(store, &r.key), &serde_json::to_vec_pretty(r)?)
}

/// Where a job is, as Slurm reports it.
#[derive(Debug, Clone, PartialEq)]
pub enum JobState {
    /// Pending, with Slurm's reason (`Resources`, `Priority`, `Dependency`, ...).
    Queued {
        reason: String,
    },
    Running,
    Completed,
    /// Ended otherwise: Slurm's state (FAILED, TIMEOUT, OUT_OF_MEMORY, CANCELLED,
    /// NODE_FAIL, ...) and reason.
    Ended {
        state: String,
        reason: String,
    },
    /// Slurm no longer knows the job (it ended longer ago than MinJobAge).
    Unknown,
}

impl JobState {
    pub fn is_active(&self) -> bool {
        matches!(self, JobState::Queued { .. } | JobState::Running)
    }
}

/// States of this user's jobs that Slurm still knows, by job id (`123`, `123_4`).
/// A failing `squeue` is asked again up to four times, 2 s apart: a controller
/// busy with ending jobs can refuse a query for a moment, and the submitter
/// should not give up its jobs for that (a query changes nothing, so a retry is
/// safe).
pub fn query() -> Result<HashMap<String, JobState>> {
    let mut attempt = 0;
    let out = loop {
        let out = squeue()?;
        attempt += 1;
        if out.status.success() || attempt == 5 {
            break out;
        }
        std::thread::sleep(std::time::Duration::from_secs(2));
    };
    if !out.status.success() {
        bail!(
            "squeue failed 5 times, the last: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let mut m = HashMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let f: Vec<&str> = line.trim().splitn(3, '|').collect();
        if f.len() < 3 {
            continue;
        }
        let (id, state, reason) = (f[0], f[1], f[2]);
        let s = match state {
            "PENDING" | "REQUEUED" | "SUSPENDED" | "RESIZING" | "REQUEUE_HOLD" | "REQUEUE_FED" => {
                JobState::Queued {
                    reason: reason.to_string(),
                }
            }
            "RUNNING" | "CONFIGURING" | "COMPLETING" | "STAGE_OUT" | "SIGNALING" => {
                JobState::Running
            }
            "COMPLETED" => JobState::Completed,
            other => JobState::Ended {
                state: other.to_string(),
                reason: reason.to_string(),
            },
        };
        // A pending array shows as `123_[0-15]`: expand it.
        if let Some((base, range)) = id.split_once("_[") {
            for idx in expand_range(range.trim_end_matches(']')) {
                m.insert(format!("{base}_{idx}"), s.clone());
            }
        } else {
            m.insert(id.to_string(), s);
        }
    }
    Ok(m)
}

/// One `squeue` of this user's jobs, every state.
fn squeue() -> Result<std::process::Output> {
    Command::new("squeue")
        .args([
            "--me",
            "--noheader",
            "--array",
            "--states=all",
            "--format=%i|%T|%r",
        ])
        .stderr(Stdio::piped())
        .output()
        .context("running squeue (is Slurm installed and on PATH?)")
}

/// `0-3,7,9-10%4` -> 0, 1, 2, 3, 7, 9, 10.
fn expand_range(r: &str) -> Vec<u64> {
    let r = r.split('%').next().unwrap_or("");
    let mut v = Vec::new();
    for part in r.split(',') {
        match part.split_once('-') {
            Some((a, b)) => {
                if let (Ok(a), Ok(b)) = (a.parse::<u64>(), b.parse::<u64>()) {
                    v.extend(a..=b);
                }
            }
            None => v.extend(part.parse::<u64>().ok()),
        }
    }
    v
}

/// Slurm's account of a job that ended: `JobState=... Reason=... ExitCode=...`.
pub fn details(job_id: &str) -> Option<String> {
    let out = Command::new("scontrol")
        .args(["show", "job", "--oneliner", job_id])
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    let fields: Vec<&str> = text
        .split_whitespace()
        .filter(|f| {
            [
                "JobState=",
                "Reason=",
                "ExitCode=",
                "RunTime=",
                "TimeLimit=",
            ]
            .iter()
            .any(|p| f.starts_with(p))
        })
        .collect();
    (!fields.is_empty()).then(|| fields.join(" "))
}

/// The longest time limit a job of `s` may ask, minutes: `max_time`, else
/// the partition's; `None`: no limit known.
pub fn max_minutes(s: &Settings) -> Option<u64> {
    s.max_time_min
        .or_else(|| partition_limit(s.partition.as_deref()))
}

/// The time limit of `partition` (the default partition if `None`) in
/// minutes, from `sinfo`; `None` if unlimited or Slurm cannot be asked.
fn partition_limit(partition: Option<&str>) -> Option<u64> {
    let out = Command::new("sinfo")
        .args(["--noheader", "--format=%P %l"])
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines().find_map(|l| {
        let (name, limit) = l.split_once(' ')?;
        let wanted = match partition {
            Some(p) => name.trim_end_matches('*') == p,
            None => name.ends_with('*'),
        };
        if wanted {
            super::plan::minutes(limit)?
        } else {
            None
        }
    })
}

/// Submit a batch script (`script` on stdin) with sbatch `args`; the job id.
pub fn submit(args: &[String], script: &str) -> Result<String> {
    let mut child = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("running sbatch (is Slurm installed and on PATH?)")?;
    child
        .stdin
        .take()
        .expect("piped stdin")
        .write_all(script.as_bytes())?;
    let out = child.wait_with_output()?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints `id` or `id;cluster`.
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        bail!("sbatch printed no job id: '{}'", text.trim());
    }
    Ok(id)
}

/// The last `n` lines of a job log (empty if it cannot be read).
pub fn log_tail(path: &Path, n: usize) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..]
        .iter()
        .map(|s| s.to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_ranges_expand() {
        assert_eq!(expand_range("0-3,7,9-10%4"), vec![0, 1, 2, 3, 7, 9, 10]);
        assert_eq!(expand_range("5"), vec![5]);
    }
}
