//! `repro figure`, `list`, `status`, `why`, `gc`: the pipeline commands.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, Subcommand};

use std::collections::BTreeMap;

use super::root::RootArgs;
use super::runs::RunsArgs;
use super::what_if::WhatIf;
use crate::pipeline::checkpoints::{Status, unix_now};
use crate::pipeline::slurm;
use crate::pipeline::{self, DEFAULT_PROFILE, Outcome, Registry, RunOptions, State, Workspace};

/// The registry the command line runs with: every kind of the library
/// (`stages::registry()`), and the framework's toy kinds when the environment
/// variable `REPRO_TOY_KINDS` is set (the integration tests' fixtures use them).
/// A runtime switch rather than a cargo feature: the tests and `make test`'s
/// figure builds then share one compiled library instead of two.
pub fn registry() -> Registry {
    let mut r = crate::stages::registry();
    if std::env::var_os(TOY_KINDS).is_some() {
        crate::pipeline::toy::register(&mut r);
    }
    r
}

/// The environment variable that adds the toy kinds to the command line's registry.
pub const TOY_KINDS: &str = "REPRO_TOY_KINDS";

/// One figure at one profile.
#[derive(Args, Debug, Clone)]
pub struct OneFigure {
    /// Figure id (pipelines/ID.yaml).
    #[arg(value_name = "ID")]
    pub id: String,
    #[arg(long, default_value = DEFAULT_PROFILE, value_name = "P")]
    pub profile: String,
    #[command(flatten)]
    pub what_if: WhatIf,
    #[command(flatten)]
    pub root: RootArgs,
}

/// The figures a command works on, at one profile.
#[derive(Args, Debug, Clone)]
pub struct Figures {
    /// Figure ids (file names of pipelines/ID.yaml without .yaml).
    #[arg(value_name = "ID", required_unless_present_any = ["all", "ci"])]
    pub ids: Vec<String>,
    /// Every figure in pipelines/.
    #[arg(long, conflicts_with_all = ["ids", "ci"])]
    pub all: bool,
    /// The figures gated in CI (`ci: true` in their pipelines/ID.yaml).
    #[arg(long, conflicts_with = "ids")]
    pub ci: bool,
    /// Size of the runs: `ci` (seconds, for tests), `small` (a laptop, minutes;
    /// shows every qualitative feature), `paper` (the paper's N and run lengths).
    #[arg(long, default_value = DEFAULT_PROFILE, value_name = "P")]
    pub profile: String,
}

impl Figures {
    /// The ids to plan: all (an empty list), those gated in CI, or those named.
    fn ids(&self, ws: &Workspace) -> Result<Vec<String>> {
        Ok(if self.all {
            Vec::new()
        } else if self.ci {
            pipeline::Catalogue::load(&ws.root)?.ci_figures()
        } else {
            self.ids.clone()
        })
    }
}

/// Where `repro figure` runs its stages.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum Executor {
    Local,
    Slurm,
}

/// What `repro figure` builds, and how.
#[derive(Args, Debug)]
pub struct FigureArgs {
    #[command(flatten)]
    figures: Figures,
    /// Stages run at once (default: all cores). Results are identical for any value.
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Print what would run, and why, without running anything.
    #[arg(long)]
    dry_run: bool,
    /// Rerun every stage of this kind even if cached (e.g. `--force plot`);
    /// repeatable. Dependents rerun only if the output bytes change.
    #[arg(long, value_name = "STAGE-KIND")]
    force: Vec<String>,
    /// Where stages run: `local` (threads of this process) or `slurm` (one
    /// job per ready stage, a job array per sweep; docs/slurm.md). With
    /// `--dry-run`, `slurm` prints the jobs, their resources and core-hours.
    #[arg(long, value_enum, default_value_t = Executor::Local)]
    executor: Executor,
    #[command(flatten)]
    what_if: WhatIf,
    #[command(flatten)]
    root: RootArgs,
}

/// What `repro plan` plans, and how it judges the plan.
#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(flatten)]
    figures: Figures,
    /// Compare the plan with the recorded CPU time of every built simulation.
    #[arg(long)]
    check: bool,
    /// With `--check`: the largest accepted ratio of measured to planned (or
    /// planned to measured).
    #[arg(long, default_value_t = 2.0, value_name = "X")]
    factor: f64,
    /// With `--check`: runs whose planned and measured CPU times are both
    /// below this many seconds are listed but not judged (a Slurm time limit
    /// is two minutes at least; start-up dominates there).
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    min_seconds: f64,
    /// With `--check`: fail when fewer than this share of the judged
    /// simulation configurations and stages lie within the factor.
    #[arg(long, default_value_t = 0.95, value_name = "SHARE")]
    share: f64,
    #[command(flatten)]
    what_if: WhatIf,
    #[command(flatten)]
    root: RootArgs,
}

#[derive(Subcommand, Debug)]
pub enum Commands {
    /// Build figures: simulate, analyse, fit and plot what is not cached, then
    /// write results/ID/ (Parquet tables, compare.parquet, the figure, provenance.json).
    ///
    /// Examples: `repro figure fig19`, `repro figure fig19 --profile ci`,
    /// `repro figure --all --jobs 2`, `repro figure fig19 --dry-run`.
    Figure(FigureArgs),
    /// The planned cost of a build: per simulation its work (collisions, kicks,
    /// force kicks, frames) and planned CPU time, the total and the longest.
    /// With `--check`, beside each the CPU time its recorded run took (cached
    /// stages only), failing if any is off by more than `--factor` either way.
    /// `--all` plans every figure whose experiments have the profile and lists
    /// the others.
    ///
    /// Examples: `repro plan --all --profile small`, `repro plan --all --check`.
    Plan(PlanArgs),
    /// Fit the planned cost of analyses, fits, plots and tables to every stage
    /// recorded in the store, write it to PATH as JSON and say how close it
    /// comes per kind. The calibration `repro plan`, the progress estimate and
    /// Slurm's time limits use is src/pipeline/stage_cost.json, compiled in:
    /// `repro calibrate src/pipeline/stage_cost.json` regenerates it.
    Calibrate {
        #[arg(value_name = "PATH")]
        path: std::path::PathBuf,
        /// The factor a stage's plan is judged within.
        #[arg(long, default_value_t = 2.0, value_name = "X")]
        factor: f64,
        /// Stages whose planned and measured CPU times are both below this
        /// many seconds are not judged.
        #[arg(long, default_value_t = 1.0, value_name = "S")]
        min_seconds: f64,
        #[command(flatten)]
        root: RootArgs,
    },
    /// List the figures with a one-line description and their cache state.
    List {
        #[arg(long, default_value = DEFAULT_PROFILE, value_name = "P")]
        profile: String,
        #[command(flatten)]
        root: RootArgs,
    },
    /// Show, per stage of a figure, whether it is cached or stale.
    Status(OneFigure),
    /// Explain why stages of a figure would rerun: which parameter, input or code
    /// fingerprint differs from the cached result.
    Why(OneFigure),
    /// The built runs of an experiment found by their parameters: grid point,
    /// replica, seed and trajectory path (Parquet, readable by pyarrow, pandas
    /// and polars), or copied out with `--export DIR`.
    ///
    /// Examples: `repro runs eps09 --profile ci --where phi=0.78`,
    /// `repro runs eps09 --profile ci --export runs/`.
    Runs(RunsArgs),
    /// Check every artifact of the cache against its content hash. Damaged ones
    /// are moved to .repro/store/quarantine/ (never deleted) and their stages rerun
    /// on the next `repro figure`; exits non-zero if any was damaged.
    Verify {
        #[command(flatten)]
        root: RootArgs,
    },
    /// Compute one stage submitted by `--executor slurm` (what its Slurm job runs).
    #[command(hide = true)]
    Worker {
        /// The store holding the stage's job record (jobs/KEY.json).
        #[arg(long, value_name = "PATH")]
        store: PathBuf,
        /// The stage's cache key.
        #[arg(long, value_name = "KEY")]
        key: String,
    },
    /// Free cache entries and artifacts that no current spec (at any profile) reaches.
    Gc {
        /// Only report what would be freed.
        #[arg(long)]
        dry_run: bool,
        #[command(flatten)]
        root: RootArgs,
    },
}

/// A running (or stopped) simulation as `repro status` shows it, `now` in Unix seconds.
fn progress_line(s: &Status, now: u64) -> String {
    let ago = |t: u64| {
        let s = now.saturating_sub(t);
        if s < 120 {
            format!("{s} s ago")
        } else if s < 7200 {
            format!("{} min ago", s / 60)
        } else {
            format!("{:.1} h ago", s as f64 / 3600.0)
        }
    };
    let at = match &s.progress {
        Some(p) => format!(
            "{} t = {:.1}, {:.1}% of the run (reported {} by {}, pid {})",
            p.stage,
            p.time,
            100.0 * p.fraction,
            ago(p.updated),
            p.host,
            p.pid
        ),
        None => "no progress report".to_string(),
    };
    match s.checkpoint {
        Some((t, written)) => format!("{at}; last checkpoint at t = {t} ({})", ago(written)),
        None => format!("{at}; no checkpoint yet"),
    }
}

fn print_status(
    graph: &pipeline::Graph,
    st: &[(usize, State)],
    only_stale: bool,
    jobs: &BTreeMap<usize, String>,
    running: &BTreeMap<usize, Status>,
) {
    for (i, s) in st {
        let n = &graph.nodes[*i];
        match s {
            State::Cached { key } if !only_stale => {
                println!("cached  {}  ({}, key {})", n.label(), n.kind, &key[..12])
            }
            State::Cached { .. } => {}
            State::Damaged { problems } => {
                println!("damaged {}  ({})", n.label(), n.kind);
                for p in problems {
                    println!("          - {p}");
                }
                println!("          - the next run quarantines it and recomputes the stage");
            }
            State::Stale { reasons } => {
                println!("stale   {}  ({})", n.label(), n.kind);
                if let Some(j) = jobs.get(i) {
                    println!("          - Slurm: {j}");
                }
                if let Some(p) = running.get(i) {
                    println!("          - {}", progress_line(p, unix_now()));
                }
                for r in reasons {
                    println!("          - {r}");
                }
            }
        }
    }
    let stale = st
        .iter()
        .filter(|(_, s)| matches!(s, State::Stale { .. }))
        .count();
    let damaged = st
        .iter()
        .filter(|(_, s)| matches!(s, State::Damaged { .. }))
        .count();
    if stale > 0 {
        println!("stale by kind: {}", stale_by_kind(graph, st));
    }
    println!(
        "{} stage(s): {} cached, {stale} stale{}",
        st.len(),
        st.len() - stale - damaged,
        if damaged > 0 {
            format!(", {damaged} damaged")
        } else {
            String::new()
        }
    );
}

/// Plan figures `ids` (with what-if settings) and the cache state of their stages.
fn planned_status(
    ws: &Workspace,
    reg: &Registry,
    what_if: &WhatIf,
    ids: &[String],
    profile: &str,
    force: &[String],
) -> Result<(pipeline::Graph, Vec<(usize, State)>)> {
    let graph = what_if.plan(ws, reg, ids, profile)?;
    let store = pipeline::Store::open(&ws.store)?;
    let st = pipeline::exec::status(&graph, &pipeline::needed_nodes(&graph), reg, &store, force);
    Ok((graph, st))
}

/// `48 simulate, 13 overlap, 2 table`: the stale stages counted by kind, most first.
fn stale_by_kind(graph: &pipeline::Graph, st: &[(usize, State)]) -> String {
    let mut count: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, s) in st {
        if matches!(s, State::Stale { .. }) {
            *count.entry(graph.nodes[*i].kind.as_str()).or_default() += 1;
        }
    }
    let mut v: Vec<(&str, usize)> = count.into_iter().collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
    v.iter()
        .map(|(k, n)| format!("{n} {k}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn status(reg: &Registry, f: &OneFigure, only_stale: bool) -> Result<()> {
    let ws = f.root.workspace();
    let (graph, st) = planned_status(
        &ws,
        reg,
        &f.what_if,
        std::slice::from_ref(&f.id),
        &f.profile,
        &[],
    )?;
    let store = pipeline::Store::open(&ws.store)?;
    let jobs = slurm::job_states(&graph, &st, reg, &store);
    let running = pipeline::exec::running(&graph, &st, reg, &store);
    print_status(&graph, &st, only_stale, &jobs, &running);
    Ok(())
}

pub fn run(c: Commands) -> Result<()> {
    let reg = registry();
    match c {
        Commands::Figure(a) => figure(&reg, a),
        Commands::Calibrate {
            path,
            factor,
            min_seconds,
            root,
        } => {
            let ws = root.workspace();
            print!(
                "{}",
                crate::study::plan::calibrate(&ws, &reg, &path, factor, min_seconds)?
            );
            Ok(())
        }
        Commands::Plan(a) => plan(&reg, a),
        Commands::List { profile, root } => list(&reg, &profile, &root),
        Commands::Status(f) => status(&reg, &f, false),
        Commands::Why(f) => status(&reg, &f, true),
        Commands::Verify { root } => verify(&root),
        Commands::Runs(a) => super::runs::run(&reg, &a),
        Commands::Worker { store, key } => slurm::worker(&store, &reg, &key),
        Commands::Gc { dry_run, root } => {
            let r = pipeline::gc(&root.workspace(), &reg, dry_run)?;
            println!(
                "{} {} entries, {} artifacts, {:.1} MB, {} checkpoint directories of finished stages",
                if dry_run { "would free" } else { "freed" },
                r.entries,
                r.objects,
                r.bytes as f64 / 1e6,
                r.checkpoints
            );
            Ok(())
        }
    }
}

/// `repro figure`: build the figures (or with `--dry-run` say what would run)
/// on the executor asked for, then say what ran and which figures were written.
fn figure(reg: &Registry, a: FigureArgs) -> Result<()> {
    let FigureArgs {
        figures,
        jobs,
        dry_run,
        force,
        executor,
        what_if,
        root,
    } = a;
    let ws = root.workspace();
    let ids = figures.ids(&ws)?;
    let profile = figures.profile;
    for k in &force {
        reg.get(k)?;
    }
    if executor == Executor::Slurm && !what_if.is_empty() {
        bail!("--set applies to the local executor: Slurm workers plan the specs as the files say");
    }
    if dry_run && executor == Executor::Slurm {
        print!("{}", slurm::dry_run(&ws, reg, &ids, &profile, &force)?);
        return Ok(());
    }
    if dry_run {
        let (graph, st) = planned_status(&ws, reg, &what_if, &ids, &profile, &force)?;
        print_status(&graph, &st, false, &BTreeMap::new(), &BTreeMap::new());
        return Ok(());
    }
    let run = match executor {
        Executor::Local => {
            let opts = RunOptions {
                jobs: jobs.unwrap_or(RunOptions::default().jobs),
                force,
                progress: true,
            };
            let graph = what_if.plan(&ws, reg, &ids, &profile)?;
            pipeline::run_planned(&what_if.workspace(ws.clone()), reg, graph, &opts)?
        }
        Executor::Slurm => {
            if jobs.is_some() {
                bail!("--jobs applies to the local executor; Slurm runs every ready stage at once");
            }
            let opts = slurm::SlurmOptions::new(force, true)?;
            slurm::run_figures(&ws, reg, &ids, &profile, &opts)?
        }
    };
    print_run(&run, &what_if.workspace(ws).results);
    run.check()?;
    Ok(())
}

/// What `repro figure` says once its stages ended: the damaged artifacts it
/// met, how many stages were executed and cached, and the figures written
/// (under `results`).
fn print_run(run: &pipeline::FigureRun, results: &std::path::Path) {
    let count = |f: fn(&Outcome) -> bool| {
        run.report
            .results
            .values()
            .filter(|r| f(&r.outcome))
            .count()
    };
    for d in &run.report.damaged {
        eprintln!("warning: {d}");
    }
    eprintln!(
        "{} stage(s): {} executed, {} cached",
        run.report.results.len(),
        count(|o| *o == Outcome::Executed),
        count(|o| *o == Outcome::Cached)
    );
    for f in &run.graph.figures {
        if run.report.complete(f) {
            eprintln!("wrote {}", results.join(&f.id).display());
        }
    }
}

/// `repro plan`: the planned cost of the figures' build and, with `--check`,
/// the recorded CPU times against it, failing when too few lie within the
/// factor.
fn plan(reg: &Registry, a: PlanArgs) -> Result<()> {
    let PlanArgs {
        figures,
        check,
        factor,
        min_seconds,
        share,
        what_if,
        root,
    } = a;
    let ws = root.workspace();
    if !(share > 0.0 && share <= 1.0) {
        bail!(
            "--share {share}: the share of judged stages that must lie within the factor is a number in (0, 1]"
        );
    }
    let mut ids = figures.ids(&ws)?;
    let profile = figures.profile;
    let mut without = Vec::new();
    if figures.all {
        (ids, without) = plannable(&ws, reg, &profile)?;
    }
    let check = check.then_some(crate::study::plan::Check {
        factor,
        min_seconds,
    });
    let graph = what_if.plan(&ws, reg, &ids, &profile)?;
    let report = crate::study::plan::plan(&ws, reg, &graph, check.as_ref())?;
    print!("{}", report.text);
    if !without.is_empty() {
        println!(
            "\nnot planned at profile '{profile}' ({} figure(s)):",
            without.len()
        );
        for w in &without {
            println!("  {w}");
        }
    }
    if let Some(c) = &check
        && ((report.judged - report.outside) as f64) < share * report.judged as f64
    {
        bail!(
            "{} of {} judged (simulation configurations by the mean of their built runs, other stages one by one) have a recorded CPU time more than {}x or less than 1/{}x the planned: more than {:.0}% of them",
            report.outside,
            report.judged,
            c.factor,
            c.factor,
            100.0 * (1.0 - share)
        );
    }
    Ok(())
}

/// `repro plan --all`: every figure that `profile` reaches, and why each of
/// the others is not planned (a figure whose experiments have no `paper`
/// profile, say); an error when none is reached.
fn plannable(ws: &Workspace, reg: &Registry, profile: &str) -> Result<(Vec<String>, Vec<String>)> {
    let (mut ids, mut without) = (Vec::new(), Vec::new());
    for id in pipeline::Catalogue::load(&ws.root)?.pipelines.keys() {
        match pipeline::figure_status(ws, reg, std::slice::from_ref(id), profile, &[]) {
            Ok(_) => ids.push(id.clone()),
            Err(e) if format!("{e:#}").contains(&format!("no profile '{profile}'")) => {
                without.push(format!("{id}: {e:#}"))
            }
            Err(e) => return Err(e),
        }
    }
    if ids.is_empty() {
        bail!(
            "no figure can be planned at profile '{profile}':\n  {}",
            without.join("\n  ")
        );
    }
    Ok((ids, without))
}

/// `repro list`: each figure with its description and its cache state at
/// `profile`.
fn list(reg: &Registry, profile: &str, root: &RootArgs) -> Result<()> {
    let ws = root.workspace();
    let cat = pipeline::Catalogue::load(&ws.root)?;
    if cat.pipelines.is_empty() {
        bail!(
            "no figures: {} has no pipelines/*.yaml (use --root or REPRO_ROOT)",
            ws.root.display()
        );
    }
    for (id, (_, spec)) in &cat.pipelines {
        let state = match pipeline::figure_status(&ws, reg, std::slice::from_ref(id), profile, &[])
        {
            Ok((_, st)) => {
                let stale = st
                    .iter()
                    .filter(|(_, s)| !matches!(s, State::Cached { .. }))
                    .count();
                if stale == 0 {
                    "cached".to_string()
                } else {
                    format!("{stale}/{} stages to run", st.len())
                }
            }
            Err(e) => format!("cannot plan: {e:#}"),
        };
        println!("{id:<16} {:<60} [{profile}: {state}]", spec.description);
    }
    Ok(())
}

/// `repro verify`: check every artifact of the store against its hash; an
/// error when any was damaged (and quarantined).
fn verify(root: &RootArgs) -> Result<()> {
    let ws = root.workspace();
    let store = pipeline::Store::open(&ws.store)?;
    let r = store.verify()?;
    for d in &r.damaged {
        println!("{d}");
    }
    println!(
        "checked {} artifacts ({:.1} MB) in {}: {} damaged",
        r.objects,
        r.bytes as f64 / 1e6,
        ws.store.display(),
        r.damaged.len()
    );
    if !r.damaged.is_empty() {
        bail!(
            "{} damaged artifact(s) quarantined; `repro figure` recomputes their stages",
            r.damaged.len()
        );
    }
    Ok(())
}
