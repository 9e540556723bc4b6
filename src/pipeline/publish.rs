//! Write `results/ID/`: the published stage files and `provenance.json`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::{Value, json};

use super::exec::{Outcome, RunReport};
use super::graph::{FigurePlan, Graph};
use super::registry::Registry;
use super::store::Store;
use crate::table::write_atomic;

/// The git commit of the checkout at `root`, if any.
fn git_commit(root: &Path) -> Option<String> {
    let out = std::process::Command::new("git")
        .arg("-C")
        .arg(root)
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Write `bytes` to `path` atomically unless it already holds them (a no-op rerun
/// then writes nothing), readable by everyone (temporary files are owner-only).
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<()> {
    if std::fs::read(path).ok().as_deref() == Some(bytes) {
        return Ok(());
    }
    write_atomic(path, bytes)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o644))?;
    }
    Ok(())
}

/// Publish one figure whose stages all succeeded into `results_dir/ID/`: each
/// published stage's files as `<stage>.<ext>`, and `provenance.json`. Files left
/// from an earlier publish that are no longer produced are removed.
pub fn publish(
    root: &Path,
    results_dir: &Path,
    graph: &Graph,
    fig: &FigurePlan,
    report: &RunReport,
    reg: &Registry,
    store: &Store,
) -> Result<()> {
    let dir = results_dir.join(&fig.id);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut published: BTreeMap<String, String> = BTreeMap::new();
    for (stage, node) in &fig.publish {
        let e = report.results[node]
            .entry
            .as_ref()
            .context("published stage has no result")?;
        for (ext, hash) in &e.files {
            let name = format!("{stage}.{ext}");
            write_if_changed(&dir.join(&name), &std::fs::read(store.object_path(hash))?)?;
            published.insert(name, hash.clone());
        }
    }
    let stages: Vec<Value> = fig
        .nodes
        .iter()
        .map(|&i| {
            let n = &graph.nodes[i];
            let r = &report.results[&i];
            let e = r.entry.as_ref();
            let modules = reg
                .get(&n.kind)
                .map(|k| k.modules().to_vec())
                .unwrap_or_default();
            json!({
                "label": n.label(),
                "kind": n.kind,
                "key": e.map(|e| e.key.clone()),
                "params": n.params,
                "point": n.point,
                "seed": n.seed,
                "code_fingerprint": reg.fingerprint(&n.kind),
                "modules": modules,
                "inputs": n.inputs.iter().map(|&j| graph.nodes[j].label()).collect::<Vec<_>>(),
                "files": e.map(|e| e.files.clone()),
                "wall_s": e.map(|e| e.wall_s),
                "cpu_s": e.and_then(|e| e.cpu_s),
                "executed_in_this_run": r.outcome == Outcome::Executed,
            })
        })
        .collect();
    let prov = json!({
        "figure": fig.id,
        "description": fig.description,
        "profile": graph.profile,
        "repro_version": env!("CARGO_PKG_VERSION"),
        "git_commit": git_commit(root),
        "published": published,
        "stages": stages,
    });
    write_if_changed(
        &dir.join("provenance.json"),
        &serde_json::to_vec_pretty(&prov)?,
    )?;
    // Remove files of an earlier publish that this run no longer produces.
    for e in std::fs::read_dir(&dir)?.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        // `.tmp*` files are another process's writes in flight: not ours to remove.
        let ours = !name.starts_with(".tmp") && name != "provenance.json";
        if e.path().is_file() && ours && !published.contains_key(&name) {
            std::fs::remove_file(e.path())?;
        }
    }
    Ok(())
}
