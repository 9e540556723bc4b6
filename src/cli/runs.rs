//! `repro runs EXPERIMENT`: the built runs of an experiment found by their
//! parameters (grid point, replica, settings), with seed and trajectory path,
//! or copied out under names made of their parameters.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde_json::Value;

use super::root::RootArgs;
use crate::pipeline::exec::stage_key;
use crate::pipeline::{Catalogue, DEFAULT_PROFILE, Registry, Store, graph};
use crate::study::variant::parse_setting;
use crate::table::runs::{self, Run};

#[derive(Args, Debug, Clone)]
pub struct RunsArgs {
    /// The experiment (experiments/NAME.yaml).
    #[arg(value_name = "EXPERIMENT")]
    pub experiment: String,
    #[arg(long, default_value = DEFAULT_PROFILE, value_name = "P")]
    pub profile: String,
    /// Only the runs with this parameter (a grid axis, `replica` or a setting
    /// such as `n`), e.g. `--where phi=0.78`; repeatable.
    #[arg(long = "where", value_name = "KEY=VALUE")]
    pub filters: Vec<String>,
    /// Copy each trajectory to DIR/EXPERIMENT_phi=0.78_replica=2.parquet and
    /// write DIR/runs.parquet, the table of the copies.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
    #[command(flatten)]
    pub root: RootArgs,
}

/// Whether `run` has `value` under `key` (numbers compare as numbers).
fn has(run: &Run, key: &str, value: &Value) -> bool {
    let v = run.point.get(key).or_else(|| run.settings.get(key));
    match (v, value.as_f64()) {
        (Some(v), Some(x)) => v.as_f64() == Some(x),
        (Some(v), None) => v == value || v.as_str() == value.as_str().filter(|_| value.is_string()),
        (None, _) => false,
    }
}

/// The built runs of the experiment at the profile (and how many are not built).
fn built(reg: &Registry, a: &RunsArgs) -> Result<(Vec<Run>, usize)> {
    let ws = a.root.workspace();
    let cat = Catalogue::load(&ws.root)?;
    let graph = graph::plan_experiment(&cat, &a.experiment, &a.profile, reg)?;
    let store = Store::open(&ws.store)?;
    let mut found = Vec::new();
    let mut missing = 0;
    for node in &graph.nodes {
        let key = stage_key(&graph, reg, node, &[]);
        let Some(entry) = store.lookup(&key) else {
            missing += 1;
            continue;
        };
        let Some(hash) = entry.files.get("parquet") else {
            bail!(
                "{}: its stored result has no trajectory (a kind that is no simulation?)",
                node.label()
            );
        };
        found.push(Run {
            experiment: a.experiment.clone(),
            point: node.point.clone().into_iter().collect(),
            settings: (*node.run).clone(),
            seed: node.seed,
            path: store.object_path(hash),
        });
    }
    Ok((found, missing))
}

pub fn run(reg: &Registry, a: &RunsArgs) -> Result<()> {
    let filters: Vec<(String, Value)> = a
        .filters
        .iter()
        .map(|f| parse_setting(f))
        .collect::<Result<_>>()?;
    let (all, missing) = built(reg, a)?;
    if let Some(first) = all.first() {
        for (k, _) in &filters {
            if !first.point.contains_key(k) && !first.settings.contains_key(k) {
                let mut known: Vec<&String> =
                    first.point.keys().chain(first.settings.keys()).collect();
                known.sort();
                bail!(
                    "--where {k}=...: the runs of '{}' have no parameter '{k}'; they have: {}",
                    a.experiment,
                    known
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
    }
    let mut chosen: Vec<Run> = all
        .into_iter()
        .filter(|r| filters.iter().all(|(k, v)| has(r, k, v)))
        .collect();
    if let Some(dir) = &a.export {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for r in &mut chosen {
            let to = dir.join(r.file_name());
            std::fs::copy(&r.path, &to)
                .with_context(|| format!("copying {} to {}", r.path.display(), to.display()))?;
            r.path = std::path::absolute(&to)?;
        }
        let table = dir.join("runs.parquet");
        crate::table::write_parquet(&table, &[runs::batch(&chosen)?], &[])?;
    }
    for r in &chosen {
        let point: Vec<String> = r.point.iter().map(|(k, v)| format!("{k}={v}")).collect();
        println!("{}  seed={}  {}", point.join(" "), r.seed, r.path.display());
    }
    println!(
        "{} run(s) of {} at profile {}{}{}",
        chosen.len(),
        a.experiment,
        a.profile,
        if missing > 0 {
            format!("; {missing} not built yet (a figure that gathers it builds them)")
        } else {
            String::new()
        },
        a.export.as_ref().map_or(String::new(), |d| format!(
            "; copied to {} with their table runs.parquet",
            d.display()
        ))
    );
    Ok(())
}
