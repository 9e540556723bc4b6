//! The pipeline framework end to end, on the toy stage kinds and the fixture specs
//! in tests/fixtures/pipeline/ (copied to a temporary root per test).

use std::path::{Path, PathBuf};
use std::process::Command;

use repro::pipeline::{self, Registry, RunOptions, State, Workspace, toy};

fn fixture() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pipeline");
    for sub in ["experiments", "pipelines"] {
        std::fs::create_dir_all(dir.path().join(sub)).unwrap();
        for e in std::fs::read_dir(src.join(sub)).unwrap().flatten() {
            std::fs::copy(e.path(), dir.path().join(sub).join(e.file_name())).unwrap();
        }
    }
    dir
}

/// The library's kinds and the toy kinds.
fn reg() -> Registry {
    let mut r = repro::stages::registry();
    toy::register(&mut r);
    r
}

fn opts(jobs: usize) -> RunOptions {
    RunOptions {
        jobs,
        ..RunOptions::default()
    }
}

fn ids(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// Run figures at the ci profile; return the sorted labels executed.
fn run_with(root: &Path, r: &Registry, figs: &[&str], o: &RunOptions) -> Vec<String> {
    let run = pipeline::run_figures(&Workspace::new(root), r, &ids(figs), "ci", o).unwrap();
    run.check().unwrap();
    run.report.executed(&run.graph)
}

fn run(root: &Path, figs: &[&str]) -> Vec<String> {
    run_with(root, &reg(), figs, &opts(2))
}

/// Replace `from` by `to` in a spec file (the text must occur).
fn edit(root: &Path, rel: &str, from: &str, to: &str) {
    let p = root.join(rel);
    let s = std::fs::read_to_string(&p).unwrap();
    assert!(s.contains(from), "{rel} does not contain {from:?}");
    std::fs::write(&p, s.replacen(from, to, 1)).unwrap();
}

fn sorted(v: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = v.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

/// Every file of `dir` with its bytes, sorted by name (provenance.json excluded:
/// it records timings).
fn published(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .filter(|(n, _)| n != "provenance.json")
        .collect();
    v.sort();
    v
}

#[test]
fn second_identical_run_executes_nothing_and_shared_stages_run_once() {
    let d = fixture();
    let first = run(d.path(), &[]);
    // 4 simulations (2 phi x 2 replicas) shared by both figures; figtoy's a = 1.0
    // analyses are identical to figtoy2's and merged: 4 + 8 + 4 (table, fit,
    // compare, figure) + 2 (per_phi tables) + 1 (fit) = 19 stages.
    assert_eq!(first.len(), 19, "{first:#?}");
    assert_eq!(
        first.iter().filter(|l| l.starts_with("toy_sweep[")).count(),
        4
    );
    assert!(run(d.path(), &[]).is_empty());
    let (_, st) =
        pipeline::figure_status(&Workspace::new(d.path()), &reg(), &[], "ci", &[]).unwrap();
    assert!(st.iter().all(|(_, s)| matches!(s, State::Cached { .. })));
    let prov: serde_json::Value = serde_json::from_slice(
        &std::fs::read(d.path().join("results/figtoy/provenance.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(prov["profile"], "ci");
    assert_eq!(prov["repro_version"], env!("CARGO_PKG_VERSION"));
    let stages = prov["stages"].as_array().unwrap();
    assert_eq!(stages.len(), 16);
    let sim = stages.iter().find(|s| s["kind"] == "toy_simulate").unwrap();
    assert_eq!(sim["params"]["seed"], sim["seed"]);
    assert_eq!(sim["key"].as_str().unwrap().len(), 64);
    assert_eq!(
        sim["code_fingerprint"].as_str().unwrap(),
        reg().fingerprint("toy_simulate")
    );
    // The code it is keyed on: its own file and what that imports, but not the
    // harness that runs it (the stage trait, the registry); the compiler.
    let modules: Vec<&str> = sim["modules"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_str().unwrap())
        .collect();
    assert!(
        modules.contains(&"pipeline/toy") && !modules.contains(&"pipeline/stage"),
        "{modules:?}"
    );
    assert!(
        prov["rustc"].as_str().unwrap().starts_with("rustc "),
        "{}",
        prov["rustc"]
    );
    assert!(sim["wall_s"].as_f64().unwrap() > 0.0 && sim["executed_in_this_run"] == false);
    for f in [
        "compare.parquet",
        "overlap_table.parquet",
        "fit.parquet",
        "figure.svg",
        "provenance.json",
    ] {
        assert!(d.path().join("results/figtoy").join(f).is_file(), "{f}");
    }
}

#[test]
fn changing_one_grid_point_reruns_exactly_what_is_downstream_of_it() {
    let d = fixture();
    run(d.path(), &["figtoy"]);
    edit(
        d.path(),
        "experiments/toy_sweep.yaml",
        "phi: [0.70, 0.75]",
        "phi: [0.70, 0.76]",
    );
    let (g, st) = pipeline::figure_status(
        &Workspace::new(d.path()),
        &reg(),
        &ids(&["figtoy"]),
        "ci",
        &[],
    )
    .unwrap();
    let stale: Vec<&str> = st
        .iter()
        .filter(|(_, s)| matches!(s, State::Stale { .. }))
        .map(|(i, _)| g.nodes[*i].label())
        .collect();
    assert_eq!(stale.len(), 10, "{stale:?}");
    let expected = sorted(&[
        "toy_sweep[phi=0.76,replica=0]",
        "toy_sweep[phi=0.76,replica=1]",
        "figtoy/overlap[a=0.5,phi=0.76,replica=0]",
        "figtoy/overlap[a=1.0,phi=0.76,replica=0]",
        "figtoy/overlap[a=0.5,phi=0.76,replica=1]",
        "figtoy/overlap[a=1.0,phi=0.76,replica=1]",
        "figtoy/overlap_table",
        "figtoy/fit",
        "figtoy/compare",
        "figtoy/figure",
    ]);
    assert_eq!(run(d.path(), &["figtoy"]), expected);
}

#[test]
fn changing_an_analysis_parameter_reruns_no_simulation_and_why_names_it() {
    let d = fixture();
    run(d.path(), &["figtoy2"]);
    edit(d.path(), "pipelines/figtoy2.yaml", "a: 1.0", "a: 1.5");
    let (g, st) = pipeline::figure_status(
        &Workspace::new(d.path()),
        &reg(),
        &ids(&["figtoy2"]),
        "ci",
        &[],
    )
    .unwrap();
    let why: Vec<String> = st
        .iter()
        .filter(|(i, _)| g.nodes[*i].kind == "toy_analyse")
        .flat_map(|(_, s)| match s {
            State::Stale { reasons } => reasons.clone(),
            State::Cached { .. } => vec!["cached".into()],
            State::Damaged { .. } => vec!["damaged".into()],
        })
        .collect();
    assert_eq!(why, vec!["parameter a: 1.0 -> 1.5"; 4]);
    let ex = run(d.path(), &["figtoy2"]);
    assert!(!ex.iter().any(|l| l.starts_with("toy_sweep")), "{ex:?}");
    assert_eq!(
        ex.iter()
            .filter(|l| l.starts_with("figtoy2/overlap["))
            .count(),
        4
    );
}

#[test]
fn early_cutoff_stops_reruns_when_outputs_are_byte_identical() {
    let d = fixture();
    run(d.path(), &["figtoy2"]);
    // n_sub = 1000 keeps all 200 values: new parameters, identical output bytes.
    edit(
        d.path(),
        "pipelines/figtoy2.yaml",
        "a: 1.0",
        "a: 1.0\n      n_sub: 1000",
    );
    let ex = run(d.path(), &["figtoy2"]);
    assert_eq!(ex.len(), 4, "only the 4 analyses rerun: {ex:?}");
    assert!(ex.iter().all(|l| l.starts_with("figtoy2/overlap[")));
    // Forcing the simulations reproduces them bit for bit: nothing downstream reruns.
    let forced = RunOptions {
        force: vec!["toy_simulate".into()],
        ..opts(2)
    };
    let ex = run_with(d.path(), &reg(), &["figtoy2"], &forced);
    assert_eq!(ex.len(), 4);
    assert!(ex.iter().all(|l| l.starts_with("toy_sweep[")), "{ex:?}");
}

/// A kind that counts how often the planner parses its parameters and how
/// often it runs, around `toy_analyse`.
struct Counting {
    inner: toy::ToyAnalyse,
    parses: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    runs: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl repro::pipeline::StageKind for Counting {
    type Params = <toy::ToyAnalyse as repro::pipeline::StageKind>::Params;
    fn name(&self) -> &str {
        "toy_analyse"
    }
    fn modules(&self) -> &[&str] {
        repro::pipeline::StageKind::modules(&self.inner)
    }
    fn parse(&self, params: &serde_json::Value) -> anyhow::Result<Self::Params> {
        self.parses
            .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        repro::pipeline::StageKind::parse(&self.inner, params)
    }
    fn run(
        &self,
        ctx: &repro::pipeline::StageCtx,
        p: &Self::Params,
        inputs: &[repro::pipeline::Artifact],
    ) -> anyhow::Result<repro::pipeline::Output> {
        self.runs.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        repro::pipeline::StageKind::run(&self.inner, ctx, p, inputs)
    }
}

#[test]
fn each_stage_s_parameters_are_parsed_once_and_the_typed_value_reaches_its_run() {
    use std::sync::atomic::Ordering::SeqCst;
    let d = fixture();
    let (parses, runs) = (Default::default(), Default::default());
    let mut r = reg();
    r.register(Counting {
        inner: toy::ToyAnalyse,
        parses: std::sync::Arc::clone(&parses),
        runs: std::sync::Arc::clone(&runs),
    });
    // figtoy's analysis: 2 phi x 2 replicas x 2 cutoffs = 8 stages, with two
    // distinct parameter sets (a = 0.5 and a = 1.0).
    let ex = run_with(d.path(), &r, &["figtoy"], &opts(2));
    let analyses = ex
        .iter()
        .filter(|l| l.starts_with("figtoy/overlap["))
        .count();
    assert_eq!(analyses, 8, "{ex:?}");
    assert_eq!(runs.load(SeqCst), 8);
    assert_eq!(
        parses.load(SeqCst),
        2,
        "one parse per parameter set, none at run time"
    );
}

#[test]
fn a_table_takes_a_setting_from_its_runs_and_reruns_when_it_changes() {
    let d = fixture();
    edit(
        d.path(),
        "pipelines/figtoy.yaml",
        "    gather: [overlap]\n",
        "    gather: [overlap]\n    params: {from_runs: [eps]}\n",
    );
    let eps_column = |root: &Path| -> Vec<f64> {
        let bytes = std::fs::read(root.join("results/figtoy/overlap_table.parquet")).unwrap();
        let (batches, _) = repro::table::read_parquet_bytes(bytes).unwrap();
        batches
            .iter()
            .flat_map(|b| {
                b.column_by_name("eps")
                    .expect("an eps column from the runs")
                    .as_any()
                    .downcast_ref::<arrow_array::Float64Array>()
                    .unwrap()
                    .values()
                    .to_vec()
            })
            .collect()
    };
    run(d.path(), &["figtoy"]);
    let eps = eps_column(d.path());
    assert!(!eps.is_empty() && eps.iter().all(|&e| e == 0.9), "{eps:?}");
    // toy_simulate's numbers do not depend on eps: the simulations rerun to the
    // same bytes and the analyses are cut off, but the table reads eps from
    // the runs, so its key moves and it reruns with the new value.
    edit(
        d.path(),
        "experiments/toy_sweep.yaml",
        "eps: 0.9",
        "eps: 0.8",
    );
    let ex = run(d.path(), &["figtoy"]);
    assert!(
        !ex.iter().any(|l| l.starts_with("figtoy/overlap[")),
        "{ex:?}"
    );
    assert!(ex.iter().any(|l| l == "figtoy/overlap_table"), "{ex:?}");
    let eps = eps_column(d.path());
    assert!(eps.iter().all(|&e| e == 0.8), "{eps:?}");
}

#[test]
fn a_code_fingerprint_change_invalidates_that_kind_and_waits_its_dependents() {
    let d = fixture();
    run(d.path(), &["figtoy"]);
    let mut r = reg();
    r.set_fingerprint("toy_fit", "edited source of toy_fit")
        .unwrap();
    let (g, st) =
        pipeline::figure_status(&Workspace::new(d.path()), &r, &ids(&["figtoy"]), "ci", &[])
            .unwrap();
    for (i, s) in &st {
        let n = &g.nodes[*i];
        match (n.kind.as_str(), s) {
            ("toy_fit", State::Stale { reasons }) => {
                assert_eq!(reasons.len(), 1, "{reasons:?}");
                assert!(
                    reasons[0]
                        .starts_with("code of stage kind 'toy_fit' changed (pipeline/toy and the ")
                        && reasons[0].contains(" modules and "),
                    "{reasons:?}"
                )
            }
            ("compare", State::Stale { reasons }) => assert!(
                reasons[0].contains("input figtoy/fit reruns first"),
                "{reasons:?}"
            ),
            (_, State::Cached { .. }) => {}
            (k, s) => panic!("{k}: unexpected {s:?}"),
        }
    }
    // The fit reruns; it gives the same bytes, so compare is cut off.
    assert_eq!(
        run_with(d.path(), &r, &["figtoy"], &opts(2)),
        vec!["figtoy/fit"]
    );
    assert!(run_with(d.path(), &r, &["figtoy"], &opts(2)).is_empty());
}

#[test]
fn jobs_1_and_jobs_2_give_byte_identical_outputs() {
    let (a, b) = (fixture(), fixture());
    run_with(a.path(), &reg(), &[], &opts(1));
    run_with(b.path(), &reg(), &[], &opts(2));
    for fig in ["figtoy", "figtoy2"] {
        let (pa, pb) = (
            published(&a.path().join("results").join(fig)),
            published(&b.path().join("results").join(fig)),
        );
        assert!(!pa.is_empty());
        assert_eq!(pa, pb, "{fig}");
    }
}

#[test]
fn a_failing_stage_stops_its_dependents_only_and_caches_nothing() {
    let d = fixture();
    std::fs::write(
        d.path().join("pipelines/figfail.yaml"),
        "description: fails on purpose\nstages:\n  - name: broken\n    kind: toy_fail\n    gather: [toy_sweep]\n    params: {fail: true}\n  - name: after\n    kind: toy_fail\n    gather: [broken]\n    params: {fail: false}\n",
    )
    .unwrap();
    let w = Workspace::new(d.path());
    let go = || {
        pipeline::run_figures(&w, &reg(), &ids(&["figfail", "figtoy2"]), "ci", &opts(2)).unwrap()
    };
    let r = go();
    let report = r.report.failure_report(&r.graph);
    assert!(
        report.contains("figfail/broken") && report.contains("toy_fail was asked to fail"),
        "{report}"
    );
    assert!(
        report.contains(r#"parameters: {"fail":true}"#) && report.contains("log: read 4 inputs"),
        "{report}"
    );
    assert!(
        report.contains("figfail/after not run: its input figfail/broken failed"),
        "{report}"
    );
    assert!(r.check().is_err());
    assert!(
        d.path().join("results/figtoy2/fit.parquet").is_file(),
        "unrelated figure finished"
    );
    assert!(!d.path().join("results/figfail").exists());
    // Nothing of the failed stage was cached: a rerun tries it again, and only it.
    let again = go();
    assert!(again.report.executed(&again.graph).is_empty());
    assert_eq!(
        again.report.not_done(&again.graph),
        vec!["figfail/after", "figfail/broken"]
    );
}

#[test]
fn gc_frees_only_what_no_spec_reaches() {
    let d = fixture();
    run(d.path(), &[]);
    edit(d.path(), "pipelines/figtoy2.yaml", "a: 1.0", "a: 2.0");
    run(d.path(), &[]);
    let w = Workspace::new(d.path());
    let dry = pipeline::gc(&w, &reg(), true).unwrap();
    // The old per_phi tables and figtoy2 fit are unreachable (the a = 1.0 analyses
    // are still reached through figtoy).
    assert_eq!(dry.entries, 3, "{dry:?}");
    assert_eq!(pipeline::gc(&w, &reg(), false).unwrap(), dry);
    assert_eq!(pipeline::gc(&w, &reg(), true).unwrap().entries, 0);
    assert!(
        run(d.path(), &[]).is_empty(),
        "gc freed something a spec reaches"
    );
}

#[test]
fn a_store_of_another_version_is_refused() {
    let d = fixture();
    let store = d.path().join(".repro/store");
    std::fs::create_dir_all(&store).unwrap();
    std::fs::write(store.join("VERSION"), "repro-store-v0\n").unwrap();
    let e = pipeline::run_figures(&Workspace::new(d.path()), &reg(), &[], "ci", &opts(1))
        .err()
        .unwrap();
    let m = format!("{e:#}");
    assert!(
        m.contains("repro-store-v0") && m.contains("repro-store-v1") && m.contains("remove"),
        "{m}"
    );
}

/// Plan the fixture after writing `text` to `rel`; return the error message.
fn plan_error(rel: &str, text: &str, figure: &str) -> String {
    let d = fixture();
    std::fs::write(d.path().join(rel), text).unwrap();
    let e = Workspace::new(d.path())
        .plan(&reg(), &ids(&[figure]), "ci")
        .expect_err("planning must fail");
    format!("{e:#}")
}

fn assert_located(msg: &str, file: &str, line: u64, words: &[&str]) {
    assert!(
        msg.contains(&format!("{file}:{line}:")),
        "expected {file}:{line}: in\n{msg}"
    );
    for w in words {
        assert!(msg.contains(w), "expected {w:?} in\n{msg}");
    }
}

const GOOD_EXP: &str = "description: d\nkind: toy_simulate\nseed: 1\nprofiles:\n  ci:\n    grid:\n      phi: [0.7]\n    replicas: 1\n    params: {n: 10}\n";

#[test]
fn each_class_of_bad_spec_has_its_own_located_error() {
    let e = plan_error(
        "experiments/toy_sweep.yaml",
        "description: d\nkind: [toy_simulate\n",
        "figtoy",
    );
    assert_located(&e, "toy_sweep.yaml", 2, &[]);
    let e = plan_error(
        "experiments/toy_sweep.yaml",
        &GOOD_EXP.replace("seed: 1\n", "seed: 1\nseeds: 2\n"),
        "figtoy",
    );
    assert_located(&e, "toy_sweep.yaml", 4, &["unknown field", "seeds", "seed"]);
    let e = plan_error(
        "experiments/toy_sweep.yaml",
        &GOOD_EXP.replace("replicas: 1", "replicas: many"),
        "figtoy",
    );
    assert_located(&e, "toy_sweep.yaml", 8, &["replicas"]);
    let e = plan_error(
        "experiments/toy_sweep.yaml",
        &GOOD_EXP.replace("[0.7]", "[]"),
        "figtoy",
    );
    assert_located(&e, "toy_sweep.yaml", 7, &["grid key 'phi'", "empty"]);
    let e = plan_error(
        "experiments/toy_sweep.yaml",
        &GOOD_EXP.replace("n: 10", "n: 10, colour: red"),
        "figtoy",
    );
    assert_located(
        &e,
        "toy_sweep.yaml",
        9,
        &["kind toy_simulate", "unknown field `colour`"],
    );
    let e = plan_error(
        "experiments/toy_sweep.yaml",
        &GOOD_EXP.replace("  ci:", "  tiny:"),
        "figtoy",
    );
    assert_located(
        &e,
        "toy_sweep.yaml",
        6,
        &["unknown profile 'tiny'", "small"],
    );
    let e = plan_error(
        "pipelines/x.yaml",
        "description: d\nstages:\n  - name: s\n    kind: table\n    gather: [toy_sweep]\n",
        "fig99",
    );
    assert!(
        e.contains("unknown figure id 'fig99'") && e.contains("figtoy, figtoy2"),
        "{e}"
    );
    let pipe = |body: &str| format!("description: d\nstages:\n{body}");
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &format!(
            "description: d\nerror_coverage:\n  tiny: {{x: two replicas}}\n{}",
            pipe("  - name: s\n    kind: table\n    gather: [toy_sweep]\n")
                .trim_start_matches("description: d\n")
        ),
        "figtoy",
    );
    assert_located(
        &e,
        "figtoy.yaml",
        3,
        &["`error_coverage` names the unknown profile 'tiny'", "small"],
    );
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &pipe("  - name: s\n    kind: toy_analyse\n    map: toy_sweeep\n    params: {a: 1}\n"),
        "figtoy",
    );
    assert_located(
        &e,
        "figtoy.yaml",
        3,
        &["reads 'toy_sweeep'", "known: toy_sweep"],
    );
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &pipe(
            "  - name: a\n    kind: table\n    gather: [b]\n  - name: b\n    kind: table\n    gather: [a]\n",
        ),
        "figtoy",
    );
    assert_located(&e, "figtoy.yaml", 3, &["cycle", "a -> b -> a"]);
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &pipe("  - name: s\n    kind: toy_analyse\n    map: toy_sweep\n    params: {a: -1}\n"),
        "figtoy",
    );
    assert_located(&e, "figtoy.yaml", 6, &["stage 's'", "a must be > 0"]);
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &pipe("  - name: s\n    kind: chi5\n    map: toy_sweep\n"),
        "figtoy",
    );
    assert_located(
        &e,
        "figtoy.yaml",
        3,
        &["unknown stage kind 'chi5'", "toy_analyse"],
    );
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &pipe("  - name: s\n    kind: toy_analyse\n    map: toy_sweep\n    sweep: {a: []}\n"),
        "figtoy",
    );
    assert_located(&e, "figtoy.yaml", 3, &["sweep over 'a'", "empty"]);
    let e = plan_error(
        "pipelines/figtoy.yaml",
        &pipe("  - name: s\n    kind: table\n"),
        "figtoy",
    );
    assert_located(&e, "figtoy.yaml", 3, &["reads nothing", "map", "gather"]);
}

// ---- child processes: kill -9 and concurrent runs -------------------------------

/// The command line with the toy kinds the fixtures use.
fn toy_cli() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_repro"));
    c.env(repro::cli::TOY_KINDS, "1");
    c
}

fn repro(root: &Path) -> Command {
    let mut c = toy_cli();
    c.arg("figure")
        .arg("--all")
        .arg("--profile")
        .arg("ci")
        .arg("--root")
        .arg(root);
    c
}

fn all_objects_intact(root: &Path) -> usize {
    let mut n = 0;
    let mut stack = vec![root.join(".repro/store/objects")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p: PathBuf = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if !e.file_name().to_string_lossy().starts_with(".tmp") {
                let name = e.file_name().to_string_lossy().into_owned();
                assert_eq!(
                    blake3::hash(&std::fs::read(&p).unwrap()).to_hex().as_str(),
                    name,
                    "truncated object"
                );
                n += 1;
            }
        }
    }
    n
}

#[test]
fn kill_9_mid_run_leaves_a_store_the_next_run_completes() {
    let d = fixture();
    // Slow simulations so the kill lands mid-stage.
    edit(
        d.path(),
        "experiments/toy_sweep.yaml",
        "n: 200",
        "n: 200\n      sleep_ms: 250",
    );
    let mut child = repro(d.path()).arg("--jobs").arg("1").spawn().unwrap();
    let entries = d.path().join(".repro/store/entries");
    let t0 = std::time::Instant::now();
    // Wait for the first finished stage, then kill while the next one runs.
    while std::fs::read_dir(&entries).map(|r| r.count()).unwrap_or(0) == 0 {
        assert!(t0.elapsed().as_secs() < 30, "no stage finished");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    std::thread::sleep(std::time::Duration::from_millis(100));
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(
        !d.path().join("results/figtoy").exists(),
        "killed before the end"
    );
    all_objects_intact(d.path());
    let out = repro(d.path()).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("19 executed"),
        "the killed run's finished stages were reused: {stderr}"
    );
    assert!(all_objects_intact(d.path()) > 0);
    let clean = fixture();
    edit(
        clean.path(),
        "experiments/toy_sweep.yaml",
        "n: 200",
        "n: 200\n      sleep_ms: 250",
    );
    assert!(repro(clean.path()).output().unwrap().status.success());
    for fig in ["figtoy", "figtoy2"] {
        assert_eq!(
            published(&d.path().join("results").join(fig)),
            published(&clean.path().join("results").join(fig))
        );
    }
}

#[test]
fn two_concurrent_runs_on_one_store_both_finish_with_identical_results() {
    let d = fixture();
    edit(
        d.path(),
        "experiments/toy_sweep.yaml",
        "n: 200",
        "n: 200\n      sleep_ms: 60",
    );
    let a = repro(d.path())
        .arg("--jobs")
        .arg("2")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let b = repro(d.path())
        .arg("--jobs")
        .arg("2")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let (oa, ob) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    let executed = |o: &std::process::Output| -> usize {
        let s = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{s}");
        let line = s
            .lines()
            .find(|l| l.contains(" executed, "))
            .unwrap_or_else(|| panic!("{s}"))
            .to_string();
        line.split(": ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    // The stage locks make each stage run in exactly one of the two processes.
    assert_eq!(executed(&oa) + executed(&ob), 19);
    let clean = fixture();
    edit(
        clean.path(),
        "experiments/toy_sweep.yaml",
        "n: 200",
        "n: 200\n      sleep_ms: 60",
    );
    run(clean.path(), &[]);
    for fig in ["figtoy", "figtoy2"] {
        assert_eq!(
            published(&d.path().join("results").join(fig)),
            published(&clean.path().join("results").join(fig))
        );
    }
    all_objects_intact(d.path());
}

#[test]
fn cli_list_why_and_dry_run_explain_the_cache() {
    let d = fixture();
    let cli = |args: &[&str]| {
        let o = toy_cli()
            .args(args)
            .arg("--root")
            .arg(d.path())
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let list = cli(&["list", "--profile", "ci"]);
    assert!(
        list.contains("figtoy2")
            && list.contains("replica-averaged")
            && list.contains("11/11 stages to run"),
        "{list}"
    );
    run(d.path(), &[]);
    assert!(
        cli(&["list", "--profile", "ci"])
            .matches("[ci: cached]")
            .count()
            == 2
    );
    edit(d.path(), "experiments/toy_sweep.yaml", "n: 200", "n: 300");
    let why = cli(&["why", "figtoy2", "--profile", "ci"]);
    assert!(
        why.contains("stale   toy_sweep[phi=0.7,replica=0]")
            && why.contains("parameter n: 200 -> 300"),
        "{why}"
    );
    let dry = cli(&["figure", "figtoy2", "--profile", "ci", "--dry-run"]);
    assert!(dry.contains("11 stage(s): 0 cached, 11 stale"), "{dry}");
    assert!(
        run(d.path(), &["figtoy2"]).len() == 11,
        "dry run ran nothing"
    );
}

/// An experiment with the run-length rule, lags up to 3 tau_guess.
const SHORT_RUNS: &str = "description: short runs\nkind: simulate\nseed: 3\nparams:\n  eps: 0.9\n  tau_guess: {A: 0.76, B: 0.148, phi0: 0.83}\n  relax_tau: 5\n  origins: 2\n  spacing_tau: 2\n  lag_min: 0.05\n  lag_max_tau: 3\n  lags_per_decade: 4\nprofiles:\n  ci:\n    grid:\n      phi: [0.6, 0.7]\n    replicas: 1\n    params: {n: 100}\n";

const AT_FIG: &str = "description: Q at multiples of tau_alpha\nstages:\n  - name: tau\n    kind: tau_alpha\n    gather: [short]\n    by: [phi]\n  - name: q_at\n    kind: overlap\n    gather: [short, tau]\n    by: [phi]\n    params:\n      time_unit: {from: tau}\n      at: [1, 8.5]\n";

#[test]
fn a_time_past_the_run_length_rule_is_refused_at_plan_time() {
    let d = fixture();
    std::fs::write(d.path().join("experiments/short.yaml"), SHORT_RUNS).unwrap();
    std::fs::write(d.path().join("pipelines/atfig.yaml"), AT_FIG).unwrap();
    let e = Workspace::new(d.path())
        .plan(&reg(), &ids(&["atfig"]), "ci")
        .expect_err("8.5 tau_alpha lies past lag_max_tau = 3");
    let e = format!("{e:#}");
    // Located at `at` in the pipeline, naming the experiment's file and the key to raise.
    assert_located(
        &e,
        "atfig.yaml",
        13,
        &[
            "8.5 tau_alpha",
            "'short'",
            "lag_max_tau = 3",
            "experiments/short.yaml",
            "raise `lag_max_tau`",
        ],
    );
    // `--dry-run` plans, so it says the same before anything runs.
    let o = toy_cli()
        .args(["figure", "atfig", "--profile", "ci", "--dry-run", "--root"])
        .arg(d.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("raise `lag_max_tau`"),
        "{err}"
    );
    // Within reach, the plan goes through.
    edit(
        d.path(),
        "experiments/short.yaml",
        "lag_max_tau: 3",
        "lag_max_tau: 10",
    );
    Workspace::new(d.path())
        .plan(&reg(), &ids(&["atfig"]), "ci")
        .unwrap();
}

/// docs/spec.md lists every registered kind, every observable with each parameter
/// its typed `Params` accepts, every fit form and every `fit` parameter.
#[test]
fn the_spec_documents_every_kind_parameter_and_form() {
    use repro::pipeline::registry::param_keys;
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/spec.md"))
        .unwrap();
    let reg = repro::stages::registry();
    for k in reg.names() {
        assert!(
            doc.contains(&format!("`{k}`")),
            "docs/spec.md never names kind `{k}`"
        );
    }
    for o in repro::analysis::observables::OBSERVABLES {
        let keys = o.param_keys();
        assert!(!keys.is_empty(), "no parameters read for {}", o.name);
        let name = format!("`{}`", o.name);
        let row = doc
            .lines()
            .find(|l| l.starts_with("| ") && l.split('|').nth(1).is_some_and(|c| c.contains(&name)))
            .unwrap_or_else(|| panic!("docs/spec.md has no parameter row for {name}"));
        for k in keys {
            assert!(
                row.contains(&format!("`{k}`")),
                "{name}: `{k}` missing from {row}"
            );
        }
    }
    for f in repro::fit::catalogue::FORMS {
        assert!(
            doc.contains(&format!("| `{}` |", f.name)),
            "form {}",
            f.name
        );
    }
    let fit = doc
        .split("### `fit`")
        .nth(1)
        .unwrap()
        .split("\n### ")
        .next()
        .unwrap();
    let keys = param_keys(|v| reg.get("fit").unwrap().validate(v));
    assert!(keys.contains(&"ranges".to_string()), "{keys:?}");
    for k in keys {
        assert!(
            fit.contains(&format!("`{k}")),
            "fit parameter `{k}` undocumented"
        );
    }
}

// ---- store integrity, side records, publishing, params errors, progress ---------

fn provenance(root: &Path, fig: &str) -> serde_json::Value {
    let p = root.join("results").join(fig).join("provenance.json");
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

fn object(root: &Path, hash: &str) -> PathBuf {
    root.join(".repro/store/objects")
        .join(&hash[..2])
        .join(hash)
}

/// The store object behind published file `name` of figure `fig`.
fn published_object(root: &Path, fig: &str, name: &str) -> PathBuf {
    object(
        root,
        provenance(root, fig)["published"][name].as_str().unwrap(),
    )
}

fn quarantined(root: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(root.join(".repro/store/quarantine"))
        .map(|rd| rd.flatten().map(|e| e.path()).collect())
        .unwrap_or_default()
}

fn labels_in_state(root: &Path, fig: &str, f: fn(&State) -> bool) -> Vec<String> {
    let (g, st) =
        pipeline::figure_status(&Workspace::new(root), &reg(), &ids(&[fig]), "ci", &[]).unwrap();
    let mut v: Vec<String> = st
        .iter()
        .filter(|(_, s)| f(s))
        .map(|(i, _)| g.nodes[*i].label().to_string())
        .collect();
    v.sort();
    v
}

#[test]
fn a_damaged_artifact_is_quarantined_recomputed_and_never_published() {
    let d = fixture();
    run(d.path(), &["figtoy"]);
    let table = d.path().join("results/figtoy/overlap_table.parquet");
    let good = std::fs::read(&table).unwrap();
    // One flipped byte in the stored table.
    let obj = published_object(d.path(), "figtoy", "overlap_table.parquet");
    let mut bytes = std::fs::read(&obj).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(&obj, &bytes).unwrap();
    assert_eq!(
        labels_in_state(d.path(), "figtoy", |s| matches!(s, State::Damaged { .. })),
        vec!["figtoy/overlap_table"]
    );
    let fr = pipeline::run_figures(
        &Workspace::new(d.path()),
        &reg(),
        &ids(&["figtoy"]),
        "ci",
        &opts(2),
    )
    .unwrap();
    fr.check().unwrap();
    // Recomputed (same bytes), so its dependents are cut off.
    assert_eq!(fr.report.executed(&fr.graph), vec!["figtoy/overlap_table"]);
    assert_eq!(fr.report.damaged.len(), 1);
    let msg = &fr.report.damaged[0];
    assert!(
        msg.contains(&obj.display().to_string()) && msg.contains("figtoy/overlap_table"),
        "{msg}"
    );
    assert_eq!(std::fs::read(&table).unwrap(), good);
    let q = quarantined(d.path());
    assert_eq!(q.len(), 1);
    assert_eq!(std::fs::read(&q[0]).unwrap(), bytes, "kept, not deleted");

    // A simulation truncated to 0 bytes: recomputed bit for bit, nothing else reruns.
    let prov = provenance(d.path(), "figtoy");
    let sim = prov["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["kind"] == "toy_simulate")
        .unwrap();
    std::fs::write(
        object(d.path(), sim["files"]["parquet"].as_str().unwrap()),
        b"",
    )
    .unwrap();
    assert_eq!(
        run_with(d.path(), &reg(), &["figtoy"], &opts(2)),
        vec![sim["label"].as_str().unwrap().to_string()]
    );
    assert!(run(d.path(), &["figtoy"]).is_empty());
    all_objects_intact(d.path());
}

#[test]
fn repro_verify_and_status_report_damage() {
    let d = fixture();
    run(d.path(), &["figtoy"]);
    let cli = |args: &[&str]| {
        toy_cli()
            .args(args)
            .arg("--root")
            .arg(d.path())
            .output()
            .unwrap()
    };
    let ok = cli(&["verify"]);
    assert!(ok.status.success());
    assert!(String::from_utf8_lossy(&ok.stdout).contains(": 0 damaged"));
    // Half an object gone.
    let obj = published_object(d.path(), "figtoy", "fit.parquet");
    let bytes = std::fs::read(&obj).unwrap();
    std::fs::write(&obj, &bytes[..bytes.len() / 2]).unwrap();
    let st = cli(&["status", "figtoy", "--profile", "ci"]);
    let out = String::from_utf8_lossy(&st.stdout);
    assert!(out.contains("damaged figtoy/fit"), "{out}");
    assert!(out.contains(", 1 damaged"), "{out}");
    let bad = cli(&["verify"]);
    let out = String::from_utf8_lossy(&bad.stdout);
    assert!(!bad.status.success(), "{out}");
    assert!(
        out.contains(&obj.display().to_string())
            && out.contains("figtoy/fit")
            && out.contains("moved to"),
        "{out}"
    );
    assert!(!obj.exists() && quarantined(d.path()).len() == 1);
    // Already quarantined: status still says damaged until a run recomputes it.
    let out =
        String::from_utf8_lossy(&cli(&["status", "figtoy", "--profile", "ci"]).stdout).into_owned();
    assert!(out.contains("damaged figtoy/fit"), "{out}");
    assert_eq!(run(d.path(), &["figtoy"]), vec!["figtoy/fit"]);
    assert!(cli(&["verify"]).status.success());
}

const SIM_EXP: &str = r#"
description: two tiny simulations
kind: simulate
seed: 7
params:
  eps: 0.9
  tau_guess: {A: 0.76, B: 0.148, phi0: 0.83}
  relax_tau: 5
  relax_min: 5
  origins: 2
  spacing_tau: 2
  lag_min: 0.05
  lag_max_tau: 8
  lags_per_decade: 4
profiles:
  ci:
    grid:
      phi: [0.6]
    replicas: 2
    params:
      n: 100
"#;

const SIM_PIPE: &str = r#"
description: tau_alpha of two tiny simulations
stages:
  - name: tau
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
  - name: tau_table
    kind: table
    gather: [tau]
"#;

#[test]
fn forcing_real_simulations_reruns_them_and_nothing_downstream() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("experiments")).unwrap();
    std::fs::create_dir_all(d.path().join("pipelines")).unwrap();
    std::fs::write(d.path().join("experiments/tiny.yaml"), SIM_EXP).unwrap();
    std::fs::write(d.path().join("pipelines/simfig.yaml"), SIM_PIPE).unwrap();
    let r = repro::stages::registry();
    assert_eq!(run_with(d.path(), &r, &["simfig"], &opts(2)).len(), 4);
    let forced = RunOptions {
        force: vec!["simulate".into()],
        ..opts(2)
    };
    // The timings differ between the two runs; the digests must not.
    assert_eq!(
        run_with(d.path(), &r, &["simfig"], &forced),
        vec!["tiny[phi=0.6,replica=0]", "tiny[phi=0.6,replica=1]"]
    );
    // The measurements live in the side record, kept with provenance.
    let prov = provenance(d.path(), "simfig");
    let sim = prov["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["kind"] == "simulate")
        .unwrap();
    assert!(sim["side"]["cpu_seconds"].as_f64().unwrap() > 0.0, "{sim}");
    assert!(sim["side"]["peak_rss_bytes"].as_u64().unwrap() > 0);
    let summary: serde_json::Value = serde_json::from_slice(
        &std::fs::read(object(d.path(), sim["files"]["json"].as_str().unwrap())).unwrap(),
    )
    .unwrap();
    assert!(summary.get("cpu_seconds").is_none() && summary.get("collisions").is_some());
}

#[test]
fn publishing_replaces_only_the_files_the_pipeline_owns() {
    let d = fixture();
    run(d.path(), &["figtoy"]);
    let dir = d.path().join("results/figtoy");
    std::fs::write(dir.join("notes.txt"), "my notes").unwrap();
    std::fs::write(dir.join("extra.svg"), "<svg/>").unwrap();
    assert!(run(d.path(), &["figtoy"]).is_empty());
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "my notes"
    );
    // The plot stage renamed: its old file goes, the new one comes, the user's stay.
    edit(
        d.path(),
        "pipelines/figtoy.yaml",
        "  - name: figure\n",
        "  - name: chart\n",
    );
    run(d.path(), &["figtoy"]);
    assert!(!dir.join("figure.svg").exists());
    assert!(dir.join("chart.svg").is_file());
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "my notes"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("extra.svg")).unwrap(),
        "<svg/>"
    );
    let mut owned: Vec<String> = provenance(d.path(), "figtoy")["published"]
        .as_object()
        .unwrap()
        .keys()
        .cloned()
        .collect();
    owned.sort();
    assert_eq!(
        owned,
        vec![
            "README.md",
            "chart.svg",
            "compare.parquet",
            "fit.parquet",
            "overlap_table.parquet"
        ]
    );
    // A pipeline without stages is an error naming its file.
    let e = plan_error(
        "pipelines/figtoy.yaml",
        "description: d\nstages: []\n",
        "figtoy",
    );
    assert_located(&e, "figtoy.yaml", 2, &["`stages` is empty"]);
}

#[test]
fn the_results_readme_says_what_every_published_table_is() {
    let d = fixture();
    run(d.path(), &["figtoy"]);
    let dir = d.path().join("results/figtoy");
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap();
    // Every published file has its section; the YAML's `describes:` names the
    // paper's figure; the kind says what made it; columns carry unit and meaning.
    for f in [
        "overlap_table.parquet",
        "compare.parquet",
        "fit.parquet",
        "figure.svg",
    ] {
        assert!(
            readme.contains(&format!("## `{f}`")),
            "{f} missing:\n{readme}"
        );
    }
    assert!(
        readme.contains("In the paper: toy paper, Fig. 1: the symbols."),
        "{readme}"
    );
    assert!(
        readme.contains("Stage `overlap_table` (kind `table`): concatenate"),
        "{readme}"
    );
    assert!(
        readme.contains("From `overlap` (kind `toy_analyse`)"),
        "{readme}"
    );
    assert!(
        readme.contains("| phi | Float64 | 1 | packing fraction (area fraction of the disks) |"),
        "{readme}"
    );
    // Counts and indices are integers in published tables.
    assert!(readme.contains("| replica | Int64 |"), "{readme}");
    // A stage's `columns:` gives a column's meaning in its table, the unit kept.
    assert!(
        readme.contains("| a | Float64 | r1 | the toy's sweep parameter |"),
        "{readme}"
    );
    // A compare table's reasons keep their references: the README says where
    // they are printed filled in.
    assert!(
        readme.contains("its `reason` is a template") && readme.contains("repro report --profile"),
        "{readme}"
    );
    let (b, _) = repro::table::read_parquet(&dir.join("overlap_table.parquet")).unwrap();
    let replica = b[0].column_by_name("replica").unwrap();
    assert_eq!(replica.data_type(), &arrow_schema::DataType::Int64);
    // The README is owned like the tables: listed in the manifest, rewritten only on change.
    assert!(provenance(d.path(), "figtoy")["published"]["README.md"].is_string());
}

#[test]
fn errors_inside_params_point_at_the_key_or_value_with_a_snippet() {
    let pipe = |params: &str| {
        plan_error(
            "pipelines/figtoy.yaml",
            &format!(
                "description: d\nstages:\n  - name: s\n    kind: toy_analyse\n    map: toy_sweep\n    params:\n{params}"
            ),
            "figtoy",
        )
    };
    let no_dump = |e: &str| assert!(!e.contains("{\"") && !e.contains("\"a\":"), "{e}");
    // Stage params: unknown key, wrong type, bad value.
    let e = pipe("      a: 1\n      y_er: 2\n");
    assert!(e.contains("figtoy.yaml:8:7:"), "{e}");
    assert!(
        e.contains("unknown field `y_er`") && e.contains("8 |       y_er: 2"),
        "{e}"
    );
    no_dump(&e);
    let e = pipe("      a: low\n");
    assert!(e.contains("figtoy.yaml:7:10:"), "{e}");
    assert!(
        e.contains("invalid type") && e.contains("7 |       a: low"),
        "{e}"
    );
    no_dump(&e);
    let e = pipe("      a: -1\n");
    assert!(e.contains("figtoy.yaml:7:10:"), "{e}");
    assert!(
        e.contains("a must be > 0") && e.contains("7 |       a: -1"),
        "{e}"
    );
    no_dump(&e);
    // A kind's check that names the key only in its message (`n`).
    let e = plan_error(
        "pipelines/figtoy.yaml",
        "description: d\nstages:\n  - name: s\n    kind: chi4_peaks\n    gather: [toy_sweep]\n    params:\n      n: []\n",
        "figtoy",
    );
    assert!(
        e.contains("figtoy.yaml:7:10:") && e.contains("no sub-box size"),
        "{e}"
    );
    // A sub-box as a fraction of the box must be one.
    let e = plan_error(
        "pipelines/figtoy.yaml",
        "description: d\nstages:\n  - name: s\n    kind: chi4_peaks\n    gather: [toy_sweep]\n    params:\n      fractions: [0.25, 1.5]\n",
        "figtoy",
    );
    assert!(
        e.contains("figtoy.yaml:7:") && e.contains("`fractions` holds 1.5"),
        "{e}"
    );
    // Experiment params: the same three classes.
    let exp = |from: &str, to: &str| {
        plan_error(
            "experiments/toy_sweep.yaml",
            &GOOD_EXP.replace(from, to),
            "figtoy",
        )
    };
    let e = exp("n: 10", "n: 10, colour: red");
    assert!(e.contains("toy_sweep.yaml:9:21:"), "{e}");
    assert!(
        e.contains("unknown field `colour`") && e.contains("9 |     params: {n: 10, colour: red}"),
        "{e}"
    );
    no_dump(&e);
    let e = exp("n: 10", "n: abc");
    assert!(e.contains("toy_sweep.yaml:9:17:"), "{e}");
    assert!(e.contains("invalid type"), "{e}");
    no_dump(&e);
    let e = exp("n: 10", "n: 0");
    assert!(e.contains("toy_sweep.yaml:9:17:"), "{e}");
    assert!(e.contains("n must be at least 1"), "{e}");
    no_dump(&e);
    // A common parameter (not overridden by the profile) is found in the common block.
    let e = exp("seed: 1\n", "seed: 1\nparams:\n  eps: high\n");
    assert!(
        e.contains("toy_sweep.yaml:5:8:") && e.contains("invalid type"),
        "{e}"
    );
}

#[test]
fn without_a_terminal_each_finished_stage_and_long_stage_prints_a_line() {
    let d = fixture();
    edit(
        d.path(),
        "experiments/toy_sweep.yaml",
        "n: 200",
        "n: 200\n      sleep_ms: 700",
    );
    let o = repro(d.path())
        .args(["--jobs", "2"])
        .env("REPRO_HEARTBEAT_S", "0.2")
        .output()
        .unwrap();
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    let finished = err.lines().filter(|l| l.contains("] executed ")).count();
    assert_eq!(finished, 19, "{err}");
    assert!(err.contains("[1/19] executed toy_sweep["), "{err}");
    assert!(
        err.lines()
            .any(|l| l.contains("running toy_sweep[") && l.contains("% (")),
        "{err}"
    );
    let log = std::fs::read_to_string(d.path().join(".repro/log/LAST-RUN.log")).unwrap();
    assert_eq!(
        log.lines().filter(|l| l.contains("] executed ")).count(),
        19
    );
    // A second run (all cached) has its own log; the first run's is kept whole
    // and LAST-RUN.log is the newest.
    assert!(repro(d.path()).output().unwrap().status.success());
    let logs: Vec<String> = std::fs::read_dir(d.path().join(".repro/log"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("run-"))
        .collect();
    assert_eq!(logs.len(), 2, "{logs:?}");
    let texts: Vec<String> = logs
        .iter()
        .map(|n| std::fs::read_to_string(d.path().join(".repro/log").join(n)).unwrap())
        .collect();
    assert!(
        texts.iter().any(|t| t.matches("] executed ").count() == 19),
        "{texts:?}"
    );
    let last = std::fs::read_to_string(d.path().join(".repro/log/LAST-RUN.log")).unwrap();
    assert!(
        last.contains("cached") && !last.contains("] executed "),
        "{last}"
    );
}

/// The example of `from: FIGURE/STAGE` in docs/spec.md, planned with the
/// repository's specs: the referring figure's stage is fig4's node itself.
#[test]
fn the_documented_reference_to_another_figure_s_stage_is_that_stage() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(repo.join("docs/spec.md")).unwrap();
    let example = doc
        .split("```yaml\n")
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("from: fig4/joint"))
        .expect("docs/spec.md shows a pipeline with `from: fig4/joint`");
    let d = repository_specs();
    std::fs::write(d.path().join("pipelines/figref.yaml"), example).unwrap();
    let g = Workspace::new(d.path())
        .plan(&reg(), &ids(&["fig4", "figref"]), "ci")
        .unwrap();
    let joint = |fig: &str| {
        let f = g.figures.iter().find(|f| f.id == fig).unwrap();
        f.publish.iter().find(|(s, _)| s == "joint").unwrap().1
    };
    assert_eq!(joint("fig4"), joint("figref"));
    let n = &g.nodes[joint("fig4")];
    assert_eq!(n.labels, ["fig4/joint", "figref/joint"]);
    // The referring figure needs fig4's joint fit and what it reads, nothing more.
    let mine = &g.figures.iter().find(|f| f.id == "figref").unwrap().nodes;
    assert!(mine.iter().all(|&i| g.nodes[i].kind != "plot"));

    // A reference to a stage fig4 does not have names the file, line and fig4's stages.
    std::fs::write(
        d.path().join("pipelines/figref.yaml"),
        example.replace("fig4/joint", "fig4/jiont"),
    )
    .unwrap();
    let e = Workspace::new(d.path())
        .plan(&reg(), &ids(&["figref"]), "ci")
        .expect_err("an unknown stage must be refused");
    assert_located(
        &format!("{e:#}"),
        "figref.yaml",
        3,
        &["no stage 'jiont'", "joint", "tau_table"],
    );
}

/// The repository's experiments and pipelines, copied to a temporary root.
fn repository_specs() -> tempfile::TempDir {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let d = tempfile::tempdir().unwrap();
    for sub in ["experiments", "pipelines"] {
        std::fs::create_dir_all(d.path().join(sub)).unwrap();
        // Files only: pipelines/examples is a project of its own.
        for e in std::fs::read_dir(repo.join(sub)).unwrap().flatten() {
            if e.path().is_file() {
                std::fs::copy(e.path(), d.path().join(sub).join(e.file_name())).unwrap();
            }
        }
    }
    d
}

/// The intruder's velocity takes the drive from the runs it analyses: a copy
/// in the pipeline that equals it plans, one that does not is refused naming
/// the stage's key and the experiment with its key.
#[test]
fn an_intruder_analysis_takes_its_drive_from_the_run_and_refuses_a_wrong_copy() {
    let d = repository_specs();
    let rel = "pipelines/intruder-fig3.yaml";
    let plan = |d: &tempfile::TempDir| {
        Workspace::new(d.path()).plan(&reg(), &ids(&["intruder-fig3"]), "ci")
    };
    plan(&d).expect("the pipeline without a copy of the drive plans");
    let line = "params: {t_start: 0, blocks: 10}";
    edit(
        d.path(),
        rel,
        line,
        "params: {t_start: 0, blocks: 10, drive: {eps: 0.7, gamma: 1.0, temperature: 1.0}, kick_rate_factor: 1000}",
    );
    plan(&d).expect("a copy equal to the run's drive is accepted");
    edit(d.path(), rel, "drive: {eps: 0.7,", "drive: {eps: 0.9,");
    let e = format!(
        "{:#}",
        plan(&d).expect_err("a copy that disagrees is refused")
    );
    for w in [
        "intruder-fig3.yaml:",
        "stage 'velocity'",
        "`drive.eps` = 0.9",
        "experiment 'intruder_eps07'",
        "intruder_eps07.yaml",
        "eps = 0.7",
    ] {
        assert!(e.contains(w), "expected {w:?} in\n{e}");
    }
    edit(d.path(), rel, "drive: {eps: 0.9,", "drive: {eps: 0.7,");
    edit(
        d.path(),
        rel,
        "kick_rate_factor: 1000}",
        "kick_rate_factor: 10000}",
    );
    let e = format!(
        "{:#}",
        plan(&d).expect_err("a kick rate that disagrees is refused")
    );
    for w in [
        "`kick_rate_factor` = 10000",
        "intruder.kick_rate_factor",
        "intruder_eps07.yaml",
    ] {
        assert!(e.contains(w), "expected {w:?} in\n{e}");
    }
}
