//! Tests of the `plot` stage kind (src/stages/plot.rs).
use crate::table::references::{Lookup, Reference, Resolved, Target, value_with_error};

/// A table every column of `layer` can be read from: three groups of twelve
/// points along a rising curve inside the panel's axes, errors of 5% of the
/// value but one twenty times its value (the bar a referee sees first).
fn synthetic(
    layer: &super::Layer,
    ps: &super::PanelSpec,
    ranges: &std::collections::BTreeMap<String, (f64, f64)>,
) -> super::Columns {
    let along = |axis: &super::Axis, f: f64, lin: (f64, f64), log: (f64, f64)| {
        let (lo, hi) = axis.range.unwrap_or(if axis.log { log } else { lin });
        if axis.log {
            10f64.powf(lo.log10() + f * (hi.log10() - lo.log10()))
        } else {
            lo + f * (hi - lo)
        }
    };
    let mut c = super::Columns::default();
    let mut put = |name: &str, v: f64| c.f64.entry(name.to_string()).or_default().push(v);
    for j in 0..3 {
        for k in 0..12 {
            let u = k as f64 / 11.0;
            // Coloured by its own x (points of phi in phi's colours): x
            // runs over the colour range, and is the group column too.
            let own = layer.group.as_deref() == Some(layer.x.as_str());
            let x = match ranges.get(&layer.x) {
                Some(&(lo, hi)) if own => lo + (hi - lo) * (0.05 + 0.9 * u),
                _ => along(&ps.x, 0.05 + 0.9 * u, (0.0, 1.0), (0.1, 100.0)),
            };
            let y = along(
                &ps.y,
                0.1 + 0.6 * u + 0.1 * j as f64,
                (0.0, 10.0),
                (0.1, 1e3),
            );
            let big = j == 0 && k == 11;
            put(&layer.x, x);
            put(&layer.y, y);
            if let Some(e) = &layer.y_err {
                put(e, if big { 20.0 * y.abs() } else { 0.05 * y.abs() });
            }
            if let Some(g) = layer.group.as_ref().filter(|_| !own) {
                // Inside the column's colour range, where the figure has one.
                let (lo, hi) = ranges.get(g).copied().unwrap_or((0.6, 0.78));
                put(g, lo + (hi - lo) * [0.0, 0.5, 1.0][j]);
            }
            if let Some(r) = &layer.radius {
                put(r, 0.01);
            }
            if let Some(a) = &layer.arrows {
                put(&a.dx, 0.01);
                put(&a.dy, 0.01);
            }
        }
    }
    c.rows = 36;
    c
}

/// The verdict lines of the compare stages the plot stage `st` gathers,
/// each paper value disagreeing with a reason as long as a line allows.
fn synthetic_verdicts(st: &serde_json::Value, stages: &[serde_json::Value]) -> Vec<String> {
    let gathered = st["gather"].as_array().cloned().unwrap_or_default();
    let compares = stages
        .iter()
        .filter(|c| c["kind"] == "compare" && gathered.contains(&c["name"]));
    let mut out = vec![];
    for c in compares {
        for v in c["params"]["paper"].as_array().into_iter().flatten() {
            let paper = v["value"].as_f64().unwrap_or(1.0);
            let row = crate::table::results::Compared {
                quantity: v["quantity"].as_str().unwrap_or("q").to_string(),
                ours: 1.05 * paper,
                ours_err: 0.0123,
                paper,
                tolerance: 0.01,
                verdict: crate::table::results::Verdict::OutOfReach,
                reason: "the profile stops short of the state point the paper reaches, with too small a box ".repeat(3),
                source: crate::table::results::Source::Ref12,
            };
            out.push(super::verdict_line(
                &row,
                "",
                "quoted, ref. 12",
                super::Against::Paper,
            ));
        }
    }
    out
}

/// Every plot spec in pipelines/ drawn from synthetic tables: no legend over
/// data, one colour per group value, every label typeset, no y axis set by
/// one error bar. Data of any figure goes through the same layout, so a
/// spec whose options (a fixed corner, a range) let the plotter do one of
/// these fails here.
#[test]
fn every_plot_spec_lays_out_without_defects() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    let (mut found, mut bad) = (0, vec![]);
    // Every experiment's profiles.
    let mut experiments: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    let exp_dir = dir.parent().unwrap().join("experiments");
    for e in std::fs::read_dir(&exp_dir).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_none_or(|x| x != "yaml") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let v: serde_json::Value = crate::pipeline::spec::parse(&path, &text).unwrap();
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let profiles = v["profiles"]
            .as_object()
            .map(|o| o.keys().cloned().collect())
            .unwrap_or_default();
        experiments.insert(name, profiles);
    }
    // The colour range of each paper-wide group column, per paper: one
    // colour per phi (eps, a) in every figure of a paper.
    let mut ranges: std::collections::BTreeMap<(&str, String), (String, (f64, f64))> =
        Default::default();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        // The specs' own parser: YAML 1.2 booleans only, so `y: y` stays a name.
        let spec: serde_json::Value = crate::pipeline::spec::parse(f, &text).unwrap();
        let stages = spec["stages"].as_array().cloned().unwrap_or_default();
        let plots = stages.iter().filter(|s| s["kind"] == "plot");
        // The profiles the figure is built at: those of every experiment
        // it reads.
        let built: Vec<&str> = ["ci", "small", "paper"]
            .into_iter()
            .filter(|prof| {
                stages.iter().all(|st| {
                    let mut src: Vec<&str> = st["gather"]
                        .as_array()
                        .into_iter()
                        .flatten()
                        .filter_map(|v| v.as_str())
                        .collect();
                    src.extend(st["map"].as_str());
                    src.iter().all(|e| {
                        experiments
                            .get(*e)
                            .is_none_or(|ps: &Vec<String>| ps.iter().any(|q| q == prof))
                    })
                })
            })
            .collect();
        // The base parameters at every profile without its own, and each
        // profile's over them.
        let variants = plots.flat_map(|st| {
            let caption = synthetic_verdicts(st, &stages);
            let base = st["params"].clone();
            let own = st["profiles"].as_object().cloned().unwrap_or_default();
            let mut all = vec![];
            for prof in built.iter().filter(|q| !own.contains_key(**q)) {
                all.push((
                    format!("{} at {prof}", st["name"]),
                    base.clone(),
                    *prof,
                    caption.clone(),
                ));
            }
            for (profile, o) in &own {
                let mut v = base.clone();
                for (k, x) in o.as_object().unwrap() {
                    v[k] = x.clone();
                }
                let prof = ["ci", "small", "paper"]
                    .into_iter()
                    .find(|q| q == profile)
                    .unwrap();
                all.push((
                    format!("{} at {profile}", st["name"]),
                    v,
                    prof,
                    caption.clone(),
                ));
            }
            all
        });
        for (stage, params, profile, caption) in variants {
            found += 1;
            let mut p: super::PlotParams = serde_json::from_value(params)
                .unwrap_or_else(|e| panic!("{}: {stage}: {e}", f.display()));
            for ps in &mut p.panels {
                for l in &mut ps.layers {
                    l.filter = Default::default();
                }
            }
            let table = |layer: &super::Layer| {
                let ps = p
                    .panels
                    .iter()
                    .find(|ps| ps.layers.iter().any(|l| std::ptr::eq(l, layer)))
                    .unwrap();
                Ok(synthetic(layer, ps, &p.colour_ranges))
            };
            let fill = |t: &str| crate::table::references::render(t, &Placeholder(profile));
            let mut fig = super::build(&p, table, fill).unwrap();
            fig.profile = Some(profile.to_string());
            let fig = super::with_caption(fig, caption).unwrap();
            let name = f.file_name().unwrap().to_string_lossy().to_string();
            let paper = match name.as_str() {
                n if n.starts_with("intruder-fig") => Some("paper I"),
                n if n.starts_with("fig") => Some("paper H"),
                _ => None,
            };
            let columns = p
                .panels
                .iter()
                .flat_map(|ps| &ps.layers)
                .filter_map(|l| l.group.clone())
                .filter(|c| ["phi", "eps", "a"].contains(&c.as_str()));
            for column in columns.filter(|_| paper.is_some()) {
                let key = (paper.unwrap(), column.clone());
                match (p.colour_ranges.get(&column), ranges.get(&key)) {
                    (None, _) => bad.push(format!(
                        "{name} {stage}: groups by {column} without its colour range"
                    )),
                    (Some(r), Some((other, r0))) if r != r0 => bad.push(format!(
                        "{name} {stage}: colour range of {column} {r:?}, {other} has {r0:?}"
                    )),
                    (Some(&r), _) => {
                        ranges.entry(key).or_insert((name.clone(), r));
                    }
                }
            }
            // REPRO_PLOT_SAMPLES=dir: the synthetic figures, for looking at.
            if let Some(dir) = std::env::var_os("REPRO_PLOT_SAMPLES") {
                let stem = format!("spec-{}-{}", name.trim_end_matches(".yaml"), found);
                let dir = std::path::Path::new(&dir);
                crate::plot::draw(
                    &fig,
                    &dir.join(format!("{stem}.svg")),
                    &dir.join(format!("{stem}.png")),
                )
                .unwrap();
            }
            for d in crate::plot::defects(&fig).unwrap() {
                bad.push(format!("{name} {stage}: {d}"));
            }
        }
    }
    assert!(found >= 30, "only {found} plot stages in {}", dir.display());
    assert!(bad.is_empty(), "{} defects:\n{}", bad.len(), bad.join("\n"));
}

/// A layer of one ensemble's table (no eps column) drawn `at` its eps
/// takes that value's colour beside the other ensembles; an expected value
/// the layer leaves out is said in a note with the layer's reason.
#[test]
fn a_layer_at_one_group_value_and_an_absent_one() {
    let yaml = r#"
colour_ranges: {eps: [0.7, 1.0]}
panels:
  - x: {label: "size"}
    y: {label: "χ"}
    legend_title: "ε"
    layers:
      - {from: others, x: size, y: chi, group: eps, expect: [0.7, 0.8, 1.0], absent: "its fit is unreliable."}
      - {from: own, x: size, y: chi, group: eps, at: 0.9}
"#;
    let fig = figure_of(yaml, |layer| {
        let mut c = vec![
            ("size", vec![1.0, 2.0, 1.0, 2.0]),
            ("chi", vec![1.0, 2.0, 1.5, 2.5]),
        ];
        if layer.from == "others" {
            c.push(("eps", vec![0.7, 0.7, 0.8, 0.8]));
        }
        c
    });
    let s = &fig.panels[0].series;
    assert_eq!(s.len(), 3);
    assert_eq!(s[2].group.as_ref().unwrap().value, 0.9);
    assert_eq!(s[2].label, "0.90");
    assert_eq!(
        fig.panels[0].notes,
        ["The paper shows ε = 1.00; its fit is unreliable."]
    );
    assert!(crate::plot::defects(&fig).unwrap().is_empty());
}

/// `{=profile}` and `{=EXPERIMENT.PARAM}` print the build's own profile,
/// N and replicas (the planner's `build` parameter), so that a note is
/// true at every profile; the figure knows its profile.
#[test]
fn notes_state_the_build_they_are_drawn_on() {
    let yaml = r#"
build: {profile: small, experiments: {eps09_long: {n: 2000, replicas: 3, origins: 8, eps: 0.9}}, windows: {oz: {where_q_max: 0.6, where_phi: 0.78}}}
panels:
  - x: {label: "a"}
    y: {label: "ξ"}
    notes: ["A small box ({=profile}: N = {=eps09_long.n}, {=eps09_long.replicas} replicas, ε = {=eps09_long.eps}).", "OZ over q ≤ {=oz.where_q_max} at φ = {=oz.where_phi}."]
    layers: []
"#;
    let v: serde_json::Value = serde_saphyr::from_str(yaml).unwrap();
    let p: super::PlotParams = serde_json::from_value(v).unwrap();
    let fig = super::figure(&p, &[]).unwrap();
    assert_eq!(
        fig.panels[0].notes,
        [
            "A small box (small: N = 2000, 3 replicas, ε = 0.9).",
            "OZ over q ≤ 0.6 at φ = 0.78."
        ]
    );
    // A window the build does not have is an error, never a blank.
    let bad = r#"
build: {profile: small, windows: {oz: {where_q_max: 0.6}}}
panels:
  - x: {label: "a"}
    y: {label: "ξ"}
    notes: ["q ≤ {=oz.where_q_min}"]
    layers: []
"#;
    let v: serde_json::Value = serde_saphyr::from_str(bad).unwrap();
    let p: super::PlotParams = serde_json::from_value(v).unwrap();
    assert!(super::figure(&p, &[]).is_err());
    assert_eq!(fig.profile.as_deref(), Some("small"));
    assert!(crate::plot::defects(&fig).unwrap().is_empty());
}

#[test]
fn fitted_values_round_to_their_error() {
    assert_eq!(value_with_error(0.80342, 0.0123), "0.803 ± 0.012");
    assert_eq!(value_with_error(0.80342, 0.031), "0.80 ± 0.03");
    assert_eq!(value_with_error(1.622, 0.35), "1.6 ± 0.3");
    assert_eq!(value_with_error(241.3, 17.0), "241 ± 17");
    assert_eq!(value_with_error(241.3, 47.0), "241 ± 47");
    assert_eq!(value_with_error(0.6, f64::NAN), "0.60");
    assert_eq!(value_with_error(-1.3521, 0.061), "−1.35 ± 0.06");
    assert_eq!(value_with_error(f64::NAN, f64::NAN), "(no fit)");
    assert_eq!(crate::table::references::legend_number(29.333), "29");
    assert_eq!(crate::table::references::legend_number(0.785), "0.785");
    assert_eq!(crate::table::references::legend_number(7.333), "7.3");
    assert_eq!(crate::table::references::legend_number(1.4), "1.40");
}

/// `scale: auto` makes the longest arrow 0.9 of the grid step (here the
/// x step 2 of a 3 x 2 grid with y step 3; the longest vector is 5 long),
/// and is read from YAML beside a number; `scale: 0` is refused.
#[test]
fn a_velocity_field_panel_prints_its_arrow_scale() {
    let yaml = r#"
panels:
  - x: {label: "x"}
    y: {label: "z"}
    legend: none
    layers:
      - {from: field, x: x, y: "y", style: arrows, arrows: {dx: vx, dy: vy, scale: auto}}
"#;
    let v: serde_json::Value = serde_saphyr::from_str(yaml).unwrap();
    let p: super::PlotParams = serde_json::from_value(v).unwrap();
    let table = |_: &super::Layer| {
        let mut c = super::Columns::default();
        let mut put = |n: &str, v: Vec<f64>| c.f64.insert(n.to_string(), v);
        put("x", vec![0.0, 2.0, 0.0, 2.0]);
        put("y", vec![0.0, 0.0, 2.0, 2.0]);
        put("vx", vec![3.0, 0.0, 1.0, 0.0]);
        put("vy", vec![4.0, 1.0, 0.0, 0.0]);
        c.rows = 4;
        Ok(c)
    };
    let fig = super::build(&p, table, |t| Ok(t.to_string())).unwrap();
    // The longest vector (5) spans 0.9 of the grid step 2: scale 0.36.
    assert_eq!(
        fig.panels[0].notes,
        ["Arrows: (vx, vy) × 0.360 in units of x; the longest |(vx, vy)| = 5.00."]
    );
}

#[test]
fn auto_arrow_scale_fits_the_longest_arrow_in_a_grid_cell() {
    use super::{ArrowColumns, ArrowScale, AutoScale, auto_arrow_scale};
    let x = [0.0, 2.0, 4.0, 0.0, 2.0, 4.0];
    let y = [1.0, 1.0, 1.0, 4.0, 4.0, 4.0];
    let dx = [3.0, 0.0, 1.0, -1.0, 0.0, 0.0];
    let dy = [4.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    let rows: Vec<usize> = (0..6).collect();
    let k = auto_arrow_scale(&x, &y, &dx, &dy, &rows).unwrap();
    assert!((k - 0.9 * 2.0 / 5.0).abs() < 1e-12, "{k}");
    // Without the longest arrow the others grow to fill the cell.
    let k3 = auto_arrow_scale(&x, &y, &dx, &dy, &rows[1..]).unwrap();
    assert!((k3 - 0.9 * 2.0 / 1.0).abs() < 1e-12, "{k3}");
    assert!(auto_arrow_scale(&x, &y, &[0.0; 6], &[0.0; 6], &rows).is_none());
    // As a stage reads its parameters: YAML, then JSON values.
    let read = |s: &str| {
        let v: serde_json::Value = serde_saphyr::from_str(s).unwrap();
        serde_json::from_value::<ArrowColumns>(v)
    };
    let a = read("{dx: vx, dy: vy, scale: auto}").unwrap();
    assert_eq!(a.scale, ArrowScale::Named(AutoScale::Auto));
    let a = read("{dx: vx, dy: vy, scale: 2.5}").unwrap();
    assert_eq!(a.scale, ArrowScale::Fixed(2.5));
    assert!(read("{dx: vx, dy: vy, scale: big}").is_err());
    let e = read("{dx: vx, dy: vy, scale: big}")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("arrows.scale must be a number > 0 or `auto`"),
        "{e}"
    );
}

/// A group whose every point is NaN (a phi whose fit failed) draws nothing,
/// so it has no series and no legend entry.
#[test]
fn a_group_without_a_finite_point_has_no_legend_entry() {
    let yaml = r#"
panels:
  - x: {label: "N"}
    y: {label: "χ"}
    legend_title: "φ"
    layers:
      - {from: t, x: size, y: chi, group: phi}
"#;
    let fig = figure_of(yaml, |_| {
        vec![
            ("size", vec![1.0, 2.0, 1.0, 2.0]),
            ("chi", vec![1.0, 2.0, f64::NAN, f64::NAN]),
            ("phi", vec![0.80, 0.80, 0.805, 0.805]),
        ]
    });
    let s = &fig.panels[0].series;
    assert_eq!(
        s.len(),
        1,
        "{:?}",
        s.iter().map(|s| &s.label).collect::<Vec<_>>()
    );
    assert_eq!(s[0].label, "0.80");
}

/// The figure of the plot parameters `yaml` over the tables `columns` gives
/// per layer: columns by name, all of one length.
fn figure_of(
    yaml: &str,
    columns: impl Fn(&super::Layer) -> Vec<(&'static str, Vec<f64>)>,
) -> crate::plot::Figure {
    let v: serde_json::Value = serde_saphyr::from_str(yaml).unwrap();
    let p: super::PlotParams = serde_json::from_value(v).unwrap();
    let table = |layer: &super::Layer| {
        let mut c = super::Columns::default();
        for (name, v) in columns(layer) {
            c.rows = v.len();
            c.f64.insert(name.to_string(), v);
        }
        Ok(c)
    };
    super::build(&p, table, |t| Ok(t.to_string())).unwrap()
}

/// Stand-ins of a build for the layout check: the profile drawn, 7 for a
/// parameter and 0.50 ± 0.02 for a value (any length a real one has).
struct Placeholder<'a>(&'a str);

impl Lookup for Placeholder<'_> {
    fn resolve(&self, r: &Reference) -> anyhow::Result<Resolved> {
        Ok(match &r.target {
            Target::Profile => Resolved::Text(self.0.to_string()),
            Target::Field { field, .. } if field == "n" || field == "replicas" => {
                Resolved::Param(serde_json::json!(7))
            }
            Target::Field { .. } => Resolved::Number {
                value: 0.5,
                error: 0.02,
            },
        })
    }
}

/// The plot stage's judgement of a straight line fitted (by the crate's
/// least squares) through `y` at x = 0..n, the line drawn as a 200-point
/// curve over the points: the notes it adds.
fn line_through(y: &[f64]) -> Vec<String> {
    use crate::fit::{Data, linear::line};
    let x: Vec<f64> = (0..y.len()).map(|i| i as f64).collect();
    let f = line(Data::new(&x, y, &vec![1.0; y.len()])).unwrap();
    let (a, b) = (f.value("intercept"), f.value("slope"));
    let cx: Vec<f64> = (0..200)
        .map(|k| k as f64 * (y.len() - 1) as f64 / 199.0)
        .collect();
    let all = [
        crate::plot::Series {
            x: x.clone(),
            y: y.to_vec(),
            style: crate::plot::Style::Points,
            ..Default::default()
        },
        crate::plot::Series {
            label: "a + b x: b = 1".into(),
            y: cx.iter().map(|&x| a + b * x).collect(),
            x: cx,
            fit: true,
            ..Default::default()
        },
    ];
    let ps: super::PanelSpec =
        serde_json::from_value(serde_json::json!({"x": {"label": "φ"}, "y": {}, "layers": []}))
            .unwrap();
    super::systematic(&all, &[], &ps)
}

/// A straight line through a parabola misses its points systematically (a
/// run at each end and one in the middle) and says where; through noisy
/// straight data it does not, at a fixed seed and, over 2000 seeds, in
/// fewer than 1% of them (the test's level).
#[test]
fn a_line_through_a_curve_that_turns_is_flagged() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let parabola: Vec<f64> = (0..20).map(|i| (i as f64 - 9.5).powi(2)).collect();
    let notes = line_through(&parabola);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("a + b x misses its points systematically over φ in [")
            && notes[0].contains(": 3 runs of residual signs in 20 points"),
        "{}",
        notes[0]
    );
    let noisy = |seed: u64| -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..20)
            .map(|i| 1.0 + 2.0 * i as f64 + Distribution::<f64>::sample(&StandardNormal, &mut rng))
            .collect()
    };
    assert!(line_through(&noisy(7)).is_empty());
    let alarms = (0..2000u64)
        .filter(|&s| !line_through(&noisy(s)).is_empty())
        .count();
    assert!(alarms < 20, "{alarms} false alarms in 2000 seeds");
}

/// A scatter with several points at each x (clusters of one N_c) has no order
/// of its residual signs: it gets no runs note, where the same curve with one
/// point per x does.
#[test]
fn a_scatter_with_tied_x_is_not_judged_by_runs() {
    let curve = |x: &[f64]| crate::plot::Series {
        label: "a + b x: b = 1".into(),
        x: x.to_vec(),
        y: x.iter().map(|&x| x).collect(),
        fit: true,
        ..Default::default()
    };
    let points = |x: Vec<f64>, y: Vec<f64>| crate::plot::Series {
        x,
        y,
        style: crate::plot::Style::Points,
        ..Default::default()
    };
    let ps: super::PanelSpec =
        serde_json::from_value(serde_json::json!({"x": {"label": "N_c"}, "y": {}, "layers": []}))
            .unwrap();
    // Twelve points above the line y = x, twelve below, far from random order.
    let x: Vec<f64> = (0..24).map(|i| 1.0 + i as f64).collect();
    let y: Vec<f64> = x
        .iter()
        .map(|&x| if x <= 12.0 { x + 1.0 } else { x - 1.0 })
        .collect();
    let line = curve(&[0.0, 30.0]);
    assert_eq!(
        super::systematic(&[points(x, y), line.clone()], &[], &ps).len(),
        1
    );
    // The same signs at six x, four points each: no note.
    let x: Vec<f64> = (0..24).map(|i| 1.0 + (i / 4) as f64).collect();
    let y: Vec<f64> = (0..24)
        .map(|i| x[i] + if i < 12 { 1.0 } else { -1.0 })
        .collect();
    assert!(super::systematic(&[points(x, y), line], &[], &ps).is_empty());
}

/// Two ungrouped point series in one panel (one eta at two drives) and a
/// line fitted to one of them that misses its points in long runs: judged
/// against every point of the panel, the other series' points, which lie on
/// both sides in turn, break the runs and hide the miss; judged against the
/// layer its `points` names, it is flagged.
#[test]
fn a_fit_is_judged_against_the_layer_it_names() {
    let x: Vec<f64> = (0..16).map(|i| 1.0 + i as f64).collect();
    // Its own points: above the line over the middle, below at both ends.
    let own: Vec<f64> = x
        .iter()
        .map(|&x| x + if (4.0..=12.0).contains(&x) { 1.0 } else { -1.0 })
        .collect();
    // The other series at x + 0.5: alternating sides.
    let xo: Vec<f64> = x.iter().map(|&x| x + 0.5).collect();
    let other: Vec<f64> = xo
        .iter()
        .enumerate()
        .map(|(i, &x)| x + if i % 2 == 0 { 2.0 } else { -2.0 })
        .collect();
    let pts = |x: &[f64], y: Vec<f64>| crate::plot::Series {
        x: x.to_vec(),
        y,
        style: crate::plot::Style::Points,
        ..Default::default()
    };
    let line = crate::plot::Series {
        label: "fit".into(),
        x: vec![0.0, 20.0],
        y: vec![0.0, 20.0],
        fit: true,
        ..Default::default()
    };
    let all = [pts(&x, own), pts(&xo, other), line];
    let ps: super::PanelSpec =
        serde_json::from_value(serde_json::json!({"x": {"label": "F"}, "y": {}, "layers": []}))
            .unwrap();
    assert!(super::systematic(&all, &[], &ps).is_empty());
    let names = [
        (Some("hot".to_string()), None),
        (Some("cold".to_string()), None),
        (None, Some("hot".to_string())),
    ];
    let notes = super::systematic(&all, &names, &ps);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("fit misses its points systematically over F"),
        "{}",
        notes[0]
    );
}

/// A fit layer's `points` that names no layer of its panel is an error that
/// names the panel and the name, before any table is read.
#[test]
fn points_naming_no_layer_is_an_error() {
    let yaml = r#"
panels:
  - x: {label: "F"}
    y: {label: "v"}
    layers:
      - {from: hot, x: force, y: v, name: hot}
      - {from: fits, file: curve.parquet, x: force, y: v, points: cold}
"#;
    let v: serde_json::Value = serde_saphyr::from_str(yaml).unwrap();
    let p: super::PlotParams = serde_json::from_value(v).unwrap();
    let e = super::figure(&p, &[]).unwrap_err().to_string();
    assert!(e.contains("panel 1") && e.contains("`points: cold`"), "{e}");
}

/// A compare table gathered by the plot: one verdict line per paper value,
/// the short reason given in `short` where the verdict is not agree, the
/// first clause of the reason otherwise, none where it agrees unless a short
/// reason is given; the
/// provenance of the paper's value where the table has that column.
#[test]
fn verdict_lines_carry_paper_ours_verdict_and_short_reason() {
    use crate::pipeline::{Kind, StageCtx};
    use crate::stages::test_support::{artifact, yaml};
    use crate::table::results::quantity_batch;
    let dir = tempfile::tempdir().unwrap();
    let rows = [
        ("phi_c".to_string(), 0.805, 0.004),
        ("gamma".to_string(), 1.01, 0.06),
        ("nu".to_string(), 0.5, 0.1),
        ("d_f".to_string(), 1.13, 0.31),
    ];
    let fit = artifact(
        dir.path(),
        "fit",
        quantity_batch(&[], &rows, "", None).unwrap(),
    );
    let params = yaml(
        "paper:\n\
         - {quantity: phi_c, value: 0.82, tolerance: 0.01}\n\
         - {quantity: gamma, value: 1.19, tolerance: 0.05}\n\
         - {quantity: nu, value: 0.55, tolerance: 0.1}\n\
         - {quantity: d_f, value: 1.6, tolerance: 0.3}\n\
         out_of_reach: {phi_c: 'the box (see the frontier) of N = {=eps09.n} is too small; and more'}\n\
         short: {gamma: the range is too narrow, d_f: the power law is loosely fixed}\n",
    );
    let ctx = StageCtx::new(0, "compare".into(), None);
    let out = super::super::compare::Compare
        .run_params(&ctx, &params, &[fit])
        .unwrap();
    let mut compare = artifact(
        dir.path(),
        "compare",
        crate::table::read_parquet_bytes(out.files["parquet"].clone())
            .unwrap()
            .0
            .remove(0),
    );
    compare.kind = "compare".into();
    // The reason's reference to an experiment upstream prints as its value.
    let build = super::BuildInfo {
        profile: "ci".into(),
        experiments: [(
            "eps09".to_string(),
            [("n".to_string(), serde_json::json!(1000))].into(),
        )]
        .into(),
        windows: Default::default(),
    };
    let lines = super::verdicts(&[compare], &build, super::Against::Paper).unwrap();
    assert_eq!(
        lines,
        [
            "phi_c: paper 0.82; ours 0.805 ± 0.004; out of reach: the box of N = 1000 is too small",
            "gamma: paper 1.19; ours 1.01 ± 0.06; disagree: the range is too narrow",
            "nu: paper 0.55; ours 0.50 ± 0.10; agree",
            // Outside the tolerance by less than twice its error.
            "d_f: paper 1.60; ours 1.1 ± 0.3; unreliable: not resolved; the power law is loosely fixed",
        ]
    );
    let c = crate::table::results::Compared {
        quantity: "phi_c".into(),
        ours: 0.805,
        ours_err: 0.004,
        paper: 0.82,
        tolerance: 0.01,
        verdict: crate::table::results::Verdict::Disagree,
        reason: "x ".repeat(100),
        source: crate::table::results::Source::Ref12,
    };
    // A paper's value prints as written, not rounded like a legend's number.
    let v_cm = crate::table::results::Compared {
        quantity: "V_cm".into(),
        paper: 16.51,
        ..c.clone()
    };
    // An agreement with a short reason (a held input) says it.
    let held = crate::table::results::Compared {
        quantity: "g".into(),
        ours: 1.44,
        ours_err: 0.08,
        paper: 1.58,
        tolerance: 0.2,
        verdict: crate::table::results::Verdict::Agree,
        ..c.clone()
    };
    // A miss within twice its error and nothing more to say: not resolved.
    let bare = crate::table::results::Compared {
        verdict: crate::table::results::Verdict::Unreliable,
        reason: "|0.808 - 0.82| = 0.012 > 0.01, by 0.0022 ± 0.015, within twice its error: the disagreement is not resolved".into(),
        ours: 0.808,
        ours_err: 0.015,
        ..c.clone()
    };
    assert_eq!(
        super::verdict_line(&bare, "", "", super::Against::Paper),
        "phi_c: paper 0.82; ours 0.808 ± 0.015; unreliable: not resolved"
    );
    assert_eq!(
        super::verdict_line(&held, "held input, not a result", "", super::Against::Paper),
        "g: paper 1.58; ours 1.44 ± 0.08; agree: held input, not a result"
    );
    assert!(
        super::verdict_line(&v_cm, "", "", super::Against::Paper)
            .starts_with("V_cm: paper 16.51; "),
    );
    // A stability figure compares with the project's own target, and says so.
    assert!(
        super::verdict_line(&v_cm, "", "", super::Against::Target)
            .starts_with("V_cm: target 16.51; "),
        "{}",
        super::verdict_line(&v_cm, "", "", super::Against::Paper)
    );
    let line = super::verdict_line(&c, "", "quoted, ref. 12", super::Against::Paper);
    assert!(
        line.starts_with("phi_c: paper 0.82 (quoted, ref. 12); ours 0.805 ± 0.004; disagree: x x")
            && line.ends_with("x…")
            && line.chars().count()
                <= "phi_c: paper 0.82 (quoted, ref. 12); ours 0.805 ± 0.004; disagree: "
                    .chars()
                    .count()
                    + super::SHORT_CHARS
                    + 1,
        "{line}"
    );
    // A claim names what it is against, another quantity or a number.
    let claim = crate::table::results::Compared {
        quantity: "chi4P_a30".into(),
        ours: 2.8,
        ours_err: 0.7,
        paper: 3.3,
        tolerance: 0.0,
        verdict: crate::table::results::Verdict::Agree,
        reason: "paper states > chi4P_a06 (margin 0); ours 2.8 against 3.3".into(),
        source: crate::table::results::Source::Figure,
    };
    assert_eq!(
        super::verdict_line(&claim, "", "", super::Against::Paper),
        "chi4P_a30: paper > chi4P_a06 (3.30); ours 2.8 ± 0.7; agree"
    );
    let claim = crate::table::results::Compared {
        quantity: "reduced_chi2".into(),
        ours: 0.9,
        paper: 3.0,
        reason: "paper states < 3 (margin 0); ours 0.9 against 3".into(),
        ..claim
    };
    assert_eq!(
        super::verdict_line(&claim, "", "", super::Against::Paper),
        "reduced_chi2: paper < 3; ours 0.9 ± 0.7; agree"
    );
    // Where it disagrees, the claim is not said a second time as the reason.
    let claim = crate::table::results::Compared {
        ours: 13.0,
        verdict: crate::table::results::Verdict::Disagree,
        reason: "paper states < 3 (margin 0); ours 13 against 3".into(),
        ..claim
    };
    assert_eq!(
        super::verdict_line(&claim, "", "", super::Against::Paper),
        "reduced_chi2: paper < 3; ours 13.0 ± 0.7; disagree"
    );
    // A bound the paper gives no number for is the project's criterion.
    let criterion = crate::table::results::Compared {
        reason: "our criterion < 3 (margin 0); ours 13 against 3".into(),
        ..claim.clone()
    };
    assert_eq!(
        super::verdict_line(&criterion, "", "", super::Against::Paper),
        "reduced_chi2: criterion < 3; ours 13.0 ± 0.7; disagree"
    );
    // A miss with a caveat: the caveat's first clause, not the arithmetic.
    let miss = crate::table::results::Compared {
        quantity: "gamma".into(),
        ours: 0.7,
        ours_err: 0.1,
        paper: 1.6,
        tolerance: 0.3,
        verdict: crate::table::results::Verdict::Disagree,
        reason: "|0.7 - 1.6| = 0.9 > 0.3; the box is too small (panel c); more".into(),
        source: crate::table::results::Source::Figure,
    };
    assert_eq!(
        super::verdict_line(&miss, "", "", super::Against::Paper),
        "gamma: paper 1.60; ours 0.70 ± 0.10; disagree: the box is too small"
    );
    // A fit's note that opens with the verdict prints it once.
    let c = crate::table::results::Compared {
        verdict: crate::table::results::Verdict::Unreliable,
        reason: "unreliable: phi_c = 0.789 falls on the last point; more".into(),
        ..c
    };
    assert_eq!(
        super::verdict_line(&c, "", "", super::Against::Paper),
        "phi_c: paper 0.82; ours 0.805 ± 0.004; unreliable: phi_c = 0.789 falls on the last point"
    );
}

/// `offset`: the k-th group value's curve (ascending) drawn k steps apart,
/// each with a dotted, unlabelled line of its colour at its shifted level;
/// a layer without a group column is refused.
#[test]
fn an_offset_stacks_the_groups_apart() {
    let yaml = r#"
panels:
  - x: {label: "t"}
    y: {label: "P"}
    legend_title: "φ"
    layers:
      - {from: t, x: t, y: p, group: phi, style: line, offset: {step: -0.5, line: 1.0}}
"#;
    // Listed out of order: the rank is that of the value, not of the row.
    let fig = figure_of(yaml, |_| {
        vec![
            ("t", vec![0.0, 1.0, 0.0, 1.0, 0.0, 2.0]),
            ("p", vec![1.0, 1.5, 2.0, 2.5, 3.0, 3.5]),
            ("phi", vec![0.78, 0.78, 0.60, 0.60, 0.70, 0.70]),
        ]
    });
    let s = &fig.panels[0].series;
    let data: Vec<(&str, Vec<f64>)> = s
        .iter()
        .filter(|s| !s.fit)
        .map(|s| (s.label.as_str(), s.y.clone()))
        .collect();
    assert_eq!(
        data,
        vec![
            ("0.60", vec![2.0, 2.5]),
            ("0.70", vec![2.5, 3.0]),
            ("0.78", vec![0.0, 0.5]),
        ]
    );
    let lines: Vec<(Vec<f64>, Vec<f64>, f64)> = s
        .iter()
        .filter(|s| s.fit)
        .map(|s| {
            assert!(s.dotted && s.label.is_empty());
            (s.x.clone(), s.y.clone(), s.group.as_ref().unwrap().value)
        })
        .collect();
    assert_eq!(
        lines,
        vec![
            (vec![0.0, 1.0], vec![1.0, 1.0], 0.60),
            (vec![0.0, 2.0], vec![0.5, 0.5], 0.70),
            (vec![0.0, 1.0], vec![0.0, 0.0], 0.78),
        ]
    );
    let v: serde_json::Value = serde_saphyr::from_str(
        "panels: [{x: {}, y: {}, layers: [{from: t, x: t, y: p, offset: {step: 1}}]}]",
    )
    .unwrap();
    let p: super::PlotParams = serde_json::from_value(v).unwrap();
    let table = |_: &super::Layer| {
        let mut c = super::Columns::default();
        c.f64.insert("t".into(), vec![0.0]);
        c.f64.insert("p".into(), vec![1.0]);
        c.rows = 1;
        Ok(c)
    };
    let e = super::build(&p, table, |t| Ok(t.to_string())).unwrap_err();
    assert!(format!("{e:#}").contains("offset"), "{e:#}");
}
