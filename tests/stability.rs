//! The stability maps' behaviour end to end with the real stage kinds: a run
//! whose collapse guard acts too often warns in its summary and its map's
//! table; a spec beyond the compression limit fails naming the spec and the
//! reached packing fraction.
//!
//! `cargo test --release --test stability`

use std::path::Path;

use repro::pipeline::store::Store;
use repro::pipeline::{RunOptions, Workspace, run_figures};

const GUARD: &str = r#"
description: the guard at eps = 0.1 and 0.9
kind: simulate
seed: 5
params:
  phi: 0.6
  collapse_tc: 1.0e-5
  tau_guess: {A: 1.0, B: 0.0, phi0: 0.9}
  relax_tau: 5
  origins: 1
  spacing_tau: 1
  lag_min: 1
  lag_max_tau: 5
  lags_per_decade: 2
profiles:
  ci: {grid: {eps: [0.1, 0.9]}, replicas: 1, params: {n: 200}}
"#;

const JAM: &str = r#"
description: beyond the jam
kind: simulate
seed: 6
params:
  phi: 0.85
  compression_rate: 0.1
  tau_guess: {A: 1.0, B: 0.0, phi0: 0.9}
  relax_tau: 1
  origins: 1
  spacing_tau: 1
  lag_min: 1
  lag_max_tau: 1
  lags_per_decade: 2
profiles:
  ci: {grid: {n: [100]}, replicas: 1}
"#;

fn pipeline(experiment: &str) -> String {
    format!(
        "description: runs as rows\nstages:\n  - {{name: runs, kind: run_summary, map: {experiment}}}\n  - {{name: rows, kind: table, gather: [runs]}}\n"
    )
}

fn workspace(dir: &Path) -> Workspace {
    std::fs::create_dir_all(dir.join("experiments")).unwrap();
    std::fs::create_dir_all(dir.join("pipelines")).unwrap();
    std::fs::write(dir.join("experiments/guard.yaml"), GUARD).unwrap();
    std::fs::write(dir.join("experiments/jam.yaml"), JAM).unwrap();
    std::fs::write(dir.join("pipelines/guardmap.yaml"), pipeline("guard")).unwrap();
    std::fs::write(dir.join("pipelines/jammap.yaml"), pipeline("jam")).unwrap();
    Workspace::new(dir)
}

fn column(path: &Path, name: &str) -> Vec<f64> {
    use arrow_array::{Array, Float64Array};
    let (batches, _) = repro::table::read_parquet(path).unwrap();
    batches
        .iter()
        .flat_map(|b| {
            let f = b
                .column_by_name(name)
                .unwrap()
                .as_any()
                .downcast_ref::<Float64Array>()
                .unwrap()
                .clone();
            (0..f.len()).map(move |i| f.value(i))
        })
        .collect()
}

#[test]
fn a_guard_acting_too_often_warns_in_the_summary_and_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let ws = workspace(dir.path());
    let reg = repro::stages::registry();
    let run = run_figures(
        &ws,
        &reg,
        &["guardmap".into()],
        "ci",
        &RunOptions::default(),
    )
    .unwrap();
    run.check().unwrap();
    let table = ws.results.join("guardmap/rows.parquet");
    let (eps, warn, frac) = (
        column(&table, "eps"),
        column(&table, "guard_warning"),
        column(&table, "guard_fraction"),
    );
    for i in 0..eps.len() {
        // eps = 0.1 at phi = 0.6: the guard makes more than 1% of collisions
        // elastic; eps = 0.9: practically none.
        assert_eq!(
            warn[i] == 1.0,
            eps[i] < 0.5,
            "eps {} fraction {}",
            eps[i],
            frac[i]
        );
        assert_eq!(warn[i] == 1.0, frac[i] > 0.01);
    }
    // The run's own summary carries the warning, naming the fraction's setting.
    let prov: serde_json::Value = serde_json::from_slice(
        &std::fs::read(ws.results.join("guardmap/provenance.json")).unwrap(),
    )
    .unwrap();
    let store = Store::open(&ws.store).unwrap();
    let mut seen = 0;
    for s in prov["stages"].as_array().unwrap() {
        if s["kind"] != "simulate" {
            continue;
        }
        let hash = s["files"]["json"].as_str().unwrap();
        let summary: serde_json::Value =
            serde_json::from_slice(&store.read_verified(hash, "summary").unwrap()).unwrap();
        let warned = summary.get("warnings").is_some();
        assert_eq!(
            warned,
            s["point"]["eps"].as_f64().unwrap() < 0.5,
            "{summary}"
        );
        if warned {
            let w = summary["warnings"][0].as_str().unwrap();
            assert!(
                w.contains("guard_warn = 0.01") && w.contains("collapse_tc"),
                "{w}"
            );
        }
        seen += 1;
    }
    assert_eq!(seen, 2);
}

#[test]
fn a_spec_beyond_the_compression_limit_fails_naming_it_and_the_reached_fraction() {
    let dir = tempfile::tempdir().unwrap();
    let ws = workspace(dir.path());
    let reg = repro::stages::registry();
    let run = run_figures(&ws, &reg, &["jammap".into()], "ci", &RunOptions::default()).unwrap();
    let report = run.report.failure_report(&run.graph);
    assert!(
        report.contains("jam.yaml") && report.contains("compression jammed at phi = 0.8"),
        "{report}"
    );
    assert!(report.contains("before reaching phi = 0.85"), "{report}");
}
