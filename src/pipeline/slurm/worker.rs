//! `repro worker`: what one Slurm job runs. It finds its stage by the key the
//! driver recorded, checks that this binary and these specs give the same key,
//! and computes the stage into the store under the stage's lock.

use std::path::Path;

use anyhow::{Context, Result, bail, ensure};

use super::super::Workspace;
use super::super::exec::{self, stage_key};
use super::super::graph::Node;
use super::super::registry::Registry;
use super::super::store::Store;
use super::state;

/// `repro worker`: compute the stage recorded under `key` in the store's job
/// records and write it to the store. Refuses when the specs or the binary
/// differ from the submitter's (the key would not match).
pub fn worker(store_dir: &Path, reg: &Registry, key: &str) -> Result<()> {
    let store = Store::open(store_dir)?;
    let rec = state::read(&store, key).with_context(|| {
        format!(
            "no job record {}/{key}.json: this stage was not submitted through this store",
            state::jobs_dir(&store).display()
        )
    })?;
    let ws = Workspace {
        root: rec.root.clone(),
        results: rec.root.join("results"),
        store: store_dir.to_path_buf(),
    };
    let graph = ws.plan(reg, &rec.figures, &rec.profile)?;
    let Some(i) = graph.nodes.iter().position(|n| n.recipe == rec.recipe) else {
        bail!(
            "stage {} is no longer in the plan of {} at profile {}: the specs under {} changed since it was submitted",
            rec.label,
            rec.figures.join(" "),
            rec.profile,
            rec.root.display()
        );
    };
    let node: &Node = &graph.nodes[i];
    ensure!(
        node.inputs.len() == rec.inputs.len(),
        "stage {}: the plan has {} inputs, the job record {}",
        rec.label,
        node.inputs.len(),
        rec.inputs.len()
    );
    let mut inputs = Vec::new();
    for (&j, k) in node.inputs.iter().zip(&rec.inputs) {
        let e = store.lookup(k).with_context(|| {
            format!(
                "input {} (key {k}) is not intact in the store {}",
                graph.nodes[j].label(),
                store_dir.display()
            )
        })?;
        inputs.push(exec::artifact(&store, reg, node, &graph.nodes[j], &e));
    }
    let digests: Vec<&str> = inputs.iter().map(|a| a.digest.as_str()).collect();
    let mine = stage_key(&graph, reg, node, &digests);
    ensure!(
        mine == key,
        "stage {}: this binary computes key {mine}, the submitter {key}: the repro binary (code fingerprint) differs from the submitter's",
        rec.label
    );
    let _lock = store.lock_key(key)?;
    if !rec.force && store.lookup(key).is_some() {
        eprintln!(
            "{} is already in the store (computed by another job)",
            rec.label
        );
        return Ok(());
    }
    eprintln!("computing {} ({}), key {key}", rec.label, rec.kind);
    match exec::compute(&store, reg, node, key.to_string(), &inputs, None) {
        Ok((e, _)) => {
            for l in &e.log {
                eprintln!("log: {l}");
            }
            eprintln!(
                "wrote {} file(s) of {} in {:.1} s",
                e.files.len(),
                rec.label,
                e.wall_s
            );
            Ok(())
        }
        Err((error, log)) => {
            for l in &log {
                eprintln!("log: {l}");
            }
            bail!("stage {} ({}) failed: {error}", rec.label, rec.kind)
        }
    }
}
