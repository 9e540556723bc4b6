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
use super::graph::StageId;

/// One kind of stage (simulate, chi4, table, fit, plot, ...).
pub trait StageKind: Send + Sync {
    /// Name used in specs (`kind: chi4`).
    fn name(&self) -> &str;
    /// One line for `--help`-like listings.
    fn describe(&self) -> &str {
        ""
    }
    /// More lines for `repro kinds`: parameters, forms, an example.
    fn details(&self) -> String {
        String::new()
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
    /// Readable label of the producing stage (`eps09[phi=0.78,replica=0]`).
    pub label: String,
    /// Which declared stages produced it (several when figures share the stage).
    pub ids: Vec<StageId>,
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
/// An unknown module name is an error: a misspelt or renamed module must not
/// silently key every stage of the kind on a constant.
pub fn code_fingerprint(name: &str, modules: &[&str]) -> Result<String> {
    code_fingerprint_in(name, modules, crate::fingerprints::of)
}

/// [`code_fingerprint`] over any table of module fingerprints (tests use one
/// computed from an edited copy of the sources).
pub fn code_fingerprint_in<'a>(
    name: &str,
    modules: &[&str],
    of: impl Fn(&str) -> Option<&'a str>,
) -> Result<String> {
    if modules.is_empty() {
        bail!("stage kind '{name}' names no source module");
    }
    let mut mods: Vec<&str> = modules.to_vec();
    mods.sort();
    let mut fields: Vec<Vec<u8>> = vec![name.as_bytes().to_vec()];
    for m in mods {
        let Some(fp) = of(m) else {
            bail!(
                "stage kind '{name}' names source module '{m}', which is not a folder or .rs file under src/"
            );
        };
        fields.push(m.as_bytes().to_vec());
        fields.push(fp.as_bytes().to_vec());
    }
    let refs: Vec<&[u8]> = fields.iter().map(|f| f.as_slice()).collect();
    Ok(hash_fields("repro-code-v1", &refs).to_hex().to_string())
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Registry::default()
    }

    /// The framework's own kinds (`table`, `compare`). The kinds of the library
    /// (simulate, analyses, fits, plots) are added by whoever assembles the
    /// registry (`stages::registry()`): the framework does not know them.
    pub fn framework() -> Self {
        let mut r = Registry::new();
        r.register(super::kinds::Table);
        r.register(super::kinds::Compare);
        r
    }

    /// Add a kind; its fingerprint comes from its modules. Replaces a kind of the
    /// same name. Panics when the kind names a module that does not exist under
    /// `src/` (a programming error every test that builds the registry catches).
    pub fn register(&mut self, kind: impl StageKind + 'static) {
        let fingerprint = code_fingerprint(kind.name(), kind.modules()).unwrap_or_else(|e| {
            panic!("{e}");
        });
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_module_is_an_error_not_a_constant() {
        let e = code_fingerprint("chi4", &["analysis", "stages/chi_4"]).unwrap_err();
        assert!(
            e.to_string().contains("'stages/chi_4'") && e.to_string().contains("chi4"),
            "{e}"
        );
        assert!(code_fingerprint("chi4", &[]).is_err());
        assert!(code_fingerprint("table", &["pipeline", "table"]).is_ok());
    }

    #[test]
    #[should_panic(expected = "names source module 'no_such_module'")]
    fn registering_a_kind_with_a_misspelt_module_panics() {
        struct Bad;
        impl StageKind for Bad {
            fn name(&self) -> &str {
                "bad"
            }
            fn modules(&self) -> &[&str] {
                &["no_such_module"]
            }
            fn validate(&self, _: &Value) -> Result<()> {
                Ok(())
            }
            fn run(&self, _: &StageCtx, _: &Value, _: &[Artifact]) -> Result<Output> {
                Ok(Output::default())
            }
        }
        Registry::new().register(Bad);
    }
}
