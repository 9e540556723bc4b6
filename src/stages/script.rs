//! `script`: one's own analysis as a stage, in any language. The stage runs
//! `INTERPRETER SCRIPT` in a fresh temporary directory with its gathered inputs
//! given as paths, its `args` as JSON and a directory of its own for outputs;
//! it declares its outputs (tables with their schema, images), which are
//! checked, stored and published like any kind's.
//!
//! What the script sees (environment variables, all absolute paths):
//! - `REPRO_PARAMS`: a JSON file holding `args`;
//! - `REPRO_INPUTS`: a JSON list, one object per input (`label`, `stage`,
//!   `kind`, `point`, `files`: extension -> path);
//! - `REPRO_RUNS`: a Parquet table of the input simulations, one row per run
//!   with its parameters, seed and trajectory path ([`crate::table::runs`]);
//! - `REPRO_OUT`: the directory its declared outputs go to;
//! - `REPRO_SEED`: the stage's seed.
//!
//! Its key holds, beyond the parameters and the inputs' digests, the content
//! of the script, of every file it `reads` and of its `requirements` (the lock
//! of its packages), and the interpreter's `--version`
//! ([`StageKind::keyed_outside`]): editing the script reruns it and what is
//! downstream of it, nothing else.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context, Result, bail, ensure};
use arrow_schema::DataType;
use serde::Deserialize;
use serde_json::{Value, json};

use crate::pipeline::registry::typed;
use crate::pipeline::stage::Holds;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::read_parquet_bytes;
use crate::table::runs::{self, Run};

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// The program that runs the script (`python3`, `bash`), found on PATH.
    pub interpreter: String,
    /// The script, relative to the project root.
    pub script: PathBuf,
    /// Other files the script reads (modules, data), relative to the project root.
    #[serde(default)]
    pub reads: Vec<PathBuf>,
    /// The lock of the interpreter's packages (a requirements file), relative to the root.
    #[serde(default)]
    pub requirements: Option<PathBuf>,
    /// Parameters handed to the script as JSON (`REPRO_PARAMS`).
    #[serde(default)]
    pub args: Value,
    /// The tables the script writes to `REPRO_OUT/NAME.parquet`.
    #[serde(default)]
    pub tables: Vec<TableSpec>,
    /// The images the script writes to `REPRO_OUT` (`q.png`, `q.svg`).
    #[serde(default)]
    pub images: Vec<String>,
    /// Seconds after which the command is killed and the stage fails.
    #[serde(default = "default_timeout")]
    pub timeout_s: f64,
}

fn default_timeout() -> f64 {
    3600.0
}

/// A declared output table: its name and its columns with their types.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    pub name: String,
    pub columns: BTreeMap<String, ColumnType>,
}

/// The column types a declared table may have.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ColumnType {
    F64,
    I64,
    U64,
    String,
    Bool,
}

impl ColumnType {
    fn matches(self, t: &DataType) -> bool {
        match self {
            ColumnType::F64 => *t == DataType::Float64,
            ColumnType::I64 => *t == DataType::Int64,
            ColumnType::U64 => *t == DataType::UInt64,
            ColumnType::String => {
                matches!(t, DataType::Utf8 | DataType::LargeUtf8 | DataType::Utf8View)
            }
            ColumnType::Bool => *t == DataType::Boolean,
        }
    }
}

/// The image formats a script may declare, by extension.
const IMAGE_FORMATS: [&str; 3] = ["png", "svg", "pdf"];

/// How much of the command's stderr a failure shows.
const STDERR_TAIL_LINES: usize = 20;

pub struct Script;

impl StageKind for Script {
    type Params = Params;
    fn name(&self) -> &str {
        "script"
    }
    fn describe(&self) -> &str {
        "one's own analysis in any language: runs INTERPRETER SCRIPT on the gathered inputs (paths, a table of the input runs) with `args` as JSON; its declared tables (schema checked) and images are stored and published like any kind's; keyed by the script's content, the files it reads, its requirements and the interpreter's version"
    }
    fn details(&self) -> String {
        "parameters: interpreter, script, reads, requirements, args, tables, images, timeout_s\n  \
         paths are relative to the project root; the script reads $REPRO_PARAMS (JSON), $REPRO_INPUTS (JSON), $REPRO_RUNS (Parquet) and writes $REPRO_OUT/NAME.parquet, $REPRO_OUT/IMAGE\n  \
         outputs: the first table is the stage's `parquet` (what `table` and `plot` read by default), the others `NAME.parquet`; the first image its format (`png`), the others `NAME.EXT`\n  \
         example:\n    - name: q\n      kind: script\n      gather: [eps09]\n      by: [phi]\n      params:\n        interpreter: python3\n        script: pipelines/examples/scripts/overlap.py\n        requirements: requirements.txt\n        args: {a: 0.6}\n        tables: [{name: q, columns: {t: f64, Q: f64}}]"
            .into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<Params> {
        let p: Params = typed("script", params)?;
        check(&p)?;
        Ok(p)
    }
    fn holds(&self) -> Holds {
        Holds::Results
    }
    fn keyed_outside(&self, p: &Params, root: &Path) -> Value {
        let files: serde_json::Map<String, Value> = keyed_files(p)
            .into_iter()
            .map(|f| {
                let h = std::fs::read(root.join(f))
                    .map(|b| blake3::hash(&b).to_hex().to_string())
                    .unwrap_or_else(|e| format!("unreadable: {e}"));
                (f.to_string_lossy().into_owned(), Value::String(h))
            })
            .collect();
        json!({"files": files, "interpreter": interpreter_version(&p.interpreter)})
    }
    fn run(&self, ctx: &StageCtx, p: &Params, inputs: &[Artifact]) -> Result<Output> {
        let root = ctx
            .root()
            .context("script: no project root (a script stage runs inside a planned pipeline)")?;
        // Absolute: the command runs in another directory (`--root .` is relative).
        let root = &std::path::absolute(root)?;
        for f in keyed_files(p) {
            let path = root.join(f);
            ensure!(
                path.is_file(),
                "script: {} not found (paths are relative to the project root {})",
                path.display(),
                root.display()
            );
        }
        let work = tempfile::tempdir().context("script: creating its working directory")?;
        let out = work.path().join("out");
        std::fs::create_dir(&out)?;
        let given = write_inputs(work.path(), p, inputs)?;
        let before = snapshot(root);
        let status = run_command(ctx, p, root, work.path(), &out)?;
        let stderr = std::fs::read_to_string(work.path().join("stderr.txt")).unwrap_or_default();
        if !status.success() {
            bail!(
                "script: `{} {}` failed ({status}); the end of its stderr:\n{}",
                p.interpreter,
                p.script.display(),
                tail(&stderr, STDERR_TAIL_LINES)
            );
        }
        let changed = changes(&before, &snapshot(root));
        ensure!(
            changed.is_empty(),
            "script: `{}` wrote outside its output directory, under the project root: {} (a script writes only to $REPRO_OUT)",
            p.script.display(),
            changed.join(", ")
        );
        let stray = undeclared(p, work.path(), &given)?;
        if !stray.is_empty() {
            ctx.note(format!(
                "script wrote files it did not declare (discarded): {}",
                stray.join(", ")
            ));
        }
        collect_outputs(p, &out)
            .map(|o| o.with_side(json!({"interpreter": interpreter_version(&p.interpreter)})))
    }
}

/// The files a stage's key hashes: the script, what it reads, its requirements.
fn keyed_files(p: &Params) -> Vec<&Path> {
    std::iter::once(p.script.as_path())
        .chain(p.reads.iter().map(PathBuf::as_path))
        .chain(p.requirements.as_deref())
        .collect()
}

/// Plan-time checks of the parameters; each error names the key.
fn check(p: &Params) -> Result<()> {
    ensure!(
        !p.interpreter.trim().is_empty(),
        "script: `interpreter` is empty (e.g. python3)"
    );
    for f in keyed_files(p) {
        ensure!(
            !f.as_os_str().is_empty() && f.components().all(|c| matches!(c, Component::Normal(_))),
            "script: '{}' must be a path relative to the project root, without `..`",
            f.display()
        );
    }
    ensure!(
        p.timeout_s.is_finite() && p.timeout_s > 0.0,
        "script: `timeout_s` = {} must be a finite number > 0",
        p.timeout_s
    );
    ensure!(
        !p.tables.is_empty() || !p.images.is_empty(),
        "script: declare at least one output (`tables` or `images`)"
    );
    let mut names = BTreeSet::new();
    for t in &p.tables {
        ensure!(
            plain_name(&t.name),
            "script: table name '{}' must be a plain file stem (letters, digits, _ and -)",
            t.name
        );
        ensure!(
            !t.columns.is_empty(),
            "script: table '{}' declares no column",
            t.name
        );
        ensure!(
            names.insert(format!("{}.parquet", t.name)),
            "script: table '{}' is declared twice",
            t.name
        );
    }
    for i in &p.images {
        let ok = i
            .rsplit_once('.')
            .is_some_and(|(stem, ext)| plain_name(stem) && IMAGE_FORMATS.contains(&ext));
        ensure!(
            ok,
            "script: image '{i}' must be NAME.EXT with EXT one of {IMAGE_FORMATS:?}"
        );
        ensure!(
            names.insert(i.clone()),
            "script: image '{i}' is declared twice"
        );
    }
    Ok(())
}

fn plain_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// `INTERPRETER --version` (once per interpreter and process), or why not.
fn interpreter_version(interpreter: &str) -> String {
    static SEEN: OnceLock<Mutex<BTreeMap<String, String>>> = OnceLock::new();
    let mut seen = SEEN.get_or_init(Mutex::default).lock().unwrap();
    seen.entry(interpreter.to_string())
        .or_insert_with(
            || match Command::new(interpreter).arg("--version").output() {
                Ok(o) => {
                    let text = [o.stdout, o.stderr].concat();
                    String::from_utf8_lossy(&text).trim().to_string()
                }
                Err(e) => format!("not found: {e}"),
            },
        )
        .clone()
}

/// Write the script's inputs into `work`: params.json, inputs.json, runs.parquet.
/// Returns their names (the files of `work` that are no output of the script).
fn write_inputs(work: &Path, p: &Params, inputs: &[Artifact]) -> Result<Vec<String>> {
    let args = if p.args.is_null() {
        json!({})
    } else {
        p.args.clone()
    };
    // A text file ends in a newline, so that a script may append to a copy.
    let mut json = serde_json::to_vec_pretty(&args)?;
    json.push(b'\n');
    std::fs::write(work.join("params.json"), json)?;
    let listed: Vec<Value> = inputs
        .iter()
        .map(|a| {
            json!({
                "label": a.label,
                "stage": a.ids.first().map(|i| i.stage.clone()),
                "kind": a.kind.name,
                "point": a.point,
                "files": a.files.iter().map(|(ext, (_, path))| (ext.clone(), json!(absolute(path)))).collect::<serde_json::Map<_, _>>(),
            })
        })
        .collect();
    std::fs::write(
        work.join("inputs.json"),
        serde_json::to_vec_pretty(&listed)?,
    )?;
    let runs: Vec<Run> = inputs
        .iter()
        .filter(|a| a.kind.holds == Holds::Trajectory)
        .map(as_run)
        .collect::<Result<_>>()?;
    let bytes = crate::table::to_parquet_bytes(&[runs::batch(&runs)?], &[])?;
    std::fs::write(work.join("runs.parquet"), bytes)?;
    Ok([
        "params.json",
        "inputs.json",
        "runs.parquet",
        "stdout.txt",
        "stderr.txt",
        "out",
    ]
    .map(String::from)
    .to_vec())
}

/// A simulation input as a row of the runs table.
pub fn as_run(a: &Artifact) -> Result<Run> {
    let (_, path) = a
        .files
        .get("parquet")
        .with_context(|| format!("run {} has no trajectory", a.label))?;
    Ok(Run {
        experiment: a.ids.first().map(|i| i.stage.clone()).unwrap_or_default(),
        point: a.point.clone().into_iter().collect(),
        settings: (*a.run).clone(),
        seed: a
            .params
            .get("seed")
            .and_then(Value::as_u64)
            .unwrap_or_default(),
        path: absolute(path),
    })
}

/// `path` as the command sees it from its own directory (the store of
/// `--root .` is relative).
fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Run the command in `work`, killed after the timeout.
fn run_command(
    ctx: &StageCtx,
    p: &Params,
    root: &Path,
    work: &Path,
    out: &Path,
) -> Result<std::process::ExitStatus> {
    let mut child = Command::new(&p.interpreter)
        .arg(root.join(&p.script))
        .current_dir(work)
        .env("REPRO_PARAMS", work.join("params.json"))
        .env("REPRO_INPUTS", work.join("inputs.json"))
        .env("REPRO_RUNS", work.join("runs.parquet"))
        .env("REPRO_OUT", out)
        .env("REPRO_SEED", ctx.seed.to_string())
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(work.join("stdout.txt"))?)
        .stderr(std::fs::File::create(work.join("stderr.txt"))?)
        .spawn()
        .with_context(|| format!("script: cannot start the interpreter '{}'", p.interpreter))?;
    let t0 = Instant::now();
    let limit = Duration::from_secs_f64(p.timeout_s);
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            bail!(
                "script: `{} {}` timed out after {} s (`timeout_s`) and was killed",
                p.interpreter,
                p.script.display(),
                p.timeout_s
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stdout = std::fs::read_to_string(work.join("stdout.txt")).unwrap_or_default();
    for line in stdout.lines() {
        ctx.log(line);
    }
    Ok(status)
}

fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

/// Directories under the project root that repro itself writes (the store,
/// results, builds) and the VCS: a script's writes there are not looked for.
const NOT_WATCHED: [&str; 5] = [".repro", "results", "target", ".git", ".venv"];

/// Size and modification time of every file under `root` outside [`NOT_WATCHED`].
fn snapshot(root: &Path) -> BTreeMap<PathBuf, (u64, Option<SystemTime>)> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let path = e.path();
            let Ok(meta) = e.metadata() else { continue };
            if meta.is_dir() {
                let top = dir == root && NOT_WATCHED.iter().any(|n| e.file_name() == *n);
                if !top {
                    stack.push(path);
                }
            } else if meta.is_file() {
                out.insert(path, (meta.len(), meta.modified().ok()));
            }
        }
    }
    out
}

/// Files created, changed or removed between two snapshots.
fn changes(
    before: &BTreeMap<PathBuf, (u64, Option<SystemTime>)>,
    after: &BTreeMap<PathBuf, (u64, Option<SystemTime>)>,
) -> Vec<String> {
    let keys: BTreeSet<&PathBuf> = before.keys().chain(after.keys()).collect();
    keys.into_iter()
        .filter(|k| before.get(*k) != after.get(*k))
        .map(|k| k.display().to_string())
        .collect()
}

/// What the script wrote besides its declared outputs: in its output
/// directory and in its working directory.
fn undeclared(p: &Params, work: &Path, given: &[String]) -> Result<Vec<String>> {
    let declared: BTreeSet<String> = p
        .tables
        .iter()
        .map(|t| format!("{}.parquet", t.name))
        .chain(p.images.iter().cloned())
        .collect();
    let mut stray = Vec::new();
    for e in std::fs::read_dir(work.join("out"))?.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !declared.contains(&name) {
            stray.push(format!("$REPRO_OUT/{name}"));
        }
    }
    for e in std::fs::read_dir(work)?.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !given.contains(&name) {
            stray.push(format!("./{name}"));
        }
    }
    stray.sort();
    Ok(stray)
}

/// The declared outputs, checked, as the stage's files.
fn collect_outputs(p: &Params, out: &Path) -> Result<Output> {
    let mut o = Output::default();
    for (i, t) in p.tables.iter().enumerate() {
        let file = format!("{}.parquet", t.name);
        let bytes = std::fs::read(out.join(&file)).with_context(|| {
            format!(
                "script: declared table '{}' missing: the script wrote no $REPRO_OUT/{file}",
                t.name
            )
        })?;
        check_schema(t, bytes.clone())?;
        o = o.with(if i == 0 { "parquet" } else { &file }, bytes);
    }
    let mut first_of = BTreeSet::new();
    for name in &p.images {
        let bytes = std::fs::read(out.join(name)).with_context(|| {
            format!(
                "script: declared image '{name}' missing: the script wrote no $REPRO_OUT/{name}"
            )
        })?;
        ensure!(
            !bytes.is_empty(),
            "script: declared image '{name}' is empty"
        );
        let ext = name.rsplit_once('.').map_or("", |(_, e)| e).to_string();
        let key = if first_of.insert(ext.clone()) {
            ext
        } else {
            name.clone()
        };
        o = o.with(&key, bytes);
    }
    Ok(o)
}

/// The table holds exactly the declared columns with the declared types.
fn check_schema(t: &TableSpec, bytes: Vec<u8>) -> Result<()> {
    let (batches, _) = read_parquet_bytes(bytes)
        .with_context(|| format!("script: table '{}' is not a readable Parquet file", t.name))?;
    let Some(b) = batches.first() else {
        // No row group: pyarrow still writes the schema, but arrow hands no batch.
        bail!("script: table '{}' has no rows", t.name);
    };
    let schema = b.schema();
    let mut problems = Vec::new();
    for (name, ty) in &t.columns {
        match schema.column_with_name(name) {
            None => problems.push(format!("column '{name}' missing")),
            Some((_, f)) if !ty.matches(f.data_type()) => problems.push(format!(
                "column '{name}' is {} (declared {ty:?})",
                f.data_type()
            )),
            Some(_) => {}
        }
    }
    for f in schema.fields() {
        if !t.columns.contains_key(f.name()) {
            problems.push(format!("column '{}' not declared", f.name()));
        }
    }
    ensure!(
        problems.is_empty(),
        "script: table '{}' is not the declared one: {}",
        t.name,
        problems.join("; ")
    );
    Ok(())
}

#[cfg(test)]
#[path = "script_tests.rs"]
mod tests;
