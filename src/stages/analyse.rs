//! The analysis stage: every observable of `src/analysis` ([`OBSERVABLES`]) as a
//! stage kind of the same name. It decodes the gathered trajectories (replicas of
//! one state point, typically `gather: [experiment]` with `by: [phi]`), calls the
//! observable and writes its tables, with how the errors were estimated in the
//! Parquet metadata (`errors`, `replicas`).
//!
//! Times in units of a measured time: `time_unit: {from: tau}` names the stage
//! (gathered too) whose table holds it (column `tau_alpha` unless `column` says
//! otherwise); the main table then gets `t_over_tau_alpha`, and `at: [0.01, 1, 8.5]`
//! reads the observable at those multiples (the lags it sets on the parsed
//! parameters, [`ObservableParams::set_lags`]): a curve of t is computed at the two
//! recorded lags around each and interpolated linearly in ln t (P(Nc) too, bin by
//! bin); a configuration (clusters, a mobility snapshot) at the nearest recorded
//! lag ([`lags::AtLag`]).
//! The lags and weights are listed in `at.parquet`; a request past the last lag
//! fails.
//!
//! `skip_origins: f` leaves the earliest fraction f of the time origins out of
//! the analysis (the run's non-stationary start, [`crate::analysis::window`]).

use std::sync::Arc;

use anyhow::{Context, Result, bail};
use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use serde::Deserialize;
use serde_json::Value;

use super::tables::{Columns, inputs_of, trajectories};
use crate::analysis::drive::DriveParams;
use crate::analysis::observable_params::{LagsFrom, ObservableParams};
use crate::analysis::observables::{OBSERVABLES, Observable};
use crate::analysis::pool::{JK_UNIT, MAX_JK_REPLICAS, jk_column};
use crate::analysis::{DEFAULT_REL_TOL, lags};
use crate::pipeline::canon::param_error;
use crate::pipeline::stage::{Holds, PlannedInput};
use crate::pipeline::{Artifact, Output, Registry, StageCtx, StageKind};
use crate::sim::{ForceMode, SimConfig};
use crate::table::{f64_batch, to_parquet_bytes};
use crate::traj::Trajectory;

/// The measured time that `at` and `t_over_*` are in units of.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TimeUnit {
    /// The stage that measured it (listed in `gather` too).
    from: String,
    /// Its column in that stage's table.
    #[serde(default = "tau_alpha")]
    column: String,
}

fn tau_alpha() -> String {
    "tau_alpha".into()
}

/// The stage's own parameters, split from the observable's (parsed into its type).
pub struct Split {
    observable: Box<dyn ObservableParams>,
    unit: Option<TimeUnit>,
    at: Option<Vec<f64>>,
    /// Fraction of the time origins, earliest first, left out of the analysis.
    skip_origins: Option<f64>,
}

/// The keys of every analysis stage; the others are the observable's.
const STAGE_KEYS: &[&str] = &["time_unit", "at", "skip_origins"];

fn split(obs: &Observable, params: &Value) -> Result<Split> {
    let name = obs.name;
    let map = params
        .as_object()
        .with_context(|| format!("parameters of analysis `{name}` must be a mapping"))?;
    let unit: Option<TimeUnit> = map
        .get("time_unit")
        .map(TimeUnit::deserialize)
        .transpose()
        .with_context(|| format!("parameters of analysis `{name}`: `time_unit` wants {{from: STAGE, column: tau_alpha}}"))?;
    let at: Option<Vec<f64>> = map
        .get("at")
        .map(Vec::deserialize)
        .transpose()
        .with_context(|| format!("parameters of analysis `{name}`: `at` wants a list of multiples, e.g. [0.01, 1, 8.5]"))?;
    let skip_origins: Option<f64> = map
        .get("skip_origins")
        .map(f64::deserialize)
        .transpose()
        .with_context(|| format!("parameters of analysis `{name}`: `skip_origins` wants a fraction in [0, 1), e.g. 0.5"))?;
    if let Some(f) = skip_origins
        && !(f.is_finite() && (0.0..1.0).contains(&f))
    {
        bail!(
            "parameters of analysis `{name}`: `skip_origins` is the fraction of time origins left out, in [0, 1); got {f}"
        );
    }
    if at.is_some() && unit.is_none() {
        bail!(
            "parameters of analysis `{name}`: `at` needs `time_unit: {{from: STAGE}}`, the stage that measured the time it is in units of"
        );
    }
    let own: serde_json::Map<String, Value> = map
        .iter()
        .filter(|(k, _)| !STAGE_KEYS.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let lags = if at.is_some() {
        LagsFrom::At
    } else {
        LagsFrom::Params
    };
    Ok(Split {
        observable: obs.parse(&Value::Object(own), lags)?,
        unit,
        at,
        skip_origins,
    })
}

/// The measured time of stage `u.from` with each replica left out
/// (`COLUMN_jkK`), when it was measured on the same replicas as this analysis
/// (same `jk_unit`): the replica samples of an analysis at multiples of it then
/// use the time measured without the same replica, so that its share of the
/// variance is counted. None otherwise.
fn measured_samples(name: &str, u: &TimeUnit, inputs: &[Artifact], unit: f64) -> Option<Vec<f64>> {
    let arts = inputs_of(name, inputs, &u.from).ok()?;
    let cols = Columns::read(&arts).ok()?;
    let same = cols
        .col(JK_UNIT)
        .ok()?
        .iter()
        .all(|v| v.to_bits() == unit.to_bits());
    if !same {
        return None;
    }
    let v: Vec<f64> = (0..MAX_JK_REPLICAS)
        .map_while(|k| cols.col(&jk_column(&u.column, k)).ok()?.first().copied())
        .collect();
    v.iter().all(|x| x.is_finite() && *x > 0.0).then_some(v)
}

/// The gathered trajectories, each cut to its analysed window: the fraction
/// `skip` of its origins when the stage gives `skip_origins`, else the one its
/// experiment's window (an input holding [`Holds::Window`]) gives at its phi,
/// else every origin.
fn windowed(
    ctx: &StageCtx,
    name: &str,
    skip: Option<f64>,
    inputs: &[Artifact],
) -> Result<Vec<Trajectory>> {
    let trajs = trajectories(name, inputs)?;
    let windows: Vec<&Artifact> = inputs
        .iter()
        .filter(|a| a.kind.holds == Holds::Window)
        .collect();
    let window = if windows.is_empty() || skip.is_some() {
        None
    } else {
        Some(Columns::read(&windows)?)
    };
    let sims = inputs.iter().filter(|a| a.kind.holds == Holds::Trajectory);
    trajs
        .into_iter()
        .zip(sims)
        .map(|(t, a)| {
            let f = match (skip, &window) {
                (Some(f), _) => f,
                (None, Some(w)) => {
                    let phi = a
                        .point
                        .get("phi")
                        .and_then(Value::as_f64)
                        .with_context(|| {
                            format!(
                                "{name}: the run {} has no phi to read its window at",
                                a.label
                            )
                        })?;
                    skip_at(w, phi).with_context(|| format!("{name}: {}", a.label))?
                }
                (None, None) => return Ok(t),
            };
            if f == 0.0 {
                return Ok(t);
            }
            ctx.log(format!(
                "{}: the earliest {f} of its time origins left out",
                a.label
            ));
            crate::analysis::window::skip_origins(&t, f)
                .with_context(|| format!("{name}: the window of {}", a.label))
        })
        .collect()
}

/// The fraction of origins the window table of an experiment leaves out at
/// `phi` (within 1e-9): the window an analysis of a run at `phi` keeps.
fn skip_at(window: &Columns, phi: f64) -> Result<f64> {
    let (skip, _) = window
        .value_of("skip_origins", &[("phi".to_string(), phi)])
        .context("the experiment's window")?;
    Ok(skip)
}

/// The jackknife unit of an analysis: named by its gathered trajectories'
/// digests, so that every analysis of the same runs shares it.
fn replica_unit(inputs: &[Artifact]) -> f64 {
    let mut digests: Vec<&str> = inputs
        .iter()
        .filter(|a| a.kind.holds == Holds::Trajectory)
        .map(|a| a.digest.as_str())
        .collect();
    digests.sort_unstable();
    let h = blake3::hash(digests.concat().as_bytes());
    (u64::from_le_bytes(h.as_bytes()[..8].try_into().expect("8 bytes")) >> 16) as f64
}

/// The measured time from the input of stage `u.from`: one finite value.
fn measured(name: &str, u: &TimeUnit, inputs: &[Artifact]) -> Result<f64> {
    let arts = inputs_of(name, inputs, &u.from)?;
    let cols = Columns::read(&arts)?;
    let v = cols.col(&u.column)?;
    let first = *v
        .first()
        .with_context(|| format!("{name}: the table of stage '{}' is empty", u.from))?;
    if v.iter().any(|x| x.to_bits() != first.to_bits()) {
        bail!(
            "{name}: stage '{}' gives {} different values of {} to this instance; gather it `by` the same keys so one value applies",
            u.from,
            v.len(),
            u.column
        );
    }
    if !(first.is_finite() && first > 0.0) {
        bail!(
            "{name}: {} from stage '{}' is {first} (not measured at this point?): cannot express times in its units",
            u.column,
            u.from
        );
    }
    Ok(first)
}

/// `b` with `t / unit` appended as `t_over_<column>` when it has a float column `t`.
fn with_scaled_t(b: RecordBatch, unit: f64, column: &str) -> Result<RecordBatch> {
    let Some(t) = b
        .column_by_name("t")
        .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
    else {
        return Ok(b);
    };
    let scaled: ArrayRef = Arc::new(Float64Array::from_iter(
        t.iter().map(|x| x.map(|x| x / unit)),
    ));
    let mut cols: Vec<(String, ArrayRef)> = b
        .schema()
        .fields()
        .iter()
        .zip(b.columns())
        .map(|(f, c)| (f.name().clone(), c.clone()))
        .collect();
    cols.push((format!("t_over_{column}"), scaled));
    Ok(RecordBatch::try_from_iter(cols)?)
}

/// Plan-time check of `at`: the largest requested multiple of the measured time
/// must lie within the lags that each gathered simulation's run-length rule
/// records, in units of its estimate tau_guess (the measured time is not known
/// before the run; the run-time refusal against it stays the last guard).
fn covered_by_run_length(at: &[f64], u: &TimeUnit, inputs: &[PlannedInput]) -> Result<()> {
    let Some(want) = at.iter().copied().reduce(f64::max) else {
        return Ok(());
    };
    let ruled = inputs
        .iter()
        .filter(|n| n.kind.holds == Holds::Trajectory && n.params.get("lag_max_tau").is_some());
    for n in ruled {
        let super::run_length::Run { rule, config: cfg } = n.parsed.get()?;
        let reach = cfg.schedule.lags.last().copied().unwrap_or(0.0) / rule.tau_guess.at(cfg.phi);
        if want > reach * (1.0 + 1e-9) {
            let experiment = n.ids.first().map_or("?", |id| id.stage.as_str());
            let file = n.file.display();
            return Err(param_error(
                &["at"],
                format!(
                    "`at` asks for {want} {col} (measured by stage '{from}'), but the lags of experiment '{experiment}' reach only {reach:.3} tau_guess at phi = {phi} (its run-length rule: lag_max_tau = {lmt}); raise `lag_max_tau` in {file} to at least {want}, or ask for less",
                    col = u.column,
                    from = u.from,
                    phi = cfg.phi,
                    lmt = rule.lag_max_tau,
                ),
            ));
        }
    }
    Ok(())
}

/// The drive of the runs an intruder analysis reads: eps, gamma, T and, with
/// the force as kicks, their rate factor. The observable takes them from the
/// run it analyses, never from a copy in the pipeline that could drift.
#[derive(Debug, Clone, PartialEq)]
struct RunDrive {
    drive: DriveParams,
    kick_rate_factor: Option<f64>,
}

/// The settings of a run ([`Artifact::run`]) that [`RunDrive`] reads: they join the stage's key.
const DRIVE_SETTINGS: &[&str] = &["eps", "gamma", "temperature", "intruder"];

impl RunDrive {
    fn of(cfg: &SimConfig) -> Self {
        RunDrive {
            drive: DriveParams {
                eps: cfg.eps,
                gamma: cfg.gamma,
                temperature: cfg.temperature,
            },
            kick_rate_factor: cfg
                .intruder
                .as_ref()
                .filter(|i| i.force_mode == ForceMode::Kicks)
                .map(|i| i.kick_rate_factor),
        }
    }

    /// The one drive of every run gathered (`runs`: where each is declared,
    /// and its configuration); `None` without runs.
    fn shared(
        name: &str,
        runs: impl IntoIterator<Item = (String, SimConfig)>,
    ) -> Result<Option<(String, Self)>> {
        let mut first: Option<(String, Self)> = None;
        for (source, cfg) in runs {
            let d = Self::of(&cfg);
            match &first {
                None => first = Some((source, d)),
                Some((f, fd)) if *fd != d => bail!(
                    "{name}: the gathered runs differ in their drive ({f}: {fd:?}; {source}: {d:?}); gather runs of one drive"
                ),
                Some(_) => {}
            }
        }
        Ok(first)
    }

    /// A copy of the drive in the pipeline (`drive`, `kick_rate_factor`) is
    /// accepted only when it equals the run's (`source` says where that is).
    fn check_copy(&self, observable: &dyn ObservableParams, source: &str) -> Result<()> {
        let (drive, kick_rate_factor) = observable.drive();
        if let Some(copy) = drive {
            let pairs = [
                ("eps", copy.eps, self.drive.eps),
                ("gamma", copy.gamma, self.drive.gamma),
                ("temperature", copy.temperature, self.drive.temperature),
            ];
            for (key, mine, run) in pairs {
                if mine.to_bits() != run.to_bits() {
                    return Err(param_error(
                        &["drive", key],
                        format!(
                            "`drive.{key}` = {mine} here, but {source} runs with {key} = {run} (its `{key}`); leave `drive` out: the analysis reads it from the run"
                        ),
                    ));
                }
            }
        }
        if let Some(k) = kick_rate_factor {
            let run = match self.kick_rate_factor {
                Some(r) if r.to_bits() == k.to_bits() => return Ok(()),
                Some(r) => {
                    format!("kicks at kick_rate_factor = {r} (its `intruder.kick_rate_factor`)")
                }
                None => "applies the force exactly (its `intruder.force_mode` is not `kicks`)"
                    .to_string(),
            };
            return Err(param_error(
                &["kick_rate_factor"],
                format!(
                    "`kick_rate_factor` = {k} here, but {source} {run}; leave it out: the analysis reads it from the run"
                ),
            ));
        }
        Ok(())
    }
}

/// Plan-time check of an intruder analysis: its runs share one drive, and a
/// copy of it in the pipeline equals theirs.
fn planned_drive(
    name: &str,
    observable: &dyn ObservableParams,
    inputs: &[PlannedInput],
) -> Result<()> {
    let mut runs = Vec::new();
    for n in inputs.iter().filter(|n| n.kind.holds == Holds::Trajectory) {
        let super::run_length::Run { config, .. } = n.parsed.get()?;
        let experiment = n.ids.first().map_or("?", |id| id.stage.as_str());
        runs.push((
            format!("experiment '{experiment}' ({})", n.file.display()),
            config.clone(),
        ));
    }
    match RunDrive::shared(name, runs)? {
        Some((source, d)) => d.check_copy(observable, &source),
        None => Ok(()),
    }
}

/// An observable that takes one reads the drive of the gathered runs.
fn take_run_drive(
    obs: &Observable,
    observable: &mut dyn ObservableParams,
    inputs: &[Artifact],
) -> Result<()> {
    if !obs.takes_drive {
        return Ok(());
    }
    let runs = inputs
        .iter()
        .filter(|a| a.kind.holds == Holds::Trajectory)
        .map(|a| Ok((a.label.clone(), super::run_length::run_config(a)?)))
        .collect::<Result<Vec<_>>>()?;
    if let Some((source, d)) = RunDrive::shared(obs.name, runs)? {
        d.check_copy(observable, &source)?;
        observable.set_drive(d.drive, d.kick_rate_factor);
    }
    Ok(())
}

/// Observables with time-block errors that also get replica samples: S4, whose
/// OZ fit per state point gives the xi that the xi fits and the collapse of
/// Fig. 19 refit with one replica left out; the intruder's stationary velocity,
/// whose time blocks within a run are not independent at strong force (the bath
/// heats along the run), so that the velocity-force fits of paper I take their
/// errors from the independent replicas.
const TIME_BLOCKS_WITH_REPLICA_SAMPLES: &[&str] = &["s4", "intruder_velocity"];

/// Replica means (`Errors::Mean`) that carry replica samples too: aging's
/// tau_alpha(t0), whose neighbouring waiting times share one run's stretch
/// of time, so that a fit across t0 (fig2's drift) scatters as its replicas
/// do, not as its points about the line (which counts correlated points as
/// independent and quoted half the seed-to-seed spread).
const MEANS_WITH_REPLICA_SAMPLES: &[&str] = &["aging"];

/// The replica jackknife columns (`X_jk0`, ..., `jk_unit`; `pool::with_replica_samples`)
/// of an observable pooled over 2 to `MAX_JK_REPLICAS` replicas: the same
/// observable with each replica left out, so that a fit downstream can refit
/// without it (`pool::replica_jackknife`). `params[k]` are the observable's
/// parameters for the sample without replica k (the lags of `at` from the time
/// measured without it); one entry serves every sample.
fn replica_samples(
    ctx: &StageCtx,
    obs: &Observable,
    refs: &[&Trajectory],
    params: &[Box<dyn ObservableParams>],
    unit: f64,
    tables: &mut crate::analysis::observables::Tables,
    read_off: &dyn Fn(Option<usize>, &RecordBatch) -> Result<RecordBatch>,
) -> Result<()> {
    use crate::analysis::pool::{self, Errors};
    let pooled = match tables.errors {
        Errors::Jackknife { .. } | Errors::SeedToSeed { .. } => true,
        Errors::TimeBlocks { .. } => TIME_BLOCKS_WITH_REPLICA_SAMPLES.contains(&obs.name),
        Errors::Mean { .. } if MEANS_WITH_REPLICA_SAMPLES.contains(&obs.name) => true,
        _ => !tables.left_out.is_empty(),
    };
    if !pooled || refs.len() < 2 || refs.len() > pool::MAX_JK_REPLICAS {
        return Ok(());
    }
    // The observable's own samples (main table only, at the full table's lags),
    // else the observable recomputed on the other replicas.
    let mut samples = Vec::new();
    let mains: Vec<RecordBatch> = if tables.left_out.is_empty() {
        for k in 0..refs.len() {
            let others: Vec<&Trajectory> = (0..refs.len())
                .filter(|&j| j != k)
                .map(|j| refs[j])
                .collect();
            let mut t = obs.compute(&others, params[k.min(params.len() - 1)].as_ref())?;
            // At `at`'s requests for this replica's measured time (the full
            // table's when there is one set of lags for all).
            let key = (params.len() > 1).then_some(k);
            t.main = read_off(key, &t.main)?;
            for (_, b) in t.extra.iter_mut() {
                *b = read_off(key, b)?;
            }
            samples.push(t);
        }
        samples.iter().map(|s| s.main.clone()).collect()
    } else {
        std::mem::take(&mut tables.left_out)
    };
    match pool::with_replica_samples(&tables.main, &mains, unit)? {
        Some(b) => tables.main = b,
        None => ctx.log(format!(
            "{}: a replica left out changes the table's shape: no replica jackknife columns",
            obs.name
        )),
    }
    for (file, b) in tables.extra.iter_mut() {
        let extra: Option<Vec<RecordBatch>> = samples
            .iter()
            .map(|s| {
                s.extra
                    .iter()
                    .find(|(f, _)| f == file)
                    .map(|(_, t)| t.clone())
            })
            .collect();
        if let Some(extra) = extra
            && !extra.is_empty()
            && let Some(with) = pool::with_replica_samples(b, &extra, unit)?
        {
            *b = with;
        }
    }
    Ok(())
}

/// One observable as a stage kind.
pub struct Analyse {
    obs: &'static Observable,
}

impl Analyse {
    pub fn new(obs: &'static Observable) -> Self {
        Analyse { obs }
    }
}

impl Analyse {
    /// The observable's own parameters, from its typed parameters.
    pub fn params(&self) -> Vec<String> {
        self.obs.param_keys()
    }
}

/// Register one analysis kind per observable.
pub fn register(r: &mut Registry) {
    for o in OBSERVABLES {
        r.register(Analyse::new(o));
    }
}

impl StageKind for Analyse {
    type Params = Split;
    fn name(&self) -> &str {
        self.obs.name
    }
    fn describe(&self) -> &str {
        self.obs.describe
    }
    fn details(&self) -> String {
        format!(
            "parameters: {keys} (docs/analysis.md), and of every analysis\n  \
             time_unit: {{from: STAGE, column: tau_alpha}}  adds t_over_tau_alpha\n  \
             at: [0.01, 1, 8.5]  read at these multiples of the measured time, interpolated in ln t (at.parquet)\n  \
             skip_origins: 0.5  leave out this fraction of the time origins, earliest first (a non-stationary start)\n\
             example: {{name: {n}, kind: {n}, gather: [eps09], by: [phi]}}",
            keys = self.params().join(", "),
            n = self.obs.name
        )
    }
    fn modules(&self) -> &[&str] {
        // The observable's own code is reached through the catalogue
        // (`analysis::observables`), which names them all ...
        &[file!()]
    }
    fn not_followed(&self) -> Vec<(&'static str, &'static str)> {
        // ... and only its own: the catalogue's edges to the other
        // observables' modules are cut.
        self.obs.not_followed()
    }
    fn takes_window(&self, s: &Split) -> bool {
        // A stage's own `skip_origins` is its window: it reads no other.
        self.obs.windowed && s.skip_origins.is_none()
    }
    fn parse(&self, params: &Value) -> Result<Split> {
        split(self.obs, params)
    }
    fn check_inputs(&self, s: &Split, inputs: &[PlannedInput]) -> Result<()> {
        if self.obs.takes_drive {
            planned_drive(self.obs.name, s.observable.as_ref(), inputs)?;
        }
        match (&s.at, &s.unit) {
            (Some(at), Some(u)) => covered_by_run_length(at, u, inputs),
            _ => Ok(()),
        }
    }
    fn reads_run(&self, _s: &Split) -> Vec<String> {
        if self.obs.takes_drive {
            DRIVE_SETTINGS.iter().map(|k| k.to_string()).collect()
        } else {
            Vec::new()
        }
    }
    fn run(&self, ctx: &StageCtx, s: &Split, inputs: &[Artifact]) -> Result<Output> {
        let name = self.obs.name;
        let trajs = windowed(ctx, name, s.skip_origins, inputs)?;
        let refs: Vec<&Trajectory> = trajs.iter().collect();
        let unit = s
            .unit
            .as_ref()
            .map(|u| measured(name, u, inputs).map(|v| (v, u)))
            .transpose()?;
        let mut obs = s.observable.clone();
        take_run_drive(self.obs, obs.as_mut(), inputs)?;
        let mut at_table = None;
        let jk_unit = replica_unit(inputs);
        let mut sample_obs = Vec::new();
        // The requests of `at` for the full table and for each replica left out.
        let mut requests: Option<Vec<lags::InUnits>> = None;
        let mut sample_requests: Vec<Vec<lags::InUnits>> = Vec::new();
        if let (Some(at), Some((unit, u))) = (&s.at, unit) {
            let rel_tol = obs.lags().map_or(DEFAULT_REL_TOL, |l| l.rel_tol());
            let recorded = lags::every_origin(&refs, None, rel_tol)?.unwrap_or_default();
            let nearest = self.obs.at == lags::AtLag::Nearest;
            let at_lags = |unit: f64| -> Result<Vec<lags::InUnits>> {
                let r = lags::in_units(&recorded, unit, &u.column, at, rel_tol)
                    .with_context(|| format!("{name}: `at`"))?;
                Ok(if nearest {
                    r.into_iter().map(lags::InUnits::nearest).collect()
                } else {
                    r
                })
            };
            let r = at_lags(unit)?;
            for x in &r {
                ctx.log(if x.below == x.above {
                    format!(
                        "{} {} = {:.6} -> recorded lag {:.6} ({:+.2}%)",
                        x.multiple,
                        u.column,
                        x.requested,
                        x.below,
                        100.0 * (x.below / x.requested - 1.0)
                    )
                } else {
                    format!(
                        "{} {} = {:.6}: between the recorded lags {:.6} and {:.6} (weight {:.3} on the second)",
                        x.multiple, u.column, x.requested, x.below, x.above, x.weight
                    )
                });
            }
            obs.set_lags(lags::bracketing_lags(&r));
            at_table = Some(f64_batch(&[
                ("multiple", r.iter().map(|x| x.multiple).collect()),
                ("requested", r.iter().map(|x| x.requested).collect()),
                ("lag_below", r.iter().map(|x| x.below).collect()),
                ("lag_above", r.iter().map(|x| x.above).collect()),
                ("weight_above", r.iter().map(|x| x.weight).collect()),
                (u.column.as_str(), vec![unit; r.len()]),
            ])?);
            // Samples at the lags of the time measured without the same replica.
            if let Some(units) = measured_samples(name, u, inputs, jk_unit)
                && units.len() == refs.len()
            {
                sample_requests = units.iter().map(|&v| at_lags(v)).collect::<Result<_>>()?;
                sample_obs = sample_requests
                    .iter()
                    .map(|r| {
                        let mut o = obs.clone();
                        o.set_lags(lags::bracketing_lags(r));
                        o
                    })
                    .collect();
                ctx.log(format!(
                    "replica samples at the lags of {} measured with the same replica left out",
                    u.column
                ));
            }
            requests = Some(r);
        }
        if sample_obs.is_empty() {
            sample_obs.push(obs.clone());
        }
        // Rows at the bracketing lags -> rows at the requested times.
        let read_off = |k: Option<usize>, b: &RecordBatch| -> Result<RecordBatch> {
            match (&requests, k.and_then(|k| sample_requests.get(k))) {
                (_, Some(r)) | (Some(r), None) => lags::at_requests(b, r),
                (None, None) => Ok(b.clone()),
            }
        };
        let mut tables = self.obs.compute(&refs, obs.as_ref())?;
        tables.main = read_off(None, &tables.main)?;
        for (_, b) in tables.extra.iter_mut() {
            *b = read_off(None, b)?;
        }
        for b in tables.left_out.iter_mut() {
            *b = read_off(None, b)?;
        }
        replica_samples(
            ctx,
            self.obs,
            &refs,
            &sample_obs,
            jk_unit,
            &mut tables,
            &read_off,
        )?;
        if let Some((unit, u)) = unit {
            tables.main = with_scaled_t(tables.main, unit, &u.column)?;
        }
        if let Some(b) = at_table {
            tables.extra.push(("at.parquet", b));
        }
        let errors = tables.errors.describe();
        let replicas = refs.len().to_string();
        let meta = [("errors", errors.as_str()), ("replicas", replicas.as_str())];
        ctx.log(format!("{}: errors {errors}", self.obs.name));
        let mut out = Output::single("parquet", to_parquet_bytes(&[tables.main], &meta)?);
        for (file, b) in tables.extra {
            out = out.with(file, to_parquet_bytes(&[b], &meta)?);
        }
        Ok(out)
    }
}
