//! The Slurm executor: the stage graph of the local executor, with the same cache,
//! keys and bytes, where each stage is computed by a Slurm job running the repro
//! binary itself (`repro worker --store S --key K`).
//!
//! A stage's key depends on its inputs' output bytes (early cut-off), so it is
//! known only once its inputs are in the store: a driver submits in waves. Each
//! wave's ready stages of one kind and one `slurm:` setting go out as one job
//! array (the simulations of a sweep: one array). The driver records every job in
//! the store (`jobs/KEY.json`), so it may exit or die: a rerun finds finished
//! stages in the store, waits for jobs still queued or running, and resubmits
//! those that failed. Workers write with the store's protocol (objects, then the
//! entry, each to a temporary name and renamed, under the stage's lock), so
//! nothing half-written enters the store.
//!
//! [`plan`]: resources from the planned work; [`state`]: job records and Slurm's
//! view of the jobs.

pub mod plan;
pub mod state;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, bail, ensure};

use super::cost;
use super::exec::{self, Outcome, RunReport, StageResult, State, stage_key};
use super::graph::{Graph, Node};
use super::progress::{self, Progress};
use super::registry::Registry;
use super::spec::Catalogue;
use super::stage::Planned;
use super::store::{Entry, Found, Store};
use super::{FigureRun, Workspace, needed_nodes, publish};
use plan::{Resources, Settings};
use state::{JobRecord, JobState};

/// How to run on Slurm.
#[derive(Debug, Clone)]
pub struct SlurmOptions {
    /// Stage kinds to rerun even when cached.
    pub force: Vec<String>,
    /// Bars on a terminal, else plain lines (as the local executor).
    pub progress: bool,
    /// How often to ask Slurm about the jobs.
    pub poll: Duration,
    /// The repro binary the jobs run (on a filesystem the nodes see).
    pub binary: PathBuf,
}

impl SlurmOptions {
    /// This binary, polling every `REPRO_SLURM_POLL_S` seconds (default 5).
    pub fn new(force: Vec<String>, progress: bool) -> Result<Self> {
        let poll = std::env::var("REPRO_SLURM_POLL_S")
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
            .filter(|s| *s > 0.0)
            .unwrap_or(5.0);
        Ok(SlurmOptions {
            force,
            progress,
            poll: Duration::from_secs_f64(poll),
            binary: std::env::current_exe().context("locating the repro binary")?,
        })
    }
}

fn absolute(p: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(p).ok();
    p.canonicalize()
        .with_context(|| format!("resolving {}", p.display()))
}

/// Build figures `ids` (all if empty) through Slurm and publish the complete ones,
/// like [`super::run_figures`]. Returns when every job has ended.
pub fn run_figures(
    ws: &Workspace,
    reg: &Registry,
    ids: &[String],
    profile: &str,
    opts: &SlurmOptions,
) -> Result<FigureRun> {
    let ws = Workspace {
        root: absolute(&ws.root)?,
        results: ws.results.clone(),
        store: absolute(&ws.store)?,
    };
    let cat = Catalogue::load(&ws.root)?;
    let graph = ws.plan(reg, ids, profile)?;
    let settings = plan::settings(&cat, &graph)?;
    let store = Store::open(&ws.store)?;
    let nodes = needed_nodes(&graph);
    let report = Driver {
        ws: &ws,
        graph: &graph,
        reg,
        store: &store,
        opts,
        settings: &settings,
    }
    .run(&nodes)?;
    for fig in &graph.figures {
        if report.complete(fig) {
            publish::publish(&ws.root, &ws.results, &graph, fig, &report, reg, &store)?;
        }
    }
    Ok(FigureRun { graph, report })
}

struct Driver<'a> {
    ws: &'a Workspace,
    graph: &'a Graph,
    reg: &'a Registry,
    store: &'a Store,
    opts: &'a SlurmOptions,
    settings: &'a [Settings],
}

fn now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// The factor on the time limit of a job that ended at its limit without a
/// result (Slurm state TIMEOUT, from `squeue` or `scontrol`'s `details`),
/// the first time only: the plan was short, so the stage goes again with twice
/// the limit (a simulation resumes from its last checkpoint). `None`: it ended
/// otherwise, or was resubmitted already.
pub fn resubmit_after_time_limit(st: &JobState, details: &str, resubmitted: bool) -> Option<f64> {
    let timeout = matches!(st, JobState::Ended { state, .. } if state.starts_with("TIMEOUT"))
        || details.contains("TIMEOUT");
    (timeout && !resubmitted).then_some(2.0)
}

fn describe(s: &JobState) -> String {
    match s {
        JobState::Queued { reason } => format!("queued ({reason})"),
        JobState::Running => "running".into(),
        JobState::Completed => "completed".into(),
        JobState::Ended { state, reason } => format!("{state} ({reason})"),
        JobState::Unknown => "no longer known to Slurm".into(),
    }
}

impl Driver<'_> {
    fn run(&self, nodes: &[usize]) -> Result<RunReport> {
        let g = self.graph;
        let n = g.nodes.len();
        let log = self
            .store
            .dir
            .parent()
            .map(|d| d.join("log").join("LAST-RUN.log"));
        let progress = Progress::new(self.opts.progress, nodes.len(), log.as_deref());
        // Slurm runs every ready stage at once: the end is the longest chain's.
        let classes: Vec<String> = g
            .nodes
            .iter()
            .map(|n| progress::class_name(&n.kind, n.label()))
            .collect();
        progress.plan(
            nodes,
            &cost::node_seconds(g, self.reg, &Default::default()),
            &classes,
            nodes.len(),
        );
        let mut results: Vec<Option<StageResult>> = vec![None; n];
        let mut watching: BTreeMap<usize, JobRecord> = BTreeMap::new();
        // Stages resubmitted once after their time limit, with the factor on it.
        let mut longer: BTreeMap<usize, f64> = BTreeMap::new();
        let mut retry: Vec<(usize, String, Vec<Entry>)> = Vec::new();
        let mut damaged = Vec::new();
        let finish = |results: &mut Vec<Option<StageResult>>, i: usize, r: StageResult| {
            let what = match &r.outcome {
                Outcome::Cached => "cached".to_string(),
                Outcome::Executed => "executed".to_string(),
                Outcome::Failed { error, .. } => format!("FAILED ({error})"),
                Outcome::Skipped { failed_input } => {
                    format!("skipped (input {failed_input} failed)")
                }
            };
            progress.finish(i, g.nodes[i].label(), &g.nodes[i].kind, &what);
            results[i] = Some(r);
        };
        loop {
            let jobs = state::query()?;
            // Jobs that ended: the store says whether they delivered.
            for (i, rec) in watching.clone() {
                let st = jobs.get(&rec.job_id).cloned().unwrap_or(JobState::Unknown);
                if st.is_active() {
                    continue;
                }
                watching.remove(&i);
                // A forced stage had an entry before: only a completed job counts.
                let entry = self.store.lookup(&rec.key);
                let why = || state::details(&rec.job_id).unwrap_or_else(|| describe(&st));
                if entry.is_none() && !rec.force {
                    let w = why();
                    if let Some(f) = resubmit_after_time_limit(&st, &w, longer.contains_key(&i)) {
                        progress.line(&format!(
                            "{}: Slurm job {} hit its time limit ({w}); resubmitting once with {f}x the limit{}",
                            rec.label,
                            rec.job_id,
                            if self.reg.planned(&rec.kind, &g.nodes[i].parsed).is_some() {
                                ", resuming from its last checkpoint"
                            } else {
                                ""
                            }
                        ));
                        longer.insert(i, f);
                        let inputs = rec
                            .inputs
                            .iter()
                            .filter_map(|k| self.store.lookup(k))
                            .collect();
                        retry.push((i, rec.key.clone(), inputs));
                        continue;
                    }
                }
                let r = match entry {
                    Some(e) if !rec.force || st == JobState::Completed => StageResult {
                        outcome: Outcome::Executed,
                        entry: Some(e),
                    },
                    _ => {
                        let why = why();
                        StageResult {
                            outcome: Outcome::Failed {
                                error: format!(
                                    "Slurm job {} ended without a result: {why}; log {}",
                                    rec.job_id,
                                    rec.log.display()
                                ),
                                log: state::log_tail(&rec.log, 15),
                            },
                            entry: None,
                        }
                    }
                };
                finish(&mut results, i, r);
            }
            // Stages whose inputs are all done: cached, adopted or ready.
            let mut ready: Vec<(usize, String, Vec<Entry>)> = std::mem::take(&mut retry);
            for &i in nodes {
                if results[i].is_some()
                    || watching.contains_key(&i)
                    || ready.iter().any(|(j, _, _)| *j == i)
                {
                    continue;
                }
                let node = &g.nodes[i];
                let mut inputs = Vec::new();
                let mut failed = None;
                let mut waiting = false;
                for &j in &node.inputs {
                    match &results[j] {
                        Some(StageResult { entry: Some(e), .. }) => inputs.push(e.clone()),
                        Some(_) => failed = Some(g.nodes[j].label().to_string()),
                        None => waiting = true,
                    }
                }
                if let Some(failed_input) = failed {
                    let r = StageResult {
                        outcome: Outcome::Skipped { failed_input },
                        entry: None,
                    };
                    finish(&mut results, i, r);
                    continue;
                }
                if waiting {
                    continue;
                }
                let digests: Vec<&str> = inputs.iter().map(|e| e.digest.as_str()).collect();
                let key = stage_key(g, self.reg, node, &digests);
                if !self.opts.force.contains(&node.kind) {
                    match self.store.find(&key) {
                        Found::Hit(e) => {
                            for l in &node.labels {
                                let _ = self.store.set_label(l, &e.key);
                            }
                            let r = StageResult {
                                outcome: Outcome::Cached,
                                entry: Some(e),
                            };
                            finish(&mut results, i, r);
                            continue;
                        }
                        Found::Damaged { problems, .. } => {
                            for msg in exec::quarantine(self.store, &problems) {
                                progress.line(&msg);
                                damaged.push(msg);
                            }
                        }
                        Found::Miss => {}
                    }
                }
                match state::read(self.store, &key) {
                    Some(rec) if jobs.get(&rec.job_id).is_some_and(JobState::is_active) => {
                        progress.line(&format!(
                            "{}: job {} is {}; waiting for it",
                            node.label(),
                            rec.job_id,
                            describe(&jobs[&rec.job_id])
                        ));
                        watching.insert(i, rec);
                    }
                    Some(rec) => {
                        let st = jobs.get(&rec.job_id).cloned().unwrap_or(JobState::Unknown);
                        let why = state::details(&rec.job_id).unwrap_or_else(|| describe(&st));
                        progress.line(&format!(
                            "{}: earlier job {} ended without a result ({why}; log {}); resubmitting",
                            node.label(),
                            rec.job_id,
                            rec.log.display()
                        ));
                        ready.push((i, key, inputs));
                    }
                    None => ready.push((i, key, inputs)),
                }
            }
            if !ready.is_empty() {
                for rec in self.submit(&ready, &longer)? {
                    let i = ready
                        .iter()
                        .find(|(_, k, _)| *k == rec.key)
                        .map(|(i, _, _)| *i)
                        .expect("submitted key is ready");
                    watching.insert(i, rec);
                }
            }
            if watching.is_empty() {
                break;
            }
            progress.beat(super::progress::heartbeat());
            std::thread::sleep(self.opts.poll);
        }
        progress.done();
        let mut out = BTreeMap::new();
        for &i in nodes {
            out.insert(i, results[i].take().expect("every node was resolved"));
        }
        Ok(RunReport {
            results: out,
            damaged,
        })
    }

    /// Submit `ready` stages: one job (an array when several) per kind and
    /// settings. Records each stage's job in the store; returns the records.
    /// `longer`: stages resubmitted after their time limit, with the factor on it.
    fn submit(
        &self,
        ready: &[(usize, String, Vec<Entry>)],
        longer: &BTreeMap<usize, f64>,
    ) -> Result<Vec<JobRecord>> {
        let g = self.graph;
        let mut groups: BTreeMap<(String, String), Vec<usize>> = BTreeMap::new();
        for (k, (i, _, _)) in ready.iter().enumerate() {
            let s = serde_json::to_string(&self.settings[*i])?;
            groups
                .entry((g.nodes[*i].kind.clone(), s))
                .or_default()
                .push(k);
        }
        let logs = state::jobs_dir(self.store).join("log");
        std::fs::create_dir_all(&logs)?;
        let figures: Vec<String> = g.figures.iter().map(|f| f.id.clone()).collect();
        let mut out = Vec::new();
        for ((kind, _), members) in groups {
            let settings = &self.settings[ready[members[0]].0];
            let res: Vec<Resources> = members
                .iter()
                .map(|&k| {
                    let (i, _, inputs) = &ready[k];
                    plan::resources(
                        &g.nodes[*i].kind,
                        &g.nodes[*i].params,
                        self.reg
                            .planned(&g.nodes[*i].kind, &g.nodes[*i].parsed)
                            .as_ref(),
                        (input_bytes(self.store, inputs), inputs.len()),
                        settings,
                    )
                })
                .collect();
            let mem = res.iter().map(|r| r.mem_mib).max().unwrap_or(1);
            // Only simulations (kinds with a cost model) checkpoint.
            let resumable = self
                .reg
                .planned(&kind, &g.nodes[ready[members[0]].0].parsed)
                .is_some();
            // Short stages share a task (one after the other); a stage that
            // ran out of time once goes alone.
            let factor: Vec<f64> = members
                .iter()
                .map(|&k| longer.get(&ready[k].0).copied().unwrap_or(1.0))
                .collect();
            let plan::JobTasks {
                tasks,
                task_of,
                time_min: time,
            } = plan::job_tasks(&res, &factor, resumable, settings);
            let (time, links) = plan::chain(time, state::max_minutes(settings), resumable);
            let keys: Vec<&str> = members.iter().map(|&k| ready[k].1.as_str()).collect();
            let array = tasks.len() > 1;
            let mut args = vec![
                format!("--job-name=repro-{kind}"),
                "--cpus-per-task=1".to_string(),
                "--ntasks=1".to_string(),
                format!("--mem={mem}M"),
                format!("--time={}", plan::time_limit(time)),
                format!(
                    "--output={}",
                    logs.join(if array { "%A_%a.log" } else { "%j.log" })
                        .display()
                ),
            ];
            if array {
                args.push(format!("--array=0-{}", tasks.len() - 1));
            }
            args.extend(settings.sbatch_args());
            if members.iter().any(|&k| longer.contains_key(&ready[k].0)) {
                // After the profile's own options: a `--time` among them set the
                // limit the job hit.
                args.push(format!("--time={}", plan::time_limit(time)));
            }
            let worker = format!(
                "{} worker --store {}",
                shell_quote(&self.opts.binary.display().to_string()),
                shell_quote(&self.store.dir.display().to_string()),
            );
            let script = if tasks.iter().all(|t| t.len() == 1) {
                format!(
                    "#!/bin/bash\n# repro: {} stage(s) of kind {kind}\nKEYS=({})\nexec {worker} --key \"${{KEYS[${{SLURM_ARRAY_TASK_ID:-0}}]}}\"\n",
                    keys.len(),
                    keys.join(" "),
                )
            } else {
                // A task's stages one after the other; the task fails if one
                // does (the others still run: each is its own stage).
                let list: Vec<String> = tasks
                    .iter()
                    .map(|t| {
                        let k: Vec<&str> = t.iter().map(|&m| keys[m]).collect();
                        format!("\"{}\"", k.join(" "))
                    })
                    .collect();
                format!(
                    "#!/bin/bash\n# repro: {} stage(s) of kind {kind} in {} task(s)\nTASKS=({})\nstatus=0\nfor KEY in ${{TASKS[${{SLURM_ARRAY_TASK_ID:-0}}]}}; do\n  {worker} --key \"$KEY\" || status=$?\ndone\nexit $status\n",
                    keys.len(),
                    tasks.len(),
                    list.join(" "),
                )
            };
            // Records first (without a job id), so a worker always finds its record.
            let mut recs: Vec<JobRecord> = members
                .iter()
                .zip(&res)
                .map(|(&k, r)| {
                    let (i, key, inputs) = &ready[k];
                    let node = &g.nodes[*i];
                    JobRecord {
                        key: key.clone(),
                        label: node.label().to_string(),
                        kind: node.kind.clone(),
                        recipe: node.recipe.clone(),
                        root: self.ws.root.clone(),
                        profile: g.profile.clone(),
                        figures: figures.clone(),
                        inputs: inputs.iter().map(|e| e.key.clone()).collect(),
                        force: self.opts.force.contains(&node.kind),
                        job_id: String::new(),
                        log: PathBuf::new(),
                        resources: r.clone(),
                        submitted: now(),
                    }
                })
                .collect();
            for r in &recs {
                state::write(self.store, r)?;
            }
            // A chain: each job starts when the one before has ended (at its
            // time limit, or done: a worker whose stage is in the store exits)
            // and resumes from the last checkpoint. The records name the last.
            let mut id = state::submit(&args, &script)?;
            let mut chain = vec![id.clone()];
            for _ in 1..links {
                let mut after = args.clone();
                after.push(format!("--dependency=afterany:{id}"));
                id = state::submit(&after, &script)?;
                chain.push(id.clone());
            }
            eprintln!(
                "submitted Slurm job {}: {} {kind} stage(s){}, {mem} MiB and {} each",
                if links > 1 {
                    format!(
                        "chain {} (each resumes from the last checkpoint)",
                        chain.join(" -> ")
                    )
                } else {
                    id.clone()
                },
                keys.len(),
                if tasks.len() < keys.len() {
                    format!(" in {} task(s)", tasks.len())
                } else {
                    String::new()
                },
                plan::time_limit(time)
            );
            for (m, r) in recs.iter_mut().enumerate() {
                let t = task_of[m];
                if array {
                    r.job_id = format!("{id}_{t}");
                    r.log = logs.join(format!("{id}_{t}.log"));
                } else {
                    r.job_id = id.clone();
                    r.log = logs.join(format!("{id}.log"));
                }
                state::write(self.store, r)?;
            }
            out.extend(recs);
        }
        Ok(out)
    }
}

fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// Bytes of the files of `inputs` in the store.
fn input_bytes(store: &Store, inputs: &[Entry]) -> u64 {
    inputs.iter().map(|e| store.entry_bytes(e)).sum()
}

/// `repro worker`: compute the stage recorded under `key` in the store's job
/// records and write it to the store. Refuses when the specs or the binary
/// differ from the submitter's (the key would not match).
pub fn worker(store_dir: &Path, reg: &Registry, key: &str) -> Result<()> {
    let store = Store::open(store_dir)?;
    let rec = state::read(&store, key).with_context(|| {
        format!(
            "no job record {}/{key}.json: this stage was not submitted through this store",
            state::jobs_dir(&store).display()
        )
    })?;
    let ws = Workspace {
        root: rec.root.clone(),
        results: rec.root.join("results"),
        store: store_dir.to_path_buf(),
    };
    let graph = ws.plan(reg, &rec.figures, &rec.profile)?;
    let Some(i) = graph.nodes.iter().position(|n| n.recipe == rec.recipe) else {
        bail!(
            "stage {} is no longer in the plan of {} at profile {}: the specs under {} changed since it was submitted",
            rec.label,
            rec.figures.join(" "),
            rec.profile,
            rec.root.display()
        );
    };
    let node: &Node = &graph.nodes[i];
    ensure!(
        node.inputs.len() == rec.inputs.len(),
        "stage {}: the plan has {} inputs, the job record {}",
        rec.label,
        node.inputs.len(),
        rec.inputs.len()
    );
    let mut inputs = Vec::new();
    for (&j, k) in node.inputs.iter().zip(&rec.inputs) {
        let e = store.lookup(k).with_context(|| {
            format!(
                "input {} (key {k}) is not intact in the store {}",
                graph.nodes[j].label(),
                store_dir.display()
            )
        })?;
        inputs.push(exec::artifact(&store, reg, node, &graph.nodes[j], &e));
    }
    let digests: Vec<&str> = inputs.iter().map(|a| a.digest.as_str()).collect();
    let mine = stage_key(&graph, reg, node, &digests);
    ensure!(
        mine == key,
        "stage {}: this binary computes key {mine}, the submitter {key}: the repro binary (code fingerprint) differs from the submitter's",
        rec.label
    );
    let _lock = store.lock_key(key)?;
    if !rec.force && store.lookup(key).is_some() {
        eprintln!(
            "{} is already in the store (computed by another job)",
            rec.label
        );
        return Ok(());
    }
    eprintln!("computing {} ({}), key {key}", rec.label, rec.kind);
    match exec::compute(&store, reg, node, key.to_string(), &inputs, None) {
        Ok((e, _)) => {
            for l in &e.log {
                eprintln!("log: {l}");
            }
            eprintln!(
                "wrote {} file(s) of {} in {:.1} s",
                e.files.len(),
                rec.label,
                e.wall_s
            );
            Ok(())
        }
        Err((error, log)) => {
            for l in &log {
                eprintln!("log: {l}");
            }
            bail!("stage {} ({}) failed: {error}", rec.label, rec.kind)
        }
    }
}

/// Slurm state of the stages of `st` that are stale and have a job record:
/// `queued (job 12_3, Priority)`, `running (job 12_3)`, `failed (...)`.
pub fn job_states(
    graph: &Graph,
    st: &[(usize, State)],
    reg: &Registry,
    store: &Store,
) -> BTreeMap<usize, String> {
    let mut out = BTreeMap::new();
    if std::fs::read_dir(state::jobs_dir(store)).map_or(true, |mut d| d.next().is_none()) {
        return out;
    }
    let recs: Vec<_> = exec::stale_keys(graph, st, reg, store)
        .into_iter()
        .filter_map(|(i, key)| Some((i, state::read(store, &key)?)))
        .collect();
    if recs.is_empty() {
        return out;
    }
    let jobs = state::query();
    for (i, r) in recs {
        let s = match &jobs {
            Err(e) => format!("submitted as job {} (cannot ask Slurm: {e:#})", r.job_id),
            Ok(m) => match m.get(&r.job_id).cloned().unwrap_or(JobState::Unknown) {
                JobState::Queued { reason } => format!("queued (job {}, {reason})", r.job_id),
                JobState::Running => format!("running (job {})", r.job_id),
                other => format!(
                    "failed (job {}: {}; log {})",
                    r.job_id,
                    state::details(&r.job_id).unwrap_or_else(|| describe(&other)),
                    r.log.display()
                ),
            },
        };
        out.insert(i, s);
    }
    out
}

/// What `--executor slurm` would submit now for figures `ids`: the stale stages
/// grouped into jobs, with resources, and the total core-hours. Stages behind a
/// stale one are planned with the bytes their inputs are expected to have.
pub fn dry_run(
    ws: &Workspace,
    reg: &Registry,
    ids: &[String],
    profile: &str,
    force: &[String],
) -> Result<String> {
    let cat = Catalogue::load(&ws.root)?;
    let (graph, st) = super::figure_status(ws, reg, ids, profile, force)?;
    let settings = plan::settings(&cat, &graph)?;
    let store = Store::open(&ws.store)?;
    let mut groups: BTreeMap<(String, String), Vec<(usize, Resources)>> = BTreeMap::new();
    let mut cached = 0;
    let planned = |n: &Node| reg.planned(&n.kind, &n.parsed);
    for (i, s) in &st {
        let node = &graph.nodes[*i];
        let key = match s {
            State::Cached { .. } => {
                cached += 1;
                continue;
            }
            _ => node.kind.clone(),
        };
        // Input sizes: cached inputs as stored; simulations to come from their
        // planned frames (x, y as f64 per disk); other stages' outputs are small.
        let bytes: u64 = node
            .inputs
            .iter()
            .map(|&j| {
                let d = match st.iter().find(|(k, _)| *k == j) {
                    Some((_, State::Cached { key })) => store.lookup(key),
                    _ => None,
                };
                match d {
                    Some(e) => store.entry_bytes(&e),
                    None => planned(&graph.nodes[j]).map_or(0, |p| p.output_bytes),
                }
            })
            .sum();
        let r = plan::resources(
            &node.kind,
            &node.params,
            planned(node).as_ref(),
            (bytes, node.inputs.len()),
            &settings[*i],
        );
        let s = serde_json::to_string(&settings[*i].sbatch_args())?;
        groups.entry((key, s)).or_default().push((*i, r));
    }
    let mut out = String::new();
    let (mut expected, mut limit, mut longest) = (0.0f64, 0.0, 0.0f64);
    let mut task_count = 0;
    for ((kind, sargs), members) in &groups {
        let mem = members.iter().map(|(_, r)| r.mem_mib).max().unwrap_or(0);
        let first = members[0].0;
        let resumable = planned(&graph.nodes[first]).is_some();
        // As submitted: short stages share a task.
        let res: Vec<Resources> = members.iter().map(|(_, r)| r.clone()).collect();
        let plan::JobTasks {
            tasks,
            task_of,
            time_min: time,
        } = plan::job_tasks(&res, &vec![1.0; res.len()], resumable, &settings[first]);
        let (time, links) = plan::chain(time, state::max_minutes(&settings[first]), resumable);
        task_count += tasks.len();
        // Each task of analyses starts once (it loads the binary and the store).
        if !resumable {
            expected += tasks.len() as f64 * plan::JOB_START_S / 3600.0;
        }
        // Slurm holds each task of an array to the array's limit.
        limit += (tasks.len() * links as usize) as f64 * time as f64 / 60.0;
        out += &format!(
            "job {kind}: {} stage(s) in {} task(s){}, 1 CPU, --mem={mem}M --time={} {}{}\n",
            members.len(),
            tasks.len(),
            if tasks.len() > 1 { " (array)" } else { "" },
            plan::time_limit(time),
            sargs,
            if links > 1 {
                format!(
                    " as a chain of {links} jobs (each after the one before, resuming from the last checkpoint)"
                )
            } else {
                String::new()
            }
        );
        for (m, (i, r)) in members.iter().enumerate() {
            let work = planned(&graph.nodes[*i]).map_or(String::new(), |p| {
                p.counts
                    .iter()
                    .take(2)
                    .map(|(name, v)| format!("{name} = {}, ", Planned::count_text(*v)))
                    .collect()
            });
            let cpu = if r.expected_s < 3600.0 {
                format!("{:.1} CPU s", r.expected_s)
            } else {
                format!("{:.2} core-h", r.expected_s / 3600.0)
            };
            out += &format!(
                "    {}  ({work}expected {cpu}, asks {} MiB, task {})\n",
                graph.nodes[*i].label(),
                r.mem_mib,
                task_of[m]
            );
            expected += r.expected_s / 3600.0 * r.cpus as f64;
            longest = longest.max(r.expected_s / 3600.0);
        }
    }
    let jobs: usize = groups.values().map(|m| m.len()).sum();
    out += &format!(
        "{jobs} stage(s) to run in {} job(s) of {task_count} task(s) (waves: stages are submitted when their inputs are done), {cached} cached\n\
         total: {expected:.2} core-hours expected, {limit:.2} core-hours requested (time limits, {:.1}x); longest stage {longest:.2} h\n",
        groups.len(),
        limit / expected.max(1e-9)
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_that_hit_its_time_limit_is_resubmitted_once_with_twice_the_limit() {
        let ended = |s: &str| JobState::Ended {
            state: s.to_string(),
            reason: "None".to_string(),
        };
        assert_eq!(
            resubmit_after_time_limit(&ended("TIMEOUT"), "", false),
            Some(2.0)
        );
        // squeue forgot the job; scontrol still knows why it ended.
        assert_eq!(
            resubmit_after_time_limit(
                &JobState::Unknown,
                "JobState=TIMEOUT Reason=TimeLimit",
                false
            ),
            Some(2.0)
        );
        assert_eq!(resubmit_after_time_limit(&ended("TIMEOUT"), "", true), None);
        assert_eq!(resubmit_after_time_limit(&ended("FAILED"), "", false), None);
        assert_eq!(
            resubmit_after_time_limit(&ended("OUT_OF_MEMORY"), "", false),
            None
        );
        assert_eq!(
            resubmit_after_time_limit(&JobState::Completed, "", false),
            None
        );
    }
}
