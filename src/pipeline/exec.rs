//! Run the stage graph: cache lookups, parallel execution on a rayon pool, early
//! cut-off, failure isolation; and `status`/`why` explanations without running.
//!
//! A stage's key is blake3(kind, canonical params, code fingerprint, the settings
//! of its upstream runs it reads, input digests) ([`stage_key`]).
//! Input digests are hashes of the upstream *files*, so a stage whose upstream
//! reran but produced byte-identical files keeps its key and is not rerun
//! (early cut-off). Keys are therefore known only once the inputs are: nodes are
//! scheduled as soon as their inputs finish.

use std::collections::BTreeMap;
use std::panic::AssertUnwindSafe;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Result;
use serde_json::Value;

use super::canon::{canonical, diff_params, hash_fields};
use super::checkpoints::Status;
use super::graph::{Graph, Node};
use super::progress::{self, Progress};
use super::registry::Registry;
use super::stage::{Artifact, StageCtx};
use super::store::{Entry, Found, Store};

/// How to run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Worker threads (stages run at once).
    pub jobs: usize,
    /// Stage kinds to rerun even when cached.
    pub force: Vec<String>,
    /// Tell the user how the run goes: bars when stderr is a terminal, else one
    /// plain line per finished stage and a heartbeat per long stage. The run log
    /// (`.repro/log/LAST-RUN.log` beside the store) is written either way.
    pub progress: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            jobs: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            force: Vec::new(),
            progress: false,
        }
    }
}

/// What happened to one stage.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Found in the cache.
    Cached,
    /// Run now.
    Executed,
    /// Its kind returned an error (or panicked): message and log.
    Failed { error: String, log: Vec<String> },
    /// Not run because an input failed.
    Skipped { failed_input: String },
}

/// One stage's result.
#[derive(Debug, Clone)]
pub struct StageResult {
    pub outcome: Outcome,
    /// The cache entry (cached or executed stages).
    pub entry: Option<Entry>,
}

/// The results of a run, indexed by node.
#[derive(Debug, Clone)]
pub struct RunReport {
    pub results: BTreeMap<usize, StageResult>,
    /// Damaged artifacts found in the store (each quarantined, its stage recomputed).
    pub damaged: Vec<String>,
}

impl RunReport {
    /// Labels of the stages executed in this run, sorted.
    pub fn executed(&self, graph: &Graph) -> Vec<String> {
        self.labels_where(graph, |o| *o == Outcome::Executed)
    }
    /// Whether every stage of `fig` succeeded (so the figure is published).
    pub fn complete(&self, fig: &super::graph::FigurePlan) -> bool {
        fig.nodes
            .iter()
            .all(|i| self.results.get(i).is_some_and(|r| r.entry.is_some()))
    }
    /// Labels of failed or skipped stages, sorted.
    pub fn not_done(&self, graph: &Graph) -> Vec<String> {
        self.labels_where(graph, |o| !matches!(o, Outcome::Executed | Outcome::Cached))
    }
    fn labels_where(&self, graph: &Graph, f: impl Fn(&Outcome) -> bool) -> Vec<String> {
        let mut v: Vec<String> = self
            .results
            .iter()
            .filter(|(_, r)| f(&r.outcome))
            .map(|(&i, _)| graph.nodes[i].label().to_string())
            .collect();
        v.sort();
        v
    }
    /// Readable report of every failure: stage, kind, parameters, error, log.
    pub fn failure_report(&self, graph: &Graph) -> String {
        let mut s = String::new();
        for (&i, r) in &self.results {
            let n = &graph.nodes[i];
            match &r.outcome {
                Outcome::Failed { error, log } => {
                    s += &format!(
                        "stage {} (kind {}, declared at {}:{}) failed: {error}\n  parameters: {}\n",
                        n.label(),
                        n.kind,
                        n.origin.0.display(),
                        n.origin.1,
                        canonical(&n.params)
                    );
                    for l in log {
                        s += &format!("  log: {l}\n");
                    }
                }
                Outcome::Skipped { failed_input } => {
                    s += &format!(
                        "stage {} not run: its input {failed_input} failed\n",
                        n.label()
                    );
                }
                _ => {}
            }
        }
        s
    }
}

/// The settings of its upstream runs a stage's kind reads
/// ([`StageKind::reads_run`](super::StageKind::reads_run)), per input in
/// input order; empty when it reads none.
fn runs_read(graph: &Graph, reg: &Registry, node: &Node) -> Vec<Value> {
    let keys = reg
        .get(&node.kind)
        .map(|k| k.reads_run(&node.parsed))
        .unwrap_or_default();
    if keys.is_empty() {
        return Vec::new();
    }
    node.inputs
        .iter()
        .map(|&j| {
            let run = &graph.nodes[j].run;
            Value::Object(
                keys.iter()
                    .filter_map(|k| run.get(k).map(|v| (k.clone(), v.clone())))
                    .collect(),
            )
        })
        .collect()
}

/// The cache key of a stage, given its inputs' digests: the hash of its kind,
/// its canonical parameters, its code fingerprint, the settings of its
/// upstream runs it reads (a field of their own, so that an edit of one
/// reruns it however its inputs' files came out), what its kind depends on
/// outside the crate ([`StageKind::keyed_outside`](super::StageKind::keyed_outside):
/// a script's files and interpreter; a field of its own too) and the digests.
pub fn stage_key(graph: &Graph, reg: &Registry, node: &Node, input_digests: &[&str]) -> String {
    let canon = canonical(&node.params);
    let fingerprint = reg.fingerprint(&node.kind);
    let mut fields: Vec<&[u8]> = vec![
        node.kind.as_bytes(),
        canon.as_bytes(),
        fingerprint.as_bytes(),
    ];
    let runs = runs_read(graph, reg, node);
    let runs = (!runs.is_empty()).then(|| canonical(&Value::Array(runs)));
    if let Some(r) = &runs {
        // A tag no input digest (hex) can equal keeps the fields apart.
        fields.extend([b"runs read".as_slice(), r.as_bytes()]);
    }
    let outside = reg
        .get(&node.kind)
        .map(|k| k.keyed_outside(&node.parsed, node.root()))
        .unwrap_or(Value::Null);
    let outside = (!outside.is_null()).then(|| canonical(&outside));
    if let Some(o) = &outside {
        fields.extend([b"outside the crate".as_slice(), o.as_bytes()]);
    }
    fields.extend(input_digests.iter().map(|d| d.as_bytes()));
    hash_fields("repro-stage-v1", &fields).to_hex().to_string()
}

/// Hash of a stage's files (extension, file hash pairs in sorted order).
fn files_digest(files: &BTreeMap<String, String>) -> String {
    let fields: Vec<&[u8]> = files
        .iter()
        .flat_map(|(k, v)| [k.as_bytes(), v.as_bytes()])
        .collect();
    hash_fields("repro-digest-v1", &fields).to_hex().to_string()
}

/// CPU time of the calling thread (Linux), in seconds.
fn thread_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14, 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

struct Shared<'a> {
    graph: &'a Graph,
    reg: &'a Registry,
    store: &'a Store,
    opts: &'a RunOptions,
    dependents: Vec<Vec<usize>>,
    remaining: Vec<AtomicUsize>,
    results: Vec<Mutex<Option<StageResult>>>,
    progress: Progress,
    damaged: Mutex<Vec<String>>,
}

/// Run `nodes` (and nothing else; they must be closed under inputs) of `graph`.
pub fn execute(
    graph: &Graph,
    nodes: &[usize],
    reg: &Registry,
    store: &Store,
    opts: &RunOptions,
) -> Result<RunReport> {
    let n = graph.nodes.len();
    let mut in_set = vec![false; n];
    for &i in nodes {
        in_set[i] = true;
    }
    let mut dependents = vec![Vec::new(); n];
    let remaining: Vec<AtomicUsize> = (0..n).map(|_| AtomicUsize::new(0)).collect();
    for &i in nodes {
        for &j in &graph.nodes[i].inputs {
            anyhow::ensure!(in_set[j], "internal: node set not closed under inputs");
            dependents[j].push(i);
            remaining[i].fetch_add(1, Ordering::Relaxed);
        }
    }
    let log = store
        .dir
        .parent()
        .map(|d| d.join("log").join("LAST-RUN.log"));
    let sh = Shared {
        graph,
        reg,
        store,
        opts,
        dependents,
        remaining,
        results: (0..n).map(|_| Mutex::new(None)).collect(),
        progress: Progress::new(opts.progress, nodes.len(), log.as_deref()),
        damaged: Mutex::new(Vec::new()),
    };
    // Only the stages that will run count toward the estimate of the end (a
    // stale one may still be cut off early when its output comes out unchanged).
    let mut planned: Option<Vec<f64>> = None;
    if opts.progress {
        let st = status(graph, nodes, reg, store, &opts.force);
        let stale: Vec<usize> = st
            .iter()
            .filter(|(_, s)| !matches!(s, State::Cached { .. }))
            .map(|(i, _)| *i)
            .collect();
        // Sizes of the built inputs of the stages to run only (a build with
        // nothing to run reads no entry).
        let wanted: std::collections::HashSet<usize> = stale
            .iter()
            .flat_map(|&i| graph.nodes[i].inputs.iter().copied())
            .collect();
        let built = super::cost::built_bytes(
            store,
            st.iter().filter_map(|(i, s)| match s {
                State::Cached { key } if wanted.contains(i) => Some((*i, key.as_str())),
                _ => None,
            }),
        );
        let seconds = super::cost::node_seconds(graph, reg, &built);
        let classes: Vec<String> = graph
            .nodes
            .iter()
            .map(|n| progress::class_name(&n.kind, n.label()))
            .collect();
        sh.progress.plan(&stale, &seconds, &classes, opts.jobs);
        planned = Some(seconds);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs.max(1))
        .build()?;
    let roots: Vec<usize> = nodes
        .iter()
        .copied()
        .filter(|&i| graph.nodes[i].inputs.is_empty())
        .collect();
    let planned =
        planned.unwrap_or_else(|| super::cost::node_seconds(graph, reg, &Default::default()));
    let roots = longest_first(roots, &planned);
    let shr = &sh;
    let (stop, stopped) = std::sync::mpsc::channel::<()>();
    std::thread::scope(|t| {
        // Heartbeat of long stages, until the pool is done.
        t.spawn(move || {
            let every = progress::heartbeat();
            let tick = every.min(std::time::Duration::from_secs(1));
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = stopped.recv_timeout(tick) {
                shr.progress.beat(every);
            }
        });
        // First in, first out: the roots start in the order given, and a
        // stage whose inputs are done queues behind those already waiting.
        pool.scope_fifo(|s| {
            for i in roots {
                s.spawn_fifo(move |s| process(s, shr, i));
            }
        });
        let _ = stop.send(());
    });
    sh.progress.done();
    let mut results = BTreeMap::new();
    for &i in nodes {
        let r = sh.results[i].lock().unwrap().take();
        results.insert(i, r.expect("every node of the set was processed"));
    }
    Ok(RunReport {
        results,
        damaged: sh.damaged.into_inner().unwrap(),
    })
}

/// `roots` in decreasing planned seconds (ties in node order): the pool takes
/// them in the order they are spawned, so the longest simulations start first
/// and a build does not end on one long run with the other workers idle.
/// The order changes no result: every stage is a function of its inputs.
fn longest_first(mut roots: Vec<usize>, planned: &[f64]) -> Vec<usize> {
    let at = |i: usize| {
        planned
            .get(i)
            .copied()
            .filter(|s| s.is_finite())
            .unwrap_or(0.0)
    };
    roots.sort_by(|&a, &b| at(b).total_cmp(&at(a)).then(a.cmp(&b)));
    roots
}

fn process<'s>(s: &rayon::ScopeFifo<'s>, sh: &'s Shared<'s>, i: usize) {
    let r = run_node(sh, i);
    let node = &sh.graph.nodes[i];
    let what = match &r.outcome {
        Outcome::Cached => "cached".to_string(),
        Outcome::Executed => "executed".to_string(),
        Outcome::Failed { error, .. } => format!("FAILED ({error})"),
        Outcome::Skipped { failed_input } => format!("skipped (input {failed_input} failed)"),
    };
    sh.progress.finish(i, node.label(), &node.kind, &what);
    *sh.results[i].lock().unwrap() = Some(r);
    for &d in &sh.dependents[i] {
        if sh.remaining[d].fetch_sub(1, Ordering::AcqRel) == 1 {
            s.spawn_fifo(move |s| process(s, sh, d));
        }
    }
}

/// `node`'s entry `e` as an input of `consumer`. A node shared between figures
/// carries every figure's name for it (fig4's `tau_table` is fig23's
/// `tau09_table`); the consumer sees only the names its own figures gave it
/// (and experiment names), so `from: tau_table` in fig23 never picks eps09's
/// table up when fig4 is planned in the same run.
pub(crate) fn artifact(
    store: &Store,
    reg: &Registry,
    consumer: &Node,
    node: &Node,
    e: &Entry,
) -> Artifact {
    let mine = |f: &Option<String>| {
        f.is_none()
            || consumer
                .ids
                .iter()
                .any(|c| c.figure.is_none() || c.figure == *f)
    };
    Artifact {
        label: node.label().to_string(),
        ids: node
            .ids
            .iter()
            .filter(|id| mine(&id.figure))
            .cloned()
            .collect(),
        kind: node.source_kind(reg),
        point: node.point.clone(),
        params: node.params.clone(),
        run: node.run.clone(),
        digest: e.digest.clone(),
        files: e
            .files
            .iter()
            .map(|(k, h)| (k.clone(), (h.clone(), store.object_path(h))))
            .collect(),
    }
}

fn run_node(sh: &Shared, i: usize) -> StageResult {
    let node = &sh.graph.nodes[i];
    let mut inputs = Vec::with_capacity(node.inputs.len());
    for &j in &node.inputs {
        let r = sh.results[j].lock().unwrap();
        match r.as_ref().and_then(|r| r.entry.as_ref()) {
            Some(e) => inputs.push(artifact(sh.store, sh.reg, node, &sh.graph.nodes[j], e)),
            None => {
                return StageResult {
                    outcome: Outcome::Skipped {
                        failed_input: sh.graph.nodes[j].label().to_string(),
                    },
                    entry: None,
                };
            }
        }
    }
    let digests: Vec<&str> = inputs.iter().map(|a| a.digest.as_str()).collect();
    let key = stage_key(sh.graph, sh.reg, node, &digests);
    let forced = sh.opts.force.contains(&node.kind);
    let hit = |e: Entry| {
        for l in &node.labels {
            // The label index only serves `why`; failing to update it is harmless.
            let _ = sh.store.set_label(l, &e.key);
        }
        StageResult {
            outcome: Outcome::Cached,
            entry: Some(e),
        }
    };
    if !forced && let Some(e) = find_or_repair(sh, &key) {
        return hit(e);
    }
    let fail = |error: String, log: Vec<String>| StageResult {
        outcome: Outcome::Failed { error, log },
        entry: None,
    };
    // Another process may be computing the same stage: wait for it, then reuse.
    let _lock = match sh.store.lock_key(&key) {
        Ok(l) => l,
        Err(e) => {
            return fail(
                format!("cannot lock the store for this stage: {e:#}"),
                vec![],
            );
        }
    };
    // Damage found above is already reported and quarantined: only a hit counts.
    if !forced && let Some(e) = sh.store.lookup(&key) {
        return hit(e);
    }
    let sink = sh.progress.start(i, node.label());
    match compute(sh.store, sh.reg, node, key, &inputs, Some(sink)) {
        Ok((entry, notes)) => {
            for n in notes {
                sh.progress.line(&format!("{}: {n}", node.label()));
            }
            StageResult {
                outcome: Outcome::Executed,
                entry: Some(entry),
            }
        }
        Err((error, log)) => fail(error, log),
    }
}

/// Run one stage whose inputs are ready and write its files to the store (objects
/// first, then the entry naming them, each written to a temporary name and
/// renamed). Both executors use it: threads here, Slurm workers (`repro worker`).
/// The caller holds the key's lock. Returns the entry and the stage's notes;
/// an error is (message, the stage's log).
pub(crate) fn compute(
    store: &Store,
    reg: &Registry,
    node: &Node,
    key: String,
    inputs: &[Artifact],
    sink: Option<super::stage::ProgressSink>,
) -> std::result::Result<(Entry, Vec<String>), (String, Vec<String>)> {
    let fingerprint = reg.fingerprint(&node.kind);
    let kind = match reg.get(&node.kind) {
        Ok(k) => k.clone(),
        Err(e) => return Err((format!("{e:#}"), vec![])),
    };
    let checkpoints = store.checkpoints(&key);
    let ctx = StageCtx::new(node.seed, node.label().to_string(), sink)
        .with_checkpoints(checkpoints.clone())
        .with_root(node.root());
    let t0 = Instant::now();
    let cpu0 = thread_cpu_seconds();
    let out = std::panic::catch_unwind(AssertUnwindSafe(|| kind.run(&ctx, &node.parsed, inputs)));
    let wall_s = t0.elapsed().as_secs_f64();
    let cpu_s = match (cpu0, thread_cpu_seconds()) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let log = ctx.take_log();
    let notes = ctx.take_notes();
    let out = match out {
        Ok(Ok(o)) => o,
        Ok(Err(e)) => return Err((format!("{e:#}"), log)),
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            return Err((format!("panicked: {msg}"), log));
        }
    };
    if out.files.is_empty() {
        return Err(("the stage produced no file".into(), log));
    }
    let mut files = BTreeMap::new();
    for (ext, bytes) in &out.files {
        match store.put_object(bytes) {
            Ok(h) => {
                files.insert(ext.clone(), h);
            }
            Err(e) => return Err((format!("writing its output to the store: {e:#}"), log)),
        }
    }
    let entry = Entry {
        key,
        kind: node.kind.clone(),
        label: node.label().to_string(),
        params: node.params.clone(),
        fingerprint: fingerprint.to_string(),
        inputs: inputs
            .iter()
            .map(|a| (a.label.clone(), a.digest.clone()))
            .collect(),
        digest: files_digest(&files),
        files,
        seed: node.seed,
        wall_s,
        cpu_s,
        log,
        side: out.side,
    };
    if let Err(e) = store.put_entry(&entry) {
        return Err((format!("writing the cache entry: {e:#}"), entry.log));
    }
    // Done: its checkpoints are of no further use (gc removes them if this fails).
    let _ = checkpoints.remove();
    for l in &node.labels[1..] {
        let _ = store.set_label(l, &entry.key);
    }
    Ok((entry, notes))
}

/// The intact cache entry of `key`, if any. A damaged one is reported (object path
/// and stage), its damaged objects are quarantined, and it counts as a miss: the
/// stage is recomputed in this run.
fn find_or_repair(sh: &Shared, key: &str) -> Option<Entry> {
    match sh.store.find(key) {
        Found::Hit(e) => Some(e),
        Found::Miss => None,
        Found::Damaged { problems, .. } => {
            for msg in quarantine(sh.store, &problems) {
                sh.progress.line(&msg);
                sh.damaged.lock().unwrap().push(msg);
            }
            None
        }
    }
}

/// Move damaged objects to the quarantine; one message per object (what, where
/// it went) for the run's report. Both executors recompute the stage afterwards.
pub(crate) fn quarantine(store: &Store, problems: &[super::store::Damage]) -> Vec<String> {
    problems
        .iter()
        .map(|d| {
            let moved = match store.quarantine(&d.hash) {
                Ok(Some(to)) => format!("; moved to {}", to.display()),
                Ok(None) => String::new(),
                Err(e) => format!("; could not be moved aside: {e:#}"),
            };
            format!("{d}{moved}; recomputing it")
        })
        .collect()
}

/// Cache state of one stage, without running anything.
#[derive(Debug, Clone, PartialEq)]
pub enum State {
    /// Cached under this key.
    Cached { key: String },
    /// Cached, but a file of the entry is damaged: the next run quarantines it
    /// and recomputes the stage. One line per damaged file.
    Damaged { problems: Vec<String> },
    /// Will run; the reasons say what differs from the last cached result.
    Stale { reasons: Vec<String> },
}

/// Cache state and reasons for `nodes` (closed under inputs), in order.
pub fn status(
    graph: &Graph,
    nodes: &[usize],
    reg: &Registry,
    store: &Store,
    force: &[String],
) -> Vec<(usize, State)> {
    let mut digest: BTreeMap<usize, String> = BTreeMap::new();
    let mut out = Vec::new();
    for &i in nodes {
        let node = &graph.nodes[i];
        let fp = reg.fingerprint(&node.kind);
        let known: Option<Vec<&str>> = node
            .inputs
            .iter()
            .map(|j| digest.get(j).map(|s| s.as_str()))
            .collect();
        let forced = force.contains(&node.kind);
        if let Some(d) = &known {
            let key = stage_key(graph, reg, node, d);
            match store.find(&key) {
                Found::Hit(e) if !forced => {
                    digest.insert(i, e.digest.clone());
                    out.push((i, State::Cached { key }));
                    continue;
                }
                Found::Damaged { problems, .. } if !forced => {
                    let problems = problems.iter().map(|d| d.to_string()).collect();
                    out.push((i, State::Damaged { problems }));
                    continue;
                }
                _ => {}
            }
        }
        let mut reasons = Vec::new();
        if forced {
            reasons.push(format!("forced (--force {})", node.kind));
        }
        match node.labels.iter().find_map(|l| store.latest(l)) {
            None => reasons.push("never built".into()),
            Some(last) => {
                reasons.extend(diff_params(&last.params, &node.params));
                if last.fingerprint != fp {
                    let own = reg
                        .get(&node.kind)
                        .map(|k| {
                            k.modules()
                                .iter()
                                .map(|m| crate::pipeline::fingerprint::module_key(m))
                                .collect::<Vec<_>>()
                                .join(", ")
                        })
                        .unwrap_or_default();
                    reasons.push(format!(
                        "code of stage kind '{}' changed ({own} and the {} modules and {} crates it uses)",
                        node.kind,
                        reg.modules(&node.kind).len().saturating_sub(1),
                        reg.crates(&node.kind).len()
                    ));
                }
                if last.inputs.len() != node.inputs.len() {
                    reasons.push(format!(
                        "number of inputs: {} -> {}",
                        last.inputs.len(),
                        node.inputs.len()
                    ));
                } else {
                    for (k, &j) in node.inputs.iter().enumerate() {
                        let label = graph.nodes[j].label();
                        match digest.get(&j) {
                            None => reasons.push(format!("input {label} reruns first (may be cut off early if its output is unchanged)")),
                            Some(d) if *d != last.inputs[k].1 => reasons.push(format!("input {label} changed")),
                            _ => {}
                        }
                    }
                }
                let outside = reg
                    .get(&node.kind)
                    .map(|k| k.keyed_outside(&node.parsed, node.root()))
                    .unwrap_or_default();
                if reasons.is_empty() && !outside.is_null() {
                    reasons.push(format!(
                        "what it reads outside the crate changed (now: {outside}), or its cache entry is missing"
                    ));
                }
                if reasons.is_empty() {
                    reasons.push(
                        "cache entry missing or incomplete (removed by gc or an interrupted run)"
                            .into(),
                    );
                }
            }
        }
        out.push((i, State::Stale { reasons }));
    }
    out
}

/// The stages of `st` that will run and whose key is known already (their
/// inputs are cached), with that key.
pub fn stale_keys(
    graph: &Graph,
    st: &[(usize, State)],
    reg: &Registry,
    store: &Store,
) -> Vec<(usize, String)> {
    let mut digest: BTreeMap<usize, String> = BTreeMap::new();
    let mut out = Vec::new();
    for (i, s) in st {
        let node = &graph.nodes[*i];
        if let State::Cached { key } = s {
            if let Some(e) = store.lookup(key) {
                digest.insert(*i, e.digest);
            }
            continue;
        }
        let known: Option<Vec<&str>> = node
            .inputs
            .iter()
            .map(|j| digest.get(j).map(|s| s.as_str()))
            .collect();
        if let Some(d) = known {
            out.push((*i, stage_key(graph, reg, node, &d)));
        }
    }
    out
}

/// Where the stages of `st` that are running (or were stopped) are, from
/// their progress files and checkpoints.
pub fn running(
    graph: &Graph,
    st: &[(usize, State)],
    reg: &Registry,
    store: &Store,
) -> BTreeMap<usize, Status> {
    stale_keys(graph, st, reg, store)
        .into_iter()
        .filter_map(|(i, key)| Some((i, store.checkpoints(&key).status()?)))
        .collect()
}

/// Keys of the cache entries that running `nodes` could use. A stage whose key is
/// known contributes that key. A stage whose key is not yet known (an input reruns
/// first) may still be cut off early onto an older entry with the same kind,
/// parameters and code, whose inputs are themselves reachable: those are kept too.
pub fn reachable_keys(
    graph: &Graph,
    nodes: &[usize],
    reg: &Registry,
    store: &Store,
    by_label: &std::collections::HashMap<String, Vec<Entry>>,
) -> std::collections::HashSet<String> {
    use std::collections::HashSet;
    let mut keep = HashSet::new();
    // Digests each node may produce: one if cached, else those of its candidates.
    let mut possible: BTreeMap<usize, HashSet<String>> = BTreeMap::new();
    for (i, s) in status(graph, nodes, reg, store, &[]) {
        let node = &graph.nodes[i];
        let mut digests = HashSet::new();
        match s {
            State::Cached { key } => {
                if let Some(e) = store.lookup(&key) {
                    digests.insert(e.digest);
                }
                keep.insert(key);
            }
            State::Stale { .. } | State::Damaged { .. } => {
                let fp = reg.fingerprint(&node.kind);
                for e in node
                    .labels
                    .iter()
                    .flat_map(|l| by_label.get(l).into_iter().flatten())
                {
                    let inputs_possible = e.inputs.len() == node.inputs.len()
                        && e.inputs
                            .iter()
                            .zip(&node.inputs)
                            .all(|((_, d), j)| possible.get(j).is_some_and(|p| p.contains(d)));
                    if e.kind == node.kind
                        && e.fingerprint == fp
                        && e.params == node.params
                        && inputs_possible
                    {
                        digests.insert(e.digest.clone());
                        keep.insert(e.key.clone());
                    }
                }
            }
        }
        possible.insert(i, digests);
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_longest_planned_roots_start_first() {
        // Node 3 is the longest, 1 and 4 tie (node order), an unplanned NaN last.
        let planned = [5.0, 2.0, f64::NAN, 90.0, 2.0];
        assert_eq!(
            longest_first(vec![0, 1, 2, 3, 4], &planned),
            vec![3, 0, 1, 4, 2]
        );
        assert_eq!(longest_first(vec![4, 2], &planned), vec![4, 2]);
    }
}
