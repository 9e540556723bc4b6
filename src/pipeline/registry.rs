//! Stage kinds: what a stage does, registered by name.
//!
//! A kind is a pure function of (its canonical parameters, its input artifacts, the
//! seed): the cache relies on that. Each kind names the source modules that
//! implement it; their build-time fingerprints are part of every stage key, so an
//! edit to the simulator reruns simulations and an edit to a plot reruns only plots.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use anyhow::{Context, Result, bail};
use serde::de::DeserializeOwned;
use serde_json::Value;

use super::canon::{ParamError, Point, hash_fields};

/// One kind of stage (simulate, chi4, table, fit, plot, ...).
pub trait StageKind: Send + Sync {
    /// Name used in specs (`kind: chi4`).
    fn name(&self) -> &str;
    /// One line for `--help`-like listings.
    fn describe(&self) -> &str {
        ""
    }
    /// The source modules implementing this kind (folders or files under `src/`).
    fn modules(&self) -> &[&str];
    /// Check parameters before anything runs; the error says what is valid.
    fn validate(&self, params: &Value) -> Result<()>;
    /// Produce this stage's files from its parameters and inputs.
    fn run(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output>;
}

/// Deserialize a kind's parameters into a typed struct (use
/// `#[serde(deny_unknown_fields)]` on it). The error is a [`ParamError`] naming the
/// offending key (the planner points at it in the YAML file).
pub fn typed<T: DeserializeOwned>(kind: &str, params: &Value) -> Result<T> {
    serde_path_to_error::deserialize(params.clone()).map_err(|e| {
        use serde_path_to_error::Segment;
        let mut path: Vec<String> = e
            .path()
            .iter()
            .filter_map(|s| match s {
                Segment::Map { key } => Some(key.clone()),
                Segment::Seq { index } => Some(index.to_string()),
                _ => None,
            })
            .collect();
        let message = e.inner().to_string();
        // An unknown key is reported at its map: point at the key itself.
        if let Some(key) = message
            .strip_prefix("unknown field `")
            .and_then(|r| r.split('`').next())
        {
            path.push(key.to_string());
        }
        ParamError {
            path,
            message: format!("invalid parameters for stage kind '{kind}': {message}"),
        }
        .into()
    })
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
    /// Readable label of the producing stage (`eps09/sim[phi=0.78,replica=0]`).
    pub label: String,
    /// Kind of the producing stage.
    pub kind: String,
    /// Grid and sweep values of the producing stage (become table columns).
    pub point: Point,
    /// Canonical parameters of the producing stage.
    pub params: Value,
    /// Hash of all its files (what the downstream key depends on).
    pub digest: String,
    /// Its files: extension -> (blake3 hex, path in the store).
    pub files: BTreeMap<String, (String, PathBuf)>,
}

impl Artifact {
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
    progress: Option<ProgressSink>,
}

impl StageCtx {
    pub fn new(seed: u64, label: String, progress: Option<ProgressSink>) -> Self {
        StageCtx {
            seed,
            label,
            log: Mutex::new(Vec::new()),
            progress,
        }
    }
    /// Append a line to this stage's log (kept with the cache entry and shown on failure).
    pub fn log(&self, line: impl Into<String>) {
        self.log.lock().unwrap().push(line.into());
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

struct Registered {
    kind: Arc<dyn StageKind>,
    fingerprint: String,
}

/// The stage kinds the planner and executor know, with their code fingerprints.
#[derive(Default)]
pub struct Registry {
    kinds: BTreeMap<String, Registered>,
}

/// Fingerprint of a kind: hash of its name and its modules' build-time fingerprints.
pub fn code_fingerprint(name: &str, modules: &[&str]) -> String {
    let mut mods: Vec<&str> = modules.to_vec();
    mods.sort();
    let mut fields: Vec<Vec<u8>> = vec![name.as_bytes().to_vec()];
    for m in mods {
        fields.push(m.as_bytes().to_vec());
        fields.push(
            crate::fingerprints::of(m)
                .unwrap_or("missing")
                .as_bytes()
                .to_vec(),
        );
    }
    let refs: Vec<&[u8]> = fields.iter().map(|f| f.as_slice()).collect();
    hash_fields("repro-code-v1", &refs).to_hex().to_string()
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Registry::default()
    }

    /// The framework's own kinds (`table`, `compare`), plus the toy kinds when the
    /// environment variable `REPRO_TEST_KINDS=1` is set (test-only).
    pub fn builtin() -> Self {
        let mut r = Registry::new();
        r.register(super::kinds::Table);
        r.register(super::kinds::Compare);
        crate::stages::register(&mut r);
        if std::env::var("REPRO_TEST_KINDS").is_ok_and(|v| v == "1") {
            super::toy::register(&mut r);
        }
        r
    }

    /// Add a kind; its fingerprint comes from its modules. Replaces a kind of the same name.
    pub fn register(&mut self, kind: impl StageKind + 'static) {
        let fingerprint = code_fingerprint(kind.name(), kind.modules());
        self.kinds.insert(
            kind.name().to_string(),
            Registered {
                kind: Arc::new(kind),
                fingerprint,
            },
        );
    }

    /// Override a kind's code fingerprint (tests simulate a code edit this way).
    pub fn set_fingerprint(&mut self, name: &str, fingerprint: &str) -> Result<()> {
        match self.kinds.get_mut(name) {
            Some(r) => {
                r.fingerprint = fingerprint.to_string();
                Ok(())
            }
            None => bail!("no stage kind '{name}' to set a fingerprint on"),
        }
    }

    /// The kind called `name`, or an error listing the known kinds.
    pub fn get(&self, name: &str) -> Result<&Arc<dyn StageKind>> {
        self.kinds.get(name).map(|r| &r.kind).with_context(|| {
            format!(
                "unknown stage kind '{name}'; known kinds: {}",
                self.names().join(", ")
            )
        })
    }

    /// Code fingerprint of kind `name` (empty if unknown).
    pub fn fingerprint(&self, name: &str) -> &str {
        self.kinds
            .get(name)
            .map(|r| r.fingerprint.as_str())
            .unwrap_or("")
    }

    /// Names of all registered kinds.
    pub fn names(&self) -> Vec<String> {
        self.kinds.keys().cloned().collect()
    }
}
