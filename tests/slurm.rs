//! The Slurm executor against a real Slurm (`scripts/slurm-local.sh start`): a ci
//! figure built through Slurm equals the local build byte for byte; a job killed
//! by scancel, a job over its time limit and a killed submitter are reported and
//! recovered from.
//!
//! Without a reachable Slurm every test prints SKIPPED and passes, unless
//! `REPRO_REQUIRE_SLURM=1` (set by `.ci/run` and `make test-slurm` once Slurm is
//! up), where it fails.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Tests that need both CPUs of a small node run one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn slurm_available(test: &str) -> bool {
    let state = || -> Option<String> {
        let o = Command::new("sinfo")
            .args(["--noheader", "--format=%T"])
            .output()
            .ok()?;
        o.status
            .success()
            .then(|| String::from_utf8_lossy(&o.stdout).into_owned())
    };
    let usable = |s: &str| {
        s.lines().any(|l| {
            ["idle", "mixed", "allocated"]
                .iter()
                .any(|u| l.starts_with(u))
        })
    };
    // A node still cleaning up after another test's killed or timed-out job
    // reports another state (`completing`) for a few seconds: wait for it, up to
    // a minute. Without Slurm (sinfo fails) there is nothing to wait for.
    let mut ok = false;
    let start = Instant::now();
    while let Some(s) = state() {
        ok = usable(&s);
        if ok || start.elapsed() > Duration::from_secs(60) {
            break;
        }
        std::thread::sleep(Duration::from_secs(1));
    }
    if !ok {
        if std::env::var("REPRO_REQUIRE_SLURM").is_ok_and(|v| v == "1") {
            panic!("{test}: REPRO_REQUIRE_SLURM=1 but no Slurm node accepts jobs (sinfo)");
        }
        eprintln!(
            "SKIPPED {test}: no Slurm node accepts jobs here (start one with `sudo scripts/slurm-local.sh start`)"
        );
    }
    ok
}

fn repro() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_repro"));
    c.env("REPRO_SLURM_POLL_S", "1")
        .env(repro::cli::TOY_KINDS, "1");
    c
}

fn run(c: &mut Command) -> Output {
    let o = c.output().expect("repro runs");
    eprintln!(
        "--- {:?}\n{}{}",
        c,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// Every file under `dir`, relative path -> bytes.
fn files(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut m = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                m.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    m
}

/// The ci sweep with 2 replicas instead of its 6: the test compares the two
/// executors, and a third of the runs keeps it short.
fn two_replicas_at_ci(spec: &Path) {
    let text = std::fs::read_to_string(spec).unwrap();
    let ci = text.find("\n  ci:").expect("eps09.yaml has a ci profile");
    let at = ci
        + text[ci..]
            .find("replicas: ")
            .expect("its ci profile sets replicas");
    let end = at + text[at..].find('\n').unwrap();
    let text = format!("{}replicas: 2{}", &text[..at], &text[end..]);
    std::fs::write(spec, text).unwrap();
}

#[test]
fn a_ci_figure_built_through_slurm_equals_the_local_build() {
    if !slurm_available("a_ci_figure_built_through_slurm_equals_the_local_build") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let project = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    let (local, remote) = (tmp.path().join("local"), tmp.path().join("slurm"));
    for r in [&local, &remote] {
        copy_dir(&project.join("experiments"), &r.join("experiments"));
        copy_dir(&project.join("pipelines"), &r.join("pipelines"));
        two_replicas_at_ci(&r.join("experiments/eps09.yaml"));
    }
    let o = run(repro()
        .args(["figure", "fig4", "--profile", "ci", "--root"])
        .arg(&local));
    assert!(o.status.success());
    // The store on another path, as on a cluster's shared filesystem.
    let store = tmp.path().join("shared-store");
    let o = run(repro()
        .args([
            "figure",
            "fig4",
            "--profile",
            "ci",
            "--executor",
            "slurm",
            "--root",
        ])
        .arg(&remote)
        .arg("--store")
        .arg(&store));
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("submitted Slurm job"), "{t}");
    // The 16 simulations of the sweep (8 phi, 2 replicas) went out as one
    // job, packed into fewer tasks (each a few CPU seconds at ci), as did the
    // analyses: each task ran its stages one after the other.
    assert!(t.contains(": 16 simulate stage(s) in "), "{t}");
    assert!(t.contains("tau_alpha stage(s) in "), "{t}");
    // Every stage's output: the same objects under the same keys, byte for byte.
    let a = files(&local.join(".repro/store/objects"));
    let b = files(&store.join("objects"));
    assert!(!a.is_empty());
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "same artifacts"
    );
    assert!(a == b, "artifact bytes differ");
    let ea: Vec<_> = files(&local.join(".repro/store/entries"))
        .into_keys()
        .collect();
    let eb: Vec<_> = files(&store.join("entries")).into_keys().collect();
    assert_eq!(ea, eb, "same cache keys");
    // And the published figure's Parquet tables.
    let pa = files(&local.join("results/fig4"));
    let pb = files(&remote.join("results/fig4"));
    let mut n = 0;
    for (k, v) in &pa {
        if k.extension().is_some_and(|e| e == "parquet") {
            assert_eq!(Some(v), pb.get(k), "{}", k.display());
            n += 1;
        }
    }
    assert!(n >= 5, "{n} parquet files");
    // A rerun submits nothing.
    let o = run(repro()
        .args([
            "figure",
            "fig4",
            "--profile",
            "ci",
            "--executor",
            "slurm",
            "--root",
        ])
        .arg(&remote)
        .arg("--store")
        .arg(&store));
    assert!(o.status.success());
    assert!(!text(&o).contains("submitted"), "{}", text(&o));
}

/// A figure of two slow toy simulations (`sleep_ms` each) read by one table.
fn slow_catalogue(root: &Path, sleep_ms: u64, slurm: &str) {
    std::fs::create_dir_all(root.join("experiments")).unwrap();
    std::fs::create_dir_all(root.join("pipelines")).unwrap();
    std::fs::write(
        root.join("experiments/slow.yaml"),
        format!(
            "description: slow toy sweep\nkind: toy_simulate\nseed: 3\nprofiles:\n  ci:\n    grid:\n      phi: [0.7, 0.75]\n    replicas: 1\n    params: {{n: 50, sleep_ms: {sleep_ms}}}\n{slurm}"
        ),
    )
    .unwrap();
    std::fs::write(
        root.join("pipelines/figslow.yaml"),
        "description: slow toy figure\nstages:\n  - name: overlap\n    kind: toy_analyse\n    map: slow\n    params: {a: 1.0}\n  - name: table\n    kind: table\n    gather: [overlap]\n",
    )
    .unwrap();
}

fn slurm_figure(root: &Path) -> Command {
    let mut c = repro();
    c.args([
        "figure",
        "figslow",
        "--profile",
        "ci",
        "--executor",
        "slurm",
        "--root",
    ])
    .arg(root);
    c
}

/// Job records of the store once `n` of them carry a job id that Slurm runs.
fn wait_running(root: &Path, n: usize, child: &mut Child) -> Vec<(String, String)> {
    let t0 = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut out = String::new();
            for pipe in [
                child
                    .stdout
                    .take()
                    .map(|p| Box::new(p) as Box<dyn std::io::Read>),
                child
                    .stderr
                    .take()
                    .map(|p| Box::new(p) as Box<dyn std::io::Read>),
            ]
            .into_iter()
            .flatten()
            {
                let mut pipe = pipe;
                let _ = pipe.read_to_string(&mut out);
            }
            panic!("the submitter exited early ({status}):\n{out}");
        }
        let mut recs = Vec::new();
        if let Ok(d) = std::fs::read_dir(root.join(".repro/store/jobs")) {
            for e in d.flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x == "json") {
                    let v: serde_json::Value =
                        serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
                    let id = v["job_id"].as_str().unwrap().to_string();
                    let key = v["key"].as_str().unwrap().to_string();
                    if !id.is_empty() {
                        recs.push((id, key));
                    }
                }
            }
        }
        let running = recs
            .iter()
            .filter(|(id, _)| {
                Command::new("squeue")
                    .args(["--noheader", "--format=%T", "-j", id])
                    .output()
                    .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "RUNNING")
            })
            .count();
        if running >= n {
            return recs;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "jobs did not start running within 120 s: {recs:?}"
        );
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// A submitter of the slow figure (sleeping `sleep_ms` per simulation), once both
/// simulations run on Slurm; with the (job id, key) of each.
fn start_slow(root: &Path, sleep_ms: u64) -> (Child, Vec<(String, String)>) {
    // One stage per job (short stages are otherwise packed into one task),
    // so that one of the two can be cancelled alone.
    slow_catalogue(root, sleep_ms, "    slurm: {pack_seconds: 0}\n");
    let mut child = slurm_figure(root)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let recs = wait_running(root, 2, &mut child);
    (child, recs)
}

fn entry_exists(root: &Path, key: &str) -> bool {
    root.join(".repro/store/entries")
        .join(&key[..2])
        .join(format!("{key}.json"))
        .exists()
}

#[test]
fn a_job_killed_by_scancel_is_reported_and_only_it_is_resubmitted() {
    if !slurm_available("a_job_killed_by_scancel_is_reported_and_only_it_is_resubmitted") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let (child, recs) = start_slow(root, 6000);
    let (victim, victim_key) = recs[0].clone();
    assert!(
        Command::new("scancel")
            .arg(&victim)
            .status()
            .unwrap()
            .success()
    );
    let o = child.wait_with_output().unwrap();
    let t = text(&o);
    eprintln!("{t}");
    assert!(!o.status.success(), "a cancelled stage fails the run");
    // Job id, Slurm's state and reason, and the log path.
    assert!(
        t.contains(&format!("Slurm job {victim} ended without a result")),
        "{t}"
    );
    assert!(t.contains("CANCELLED"), "{t}");
    assert!(t.contains(&format!("{victim}.log")), "{t}");
    assert!(
        !entry_exists(root, &victim_key),
        "nothing of it in the store"
    );
    // The other simulation finished and is kept.
    let other = recs.iter().find(|(id, _)| *id != victim).unwrap();
    assert!(entry_exists(root, &other.1));
    // `repro status` shows the failed job.
    let o = run(repro()
        .args(["status", "figslow", "--profile", "ci", "--root"])
        .arg(root));
    let s = text(&o);
    assert!(s.contains(&format!("failed (job {victim}")), "{s}");
    // A rerun resubmits only the cancelled simulation, then the rest.
    let o = run(&mut slurm_figure(root));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("resubmitting"), "{t}");
    assert!(t.contains(": 1 toy_simulate stage(s)"), "{t}");
    assert!(!t.contains(": 2 toy_simulate stage(s)"), "{t}");
    assert!(entry_exists(root, &victim_key));
}

/// A job killed at its time limit goes again once with twice the planned
/// limit (that it goes only once: the unit test of
/// `resubmit_after_time_limit`). About five minutes of waiting
/// (Slurm's smallest limit is one minute), so it runs in `make test-slurm`.
#[test]
#[ignore = "five minutes: run by `make test-slurm`"]
fn a_job_over_its_time_limit_is_resubmitted_once_with_a_longer_limit() {
    if !slurm_available("a_job_over_its_time_limit_is_resubmitted_once_with_a_longer_limit") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let tmp = tempfile::tempdir().unwrap();
    // One minute (the profile's `--time=1`) for simulations sleeping 150 s: the
    // first jobs time out, the second ones (the planned two minutes, twice)
    // finish.
    let root = tmp.path().join("once");
    slow_catalogue(
        &root,
        150_000,
        "    slurm: {extra: [\"--time=1\"], time_margin: 1}\n",
    );
    let o = run(&mut slurm_figure(&root));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("hit its time limit"), "{t}");
    assert!(t.contains("resubmitting once with 2x the limit"), "{t}");
    assert!(t.contains("0-00:04:00"), "{t}");
}

#[test]
fn a_killed_submitter_is_resumed_without_resubmitting_running_jobs() {
    if !slurm_available("a_killed_submitter_is_resumed_without_resubmitting_running_jobs") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let (mut child, recs) = start_slow(root, 8000);
    child.kill().unwrap();
    child.wait().unwrap();
    // While the jobs run, status names them.
    let o = run(repro()
        .args(["status", "figslow", "--profile", "ci", "--root"])
        .arg(root));
    let s = text(&o);
    for (id, _) in &recs {
        assert!(s.contains(&format!("running (job {id})")), "{s}");
    }
    let o = run(&mut slurm_figure(root));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    for (id, _) in &recs {
        assert!(
            t.contains(&format!("job {id} is running; waiting for it")),
            "{t}"
        );
    }
    assert!(
        !t.contains("toy_simulate stage(s)"),
        "no simulation resubmitted: {t}"
    );
    // The result equals a local build of the same catalogue.
    let local = tmp.path().join("local");
    slow_catalogue(&local, 8000, "");
    let o = run(repro()
        .args(["figure", "figslow", "--profile", "ci", "--root"])
        .arg(&local));
    assert!(o.status.success());
    assert_eq!(
        files(&root.join("results/figslow"))
            .into_iter()
            .filter(|(k, _)| k.extension().is_some_and(|e| e == "parquet"))
            .collect::<Vec<_>>(),
        files(&local.join("results/figslow"))
            .into_iter()
            .filter(|(k, _)| k.extension().is_some_and(|e| e == "parquet"))
            .collect::<Vec<_>>()
    );
}

/// A simulation of about 85 CPU seconds, checkpointed every 500 time units
/// (~3 s), gathered by a one-stage figure; `slurm`: the profile's block.
fn long_catalogue(root: &Path, slurm: &str) {
    std::fs::create_dir_all(root.join("experiments")).unwrap();
    std::fs::create_dir_all(root.join("pipelines")).unwrap();
    std::fs::write(
        root.join("experiments/long.yaml"),
        format!(
            "description: one long simulation\nkind: simulate\nseed: 5\nparams:\n  eps: 0.9\n  n: 1000\n  tau_guess: {{A: 45, B: 0.148, phi0: 0.83}}\n  relax_tau: 9\n  origins: 4\n  spacing_tau: 2\n  lag_min: 0.05\n  lag_max_tau: 10\n  lags_per_decade: 3\n  checkpoint_every: 500\nprofiles:\n  ci:\n    grid:\n      phi: [0.77]\n    replicas: 1\n{slurm}"
        ),
    )
    .unwrap();
    std::fs::write(
        root.join("pipelines/figlong.yaml"),
        "description: the long simulation's summary\nstages:\n  - name: runs\n    kind: run_summary\n    map: long\n",
    )
    .unwrap();
}

/// The simulate stage's Parquet bytes in `store`.
fn long_trajectory(store: &Path) -> Vec<u8> {
    for bytes in files(&store.join("entries")).into_values() {
        let v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        if v["kind"] == "simulate" {
            let h = v["files"]["parquet"].as_str().unwrap();
            return std::fs::read(store.join("objects").join(&h[..2]).join(h)).unwrap();
        }
    }
    panic!("no simulate entry in {}", store.display());
}

/// The child's stdout and stderr as they come, in one string.
fn collect(child: &mut Child) -> std::sync::Arc<Mutex<String>> {
    let out = std::sync::Arc::new(Mutex::new(String::new()));
    let pipes: Vec<Box<dyn Read + Send>> = vec![
        Box::new(child.stdout.take().unwrap()),
        Box::new(child.stderr.take().unwrap()),
    ];
    for mut pipe in pipes {
        let out = out.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                out.lock()
                    .unwrap()
                    .push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        });
    }
    out
}

/// The first job of the chain the submitter announced, once the store holds a
/// checkpoint of its simulation.
fn first_job_at_a_checkpoint(root: &Path, out: &Mutex<String>, child: &mut Child) -> String {
    let t0 = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            panic!(
                "the submitter ended ({status}) before a checkpoint:\n{}",
                out.lock().unwrap()
            );
        }
        let text = out.lock().unwrap().clone();
        let first = text
            .split("submitted Slurm job chain ")
            .nth(1)
            .and_then(|r| r.split_whitespace().next())
            .map(str::to_string);
        // checkpoints/KEY/tTIME.ckpt (listed only: the run replaces them).
        let checkpointed = std::fs::read_dir(root.join(".repro/store/checkpoints"))
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|d| std::fs::read_dir(d.path()).ok())
            .flatten()
            .flatten()
            .any(|f| f.path().extension().is_some_and(|x| x == "ckpt"));
        if let (Some(first), true) = (first, checkpointed) {
            return first;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(180),
            "no checkpoint within 180 s:\n{text}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Two minutes of two CPUs (a run planned longer than Slurm's shortest time
/// limit, built twice): run by `make test-slurm`, not by `make test`, whose CI
/// run must stay under 20 minutes on 2 cores. The first job is ended at its
/// first checkpoint by the test, so a later one resumes however fast the
/// machine is.
#[test]
#[ignore = "two minutes: run by `make test-slurm`"]
fn a_run_longer_than_the_partition_limit_finishes_through_a_chain() {
    if !slurm_available("a_run_longer_than_the_partition_limit_finishes_through_a_chain") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let tmp = tempfile::tempdir().unwrap();
    let (local, remote) = (tmp.path().join("local"), tmp.path().join("slurm"));
    long_catalogue(&local, "");
    long_catalogue(&remote, "    slurm: {max_time: \"1\"}\n");
    let figure = |root: &Path, slurm: bool| {
        let mut c = repro();
        c.args(["figure", "figlong", "--profile", "ci", "--root"])
            .arg(root);
        if slurm {
            c.args(["--executor", "slurm"]);
        }
        c
    };
    // The plan shows the chain.
    let o = run(figure(&remote, true).arg("--dry-run"));
    let t = text(&o);
    assert!(
        t.contains("--time=0-00:01:00") && t.contains("as a chain of"),
        "{t}"
    );
    // The local build on the other CPU meanwhile.
    let local_build = std::thread::spawn({
        let local = local.clone();
        move || run(&mut figure(&local, false))
    });
    let mut child = figure(&remote, true)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = collect(&mut child);
    // The first job of the chain ends at its first checkpoint whatever the
    // machine's speed: the test sends it what Slurm sends at a time limit
    // (SIGTERM, then SIGKILL), so the run cannot finish inside it.
    let first = first_job_at_a_checkpoint(&remote, &out, &mut child);
    assert!(
        Command::new("scancel")
            .arg(&first)
            .status()
            .unwrap()
            .success()
    );
    let status = child.wait().unwrap();
    let t = out.lock().unwrap().clone();
    eprintln!("{t}");
    assert!(status.success(), "{t}");
    assert!(t.contains("submitted Slurm job chain"), "{t}");
    assert!(local_build.join().unwrap().status.success());
    // A later job of the chain resumed from the first job's checkpoint.
    let logs = files(&remote.join(".repro/store/jobs/log"));
    let resumed: Vec<&PathBuf> = logs
        .iter()
        .filter(|(_, b)| String::from_utf8_lossy(b).contains("resumed from the checkpoint at t = "))
        .map(|(p, _)| p)
        .collect();
    assert!(
        !resumed.is_empty()
            && resumed
                .iter()
                .all(|p| *p != &PathBuf::from(format!("{first}.log"))),
        "logs resuming: {resumed:?} (the first job: {first}); logs: {:?}",
        logs.keys().collect::<Vec<_>>()
    );
    assert!(
        long_trajectory(&remote.join(".repro/store"))
            == long_trajectory(&local.join(".repro/store")),
        "the chain's trajectory differs from the local build's"
    );
}

/// A toy sweep (two simulations) read by a `script` stage: a python3 script of
/// the standard library alone that lists its inputs in an SVG.
fn script_catalogue(root: &Path) {
    slow_catalogue(root, 0, "");
    std::fs::create_dir_all(root.join("scripts")).unwrap();
    std::fs::write(
        root.join("scripts/count.py"),
        "import json, os\n\
         inputs = json.load(open(os.environ['REPRO_INPUTS']))\n\
         args = json.load(open(os.environ['REPRO_PARAMS']))\n\
         labels = sorted(i['label'] for i in inputs)\n\
         text = args['title'] + ': ' + ', '.join(labels)\n\
         svg = '<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"600\" height=\"40\"><text x=\"5\" y=\"20\">' + text + '</text></svg>'\n\
         open(os.path.join(os.environ['REPRO_OUT'], 'count.svg'), 'w').write(svg)\n",
    )
    .unwrap();
    std::fs::write(
        root.join("pipelines/figscript.yaml"),
        "description: a script stage over a toy sweep\nstages:\n  - name: count\n    kind: script\n    gather: [slow]\n    params:\n      interpreter: python3\n      script: scripts/count.py\n      args: {title: runs}\n      images: [count.svg]\n",
    )
    .unwrap();
}

fn script_figure(root: &Path, executor: &str) -> Output {
    run(repro()
        .args([
            "figure",
            "figscript",
            "--profile",
            "ci",
            "--executor",
            executor,
            "--root",
        ])
        .arg(root))
}

/// A script stage runs under `--executor slurm` as any stage does: the same
/// outputs under the same keys as a local build, and an edit of the script
/// submits that stage alone.
#[test]
fn a_script_stage_runs_through_slurm_as_locally() {
    if !slurm_available("a_script_stage_runs_through_slurm_as_locally") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let tmp = tempfile::tempdir().unwrap();
    let (local, remote) = (tmp.path().join("local"), tmp.path().join("slurm"));
    for r in [&local, &remote] {
        script_catalogue(r);
    }
    assert!(script_figure(&local, "local").status.success());
    let o = script_figure(&remote, "slurm");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains(": 1 script stage(s)"), "{t}");
    let svg = std::fs::read_to_string(remote.join("results/figscript/count.svg")).unwrap();
    assert!(svg.contains("runs: slow[phi=0.7"), "{svg}");
    for d in ["objects", "entries"] {
        let a = files(&local.join(".repro/store").join(d));
        let b = files(&remote.join(".repro/store").join(d));
        assert_eq!(
            a.keys().collect::<Vec<_>>(),
            b.keys().collect::<Vec<_>>(),
            "{d}"
        );
        if d == "objects" {
            assert!(a == b, "artifact bytes differ");
        }
    }
    // The script edited: its stage alone is submitted, the simulations stay.
    let script = remote.join("scripts/count.py");
    let edited = std::fs::read_to_string(&script)
        .unwrap()
        .replace("': ' + ', '", "' - ' + ' ; '");
    std::fs::write(&script, edited).unwrap();
    let o = script_figure(&remote, "slurm");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains(": 1 script stage(s)"), "{t}");
    assert!(!t.contains("toy_simulate stage(s)"), "{t}");
    let svg = std::fs::read_to_string(remote.join("results/figscript/count.svg")).unwrap();
    assert!(svg.contains("runs - slow[phi=0.7"), "{svg}");
}
