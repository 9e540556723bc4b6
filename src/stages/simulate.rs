//! `simulate`: one replica at one parameter point, as a trajectory (Parquet) and a
//! run summary (JSON).
//!
//! Run lengths follow tau_alpha: relaxing >= 9 tau_alpha (paper H) and lags up to
//! 10 tau_alpha need a length that grows by 10^3 over the phi sweep, so the spec
//! gives an *estimate* tau_guess(phi) = A exp[B / (phi0 - phi)] (a VFT law fitted
//! once to measured tau_alpha) and lengths in units of it:
//!
//! - relaxation `relax_tau` x tau_guess (at least `relax_min`);
//! - `origins` time origins spaced by `spacing_tau` x tau_guess;
//! - after each origin, `lags_per_decade` log-spaced lags from `lag_min` to
//!   `lag_max_tau` x tau_guess;
//! - optional `overlap_spacing_tau`: the same window with origins every
//!   `overlap_spacing_tau` x tau_guess (overlapping blocks: more origins for the
//!   same simulated time, more stored frames; [`crate::traj::Schedule::overlapping`]).
//!
//! Every other parameter is a [`SimConfig`] field (n, phi, eps, seed, ...).

use std::cell::Cell;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use serde_json::{Map, Value};

use super::run_length::RULE_KEYS;
pub use super::run_length::{Run, RunLength, TauGuess, run_config};
use crate::pipeline::canon::{ParamError, param_error};
use crate::pipeline::checkpoints::{Checkpoints, RunProgress, unix_now};
use crate::pipeline::registry::typed;
use crate::pipeline::stage::Holds;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::sim::run::checkpoint::Keeper;
use crate::sim::{self, SimConfig};

/// Split the stage parameters into the run-length rule and the SimConfig.
/// A flat `force: F` (a grid key: grid values are flat parameters and become table
/// columns) is the intruder's force: it sets `intruder.force`, creating the intruder
/// with paper I's radius and mass when `intruder` is not given.
fn force_into_intruder(mut rest: Map<String, Value>) -> Result<Map<String, Value>> {
    let Some(force) = rest.remove("force") else {
        return Ok(rest);
    };
    match rest
        .entry("intruder")
        .or_insert_with(|| Value::Object(Map::new()))
    {
        Value::Object(m) => {
            if m.contains_key("force") {
                return Err(param_error(
                    &["force"],
                    "simulate: `force` and `intruder.force` are both given; keep one".to_string(),
                ));
            }
            m.insert("force".into(), force);
        }
        _ => {
            return Err(param_error(
                &["intruder"],
                "simulate: `intruder` must be a map ({force: F, radius: R0, mass: m0}) when `force` is given"
                    .to_string(),
            ));
        }
    }
    Ok(rest)
}

/// Parse a simulation stage's parameters: the run-length rule, and every other
/// key a [`SimConfig`] field, resolved by the rule and checked.
pub fn config(params: &Value) -> Result<(RunLength, SimConfig)> {
    let obj = params
        .as_object()
        .context("simulate: parameters must be a map")?;
    let (rule, rest): (Map<String, Value>, Map<String, Value>) = obj
        .clone()
        .into_iter()
        .partition(|(k, _)| RULE_KEYS.contains(&k.as_str()));
    // The rule sets these: a value given beside it would be silently overwritten.
    for (key, set_by) in [
        (
            "relax_time",
            "relax_tau x tau_guess(phi), at least relax_min",
        ),
        (
            "schedule",
            "origins, spacing_tau, lag_min, lag_max_tau and lags_per_decade",
        ),
    ] {
        if rest.contains_key(key) {
            bail!(
                "simulate: `{key}` cannot be given with the run-length rule, which sets it from {set_by}; \
                 remove `{key}` or change those keys"
            );
        }
    }
    let rest = force_into_intruder(rest)?;
    let rule: RunLength = typed("simulate (run-length rule)", &Value::Object(rule))?;
    rule.check()?;
    let mut cfg: SimConfig =
        typed("simulate", &Value::Object(rest)).map_err(|e| match e.downcast::<ParamError>() {
            Ok(mut pe) => {
                pe.message = format!(
                    "{}; valid keys are the SimConfig fields (n, phi, eps, radius_ratio, ...) \
                     and the run-length rule ({})",
                    pe.message,
                    RULE_KEYS.join(", ")
                );
                pe.into()
            }
            Err(e) => e,
        })?;
    let phi = cfg.phi;
    // NaN-safe: a NaN phi is rejected too.
    if phi.partial_cmp(&rule.tau_guess.phi0) != Some(std::cmp::Ordering::Less) {
        return Err(param_error(
            &["phi"],
            format!(
                "simulate: phi = {phi} is at or beyond tau_guess.phi0 = {}, where the run-length rule diverges",
                rule.tau_guess.phi0
            ),
        ));
    }
    (cfg.relax_time, cfg.schedule) = rule.schedule(phi);
    cfg.validate()?;
    Ok((rule, cfg))
}

/// A run's every setting as a map: what [`Artifact::run`] carries to every
/// stage downstream of the run. It is resolved from the parameters when the
/// stage is planned, by the function the run itself uses ([`config`]), and is
/// kept out of the output files so that their digests, and the replica
/// identities derived from them (`jk_unit`), do not depend on it.
pub fn resolved(cfg: &SimConfig) -> Result<Map<String, Value>> {
    match serde_json::to_value(cfg)? {
        Value::Object(m) => Ok(m),
        other => bail!("internal: a SimConfig serialised to {other}"),
    }
}

/// Summary fields that measure the machine rather than the physics.
const MEASURED: &[&str] = &[
    "cpu_seconds",
    "collisions_per_second",
    "events_per_second",
    "peak_rss_bytes",
];

pub struct Simulate;

impl StageKind for Simulate {
    type Params = Run;
    fn name(&self) -> &str {
        "simulate"
    }
    fn describe(&self) -> &str {
        "one seeded event-driven simulation: trajectory (Parquet) and run summary (JSON)"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<Run> {
        let (rule, config) = config(params)?;
        Ok(Run { rule, config })
    }
    fn holds(&self) -> Holds {
        Holds::Trajectory
    }
    fn resolved(&self, run: &Run) -> Option<Map<String, Value>> {
        resolved(&run.config).ok()
    }
    fn run(&self, ctx: &StageCtx, run: &Run, _inputs: &[Artifact]) -> Result<Output> {
        let cfg = &run.config;
        let track = Track::default();
        let report = |p: sim::Progress| {
            ctx.progress(
                p.time,
                p.end,
                &format!(
                    "{:?} t = {:.1}/{:.1}, {:.2e} events/s",
                    p.stage, p.time, p.end, p.events_per_second
                ),
            );
            if let Some(dir) = ctx.checkpoints() {
                track.report(dir, &p);
            }
        };
        let mut keeper = ctx.checkpoints().map(|dir| StoreKeeper {
            ctx,
            dir,
            track: &track,
        });
        let (traj, summary) = sim::run::simulation::run_kept(
            cfg,
            &report,
            keeper.as_mut().map(|k| k as &mut dyn Keeper),
        )?;
        ctx.log(format!(
            "n = {}, phi = {}, T = {:.4}, {} collisions, {:.1} CPU s, {} guard activations",
            summary.n,
            summary.phi,
            summary.temperature,
            summary.collisions,
            summary.cpu_seconds,
            summary.guard_activations
        ));
        // Timings, speeds and memory differ between identical runs: they go in the
        // side record, so the summary file (and the digest) stays a pure function of
        // the parameters and a rerun is cut off early.
        let mut json = serde_json::to_value(&summary)?;
        let warnings: Vec<String> = cfg
            .guard_warning(summary.guard_activations, summary.collisions)
            .into_iter()
            .collect();
        for w in &warnings {
            ctx.log(format!("warning: {w}"));
        }
        if !warnings.is_empty()
            && let Some(obj) = json.as_object_mut()
        {
            obj.insert("warnings".into(), serde_json::to_value(&warnings)?);
        }
        let mut side = Map::new();
        if let Some(obj) = json.as_object_mut() {
            for k in MEASURED {
                if let Some(v) = obj.remove(*k) {
                    side.insert(k.to_string(), v);
                }
            }
        }
        Ok(Output::single(
            "parquet",
            crate::table::trajectory::to_parquet_bytes(&traj)?,
        )
        .with("json", serde_json::to_vec_pretty(&json)?)
        .with_side(Value::Object(side)))
    }
}

/// Where a simulation stage is, for its progress file: the last report and
/// when the file was written.
#[derive(Default)]
struct Track {
    last: Cell<Option<(sim::Progress, Instant)>>,
}

/// Seconds between two writes of the progress file.
const PROGRESS_EVERY: f64 = 2.0;

impl Track {
    /// Note a progress report; write the progress file if the last write is
    /// older than [`PROGRESS_EVERY`].
    fn report(&self, dir: &Checkpoints, p: &sim::Progress) {
        let due = self
            .last
            .get()
            .is_none_or(|(_, at)| at.elapsed().as_secs_f64() >= PROGRESS_EVERY);
        let at = match self.last.get() {
            Some((_, at)) if !due => at,
            _ => Instant::now(),
        };
        self.last.set(Some((*p, at)));
        if due {
            self.write(dir);
        }
    }

    /// Write the progress file (a failure only costs `repro status` its line).
    fn write(&self, dir: &Checkpoints) {
        let Some((p, _)) = self.last.get() else {
            return;
        };
        let progress = RunProgress {
            stage: format!("{:?}", p.stage).to_lowercase(),
            time: p.time,
            fraction: p.fraction,
            updated: unix_now(),
            host: hostname(),
            pid: std::process::id(),
        };
        let _ = dir.set_progress(&progress);
    }
}

/// This machine's name (for `repro status`).
fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_default()
}

/// A simulation's checkpoints in its stage's directory of the store: an
/// unusable one is quarantined, the checkpoint resumed from is logged.
struct StoreKeeper<'a> {
    ctx: &'a StageCtx,
    dir: &'a Checkpoints,
    track: &'a Track,
}

impl Keeper for StoreKeeper<'_> {
    fn saved(&mut self) -> Vec<String> {
        self.dir.saved().into_iter().map(|(name, _)| name).collect()
    }
    fn read(&mut self, name: &str) -> Result<Vec<u8>> {
        self.dir.read(name)
    }
    fn reject(&mut self, name: &str, why: &str) {
        let moved = match self.dir.quarantine(name) {
            Ok(to) => format!("moved to {}", to.display()),
            Err(e) => format!("could not be moved aside: {e:#}"),
        };
        self.ctx.note(format!(
            "checkpoint {} is unusable ({why}); {moved}",
            self.dir.dir().join(name).display()
        ));
    }
    fn resumed(&mut self, name: &str, time: f64) {
        self.ctx.note(format!(
            "resumed from the checkpoint at t = {time} ({name})"
        ));
    }
    fn save(&mut self, time: f64, bytes: &[u8]) -> Result<()> {
        // A checkpoint that cannot be written only costs a longer rerun.
        match self.dir.save(time, bytes) {
            Ok(_) => self.track.write(self.dir),
            Err(e) => self
                .ctx
                .log(format!("warning: no checkpoint at t = {time}: {e:#}")),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Value {
        serde_json::json!({
            "n": 100, "phi": 0.7, "eps": 0.9, "seed": 3,
            "tau_guess": {"A": 0.1, "B": 1.0, "phi0": 0.8},
            "relax_tau": 9.0, "origins": 3, "spacing_tau": 2.0,
            "lag_min": 0.1, "lag_max_tau": 10.0, "lags_per_decade": 4
        })
    }

    #[test]
    fn run_lengths_scale_with_the_tau_estimate() {
        let (rule, cfg) = config(&params()).unwrap();
        let tau = 0.1 * (1.0f64 / 0.1).exp();
        assert!((cfg.relax_time - 9.0 * tau).abs() < 1e-9 * tau);
        assert!((cfg.schedule.origin_spacing - 2.0 * tau).abs() < 1e-9 * tau);
        let last = *cfg.schedule.lags.last().unwrap();
        assert!((last - 10.0 * tau).abs() < 1e-9 * last);
        assert_eq!(rule.origins, cfg.schedule.origins);

        // Overlapping origins: the same last frame, origins every 0.5 tau.
        let mut p = params();
        p["overlap_spacing_tau"] = serde_json::json!(0.5);
        let (_, o) = config(&p).unwrap();
        assert_eq!(o.schedule.origins, 9);
        assert!((o.schedule.end() - cfg.schedule.end()).abs() < 1e-9 * last);
        assert_eq!(o.relax_time, cfg.relax_time);
    }

    #[test]
    fn the_resolved_configuration_travels_and_reads_back_as_the_run_s() {
        let p = params();
        let run = Simulate.parse(&p).unwrap();
        let (_, cfg) = config(&p).unwrap();
        assert_eq!(run.config, cfg);
        // Defaults and the rule's relaxation and schedule are in it, not only
        // the keys the spec gave.
        let map = Simulate.resolved(&run).unwrap();
        for key in [
            "eps",
            "phi",
            "seed",
            "relax_time",
            "schedule",
            "gamma",
            "drive",
        ] {
            assert!(map.contains_key(key), "{key} missing from {map:?}");
        }
        let dir = tempfile::tempdir().unwrap();
        let mut a = crate::stages::test_support::artifact(
            dir.path(),
            "sim",
            crate::table::f64_batch(&[("x", vec![0.0])]).unwrap(),
        );
        a.run = std::sync::Arc::new(map);
        assert_eq!(run_config(&a).unwrap(), cfg);
    }

    #[test]
    fn bad_parameters_are_named() {
        let mut p = params();
        p["phi"] = serde_json::json!(0.81);
        assert!(format!("{:#}", config(&p).unwrap_err()).contains("phi0"));
        let mut p = params();
        p["colour"] = serde_json::json!(1);
        let e = format!("{:#}", config(&p).unwrap_err());
        assert!(e.contains("colour") && e.contains("SimConfig"), "{e}");
        let mut p = params();
        p["relax_tau"] = serde_json::json!(-1.0);
        assert!(format!("{:#}", config(&p).unwrap_err()).contains("relax_tau"));
        // A relax_time or schedule beside the rule is refused, not overwritten.
        for key in ["relax_time", "schedule"] {
            let mut p = params();
            p[key] = serde_json::json!(100.0);
            let e = format!("{:#}", config(&p).unwrap_err());
            assert!(e.contains(key) && e.contains("run-length rule"), "{e}");
        }
    }

    #[test]
    fn a_flat_force_is_the_intruders() {
        // Paper I's intruder (R0 = 2, m0 = 4) from a flat grid key.
        let mut p = params();
        p["force"] = serde_json::json!(8.0);
        let (_, cfg) = config(&p).unwrap();
        let i = cfg.intruder.unwrap();
        assert_eq!((i.force, i.radius, i.mass), (8.0, 2.0, 4.0));
        // Merged into a given intruder map.
        p["intruder"] = serde_json::json!({"radius": 2.5});
        let i = config(&p).unwrap().1.intruder.unwrap();
        assert_eq!((i.force, i.radius), (8.0, 2.5));
        // Both given, or an intruder that is not a map: errors naming the key.
        p["intruder"] = serde_json::json!({"force": 2.0});
        let e = format!("{:#}", config(&p).unwrap_err());
        assert!(e.contains("`force` and `intruder.force`"), "{e}");
        p["intruder"] = serde_json::json!(5);
        let e = format!("{:#}", config(&p).unwrap_err());
        assert!(e.contains("`intruder` must be a map"), "{e}");
    }
}
