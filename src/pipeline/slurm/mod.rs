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
//! view of the jobs; [`worker`]: a job's side, one stage computed into the
//! store; [`dry_run`]: the jobs a build would submit, without submitting.

mod dry_run;
pub mod plan;
pub mod state;
mod worker;

pub use dry_run::dry_run;
pub use worker::worker;

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result};

use super::cost;
use super::exec::{self, Outcome, RunReport, StageResult, State, stage_key};
use super::graph::{Graph, Node};
use super::progress::{self, Progress};
use super::registry::Registry;
use super::spec::Catalogue;
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

/// A stage ready to be submitted: its node, its cache key and its inputs'
/// entries.
struct Ready {
    node: usize,
    key: String,
    inputs: Vec<Entry>,
}

/// What the driver knows of the stages between two polls of Slurm.
struct Tracking {
    /// Each node's result, once resolved.
    results: Vec<Option<StageResult>>,
    /// Stages whose job is queued or running, with its record.
    watching: BTreeMap<usize, JobRecord>,
    /// Stages resubmitted once after their time limit, with the factor on it.
    longer: BTreeMap<usize, f64>,
    /// Stages to submit again with the next wave (after their time limit).
    retry: Vec<Ready>,
    /// The damaged artifacts met, quarantined.
    damaged: Vec<String>,
}

impl Tracking {
    fn new(nodes: usize) -> Self {
        Tracking {
            results: vec![None; nodes],
            watching: BTreeMap::new(),
            longer: BTreeMap::new(),
            retry: Vec::new(),
            damaged: Vec::new(),
        }
    }

    /// Stage `i` is resolved with `r`: record it and say so.
    fn finish(&mut self, progress: &Progress, g: &Graph, i: usize, r: StageResult) {
        let what = match &r.outcome {
            Outcome::Cached => "cached".to_string(),
            Outcome::Executed => "executed".to_string(),
            Outcome::Failed { error, .. } => format!("FAILED ({error})"),
            Outcome::Skipped { failed_input } => {
                format!("skipped (input {failed_input} failed)")
            }
        };
        progress.finish(i, g.nodes[i].label(), &g.nodes[i].kind, &what);
        self.results[i] = Some(r);
    }
}

/// A stage's inputs as the driver finds them.
enum Inputs {
    /// Every input is in the store: their entries.
    Done(Vec<Entry>),
    /// An input failed (or was skipped): its label.
    Failed(String),
    /// Some input is not resolved yet.
    Waiting,
}

/// One Slurm job of stages of one kind and one `slurm:` setting, as it is
/// submitted: an array when it has several tasks, a chain of `links` jobs when
/// it runs past the partition's limit and can resume.
struct Job<'r> {
    kind: String,
    /// The members' stages (indices into the wave's ready stages).
    members: Vec<usize>,
    /// Each member's resources.
    res: Vec<Resources>,
    /// The memory each task asks for: the largest member's.
    mem: u64,
    /// The members of each task (run one after the other), and each member's task.
    tasks: Vec<Vec<usize>>,
    task_of: Vec<usize>,
    /// Each job's time limit in minutes, and how many jobs the chain has.
    time: u64,
    links: u64,
    /// The members' cache keys.
    keys: Vec<&'r str>,
    /// Whether a member is resubmitted after its time limit.
    resubmitted: bool,
}

impl Job<'_> {
    fn array(&self) -> bool {
        self.tasks.len() > 1
    }
}

impl Driver<'_> {
    fn run(&self, nodes: &[usize]) -> Result<RunReport> {
        let progress = self.progress(nodes);
        let mut t = Tracking::new(self.graph.nodes.len());
        loop {
            let jobs = state::query()?;
            self.collect_ended(&jobs, &progress, &mut t);
            let ready = self.next_wave(nodes, &jobs, &progress, &mut t);
            if !ready.is_empty() {
                for rec in self.submit(&ready, &t.longer)? {
                    let i = ready
                        .iter()
                        .find(|r| r.key == rec.key)
                        .map(|r| r.node)
                        .expect("submitted key is ready");
                    t.watching.insert(i, rec);
                }
            }
            if t.watching.is_empty() {
                break;
            }
            progress.beat(super::progress::heartbeat());
            std::thread::sleep(self.opts.poll);
        }
        progress.done();
        let mut out = BTreeMap::new();
        for &i in nodes {
            out.insert(i, t.results[i].take().expect("every node was resolved"));
        }
        Ok(RunReport {
            results: out,
            damaged: t.damaged,
        })
    }

    /// The progress report of a build of `nodes`, logged beside the store.
    /// Slurm runs every ready stage at once: the end is the longest chain's.
    fn progress(&self, nodes: &[usize]) -> Progress {
        let g = self.graph;
        let log = self
            .store
            .dir
            .parent()
            .map(|d| d.join("log").join("LAST-RUN.log"));
        let progress = Progress::new(self.opts.progress, nodes.len(), log.as_deref());
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
        progress
    }

    /// The watched stages whose job ended: the store says whether they
    /// delivered. One that hit its time limit without a result goes to
    /// `t.retry` once, with a longer limit; the others are resolved, executed
    /// or failed.
    fn collect_ended(
        &self,
        jobs: &HashMap<String, JobState>,
        progress: &Progress,
        t: &mut Tracking,
    ) {
        let g = self.graph;
        for (i, rec) in t.watching.clone() {
            let st = jobs.get(&rec.job_id).cloned().unwrap_or(JobState::Unknown);
            if st.is_active() {
                continue;
            }
            t.watching.remove(&i);
            // A forced stage had an entry before: only a completed job counts.
            let entry = self.store.lookup(&rec.key);
            let why = || state::details(&rec.job_id).unwrap_or_else(|| describe(&st));
            if entry.is_none() && !rec.force {
                let w = why();
                if let Some(f) = resubmit_after_time_limit(&st, &w, t.longer.contains_key(&i)) {
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
                    t.longer.insert(i, f);
                    let inputs = rec
                        .inputs
                        .iter()
                        .filter_map(|k| self.store.lookup(k))
                        .collect();
                    t.retry.push(Ready {
                        node: i,
                        key: rec.key.clone(),
                        inputs,
                    });
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
            t.finish(progress, g, i, r);
        }
    }

    /// The next wave: the stages of `nodes` whose inputs are all done and
    /// that are neither resolved nor watched. Those with a failed input are
    /// skipped, those in the store cached, those whose earlier job is still
    /// queued or running watched; the others, with the stages to retry, are
    /// returned to be submitted.
    fn next_wave(
        &self,
        nodes: &[usize],
        jobs: &HashMap<String, JobState>,
        progress: &Progress,
        t: &mut Tracking,
    ) -> Vec<Ready> {
        let g = self.graph;
        let mut ready: Vec<Ready> = std::mem::take(&mut t.retry);
        for &i in nodes {
            if t.results[i].is_some()
                || t.watching.contains_key(&i)
                || ready.iter().any(|r| r.node == i)
            {
                continue;
            }
            let node = &g.nodes[i];
            let inputs = match input_entries(g, node, &t.results) {
                Inputs::Done(inputs) => inputs,
                Inputs::Failed(failed_input) => {
                    let r = StageResult {
                        outcome: Outcome::Skipped { failed_input },
                        entry: None,
                    };
                    t.finish(progress, g, i, r);
                    continue;
                }
                Inputs::Waiting => continue,
            };
            let digests: Vec<&str> = inputs.iter().map(|e| e.digest.as_str()).collect();
            let key = stage_key(g, self.reg, node, &digests);
            if let Some(e) = self.in_store(node, &key, progress, &mut t.damaged) {
                let r = StageResult {
                    outcome: Outcome::Cached,
                    entry: Some(e),
                };
                t.finish(progress, g, i, r);
                continue;
            }
            match state::read(self.store, &key) {
                Some(rec) if jobs.get(&rec.job_id).is_some_and(JobState::is_active) => {
                    progress.line(&format!(
                        "{}: job {} is {}; waiting for it",
                        node.label(),
                        rec.job_id,
                        describe(&jobs[&rec.job_id])
                    ));
                    t.watching.insert(i, rec);
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
                    ready.push(Ready {
                        node: i,
                        key,
                        inputs,
                    });
                }
                None => ready.push(Ready {
                    node: i,
                    key,
                    inputs,
                }),
            }
        }
        ready
    }

    /// The entry of `node` under `key` when the store holds it intact and its
    /// kind is not forced, its labels then set; damaged artifacts met are
    /// quarantined and added to `damaged`.
    fn in_store(
        &self,
        node: &Node,
        key: &str,
        progress: &Progress,
        damaged: &mut Vec<String>,
    ) -> Option<Entry> {
        if self.opts.force.contains(&node.kind) {
            return None;
        }
        match self.store.find(key) {
            Found::Hit(e) => {
                for l in &node.labels {
                    let _ = self.store.set_label(l, &e.key);
                }
                Some(e)
            }
            Found::Damaged { problems, .. } => {
                for msg in exec::quarantine(self.store, &problems) {
                    progress.line(&msg);
                    damaged.push(msg);
                }
                None
            }
            Found::Miss => None,
        }
    }

    /// Submit `ready` stages: one job (an array when several) per kind and
    /// settings. Records each stage's job in the store; returns the records.
    /// `longer`: stages resubmitted after their time limit, with the factor on it.
    fn submit(&self, ready: &[Ready], longer: &BTreeMap<usize, f64>) -> Result<Vec<JobRecord>> {
        let g = self.graph;
        let mut groups: BTreeMap<(String, String), Vec<usize>> = BTreeMap::new();
        for (k, r) in ready.iter().enumerate() {
            let s = serde_json::to_string(&self.settings[r.node])?;
            groups
                .entry((g.nodes[r.node].kind.clone(), s))
                .or_default()
                .push(k);
        }
        let logs = state::jobs_dir(self.store).join("log");
        std::fs::create_dir_all(&logs)?;
        let mut out = Vec::new();
        for ((kind, _), members) in groups {
            let settings = &self.settings[ready[members[0]].node];
            let job = self.job(ready, kind, members, longer);
            let args = self.sbatch_args(&job, &logs, settings);
            let script = self.script(&job);
            // Records first (without a job id), so a worker always finds its record.
            let mut recs = self.records(ready, &job);
            for r in &recs {
                state::write(self.store, r)?;
            }
            let id = submit_chain(&job, &args, &script)?;
            for (m, r) in recs.iter_mut().enumerate() {
                let t = job.task_of[m];
                if job.array() {
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

    /// The job of the `members` of `ready` (stages of one kind and settings):
    /// each one's resources, its tasks (short stages share one, one after the
    /// other; a stage that ran out of time once goes alone) and its time limit.
    fn job<'r>(
        &self,
        ready: &'r [Ready],
        kind: String,
        members: Vec<usize>,
        longer: &BTreeMap<usize, f64>,
    ) -> Job<'r> {
        let g = self.graph;
        let settings = &self.settings[ready[members[0]].node];
        let res: Vec<Resources> = members
            .iter()
            .map(|&k| {
                let Ready {
                    node: i, inputs, ..
                } = &ready[k];
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
            .planned(&kind, &g.nodes[ready[members[0]].node].parsed)
            .is_some();
        let factor: Vec<f64> = members
            .iter()
            .map(|&k| longer.get(&ready[k].node).copied().unwrap_or(1.0))
            .collect();
        let plan::JobTasks {
            tasks,
            task_of,
            time_min: time,
        } = plan::job_tasks(&res, &factor, resumable, settings);
        let (time, links) = plan::chain(time, state::max_minutes(settings), resumable);
        let keys: Vec<&str> = members.iter().map(|&k| ready[k].key.as_str()).collect();
        let resubmitted = members.iter().any(|&k| longer.contains_key(&ready[k].node));
        Job {
            kind,
            members,
            res,
            mem,
            tasks,
            task_of,
            time,
            links,
            keys,
            resubmitted,
        }
    }

    /// `sbatch`'s options for `job`: name, one CPU, memory, time limit, log
    /// files under `logs`, the array, then the profile's own options.
    fn sbatch_args(&self, job: &Job, logs: &Path, settings: &Settings) -> Vec<String> {
        let mut args = vec![
            format!("--job-name=repro-{}", job.kind),
            "--cpus-per-task=1".to_string(),
            "--ntasks=1".to_string(),
            format!("--mem={}M", job.mem),
            format!("--time={}", plan::time_limit(job.time)),
            format!(
                "--output={}",
                logs.join(if job.array() { "%A_%a.log" } else { "%j.log" })
                    .display()
            ),
        ];
        if job.array() {
            args.push(format!("--array=0-{}", job.tasks.len() - 1));
        }
        args.extend(settings.sbatch_args());
        if job.resubmitted {
            // After the profile's own options: a `--time` among them set the
            // limit the job hit.
            args.push(format!("--time={}", plan::time_limit(job.time)));
        }
        args
    }

    /// The batch script of `job`: each array task runs `repro worker` on its
    /// stage, or on its stages one after the other.
    fn script(&self, job: &Job) -> String {
        let kind = &job.kind;
        let keys = &job.keys;
        let worker = format!(
            "{} worker --store {}",
            shell_quote(&self.opts.binary.display().to_string()),
            shell_quote(&self.store.dir.display().to_string()),
        );
        if job.tasks.iter().all(|t| t.len() == 1) {
            format!(
                "#!/bin/bash\n# repro: {} stage(s) of kind {kind}\nKEYS=({})\nexec {worker} --key \"${{KEYS[${{SLURM_ARRAY_TASK_ID:-0}}]}}\"\n",
                keys.len(),
                keys.join(" "),
            )
        } else {
            // A task's stages one after the other; the task fails if one
            // does (the others still run: each is its own stage).
            let list: Vec<String> = job
                .tasks
                .iter()
                .map(|t| {
                    let k: Vec<&str> = t.iter().map(|&m| keys[m]).collect();
                    format!("\"{}\"", k.join(" "))
                })
                .collect();
            format!(
                "#!/bin/bash\n# repro: {} stage(s) of kind {kind} in {} task(s)\nTASKS=({})\nstatus=0\nfor KEY in ${{TASKS[${{SLURM_ARRAY_TASK_ID:-0}}]}}; do\n  {worker} --key \"$KEY\" || status=$?\ndone\nexit $status\n",
                keys.len(),
                job.tasks.len(),
                list.join(" "),
            )
        }
    }

    /// The job records of `job`'s stages, without a job id yet.
    fn records(&self, ready: &[Ready], job: &Job) -> Vec<JobRecord> {
        let g = self.graph;
        let figures: Vec<String> = g.figures.iter().map(|f| f.id.clone()).collect();
        job.members
            .iter()
            .zip(&job.res)
            .map(|(&k, r)| {
                let Ready {
                    node: i,
                    key,
                    inputs,
                } = &ready[k];
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
            .collect()
    }
}

/// A stage's inputs: their entries once all are in `results`, else the first
/// failed one (before any still to come), else waiting.
fn input_entries(g: &Graph, node: &Node, results: &[Option<StageResult>]) -> Inputs {
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
        Inputs::Failed(failed_input)
    } else if waiting {
        Inputs::Waiting
    } else {
        Inputs::Done(inputs)
    }
}

/// Submit `job` with `args` and `script`, as a chain when it has several
/// links: each job starts when the one before has ended (at its time limit,
/// or done: a worker whose stage is in the store exits) and resumes from the
/// last checkpoint. Returns the last job's id, which the records name.
fn submit_chain(job: &Job, args: &[String], script: &str) -> Result<String> {
    let mut id = state::submit(args, script)?;
    let mut chain = vec![id.clone()];
    for _ in 1..job.links {
        let mut after = args.to_vec();
        after.push(format!("--dependency=afterany:{id}"));
        id = state::submit(&after, script)?;
        chain.push(id.clone());
    }
    eprintln!(
        "submitted Slurm job {}: {} {} stage(s){}, {} MiB and {} each",
        if job.links > 1 {
            format!(
                "chain {} (each resumes from the last checkpoint)",
                chain.join(" -> ")
            )
        } else {
            id.clone()
        },
        job.keys.len(),
        job.kind,
        if job.tasks.len() < job.keys.len() {
            format!(" in {} task(s)", job.tasks.len())
        } else {
            String::new()
        },
        job.mem,
        plan::time_limit(job.time)
    );
    Ok(id)
}

fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// Bytes of the files of `inputs` in the store.
fn input_bytes(store: &Store, inputs: &[Entry]) -> u64 {
    inputs.iter().map(|e| store.entry_bytes(e)).sum()
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
