//! `repro regress` (CI regression of the figures' key numbers against committed
//! golden values) and `repro frontier` (accuracy of the key numbers against their
//! CPU cost over system sizes and replicas).
//!
//! Both run figures from *variants* of the specs: a temporary copy of
//! `experiments/` and `pipelines/` in which one experiment's master seed, N,
//! replicas or origins are changed. The cache store is shared with the project,
//! so a variant already computed is not recomputed.

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use arrow_array::{Array, Float64Array, StringArray};
use clap::{Args, Subcommand};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::pipeline::{self, RunOptions, Workspace};

#[derive(Subcommand, Debug)]
pub enum Commands {
    /// Check the key numbers of built figures (results/ID: compare.parquet and the
    /// fit tables) against the golden bands in tests/golden/PROFILE.json; exit
    /// non-zero naming figure,
    /// quantity, value and band on any regression. With --record, rebuild the
    /// goldens from several master seeds instead.
    Regress(RegressArgs),
    /// Speed against accuracy: rebuild a figure at several N and replica counts
    /// with several seeds; table and chart of its key numbers (seed-to-seed
    /// spread) against CPU seconds, in results/frontier/.
    Frontier(FrontierArgs),
}

#[derive(Args, Debug)]
pub struct RegressArgs {
    /// Figures to check (default: every figure in the golden file).
    #[arg(value_name = "ID")]
    pub ids: Vec<String>,
    #[arg(long, default_value = "ci")]
    pub profile: String,
    /// Golden file (default: tests/golden/PROFILE.json under the root).
    #[arg(long)]
    pub golden: Option<PathBuf>,
    /// Rebuild the golden file: run the figures at each of these master seeds.
    #[arg(long)]
    pub record: bool,
    #[arg(long, value_delimiter = ',', default_values_t = [1u64, 2, 3, 4, 5])]
    pub seeds: Vec<u64>,
    /// With --record: key numbers left out of the bands (FIGURE:QUANTITY), e.g. fits
    /// that the profile cannot resolve and whose seed-to-seed scatter is heavy-tailed.
    #[arg(long, value_delimiter = ',')]
    pub ungated: Vec<String>,
    /// The experiment whose seed --record varies.
    #[arg(long, default_value = "eps09")]
    pub experiment: String,
    #[arg(long)]
    pub jobs: Option<usize>,
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub root: PathBuf,
}

#[derive(Args, Debug)]
pub struct FrontierArgs {
    /// The figure (e.g. fig4, fig19).
    pub id: String,
    /// Profile whose grid and run lengths are the base of every variant.
    #[arg(long, default_value = "ci")]
    pub profile: String,
    #[arg(long, value_delimiter = ',', default_values_t = [500usize, 1000, 2000])]
    pub n: Vec<usize>,
    #[arg(long, value_delimiter = ',', default_values_t = [2u64])]
    pub replicas: Vec<u64>,
    /// Master seeds of each configuration (the spread between them is the error).
    #[arg(long, value_delimiter = ',', default_values_t = [1u64, 2, 3])]
    pub seeds: Vec<u64>,
    #[arg(long, default_value = "eps09")]
    pub experiment: String,
    #[arg(long)]
    pub jobs: Option<usize>,
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub root: PathBuf,
}

/// One key number as `compare` reported it.
#[derive(Clone, Debug)]
pub struct Compared {
    pub quantity: String,
    pub ours: f64,
    pub paper: f64,
    pub tolerance: f64,
}

/// Read `results/ID/compare.parquet`.
pub fn read_compare(dir: &Path) -> Result<Vec<Compared>> {
    let path = dir.join("compare.parquet");
    let (batches, _) = crate::table::read_parquet(&path)?;
    let mut out = Vec::new();
    for b in batches {
        let s = |n: &str| -> Result<&StringArray> {
            b.column_by_name(n)
                .and_then(|c| c.as_any().downcast_ref::<StringArray>())
                .with_context(|| format!("{}: no string column '{n}'", path.display()))
        };
        let f = |n: &str| -> Result<&Float64Array> {
            b.column_by_name(n)
                .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
                .with_context(|| format!("{}: no float column '{n}'", path.display()))
        };
        let (q, o, p, t) = (s("quantity")?, f("ours")?, f("paper")?, f("tolerance")?);
        for i in 0..b.num_rows() {
            out.push(Compared {
                quantity: q.value(i).to_string(),
                ours: if o.is_null(i) { f64::NAN } else { o.value(i) },
                paper: p.value(i),
                tolerance: t.value(i),
            });
        }
    }
    Ok(out)
}

/// Every key number of a built figure: the `ours` column of compare.parquet and
/// the `value` of every published fit table (quantity, value, error), by name.
pub fn key_numbers(dir: &Path) -> Result<BTreeMap<String, f64>> {
    let mut out = BTreeMap::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension().is_some_and(|x| x == "parquet") && !p.ends_with("compare.parquet")
        })
        .collect();
    files.sort();
    for f in files {
        let (batches, _) = crate::table::read_parquet(&f)?;
        for b in batches {
            let q = b
                .column_by_name("quantity")
                .and_then(|c| c.as_any().downcast_ref::<StringArray>());
            let v = b
                .column_by_name("value")
                .and_then(|c| c.as_any().downcast_ref::<Float64Array>());
            if let (Some(q), Some(v)) = (q, v) {
                for i in 0..b.num_rows() {
                    out.insert(
                        q.value(i).to_string(),
                        if v.is_null(i) { f64::NAN } else { v.value(i) },
                    );
                }
            }
        }
    }
    if dir.join("compare.parquet").exists() {
        for c in read_compare(dir)? {
            out.insert(c.quantity, c.ours);
        }
    }
    Ok(out)
}

/// The profile a published figure was built at, and the CPU seconds of all its stages.
fn provenance(dir: &Path) -> Result<(String, f64)> {
    let path = dir.join("provenance.json");
    let v: Value = serde_json::from_slice(
        &std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?,
    )?;
    let profile = v["profile"].as_str().unwrap_or("").to_string();
    let cpu = v["stages"]
        .as_array()
        .map(|s| s.iter().filter_map(|x| x["cpu_s"].as_f64()).sum())
        .unwrap_or(f64::NAN);
    Ok((profile, cpu))
}

/// Changes to one experiment of a spec variant.
#[derive(Clone, Debug, Default)]
pub struct Variant {
    pub seed: Option<u64>,
    pub n: Option<usize>,
    pub replicas: Option<u64>,
}

/// A copy of the specs under `root` with `experiment` changed, in a temporary
/// directory; the returned workspace shares the project's cache store.
pub fn variant_workspace(
    root: &Path,
    experiment: &str,
    profile: &str,
    v: &Variant,
) -> Result<(tempfile::TempDir, Workspace)> {
    let tmp = tempfile::tempdir().context("creating a temporary spec directory")?;
    for sub in ["experiments", "pipelines"] {
        let dst = tmp.path().join(sub);
        std::fs::create_dir_all(&dst)?;
        for e in std::fs::read_dir(root.join(sub))
            .with_context(|| format!("listing {}/{sub}", root.display()))?
        {
            let p = e?.path();
            if p.extension().is_some_and(|x| x == "yaml") {
                std::fs::copy(&p, dst.join(p.file_name().unwrap()))?;
            }
        }
    }
    let file = tmp
        .path()
        .join("experiments")
        .join(format!("{experiment}.yaml"));
    let text = std::fs::read_to_string(&file).with_context(|| {
        format!(
            "no experiment '{experiment}' (experiments/{experiment}.yaml) under {}",
            root.display()
        )
    })?;
    let mut spec: Value =
        serde_saphyr::from_str(&text).with_context(|| format!("parsing {}", file.display()))?;
    if let Some(s) = v.seed {
        spec["seed"] = Value::from(s);
    }
    let prof = spec
        .get_mut("profiles")
        .and_then(|p| p.get_mut(profile))
        .with_context(|| format!("experiment '{experiment}' has no profile '{profile}'"))?;
    if let Some(r) = v.replicas {
        prof["replicas"] = Value::from(r);
    }
    if let Some(n) = v.n {
        if prof.get("params").is_none() {
            prof["params"] = Value::Object(Default::default());
        }
        prof["params"]["n"] = Value::from(n);
    }
    // JSON is YAML 1.2: the variant is written as JSON.
    std::fs::write(&file, serde_json::to_string_pretty(&spec)?)?;
    let mut ws = Workspace::new(tmp.path());
    ws.store = Workspace::new(root).store;
    Ok((tmp, ws))
}

fn options(jobs: Option<usize>) -> RunOptions {
    let mut o = RunOptions {
        progress: std::io::stderr().is_terminal(),
        ..RunOptions::default()
    };
    if let Some(j) = jobs {
        o.jobs = j.max(1);
    }
    o
}

/// Build `ids` in workspace `ws`; error if any stage failed.
fn build(ws: &Workspace, ids: &[String], profile: &str, jobs: Option<usize>) -> Result<()> {
    let run = pipeline::run_figures(ws, &super::registry(), ids, profile, &options(jobs))?;
    run.check()
}

/// Golden values of one quantity of one figure.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Golden {
    pub figure: String,
    pub quantity: String,
    pub seeds: Vec<u64>,
    /// Per seed; a seed whose fit gave no number is NaN, written as `null`.
    #[serde(with = "nan_as_null")]
    pub values: Vec<f64>,
    pub mean: f64,
    pub std: f64,
    pub band: [f64; 2],
}

/// JSON has no NaN: serde_json writes it as `null`, which must read back as NaN.
mod nan_as_null {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let o: Vec<Option<f64>> = v.iter().map(|x| x.is_finite().then_some(*x)).collect();
        o.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let o = Vec::<Option<f64>>::deserialize(d)?;
        Ok(o.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GoldenFile {
    pub profile: String,
    pub how: String,
    pub sigmas: f64,
    pub relative_floor: f64,
    pub quantities: Vec<Golden>,
}

/// Band = mean +- max(sigmas x seed-to-seed standard deviation, relative_floor x |mean|).
pub fn golden(
    figure: &str,
    quantity: &str,
    seeds: &[u64],
    values: &[f64],
    sigmas: f64,
    floor: f64,
) -> Golden {
    let ok: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let n = ok.len() as f64;
    let mean = ok.iter().sum::<f64>() / n;
    let std = if ok.len() > 1 {
        (ok.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    };
    let half = (sigmas * std).max(floor * mean.abs());
    Golden {
        figure: figure.into(),
        quantity: quantity.into(),
        seeds: seeds.to_vec(),
        values: values.to_vec(),
        mean,
        std,
        band: [mean - half, mean + half],
    }
}

/// One line per quantity; the failures (figure, quantity, value, band).
pub fn check(g: &GoldenFile, results: &Path, ids: &[String]) -> Result<(Vec<String>, Vec<String>)> {
    let mut lines = Vec::new();
    let mut failures = Vec::new();
    let mut by_fig: BTreeMap<&str, Vec<&Golden>> = BTreeMap::new();
    for q in &g.quantities {
        if ids.is_empty() || ids.contains(&q.figure) {
            by_fig.entry(&q.figure).or_default().push(q);
        }
    }
    for id in ids {
        if !by_fig.contains_key(id.as_str()) {
            bail!("the golden file has no quantity of figure '{id}'");
        }
    }
    for (fig, qs) in by_fig {
        let dir = results.join(fig);
        let (profile, _) = provenance(&dir).with_context(|| {
            format!(
                "{fig}: no built figure in {}; run `repro figure {fig} --profile {}` first",
                dir.display(),
                g.profile
            )
        })?;
        if profile != g.profile {
            bail!(
                "{fig}: {} was built at profile '{profile}', the goldens are for '{}'; run `repro figure {fig} --profile {}`",
                dir.display(),
                g.profile,
                g.profile
            );
        }
        let got = key_numbers(&dir)?;
        for q in qs {
            let v = got.get(&q.quantity).copied().unwrap_or(f64::NAN);
            let inside = v >= q.band[0] && v <= q.band[1];
            let line = format!(
                "{fig} {}: {v:.5} {} band [{:.5}, {:.5}] (golden mean {:.5}, seed-to-seed std {:.5})",
                q.quantity,
                if inside { "inside" } else { "OUTSIDE" },
                q.band[0],
                q.band[1],
                q.mean,
                q.std
            );
            if !inside {
                failures.push(format!(
                    "regression in {fig}: {} = {v:.5} is outside the band [{:.5}, {:.5}]",
                    q.quantity, q.band[0], q.band[1]
                ));
            }
            lines.push(line);
        }
    }
    Ok((lines, failures))
}

fn regress(a: RegressArgs) -> Result<()> {
    let golden_path = a.golden.clone().unwrap_or_else(|| {
        a.root
            .join("tests")
            .join("golden")
            .join(format!("{}.json", a.profile))
    });
    if a.record {
        return record(&a, &golden_path);
    }
    let g: GoldenFile = serde_json::from_slice(
        &std::fs::read(&golden_path)
            .with_context(|| format!("reading the golden file {}", golden_path.display()))?,
    )
    .with_context(|| format!("parsing {}", golden_path.display()))?;
    let (lines, failures) = check(&g, &Workspace::new(&a.root).results, &a.ids)?;
    for l in &lines {
        println!("{l}");
    }
    if !failures.is_empty() {
        bail!(
            "{} key number(s) regressed:\n{}",
            failures.len(),
            failures.join("\n")
        );
    }
    println!("all {} key numbers inside their golden bands", lines.len());
    Ok(())
}

const SIGMAS: f64 = 4.0;
const FLOOR: f64 = 0.01;

fn record(a: &RegressArgs, path: &Path) -> Result<()> {
    let ids: Vec<String> = if a.ids.is_empty() {
        vec!["fig2", "fig3", "fig4", "fig15", "fig19"]
            .into_iter()
            .map(String::from)
            .collect()
    } else {
        a.ids.clone()
    };
    let mut values: BTreeMap<(String, String), Vec<f64>> = BTreeMap::new();
    for &seed in &a.seeds {
        let v = Variant {
            seed: Some(seed),
            ..Variant::default()
        };
        let (_tmp, ws) = variant_workspace(&a.root, &a.experiment, &a.profile, &v)?;
        eprintln!("regress --record: master seed {seed}");
        build(&ws, &ids, &a.profile, a.jobs)?;
        for id in &ids {
            for (q, v) in key_numbers(&ws.results.join(id))? {
                values.entry((id.clone(), q)).or_default().push(v);
            }
        }
    }
    // A number no seed produced (a fit failing at this profile) has no band.
    let quantities = values
        .iter()
        .filter(|(_, v)| v.iter().filter(|x| x.is_finite()).count() >= 2)
        .filter(|((f, q), _)| !a.ungated.contains(&format!("{f}:{q}")))
        .map(|((f, q), v)| golden(f, q, &a.seeds, v, SIGMAS, FLOOR))
        .collect();
    let g = GoldenFile {
        profile: a.profile.clone(),
        how: format!(
            "`repro regress --record --profile {} --seeds {}`: the figures built with experiment '{}' at each master seed; \
             band = mean +- max({SIGMAS} x seed-to-seed standard deviation, {FLOOR} x |mean|); not gated: {}",
            a.profile,
            a.seeds
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(","),
            a.experiment,
            if a.ungated.is_empty() {
                "none".to_string()
            } else {
                a.ungated.join(", ")
            }
        ),
        sigmas: SIGMAS,
        relative_floor: FLOOR,
        quantities,
    };
    crate::table::write_atomic(path, serde_json::to_string_pretty(&g)?.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// One frontier configuration's outcome for one quantity.
#[derive(Clone, Debug, Serialize)]
pub struct FrontierRow {
    pub n: usize,
    pub replicas: u64,
    pub quantity: String,
    pub mean: f64,
    pub spread: f64,
    pub paper: f64,
    pub tolerance: f64,
    pub cpu_s: f64,
    pub values: Vec<f64>,
}

fn frontier(a: FrontierArgs) -> Result<()> {
    let ids = vec![a.id.clone()];
    let mut rows: Vec<FrontierRow> = Vec::new();
    for &n in &a.n {
        for &r in &a.replicas {
            let mut per_q: BTreeMap<String, (Vec<f64>, f64, f64)> = BTreeMap::new();
            let mut cpu = Vec::new();
            for &seed in &a.seeds {
                let v = Variant {
                    seed: Some(seed),
                    n: Some(n),
                    replicas: Some(r),
                };
                let (_tmp, ws) = variant_workspace(&a.root, &a.experiment, &a.profile, &v)?;
                eprintln!("frontier {}: N = {n}, replicas = {r}, seed {seed}", a.id);
                build(&ws, &ids, &a.profile, a.jobs)?;
                let dir = ws.results.join(&a.id);
                cpu.push(provenance(&dir)?.1);
                for c in read_compare(&dir)? {
                    let e = per_q
                        .entry(c.quantity)
                        .or_insert((vec![], c.paper, c.tolerance));
                    e.0.push(c.ours);
                }
            }
            let cpu_s = cpu.iter().sum::<f64>() / cpu.len() as f64;
            for (q, (vals, paper, tol)) in per_q {
                let g = golden(&a.id, &q, &a.seeds, &vals, 1.0, 0.0);
                rows.push(FrontierRow {
                    n,
                    replicas: r,
                    quantity: q,
                    mean: g.mean,
                    spread: g.std,
                    paper,
                    tolerance: tol,
                    cpu_s,
                    values: vals,
                });
            }
        }
    }
    let out = Workspace::new(&a.root).results.join("frontier");
    let stem = format!("{}-{}", a.id, a.profile);
    std::fs::create_dir_all(&out)?;
    let b = crate::table::f64_batch(&[
        ("N", rows.iter().map(|r| r.n as f64).collect()),
        ("replicas", rows.iter().map(|r| r.replicas as f64).collect()),
        ("mean", rows.iter().map(|r| r.mean).collect()),
        ("spread", rows.iter().map(|r| r.spread).collect()),
        ("paper", rows.iter().map(|r| r.paper).collect()),
        ("tolerance", rows.iter().map(|r| r.tolerance).collect()),
        ("cpu_s", rows.iter().map(|r| r.cpu_s).collect()),
    ])?;
    let q =
        arrow_array::StringArray::from(rows.iter().map(|r| r.quantity.clone()).collect::<Vec<_>>());
    let b = {
        let schema = b.schema();
        let mut cols: Vec<(&str, arrow_array::ArrayRef)> =
            vec![("quantity", std::sync::Arc::new(q))];
        for (f, c) in schema.fields().iter().zip(b.columns()) {
            cols.push((f.name().as_str(), c.clone()));
        }
        arrow_array::RecordBatch::try_from_iter(cols)?
    };
    crate::table::write_parquet(
        &out.join(format!("{stem}.parquet")),
        &[b],
        &[("seeds", &format!("{:?}", a.seeds))],
    )?;
    std::fs::write(
        out.join(format!("{stem}.json")),
        serde_json::to_string_pretty(&rows)?,
    )?;
    let fig = frontier_chart(&format!("{} ({})", a.id, a.profile), &rows);
    crate::plot::draw(
        &fig,
        &out.join(format!("{stem}.svg")),
        &out.join(format!("{stem}.png")),
    )?;
    for r in &rows {
        println!(
            "{} N = {:>6} replicas = {} : {} = {:.4} +- {:.4} (seed spread; paper {} +- {}), {:.1} CPU s",
            a.id, r.n, r.replicas, r.quantity, r.mean, r.spread, r.paper, r.tolerance, r.cpu_s
        );
    }
    println!("{}", smallest(&rows));
    println!("wrote {}/{stem}.{{parquet,json,svg,png}}", out.display());
    Ok(())
}

/// The cheapest configuration whose every quantity is within the paper's
/// tolerance, with a seed spread inside it too.
pub fn smallest(rows: &[FrontierRow]) -> String {
    let mut configs: BTreeMap<(usize, u64), (f64, bool)> = BTreeMap::new();
    for r in rows {
        let ok = (r.mean - r.paper).abs() <= r.tolerance && r.spread <= r.tolerance;
        let e = configs.entry((r.n, r.replicas)).or_insert((r.cpu_s, true));
        e.1 &= ok;
    }
    match configs
        .iter()
        .filter(|(_, (_, ok))| *ok)
        .min_by(|a, b| a.1.0.total_cmp(&b.1.0))
    {
        Some(((n, r), (cpu, _))) => format!(
            "smallest configuration within the paper's tolerance: N = {n}, replicas = {r} ({cpu:.1} CPU s)"
        ),
        None => "no configuration tried reproduces every key number within the paper's tolerance"
            .to_string(),
    }
}

fn frontier_chart(id: &str, rows: &[FrontierRow]) -> crate::plot::Figure {
    use crate::plot::{Axis, Figure, Legend, Marker, Palette, Panel, RefLine, Series, Style};
    let mut qs: Vec<&str> = rows.iter().map(|r| r.quantity.as_str()).collect();
    qs.sort();
    qs.dedup();
    let panels: Vec<Panel> = qs
        .iter()
        .map(|q| {
            let mine: Vec<&FrontierRow> = rows.iter().filter(|r| r.quantity == *q).collect();
            let mut reps: Vec<u64> = mine.iter().map(|r| r.replicas).collect();
            reps.sort();
            reps.dedup();
            let series = reps
                .iter()
                .map(|&rep| {
                    let mut pts: Vec<&&FrontierRow> =
                        mine.iter().filter(|r| r.replicas == rep).collect();
                    pts.sort_by(|a, b| a.cpu_s.total_cmp(&b.cpu_s));
                    Series {
                        label: format!(
                            "{rep} replicas, N = {}",
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
                    }
                })
                .collect();
            let paper = mine.first().map(|r| r.paper).unwrap_or(f64::NAN);
            // Show the paper's value even when every configuration misses it.
            let (lo, hi) = mine.iter().fold((paper, paper), |(lo, hi), r| {
                (lo.min(r.mean - r.spread), hi.max(r.mean + r.spread))
            });
            let pad = 0.08 * (hi - lo).max(1e-9);
            let range = (lo.is_finite() && hi.is_finite()).then_some((lo - pad, hi + pad));
            Panel {
                title: format!("{id}: {q}"),
                x: Axis {
                    label: "CPU seconds (all stages)".into(),
                    log: true,
                    range: None,
                },
                y: Axis {
                    label: q.to_string(),
                    log: false,
                    range,
                },
                series,
                hlines: vec![RefLine {
                    at: paper,
                    label: "paper".into(),
                    dashed: true,
                    color: None,
                }],
                vlines: vec![],
                legend: Legend::Auto,
                legend_title: String::new(),
                palette: Palette::Categorical,
            }
        })
        .collect();
    let n = panels.len().max(1) as u32;
    Figure {
        title: String::new(),
        panels,
        columns: None,
        width: 480 * n,
        height: 400,
    }
}

pub fn run(c: Commands) -> Result<()> {
    match c {
        Commands::Regress(a) => regress(a),
        Commands::Frontier(a) => frontier(a),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_band_is_four_sigma_or_the_floor() {
        let g = golden("fig4", "phi_c", &[1, 2, 3], &[1.0, 2.0, 3.0], 4.0, 0.01);
        assert!((g.mean - 2.0).abs() < 1e-12 && (g.std - 1.0).abs() < 1e-12);
        assert_eq!(g.band, [-2.0, 6.0]);
        let flat = golden("fig4", "phi_c", &[1, 2], &[0.8, 0.8], 4.0, 0.01);
        assert!(
            (flat.band[1] - 0.808).abs() < 1e-12,
            "floor applies when seeds agree"
        );
    }

    /// A seed whose fit failed (NaN) is left out of the band, written as
    /// `null`, and read back as NaN.
    #[test]
    fn a_failed_seed_round_trips_as_null() {
        let g = golden(
            "fig19",
            "gamma_xi",
            &[1, 2, 3],
            &[1.0, f64::NAN, 3.0],
            4.0,
            0.01,
        );
        assert!((g.mean - 2.0).abs() < 1e-12);
        let json = serde_json::to_string(&g).unwrap();
        assert!(json.contains("[1.0,null,3.0]"), "{json}");
        let back: Golden = serde_json::from_str(&json).unwrap();
        assert_eq!(back.values[0], 1.0);
        assert!(back.values[1].is_nan());
        assert_eq!(back.band, g.band);
    }

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
}
