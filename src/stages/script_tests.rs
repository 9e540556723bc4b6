//! The script kind against scripts with known behaviour (POSIX `sh`): what it
//! hands over, what it keys, and each way a script can go wrong.

use std::path::Path;

use serde_json::{Value, json};

use super::*;
use crate::pipeline::Kind;
use crate::pipeline::graph::StageId;
use crate::pipeline::stage::SourceKind;
use crate::stages::test_support::yaml;
use crate::table::f64_batch;

/// A project root holding `scripts/s.sh` (`body`) and a table `data/q.parquet`
/// with float columns t and Q.
fn root(body: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("scripts")).unwrap();
    std::fs::create_dir_all(dir.path().join("data")).unwrap();
    std::fs::write(dir.path().join("scripts/s.sh"), body).unwrap();
    let b = f64_batch(&[("t", vec![0.1, 1.0]), ("Q", vec![0.9, 0.4])]).unwrap();
    std::fs::write(
        dir.path().join("data/q.parquet"),
        crate::table::to_parquet_bytes(&[b], &[]).unwrap(),
    )
    .unwrap();
    dir
}

const PARAMS: &str = "interpreter: sh\nscript: scripts/s.sh\nreads: [data/q.parquet]\ntables: [{name: q, columns: {t: f64, Q: f64}}]\n";

/// Copies the table it reads to its output.
const COPY: &str = "cp \"$OLDPWD/data/q.parquet\" \"$REPRO_OUT/q.parquet\"\n";

fn run(root: &Path, params: &str, inputs: &[Artifact]) -> Result<Output> {
    let ctx = StageCtx::new(7, "s".into(), None).with_root(root);
    Script.run_params(&ctx, &yaml(params), inputs)
}

fn err(root: &Path, params: &str) -> String {
    format!("{:#}", run(root, params, &[]).unwrap_err())
}

/// The script's cwd is a fresh directory: it finds the root's files through
/// the cwd it was started from (`OLDPWD` is not set by repro), so the tests
/// hand it the root in the script itself.
fn at_root(root: &Path, body: &str) -> String {
    body.replace("$OLDPWD", &root.display().to_string())
}

#[test]
fn a_declared_table_is_the_stage_s_parquet_and_strays_are_reported() {
    let dir = root("");
    let body = at_root(dir.path(), COPY)
        + "echo scratch > notes.txt\necho extra > \"$REPRO_OUT/extra.csv\"\n";
    std::fs::write(dir.path().join("scripts/s.sh"), body).unwrap();
    let ctx = StageCtx::new(7, "s".into(), None).with_root(dir.path());
    let out = Script.run_params(&ctx, &yaml(PARAMS), &[]).unwrap();
    assert_eq!(
        out.files["parquet"],
        std::fs::read(dir.path().join("data/q.parquet")).unwrap()
    );
    assert_eq!(out.files.len(), 1);
    let notes = ctx.take_notes().join("\n");
    assert!(
        notes.contains("$REPRO_OUT/extra.csv") && notes.contains("./notes.txt"),
        "{notes}"
    );
    // Nothing the script did touched the root.
    assert!(!dir.path().join("notes.txt").exists());
}

/// The script gets its args as JSON, its seed, and its input runs as a table
/// whose rows carry their parameters and trajectory paths.
#[test]
fn the_script_receives_args_seed_and_its_runs_as_a_table() {
    let dir = root(
        "cp \"$REPRO_RUNS\" \"$REPRO_OUT/runs.parquet\"\ncp \"$REPRO_PARAMS\" \"$REPRO_OUT/args.svg\"\necho \"$REPRO_SEED\" >> \"$REPRO_OUT/args.svg\"\n",
    );
    let traj = dir.path().join("data/q.parquet");
    let sim = |phi: f64, replica: u64, seed: u64| Artifact {
        label: format!("e[phi={phi},replica={replica}]"),
        ids: vec![StageId {
            figure: None,
            stage: "e".into(),
            point: Default::default(),
        }],
        kind: SourceKind {
            name: "simulate".into(),
            holds: Holds::Trajectory,
        },
        point: json!({"phi": phi, "replica": replica})
            .as_object()
            .unwrap()
            .clone()
            .into_iter()
            .collect(),
        params: json!({"seed": seed}),
        run: std::sync::Arc::new(json!({"n": 100, "eps": 0.9}).as_object().unwrap().clone()),
        digest: String::new(),
        files: [("parquet".to_string(), (String::new(), traj.clone()))].into(),
    };
    let params = "interpreter: sh\nscript: scripts/s.sh\nargs: {a: 0.6}\nimages: [args.svg]\n\
        tables: [{name: runs, columns: {experiment: string, phi: f64, replica: i64, eps: f64, n: i64, seed: u64, path: string}}]\n";
    let out = run(dir.path(), params, &[sim(0.78, 2, 11), sim(0.8, 0, 12)]).unwrap();
    let (b, _) = read_parquet_bytes(out.files["parquet"].clone()).unwrap();
    let want = runs::batch(&[
        as_run(&sim(0.78, 2, 11)).unwrap(),
        as_run(&sim(0.8, 0, 12)).unwrap(),
    ])
    .unwrap();
    // The same columns (the written file adds each known column's unit and meaning).
    let names = |b: &arrow_array::RecordBatch| -> Vec<String> {
        b.schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect()
    };
    assert_eq!(names(&b[0]), names(&want));
    assert_eq!(b[0].columns(), want.columns());
    let seed = want.column_by_name("seed").unwrap();
    let seed = seed
        .as_any()
        .downcast_ref::<arrow_array::UInt64Array>()
        .unwrap();
    assert_eq!(seed.values().to_vec(), vec![11, 12]);
    let args = String::from_utf8(out.files["svg"].clone()).unwrap();
    let (json_part, seed_line) = args.trim().rsplit_once('\n').unwrap();
    assert_eq!(
        serde_json::from_str::<Value>(json_part).unwrap(),
        json!({"a": 0.6})
    );
    assert_eq!(seed_line, "7");
}

/// Editing the script, a file it reads or its requirements moves the key;
/// another file of the root does not.
#[test]
fn the_key_holds_the_script_what_it_reads_and_its_requirements() {
    let dir = root("true\n");
    std::fs::write(dir.path().join("requirements.txt"), "numpy==2.1.0\n").unwrap();
    std::fs::write(dir.path().join("other.py"), "x = 1\n").unwrap();
    let params = format!("{PARAMS}requirements: requirements.txt\n");
    let p = StageKind::parse(&Script, &yaml(&params)).unwrap();
    let key = || StageKind::keyed_outside(&Script, &p, dir.path());
    let base = key();
    assert!(
        base["interpreter"].as_str().is_some_and(|v| !v.is_empty()),
        "{base}"
    );
    let edit = |rel: &str, text: &str| std::fs::write(dir.path().join(rel), text).unwrap();
    edit("other.py", "x = 2\n");
    assert_eq!(key(), base, "an unrelated file moved the key");
    for (rel, text) in [
        ("scripts/s.sh", "true # edited\n"),
        ("data/q.parquet", "not the same"),
        ("requirements.txt", "numpy==2.2.0\n"),
    ] {
        let before = key();
        edit(rel, text);
        assert_ne!(key(), before, "editing {rel} left the key");
    }
}

#[test]
fn a_non_zero_exit_fails_with_the_end_of_stderr() {
    let dir = root("echo first >&2\necho 'ValueError: phi out of range' >&2\nexit 3\n");
    let e = err(dir.path(), PARAMS);
    assert!(e.contains("failed") && e.contains("exit status: 3"), "{e}");
    assert!(e.contains("ValueError: phi out of range"), "{e}");
}

#[test]
fn a_declared_output_missing_is_named() {
    let dir = root("true\n");
    let e = err(dir.path(), PARAMS);
    assert!(
        e.contains("declared table 'q' missing") && e.contains("$REPRO_OUT/q.parquet"),
        "{e}"
    );
    let e = err(
        dir.path(),
        &format!(
            "{}images: [q.png]\n",
            PARAMS.replace("tables: [{name: q, columns: {t: f64, Q: f64}}]\n", "")
        ),
    );
    assert!(e.contains("declared image 'q.png' missing"), "{e}");
}

#[test]
fn a_table_of_another_schema_is_refused_with_each_difference() {
    let dir = root("");
    std::fs::write(dir.path().join("scripts/s.sh"), at_root(dir.path(), COPY)).unwrap();
    let params = PARAMS.replace("{t: f64, Q: f64}", "{t: i64, chi4: f64}");
    let e = err(dir.path(), &params);
    assert!(e.contains("table 'q' is not the declared one"), "{e}");
    assert!(e.contains("column 't' is Float64 (declared I64)"), "{e}");
    assert!(
        e.contains("column 'chi4' missing") && e.contains("column 'Q' not declared"),
        "{e}"
    );
    std::fs::write(
        dir.path().join("scripts/s.sh"),
        "echo text > \"$REPRO_OUT/q.parquet\"\n",
    )
    .unwrap();
    let e = err(dir.path(), PARAMS);
    assert!(
        e.contains("table 'q' is not a readable Parquet file"),
        "{e}"
    );
}

#[test]
fn a_write_under_the_project_root_fails_the_stage() {
    let dir = root("");
    let body =
        at_root(dir.path(), COPY) + &at_root(dir.path(), "echo 1 > \"$OLDPWD/data/new.csv\"\n");
    std::fs::write(dir.path().join("scripts/s.sh"), body).unwrap();
    let e = err(dir.path(), PARAMS);
    assert!(
        e.contains("wrote outside its output directory") && e.contains("data/new.csv"),
        "{e}"
    );
}

#[test]
fn a_script_not_found_is_named_with_the_root() {
    let dir = root("true\n");
    let e = err(
        dir.path(),
        &PARAMS.replace("scripts/s.sh", "scripts/missing.sh"),
    );
    assert!(
        e.contains("scripts/missing.sh not found") && e.contains("relative to the project root"),
        "{e}"
    );
    let e = format!(
        "{:#}",
        StageKind::parse(&Script, &yaml(&PARAMS.replace("scripts/s.sh", "../s.sh"))).unwrap_err()
    );
    assert!(
        e.contains("'../s.sh' must be a path relative to the project root"),
        "{e}"
    );
    let e = err(
        dir.path(),
        &PARAMS.replace("interpreter: sh", "interpreter: no-such-interpreter"),
    );
    assert!(
        e.contains("cannot start the interpreter 'no-such-interpreter'"),
        "{e}"
    );
}

#[test]
fn a_script_past_its_timeout_is_killed() {
    let dir = root("sleep 30\n");
    let t0 = std::time::Instant::now();
    let e = err(dir.path(), &format!("{PARAMS}timeout_s: 0.3\n"));
    assert!(e.contains("timed out after 0.3 s"), "{e}");
    // Killed, not waited for (a generous bound: no timing in pass/fail otherwise).
    assert!(t0.elapsed().as_secs() < 25);
}

#[test]
fn parameters_are_checked_before_anything_runs() {
    for (edit, words) in [
        (
            PARAMS.replace("tables: [{name: q, columns: {t: f64, Q: f64}}]\n", ""),
            "at least one output",
        ),
        (
            PARAMS.replace("{t: f64, Q: f64}", "{t: float}"),
            "unknown variant `float`",
        ),
        (
            format!("{PARAMS}images: [q.gif]\n"),
            "one of [\"png\", \"svg\", \"pdf\"]",
        ),
        (PARAMS.replace("name: q", "name: ../q"), "plain file stem"),
        (format!("{PARAMS}timeout_s: 0\n"), "`timeout_s` = 0"),
        (format!("{PARAMS}comand: x\n"), "unknown field `comand`"),
    ] {
        let e = format!("{:#}", StageKind::parse(&Script, &yaml(&edit)).unwrap_err());
        assert!(e.contains(words), "{edit}: {e}");
    }
}
