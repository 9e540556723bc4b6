//! The values a report's texts name, read back from the store: the compare
//! reasons of `repro report` and the `error_coverage` of `repro coverage`
//! resolve their references ([`crate::table::references`]) here. A stage is
//! looked up under the key the current specs and code give it at that profile,
//! so a build of other code or parameters reads as not built, never as an old
//! number.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;
use std::rc::Rc;

use anyhow::{Context, Result, bail};

use crate::pipeline::exec::{State, artifact, status};
use crate::pipeline::{Catalogue, Graph, Registry, Store, Workspace, needed_nodes};
use crate::stages::tables::Columns;
use crate::table::references::{Lookup, Reference, Resolved, Target, render};

/// The builds in a workspace's store, seen from one profile.
pub struct Built<'a> {
    ws: Workspace,
    reg: &'a Registry,
    cat: Catalogue,
    store: Store,
    /// The profile a reference without `PROFILE:` names.
    profile: String,
    /// Each (figure, profile) planned so far, with the keys of its cached stages.
    plans: RefCell<BTreeMap<(String, String), Rc<Plan>>>,
}

struct Plan {
    graph: Graph,
    /// Node -> cache key, for the stages whose current result is in the store.
    cached: BTreeMap<usize, String>,
}

impl<'a> Built<'a> {
    /// The store and specs under `root`, read at `profile`.
    pub fn open(root: &Path, reg: &'a Registry, profile: &str) -> Result<Built<'a>> {
        let ws = Workspace::new(root);
        Ok(Built {
            cat: Catalogue::load(root)?,
            store: Store::open(&ws.store)?,
            ws,
            reg,
            profile: profile.to_string(),
            plans: RefCell::default(),
        })
    }

    /// `text` of figure `figure` with its references resolved.
    pub fn render(&self, figure: &str, text: &str) -> Result<String> {
        render(
            text,
            &Of {
                built: self,
                figure,
            },
        )
        .with_context(|| format!("figure {figure}"))
    }

    fn plan(&self, figure: &str, profile: &str) -> Result<Rc<Plan>> {
        let k = (figure.to_string(), profile.to_string());
        if let Some(p) = self.plans.borrow().get(&k) {
            return Ok(p.clone());
        }
        let graph = self.ws.plan(self.reg, &[figure.to_string()], profile)?;
        let cached = status(&graph, &needed_nodes(&graph), self.reg, &self.store, &[])
            .into_iter()
            .filter_map(|(i, s)| match s {
                State::Cached { key } => Some((i, key)),
                _ => None,
            })
            .collect();
        let p = Rc::new(Plan { graph, cached });
        self.plans.borrow_mut().insert(k, p.clone());
        Ok(p)
    }

    /// Value `field` of stage `name` of `figure` at `profile` (the row `row`).
    fn stage_value(
        &self,
        figure: &str,
        profile: &str,
        name: &str,
        field: &str,
        row: &[(String, f64)],
    ) -> Result<Resolved> {
        let plan = self.plan(figure, profile)?;
        let nodes: Vec<usize> = (0..plan.graph.nodes.len())
            .filter(|&i| {
                plan.graph.nodes[i]
                    .ids
                    .iter()
                    .any(|id| id.figure.as_deref() == Some(figure) && id.stage == name)
            })
            .collect();
        let i = match nodes[..] {
            [i] => i,
            [] => bail!("figure {figure} has no stage '{name}' at profile {profile}"),
            _ => bail!(
                "stage {figure}/{name} has {} instances at {profile}: reference the table that gathers them",
                nodes.len()
            ),
        };
        let Some(key) = plan.cached.get(&i) else {
            return Ok(Resolved::NotBuilt {
                profile: profile.to_string(),
                figure: figure.to_string(),
            });
        };
        let entry = self
            .store
            .lookup(key)
            .with_context(|| format!("the store lost the entry of {figure}/{name}"))?;
        let node = &plan.graph.nodes[i];
        let art = artifact(&self.store, self.reg, node, node, &entry);
        let (value, error) = Columns::read(&[&art])?.value_of(field, row)?;
        Ok(Resolved::Number { value, error })
    }
}

/// The builds seen from one figure's texts.
struct Of<'b, 'a> {
    built: &'b Built<'a>,
    figure: &'b str,
}

impl Lookup for Of<'_, '_> {
    fn resolve(&self, r: &Reference) -> Result<Resolved> {
        let b = self.built;
        let profile = r.profile.as_deref().unwrap_or(&b.profile);
        let figure = r.figure.as_deref().unwrap_or(self.figure);
        let Target::Field { name, field, row } = &r.target else {
            return Ok(Resolved::Text(profile.to_string()));
        };
        let Some((_, exp)) = b.cat.experiments.get(name) else {
            return b.stage_value(figure, profile, name, field, row);
        };
        if !row.is_empty() {
            bail!("experiment {name}: a parameter has no rows");
        }
        let params = exp
            .parameters(profile)
            .with_context(|| format!("experiment {name} has no profile {profile}"))?;
        let v = params.get(field.as_str()).with_context(|| {
            format!(
                "experiment {name} has no parameter '{field}' at {profile}; it has: {}",
                params.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })?;
        Ok(Resolved::Param(v.clone()))
    }
}
