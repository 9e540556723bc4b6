//! YAML specs, the stage graph, the content-hash cache and the executors.
//!
//! - [`spec`]: the typed YAML specs (experiments, pipelines) and located errors.
//! - [`graph`]: expansion of specs into one DAG of stage instances, shared nodes merged.
//! - [`stage`]: the [`StageKind`] trait and what a kind sees (its inputs when
//!   planned and when run, its context, its output, the work it plans);
//!   [`registry`]: the registry of kinds with their code fingerprints; [`kinds`]
//!   the framework's own kind (`table`); [`toy`] test-only kinds (registered by
//!   tests, and by the command line only under `REPRO_TOY_KINDS`). The library's kinds
//!   are registered by whoever assembles the registry (`stages::registry()`): this
//!   module imports nothing from `stages`.
//! - [`store`]: the content-addressed cache on disk; [`checkpoints`]: a running
//!   stage's checkpoints and progress beside it; [`cost`]: a stage's planned CPU
//!   seconds; [`exec`]: parallel execution,
//!   early cut-off, `status`/`why`; [`progress`]: bars, plain lines and the run
//!   log; [`publish`]: `results/ID/` and provenance.
//!
//! The functions here are what the CLI and the tests call.

pub mod calibration;
pub mod canon;
pub mod checkpoints;
pub mod cost;
pub mod exec;
pub mod fingerprint;
pub mod graph;
pub mod kinds;
pub mod progress;
pub mod publish;
pub mod registry;
pub mod slurm;
pub mod spec;
pub mod stage;
pub mod store;
pub mod toy;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};

pub use exec::{Outcome, RunOptions, RunReport, State};
pub use graph::Graph;
pub use registry::Registry;
pub use spec::{Catalogue, DEFAULT_PROFILE, SpecError};
pub use stage::{Artifact, Kind, Output, Parsed, Planned, StageCtx, StageKind};
pub use store::{GcReport, Store, VerifyReport};

/// Where specs, results and the store live.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// Holds `experiments/` and `pipelines/`.
    pub root: PathBuf,
    /// Figures are written to `results/ID/`.
    pub results: PathBuf,
    /// The cache.
    pub store: PathBuf,
}

impl Workspace {
    /// The default layout under `root`: `results/` and `.repro/store`.
    pub fn new(root: &Path) -> Self {
        Workspace {
            root: root.to_path_buf(),
            results: root.join("results"),
            store: root.join(".repro").join("store"),
        }
    }

    /// Load the catalogue and plan figures `ids` (all if empty) at `profile`.
    pub fn plan(&self, reg: &Registry, ids: &[String], profile: &str) -> Result<Graph> {
        let cat = Catalogue::load(&self.root)?;
        if cat.pipelines.is_empty() {
            bail!(
                "no figures: {} has no pipelines/*.yaml (set --root or REPRO_ROOT to the project directory)",
                self.root.display()
            );
        }
        graph::plan(&cat, ids, profile, reg)
    }
}

/// Every node the planned figures need, in topological order.
pub fn needed_nodes(graph: &Graph) -> Vec<usize> {
    let mut v: Vec<usize> = graph
        .figures
        .iter()
        .flat_map(|f| f.nodes.iter().copied())
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// The outcome of `repro figure`.
pub struct FigureRun {
    pub graph: Graph,
    pub report: RunReport,
}

impl FigureRun {
    /// Ok if every stage succeeded; else an error with the failure report.
    pub fn check(&self) -> Result<()> {
        let bad = self.report.not_done(&self.graph);
        if bad.is_empty() {
            Ok(())
        } else {
            bail!(
                "{} stage(s) failed or were skipped; figures depending on them were not written:\n{}",
                bad.len(),
                self.report.failure_report(&self.graph)
            )
        }
    }
}

/// Build figures `ids` (all if empty): run what is stale, publish every figure
/// whose stages all succeeded. Stage failures are in the report (see
/// [`FigureRun::check`]), not an `Err`: unrelated figures are still written.
pub fn run_figures(
    ws: &Workspace,
    reg: &Registry,
    ids: &[String],
    profile: &str,
    opts: &RunOptions,
) -> Result<FigureRun> {
    run_planned(ws, reg, ws.plan(reg, ids, profile)?, opts)
}

/// [`run_figures`] for a graph already planned (e.g. from a catalogue changed in
/// memory): results go to `ws.results`, the cache is `ws.store`.
pub fn run_planned(
    ws: &Workspace,
    reg: &Registry,
    graph: Graph,
    opts: &RunOptions,
) -> Result<FigureRun> {
    let store = Store::open(&ws.store)?;
    let nodes = needed_nodes(&graph);
    let report = exec::execute(&graph, &nodes, reg, &store, opts)?;
    for fig in &graph.figures {
        if report.complete(fig) {
            publish::publish(&ws.root, &ws.results, &graph, fig, &report, reg, &store)?;
        }
    }
    Ok(FigureRun { graph, report })
}

/// Cache state of every stage of figures `ids` (all if empty), without running.
pub fn figure_status(
    ws: &Workspace,
    reg: &Registry,
    ids: &[String],
    profile: &str,
    force: &[String],
) -> Result<(Graph, Vec<(usize, State)>)> {
    let graph = ws.plan(reg, ids, profile)?;
    let store = Store::open(&ws.store)?;
    let nodes = needed_nodes(&graph);
    let st = exec::status(&graph, &nodes, reg, &store, force);
    Ok((graph, st))
}

/// Free what no current spec reaches, at any profile (see
/// [`exec::reachable_keys`]: entries early cut-off could reuse are kept). Refuses when a spec is broken (it could not tell what is
/// reachable) or another `repro` uses the store.
pub fn gc(ws: &Workspace, reg: &Registry, dry_run: bool) -> Result<GcReport> {
    let cat = Catalogue::load(&ws.root)?;
    let store = Store::open_exclusive(&ws.store)?;
    let mut by_label: HashMap<String, Vec<store::Entry>> = HashMap::new();
    for e in store.entries() {
        by_label.entry(e.label.clone()).or_default().push(e);
    }
    let mut keep: HashSet<String> = HashSet::new();
    for profile in spec::PROFILES {
        for id in cat.pipelines.keys() {
            let graph = match graph::plan(&cat, std::slice::from_ref(id), profile, reg) {
                Ok(g) => g,
                // A figure without this profile has nothing to keep at it.
                Err(e)
                    if e.downcast_ref::<SpecError>()
                        .is_some_and(|s| s.message.contains("has no profile")) =>
                {
                    continue;
                }
                Err(e) => {
                    return Err(e.context(format!(
                        "gc: planning {id} at profile {profile}; fix the spec first"
                    )));
                }
            };
            keep.extend(exec::reachable_keys(
                &graph,
                &needed_nodes(&graph),
                reg,
                &store,
                &by_label,
            ));
        }
    }
    store.gc(&keep, dry_run)
}
