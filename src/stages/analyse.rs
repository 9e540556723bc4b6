//! The analysis stage: every observable of `src/analysis` ([`OBSERVABLES`]) as a
//! stage kind of the same name. It decodes the gathered trajectories (replicas of
//! one state point, typically `gather: [experiment]` with `by: [phi]`), calls the
//! observable and writes its tables, with how the errors were estimated in the
//! Parquet metadata (`errors`, `replicas`).

use anyhow::Result;
use serde_json::Value;

use super::tables::trajectories;
use crate::analysis::observables::{OBSERVABLES, Observable};
use crate::pipeline::{Artifact, Output, Registry, StageCtx, StageKind};
use crate::table::to_parquet_bytes;
use crate::traj::Trajectory;

/// What every analysis stage runs besides its observable's own modules.
const COMMON: &[&str] = &[
    "analysis/observables",
    "analysis/pool",
    "analysis/mod",
    "traj",
    "table",
    "stages/analyse",
    "stages/tables",
];

/// One observable as a stage kind.
pub struct Analyse {
    obs: &'static Observable,
    modules: Vec<&'static str>,
}

impl Analyse {
    pub fn new(obs: &'static Observable) -> Self {
        let mut modules: Vec<&'static str> = obs.modules.to_vec();
        modules.extend(COMMON.iter().filter(|m| !obs.modules.contains(m)));
        Analyse { obs, modules }
    }
}

/// Register one analysis kind per observable.
pub fn register(r: &mut Registry) {
    for o in OBSERVABLES {
        r.register(Analyse::new(o));
    }
}

impl StageKind for Analyse {
    fn name(&self) -> &str {
        self.obs.name
    }
    fn describe(&self) -> &str {
        self.obs.describe
    }
    fn modules(&self) -> &[&str] {
        &self.modules
    }
    fn validate(&self, params: &Value) -> Result<()> {
        (self.obs.validate)(params)
    }
    fn run(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let trajs = trajectories(self.obs.name, inputs)?;
        let refs: Vec<&Trajectory> = trajs.iter().collect();
        let tables = (self.obs.compute)(&refs, params)?;
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
