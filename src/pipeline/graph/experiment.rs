//! An experiment expanded into its simulations: one simulate node per (grid
//! point, replica) at the plan's profile.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Result;
use serde_json::Value;

use super::super::canon::derive_seed;
use super::super::spec::{self, ExperimentSpec, SpecError};
use super::{Planner, StageId, combinations, mark};

impl Planner<'_> {
    /// The simulations of experiment `name` at the plan's profile, planned
    /// once: one node per (grid point, replica), each with the seed derived
    /// from the experiment's master seed, its point and replica.
    pub(super) fn experiment(&mut self, name: &str) -> Result<Vec<usize>> {
        if let Some(v) = self.experiments.get(name) {
            return Ok(v.clone());
        }
        let (file, spec): &(PathBuf, ExperimentSpec) = &self.cat.experiments[name];
        let profile = self.graph.profile.clone();
        let Some(prof) = spec.profiles.get(&profile) else {
            return Err(SpecError::file(
                file,
                format!(
                    "experiment '{name}' has no profile '{profile}'; it defines: {}",
                    spec.profiles.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
            .into());
        };
        let mut base: serde_json::Map<String, Value> = spec.params.clone().into_iter().collect();
        base.extend(prof.value.params.clone());
        let grid: BTreeMap<String, Vec<Value>> = prof
            .value
            .grid
            .iter()
            .map(|(k, v)| (k.clone(), v.value.clone()))
            .collect();
        let kind = spec.kind.value.clone();
        let line = prof.referenced.line();
        let mut nodes = Vec::new();
        for point in combinations(&grid) {
            for replica in 0..prof.value.replicas.value {
                let seed = derive_seed(spec.seed, &point, replica);
                let mut params = base.clone();
                params.extend(point.clone());
                params.insert("seed".into(), Value::from(seed));
                let parsed = self.parse(&kind, &params).map_err(|e| {
                    let at = |p: &[&str]| p.iter().map(|s| s.to_string()).collect::<Vec<_>>();
                    spec::param_error(
                        file,
                        &[
                            at(&["profiles", &profile, "params"]),
                            at(&["profiles", &profile, "grid"]),
                            at(&["params"]),
                        ],
                        mark(&spec.kind),
                        &format!("experiment '{name}', profile '{profile}' (kind {kind})"),
                        &e,
                    )
                })?;
                let mut pt = point.clone();
                pt.insert("replica".into(), Value::from(replica));
                let id = StageId {
                    figure: None,
                    stage: name.to_string(),
                    point: pt.clone(),
                };
                nodes.push(self.add(
                    &kind,
                    id,
                    params,
                    parsed,
                    pt,
                    vec![],
                    Some(seed),
                    (file.clone(), line),
                ));
            }
        }
        self.experiments.insert(name.to_string(), nodes.clone());
        Ok(nodes)
    }
}
