//! The YAML specs: experiments (simulation ensembles) and pipelines (one figure each).
//!
//! Both are parsed with serde-saphyr into typed structs that reject unknown keys;
//! every error names the file, the line and column, the key, and what is valid.
//! The schema is documented with examples in docs/spec.md.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use serde_saphyr::Spanned;
use serde_saphyr::granit_parser::{Event, Parser};

use super::canon::ParamError;

/// The profiles an experiment may define; `small` is the default, `reach` the
/// smallest run the convergence sweeps say reaches what the box size can.
pub const PROFILES: &[&str] = &["ci", "small", "reach", "paper"];
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
    /// The analysed window of its runs, `FIGURE/STAGE`: a stage whose kind
    /// holds a window (phi, skip_origins), planned as that figure plans it.
    /// Every analysis of these runs outside that figure reads it
    /// (src/analysis/window.rs); without it they read every origin.
    #[serde(default)]
    pub window: Option<Spanned<String>>,
}

impl ExperimentSpec {
    /// Its parameters at `profile` (None: no such profile), as a text may
    /// state them (`{=eps09.n}`): the common and the profile's `params`, each
    /// grid key (one value as itself, several as a list) and `replicas`.
    pub fn parameters(&self, profile: &str) -> Option<serde_json::Map<String, Value>> {
        let prof = &self.profiles.get(profile)?.value;
        let mut m: serde_json::Map<String, Value> = self
            .params
            .iter()
            .chain(prof.params.iter())
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        for (k, v) in &prof.grid {
            let v = match v.value.as_slice() {
                [one] => one.clone(),
                many => Value::Array(many.to_vec()),
            };
            m.insert(k.clone(), v);
        }
        m.insert("replicas".into(), Value::from(prof.replicas.value));
        Some(m)
    }
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
    /// How this profile's jobs go to Slurm (`--executor slurm`); see docs/slurm.md.
    #[serde(default)]
    pub slurm: Option<Spanned<SlurmSpec>>,
}

/// Slurm settings of one experiment profile: where its jobs (and those of the
/// stages reading it) are submitted, and the margins on the planned resources.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmSpec {
    #[serde(default)]
    pub partition: Option<String>,
    #[serde(default)]
    pub account: Option<String>,
    #[serde(default)]
    pub qos: Option<String>,
    /// More sbatch options, verbatim (e.g. `--constraint=cpu`).
    #[serde(default)]
    pub extra: Vec<String>,
    /// Requested memory = planned memory x this (default 1.5; at least 1).
    #[serde(default)]
    pub mem_margin: Option<Spanned<f64>>,
    /// Time limit = planned time x this (default 3; at least 1).
    #[serde(default)]
    pub time_margin: Option<Spanned<f64>>,
    /// The longest time limit a job may ask (Slurm's format, e.g.
    /// `2-00:00:00`); default: the partition's, from `sinfo`. A stage planned
    /// longer runs as a chain of jobs, each resuming from the last checkpoint.
    #[serde(default)]
    pub max_time: Option<Spanned<String>>,
    /// Planned CPU seconds a job's task is filled up to with short stages of
    /// one kind, run one after the other (default: what fits under Slurm's
    /// two-minute floor at the time margin, 30 s at the margin 3; 0: one
    /// stage per task).
    #[serde(default)]
    pub pack_seconds: Option<Spanned<f64>>,
}

/// `pipelines/ID.yaml`: one figure.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    /// One line shown by `repro list`.
    pub description: String,
    /// Gated in the CI regression: `make test` builds it at the ci profile
    /// (`repro figure --ci`) and `repro regress` checks its key numbers against
    /// tests/golden/ci.json.
    #[serde(default)]
    pub ci: bool,
    /// Why a key number's quoted error misses the rule of `repro coverage`
    /// (median quoted error within 0.5-2 of the seed-to-seed spread, no seed
    /// beyond 5 of its errors), per profile: quantity -> the reason, with the
    /// survey that measured it. Read by `repro coverage` only, so editing a
    /// reason reruns nothing.
    #[serde(default)]
    pub error_coverage: BTreeMap<String, BTreeMap<String, String>>,
    /// Paragraphs several texts share (id -> text), included by
    /// `{reason:ID}`; expanded at load ([`expand_shared_reasons`]).
    #[serde(default)]
    pub reasons: BTreeMap<String, String>,
    /// The stages, in any order; each reads experiments or other stages by name.
    pub stages: Vec<Spanned<StageSpec>>,
}

/// One stage of a pipeline, expanded into one or more stage instances.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    /// Name, unique within the pipeline; published files are named after it.
    pub name: String,
    /// The stage kind (registered in the stage-kind registry); empty for a
    /// stage that is another figure's (`from`).
    #[serde(default)]
    pub kind: String,
    /// Another figure's stage, `FIGURE/STAGE` (`fig4/joint`), read by reference
    /// instead of copied: its instances are planned once (same node, same key)
    /// whichever figure asks for them. Takes no `kind`, sources or parameters.
    #[serde(default)]
    pub from: Option<String>,
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
    /// What the published table is in the paper (e.g. "paper H, Fig. 4: the
    /// symbols"), for `results/ID/README.md`; not part of any cache key.
    #[serde(default)]
    pub describes: Option<String>,
    /// What a column of the published table means where its usual meaning
    /// (src/table/columns.rs) does not hold, e.g. `t` as the time since the
    /// force was switched on, not a lag; for the README only, in no key.
    #[serde(default)]
    pub columns: BTreeMap<String, String>,
}

/// `spec` with every `{reason:ID}` of its `error_coverage` and stage
/// parameters replaced by the text `reasons[ID]`, and the `{paper:X}` of its
/// description and `describes` printed (docs/spec.md, "Numbers in texts"):
/// before planning, so a stage's key sees the text it states. An unknown id,
/// or one no text uses, is an error naming it.
fn expand_shared_reasons(mut spec: PipelineSpec) -> Result<PipelineSpec, String> {
    use crate::table::references::expand_reasons;
    fn in_value(
        v: &mut Value,
        expand: &mut dyn FnMut(&str) -> Result<String, String>,
    ) -> Result<(), String> {
        match v {
            Value::String(s) if s.contains("{reason:") => *s = expand(s)?,
            Value::Array(xs) => xs.iter_mut().try_for_each(|x| in_value(x, expand))?,
            Value::Object(m) => m.values_mut().try_for_each(|x| in_value(x, expand))?,
            _ => {}
        }
        Ok(())
    }
    let reasons = std::mem::take(&mut spec.reasons);
    let mut used = std::collections::BTreeSet::new();
    let mut expand = |t: &str| expand_reasons(t, &reasons, &mut used).map_err(|e| format!("{e:#}"));
    for why in spec
        .error_coverage
        .values_mut()
        .flat_map(|m| m.values_mut())
    {
        *why = expand(why)?;
    }
    for st in &mut spec.stages {
        let st = &mut st.value;
        for v in st
            .params
            .values_mut()
            .chain(st.profiles.values_mut().flat_map(|m| m.values_mut()))
        {
            in_value(v, &mut expand)?;
        }
    }
    // Texts that name no build: their quotations are printed once, here.
    let quoted = |t: &str| crate::table::references::quotations(t).map_err(|e| format!("{e:#}"));
    spec.description = quoted(&spec.description)?;
    for st in &mut spec.stages {
        if let Some(d) = &st.value.describes {
            st.value.describes = Some(quoted(d)?);
        }
    }
    if let Some(id) = reasons.keys().find(|id| !used.contains(*id)) {
        return Err(format!(
            "`reasons` holds '{id}', which no text uses as {{reason:{id}}}"
        ));
    }
    spec.reasons = reasons;
    Ok(spec)
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
    /// The figures marked `ci: true`, sorted by name.
    pub fn ci_figures(&self) -> Vec<String> {
        self.pipelines
            .iter()
            .filter(|(_, (_, p))| p.ci)
            .map(|(n, _)| n.clone())
            .collect()
    }

    /// Every figure's reasons for key numbers whose quoted errors miss the
    /// coverage rule at `profile`: (figure, quantity) -> reason.
    pub fn error_coverage(&self, profile: &str) -> BTreeMap<(String, String), String> {
        let mut out = BTreeMap::new();
        for (fig, (_, p)) in &self.pipelines {
            for (q, why) in p.error_coverage.get(profile).into_iter().flatten() {
                out.insert((fig.clone(), q.clone()), why.clone());
            }
        }
        out
    }

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
            let text = read(&file)?;
            let spec: PipelineSpec = parse(&file, &text)?;
            if spec.stages.is_empty() {
                let (line, column) = yaml_marks(&text)
                    .get(&vec!["stages".to_string()])
                    .map(|(k, _)| k.unwrap_or_default())
                    .map(|m| (m.line, m.column))
                    .unwrap_or((0, 0));
                return Err(SpecError {
                    file,
                    line,
                    column,
                    message: "`stages` is empty: a pipeline needs at least one stage".into(),
                });
            }
            if let Some(p) = spec
                .error_coverage
                .keys()
                .find(|p| !PROFILES.contains(&p.as_str()))
            {
                let (line, column) = yaml_marks(&text)
                    .get(&vec!["error_coverage".to_string(), p.clone()])
                    .and_then(|(k, _)| *k)
                    .map_or((0, 0), |m| (m.line, m.column));
                return Err(SpecError {
                    file,
                    line,
                    column,
                    message: format!(
                        "`error_coverage` names the unknown profile '{p}'; valid profiles: {PROFILES:?}"
                    ),
                });
            }
            let spec = expand_shared_reasons(spec).map_err(|e| SpecError::file(&file, e))?;
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

/// A position in a YAML file (1-based line and column).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Mark {
    pub line: u64,
    pub column: u64,
}

/// The marks of one node: of its key (map entries) and of its value.
pub type Marks = (Option<Mark>, Mark);

/// Every node of the first document of `text`, by path (map keys and sequence
/// indices, outermost first), with the marks of its key and value. serde-saphyr
/// locates the typed spec; this locates inside free-form values such as `params`.
/// Whatever follows a syntax error is missing (that error is reported by itself).
pub fn yaml_marks(text: &str) -> HashMap<Vec<String>, Marks> {
    enum Frame {
        Map {
            path: Vec<String>,
            key: Option<(String, Mark)>,
        },
        Seq {
            path: Vec<String>,
            index: usize,
        },
    }
    let mut out = HashMap::new();
    let mut stack: Vec<Frame> = Vec::new();
    for ev in Parser::new_from_str(text) {
        let Ok((ev, span)) = ev else { break };
        let mark = Mark {
            line: span.start.line() as u64,
            column: span.start.col() as u64 + 1,
        };
        let (scalar, opens) = match &ev {
            Event::Scalar(v, ..) => (Some(v.to_string()), false),
            Event::Alias(_) => (Some(String::new()), false),
            Event::MappingStart(..) | Event::SequenceStart(..) => (None, true),
            Event::MappingEnd | Event::SequenceEnd => {
                stack.pop();
                continue;
            }
            Event::DocumentEnd => break,
            _ => continue,
        };
        let (path, key_mark) = match stack.last_mut() {
            None => (Vec::new(), None),
            Some(Frame::Map {
                key: key @ None, ..
            }) => match scalar {
                Some(k) => {
                    *key = Some((k, mark));
                    continue;
                }
                // A mapping or sequence as a key: too exotic for a spec.
                None => break,
            },
            Some(Frame::Map { path, key }) => {
                let (k, km) = key.take().expect("matched Some above");
                let mut p = path.clone();
                p.push(k);
                (p, Some(km))
            }
            Some(Frame::Seq { path, index }) => {
                let mut p = path.clone();
                p.push(index.to_string());
                *index += 1;
                (p, None)
            }
        };
        out.insert(path.clone(), (key_mark, mark));
        if opens {
            stack.push(match ev {
                Event::MappingStart(..) => Frame::Map { path, key: None },
                _ => Frame::Seq { path, index: 0 },
            });
        }
    }
    out
}

/// The line `mark` points at, with a caret under the column (like serde-saphyr's
/// own errors).
pub fn snippet(text: &str, mark: Mark) -> String {
    let line = text
        .lines()
        .nth(mark.line.saturating_sub(1) as usize)
        .unwrap_or("");
    let n = mark.line.to_string();
    let pad = " ".repeat(n.len());
    format!(
        "\n {pad} |\n {n} | {line}\n {pad} | {}^",
        " ".repeat(mark.column.saturating_sub(1) as usize)
    )
}

/// Where parameter error `pe` points in the file: the deepest node of its path
/// that exists (a nested key may sit in a flow map) in the first source holding it.
fn locate(
    marks: &HashMap<Vec<String>, Marks>,
    text: &str,
    sources: &[Vec<String>],
    pe: &ParamError,
) -> Option<(Mark, String)> {
    let unknown = pe.message.contains("unknown field");
    for k in (1..=pe.path.len()).rev() {
        for src in sources {
            let mut p = src.clone();
            p.extend(pe.path[..k].iter().cloned());
            if let Some(&(key, value)) = marks.get(&p) {
                let at = if unknown || k < pe.path.len() {
                    key.unwrap_or(value)
                } else {
                    value
                };
                return Some((at, snippet(text, at)));
            }
        }
    }
    None
}

/// A kind's rejection of parameters as a located error. When `err` names the
/// offending parameter (a [`ParamError`]), the error points at it in the first of
/// `sources` that holds it (paths of the YAML maps the parameters were merged from,
/// highest precedence first): an unknown key at the key, anything else at the value,
/// with a snippet. Otherwise at the first parameter the message names in backticks,
/// else at `fallback`.
pub fn param_error(
    file: &Path,
    sources: &[Vec<String>],
    fallback: Mark,
    context: &str,
    err: &anyhow::Error,
) -> SpecError {
    let message = format!("{context}: {err:#}");
    // Without a ParamError, a key the message names in backticks (`n`), if any.
    let named = || {
        message
            .split('`')
            .skip(1)
            .step_by(2)
            .map(|k| ParamError {
                path: vec![k.to_string()],
                message: String::new(),
            })
            .collect::<Vec<_>>()
    };
    let candidates = match err.downcast_ref::<ParamError>() {
        Some(pe) => vec![pe.clone()],
        None => named(),
    };
    let located = (|| {
        let text = std::fs::read_to_string(file).ok()?;
        let marks = yaml_marks(&text);
        candidates
            .iter()
            .find_map(|pe| locate(&marks, &text, sources, pe))
    })();
    match located {
        Some((at, snip)) => SpecError {
            file: file.to_path_buf(),
            line: at.line,
            column: at.column,
            message: format!("{message}{snip}"),
        },
        None => SpecError {
            file: file.to_path_buf(),
            line: fallback.line,
            column: fallback.column,
            message,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaml_marks_locate_keys_and_values_in_block_and_flow_style() {
        let text = "a: 1\nstages:\n  - name: s\n    params: {n: 10, tau: {A: x}}\n";
        let m = yaml_marks(text);
        let at = |p: &[&str]| m[&p.iter().map(|s| s.to_string()).collect::<Vec<_>>()];
        let mk = |line, column| Mark { line, column };
        assert_eq!(at(&["a"]), (Some(mk(1, 1)), mk(1, 4)));
        assert_eq!(at(&["stages", "0", "name"]).1, mk(3, 11));
        assert_eq!(
            at(&["stages", "0", "params", "n"]),
            (Some(mk(4, 14)), mk(4, 17))
        );
        assert_eq!(at(&["stages", "0", "params", "tau", "A"]).1, mk(4, 30));
        assert!(snippet(text, mk(4, 30)).ends_with(&format!(
            " 4 |     params: {{n: 10, tau: {{A: x}}}}\n   | {}^",
            " ".repeat(29)
        )));
    }

    /// `ci: true` marks a figure for CI; absent means not; a misspelt key is a
    /// located error, as every unknown key.
    /// A paragraph shared by several texts is written once under `reasons:`
    /// and included where `{reason:ID}` stands; an unknown or unused id fails
    /// the load with the file and the id.
    #[test]
    fn shared_reasons_are_expanded_at_load_and_checked() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pipelines");
        std::fs::create_dir_all(&p).unwrap();
        let write = |body: &str| {
            std::fs::write(
                p.join("a.yaml"),
                format!(
                    "description: a\n{body}stages:\n  - {{name: c, kind: compare, gather: [x], params: {{caveats: {{q: \"{{reason:jk}} Two.\"}}}}}}\n"
                ),
            )
            .unwrap()
        };
        write("reasons: {jk: \"One.\"}\nerror_coverage: {small: {q: \"{reason:jk}\"}}\n");
        let c = Catalogue::load(dir.path()).unwrap();
        let spec = &c.pipelines["a"].1;
        assert_eq!(spec.error_coverage["small"]["q"], "One.");
        assert_eq!(spec.stages[0].value.params["caveats"]["q"], "One. Two.");
        write("reasons: {jk: \"One.\", other: \"unused\"}\n");
        let e = Catalogue::load(dir.path()).unwrap_err().to_string();
        assert!(e.contains("a.yaml") && e.contains("'other'"), "{e}");
        write("reasons: {other: \"x\"}\nerror_coverage: {small: {q: \"{reason:other}\"}}\n");
        let e = Catalogue::load(dir.path()).unwrap_err().to_string();
        assert!(e.contains("{reason:jk}") && e.contains("other"), "{e}");
    }

    #[test]
    fn ci_figures_are_those_marked_ci() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pipelines");
        std::fs::create_dir_all(&p).unwrap();
        let stage = "stages:\n  - {name: t, kind: table, gather: [x]}\n";
        std::fs::write(
            p.join("b.yaml"),
            format!("description: b\nci: true\n{stage}"),
        )
        .unwrap();
        std::fs::write(p.join("a.yaml"), format!("description: a\n{stage}")).unwrap();
        std::fs::write(
            p.join("c.yaml"),
            format!("description: c\nci: true\n{stage}"),
        )
        .unwrap();
        assert_eq!(
            Catalogue::load(dir.path()).unwrap().ci_figures(),
            ["b", "c"]
        );
        std::fs::write(
            p.join("a.yaml"),
            format!("description: a\ncI: true\n{stage}"),
        )
        .unwrap();
        let e = Catalogue::load(dir.path()).unwrap_err().to_string();
        assert!(e.contains("a.yaml:2") && e.contains("cI"), "{e}");
    }
}
