//! Write `results/ID/`: the published stage files and `provenance.json`.
//!
//! The directory is shared with the user: the pipeline owns only the files listed
//! in the `published` map of its `provenance.json` (the manifest) and
//! `provenance.json` itself. A publish writes each file to a temporary name and
//! renames it; files of the previous manifest that are no longer produced are
//! removed; every other file (notes, an extra plot) is left alone.

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
pub(crate) fn git_commit(root: &Path) -> Option<String> {
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

/// The files the previous publish into `dir` owned (its manifest), if any.
fn previous_manifest(dir: &Path) -> Vec<String> {
    std::fs::read(dir.join(PROVENANCE))
        .ok()
        .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
        .and_then(|v| {
            v.get("published")?
                .as_object()
                .map(|m| m.keys().cloned().collect())
        })
        .unwrap_or_default()
}

const PROVENANCE: &str = "provenance.json";
const README: &str = "README.md";

/// The top of `README.md`: the figure, how it was made, the units.
fn readme_head(graph: &Graph, fig: &FigurePlan) -> String {
    format!(
        "# {id} ({profile} profile)\n\n{desc}\n\n\
         Made by `repro figure {id} --profile {profile}` from `pipelines/{id}.yaml`; every \
         stage's parameters, inputs, seed and code fingerprint are in `provenance.json`.\n\n\
         Units: lengths in r1 (the small-disk radius), times in r1 sqrt(m1/T), wavenumbers \
         in 1/r1, \"1\" dimensionless. A column `X_err` is the 1-sigma error of `X`. Paper H: \
         dynamical heterogeneities of driven bidisperse inelastic hard disks; paper I: an \
         intruder pulled through a dense granular fluid.\n",
        id = fig.id,
        profile = graph.profile,
        desc = fig.description
    )
}

/// The section of `README.md` for one published stage: what it is in the paper,
/// what made it from what, and every Parquet file's columns with unit and meaning.
fn readme_stage(
    graph: &Graph,
    fig: &FigurePlan,
    reg: &Registry,
    stage: &str,
    node: usize,
    files: &[(String, Vec<u8>)],
) -> String {
    let n = &graph.nodes[node];
    let explain =
        |kind: &str, params: &Value| reg.get(kind).map(|k| k.explain(params)).unwrap_or_default();
    let names: Vec<String> = files.iter().map(|(f, _)| format!("`{f}`")).collect();
    let mut s = format!("\n## {}\n\n", names.join(", "));
    if let Some(d) = fig.describes.get(stage) {
        s.push_str(&format!("In the paper: {d}.\n\n"));
    }
    s.push_str(&format!(
        "Stage `{stage}` (kind `{}`): {}.\n",
        n.kind,
        explain(&n.kind, &n.params)
    ));
    // Each upstream stage once (a gather reads many instances of one stage).
    let mut seen = std::collections::BTreeSet::new();
    for &i in &n.inputs {
        let up = &graph.nodes[i];
        // A node shared between figures: its name in this figure's pipeline.
        let name = up
            .ids
            .iter()
            .find(|id| id.figure.as_deref() == Some(fig.id.as_str()))
            .or(up.ids.first())
            .map_or(up.label(), |id| id.stage.as_str());
        if seen.insert(name.to_string()) {
            s.push_str(&format!(
                "From `{name}` (kind `{}`): {}.\n",
                up.kind,
                explain(&up.kind, &up.params)
            ));
        }
    }
    for (file, bytes) in files {
        if !file.ends_with(".parquet") {
            continue;
        }
        let Ok((batches, kv)) = crate::table::read_parquet_bytes(bytes.clone()) else {
            continue;
        };
        s.push_str(&format!("\n`{file}`"));
        if let Some((_, e)) = kv.iter().find(|(k, _)| k == "errors") {
            s.push_str(&format!(" (errors: {e})"));
        }
        if file.starts_with("compare.") {
            // The reasons keep their references, resolved where they are read.
            s.push_str(
                " (its `reason` is a template: `{=STAGE.QUANTITY}` names a number of a build, \
                 `{paper:X}` quotes the paper; `repro report --profile PROFILE` prints every \
                 reason filled in, docs/report-PROFILE.md)",
            );
        }
        s.push_str(":\n\n| column | type | unit | meaning |\n|---|---|---|---|\n");
        if let Some(b) = batches.first() {
            for f in b.schema().fields() {
                // A known column, else the meaning its stage wrote (a
                // figure's own derived column).
                // This stage's own meaning first (its `columns:`), then a
                // known column, else the meaning its stage wrote (a figure's
                // own derived column).
                let own = fig
                    .columns
                    .get(stage)
                    .and_then(|m| m.get(f.name()))
                    .map(|what| {
                        let unit = crate::table::columns::describe(f.name())
                            .map_or(String::new(), |(u, _)| u);
                        (unit, what.clone())
                    });
                let (unit, what) = own
                    .or_else(|| crate::table::columns::describe(f.name()))
                    .or_else(|| {
                        let m = f.metadata();
                        m.get("description")
                            .map(|d| (m.get("unit").cloned().unwrap_or_default(), d.clone()))
                    })
                    .unwrap_or_default();
                s.push_str(&format!(
                    "| {} | {} | {unit} | {what} |\n",
                    f.name(),
                    f.data_type()
                ));
            }
        }
    }
    s
}

/// Publish one figure whose stages all succeeded into `results_dir/ID/`: each
/// published stage's files as `<stage>.<ext>` (checked against their hash on the
/// way), and `provenance.json` with the manifest. Files of the previous manifest
/// that are no longer produced are removed; files the pipeline never wrote stay.
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
    let before = previous_manifest(&dir);
    let mut published: BTreeMap<String, String> = BTreeMap::new();
    let mut readme = readme_head(graph, fig);
    for (stage, node) in &fig.publish {
        let e = report.results[node]
            .entry
            .as_ref()
            .context("published stage has no result")?;
        let mut files = Vec::new();
        for (ext, hash) in &e.files {
            let name = format!("{stage}.{ext}");
            let label = graph.nodes[*node].label();
            let bytes = store.read_verified(hash, label)?;
            write_if_changed(&dir.join(&name), &bytes)?;
            published.insert(name.clone(), hash.clone());
            files.push((name, bytes));
        }
        readme.push_str(&readme_stage(graph, fig, reg, stage, *node, &files));
    }
    let readme = readme.into_bytes();
    write_if_changed(&dir.join(README), &readme)?;
    published.insert(README.into(), blake3::hash(&readme).to_hex().to_string());
    let stages: Vec<Value> = fig
        .nodes
        .iter()
        .map(|&i| {
            let n = &graph.nodes[i];
            let r = &report.results[&i];
            let e = r.entry.as_ref();
            json!({
                "label": n.label(),
                "kind": n.kind,
                "key": e.map(|e| e.key.clone()),
                "params": n.params,
                "point": n.point,
                "seed": n.seed,
                "code_fingerprint": reg.fingerprint(&n.kind),
                "modules": reg.modules(&n.kind),
                "crates": reg.crates(&n.kind),
                "inputs": n.inputs.iter().map(|&j| graph.nodes[j].label()).collect::<Vec<_>>(),
                "files": e.map(|e| e.files.clone()),
                "wall_s": e.map(|e| e.wall_s),
                "cpu_s": e.and_then(|e| e.cpu_s),
                "side": e.and_then(|e| e.side.clone()),
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
        "rustc": crate::fingerprints::RUSTC_VERSION,
        "published": published,
        "stages": stages,
    });
    write_if_changed(&dir.join(PROVENANCE), &serde_json::to_vec_pretty(&prov)?)?;
    // The new manifest is in place: remove what the old one owned and this one does not.
    for name in before {
        let path = dir.join(&name);
        let plain_name = !name.contains(['/', '\\']) && name != PROVENANCE && name != "..";
        if plain_name && !published.contains_key(&name) && path.is_file() {
            std::fs::remove_file(&path)
                .with_context(|| format!("removing {} (no longer produced)", path.display()))?;
        }
    }
    Ok(())
}
