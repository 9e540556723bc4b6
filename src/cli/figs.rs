//! `repro regress` (CI regression of the figures' key numbers against committed
//! golden values), `repro frontier` (accuracy of the key numbers against their CPU
//! cost) and `repro report` (the gallery and key-number table from the results).
//! The work is in [`crate::study`]; this file parses and prints.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, Subcommand};

use crate::pipeline::{RunOptions, Workspace};
use crate::study::coverage::{self, Coverage};
use crate::study::frontier::{self, Frontier};
use crate::study::golden::{self, GoldenFile, Recording, SeedCheck};
use crate::study::report;
use crate::study::results::{Tally, read_compare};
use crate::study::variant::{self, Variant};

#[derive(Subcommand, Debug)]
pub enum Commands {
    /// Check the key numbers of built figures (results/ID: compare.parquet and the
    /// fit tables) against the golden bands in tests/golden/PROFILE.json; exit
    /// non-zero naming figure, quantity, value and band on any regression. With
    /// --set or --seed, build that variant of the specs first and check it. With
    /// --record, rebuild the goldens from several master seeds instead.
    Regress(RegressArgs),
    /// Speed against accuracy: rebuild a figure at several N and replica counts
    /// with several seeds; table and chart of its key numbers (seed-to-seed
    /// spread) against CPU seconds, in results/frontier/.
    Frontier(FrontierArgs),
    /// Write results/REPORT.md (and with --docs docs/report-PROFILE.md, with
    /// --html results/report/index.html): the gallery and every key number (ours,
    /// error, paper, verdict, reason) of the built figures, with the profile,
    /// commit and date that produced them. Nothing is rebuilt.
    Report(ReportArgs),
    /// Do the quoted errors mean what they say? Build the figures at several
    /// master seeds; per key number, the fraction of seeds whose quoted 1-sigma
    /// interval covers the all-seed mean and the ratio quoted error / seed-to-seed
    /// spread; on seeds the goldens were not recorded at, whether `repro regress`
    /// would fail (a false alarm). Written to results/coverage-PROFILE.json and
    /// .md (with --docs, the .md to docs/).
    Coverage(CoverageArgs),
}

#[derive(Args, Debug)]
pub struct CoverageArgs {
    /// Figures (default: the CI figures).
    #[arg(value_name = "ID")]
    pub ids: Vec<String>,
    #[arg(long, default_value = "ci")]
    pub profile: String,
    /// Master seeds, separated by commas (11,12,13).
    #[arg(long, value_delimiter = ',', default_value = "1,2,3,4,5,6,7,8,9,10")]
    pub seeds: Vec<u64>,
    /// Suffix of the output file: results/coverage-PROFILE[-LABEL].json.
    #[arg(long, default_value = "")]
    pub label: String,
    /// Read the per-seed values and quoted errors recorded in this golden file
    /// (`repro regress --record`) instead of building the seeds.
    #[arg(long)]
    pub golden: Option<PathBuf>,
    /// Read the per-seed values of earlier surveys instead of building:
    /// results/coverage-PROFILE-LABEL.json of each label (separated by commas,
    /// all of the same seeds; a number in several is taken from the last), and
    /// check each seed against the golden file as it is now (after a
    /// re-recording, or with the numbers of several figures' surveys together).
    #[arg(long, value_delimiter = ',', conflicts_with = "golden")]
    pub stored: Vec<String>,
    /// Write the Markdown table to docs/coverage-PROFILE[-LABEL].md instead of
    /// results/.
    #[arg(long)]
    pub docs: bool,
    #[command(flatten)]
    pub variant: VariantArgs,
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
    /// Rebuild the golden file: run the figures at each of --seeds.
    #[arg(long)]
    pub record: bool,
    /// With --record: the master seeds, separated by commas.
    #[arg(long, value_delimiter = ',', default_value = "1,2,3,4,5")]
    pub seeds: Vec<u64>,
    /// With --record: a key number left out of the bands by hand, with the reason
    /// written into the golden file: FIGURE:QUANTITY=REASON (repeat the option).
    /// Constants, numbers missing at some seed and fit diagnostics are left out
    /// without asking.
    #[arg(long, value_parser = parse_ungated)]
    pub ungated: Vec<(String, String)>,
    /// Check a variant built at this master seed. At a seed the goldens were
    /// recorded at (and no --set), also check that every number is the one
    /// recorded there: a number the code has moved since is a stale golden.
    #[arg(long)]
    pub seed: Option<u64>,
    #[command(flatten)]
    pub variant: VariantArgs,
}

#[derive(Args, Debug)]
pub struct FrontierArgs {
    /// The figure (e.g. fig4, fig19).
    pub id: String,
    /// Profile whose grid and run lengths are the base of every variant.
    #[arg(long, default_value = "ci")]
    pub profile: String,
    #[arg(long, value_delimiter = ',', default_value = "500,1000,2000")]
    pub n: Vec<usize>,
    #[arg(long, value_delimiter = ',', default_value = "2")]
    pub replicas: Vec<u64>,
    /// Master seeds of each configuration (the spread between them is the error).
    #[arg(long, value_delimiter = ',', default_value = "1,2,3")]
    pub seeds: Vec<u64>,
    /// Name of these configurations; rows of other labels already in
    /// results/frontier/ID-PROFILE.json are kept, so one chart compares them.
    #[arg(long, default_value = "")]
    pub label: String,
    #[command(flatten)]
    pub variant: VariantArgs,
}

/// What every command that builds variants of the specs shares.
#[derive(Args, Debug)]
pub struct VariantArgs {
    /// Profile parameters to change (KEY=VALUE, e.g. eps=0.88 for a deliberate
    /// physics change, overlap_spacing_tau=0.5 for overlapping time origins), or
    /// a grid axis's values (grid.AXIS=[...], e.g. grid.force=[1000,10000]);
    /// regress then checks that variant, built in a temporary directory.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// The experiment whose parameters (--set, N, replicas) the variants change;
    /// a master seed applies to every experiment.
    #[arg(long, default_value = "eps09")]
    pub experiment: String,
    #[arg(long)]
    pub jobs: Option<usize>,
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub root: PathBuf,
}

#[derive(Args, Debug)]
pub struct ReportArgs {
    /// Report the figures built at this profile (default: the one profile of
    /// every built figure).
    #[arg(long)]
    pub profile: Option<String>,
    /// Also write docs/report-PROFILE.md, with the PNGs copied to
    /// docs/img/ID-PROFILE.png (what the README links).
    #[arg(long)]
    pub docs: bool,
    /// Also write the HTML report: results/report/index.html (a scoreboard of
    /// every figure) and a page per built figure, opened from the file system.
    #[arg(long)]
    pub html: bool,
    /// With --html: write it into DIR instead, with copies of the built figures'
    /// files, to share on its own.
    #[arg(long, value_name = "DIR", requires = "html")]
    pub out: Option<PathBuf>,
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub root: PathBuf,
}

/// `FIGURE:QUANTITY=REASON` of `--ungated`.
fn parse_ungated(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((fq, why)) if fq.contains(':') && !why.trim().is_empty() => {
            Ok((fq.trim().to_string(), why.trim().to_string()))
        }
        _ => Err(format!(
            "expected FIGURE:QUANTITY=REASON (the reason goes into the golden file), got '{s}'"
        )),
    }
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

/// The figures named, or the CI figures (`ci: true`) when none is.
fn or_ci_figures(root: &std::path::Path, ids: &[String]) -> Result<Vec<String>> {
    if !ids.is_empty() {
        return Ok(ids.to_vec());
    }
    let ci = crate::pipeline::Catalogue::load(root)?.ci_figures();
    if ci.is_empty() {
        anyhow::bail!(
            "no figure of {}/pipelines is marked `ci: true`; name the figures",
            root.display()
        );
    }
    Ok(ci)
}

fn coverage(a: CoverageArgs) -> Result<()> {
    let golden_path = a
        .variant
        .root
        .join("tests")
        .join("golden")
        .join(format!("{}.json", a.profile));
    let survey = if let Some(path) = &a.golden {
        recorded_survey(&a, path)?
    } else if !a.stored.is_empty() {
        stored_survey(&a, &golden_path)?
    } else {
        built_survey(&a, &golden_path)?
    };
    print_survey(&survey);
    write_survey(&a, &survey)
}

/// A coverage survey's numbers, from whichever source `repro coverage` reads.
struct Survey {
    /// Each key number's coverage over the seeds.
    rows: Vec<Coverage>,
    /// The golden file whose gates the Markdown table shows.
    golden: Option<GoldenFile>,
    /// Each fresh seed checked against the goldens as CI would.
    checks: Vec<SeedCheck>,
    /// Each key number's value and quoted error per seed (NaN written as
    /// null), so a survey can be read again without rebuilding it.
    per_seed_json: serde_json::Map<String, serde_json::Value>,
    /// The master seeds.
    seeds: Vec<u64>,
    /// The commits a stored survey was built at (empty otherwise).
    built: Vec<String>,
}

/// The golden file at `path` if it exists.
fn golden_if_any(path: &std::path::Path) -> Result<Option<GoldenFile>> {
    path.exists().then(|| GoldenFile::read(path)).transpose()
}

/// `--golden`: the per-seed values and quoted errors recorded in a golden
/// file, at the seeds it was recorded at.
fn recorded_survey(a: &CoverageArgs, path: &std::path::Path) -> Result<Survey> {
    let g = GoldenFile::read(path)?;
    Ok(Survey {
        rows: coverage::from_golden(&g, &a.ids),
        seeds: g.seeds.clone(),
        golden: Some(g),
        checks: Vec::new(),
        per_seed_json: serde_json::Map::new(),
        built: Vec::new(),
    })
}

/// `--stored`: the per-seed values of earlier surveys, each seed checked
/// against the golden file as it is now when the seeds are not its own.
fn stored_survey(a: &CoverageArgs, golden_path: &std::path::Path) -> Result<Survey> {
    let results = Workspace::new(&a.variant.root).results;
    let files: Vec<PathBuf> = a
        .stored
        .iter()
        .map(|l| results.join(format!("coverage-{}-{l}.json", a.profile)))
        .collect();
    let (seeds, per_seed, built) = coverage::read_stored(&files)?;
    let g = golden_if_any(golden_path)?;
    let checks = match g
        .as_ref()
        .filter(|g| !seeds.iter().any(|s| g.seeds.contains(s)))
    {
        Some(g) => coverage::check_stored(g, &seeds, &per_seed, &a.ids),
        None => Vec::new(),
    };
    Ok(Survey {
        rows: per_seed
            .iter()
            .filter(|((f, _), _)| a.ids.is_empty() || a.ids.contains(f))
            .filter_map(|((f, q), v)| coverage::coverage(f, q, v))
            .collect(),
        golden: g,
        checks,
        per_seed_json: coverage::per_seed_json(&per_seed),
        seeds,
        built,
    })
}

/// The figures built at each of `--seeds`; each seed's build checked against
/// the goldens as CI would, when the profile has them and the seeds are not
/// the recorded ones.
fn built_survey(a: &CoverageArgs, golden_path: &std::path::Path) -> Result<Survey> {
    let ids = or_ci_figures(&a.variant.root, &a.ids)?;
    let g = golden_if_any(golden_path)?;
    let gate = g
        .as_ref()
        .filter(|g| !a.seeds.iter().any(|s| g.seeds.contains(s)));
    let (per_seed, checks) = golden::seed_numbers(
        &a.variant.root,
        &a.variant.experiment,
        &a.profile,
        &ids,
        &a.seeds,
        &Variant {
            set: settings(&a.variant.set)?,
            ..Variant::default()
        },
        gate,
        &options(a.variant.jobs),
    )?;
    Ok(Survey {
        rows: per_seed
            .iter()
            .filter_map(|((f, q), v)| coverage::coverage(f, q, v))
            .collect(),
        golden: g,
        checks,
        per_seed_json: coverage::per_seed_json(&per_seed),
        seeds: a.seeds.clone(),
        built: Vec::new(),
    })
}

/// The survey's table on standard output, and how often `repro regress`
/// fired at the fresh seeds.
fn print_survey(survey: &Survey) {
    println!(
        "| figure | quantity | seeds | mean | seed-to-seed spread | rms quoted error | quoted / spread | median quoted / spread | coverage | max distance from the median / quoted |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for c in &survey.rows {
        println!(
            "| {} | {} | {} | {:.5} | {:.5} | {:.5} | {:.2} | {:.2} | {:.0}% | {:.1} |",
            c.figure,
            c.quantity,
            c.seeds,
            c.mean,
            c.spread,
            c.quoted,
            c.ratio,
            c.median_ratio,
            100.0 * c.coverage,
            c.max_from_median
        );
    }
    let checks = &survey.checks;
    if !checks.is_empty() {
        let fired = checks.iter().filter(|c| !c.failures.is_empty()).count();
        println!(
            "repro regress fails at {fired} of {} fresh master seeds",
            checks.len()
        );
    }
}

/// Each number's gate in the golden file, for the Markdown table.
fn gates(g: Option<&GoldenFile>) -> std::collections::BTreeMap<(String, String), String> {
    let mut gates = std::collections::BTreeMap::new();
    if let Some(g) = g {
        for q in &g.quantities {
            gates.insert((q.figure.clone(), q.quantity.clone()), q.gate.to_string());
        }
        for fq in g.ungated.keys() {
            if let Some((f, q)) = fq.split_once(':') {
                gates.insert((f.to_string(), q.to_string()), "ungated".to_string());
            }
        }
    }
    gates
}

/// The survey as results/coverage-PROFILE[-LABEL].json and its Markdown table
/// (in docs/ with `--docs`).
fn write_survey(a: &CoverageArgs, survey: &Survey) -> Result<()> {
    let gates = gates(survey.golden.as_ref());
    let stem = if a.label.is_empty() {
        format!("coverage-{}", a.profile)
    } else {
        format!("coverage-{}-{}", a.profile, a.label)
    };
    let results = Workspace::new(&a.variant.root).results;
    let out = results.join(format!("{stem}.json"));
    std::fs::create_dir_all(&results)?;
    let Survey {
        rows,
        checks,
        per_seed_json,
        seeds,
        built,
        ..
    } = survey;
    let commit = crate::pipeline::publish::git_commit(&a.variant.root);
    let json = serde_json::json!({
        "commits": if built.is_empty() { commit.iter().cloned().collect() } else { built.clone() },
        "seeds": seeds,
        "rows": rows,
        "regress": checks,
        "per_seed": per_seed_json,
    });
    crate::table::write_atomic(&out, serde_json::to_string_pretty(&json)?.as_bytes())?;
    println!("wrote {}", out.display());
    let command = std::env::args()
        .skip(1)
        .fold("repro".to_string(), |acc, x| acc + " " + &x);
    let md = coverage::markdown(
        &command,
        commit.as_deref(),
        built,
        seeds,
        rows,
        &gates,
        &coverage::reasons(&a.variant.root, &a.profile)?,
        checks,
    );
    let md_path = if a.docs {
        a.variant.root.join("docs").join(format!("{stem}.md"))
    } else {
        results.join(format!("{stem}.md"))
    };
    crate::table::write_atomic(&md_path, md.as_bytes())?;
    println!("wrote {}", md_path.display());
    Ok(())
}

fn regress(a: RegressArgs) -> Result<()> {
    let golden_path = a.golden.clone().unwrap_or_else(|| {
        a.variant
            .root
            .join("tests")
            .join("golden")
            .join(format!("{}.json", a.profile))
    });
    let opts = options(a.variant.jobs);
    if a.record {
        let ids = or_ci_figures(&a.variant.root, &a.ids)?;
        let g = golden::record(
            &Recording {
                root: &a.variant.root,
                experiment: &a.variant.experiment,
                profile: &a.profile,
                ids: &ids,
                seeds: &a.seeds,
                ungated: &a.ungated.iter().cloned().collect(),
            },
            &opts,
        )?;
        // Figures named: their bands replace theirs, the others' stay.
        let g = if !a.ids.is_empty() && golden_path.exists() {
            golden::merge(
                GoldenFile::read(&golden_path)?,
                g,
                &ids,
                &a.variant.experiment,
            )?
        } else {
            g
        };
        g.write(&golden_path)?;
        println!("wrote {}", golden_path.display());
        return Ok(());
    }
    let g = GoldenFile::read(&golden_path)?;
    let v = Variant {
        seed: a.seed,
        set: settings(&a.variant.set)?,
        ..Variant::default()
    };
    let built;
    let results = if v.seed.is_some() || !v.set.is_empty() {
        let ids: Vec<String> = if a.ids.is_empty() {
            let mut f: Vec<String> = g.quantities.iter().map(|q| q.figure.clone()).collect();
            f.dedup();
            f
        } else {
            a.ids.clone()
        };
        built = variant::build(
            &a.variant.root,
            &a.variant.experiment,
            &a.profile,
            &v,
            &ids,
            &opts,
        )?;
        built.results.clone()
    } else {
        Workspace::new(&a.variant.root).results
    };
    if a.ids.is_empty() {
        let ci = crate::pipeline::Catalogue::load(&a.variant.root)?.ci_figures();
        golden::all_recorded(&g, &golden_path, &ci, &results)?;
    }
    let (lines, mut failures) = golden::check(&g, &results, &a.ids)?;
    // At a recorded seed, the goldens must be what this code gives.
    if let Some(seed) = v.seed.filter(|s| g.seeds.contains(s) && v.set.is_empty()) {
        failures.extend(golden::stale(&g, &results, &a.ids, seed)?);
    }
    for l in &lines {
        println!("{l}");
    }
    println!("{}", verdicts(&g, &results, &a.ids)?);
    if !failures.is_empty() {
        let jointly = failures.iter().filter(|f| f.contains(" jointly: ")).count();
        let mut fired = Vec::new();
        if failures.len() > jointly {
            fired.push(format!("{} band(s) or check(s)", failures.len() - jointly));
        }
        if jointly > 0 {
            fired.push("the joint test (Hotelling T^2)".to_string());
        }
        bail!(
            "regress fired: {}\n{}",
            fired.join(" and "),
            failures.join("\n")
        );
    }
    println!("all {} key numbers inside their golden bands", lines.len());
    Ok(())
}

/// The paper verdicts of the checked figures, as the HTML report's scoreboard
/// totals them: `verdicts against the paper: 5 agree, ... (8 key numbers, 3 figures)`.
fn verdicts(g: &GoldenFile, results: &std::path::Path, ids: &[String]) -> Result<String> {
    let mut figs: Vec<&str> = g
        .quantities
        .iter()
        .map(|q| q.figure.as_str())
        .filter(|f| ids.is_empty() || ids.iter().any(|i| i == f))
        .collect();
    figs.sort();
    figs.dedup();
    let mut t = Tally::default();
    for f in &figs {
        let dir = results.join(f);
        if dir.join("compare.parquet").is_file() {
            t.add(&Tally::of(&read_compare(&dir)?));
        }
    }
    Ok(format!(
        "verdicts against the paper: {} ({} key numbers, {} figures)",
        t.line(),
        t.total(),
        figs.len()
    ))
}

fn settings(set: &[String]) -> Result<std::collections::BTreeMap<String, serde_json::Value>> {
    set.iter().map(|s| variant::parse_setting(s)).collect()
}

fn frontier(a: FrontierArgs) -> Result<()> {
    let set = settings(&a.variant.set)?;
    let rows = frontier::measure(
        &Frontier {
            root: &a.variant.root,
            experiment: &a.variant.experiment,
            profile: &a.profile,
            id: &a.id,
            n: &a.n,
            replicas: &a.replicas,
            seeds: &a.seeds,
            set: &set,
            label: &a.label,
        },
        &options(a.variant.jobs),
    )?;
    let out = Workspace::new(&a.variant.root).results.join("frontier");
    let all = frontier::write(&out, &a.id, &a.profile, &a.seeds, &rows)?;
    for r in &all {
        println!(
            "{} [{}] N = {:>6} replicas = {} : {} = {:.4} +- {:.4} (seed spread; paper {} +- {}), {:.1} CPU s, {:.1} MB of trajectories",
            a.id,
            r.label,
            r.n,
            r.replicas,
            r.quantity,
            r.mean,
            r.spread,
            r.paper,
            r.tolerance,
            r.cpu_s,
            r.trajectory_bytes / 1e6
        );
    }
    println!("{}", frontier::smallest(&all));
    println!(
        "wrote {}/{}-{}.{{parquet,json,svg,png}}",
        out.display(),
        a.id,
        a.profile
    );
    Ok(())
}

fn report(a: ReportArgs) -> Result<()> {
    let ws = Workspace::new(&a.root);
    let r = report::collect(&a.root, &ws.results, a.profile.as_deref())?;
    let mut w = report::write_markdown(&r, &a.root, &ws.results, a.docs)?;
    if a.html {
        w.files
            .push(report::html::write(&r, &ws.results, a.out.as_deref())?);
    }
    for f in &w.files {
        println!(
            "wrote {} ({} of {} figures built, profile {})",
            f.display(),
            w.figures,
            r.entries.len(),
            w.profile
        );
    }
    Ok(())
}

pub fn run(c: Commands) -> Result<()> {
    match c {
        Commands::Regress(a) => regress(a),
        Commands::Frontier(a) => frontier(a),
        Commands::Report(a) => report(a),
        Commands::Coverage(a) => coverage(a),
    }
}
