//! What a stage kind is and what it sees: the [`StageKind`] trait, a stage's
//! [`Output`], its inputs as [`Artifact`]s when it runs and as [`PlannedInput`]s
//! when it is planned, the [`StageCtx`] it runs in, and the [`Planned`] cost of a long one.
//!
//! A kind is a pure function of (its canonical parameters, its input artifacts, the
//! seed): the cache relies on that. Each kind names its own source file; the
//! fingerprint of the modules that file reaches is part of every stage key, so
//! an edit to the simulator reruns simulations and an edit to a plot reruns only
//! plots.
//!
//! This file depends on nothing else of the framework but [`super::canon`] and
//! [`super::checkpoints`]: the graph and the registry build on it.

use std::any::Any;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use anyhow::{Context, Result};
use serde_json::{Map, Value};

use super::canon::{Point, point_label};
use super::checkpoints::Checkpoints;

/// One kind of stage (simulate, chi4, table, fit, plot, ...), with its
/// parameters as a type of its own: the planner parses each stage's parameters
/// once ([`StageKind::parse`]) and hands the typed value to the plan-time check,
/// the plan and the run. The registry holds kinds as [`Kind`].
pub trait StageKind: Send + Sync + 'static {
    /// The kind's parameters, parsed and checked.
    type Params: Send + Sync + 'static;
    /// Name used in specs (`kind: chi4`).
    fn name(&self) -> &str;
    /// One line for `--help`-like listings.
    fn describe(&self) -> &str {
        ""
    }
    /// What one stage of this kind produces with these parameters, for
    /// `results/ID/README.md` (a fit names its form and equation).
    fn explain(&self, _params: &Value) -> String {
        self.describe().to_string()
    }
    /// More lines for `repro kinds`: parameters, forms, an example.
    fn details(&self) -> String {
        String::new()
    }
    /// The kind's own source file(s) under `src/` (`&[file!()]`, or module
    /// paths such as `stages/simulate`): its code fingerprint hashes every module
    /// they reach through the import graph ([`super::fingerprint`]).
    fn modules(&self) -> &[&str];
    /// Import edges (`(from, to)` module keys) its key does not follow. A
    /// catalogue that names every member of a family to dispatch by name
    /// (`analysis::observables` names every observable's module) would put
    /// every member into every member's key: an analysis kind cuts the
    /// catalogue's edges to the members it does not run
    /// ([`super::fingerprint::Sources::closure_cut`]).
    fn not_followed(&self) -> Vec<(&'static str, &'static str)> {
        Vec::new()
    }
    /// Whether its stages analyse the window an experiment names (`window:` in
    /// its YAML) rather than every origin of its runs: the planner then adds
    /// that window's table to their inputs. Analyses of runs do; a kind that
    /// measures the window itself (aging) does not.
    fn takes_window(&self, _params: &Self::Params) -> bool {
        false
    }
    /// Parse and check parameters before anything runs; the error says what is
    /// valid (a [`ParamError`](super::canon::ParamError) is located at its key).
    fn parse(&self, params: &Value) -> Result<Self::Params>;
    /// Check at plan time what these parameters ask of the planned inputs (their
    /// kinds and parameters), e.g. that an experiment's lags reach a requested
    /// time; before anything runs, so `--dry-run` reports it too. A
    /// [`ParamError`](super::canon::ParamError) is located at its key in the stage's YAML.
    fn check_inputs(&self, _params: &Self::Params, _inputs: &[PlannedInput]) -> Result<()> {
        Ok(())
    }
    /// What this kind's output holds, for consumers that need a kind of content.
    fn holds(&self) -> Holds {
        Holds::Results
    }
    /// The configuration a run resolves from its parameters (a simulation's
    /// every setting, defaults and run-length rule applied), which travels to
    /// the stages downstream ([`Artifact::run`]); `None` for a kind that is no run.
    fn resolved(&self, _params: &Self::Params) -> Option<Map<String, Value>> {
        None
    }
    /// The keys of the upstream runs' resolved configuration ([`Artifact::run`])
    /// that these parameters read: their values become part of the stage's key.
    fn reads_run(&self, _params: &Self::Params) -> Vec<String> {
        Vec::new()
    }
    /// What a stage's result depends on outside its parameters, its inputs and
    /// the crate's code (a script kind: the content of the files it runs and
    /// reads, its interpreter's version), resolved under the project `root`:
    /// it becomes part of the stage's key. `Null` (nothing) for the built-in kinds.
    fn keyed_outside(&self, _params: &Self::Params, _root: &Path) -> Value {
        Value::Null
    }
    /// Produce this stage's files from its parameters and inputs.
    fn run(&self, ctx: &StageCtx, params: &Self::Params, inputs: &[Artifact]) -> Result<Output>;
}

/// A stage's parameters as its kind parsed them ([`StageKind::parse`]), held by
/// the planned node and handed to its kind.
#[derive(Clone)]
pub struct Parsed(Arc<dyn Any + Send + Sync>);

impl Parsed {
    /// The typed parameters; an error if they were parsed by another kind.
    pub fn get<T: 'static>(&self) -> Result<&T> {
        self.0.downcast_ref::<T>().with_context(|| {
            format!(
                "internal: parameters handed to a kind that did not parse them (expected {})",
                std::any::type_name::<T>()
            )
        })
    }
}

impl std::fmt::Debug for Parsed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Parsed(..)")
    }
}

/// A [`StageKind`] whose parameter type is erased, as the registry, the
/// planner and the executors hold it. Implemented for every `StageKind`.
pub trait Kind: Send + Sync {
    fn name(&self) -> &str;
    fn describe(&self) -> &str;
    fn explain(&self, params: &Value) -> String;
    fn details(&self) -> String;
    fn modules(&self) -> &[&str];
    fn not_followed(&self) -> Vec<(&'static str, &'static str)>;
    fn holds(&self) -> Holds;
    fn takes_window(&self, params: &Parsed) -> bool;
    /// [`StageKind::parse`], the value kept for the other calls.
    fn parse(&self, params: &Value) -> Result<Parsed>;
    /// Parse and drop (listings probe the accepted keys this way).
    fn validate(&self, params: &Value) -> Result<()> {
        self.parse(params).map(drop)
    }
    fn check_inputs(&self, params: &Parsed, inputs: &[PlannedInput]) -> Result<()>;
    fn resolved(&self, params: &Parsed) -> Option<Map<String, Value>>;
    fn reads_run(&self, params: &Parsed) -> Vec<String>;
    fn keyed_outside(&self, params: &Parsed, root: &Path) -> Value;
    fn run(&self, ctx: &StageCtx, params: &Parsed, inputs: &[Artifact]) -> Result<Output>;
    /// Parse and run (tests and tools that run a kind outside a planned graph).
    fn run_params(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        self.run(ctx, &self.parse(params)?, inputs)
    }
}

impl<K: StageKind> Kind for K {
    fn name(&self) -> &str {
        StageKind::name(self)
    }
    fn describe(&self) -> &str {
        StageKind::describe(self)
    }
    fn explain(&self, params: &Value) -> String {
        StageKind::explain(self, params)
    }
    fn details(&self) -> String {
        StageKind::details(self)
    }
    fn modules(&self) -> &[&str] {
        StageKind::modules(self)
    }
    fn not_followed(&self) -> Vec<(&'static str, &'static str)> {
        StageKind::not_followed(self)
    }
    fn holds(&self) -> Holds {
        StageKind::holds(self)
    }
    fn takes_window(&self, params: &Parsed) -> bool {
        params
            .get::<K::Params>()
            .is_ok_and(|p| StageKind::takes_window(self, p))
    }
    fn parse(&self, params: &Value) -> Result<Parsed> {
        Ok(Parsed(Arc::new(StageKind::parse(self, params)?)))
    }
    fn check_inputs(&self, params: &Parsed, inputs: &[PlannedInput]) -> Result<()> {
        StageKind::check_inputs(self, params.get::<K::Params>()?, inputs)
    }
    fn resolved(&self, params: &Parsed) -> Option<Map<String, Value>> {
        StageKind::resolved(self, params.get::<K::Params>().ok()?)
    }
    fn reads_run(&self, params: &Parsed) -> Vec<String> {
        params
            .get::<K::Params>()
            .map(|p| StageKind::reads_run(self, p))
            .unwrap_or_default()
    }
    fn keyed_outside(&self, params: &Parsed, root: &Path) -> Value {
        params
            .get::<K::Params>()
            .map_or(Value::Null, |p| StageKind::keyed_outside(self, p, root))
    }
    fn run(&self, ctx: &StageCtx, params: &Parsed, inputs: &[Artifact]) -> Result<Output> {
        StageKind::run(self, ctx, params.get::<K::Params>()?, inputs)
    }
}

/// What a kind's output holds, declared by the kind ([`StageKind::holds`]) so that
/// consumers look for a kind of content, never for a kind by its name.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Holds {
    /// Tables, figures or anything else a consumer picks by the stage that made it.
    #[default]
    Results,
    /// A simulated trajectory (`parquet`) with its run summary (`json`) and the
    /// run's parameters.
    Trajectory,
    /// The analysed window of an experiment's runs per state point (`parquet`:
    /// phi, skip_origins), which an experiment names as its `window`.
    Window,
}

/// What one long stage (a simulation) is planned to cost, as the function its
/// kind registered with ([`super::Registry::register_planned`]) estimates it
/// from its parameters before it runs: what the executors size their requests
/// by. The framework knows no physics: the model lives beside the kind
/// (`stages::simulate_cost`), outside its key, since it changes no output.
#[derive(Debug, Clone, PartialEq)]
pub struct Planned {
    /// CPU seconds.
    pub cpu_seconds: f64,
    /// Peak memory beyond the process's baseline, bytes.
    pub memory_bytes: f64,
    /// Bytes of its output a stage downstream reads (a trajectory's positions).
    pub output_bytes: u64,
    /// What the estimate counts, for listings (`N`, `collisions`, ...), in
    /// the order the kind gives them.
    pub counts: Vec<(&'static str, f64)>,
}

impl Planned {
    /// A count as listings print it: a whole number below 10^6 as it is
    /// (`2000`), anything else in three significant digits (`3.142e8`).
    pub fn count_text(v: f64) -> String {
        if v.fract() == 0.0 && v.abs() < 1e6 {
            format!("{v}")
        } else {
            format!("{v:.3e}")
        }
    }
}

/// Which declared stage an instance is: a stage of a figure's pipeline at one
/// point of its sweep, or one simulation of an experiment. Code that needs "the
/// stage called `tau`" matches on these fields, never on the label text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StageId {
    /// The figure whose pipeline declares the stage (`fig4`); `None` for an
    /// experiment's simulations.
    pub figure: Option<String>,
    /// The stage's name in its pipeline (`tau`), or the experiment's name (`eps09`).
    pub stage: String,
    /// Grid and sweep values of the instance (empty for a single instance).
    pub point: Point,
}

impl std::fmt::Display for StageId {
    /// The readable label: `fig4/tau[phi=0.6]`, `fig4/taufit`, `eps09[phi=0.6,replica=0]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(fig) = &self.figure {
            write!(f, "{fig}/")?;
        }
        write!(f, "{}", self.stage)?;
        if !self.point.is_empty() {
            write!(f, "[{}]", point_label(&self.point))?;
        }
        Ok(())
    }
}

/// The kind of the stage an input comes from: its name (for messages) and what
/// its output holds (asked of the registry when the input is handed over).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceKind {
    pub name: String,
    pub holds: Holds,
}

impl From<&str> for SourceKind {
    /// A kind that declares no particular content ([`Holds::Results`]).
    fn from(name: &str) -> Self {
        SourceKind {
            name: name.to_string(),
            holds: Holds::default(),
        }
    }
}

/// A planned input stage as a kind sees it at plan time ([`StageKind::check_inputs`]).
#[derive(Debug, Clone)]
pub struct PlannedInput<'a> {
    pub kind: SourceKind,
    /// Which declared stages it is.
    pub ids: &'a [StageId],
    /// Its canonical parameters.
    pub params: &'a Value,
    /// Its parameters as its kind parsed them.
    pub parsed: &'a Parsed,
    /// The resolved configuration of the runs it comes from ([`Artifact::run`]).
    pub run: &'a Map<String, Value>,
    /// The spec file that declares it.
    pub file: &'a Path,
}

/// The files a stage produced, named by extension (`parquet`, `svg`, `png`, ...).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Output {
    pub files: BTreeMap<String, Vec<u8>>,
    /// Measurements of the run (CPU seconds, speeds, memory): kept with the cache
    /// entry and provenance, not part of the output digest.
    pub side: Option<Value>,
}

impl Output {
    /// An output of one file.
    pub fn single(ext: &str, bytes: Vec<u8>) -> Self {
        Output::default().with(ext, bytes)
    }
    /// Add one file.
    pub fn with(mut self, ext: &str, bytes: Vec<u8>) -> Self {
        self.files.insert(ext.to_string(), bytes);
        self
    }
    /// Attach the side record.
    pub fn with_side(mut self, side: Value) -> Self {
        self.side = Some(side);
        self
    }
}

/// An upstream stage's result as seen by a downstream stage.
#[derive(Debug, Clone)]
pub struct Artifact {
    /// Readable label of the producing stage (`eps09[phi=0.78,replica=0]`).
    pub label: String,
    /// Which declared stages produced it (several when figures share the stage).
    pub ids: Vec<StageId>,
    /// Kind of the producing stage.
    pub kind: SourceKind,
    /// Grid and sweep values of the producing stage (become table columns).
    pub point: Point,
    /// Canonical parameters of the producing stage.
    pub params: Value,
    /// The resolved configuration of the runs it comes from: a simulation's
    /// every setting ([`StageKind::resolved`]), and for any other stage the
    /// settings its upstream runs share (`eps` and `n` of a sweep over `phi`).
    pub run: Arc<Map<String, Value>>,
    /// Hash of all its files (what the downstream key depends on).
    pub digest: String,
    /// Its files: extension -> (blake3 hex, path in the store).
    pub files: BTreeMap<String, (String, PathBuf)>,
}

impl Artifact {
    /// Whether this input was produced by a stage named `stage` (a pipeline stage's
    /// name or an experiment's name).
    pub fn is_from(&self, stage: &str) -> bool {
        self.ids.iter().any(|id| id.stage == stage)
    }

    /// Bytes of the file with extension `ext`.
    pub fn read(&self, ext: &str) -> Result<Vec<u8>> {
        let (_, path) = self.files.get(ext).with_context(|| {
            format!(
                "input {} has no '{ext}' file (it has: {})",
                self.label,
                self.files.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })?;
        std::fs::read(path).with_context(|| format!("reading {} of {}", path.display(), self.label))
    }
}

/// Where a running stage reports progress; `None` when not drawing bars.
pub type ProgressSink = Arc<dyn Fn(f64, f64, &str) + Send + Sync>;

/// What a running stage gets besides its parameters and inputs.
pub struct StageCtx {
    /// Seed of this stage: the `seed` parameter when present (simulations: derived
    /// from master seed, point and replica), else a hash of the stage recipe.
    pub seed: u64,
    /// Readable label of this stage.
    pub label: String,
    log: Mutex<Vec<String>>,
    /// Log lines the run's output shows too.
    notes: Mutex<Vec<String>>,
    progress: Option<ProgressSink>,
    checkpoints: Option<Checkpoints>,
    root: Option<PathBuf>,
}

impl StageCtx {
    pub fn new(seed: u64, label: String, progress: Option<ProgressSink>) -> Self {
        StageCtx {
            seed,
            label,
            log: Mutex::new(Vec::new()),
            notes: Mutex::new(Vec::new()),
            progress,
            checkpoints: None,
            root: None,
        }
    }
    /// The same context with the project root the stage was declared under.
    pub fn with_root(mut self, root: &Path) -> Self {
        self.root = Some(root.to_path_buf());
        self
    }
    /// The project root (holding `pipelines/`) the stage was declared under;
    /// `None` for a kind run outside a planned graph.
    pub fn root(&self) -> Option<&Path> {
        self.root.as_deref()
    }
    /// The same context with a directory for the stage's checkpoints.
    pub fn with_checkpoints(mut self, c: Checkpoints) -> Self {
        self.checkpoints = Some(c);
        self
    }
    /// Where a long stage may keep checkpoints to resume from (none in tests
    /// and tools that run a kind outside the store).
    pub fn checkpoints(&self) -> Option<&Checkpoints> {
        self.checkpoints.as_ref()
    }
    /// Append a line to this stage's log (kept with the cache entry and shown on failure).
    pub fn log(&self, line: impl Into<String>) {
        self.log.lock().unwrap().push(line.into());
    }
    /// A log line worth showing in the run's output too (e.g. that the stage
    /// resumed from a checkpoint).
    pub fn note(&self, line: impl Into<String>) {
        let line = line.into();
        self.notes.lock().unwrap().push(line.clone());
        self.log(line);
    }
    /// The notes so far.
    pub fn take_notes(&self) -> Vec<String> {
        std::mem::take(&mut *self.notes.lock().unwrap())
    }
    /// Report progress: `done` out of `total` (e.g. simulated time), with a message
    /// such as events per second. Cheap when no bar is drawn.
    pub fn progress(&self, done: f64, total: f64, message: &str) {
        if let Some(p) = &self.progress {
            p(done, total, message);
        }
    }
    /// The log lines so far.
    pub fn take_log(&self) -> Vec<String> {
        std::mem::take(&mut *self.log.lock().unwrap())
    }
}
