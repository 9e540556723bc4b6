//! `--set EXPERIMENT.KEY=VALUE` on `figure`, `plan` and `why`: the figures of a
//! catalogue changed in memory (the YAML files are never rewritten), with the
//! changes `regress` and `frontier` apply ([`crate::study::variant`]).

use std::collections::BTreeMap;

use anyhow::{Context, Result};
use clap::Args;
use serde_json::Value;

use crate::pipeline::{Catalogue, Graph, Registry, Workspace, graph};
use crate::study::variant::{self, Variant};

/// What-if settings of a command.
#[derive(Args, Debug, Clone, Default)]
pub struct WhatIf {
    /// Change an experiment's profile parameter or grid axis for this command
    /// only, e.g. `--set eps09.eps=0.88` or `--set eps09.grid.phi=[0.7,0.78]`
    /// (repeatable; the YAML files are left alone). `figure` writes the
    /// figures to results/what-if/ID/.
    #[arg(long = "set", value_name = "EXPERIMENT.KEY=VALUE")]
    pub set: Vec<String>,
}

impl WhatIf {
    pub fn is_empty(&self) -> bool {
        self.set.is_empty()
    }

    /// The settings by experiment.
    fn by_experiment(&self) -> Result<BTreeMap<String, BTreeMap<String, Value>>> {
        let mut out: BTreeMap<String, BTreeMap<String, Value>> = BTreeMap::new();
        for s in &self.set {
            let (key, value) = variant::parse_setting(s)?;
            let (experiment, key) = key.split_once('.').with_context(|| {
                format!("--set {s}: name the experiment, e.g. --set eps09.{key}=...")
            })?;
            out.entry(experiment.to_string())
                .or_default()
                .insert(key.to_string(), value);
        }
        Ok(out)
    }

    /// Plan figures `ids` (all if empty) at `profile` from the catalogue
    /// under `ws.root` with these settings applied.
    pub fn plan(
        &self,
        ws: &Workspace,
        reg: &Registry,
        ids: &[String],
        profile: &str,
    ) -> Result<Graph> {
        if self.is_empty() {
            return ws.plan(reg, ids, profile);
        }
        let mut cat = Catalogue::load(&ws.root)?;
        for (experiment, set) in self.by_experiment()? {
            let v = Variant {
                set,
                ..Variant::default()
            };
            variant::apply(&mut cat, &experiment, profile, &v)?;
        }
        graph::plan(&cat, ids, profile, reg)
    }

    /// Where `figure` publishes: `results/` as usual, `results/what-if/` for a what-if.
    pub fn workspace(&self, ws: Workspace) -> Workspace {
        if self.is_empty() {
            return ws;
        }
        Workspace {
            results: ws.results.join("what-if"),
            ..ws
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_name_their_experiment() {
        let w = WhatIf {
            set: vec![
                "eps09.eps=0.88".into(),
                "eps09.grid.phi=[0.7, 0.78]".into(),
                "eps07.n=500".into(),
            ],
        };
        let by = w.by_experiment().unwrap();
        assert_eq!(by["eps09"]["eps"], serde_json::json!(0.88));
        assert_eq!(by["eps09"]["grid.phi"], serde_json::json!([0.7, 0.78]));
        assert_eq!(by["eps07"]["n"], serde_json::json!(500));
        let e = WhatIf {
            set: vec!["eps=0.88".into()],
        }
        .by_experiment()
        .unwrap_err();
        assert!(
            format!("{e:#}").contains("name the experiment, e.g. --set eps09.eps="),
            "{e:#}"
        );
    }
}
