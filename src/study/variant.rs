//! Figures built from a variant of the spec catalogue: the master seed (of every
//! experiment), one experiment's N, replicas or any other profile parameter
//! changed in memory (the YAML files are read once, never copied or rewritten). Results go to a temporary
//! directory; the cache store is the project's, so a variant already computed is
//! not recomputed.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::Value;

use crate::pipeline::{self, Catalogue, RunOptions, Workspace};

/// Changes to the catalogue at one profile.
#[derive(Clone, Debug, Default)]
pub struct Variant {
    /// Master seed of every experiment: a figure gathering several experiments
    /// (eps = 0.7, 0.8, 0.9, ...) then scatters in all of them from seed to seed.
    pub seed: Option<u64>,
    pub n: Option<usize>,
    pub replicas: Option<u64>,
    /// Profile parameters to set (they override the experiment's common params),
    /// e.g. `eps` for a deliberate physics change or `schedule`.
    pub set: BTreeMap<String, Value>,
}

impl Variant {
    pub fn seed(seed: u64) -> Variant {
        Variant {
            seed: Some(seed),
            ..Variant::default()
        }
    }
}

/// Apply `v` at `profile` of a loaded catalogue: the seed to every experiment,
/// the rest to experiment `experiment`.
pub fn apply(cat: &mut Catalogue, experiment: &str, profile: &str, v: &Variant) -> Result<()> {
    let known: Vec<String> = cat.experiments.keys().cloned().collect();
    if let Some(s) = v.seed {
        // Every experiment gets the master seed itself (not one derived from
        // it): the committed seeds' trajectories of the named experiment stay
        // cached, and experiments differ by their physics and grid anyway.
        for (_, spec) in cat.experiments.values_mut() {
            spec.seed = s;
        }
    }
    let (_, spec) = cat.experiments.get_mut(experiment).with_context(|| {
        format!(
            "no experiment '{experiment}' (experiments/{experiment}.yaml); known: {}",
            known.join(", ")
        )
    })?;
    let prof = &mut spec
        .profiles
        .get_mut(profile)
        .with_context(|| format!("experiment '{experiment}' has no profile '{profile}'"))?
        .value;
    if let Some(r) = v.replicas {
        prof.replicas.value = r;
    }
    if let Some(n) = v.n {
        prof.params.insert("n".into(), Value::from(n));
    }
    for (k, x) in &v.set {
        // `grid.AXIS` replaces the values of a grid axis (e.g. a force range);
        // every other key is a profile parameter.
        if let Some(axis) = k.strip_prefix("grid.") {
            let axes: Vec<String> = prof.grid.keys().cloned().collect();
            let values = x.as_array().filter(|a| !a.is_empty()).with_context(|| {
                format!("--set {k}: give the axis' values as a YAML list, e.g. {k}=[1000, 10000]")
            })?;
            prof.grid
                .get_mut(axis)
                .with_context(|| {
                    format!(
                        "--set {k}: experiment '{experiment}' has no grid axis '{axis}' at profile '{profile}'; axes: {}",
                        axes.join(", ")
                    )
                })?
                .value = values.clone();
        } else {
            prof.params.insert(k.clone(), x.clone());
        }
    }
    Ok(())
}

/// Parse `KEY=VALUE` (the value as YAML: `eps=0.88`, `schedule=overlap`).
pub fn parse_setting(s: &str) -> Result<(String, Value)> {
    let (k, v) = s
        .split_once('=')
        .with_context(|| format!("'{s}': expected KEY=VALUE, e.g. eps=0.88"))?;
    let value: Value = serde_saphyr::from_str(v)
        .with_context(|| format!("'{s}': the value '{v}' is not a YAML scalar"))?;
    Ok((k.trim().to_string(), value))
}

/// A built variant: its results directory lives as long as this value.
pub struct Built {
    _tmp: tempfile::TempDir,
    pub results: std::path::PathBuf,
}

/// Build figures `ids` at `profile` from the catalogue under `root` changed by
/// `v`; error if any stage failed.
pub fn build(
    root: &Path,
    experiment: &str,
    profile: &str,
    v: &Variant,
    ids: &[String],
    opts: &RunOptions,
) -> Result<Built> {
    let mut cat = Catalogue::load(root)?;
    apply(&mut cat, experiment, profile, v)?;
    let reg = crate::stages::registry();
    let graph = pipeline::graph::plan(&cat, ids, profile, &reg)?;
    let tmp = tempfile::tempdir().context("creating a temporary results directory")?;
    let ws = Workspace {
        results: tmp.path().join("results"),
        ..Workspace::new(root)
    };
    pipeline::run_planned(&ws, &reg, graph, opts)?.check()?;
    Ok(Built {
        results: ws.results,
        _tmp: tmp,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXP: &str = "description: t\nkind: simulate\nseed: 3\nparams: {eps: 0.9}\n\
        profiles:\n  ci:\n    grid: {phi: [0.6]}\n    replicas: 2\n    params: {n: 100}\n";

    fn catalogue() -> Catalogue {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("experiments")).unwrap();
        std::fs::write(dir.path().join("experiments/e.yaml"), EXP).unwrap();
        let other = EXP.replace("seed: 3", "seed: 5").replace("0.9", "0.8");
        std::fs::write(dir.path().join("experiments/f.yaml"), other).unwrap();
        Catalogue::load(dir.path()).unwrap()
    }

    /// A figure gathering two experiments scatters in both from seed to seed:
    /// the master seed reaches every experiment, the other changes only the named one.
    #[test]
    fn the_master_seed_reaches_every_experiment() {
        let mut cat = catalogue();
        let mut v = Variant::seed(11);
        v.replicas = Some(4);
        apply(&mut cat, "e", "ci", &v).unwrap();
        assert_eq!(cat.experiments["e"].1.seed, 11);
        assert_eq!(cat.experiments["f"].1.seed, 11);
        assert_eq!(
            cat.experiments["e"].1.profiles["ci"].value.replicas.value,
            4
        );
        assert_eq!(
            cat.experiments["f"].1.profiles["ci"].value.replicas.value,
            2
        );
        let mut cat = catalogue();
        apply(&mut cat, "e", "ci", &Variant::default()).unwrap();
        assert_eq!(
            cat.experiments["f"].1.seed, 5,
            "no seed given: seeds untouched"
        );
    }

    #[test]
    fn a_variant_changes_only_what_it_names() {
        let mut cat = catalogue();
        let mut v = Variant::seed(11);
        v.n = Some(400);
        v.set.insert("eps".into(), Value::from(0.88));
        apply(&mut cat, "e", "ci", &v).unwrap();
        let spec = &cat.experiments["e"].1;
        assert_eq!(spec.seed, 11);
        let p = &spec.profiles["ci"].value;
        assert_eq!(p.replicas.value, 2);
        assert_eq!(p.params["n"], Value::from(400));
        assert_eq!(p.params["eps"], Value::from(0.88));
        assert_eq!(
            spec.params["eps"],
            Value::from(0.9),
            "common params untouched"
        );
    }

    /// `grid.AXIS` replaces a grid axis' values (a force range for the frontier
    /// of paper I's Fig. 5), not a parameter; a missing axis or a scalar is named.
    #[test]
    fn a_grid_setting_replaces_the_axis() {
        let mut cat = catalogue();
        let mut v = Variant::default();
        let (k, x) = parse_setting("grid.phi=[0.7, 0.8]").unwrap();
        v.set.insert(k, x);
        apply(&mut cat, "e", "ci", &v).unwrap();
        let p = &cat.experiments["e"].1.profiles["ci"].value;
        assert_eq!(
            p.grid["phi"].value,
            vec![Value::from(0.7), Value::from(0.8)]
        );
        assert!(!p.params.contains_key("grid.phi"));
        let mut v = Variant::default();
        v.set.insert("grid.force".into(), Value::from(vec![1.0]));
        let e = apply(&mut catalogue(), "e", "ci", &v).unwrap_err();
        assert!(e.to_string().contains("no grid axis 'force'"), "{e}");
        let mut v = Variant::default();
        v.set.insert("grid.phi".into(), Value::from(0.7));
        let e = apply(&mut catalogue(), "e", "ci", &v).unwrap_err();
        assert!(e.to_string().contains("as a YAML list"), "{e}");
    }

    #[test]
    fn unknown_experiment_profile_or_setting_is_named() {
        let mut cat = catalogue();
        let e = apply(&mut cat, "nope", "ci", &Variant::default()).unwrap_err();
        assert!(e.to_string().contains("no experiment 'nope'"), "{e}");
        let e = apply(&mut cat, "e", "paper", &Variant::default()).unwrap_err();
        assert!(e.to_string().contains("no profile 'paper'"), "{e}");
        assert!(parse_setting("eps").is_err());
        assert_eq!(parse_setting("eps=0.88").unwrap().1, Value::from(0.88));
    }
}
