//! End to end with the real stage kinds on a tiny ensemble: simulate -> overlap /
//! tau_alpha / chi4 -> fit -> compare -> plot, then the regression check.
//!
//! `cargo test --release --test figures`

use std::path::Path;

use repro::pipeline::{Registry, RunOptions, Workspace, run_figures};
use repro::study::golden::{GoldenFile, check, golden};
use repro::study::results::read_compare;

const EXPERIMENT: &str = r#"
description: tiny eps = 0.9 sweep for tests
kind: simulate
seed: 7
params:
  eps: 0.9
  tau_guess: {A: 0.76, B: 0.148, phi0: 0.83}
  relax_tau: 5
  relax_min: 5
  origins: 3
  spacing_tau: 2
  lag_min: 0.05
  lag_max_tau: 8
  lags_per_decade: 5
profiles:
  ci:
    grid:
      phi: [0.55, 0.62, 0.68, 0.72]
    replicas: 2
    params:
      n: 200
"#;

const PIPELINE: &str = r#"
description: tiny fig4 + fig15
stages:
  - name: tau
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
  - name: tau_table
    kind: table
    gather: [tau]
  - name: exponential
    kind: fit
    gather: [tau_table]
    params:
      form: vft
      data: tau_table
      x: phi
      y: tau_alpha
      y_err: tau_alpha_err
      curve: {}
  - name: peaks
    kind: chi4_peaks
    gather: [tiny]
    by: [phi]
    params: {n: [25, 50, 1000]}
  - name: peaks_table
    kind: table
    gather: [peaks]
  - name: compare
    kind: compare
    gather: [exponential]
    params:
      paper:
        - {quantity: phi_0, value: 0.83, tolerance: 0.05}
  - name: figure
    kind: plot
    gather: [tau_table, exponential, peaks_table]
    params:
      panels:
        - x: {label: "φ"}
          y: {label: "τ_α", log: true}
          layers:
            - {from: tau_table, x: phi, y: tau_alpha, y_err: tau_alpha_err, style: points}
            - {from: exponential, file: curve.parquet, x: x, y: y}
        - x: {label: "N", log: true}
          y: {label: "χ₄ᴾ", log: true}
          layers:
            - {from: peaks_table, x: N, y: chi4P, group: phi, style: "line+points"}
"#;

fn write_specs(root: &Path) {
    std::fs::create_dir_all(root.join("experiments")).unwrap();
    std::fs::create_dir_all(root.join("pipelines")).unwrap();
    std::fs::write(root.join("experiments/tiny.yaml"), EXPERIMENT).unwrap();
    std::fs::write(root.join("pipelines/tinyfig.yaml"), PIPELINE).unwrap();
}

fn column(path: &Path, name: &str) -> Vec<f64> {
    use arrow_array::{Array, Float64Array};
    let (batches, _) = repro::table::read_parquet(path).unwrap();
    batches
        .iter()
        .flat_map(|b| {
            let c = b
                .column_by_name(name)
                .unwrap_or_else(|| panic!("no column {name} in {}", path.display()));
            let f = c.as_any().downcast_ref::<Float64Array>().unwrap();
            (0..f.len()).map(|i| f.value(i)).collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn tiny_figure_end_to_end_then_regression_check() {
    let dir = tempfile::tempdir().unwrap();
    write_specs(dir.path());
    let ws = Workspace::new(dir.path());
    let opts = RunOptions {
        jobs: 2,
        ..RunOptions::default()
    };
    let ids = vec!["tinyfig".to_string()];
    let run = run_figures(&ws, &Registry::builtin(), &ids, "ci", &opts).unwrap();
    run.check().unwrap();
    let out = ws.results.join("tinyfig");
    for f in [
        "tau_table.parquet",
        "peaks_table.parquet",
        "compare.parquet",
        "figure.svg",
        "figure.png",
        "provenance.json",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }

    // Physics: the relaxation slows down monotonically with packing fraction.
    let phi = column(&out.join("tau_table.parquet"), "phi");
    let tau = column(&out.join("tau_table.parquet"), "tau_alpha");
    assert_eq!(phi, vec![0.55, 0.62, 0.68, 0.72]);
    assert!(
        tau.windows(2).all(|w| w[0] < w[1]),
        "tau_alpha not increasing with phi: {tau:?}"
    );
    // chi4 of the whole system is clamped to N = 200 and chi4 >= 0 by construction.
    let n = column(&out.join("peaks_table.parquet"), "N");
    assert!(
        n.iter().all(|&x| x == 25.0 || x == 50.0 || x == 200.0),
        "{n:?}"
    );
    assert!(
        column(&out.join("peaks_table.parquet"), "chi4P")
            .iter()
            .all(|&c| c > 0.0)
    );

    // Rerunning is all cached and bit-identical.
    let before = std::fs::read(out.join("tau_table.parquet")).unwrap();
    let again = run_figures(
        &ws,
        &Registry::builtin(),
        &ids,
        "ci",
        &RunOptions { jobs: 1, ..opts },
    )
    .unwrap();
    assert!(
        again.report.executed(&again.graph).is_empty(),
        "a rerun executed stages"
    );
    assert_eq!(
        before,
        std::fs::read(out.join("tau_table.parquet")).unwrap()
    );

    // The regression check: inside the band passes, outside names figure,
    // quantity, value and band.
    let ours = read_compare(&out).unwrap();
    let phi_0 = ours.iter().find(|c| c.quantity == "phi_0").unwrap().ours;
    let good = GoldenFile {
        profile: "ci".into(),
        how: "test".into(),
        sigmas: 4.0,
        relative_floor: 0.01,
        quantities: vec![golden(
            "tinyfig",
            "phi_0",
            &[1, 2],
            &[phi_0, phi_0],
            4.0,
            0.01,
        )],
    };
    let (lines, failures) = check(&good, &ws.results, &[]).unwrap();
    assert_eq!(lines.len(), 1);
    assert!(failures.is_empty(), "{failures:?}");
    let bad = GoldenFile {
        quantities: vec![golden(
            "tinyfig",
            "phi_0",
            &[1, 2],
            &[phi_0 + 1.0, phi_0 + 1.0],
            4.0,
            0.01,
        )],
        ..good.clone()
    };
    let (_, failures) = check(&bad, &ws.results, &[]).unwrap();
    assert_eq!(failures.len(), 1);
    let msg = &failures[0];
    assert!(
        msg.contains("tinyfig") && msg.contains("phi_0") && msg.contains(&format!("{phi_0:.5}")),
        "{msg}"
    );
    assert!(
        msg.contains(&format!("{:.5}", bad.quantities[0].band[0])),
        "{msg}"
    );
    // Goldens of another profile are refused with the command to run.
    let other = GoldenFile {
        profile: "small".into(),
        ..good
    };
    let e = format!("{:#}", check(&other, &ws.results, &[]).unwrap_err());
    assert!(
        e.contains("profile 'ci'") && e.contains("repro figure tinyfig --profile small"),
        "{e}"
    );

    // The report quotes the compare stage's number with its error and verdict.
    let c = ours.iter().find(|c| c.quantity == "phi_0").unwrap();
    repro::study::report::write(dir.path(), &ws.results, Some("ci"), false).unwrap();
    let md = std::fs::read_to_string(ws.results.join("REPORT.md")).unwrap();
    let row = format!(
        "| tinyfig | phi_0 | {} |",
        repro::study::report::number(c.ours, c.ours_err)
    );
    assert!(md.contains(&row) && md.contains(&c.verdict), "{row}\n{md}");
    assert!(md.contains("![tinyfig](tinyfig/figure.png)"), "{md}");
}
