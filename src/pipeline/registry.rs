//! The registry: the stage kinds ([`StageKind`]) the planner and the executors
//! know, by name, with their code fingerprints; and the typed parameter decoder
//! every kind (and every observable) reads its parameters with.
//!
//! The framework's own kinds are registered by [`Registry::framework`] (in
//! [`super::kinds`], which builds on this file).

use std::collections::BTreeMap;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use serde::de::DeserializeOwned;
use serde_json::Value;

use super::canon::ParamError;
use super::fingerprint::{Fingerprint, Sources};
use super::stage::{Holds, Kind, Parsed, Planned, StageKind};

/// Deserialize a kind's parameters into a typed struct (use
/// `#[serde(deny_unknown_fields)]` on it). The error is a [`ParamError`] naming the
/// offending key (the planner points at it in the YAML file).
pub fn typed<T: DeserializeOwned>(kind: &str, params: &Value) -> Result<T> {
    serde_path_to_error::deserialize(params.clone()).map_err(|e| {
        use serde_path_to_error::Segment;
        let mut path: Vec<String> = e
            .path()
            .iter()
            .filter_map(|s| match s {
                Segment::Map { key } => Some(key.clone()),
                Segment::Seq { index } => Some(index.to_string()),
                _ => None,
            })
            .collect();
        let message = e.inner().to_string();
        // An unknown key is reported at its map: point at the key itself.
        if let Some(key) = message
            .strip_prefix("unknown field `")
            .and_then(|r| r.split('`').next())
        {
            path.push(key.to_string());
        }
        ParamError {
            path,
            message: format!("invalid parameters for stage kind '{kind}': {message}"),
        }
        .into()
    })
}

/// The keys typed parameters accept, in declaration order, read from the
/// validation itself: serde names every field when it refuses an unknown one
/// (`#[serde(deny_unknown_fields)]`), so `repro kinds` and the docs test list what
/// the code accepts rather than a hand-kept copy.
pub fn param_keys(validate: impl Fn(&Value) -> Result<()>) -> Vec<String> {
    let probe = serde_json::json!({ "__not_a_parameter__": 0 });
    let Err(e) = validate(&probe) else {
        return Vec::new();
    };
    let message = format!("{e:#}");
    message
        .split_once("expected ")
        .map(|(_, rest)| {
            rest.split('`')
                .skip(1)
                .step_by(2)
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default()
}

/// A kind's cost model: its parameters, parsed, to what one stage is planned to
/// cost (`None` when they are not this kind's).
type PlanFn = Box<dyn Fn(&Parsed) -> Option<Planned> + Send + Sync>;

struct Registered {
    kind: Arc<dyn Kind>,
    fingerprint: Fingerprint,
    plan: Option<PlanFn>,
}

/// The stage kinds the planner and executor know, with their code fingerprints.
#[derive(Default)]
pub struct Registry {
    kinds: BTreeMap<String, Registered>,
}

/// Fingerprint of a kind from the sources of this build: its own files
/// ([`StageKind::modules`]) closed over the import graph, with the lock entries
/// of the crates they use ([`Sources::fingerprint`]). A file that is no module
/// under `src/` is an error: a misspelt or renamed file must not silently key
/// every stage of the kind on a constant.
/// The edges `cut` are not followed ([`StageKind::not_followed`]).
pub fn code_fingerprint(name: &str, modules: &[&str], cut: &[(&str, &str)]) -> Result<Fingerprint> {
    code_fingerprint_in(crate::fingerprints::sources(), name, modules, cut)
}

/// [`code_fingerprint`] over any sources (tests read an edited copy).
pub fn code_fingerprint_in(
    sources: &Sources,
    name: &str,
    modules: &[&str],
    cut: &[(&str, &str)],
) -> Result<Fingerprint> {
    sources
        .fingerprint_cut(name, modules, cut)
        .map_err(anyhow::Error::msg)
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Registry::default()
    }

    /// Add a kind; its fingerprint comes from its files' import closure. Replaces
    /// a kind of the same name. Panics when the kind names a file that does not
    /// exist under `src/` (a programming error every test that builds the
    /// registry catches).
    pub fn register(&mut self, kind: impl StageKind) {
        let fingerprint = code_fingerprint(
            StageKind::name(&kind),
            StageKind::modules(&kind),
            &StageKind::not_followed(&kind),
        )
        .unwrap_or_else(|e| {
            panic!("{e}");
        });
        self.kinds.insert(
            StageKind::name(&kind).to_string(),
            Registered {
                kind: Arc::new(kind),
                fingerprint,
                plan: None,
            },
        );
    }

    /// [`Registry::register`] a kind of long stages (simulations) with the
    /// model of what one costs, from its parameters: the executors size their
    /// requests by it, and such stages checkpoint. The model is registered here
    /// and not called by the kind, so that its file is in no key: a
    /// recalibrated cost reruns nothing.
    pub fn register_planned<K: StageKind>(&mut self, kind: K, plan: fn(&K::Params) -> Planned) {
        let name = StageKind::name(&kind).to_string();
        self.register(kind);
        if let Some(r) = self.kinds.get_mut(&name) {
            r.plan = Some(Box::new(move |p: &Parsed| {
                p.get::<K::Params>().ok().map(plan)
            }));
        }
    }

    /// Override a kind's code fingerprint (tests simulate a code edit this way).
    pub fn set_fingerprint(&mut self, name: &str, fingerprint: &str) -> Result<()> {
        match self.kinds.get_mut(name) {
            Some(r) => {
                r.fingerprint.hash = fingerprint.to_string();
                Ok(())
            }
            None => bail!("no stage kind '{name}' to set a fingerprint on"),
        }
    }

    /// The kind called `name`, or an error listing the known kinds.
    pub fn get(&self, name: &str) -> Result<&Arc<dyn Kind>> {
        self.kinds.get(name).map(|r| &r.kind).with_context(|| {
            format!(
                "unknown stage kind '{name}'; known kinds: {}",
                self.names().join(", ")
            )
        })
    }

    /// Code fingerprint of kind `name` (empty if unknown).
    pub fn fingerprint(&self, name: &str) -> &str {
        self.kinds
            .get(name)
            .map(|r| r.fingerprint.hash.as_str())
            .unwrap_or("")
    }

    /// The source modules kind `name` runs (the closure its fingerprint
    /// hashes), sorted; empty if unknown.
    pub fn modules(&self, name: &str) -> &[String] {
        self.kinds
            .get(name)
            .map_or(&[], |r| r.fingerprint.modules.as_slice())
    }

    /// `name version` of the crates kind `name` runs (the lock entries its
    /// fingerprint hashes), sorted; empty if unknown.
    pub fn crates(&self, name: &str) -> &[String] {
        self.kinds
            .get(name)
            .map_or(&[], |r| r.fingerprint.crates.as_slice())
    }

    /// What the output of kind `name` holds ([`Holds::Results`] if unknown).
    pub fn holds(&self, name: &str) -> Holds {
        self.kinds
            .get(name)
            .map_or(Holds::default(), |r| r.kind.holds())
    }

    /// What a stage of kind `name` with parameters `params` (parsed by that
    /// kind) is planned to cost ([`Registry::register_planned`]); `None` if
    /// the kind has no cost model (its stages are short) or is unknown.
    pub fn planned(&self, name: &str, params: &Parsed) -> Option<Planned> {
        (self.kinds.get(name)?.plan.as_ref()?)(params)
    }

    /// [`Registry::planned`] of parameters not yet parsed (a recorded stage's);
    /// `None` also when they no longer parse.
    pub fn planned_raw(&self, name: &str, params: &Value) -> Option<Planned> {
        let r = self.kinds.get(name)?;
        (r.plan.as_ref()?)(&r.kind.parse(params).ok()?)
    }

    /// Names of all registered kinds.
    pub fn names(&self) -> Vec<String> {
        self.kinds.keys().cloned().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::stage::{Artifact, Output, StageCtx};

    #[test]
    fn an_unknown_module_is_an_error_not_a_constant() {
        let e = code_fingerprint("chi4", &["analysis", "stages/chi_4"], &[]).unwrap_err();
        assert!(
            e.to_string().contains("'stages/chi_4'") && e.to_string().contains("chi4"),
            "{e}"
        );
        assert!(code_fingerprint("chi4", &[], &[]).is_err());
        let f = code_fingerprint("table", &["src/pipeline/kinds.rs"], &[]).unwrap();
        assert!(f.modules.contains(&"pipeline/kinds".to_string()), "{f:?}");
        assert!(f.modules.contains(&"table/columns".to_string()), "{f:?}");
        // The stage trait is harness, in no key.
        assert!(!f.modules.contains(&"pipeline/stage".to_string()), "{f:?}");
    }

    #[test]
    #[should_panic(expected = "'no_such_module' is not a source file")]
    fn registering_a_kind_with_a_misspelt_module_panics() {
        struct Bad;
        impl StageKind for Bad {
            type Params = ();
            fn name(&self) -> &str {
                "bad"
            }
            fn modules(&self) -> &[&str] {
                &["no_such_module"]
            }
            fn parse(&self, _: &Value) -> Result<()> {
                Ok(())
            }
            fn run(&self, _: &StageCtx, _: &(), _: &[Artifact]) -> Result<Output> {
                Ok(Output::default())
            }
        }
        Registry::new().register(Bad);
    }
}
