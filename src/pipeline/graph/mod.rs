//! Expand specs into the stage graph: one node per stage instance, identical
//! instances from different figures merged into one node.
//!
//! An experiment expands into one simulate node per (grid point, replica). A
//! pipeline stage either *maps* over the instances of one source (one node each,
//! times its sweep) or *gathers* the instances of its sources (one node, or one per
//! group of equal `by` values, times its sweep). Nodes are stored in topological
//! order: every node's inputs come before it.
//!
//! This file holds the graph's types, the entry points and the node table
//! (identical instances merged by recipe); `experiment.rs` expands
//! experiments, `stages.rs` a figure's pipeline, `reference.rs` a stage read
//! from another figure, and `order.rs` checks a pipeline's stage names and
//! orders its stages.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Result;
use serde_json::{Map, Value};
use serde_saphyr::Spanned;

use super::canon::{Point, canonical, hash_fields};
use super::registry::Registry;
use super::spec;
use super::spec::{Catalogue, PROFILES, SpecError};
pub use super::stage::StageId;
use super::stage::{Parsed, PlannedInput, SourceKind};

mod experiment;
mod order;
mod reference;
mod stages;
mod window;

/// One stage instance.
#[derive(Debug, Clone)]
pub struct Node {
    pub kind: String,
    /// Which declared stages this instance is (a node shared by figures has several;
    /// the first is shown).
    pub ids: Vec<StageId>,
    /// Their readable labels, in the same order (keys of the store's history).
    pub labels: Vec<String>,
    /// Canonical parameters (a JSON object with sorted keys).
    pub params: Value,
    /// The same parameters as its kind parsed them, once, when planned.
    pub parsed: Parsed,
    /// The resolved configuration of the runs it comes from
    /// ([`Artifact::run`](super::stage::Artifact::run)).
    pub run: Arc<Map<String, Value>>,
    /// Grid and sweep values of this instance.
    pub point: Point,
    /// Input nodes, in a fixed order.
    pub inputs: Vec<usize>,
    /// Hash of (kind, params, input recipes): identity before anything runs.
    pub recipe: String,
    /// Seed handed to the stage.
    pub seed: u64,
    /// Where the stage was declared (for errors).
    pub origin: (PathBuf, u64),
}

impl Node {
    pub fn label(&self) -> &str {
        &self.labels[0]
    }

    /// The project root the stage was declared under (its spec file is
    /// `ROOT/pipelines/ID.yaml` or `ROOT/experiments/NAME.yaml`).
    pub fn root(&self) -> &Path {
        self.origin.0.ancestors().nth(2).unwrap_or(Path::new(""))
    }

    /// This node as an input of a stage being planned.
    pub fn planned(&self, reg: &Registry) -> PlannedInput<'_> {
        PlannedInput {
            kind: self.source_kind(reg),
            ids: &self.ids,
            params: &self.params,
            parsed: &self.parsed,
            run: &self.run,
            file: &self.origin.0,
        }
    }

    /// Its kind as its consumers see it: the name and what its output holds.
    pub fn source_kind(&self, reg: &Registry) -> SourceKind {
        SourceKind {
            name: self.kind.clone(),
            holds: reg.holds(&self.kind),
        }
    }
}

/// One figure: its nodes and the stages it publishes into `results/ID/`.
#[derive(Debug, Clone)]
pub struct FigurePlan {
    pub id: String,
    pub description: String,
    /// Every node this figure needs, in topological order.
    pub nodes: Vec<usize>,
    /// (stage name, node) copied into `results/ID/`.
    pub publish: Vec<(String, usize)>,
    /// Stage name -> what it is in the paper (the stages' `describes:`).
    pub describes: BTreeMap<String, String>,
    /// Stage name -> column -> its meaning there (the stages' `columns:`).
    pub columns: BTreeMap<String, BTreeMap<String, String>>,
}

/// The stage graph of one or more figures at one profile.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    pub profile: String,
    pub nodes: Vec<Node>,
    pub figures: Vec<FigurePlan>,
    by_recipe: HashMap<String, usize>,
}

struct Planner<'a> {
    cat: &'a Catalogue,
    reg: &'a Registry,
    graph: Graph,
    experiments: HashMap<String, Vec<usize>>,
    parsed: HashMap<(String, String), Parsed>,
    /// Figures being planned, outermost first: a `from` back to one is a cycle.
    open: Vec<String>,
    /// Experiments' windows planned so far, by `FIGURE/STAGE`.
    windows: HashMap<String, usize>,
}

/// Plan figures `ids` (all figures if empty) at `profile`.
pub fn plan(cat: &Catalogue, ids: &[String], profile: &str, reg: &Registry) -> Result<Graph> {
    let ids: Vec<String> = if ids.is_empty() {
        cat.pipelines.keys().cloned().collect()
    } else {
        ids.to_vec()
    };
    let mut p = Planner::new(cat, reg, profile)?;
    for id in &ids {
        let (file, spec) = cat.pipeline(id).map_err(anyhow::Error::msg)?;
        let fig = p.pipeline(id, file, spec)?;
        p.graph.figures.push(fig);
    }
    Ok(p.graph)
}

/// Plan the simulations of experiment `name` at `profile` alone (no figure):
/// what `repro runs` lists.
pub fn plan_experiment(
    cat: &Catalogue,
    name: &str,
    profile: &str,
    reg: &Registry,
) -> Result<Graph> {
    if !cat.experiments.contains_key(name) {
        anyhow::bail!(
            "no experiment '{name}' (experiments/{name}.yaml); known: {}",
            cat.experiments
                .keys()
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let mut p = Planner::new(cat, reg, profile)?;
    p.experiment(name)?;
    Ok(p.graph)
}

fn err<T>(file: &Path, span: &Spanned<T>, msg: String) -> anyhow::Error {
    SpecError::at(file, span, msg).into()
}

fn mark<T>(span: &Spanned<T>) -> spec::Mark {
    spec::Mark {
        line: span.referenced.line(),
        column: span.referenced.column(),
    }
}

/// The settings every run of `runs` shares (same key, same value): what a
/// stage downstream of several simulations knows of them.
fn shared_run<'a>(
    mut runs: impl Iterator<Item = &'a Map<String, Value>>,
) -> Arc<Map<String, Value>> {
    let Some(first) = runs.next() else {
        return Arc::default();
    };
    let mut shared = first.clone();
    for r in runs {
        shared.retain(|k, v| r.get(k) == Some(v));
    }
    Arc::new(shared)
}

/// Every combination of the listed values, keys in sorted order, last key fastest.
fn combinations(lists: &BTreeMap<String, Vec<Value>>) -> Vec<Point> {
    let mut out = vec![Point::new()];
    for (k, values) in lists {
        out = out
            .into_iter()
            .flat_map(|p| {
                values.iter().map(move |v| {
                    let mut q = p.clone();
                    q.insert(k.clone(), v.clone());
                    q
                })
            })
            .collect();
    }
    out
}

impl<'a> Planner<'a> {
    /// An empty plan at `profile` (an error if no such profile exists).
    fn new(cat: &'a Catalogue, reg: &'a Registry, profile: &str) -> Result<Self> {
        if !PROFILES.contains(&profile) {
            anyhow::bail!("unknown profile '{profile}'; valid profiles: {PROFILES:?}");
        }
        Ok(Planner {
            cat,
            reg,
            graph: Graph {
                profile: profile.to_string(),
                ..Graph::default()
            },
            experiments: HashMap::new(),
            parsed: HashMap::new(),
            open: Vec::new(),
            windows: HashMap::new(),
        })
    }

    /// Add a node unless an identical one exists; returns its index.
    #[allow(clippy::too_many_arguments)]
    fn add(
        &mut self,
        kind: &str,
        id: StageId,
        params: serde_json::Map<String, Value>,
        parsed: Parsed,
        point: Point,
        inputs: Vec<usize>,
        seed: Option<u64>,
        origin: (PathBuf, u64),
    ) -> usize {
        let params = Value::Object(params);
        let canon = canonical(&params);
        let mut fields: Vec<&[u8]> = vec![kind.as_bytes(), canon.as_bytes()];
        let input_recipes: Vec<String> = inputs
            .iter()
            .map(|&i| self.graph.nodes[i].recipe.clone())
            .collect();
        fields.extend(input_recipes.iter().map(|r| r.as_bytes()));
        let recipe = hash_fields("repro-recipe-v1", &fields);
        let recipe_hex = recipe.to_hex().to_string();
        let label = id.to_string();
        if let Some(&i) = self.graph.by_recipe.get(&recipe_hex) {
            self.also_is(i, id);
            return i;
        }
        let seed =
            seed.unwrap_or_else(|| u64::from_le_bytes(recipe.as_bytes()[..8].try_into().unwrap()));
        let run = match self.reg.get(kind).ok().and_then(|k| k.resolved(&parsed)) {
            Some(own) => Arc::new(own),
            None => shared_run(inputs.iter().map(|&i| &*self.graph.nodes[i].run)),
        };
        self.graph.nodes.push(Node {
            kind: kind.to_string(),
            ids: vec![id],
            labels: vec![label],
            params,
            parsed,
            run,
            point,
            inputs,
            recipe: recipe_hex.clone(),
            seed,
            origin,
        });
        let i = self.graph.nodes.len() - 1;
        self.graph.by_recipe.insert(recipe_hex, i);
        i
    }

    /// Node `i` is also the declared stage `id` (another figure's identical
    /// stage, or a reference to it).
    fn also_is(&mut self, i: usize, id: StageId) {
        let node = &mut self.graph.nodes[i];
        let label = id.to_string();
        if !node.labels.contains(&label) {
            node.labels.push(label);
            node.ids.push(id);
        }
    }

    /// Parse a stage's parameters with its kind, once per (kind, parameters).
    fn parse(&mut self, kind: &str, params: &serde_json::Map<String, Value>) -> Result<Parsed> {
        let canon = canonical(&Value::Object(params.clone()));
        if let Some(p) = self.parsed.get(&(kind.to_string(), canon.clone())) {
            return Ok(p.clone());
        }
        let p = self.reg.get(kind)?.parse(&Value::Object(params.clone()))?;
        self.parsed.insert((kind.to_string(), canon), p.clone());
        Ok(p)
    }

    /// What a plot's notes may state about the build it draws: the profile,
    /// and of every experiment upstream of `inputs` its number-valued
    /// parameters at this profile (e.g. `n`) and `replicas`
    /// (`{=eps09.n}` in a note; [`crate::stages::plot`]).
    fn build_info(&self, inputs: &[usize]) -> Value {
        let mut seen = vec![false; self.graph.nodes.len()];
        let mut stack = inputs.to_vec();
        let mut names: BTreeMap<String, ()> = BTreeMap::new();
        // The row windows (`where`) of this figure's stages upstream, one per
        // stage name; `None` where its instances differ (no one number).
        let mut windows: BTreeMap<String, Option<serde_json::Map<String, Value>>> = BTreeMap::new();
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            let node = &self.graph.nodes[n];
            for id in node.ids.iter().filter(|id| id.figure.is_none()) {
                names.insert(id.stage.clone(), ());
            }
            if let Some(id) = node.ids.iter().find(|id| id.figure.is_some())
                && let Some(w) = node.params.get("where").and_then(window_fields)
            {
                windows
                    .entry(id.stage.clone())
                    .and_modify(|e| {
                        if e.as_ref() != Some(&w) {
                            *e = None;
                        }
                    })
                    .or_insert(Some(w));
            }
            stack.extend(node.inputs.iter().copied());
        }
        let mut experiments = serde_json::Map::new();
        for name in names.keys() {
            let Some((_, spec)) = self.cat.experiments.get(name) else {
                continue;
            };
            let Some(mut m) = spec.parameters(&self.graph.profile) else {
                continue;
            };
            // Numbers only: a grid of several values is not one number of the build.
            m.retain(|_, v| v.is_number());
            experiments.insert(name.clone(), Value::Object(m));
        }
        let windows: serde_json::Map<String, Value> = windows
            .into_iter()
            .filter_map(|(k, w)| Some((k, Value::Object(w?))))
            .collect();
        serde_json::json!({"profile": self.graph.profile, "experiments": experiments, "windows": windows})
    }

    /// Every node `roots` reach through their inputs, the roots included, in order.
    fn upstream(&self, roots: impl Iterator<Item = usize>) -> Vec<usize> {
        let mut needed = vec![false; self.graph.nodes.len()];
        let mut stack: Vec<usize> = roots.collect();
        while let Some(n) = stack.pop() {
            if !needed[n] {
                needed[n] = true;
                stack.extend(self.graph.nodes[n].inputs.iter().copied());
            }
        }
        (0..needed.len()).filter(|&i| needed[i]).collect()
    }
}

/// A stage's `where` as numbers a text may name: `where_COL` for an equality
/// (or a list), `where_COL_min` and `where_COL_max` for a range
/// (`{=oz_04.where_q_max}` prints the q window a fit used).
fn window_fields(w: &Value) -> Option<serde_json::Map<String, Value>> {
    let mut out = serde_json::Map::new();
    for (col, cond) in w.as_object()? {
        match cond {
            Value::Number(_) | Value::Array(_) => {
                out.insert(format!("where_{col}"), cond.clone());
            }
            Value::Object(r) => {
                for end in ["min", "max"] {
                    if let Some(v) = r.get(end).filter(|v| v.is_number()) {
                        out.insert(format!("where_{col}_{end}"), v.clone());
                    }
                }
            }
            _ => {}
        }
    }
    (!out.is_empty()).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::spec::parse;
    use serde_json::json;

    const EXP: &str = "description: e\nkind: toy_simulate\nseed: 5\nprofiles:\n  ci:\n    grid:\n      phi: [0.7, 0.8]\n      eps: [0.8, 0.9, 1.0]\n    replicas: 2\n    params: {n: 4}\n";

    fn catalogue(pipes: &[(&str, &str)]) -> Catalogue {
        let mut c = Catalogue::default();
        let f = PathBuf::from("experiments/e.yaml");
        c.experiments
            .insert("e".into(), (f.clone(), parse(&f, EXP).unwrap()));
        for (id, text) in pipes {
            let f = PathBuf::from(format!("pipelines/{id}.yaml"));
            c.pipelines
                .insert(id.to_string(), (f.clone(), parse(&f, text).unwrap()));
        }
        c
    }

    fn registry() -> Registry {
        let mut r = Registry::framework();
        crate::pipeline::toy::register(&mut r);
        r
    }

    #[test]
    fn stage_ids_are_typed_and_render_as_labels() {
        let pt = |v: &[(&str, Value)]| -> Point {
            v.iter().map(|(k, x)| (k.to_string(), x.clone())).collect()
        };
        let tau = StageId {
            figure: Some("fig4".into()),
            stage: "tau".into(),
            point: pt(&[("phi", Value::from(0.6))]),
        };
        assert_eq!(tau.to_string(), "fig4/tau[phi=0.6]");
        let fit = StageId {
            figure: Some("fig4".into()),
            stage: "taufit".into(),
            point: Point::new(),
        };
        assert_eq!(fit.to_string(), "fig4/taufit");
        let sim = StageId {
            figure: None,
            stage: "eps09".into(),
            point: pt(&[("phi", Value::from(0.6)), ("replica", Value::from(0))]),
        };
        assert_eq!(sim.to_string(), "eps09[phi=0.6,replica=0]");
        // A planned node carries its id: the stage is found by name, not by label text.
        let g = plan(
            &catalogue(&[(
                "p",
                "description: p\nstages:\n  - name: s\n    kind: toy_analyse\n    map: e\n    params: {a: 1.0}\n",
            )]),
            &["p".to_string()],
            "ci",
            &registry(),
        )
        .unwrap();
        let n = g.nodes.iter().find(|n| n.kind == "toy_analyse").unwrap();
        assert_eq!(n.ids[0].figure.as_deref(), Some("p"));
        assert_eq!(n.ids[0].stage, "s");
        assert_eq!(n.label(), n.ids[0].to_string());
        let sim = &g.nodes[n.inputs[0]];
        assert_eq!(
            (sim.ids[0].figure.as_ref(), sim.ids[0].stage.as_str()),
            (None, "e")
        );
    }

    /// A stage's `where` as the numbers a text may name.
    #[test]
    fn a_window_names_its_bounds_and_values() {
        let w =
            window_fields(&json!({"q": {"min": 0.001, "max": 0.4}, "phi": 0.78, "kind": [0, 1]}))
                .unwrap();
        assert_eq!(
            Value::Object(w),
            json!({"where_q_min": 0.001, "where_q_max": 0.4, "where_phi": 0.78, "where_kind": [0, 1]})
        );
        assert!(window_fields(&json!({})).is_none());
    }

    #[test]
    fn combinations_cover_the_product_last_key_fastest() {
        let mut l = BTreeMap::new();
        l.insert("a".to_string(), vec![json!(1), json!(2)]);
        l.insert("b".to_string(), vec![json!("x"), json!("y"), json!("z")]);
        let c = combinations(&l);
        assert_eq!(c.len(), 6);
        assert_eq!(
            (c[0]["a"].clone(), c[0]["b"].clone()),
            (json!(1), json!("x"))
        );
        assert_eq!(
            (c[1]["a"].clone(), c[1]["b"].clone()),
            (json!(1), json!("y"))
        );
        assert_eq!(c[5]["a"], json!(2));
    }

    #[test]
    fn map_sweep_gather_by_and_sharing_give_the_expected_nodes() {
        let p1 = "description: p\nstages:\n  - name: s\n    kind: toy_analyse\n    map: e\n    sweep: {a: [0.5, 1.0]}\n  - name: t\n    kind: table\n    gather: [s]\n    by: [phi, a]\n";
        let p2 = "description: q\nstages:\n  - name: s2\n    kind: toy_analyse\n    map: e\n    params: {a: 1.0}\n";
        let c = catalogue(&[("p1", p1), ("p2", p2)]);
        let g = plan(&c, &[], "ci", &registry()).unwrap();
        let count = |k: &str| g.nodes.iter().filter(|n| n.kind == k).count();
        // 2 phi x 3 eps x 2 replicas simulations, shared by both figures.
        assert_eq!(count("toy_simulate"), 12);
        // p1: 12 x 2 cutoffs; p2's a = 1.0 analyses are the same nodes as p1's.
        assert_eq!(count("toy_analyse"), 24);
        assert!(
            g.nodes
                .iter()
                .any(|n| n.labels.len() == 2 && n.labels[1].starts_with("p2/s2["))
        );
        // Grouped by (phi, a): 4 tables of 3 eps x 2 replicas each.
        let tables: Vec<&Node> = g.nodes.iter().filter(|n| n.kind == "table").collect();
        assert_eq!(tables.len(), 4);
        assert!(
            tables
                .iter()
                .all(|t| t.inputs.len() == 6 && t.point.len() == 2)
        );
        // Topological order and distinct seeds for every simulation.
        for (i, n) in g.nodes.iter().enumerate() {
            assert!(n.inputs.iter().all(|&j| j < i));
        }
        let mut seeds: Vec<u64> = g
            .nodes
            .iter()
            .filter(|n| n.kind == "toy_simulate")
            .map(|n| n.seed)
            .collect();
        seeds.sort();
        seeds.dedup();
        assert_eq!(seeds.len(), 12);
        // Planning is deterministic: same recipes in the same order.
        let again = plan(&c, &[], "ci", &registry()).unwrap();
        let r = |g: &Graph| g.nodes.iter().map(|n| n.recipe.clone()).collect::<Vec<_>>();
        assert_eq!(r(&g), r(&again));
    }

    #[test]
    fn a_stage_from_another_figure_is_its_node_and_a_wrong_reference_is_located() {
        let a = "description: a\nstages:\n  - name: s\n    kind: toy_analyse\n    map: e\n    params: {a: 1.0}\n  - name: t\n    kind: table\n    gather: [s]\n";
        let b = "description: b\nstages:\n  - name: mine\n    from: a/t\n  - name: u\n    kind: table\n    gather: [mine]\n";
        let g = plan(
            &catalogue(&[("a", a), ("b", b)]),
            &["b".into()],
            "ci",
            &registry(),
        )
        .unwrap();
        // Only what b reads of a is planned, once: one table node that is both stages.
        let tables: Vec<&Node> = g.nodes.iter().filter(|n| n.kind == "table").collect();
        assert_eq!(tables.len(), 2);
        let t = tables.iter().find(|n| n.labels[0] == "a/t").unwrap();
        assert_eq!(t.labels, ["a/t", "b/mine"]);
        let u = tables.iter().find(|n| n.labels[0] == "b/u").unwrap();
        assert_eq!(g.nodes[u.inputs[0]].recipe, t.recipe);
        let fig = &g.figures[0];
        assert!(fig.publish.iter().any(|(name, _)| name == "mine"));
        // Planning a too gives the very same node.
        let both = plan(
            &catalogue(&[("a", a), ("b", b)]),
            &["a".into(), "b".into()],
            "ci",
            &registry(),
        )
        .unwrap();
        let recipe = |g: &Graph, fig: &str, stage: &str| {
            let f = g.figures.iter().find(|f| f.id == fig).unwrap();
            let (_, n) = f.publish.iter().find(|(s, _)| s == stage).unwrap();
            g.nodes[*n].recipe.clone()
        };
        assert_eq!(recipe(&both, "a", "t"), recipe(&both, "b", "mine"));
        assert_eq!(recipe(&both, "a", "t"), t.recipe);

        let wrong = |b: &str| {
            let e = plan(
                &catalogue(&[("a", a), ("b", b)]),
                &["b".into()],
                "ci",
                &registry(),
            )
            .unwrap_err();
            format!("{e:#}")
        };
        let m = wrong("description: b\nstages:\n  - name: mine\n    from: a/nope\n");
        assert!(
            m.starts_with("pipelines/b.yaml:3:")
                && m.contains("no stage 'nope'")
                && m.contains("its stages: s, t"),
            "{m}"
        );
        let m = wrong("description: b\nstages:\n  - name: mine\n    from: z/t\n");
        assert!(
            m.starts_with("pipelines/b.yaml:3:")
                && m.contains("'z'")
                && m.contains("known figures: a, b"),
            "{m}"
        );
        let m = wrong("description: b\nstages:\n  - name: mine\n    from: a/t\n    kind: table\n");
        assert!(
            m.contains("takes only `name`, `publish`, `describes` and `columns`"),
            "{m}"
        );
        let m = wrong("description: b\nstages:\n  - name: mine\n    map: e\n");
        assert!(m.contains("has no `kind`"), "{m}");
        // Figures reading each other's stages in a circle.
        let a2 = "description: a\nstages:\n  - name: t\n    from: b/mine\n";
        let e = plan(
            &catalogue(&[("a", a2), ("b", b)]),
            &["b".into()],
            "ci",
            &registry(),
        )
        .unwrap_err();
        assert!(
            format!("{e:#}").contains("cycle of figures")
                && format!("{e:#}").contains("b -> a -> b"),
            "{e:#}"
        );
    }

    #[test]
    fn publishing_a_multi_instance_stage_is_an_error() {
        let p = "description: p\nstages:\n  - name: s\n    kind: toy_analyse\n    map: e\n    params: {a: 1}\n    publish: true\n";
        let e = plan(&catalogue(&[("p", p)]), &[], "ci", &registry()).unwrap_err();
        let m = format!("{e:#}");
        assert!(
            m.starts_with("pipelines/p.yaml:3:") && m.contains("12 instances"),
            "{m}"
        );
    }

    #[test]
    fn a_missing_profile_names_the_ones_defined() {
        let p = "description: p\nstages:\n  - name: t\n    kind: table\n    gather: [e]\n";
        let e = plan(&catalogue(&[("p", p)]), &[], "paper", &registry()).unwrap_err();
        assert!(
            format!("{e:#}").contains("experiment 'e' has no profile 'paper'; it defines: ci"),
            "{e:#}"
        );
    }
}
