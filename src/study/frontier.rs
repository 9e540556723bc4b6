//! Speed against accuracy (`repro frontier`): a figure rebuilt from variants of
//! the catalogue (N, replicas, master seed); each key number's seed-to-seed mean
//! and spread against the CPU seconds of all its stages.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use super::results::{nan_as_null, provenance, read_compare};
use super::variant::{self, Variant};
use crate::pipeline::RunOptions;

/// One frontier configuration's outcome for one quantity.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrontierRow {
    pub n: usize,
    pub replicas: u64,
    pub quantity: String,
    #[serde(deserialize_with = "nan_as_null::one")]
    pub mean: f64,
    #[serde(deserialize_with = "nan_as_null::one")]
    pub spread: f64,
    pub paper: f64,
    pub tolerance: f64,
    #[serde(deserialize_with = "nan_as_null::one")]
    pub cpu_s: f64,
    /// Per master seed.
    #[serde(with = "nan_as_null")]
    pub values: Vec<f64>,
    /// The configuration's name (e.g. the frame schedule), empty for the base.
    #[serde(default)]
    pub label: String,
    /// Bytes of the stored trajectories of one seed (all points and replicas).
    #[serde(default)]
    pub trajectory_bytes: f64,
}

/// What a frontier run varies.
pub struct Frontier<'a> {
    pub root: &'a Path,
    pub experiment: &'a str,
    pub profile: &'a str,
    pub id: &'a str,
    pub n: &'a [usize],
    pub replicas: &'a [u64],
    pub seeds: &'a [u64],
    /// Profile parameters set in every configuration (e.g. a frame schedule).
    pub set: &'a BTreeMap<String, serde_json::Value>,
    /// Name of these configurations in the table and chart.
    pub label: &'a str,
}

/// Bytes of the trajectories (outputs of the kinds that hold one) a built figure read.
fn trajectory_bytes(root: &Path, dir: &Path) -> Result<f64> {
    let path = dir.join("provenance.json");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path)?)?;
    let store = crate::pipeline::Store::open(&crate::pipeline::Workspace::new(root).store)?;
    let registry = crate::stages::registry();
    let mut total = 0.0;
    for st in v["stages"].as_array().into_iter().flatten() {
        if st["kind"]
            .as_str()
            .is_some_and(|k| registry.holds(k) == crate::pipeline::stage::Holds::Trajectory)
            && let Some(h) = st["files"]["parquet"].as_str()
        {
            total += std::fs::metadata(store.object_path(h))?.len() as f64;
        }
    }
    Ok(total)
}

/// Build every configuration at every seed; one row per (configuration, quantity).
pub fn measure(f: &Frontier, opts: &RunOptions) -> Result<Vec<FrontierRow>> {
    let ids = vec![f.id.to_string()];
    let mut rows: Vec<FrontierRow> = Vec::new();
    for &n in f.n {
        for &r in f.replicas {
            let mut per_q: BTreeMap<String, (Vec<f64>, f64, f64)> = BTreeMap::new();
            let mut cpu = Vec::new();
            let mut bytes = Vec::new();
            for &seed in f.seeds {
                let v = Variant {
                    seed: Some(seed),
                    n: Some(n),
                    replicas: Some(r),
                    set: f.set.clone(),
                };
                eprintln!("frontier {}: N = {n}, replicas = {r}, seed {seed}", f.id);
                let built = variant::build(f.root, f.experiment, f.profile, &v, &ids, opts)?;
                let dir = built.results.join(f.id);
                cpu.push(provenance(&dir)?.cpu_s);
                bytes.push(trajectory_bytes(f.root, &dir)?);
                for c in read_compare(&dir)? {
                    let e = per_q
                        .entry(c.quantity)
                        .or_insert((vec![], c.paper, c.tolerance));
                    e.0.push(c.ours);
                }
            }
            let cpu_s = cpu.iter().sum::<f64>() / cpu.len() as f64;
            let trajectory_bytes = bytes.iter().sum::<f64>() / bytes.len() as f64;
            for (q, (vals, paper, tol)) in per_q {
                let (mean, spread) = crate::analysis::stats::mean_std(&vals);
                rows.push(FrontierRow {
                    n,
                    replicas: r,
                    quantity: q,
                    mean,
                    spread,
                    paper,
                    tolerance: tol,
                    cpu_s,
                    values: vals,
                    label: f.label.to_string(),
                    trajectory_bytes,
                });
            }
        }
    }
    Ok(rows)
}

/// Write `out/ID-PROFILE.{parquet,json,svg,png}` with `new` and the rows of
/// other labels already there (so configurations measured by separate runs, e.g.
/// two frame schedules, share one table and chart); returns every row.
pub fn write(
    out: &Path,
    id: &str,
    profile: &str,
    seeds: &[u64],
    new: &[FrontierRow],
) -> Result<Vec<FrontierRow>> {
    let stem = out.join(format!("{id}-{profile}"));
    std::fs::create_dir_all(out)?;
    let mut rows: Vec<FrontierRow> = match std::fs::read(stem.with_extension("json")) {
        Ok(b) => serde_json::from_slice::<Vec<FrontierRow>>(&b)
            .with_context(|| format!("parsing {}", stem.with_extension("json").display()))?
            .into_iter()
            .filter(|r| new.iter().all(|n| n.label != r.label))
            .collect(),
        Err(_) => Vec::new(),
    };
    rows.extend(new.iter().cloned());
    let rows = &rows[..];
    let b = crate::table::f64_batch(&[
        ("N", rows.iter().map(|r| r.n as f64).collect()),
        ("replicas", rows.iter().map(|r| r.replicas as f64).collect()),
        ("mean", rows.iter().map(|r| r.mean).collect()),
        ("spread", rows.iter().map(|r| r.spread).collect()),
        ("paper", rows.iter().map(|r| r.paper).collect()),
        ("tolerance", rows.iter().map(|r| r.tolerance).collect()),
        ("cpu_s", rows.iter().map(|r| r.cpu_s).collect()),
        (
            "trajectory_bytes",
            rows.iter().map(|r| r.trajectory_bytes).collect(),
        ),
    ])?;
    let l =
        arrow_array::StringArray::from(rows.iter().map(|r| r.label.clone()).collect::<Vec<_>>());
    let q =
        arrow_array::StringArray::from(rows.iter().map(|r| r.quantity.clone()).collect::<Vec<_>>());
    let b = {
        let schema = b.schema();
        let mut cols: Vec<(&str, arrow_array::ArrayRef)> = vec![
            ("label", std::sync::Arc::new(l)),
            ("quantity", std::sync::Arc::new(q)),
        ];
        for (f, c) in schema.fields().iter().zip(b.columns()) {
            cols.push((f.name().as_str(), c.clone()));
        }
        arrow_array::RecordBatch::try_from_iter(cols)?
    };
    crate::table::write_parquet(
        &stem.with_extension("parquet"),
        &[b],
        &[("seeds", &format!("{seeds:?}"))],
    )?;
    std::fs::write(
        stem.with_extension("json"),
        serde_json::to_string_pretty(&rows)?,
    )?;
    let fig = chart(&format!("{id} ({profile})"), rows);
    crate::plot::draw(
        &fig,
        &stem.with_extension("svg"),
        &stem.with_extension("png"),
    )?;
    Ok(rows.to_vec())
}

/// The cheapest configuration whose every quantity is within the paper's
/// tolerance, with a seed spread inside it too.
pub fn smallest(rows: &[FrontierRow]) -> String {
    let mut configs: BTreeMap<(usize, u64, &str), (f64, bool)> = BTreeMap::new();
    for r in rows {
        let ok = (r.mean - r.paper).abs() <= r.tolerance && r.spread <= r.tolerance;
        let e = configs
            .entry((r.n, r.replicas, r.label.as_str()))
            .or_insert((r.cpu_s, true));
        e.1 &= ok;
    }
    match configs
        .iter()
        .filter(|(_, (_, ok))| *ok)
        .min_by(|a, b| a.1.0.total_cmp(&b.1.0))
    {
        Some(((n, r, label), (cpu, _))) => format!(
            "smallest configuration within the paper's tolerance: N = {n}, replicas = {r}{} ({cpu:.1} CPU s)",
            if label.is_empty() {
                String::new()
            } else {
                format!(", {label}")
            }
        ),
        None => "no configuration tried reproduces every key number within the paper's tolerance"
            .to_string(),
    }
}

/// A key number's name as a chart label: Greek names as letters, short
/// suffixes as subscripts, `_over_` as a fraction bar, other words spaced
/// (`gamma_chi_over_gamma_xi` -> γ_{χ}/γ_{ξ}, `phi_0` -> φ_{0},
/// `tau4_exponent` -> τ4 exponent).
fn symbol(name: &str) -> String {
    const GREEK: [(&str, &str); 20] = [
        ("alpha", "α"),
        ("beta", "β"),
        ("gamma", "γ"),
        ("delta", "δ"),
        ("epsilon", "ε"),
        ("eps", "ε"),
        ("eta", "η"),
        ("theta", "θ"),
        ("kappa", "κ"),
        ("lambda", "λ"),
        ("mu", "μ"),
        ("nu", "ν"),
        ("xi", "ξ"),
        ("rho", "ρ"),
        ("sigma", "σ"),
        ("tau", "τ"),
        ("phi", "φ"),
        ("chi", "χ"),
        ("psi", "ψ"),
        ("omega", "ω"),
    ];
    // A Greek name, possibly followed by digits (tau4, chi2).
    let letter = |w: &str| {
        let stem = w.trim_end_matches(|c: char| c.is_ascii_digit());
        GREEK
            .iter()
            .find(|(g, _)| *g == stem)
            .map(|(_, l)| format!("{l}{}", &w[stem.len()..]))
    };
    let part = |p: &str| {
        let mut words = p.split('_').filter(|w| !w.is_empty());
        let mut out = match words.next() {
            Some("minus") => "−".to_string(),
            Some(w) => letter(w).unwrap_or_else(|| w.to_string()),
            None => String::new(),
        };
        let mut subs: Vec<String> = vec![];
        for w in words {
            if w == "prime" {
                out.push('′');
                continue;
            }
            match letter(w) {
                // After a lone minus sign the next name is the symbol itself.
                Some(l) if out == "−" => out.push_str(&l),
                Some(l) => subs.push(l),
                None if w.len() <= 2 => subs.push(w.to_string()),
                None => {
                    if !subs.is_empty() {
                        out.push_str(&format!("_{{{}}}", subs.join(",")));
                        subs.clear();
                    }
                    out.push(' ');
                    out.push_str(w);
                }
            }
        }
        if !subs.is_empty() {
            out.push_str(&format!("_{{{}}}", subs.join(",")));
        }
        out
    };
    name.split("_over_").map(part).collect::<Vec<_>>().join("/")
}

fn chart(id: &str, rows: &[FrontierRow]) -> crate::plot::Figure {
    use crate::plot::{Axis, Figure, Legend, Marker, Palette, Panel, RefLine, Series, Style};
    let mut qs: Vec<&str> = rows.iter().map(|r| r.quantity.as_str()).collect();
    qs.sort();
    qs.dedup();
    let panels: Vec<Panel> = qs
        .iter()
        .map(|q| {
            let mine: Vec<&FrontierRow> = rows.iter().filter(|r| r.quantity == *q).collect();
            let mut reps: Vec<(&str, u64)> = mine
                .iter()
                .map(|r| (r.label.as_str(), r.replicas))
                .collect();
            reps.sort();
            reps.dedup();
            let series = reps
                .iter()
                .map(|&(label, rep)| {
                    let mut pts: Vec<&&FrontierRow> = mine
                        .iter()
                        .filter(|r| r.replicas == rep && r.label == label)
                        .collect();
                    pts.sort_by(|a, b| a.cpu_s.total_cmp(&b.cpu_s));
                    Series {
                        label: format!(
                            "{}{rep} replicas, N = {}",
                            if label.is_empty() {
                                String::new()
                            } else {
                                format!("{label}: ")
                            },
                            pts.iter()
                                .map(|r| r.n.to_string())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                        x: pts.iter().map(|r| r.cpu_s).collect(),
                        y: pts.iter().map(|r| r.mean).collect(),
                        y_err: Some(pts.iter().map(|r| r.spread).collect()),
                        style: Style::LinePoints,
                        dashed: false,
                        color: None,
                        marker: Marker::Circle,
                        radius: None,
                        arrows: None,
                        ..Default::default()
                    }
                })
                .collect();
            let paper = mine.first().map(|r| r.paper).unwrap_or(f64::NAN);
            let tol = mine.first().map(|r| r.tolerance).unwrap_or(f64::NAN);
            // Show the paper's band even when every configuration misses it.
            let (lo, hi) = mine.iter().fold((paper - tol, paper + tol), |(lo, hi), r| {
                (lo.min(r.mean - r.spread), hi.max(r.mean + r.spread))
            });
            let pad = 0.08 * (hi - lo).max(1e-9);
            let range = (lo.is_finite() && hi.is_finite()).then_some((lo - pad, hi + pad));
            Panel {
                title: format!("{id}: {}", symbol(q)),
                x: Axis {
                    label: "CPU seconds (all stages)".into(),
                    log: true,
                    range: None,
                    from_zero: false,
                },
                y: Axis {
                    label: symbol(q),
                    log: false,
                    range,
                    from_zero: false,
                },
                series,
                // The paper's value and its tolerance band: the distance to
                // the paper reads off against the band, the spread as error bars.
                hlines: vec![RefLine {
                    at: paper,
                    label: "paper ± tolerance".into(),
                    dashed: true,
                    color: Some(crate::plot::Color([0, 0, 0])),
                    band: (tol > 0.0).then_some(tol),
                }],
                vlines: vec![],
                legend: Legend::Auto,
                legend_title: String::new(),
                palette: Palette::Categorical,
                ..Default::default()
            }
        })
        .collect();
    let n = panels.len().max(1) as u32;
    // Room for a legend of labelled configurations beside the data.
    Figure {
        title: String::new(),
        panels,
        columns: None,
        width: 640 * n,
        height: 400,
        colour_ranges: Default::default(),
        profile: None,
        caption: vec![],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smallest_configuration_needs_every_quantity_within_tolerance() {
        let row = |n, q: &str, mean, spread, cpu| FrontierRow {
            n,
            replicas: 2,
            quantity: q.into(),
            mean,
            spread,
            paper: 0.82,
            tolerance: 0.01,
            cpu_s: cpu,
            values: vec![],
            label: String::new(),
            trajectory_bytes: 0.0,
        };
        let rows = vec![
            row(500, "phi_c", 0.79, 0.005, 1.0),
            row(1000, "phi_c", 0.815, 0.005, 2.0),
            row(1000, "phi_0", 0.80, 0.005, 2.0),
            row(2000, "phi_c", 0.82, 0.002, 4.0),
            row(2000, "phi_0", 0.825, 0.002, 4.0),
        ];
        assert!(smallest(&rows).contains("N = 2000"), "{}", smallest(&rows));
        assert!(smallest(&rows[..1]).starts_with("no configuration"));
    }

    /// The chart a referee reads: key-number names typeset (no `phi_0`), the
    /// paper's label free of the legend and the data, two x tick labels.
    #[test]
    fn the_chart_has_no_defects() {
        assert_eq!(symbol("gamma_chi_over_gamma_xi"), "γ_{χ}/γ_{ξ}");
        assert_eq!(symbol("phi_0"), "φ_{0}");
        assert_eq!(symbol("minus_theta_prime"), "−θ′");
        assert_eq!(symbol("tau4_exponent"), "τ4 exponent");
        assert_eq!(symbol("d_f_a06"), "d_{f} a06");
        let row = |n, q: &str, mean, spread, cpu| FrontierRow {
            n,
            replicas: 2,
            quantity: q.into(),
            mean,
            spread,
            paper: 1.56,
            tolerance: 0.3,
            cpu_s: cpu,
            values: vec![],
            label: String::new(),
            trajectory_bytes: 0.0,
        };
        let rows: Vec<FrontierRow> = ["gamma_chi_over_gamma_xi", "phi_0", "collapse_S"]
            .iter()
            .flat_map(|q| {
                [
                    row(500, q, 0.73, 0.04, 12.0),
                    row(1000, q, 1.04, 0.2, 26.0),
                    row(2000, q, 1.14, 0.19, 52.0),
                ]
            })
            .collect();
        let fig = chart("fig19 (ci)", &rows);
        assert_eq!(crate::plot::defects(&fig).unwrap(), Vec::<String>::new());
    }
}
