//! End to end with the real stage kinds on a tiny ensemble: simulate -> overlap /
//! tau_alpha / chi4 -> fit -> compare -> plot, then the regression check.
//!
//! `cargo test --release --test figures`

use std::path::Path;

use repro::pipeline::{RunOptions, Workspace, run_figures};
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
            - {from: exponential, file: curve.parquet, x: phi, y: tau_alpha}
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

fn options() -> RunOptions {
    RunOptions {
        jobs: 2,
        ..RunOptions::default()
    }
}

/// The tiny experiment and pipeline `id` (`spec`) in `dir`, built at ci and checked.
fn build(dir: &Path, id: &str, spec: &str) -> (Workspace, repro::pipeline::FigureRun) {
    write_specs(dir);
    std::fs::write(dir.join(format!("pipelines/{id}.yaml")), spec).unwrap();
    let ws = Workspace::new(dir);
    let reg = repro::stages::registry();
    let run = run_figures(&ws, &reg, &[id.to_string()], "ci", &options()).unwrap();
    run.check().unwrap();
    (ws, run)
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
    let run = run_figures(&ws, &repro::stages::registry(), &ids, "ci", &opts).unwrap();
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

    // Every published column says its unit and what it is (Parquet field metadata).
    for e in std::fs::read_dir(&out).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "parquet") {
            let (batches, _) = repro::table::read_parquet(&p).unwrap();
            for f in batches[0].schema().fields() {
                let m = f.metadata();
                assert!(
                    m.contains_key("unit") && m.get("description").is_some_and(|d| !d.is_empty()),
                    "{}: column {} has no unit/description",
                    p.display(),
                    f.name()
                );
            }
        }
    }

    // Rerunning is all cached and bit-identical.
    let before = std::fs::read(out.join("tau_table.parquet")).unwrap();
    let again = run_figures(
        &ws,
        &repro::stages::registry(),
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
    // Every other key number of the figure left out with a reason.
    let others: std::collections::BTreeMap<String, String> =
        repro::study::results::key_numbers(&out)
            .unwrap()
            .into_keys()
            .filter(|q| q != "phi_0")
            .map(|q| (format!("tinyfig:{q}"), "not under test".to_string()))
            .collect();
    assert!(!others.is_empty());
    let good = GoldenFile {
        profile: "ci".into(),
        how: "test".into(),
        sigmas: 4.0,
        relative_floor: 0.01,
        seeds: vec![1, 2],
        ungated: others.clone(),
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
    assert_eq!(lines.len(), 3, "{lines:?}");
    assert!(lines[1].starts_with("agreed with the paper"), "{lines:?}");
    assert!(lines[2].starts_with("joint:"), "{lines:?}");
    assert!(failures.is_empty(), "{failures:?}");
    // At a recorded seed the built number is the recorded one; a golden the
    // code has moved away from is named stale, with its two values.
    use repro::study::golden::stale;
    assert!(stale(&good, &ws.results, &[], 1).unwrap().is_empty());
    let mut moved = good.clone();
    moved.quantities[0].values[0] = phi_0 + 0.5;
    moved.quantities[0].std = 0.1;
    let s = stale(&moved, &ws.results, &[], 1).unwrap();
    assert!(
        s.len() == 1 && s[0].starts_with("stale golden in tinyfig: phi_0") && s[0].contains("-5.0"),
        "{s:?}"
    );
    assert!(stale(&moved, &ws.results, &[], 2).unwrap().is_empty());
    assert!(stale(&moved, &ws.results, &[], 3).unwrap().is_empty());
    // A key number with neither a band nor a reason fails, named.
    let (first, _) = others.iter().next().unwrap();
    let mut unrecorded = good.clone();
    unrecorded.ungated.remove(first);
    let (_, failures) = check(&unrecorded, &ws.results, &[]).unwrap();
    let name = first.trim_start_matches("tinyfig:");
    assert!(
        failures.len() == 1 && failures[0].contains(name) && failures[0].contains("neither"),
        "{failures:?}"
    );
    // Gated on agreeing with the paper: listed, and failing exactly when the
    // verdict is now `disagree`.
    let verdict = ours.iter().find(|c| c.quantity == "phi_0").unwrap().verdict;
    let mut agreeing = good.clone();
    agreeing.quantities[0].always_agree = true;
    let (lines, failures) = check(&agreeing, &ws.results, &[]).unwrap();
    assert!(lines[1].contains("(1): tinyfig:phi_0"), "{lines:?}");
    assert_eq!(
        failures.len(),
        usize::from(verdict == repro::study::results::Verdict::Disagree),
        "{verdict:?}: {failures:?}"
    );
    // A CI figure with key numbers but no band is refused, with the command.
    let tiny = ["tinyfig".to_string()];
    let g = std::path::Path::new("ci.json");
    repro::study::golden::all_recorded(&good, g, &tiny, &ws.results).unwrap();
    let empty = GoldenFile {
        quantities: vec![],
        ..good.clone()
    };
    let e = repro::study::golden::all_recorded(&empty, g, &tiny, &ws.results).unwrap_err();
    assert!(format!("{e}").contains("--seeds 1,2 tinyfig"), "{e}");
    // ... but one whose every key number is ungated with a reason is recorded.
    let all_ungated = GoldenFile {
        quantities: vec![],
        ungated: repro::study::results::key_numbers(&ws.results.join("tinyfig"))
            .unwrap()
            .keys()
            .map(|q| {
                (
                    format!("tinyfig:{q}"),
                    "its fit fails at some seeds".to_string(),
                )
            })
            .collect(),
        ..good.clone()
    };
    repro::study::golden::all_recorded(&all_ungated, g, &tiny, &ws.results).unwrap();
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
    assert!(
        md.contains(&row) && md.contains(c.verdict.as_str()),
        "{row}\n{md}"
    );
    assert!(md.contains("![tinyfig](tinyfig/figure.png)"), "{md}");
}

const AT_PIPELINE: &str = r#"
description: Q at multiples of the measured tau_alpha
stages:
  - name: tau
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
  - name: q_at
    kind: overlap
    gather: [tiny, tau]
    by: [phi]
    params:
      time_unit: {from: tau}
      at: [0.1, 1, 2]
  - name: q_at_table
    kind: table
    gather: [q_at]
  - name: q
    kind: overlap
    gather: [tiny]
    by: [phi]
  - name: q_table
    kind: table
    gather: [q]
  - name: relax              # Eq. 8 of paper H, one fit per phi
    kind: fit
    gather: [q_table]
    params: {form: q_relaxation, data: q_table, x: t, y: Q, y_err: Q_err, group_by: [phi], curve: {points: 20}}
  - name: tau_table
    kind: table
    gather: [tau]
  - name: q_scaled           # Q(t) with t/tau_alpha, joined by phi
    kind: join
    gather: [q_table, tau_table]
    params: {left: q_table, right: tau_table, on: [phi], derive: [{name: t_over_tau, op: divide, a: t, b: tau_alpha}]}
  - name: too_short          # two points for two parameters: a failed fit, not a crash
    kind: fit
    gather: [q_table]
    params: {form: q_relaxation, data: q_table, x: t, y: Q, where: {t: {max: 0.1}}, group_by: [phi]}
"#;

/// "At 1 tau_alpha" from YAML: Q is read at exactly 0.1, 1 and 2 tau_alpha
/// (interpolated in ln t between the recorded lags around each, listed in
/// at.parquet), so Q(tau_alpha) = 1/e up to the two interpolations; the errors
/// are labelled, and a request past the last recorded lag fails the stage with
/// its reason.
#[test]
fn times_in_units_of_a_measured_tau_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let (ws, run) = build(dir.path(), "atfig", AT_PIPELINE);
    let table = ws.results.join("atfig/q_at_table.parquet");
    let (phi, x, q) = (
        column(&table, "phi"),
        column(&table, "t_over_tau_alpha"),
        column(&table, "Q"),
    );
    for p in [0.55, 0.62, 0.68, 0.72] {
        let rows: Vec<usize> = (0..phi.len()).filter(|&i| phi[i] == p).collect();
        let at: Vec<f64> = rows.iter().map(|&i| x[i]).collect();
        for (got, want) in at.iter().zip([0.1, 1.0, 2.0]) {
            assert!((got - want).abs() < 1e-9, "phi {p}: t/tau_alpha = {at:?}");
        }
        // tau_alpha is where Q crosses 1/e: read back there, Q is 1/e but for
        // the difference of the crossing's and this interpolation.
        let q1 = q[rows[1]];
        assert!(
            (q1 - (-1f64).exp()).abs() < 0.02,
            "phi {p}: Q(tau_alpha) = {q1}"
        );
        assert!(q[rows[0]] > q1 && q1 > q[rows[2]], "phi {p}");
    }
    // How the errors were estimated is in the analysis table's metadata.
    let node = run
        .graph
        .nodes
        .iter()
        .position(|n| n.kind == "overlap")
        .unwrap();
    let entry = run.report.results[&node].entry.as_ref().unwrap();
    let store = repro::pipeline::Store::open(&ws.store).unwrap();
    let (_, meta) =
        repro::table::read_parquet(&store.object_path(&entry.files["parquet"])).unwrap();
    assert!(
        meta.iter()
            .any(|(k, v)| k == "errors" && v.contains("jackknife") && v.contains("2 replica")),
        "{meta:?}"
    );
    // The lags used and their distance from the requests: at.parquet.
    let (at, _) =
        repro::table::read_parquet(&store.object_path(&entry.files["at.parquet"])).unwrap();
    assert_eq!(at[0].num_rows(), 3);
    let col = |name: &str| {
        at[0]
            .column_by_name(name)
            .unwrap()
            .as_any()
            .downcast_ref::<arrow_array::Float64Array>()
            .unwrap()
            .values()
            .to_vec()
    };
    let (below, want, above, w) = (
        col("lag_below"),
        col("requested"),
        col("lag_above"),
        col("weight_above"),
    );
    for i in 0..3 {
        assert!(
            below[i] <= want[i] && want[i] <= above[i],
            "{below:?} {want:?} {above:?}"
        );
        assert!((0.0..=1.0).contains(&w[i]), "{w:?}");
    }
    // Grouped fits: one row group per phi, the relaxation slowing down with phi;
    // the curve is named after the fitted columns.
    let relax = ws.results.join("atfig/relax.parquet");
    let (batches, _) = repro::table::read_parquet(&relax).unwrap();
    let (mut phis, mut tau0) = (Vec::new(), Vec::new());
    for b in &batches {
        use arrow_array::{Array, Float64Array, StringArray};
        let q = b
            .column_by_name("quantity")
            .unwrap()
            .as_any()
            .downcast_ref::<StringArray>()
            .unwrap();
        let v = b
            .column_by_name("value")
            .unwrap()
            .as_any()
            .downcast_ref::<Float64Array>()
            .unwrap();
        let p = b
            .column_by_name("phi")
            .unwrap()
            .as_any()
            .downcast_ref::<Float64Array>()
            .unwrap();
        for i in 0..b.num_rows() {
            if q.value(i) == "tau0" {
                phis.push(p.value(i));
                tau0.push(v.value(i));
            }
        }
    }
    assert_eq!(phis, vec![0.55, 0.62, 0.68, 0.72]);
    assert!(tau0.windows(2).all(|w| w[0] < w[1]), "{tau0:?}");
    let curve = ws.results.join("atfig/relax.curve.parquet");
    assert_eq!(column(&curve, "phi").len(), 80);
    assert!(column(&curve, "Q").iter().all(|q| (0.0..=1.0).contains(q)));
    let failed = ws.results.join("atfig/too_short.parquet");
    assert!(column(&failed, "value").iter().all(|v| v.is_nan()));
    let (b, _) = repro::table::read_parquet(&failed).unwrap();
    let note = b[0]
        .column_by_name("note")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow_array::StringArray>()
        .unwrap()
        .value(0)
        .to_string();
    assert!(
        note.starts_with("fit failed:") && note.contains("q_relaxation"),
        "{note}"
    );

    // The join: every Q row got its phi's tau_alpha and t / tau_alpha.
    let scaled = ws.results.join("atfig/q_scaled.parquet");
    let (t, ta, x) = (
        column(&scaled, "t"),
        column(&scaled, "tau_alpha"),
        column(&scaled, "t_over_tau"),
    );
    assert_eq!(
        t.len(),
        column(&ws.results.join("atfig/q_table.parquet"), "t").len()
    );
    assert!((0..t.len()).all(|i| ta[i] > 0.0 && x[i] == t[i] / ta[i]));
    // A key missing from one table is an error naming it.
    let (reg, opts) = (repro::stages::registry(), options());
    let missing = AT_PIPELINE.replace("on: [phi]", "on: [eps]");
    std::fs::write(dir.path().join("pipelines/atfig.yaml"), missing).unwrap();
    let run = run_figures(&ws, &reg, &["atfig".to_string()], "ci", &opts).unwrap();
    let report = run.report.failure_report(&run.graph);
    assert!(
        report.contains("key 'eps' is not a column of stage 'q_table'"),
        "{report}"
    );

    // Past what the run-length rule records: refused when planning, located.
    let bad = AT_PIPELINE.replace("at: [0.1, 1, 2]", "at: [1000]");
    std::fs::write(dir.path().join("pipelines/atfig.yaml"), bad).unwrap();
    let e = run_figures(&ws, &reg, &["atfig".to_string()], "ci", &opts)
        .err()
        .expect("refused at plan time");
    let e = format!("{e:#}");
    assert!(
        e.contains("1000 tau_alpha") && e.contains("raise `lag_max_tau`"),
        "{e}"
    );
    // Before the first recorded lag of the measured tau_alpha: refused when running.
    let bad = AT_PIPELINE.replace("at: [0.1, 1, 2]", "at: [0.001]");
    std::fs::write(dir.path().join("pipelines/atfig.yaml"), bad).unwrap();
    let run = run_figures(&ws, &reg, &["atfig".to_string()], "ci", &opts).unwrap();
    let report = run.report.failure_report(&run.graph);
    assert!(
        report.contains("0.001 tau_alpha") && report.contains("refusing to extrapolate"),
        "{report}"
    );
}

const S4_PIPELINE: &str = r#"
description: tiny figs 16-18
stages:
  - name: tau
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
  - name: tau_table
    kind: table
    gather: [tau]
  - name: s4
    kind: s4
    gather: [tiny, tau]
    by: [phi]
    params: {a: 0.6, q_max: 2.0, time_unit: {from: tau}, at: [1]}
  - name: s4_table
    kind: table
    gather: [s4]
  - name: chi4_whole
    kind: chi4
    gather: [tiny, tau]
    by: [phi]
    params: {a: 0.6, n: [100000], time_unit: {from: tau}, at: [1]}
  - name: chi4_table
    kind: table
    gather: [chi4_whole]
  - name: s4_vs_chi4
    kind: join
    gather: [s4_table, chi4_table]
    params: {left: s4_table, right: chi4_table, on: [phi, t]}
  - name: oz
    kind: fit
    gather: [s4_table]
    params: {form: oz, data: s4_table, x: q, y: S4, y_err: S4_err, where: {q: {min: 0.001, max: 1.5}}, group_by: [phi]}
  - name: xi_table
    kind: join
    gather: [tau_table, oz]
    params: {left: tau_table, right: oz, on: [phi], derive: [{name: xi_over_tau, op: divide, a: xi, b: tau_alpha}, {name: inv_xi, op: reciprocal, a: xi}]}
  - name: tau_pl
    kind: fit
    gather: [tau_table]
    params: {form: power_law_offset, data: tau_table, x: phi, y: tau_alpha, y_err: tau_alpha_err, fixed: {phi_c: 0.725}}
  - name: compare
    kind: compare
    gather: [tau_pl]
    params: {paper: [{quantity: gamma, value: 1.6, tolerance: 100}]}
"#;

/// Figs 16-18: S4 at tau_alpha pooled over replicas, its q = 0 row equal to chi4
/// of the whole system at the same lag, and a grouped fit table joined as one row
/// per phi with a column per fitted quantity.
#[test]
fn s4_q_zero_is_chi4_and_fit_tables_join_as_columns() {
    let dir = tempfile::tempdir().unwrap();
    let (ws, _) = build(dir.path(), "s4fig", S4_PIPELINE);
    let joined = ws.results.join("s4fig/s4_vs_chi4.parquet");
    let (phi, q, s4, chi4, n) = (
        column(&joined, "phi"),
        column(&joined, "q"),
        column(&joined, "S4"),
        column(&joined, "chi4"),
        column(&joined, "N"),
    );
    let zeros: Vec<usize> = (0..q.len()).filter(|&i| q[i] == 0.0).collect();
    assert_eq!(zeros.len(), 4, "one q = 0 row per phi");
    for &i in &zeros {
        assert_eq!(n[i], 200.0, "chi4 of the whole system");
        assert!(
            (s4[i] - chi4[i]).abs() <= 1e-9 * chi4[i],
            "phi {}: S4(0) = {} vs chi4 = {}",
            phi[i],
            s4[i],
            chi4[i]
        );
    }
    assert!(q.iter().filter(|&&v| v > 0.0).count() > 4 * 3);
    // The fit table (4 quantities per phi) joined as one row per phi.
    let xi = ws.results.join("s4fig/xi_table.parquet");
    let (phis, x, xe, ta, r) = (
        column(&xi, "phi"),
        column(&xi, "xi"),
        column(&xi, "xi_err"),
        column(&xi, "tau_alpha"),
        column(&xi, "xi_over_tau"),
    );
    assert_eq!(phis, vec![0.55, 0.62, 0.68, 0.72]);
    assert_eq!(column(&xi, "chi0").len(), 4);
    let (inv, inv_err) = (column(&xi, "inv_xi"), column(&xi, "inv_xi_err"));
    for i in 0..4 {
        assert!(x[i].is_nan() || (x[i] > 0.0 && xe[i] >= 0.0), "xi {}", x[i]);
        assert!(x[i].is_nan() || r[i] == x[i] / ta[i]);
        // `reciprocal`: 1/xi with the propagated error xi_err / xi^2.
        assert!(x[i].is_nan() || inv[i] == 1.0 / x[i]);
        assert!(x[i].is_nan() || (inv_err[i] - xe[i] / (x[i] * x[i])).abs() <= 1e-12 * inv_err[i]);
    }
    assert!(x.iter().any(|v| v.is_finite()), "{x:?}");
    // S4 carries replica samples, so xi per phi carries its OZ refits with each
    // replica left out, under the unit of tau_alpha's runs: a fit of xi across
    // phi refits xi and phi_c on the same replicas.
    let (jk0, jk1) = (column(&xi, "xi_jk0"), column(&xi, "xi_jk1"));
    let tau = ws.results.join("s4fig/tau_table.parquet");
    let (tau_phi, tau_unit) = (column(&tau, "phi"), column(&tau, "jk_unit"));
    let oz = ws.results.join("s4fig/oz.parquet");
    for (p, u) in column(&oz, "phi").iter().zip(column(&oz, "jk_unit")) {
        let j = tau_phi.iter().position(|t| t == p).unwrap();
        assert_eq!(
            u, tau_unit[j],
            "phi {p}: the OZ fit's unit is not tau_alpha's"
        );
    }
    for i in 0..4 {
        if x[i].is_finite() && jk0[i].is_finite() && jk1[i].is_finite() {
            assert!(
                jk0[i] != jk1[i] && jk0[i] > 0.0 && jk1[i] > 0.0,
                "phi {}: {} {}",
                phis[i],
                jk0[i],
                jk1[i]
            );
        }
    }
    assert!(
        jk0.iter()
            .zip(&jk1)
            .any(|(a, b)| a.is_finite() && b.is_finite()),
        "{jk0:?} {jk1:?}"
    );
    // A divergence 0.005 beyond the last phi (steps of 0.04): the compare verdict
    // is `unreliable` with the reason, however wide the tolerance.
    let c = read_compare(&ws.results.join("s4fig")).unwrap();
    assert_eq!(c[0].verdict, "unreliable", "{}", c[0].reason);
    assert!(
        c[0].reason.contains("last data point 0.72"),
        "{}",
        c[0].reason
    );
}

const DISPLACEMENT_PIPELINE: &str = r#"
description: tiny figs 5 and 9, with qualitative claims in compare
stages:
  - name: diffusion
    kind: diffusion
    gather: [tiny]
    by: [phi]
    params: {fit_min_tau: 1.0}
  - name: d_table
    kind: table
    gather: [diffusion]
  - name: levels
    kind: q_levels
    gather: [tiny]
    by: [phi]
    params: {levels: [0.6, 0.5]}
  - name: levels_table
    kind: table
    gather: [levels]
  - name: d_low
    kind: fit
    gather: [d_table]
    params: {form: value, data: d_table, x: phi, y: D, y_err: D_err, where: {phi: 0.55}, rename: {value: D_055}}
  - name: d_high
    kind: fit
    gather: [d_table]
    params: {form: value, data: d_table, x: phi, y: D, y_err: D_err, where: {phi: 0.72}, rename: {value: D_072}}
  - name: compare
    kind: compare
    gather: [d_low, d_high]
    params:
      paper:
        - {quantity: D_072, value: 0, tolerance: 0, claim: below, than: D_055}
        - {quantity: D_072, value: 0, tolerance: 0, claim: above, than: D_055}
        - {quantity: D_055, value: 0, tolerance: 0, claim: above}
"#;

const AGING_PIPELINE: &str = r#"
description: tiny fig2 drift
stages:
  - name: aging
    kind: aging
    gather: [tiny]
    by: [phi]
  - name: drift
    kind: fit
    gather: [aging]
    params: {form: drift, file: tau.parquet, x: t0, y: tau_alpha, where: {phi: 0.55}}
"#;

/// fig2's drift of tau_alpha(t0): the waiting times of one run share its
/// stretch of time, so its error is the replica jackknife (tau.parquet
/// carries tau_alpha with each replica left out), not the scatter about the
/// line of points that are not independent.
#[test]
fn the_aging_drift_is_refitted_per_replica() {
    let dir = tempfile::tempdir().unwrap();
    let (ws, _) = build(dir.path(), "agefig", AGING_PIPELINE);
    let drift = ws.results.join("agefig/drift.parquet");
    let (v, jk0, jk1) = (
        column(&drift, "value"),
        column(&drift, "value_jk0"),
        column(&drift, "value_jk1"),
    );
    assert!(
        v[0].is_finite() && jk0[0].is_finite() && jk1[0].is_finite(),
        "{v:?} {jk0:?} {jk1:?}"
    );
    assert!(
        jk0[0] != jk1[0],
        "each replica left out refits its own drift"
    );
    // Two replicas: the jackknife error sqrt((n-1)/n sum (jk_k - mean)^2) is
    // |jk0 - jk1| / 2.
    let e = column(&drift, "error")[0];
    let expect = (jk0[0] - jk1[0]).abs() / 2.0;
    assert!(
        e >= 0.99 * expect,
        "error {e} against the jackknife {expect}"
    );
}

#[test]
fn diffusion_levels_and_claims_on_a_tiny_sweep() {
    let dir = tempfile::tempdir().unwrap();
    write_specs(dir.path());
    std::fs::write(
        dir.path().join("pipelines/dispfig.yaml"),
        DISPLACEMENT_PIPELINE,
    )
    .unwrap();
    let ws = Workspace::new(dir.path());
    let opts = RunOptions {
        jobs: 2,
        ..RunOptions::default()
    };
    let reg = repro::stages::registry();
    let run = run_figures(&ws, &reg, &["dispfig".to_string()], "ci", &opts).unwrap();
    run.check().unwrap();
    // D falls and tau_alpha grows with phi; the fit starts at tau_alpha.
    let d = ws.results.join("dispfig/d_table.parquet");
    let (dd, tau, t0) = (
        column(&d, "D"),
        column(&d, "tau_alpha"),
        column(&d, "t_fit_min"),
    );
    assert_eq!(dd.len(), 4);
    assert!(dd.windows(2).all(|w| w[0] > w[1]), "D {dd:?}");
    assert!(tau.windows(2).all(|w| w[0] < w[1]), "tau {tau:?}");
    assert!(
        (0..4).all(|i| t0[i] >= tau[i] * (1.0 - 1e-9)),
        "{t0:?} {tau:?}"
    );
    // Q crosses 0.6 before 0.5, both before 1/e: ratios in (0, 1) ordered by level.
    let l = ws.results.join("dispfig/levels_table.parquet");
    let (lev, r) = (column(&l, "level"), column(&l, "t_over_tau_alpha"));
    assert_eq!(lev.len(), 8);
    for i in (0..8).step_by(2) {
        assert!(0.0 < r[i] && r[i] < r[i + 1] && r[i + 1] < 1.0, "{r:?}");
    }
    // Claims: below another quantity agrees, the opposite claim disagrees, and the
    // paper column shows the quantity compared with.
    let rows = read_compare(&ws.results.join("dispfig")).unwrap();
    let verdicts: Vec<&str> = rows.iter().map(|r| r.verdict.as_str()).collect();
    assert_eq!(verdicts, ["agree", "disagree", "agree"], "{verdicts:?}");
    assert_eq!(rows[0].paper, dd[0]);
    // `than` without `claim` is refused before anything runs.
    let bad = DISPLACEMENT_PIPELINE.replace(
        "{quantity: D_055, value: 0, tolerance: 0, claim: above}",
        "{quantity: D_055, value: 0, tolerance: 0, than: D_072}",
    );
    std::fs::write(dir.path().join("pipelines/dispfig.yaml"), bad).unwrap();
    let e = run_figures(&ws, &reg, &["dispfig".to_string()], "ci", &opts)
        .err()
        .map(|e| format!("{e:#}"))
        .unwrap_or_default();
    assert!(e.contains("`than` without a `claim`"), "{e}");
}

const Q_SCALED_PIPELINE: &str = r#"
description: tiny fig6 (Eq. 8 collapse) and fig20 (tau_alpha of a cut-off a)
stages:
  - name: q
    kind: overlap
    gather: [tiny]
    by: [phi]
  - name: q_table
    kind: table
    gather: [q]
  - name: relax
    kind: fit
    gather: [q_table]
    params: {form: q_relaxation, data: q_table, x: t, y: Q, y_err: Q_err, group_by: [phi]}
  - name: q_scaled
    kind: join
    gather: [q_table, relax]
    params:
      left: q_table
      right: relax
      on: [phi]
      derive: [{name: t_over_tau0, op: divide, a: t, b: tau0}, {name: x, op: ln_times, a: t_over_tau0, b: beta}]
  - name: tau_a10
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
    sweep: {a: [1.0]}
  - name: tau_a06
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
    sweep: {a: [0.6]}
  - name: tau_table
    kind: table
    gather: [tau_a06, tau_a10]
"#;

/// Fig. 6: x = beta ln(t/tau0) from the per-phi Eq. 8 fits collapses Q onto
/// 1/(e^x + 1); fig20: a one-value sweep of the cut-off puts `a` into the table,
/// and a larger cut-off relaxes later.
#[test]
fn q_collapses_on_beta_ln_t_over_tau0_and_a_larger_cutoff_relaxes_later() {
    let dir = tempfile::tempdir().unwrap();
    let (ws, _) = build(dir.path(), "qfig", Q_SCALED_PIPELINE);
    let s = ws.results.join("qfig/q_scaled.parquet");
    let (t, q, tau0, beta, x) = (
        column(&s, "t"),
        column(&s, "Q"),
        column(&s, "tau0"),
        column(&s, "beta"),
        column(&s, "x"),
    );
    let mut dev = 0.0;
    for i in 0..t.len() {
        assert!((x[i] - beta[i] * (t[i] / tau0[i]).ln()).abs() <= 1e-12 * (1.0 + x[i].abs()));
        dev += (q[i] - 1.0 / (x[i].exp() + 1.0)).abs();
    }
    // Eq. 8 describes the tiny runs' Q(t) to a few percent on average.
    assert!(
        dev / (t.len() as f64) < 0.05,
        "mean |Q - 1/(e^x + 1)| = {}",
        dev / t.len() as f64
    );
    let tt = ws.results.join("qfig/tau_table.parquet");
    let (a, phi, tau) = (
        column(&tt, "a"),
        column(&tt, "phi"),
        column(&tt, "tau_alpha"),
    );
    assert_eq!(a.len(), 8, "4 phi x 2 cut-offs");
    for i in 0..a.len() {
        if a[i] == 1.0 {
            let j = (0..a.len())
                .find(|&j| a[j] == 0.6 && phi[j] == phi[i])
                .unwrap();
            assert!(
                tau[i] > tau[j],
                "phi {}: tau(a=1) {} <= tau(a=0.6) {}",
                phi[i],
                tau[i],
                tau[j]
            );
        }
    }
}

/// A second figure that shares tinyfig's `tau_table` node under the name
/// `tau09_table` and has a `tau_table` of its own (another cut-off a).
const SHARING_PIPELINE: &str = r#"
description: a figure sharing a node that another figure names like one of its own
stages:
  - name: tau09
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
  - name: tau09_table
    kind: table
    gather: [tau09]
  - name: tau_a05
    kind: tau_alpha
    gather: [tiny]
    by: [phi]
    params: {a: 0.5}
  - name: tau_table
    kind: table
    gather: [tau_a05]
  - name: both
    kind: join
    gather: [tau_table, tau09_table]
    params: {left: tau_table, right: tau09_table, on: [phi]}
"#;

/// A node shared between figures answers to each figure's name for it, but a
/// stage reads it only under its own figure's name: planned together with
/// tinyfig (whose `tau_table` is this figure's `tau09_table`), `left: tau_table`
/// still reads this figure's table alone (it used to read both, and rows without
/// a column of the other, such as eps, showed as a group "NaN" in a legend).
#[test]
fn a_shared_node_is_read_under_its_own_figures_name_only() {
    let dir = tempfile::tempdir().unwrap();
    write_specs(dir.path());
    std::fs::write(dir.path().join("pipelines/sharing.yaml"), SHARING_PIPELINE).unwrap();
    let ws = Workspace::new(dir.path());
    let reg = repro::stages::registry();
    let figs = ["sharing".to_string(), "tinyfig".to_string()];
    run_figures(&ws, &reg, &figs, "ci", &options())
        .unwrap()
        .check()
        .unwrap();
    let phi = column(&ws.results.join("sharing/both.parquet"), "phi");
    assert_eq!(
        phi,
        vec![0.55, 0.62, 0.68, 0.72],
        "one row per phi of its own table"
    );
    // The smaller cut-off relaxes sooner: every row is this figure's a = 0.5.
    let own = column(&ws.results.join("sharing/tau_table.parquet"), "tau_alpha");
    let joined = column(&ws.results.join("sharing/both.parquet"), "tau_alpha");
    assert_eq!(own, joined);
}
