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

use std::collections::{BTreeMap, HashMap};
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
