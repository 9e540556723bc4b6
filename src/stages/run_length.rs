//! A simulation stage's parameters as its consumers read them: the run-length
//! rule (lengths in units of an estimate tau_guess(phi) of tau_alpha) and the
//! configuration it resolves to. Below the engine, so that a stage that reads a
//! run's parameters (an analysis checking its lags) does not run the simulator.

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use serde_json::Value;

use crate::pipeline::Artifact;
use crate::pipeline::canon::param_error;
use crate::sim::SimConfig;
use crate::traj::Schedule;

/// An estimate of tau_alpha(phi): A exp[B / (phi0 - phi)].
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TauGuess {
    #[serde(rename = "A")]
    pub a: f64,
    #[serde(rename = "B")]
    pub b: f64,
    pub phi0: f64,
}

impl TauGuess {
    pub fn at(&self, phi: f64) -> f64 {
        self.a * (self.b / (self.phi0 - phi)).exp()
    }
}

/// The run-length rule (keys of the stage parameters besides the SimConfig ones).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RunLength {
    pub tau_guess: TauGuess,
    pub relax_tau: f64,
    #[serde(default)]
    pub relax_min: f64,
    pub origins: usize,
    pub spacing_tau: f64,
    pub lag_min: f64,
    pub lag_max_tau: f64,
    pub lags_per_decade: usize,
    #[serde(default)]
    pub overlap_spacing_tau: Option<f64>,
}

pub(super) const RULE_KEYS: &[&str] = &[
    "tau_guess",
    "relax_tau",
    "relax_min",
    "origins",
    "spacing_tau",
    "lag_min",
    "lag_max_tau",
    "lags_per_decade",
    "overlap_spacing_tau",
];

impl RunLength {
    /// Relaxation time and frame schedule at packing fraction `phi`.
    pub fn schedule(&self, phi: f64) -> (f64, Schedule) {
        let tau = self.tau_guess.at(phi);
        let lag_max = (self.lag_max_tau * tau).max(self.lag_min * 10.0);
        let s = Schedule {
            start: 0.0,
            origins: self.origins,
            origin_spacing: self.spacing_tau * tau,
            lags: Schedule::log_lags(self.lag_min, lag_max, self.lags_per_decade),
        };
        (
            (self.relax_tau * tau).max(self.relax_min),
            match self.overlap_spacing_tau {
                Some(o) => s.overlapping(o * tau),
                None => s,
            },
        )
    }

    pub(super) fn check(&self) -> Result<()> {
        let g = &self.tau_guess;
        for (name, v) in [
            ("tau_guess.A", g.a),
            ("relax_tau", self.relax_tau),
            ("spacing_tau", self.spacing_tau),
            ("lag_min", self.lag_min),
            ("lag_max_tau", self.lag_max_tau),
            (
                "overlap_spacing_tau",
                self.overlap_spacing_tau.unwrap_or(1.0),
            ),
        ] {
            if !(v.is_finite() && v > 0.0) {
                let path: Vec<&str> = name.split('.').collect();
                return Err(param_error(
                    &path,
                    format!("simulate: `{name}` = {v} must be a finite number > 0"),
                ));
            }
        }
        if !(g.b.is_finite() && g.b >= 0.0 && g.phi0.is_finite()) {
            bail!(
                "simulate: tau_guess needs B >= 0 and a finite phi0, got B = {}, phi0 = {}",
                g.b,
                g.phi0
            );
        }
        for (name, v) in [
            ("origins", self.origins),
            ("lags_per_decade", self.lags_per_decade),
        ] {
            if v == 0 {
                return Err(param_error(
                    &[name],
                    format!("simulate: `{name}` must be at least 1"),
                ));
            }
        }
        Ok(())
    }
}

/// A simulation stage's parameters, parsed: its run-length rule and the
/// configuration the rule resolves to (relaxation and schedule set).
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    pub rule: RunLength,
    pub config: SimConfig,
}

/// The configuration of the run a simulation artifact comes from, as it
/// travelled with its output.
pub fn run_config(sim: &Artifact) -> Result<SimConfig> {
    serde_json::from_value(Value::Object((*sim.run).clone()))
        .with_context(|| format!("the resolved configuration of {}", sim.label))
}
