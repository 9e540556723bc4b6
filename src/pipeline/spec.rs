//! The YAML specs: experiments (simulation ensembles) and pipelines (one figure each).
//!
//! Both are parsed with serde-saphyr into typed structs that reject unknown keys;
//! every error names the file, the line and column, the key, and what is valid.
//! The schema is documented with examples in docs/spec.md.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use serde_saphyr::Spanned;

/// The profiles every experiment may define; `small` is the default.
pub const PROFILES: &[&str] = &["ci", "small", "paper"];
/// The profile used when none is given.
pub const DEFAULT_PROFILE: &str = "small";

/// A spec error located in a file: `file:line:column: message`.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecError {
    pub file: PathBuf,
    /// 1-based line, 0 when unknown (e.g. an unreadable file).
    pub line: u64,
    pub column: u64,
    pub message: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.file.display(), self.message)
        } else {
            write!(
                f,
                "{}:{}:{}: {}",
                self.file.display(),
                self.line,
                self.column,
                self.message
            )
        }
    }
}

impl std::error::Error for SpecError {}

impl SpecError {
    pub fn at<T>(file: &Path, span: &Spanned<T>, message: impl Into<String>) -> Self {
        SpecError {
            file: file.to_path_buf(),
            line: span.referenced.line(),
            column: span.referenced.column(),
            message: message.into(),
        }
    }
    pub fn file(file: &Path, message: impl Into<String>) -> Self {
        SpecError {
            file: file.to_path_buf(),
            line: 0,
            column: 0,
            message: message.into(),
        }
    }
}

/// `experiments/NAME.yaml`: one simulation ensemble, shared by every figure using it.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    /// One line shown by `repro list`.
    pub description: String,
    /// The stage kind that simulates one replica at one point (e.g. `simulate`).
    pub kind: Spanned<String>,
    /// Master seed; each replica's seed is hashed from (seed, point, replica).
    pub seed: u64,
    /// Parameters common to every profile and point (model, eps, ...).
    #[serde(default)]
    pub params: BTreeMap<String, Value>,
    /// Per-profile grid, replicas and run length (`ci`, `small`, `paper`).
    pub profiles: BTreeMap<String, Spanned<ProfileSpec>>,
}

/// The ensemble at one profile.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileSpec {
    /// Parameter grid: every combination of the listed values is one point.
    #[serde(default)]
    pub grid: BTreeMap<String, Spanned<Vec<Value>>>,
    /// Independent replicas per point (different seeds).
    pub replicas: Spanned<u64>,
    /// Parameters of this profile (N, run length, sampling schedule, ...); they
    /// override the experiment's common `params`.
    #[serde(default)]
    pub params: BTreeMap<String, Value>,
}

/// `pipelines/ID.yaml`: one figure.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    /// One line shown by `repro list`.
    pub description: String,
    /// The stages, in any order; each reads experiments or other stages by name.
    pub stages: Vec<Spanned<StageSpec>>,
}

/// One stage of a pipeline, expanded into one or more stage instances.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    /// Name, unique within the pipeline; published files are named after it.
    pub name: String,
    /// The stage kind (registered in the stage-kind registry).
    pub kind: String,
    /// Map: one instance per instance of this experiment or stage.
    #[serde(default)]
    pub map: Option<String>,
    /// Gather: one instance reading every instance of these experiments or stages
    /// (or one per group of equal `by` values).
    #[serde(default)]
    pub gather: Option<Vec<String>>,
    /// With `gather`: group instances by these point keys (e.g. `[phi]` to average
    /// replicas per packing fraction).
    #[serde(default)]
    pub by: Vec<String>,
    /// Parameters of the stage kind.
    #[serde(default)]
    pub params: BTreeMap<String, Value>,
    /// Sweep over stage parameters: every combination is one more instance, and
    /// the swept values become point keys (columns of downstream tables).
    #[serde(default)]
    pub sweep: BTreeMap<String, Vec<Value>>,
    /// Per-profile overrides of `params`.
    #[serde(default)]
    pub profiles: BTreeMap<String, BTreeMap<String, Value>>,
    /// Copy this stage's files into `results/ID/` (default: yes when the stage has
    /// exactly one instance).
    #[serde(default)]
    pub publish: Option<bool>,
}

/// Every spec under a root: experiments and pipelines by name, with their files.
#[derive(Debug, Clone, Default)]
pub struct Catalogue {
    pub experiments: BTreeMap<String, (PathBuf, ExperimentSpec)>,
    pub pipelines: BTreeMap<String, (PathBuf, PipelineSpec)>,
}

/// Parse one YAML file into a spec struct, with a located error.
pub fn parse<T: DeserializeOwned>(file: &Path, text: &str) -> Result<T, SpecError> {
    let opts = serde_saphyr::options! { strict_booleans: true };
    serde_saphyr::from_str_with_options(text, opts).map_err(|e| {
        let (line, column) = e
            .location()
            .map(|l| (l.line(), l.column()))
            .unwrap_or((0, 0));
        // The rendered message repeats the location and calls the file `<input>`.
        let text = e.to_string();
        let prefix = format!("error: line {line} column {column}: ");
        let message = text
            .strip_prefix(&prefix)
            .unwrap_or(&text)
            .replace("<input>", &file.display().to_string());
        SpecError {
            file: file.to_path_buf(),
            line,
            column,
            message,
        }
    })
}

fn yaml_files(dir: &Path) -> Result<Vec<(String, PathBuf)>, SpecError> {
    let rd = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(SpecError::file(dir, format!("cannot list directory: {e}"))),
    };
    let mut out: Vec<(String, PathBuf)> = rd
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml" || x == "yml"))
        .filter_map(|p| Some((p.file_stem()?.to_str()?.to_string(), p)))
        .collect();
    out.sort();
    Ok(out)
}

fn read(file: &Path) -> Result<String, SpecError> {
    std::fs::read_to_string(file).map_err(|e| SpecError::file(file, format!("cannot read: {e}")))
}

impl Catalogue {
    /// Load `ROOT/experiments/*.yaml` and `ROOT/pipelines/*.yaml`; names are the
    /// file stems. Every file is parsed (a broken spec is reported even when
    /// another figure is asked for: the catalogue is one whole).
    pub fn load(root: &Path) -> Result<Catalogue, SpecError> {
        let mut c = Catalogue::default();
        for (name, file) in yaml_files(&root.join("experiments"))? {
            let spec: ExperimentSpec = parse(&file, &read(&file)?)?;
            check_experiment(&file, &spec)?;
            c.experiments.insert(name, (file, spec));
        }
        for (name, file) in yaml_files(&root.join("pipelines"))? {
            let spec: PipelineSpec = parse(&file, &read(&file)?)?;
            c.pipelines.insert(name, (file, spec));
        }
        Ok(c)
    }

    /// The pipeline of figure `id`, or an error listing the known ids.
    pub fn pipeline(&self, id: &str) -> Result<&(PathBuf, PipelineSpec), String> {
        self.pipelines.get(id).ok_or_else(|| {
            let known: Vec<&str> = self.pipelines.keys().map(|s| s.as_str()).collect();
            format!(
                "unknown figure id '{id}': there is no pipelines/{id}.yaml; known figures: {}",
                if known.is_empty() {
                    "none (is --root right?)".to_string()
                } else {
                    known.join(", ")
                }
            )
        })
    }
}

/// Checks serde cannot express: known profiles, non-empty grids, replicas >= 1.
fn check_experiment(file: &Path, spec: &ExperimentSpec) -> Result<(), SpecError> {
    if spec.profiles.is_empty() {
        return Err(SpecError::file(
            file,
            format!("`profiles` is empty; define at least one of {PROFILES:?}"),
        ));
    }
    for (name, p) in &spec.profiles {
        if !PROFILES.contains(&name.as_str()) {
            return Err(SpecError::at(
                file,
                p,
                format!("unknown profile '{name}'; valid profiles: {PROFILES:?}"),
            ));
        }
        for (key, values) in &p.value.grid {
            if values.value.is_empty() {
                return Err(SpecError::at(
                    file,
                    values,
                    format!(
                        "profile '{name}': grid key '{key}' has an empty list of values; give at least one value"
                    ),
                ));
            }
            if key == "replica" || key == "seed" {
                return Err(SpecError::at(
                    file,
                    values,
                    format!("grid key '{key}' is reserved (set by the framework); rename it"),
                ));
            }
        }
        if p.value.replicas.value == 0 {
            return Err(SpecError::at(
                file,
                &p.value.replicas,
                format!("profile '{name}': `replicas` must be at least 1"),
            ));
        }
    }
    Ok(())
}
