//! `run_summary`: what one simulation measured about itself (T against its
//! target, collision rate against Enskog, guard activations per collision,
//! energy ledger, closest approach of two disks) as a one-row table, for the stability maps.

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use serde_json::Value;

use super::simulate;
use super::tables::trajectories;
use crate::analysis::run_summary;
use crate::pipeline::registry::typed;
use crate::pipeline::stage::Holds;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Relative deviation of T from its target that still counts as held.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Instead of the one row: the run's samples of T and P over the whole run,
    /// relaxation included (the stationarity check).
    #[serde(default)]
    pub series: bool,
}

fn default_tolerance() -> f64 {
    0.02
}

pub struct RunSummary;

impl StageKind for RunSummary {
    type Params = Params;
    fn name(&self) -> &str {
        "run_summary"
    }
    fn describe(&self) -> &str {
        "one simulation's own measurements as a row: T vs target (T_held within `tolerance`), collision rate vs Enskog and paper H's 1.46 phi G_c, guard activations per collision (guard_warning), energy drift, closest approach (negative: overlap), float precision"
    }
    fn details(&self) -> String {
        "  parameters: tolerance (relative, default 0.02)\n  use: map: EXPERIMENT (one row per run), then a `table` gathering it\n  example:\n    - {name: runs, kind: run_summary, map: stability_drive_enskog, params: {tolerance: 0.02}}".into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<Params> {
        let p: Params = typed("run_summary", params)?;
        if !(p.tolerance.is_finite() && p.tolerance > 0.0) {
            bail!(
                "run_summary: `tolerance` = {} must be a finite number > 0",
                p.tolerance
            );
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &Params, inputs: &[Artifact]) -> Result<Output> {
        let sims: Vec<&Artifact> = inputs
            .iter()
            .filter(|a| a.kind.holds == Holds::Trajectory)
            .collect();
        let [sim] = sims.as_slice() else {
            bail!(
                "run_summary: needs exactly one simulation (map: EXPERIMENT), got {}",
                sims.len()
            );
        };
        let summary: Value = serde_json::from_slice(&sim.read("json")?)
            .with_context(|| format!("run_summary: the summary of {}", sim.label))?;
        let cfg = simulate::run_config(sim)?;
        let traj = trajectories("run_summary", std::slice::from_ref(*sim))?;
        let cols: Vec<(&str, Vec<f64>)> = if p.series {
            run_summary::series(&summary)?
        } else {
            let row = run_summary::row(&summary, &cfg, &traj[0], p.tolerance)?;
            row.into_iter().map(|(k, v)| (k, vec![v])).collect()
        };
        Ok(Output::single(
            "parquet",
            to_parquet_bytes(&[f64_batch(&cols)?], &[])?,
        ))
    }
}
