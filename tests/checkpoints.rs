//! Long simulations survive: a simulation killed with SIGKILL about halfway
//! resumes from its last checkpoint on the next `repro figure` and writes the
//! same Parquet bytes as an uninterrupted build, also when its newest
//! checkpoint was truncated (quarantined; the one before is used). `repro
//! status` shows where it stopped; the checkpoints are gone once the stage is
//! done.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// One simulation of ~230 time units at phi = 0.77 (a few CPU seconds),
/// checkpointed every 25, gathered by a one-stage figure.
const EXPERIMENT: &str = "\
description: A ci-sized simulation checkpointed every 25 time units
kind: simulate
seed: 77
params:
  eps: 0.9
  n: 1000
  tau_guess: {A: 0.76, B: 0.148, phi0: 0.83}
  relax_tau: 9
  origins: 4
  spacing_tau: 2
  lag_min: 0.05
  lag_max_tau: 10
  lags_per_decade: 6
  overlap_spacing_tau: 0.5
  checkpoint_every: 25
profiles:
  ci:
    grid:
      phi: [0.77]
    replicas: 1
";

const PIPELINE: &str = "\
description: The run summary of the checkpointed simulation
stages:
  - name: runs
    kind: run_summary
    map: ckpt
";

fn root() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (sub, name, text) in [
        ("experiments", "ckpt.yaml", EXPERIMENT),
        ("pipelines", "figckpt.yaml", PIPELINE),
    ] {
        std::fs::create_dir_all(dir.path().join(sub)).unwrap();
        std::fs::write(dir.path().join(sub).join(name), text).unwrap();
    }
    dir
}

fn figure(root: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_repro"));
    c.args([
        "figure",
        "figckpt",
        "--profile",
        "ci",
        "--jobs",
        "1",
        "--root",
    ])
    .arg(root);
    c
}

fn build(root: &Path) -> String {
    let o: Output = figure(root).output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "repro figure failed:\n{text}");
    text
}

/// The simulate stage's Parquet bytes in the store of `root`, if it is done.
fn trajectory(root: &Path) -> Option<Vec<u8>> {
    let store = root.join(".repro/store");
    for shard in std::fs::read_dir(store.join("entries")).ok()?.flatten() {
        for e in std::fs::read_dir(shard.path()).unwrap().flatten() {
            let v: serde_json::Value =
                serde_json::from_slice(&std::fs::read(e.path()).unwrap()).unwrap();
            if v["kind"] == "simulate" {
                let h = v["files"]["parquet"].as_str().unwrap();
                return Some(std::fs::read(store.join("objects").join(&h[..2]).join(h)).unwrap());
            }
        }
    }
    None
}

/// The checkpoint directories of the store of `root`.
fn checkpoint_dirs(root: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(root.join(".repro/store/checkpoints"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .collect()
}

/// The checkpoint files of the store of `root`, newest first, with their times.
fn checkpoints(root: &Path) -> Vec<(PathBuf, f64)> {
    let mut v: Vec<(PathBuf, f64)> = checkpoint_dirs(root)
        .iter()
        .flat_map(|d| std::fs::read_dir(d).unwrap().flatten())
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let t = name
                .strip_prefix('t')?
                .strip_suffix(".ckpt")?
                .parse()
                .ok()?;
            Some((e.path(), t))
        })
        .collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1));
    v
}

/// The fraction of the run done, from its progress file.
fn fraction(root: &Path) -> f64 {
    checkpoint_dirs(root)
        .iter()
        .filter_map(|d| std::fs::read(d.join("progress.json")).ok())
        .filter_map(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .filter_map(|v| v["fraction"].as_f64())
        .fold(0.0, f64::max)
}

/// Start a build and SIGKILL it once the run is about halfway and has two
/// checkpoints.
fn kill_halfway(root: &Path) {
    let mut child = figure(root)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !(checkpoints(root).len() >= 2 && fraction(root) >= 0.4) {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the build ended before it was halfway"
        );
        assert!(start.elapsed() < Duration::from_secs(300), "no checkpoint");
        std::thread::sleep(Duration::from_millis(10));
    }
    // SIGKILL: nothing of the process runs after it.
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        trajectory(root).is_none(),
        "killed too late: the stage is done"
    );
}

/// The uninterrupted build's trajectory.
fn reference() -> &'static [u8] {
    static REF: OnceLock<Vec<u8>> = OnceLock::new();
    REF.get_or_init(|| {
        let r = root();
        let out = build(r.path());
        assert!(!out.contains("resumed"), "{out}");
        assert!(checkpoint_dirs(r.path()).is_empty(), "checkpoints left");
        trajectory(r.path()).unwrap()
    })
}

#[test]
fn a_killed_simulation_resumes_to_the_same_bytes() {
    let r = root();
    kill_halfway(r.path());
    let (_, last) = checkpoints(r.path())[0].clone();
    // `repro status` shows where the run stopped.
    let o = Command::new(env!("CARGO_BIN_EXE_repro"))
        .args(["status", "figckpt", "--profile", "ci", "--root"])
        .arg(r.path())
        .output()
        .unwrap();
    let status = String::from_utf8_lossy(&o.stdout);
    assert!(
        status.contains(&format!("last checkpoint at t = {last} ("))
            && status.contains("% of the run"),
        "{status}"
    );
    let out = build(r.path());
    assert!(
        out.contains(&format!("resumed from the checkpoint at t = {last} ")),
        "{out}"
    );
    assert!(trajectory(r.path()).unwrap() == reference(), "bytes differ");
    assert!(checkpoint_dirs(r.path()).is_empty(), "checkpoints left");
}

#[test]
fn a_truncated_checkpoint_is_quarantined_and_the_one_before_used() {
    let r = root();
    kill_halfway(r.path());
    let saved = checkpoints(r.path());
    let (newest, before) = (&saved[0].0, saved[1].1);
    let bytes = std::fs::read(newest).unwrap();
    std::fs::write(newest, &bytes[..bytes.len() / 3]).unwrap();
    let out = build(r.path());
    assert!(out.contains("is unusable (truncated"), "{out}");
    assert!(
        out.contains(&format!("resumed from the checkpoint at t = {before} ")),
        "{out}"
    );
    let quarantined = std::fs::read_dir(r.path().join(".repro/store/quarantine"))
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("checkpoint-"))
        .count();
    assert_eq!(quarantined, 1);
    assert!(trajectory(r.path()).unwrap() == reference(), "bytes differ");
}
