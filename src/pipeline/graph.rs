//! Expand specs into the stage graph: one node per stage instance, identical
//! instances from different figures merged into one node.
//!
//! An experiment expands into one simulate node per (grid point, replica). A
//! pipeline stage either *maps* over the instances of one source (one node each,
//! times its sweep) or *gathers* the instances of its sources (one node, or one per
//! group of equal `by` values, times its sweep). Nodes are stored in topological
//! order: every node's inputs come before it.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Result;
use serde_json::{Map, Value};
use serde_saphyr::Spanned;

use super::canon::{Point, canonical, derive_seed, hash_fields};
use super::registry::Registry;
use super::spec;
use super::spec::{Catalogue, ExperimentSpec, PROFILES, PipelineSpec, SpecError, StageSpec};
pub use super::stage::StageId;
use super::stage::{Parsed, PlannedInput, SourceKind};

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
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            let node = &self.graph.nodes[n];
            for id in node.ids.iter().filter(|id| id.figure.is_none()) {
                names.insert(id.stage.clone(), ());
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
        serde_json::json!({"profile": self.graph.profile, "experiments": experiments})
    }

    fn experiment(&mut self, name: &str) -> Result<Vec<usize>> {
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

    /// Plan figure `id`: every stage of its pipeline and what they read.
    fn pipeline(&mut self, id: &str, file: &Path, spec: &PipelineSpec) -> Result<FigurePlan> {
        self.open.push(id.to_string());
        let planned = self.stages(id, file, spec, None);
        self.open.pop();
        let planned = planned?;
        let nodes = self.upstream(planned.instances.values().flatten().copied());
        Ok(FigurePlan {
            id: id.to_string(),
            description: spec.description.clone(),
            nodes,
            publish: planned.publish,
            describes: planned.describes,
        })
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

    /// Plan the stages of figure `id` (only `root` and what it reads, when given).
    fn stages(
        &mut self,
        id: &str,
        file: &Path,
        spec: &PipelineSpec,
        root: Option<&str>,
    ) -> Result<Stages> {
        let by_name = stage_names(file, spec, self.cat)?;
        let order = topological(file, spec, &by_name, self.cat, root)?;
        let mut out = Stages::default();
        for s in order {
            let site = Site {
                figure: id,
                file,
                spec,
                stage: s,
            };
            let st = &s.value;
            if let Some(d) = &st.describes {
                out.describes.insert(st.name.clone(), d.clone());
            }
            let mine = match &st.from {
                Some(target) => self.reference(site, target)?,
                None => self.declared(site, &out.instances)?,
            };
            if let Some(n) = published(site, &mine)? {
                out.publish.push((st.name.clone(), n));
            }
            out.instances.insert(st.name.clone(), mine);
        }
        Ok(out)
    }

    /// The instances of another figure's stage (`from: FIGURE/STAGE`), planned
    /// as that figure plans them, so that both figures share the nodes.
    fn reference(&mut self, site: Site, target: &str) -> Result<Vec<usize>> {
        let st = &site.stage.value;
        if !st.kind.is_empty()
            || st.map.is_some()
            || st.gather.is_some()
            || !st.by.is_empty()
            || !st.params.is_empty()
            || !st.sweep.is_empty()
            || !st.profiles.is_empty()
        {
            return Err(site.err(format!(
                "stage '{}' is `from: {target}`, another figure's stage as that figure declares it: it takes only `name`, `publish` and `describes` (no `kind`, `map`, `gather`, `by`, `params`, `sweep` or `profiles`)",
                st.name
            )));
        }
        let Some((fig, stage)) = target.split_once('/') else {
            return Err(site.err(format!(
                "stage '{}': `from` wants FIGURE/STAGE (e.g. fig4/joint); got '{target}'",
                st.name
            )));
        };
        let (file, spec) = self
            .cat
            .pipeline(fig)
            .map_err(|e| site.err(format!("stage '{}': `from: {target}`: {e}", st.name)))?;
        if !spec.stages.iter().any(|x| x.value.name == stage) {
            let known: Vec<&str> = spec.stages.iter().map(|x| x.value.name.as_str()).collect();
            return Err(site.err(format!(
                "stage '{}': `from: {target}`: figure '{fig}' ({}) has no stage '{stage}'; its stages: {}",
                st.name,
                file.display(),
                known.join(", ")
            )));
        }
        if self.open.iter().any(|f| f == fig) {
            return Err(site.err(format!(
                "stage '{}': `from: {target}` closes a cycle of figures reading each other's stages: {} -> {fig}",
                st.name,
                self.open.join(" -> ")
            )));
        }
        self.open.push(fig.to_string());
        let planned = self.stages(fig, file, spec, Some(stage));
        self.open.pop();
        let nodes = planned?.instances.remove(stage).unwrap_or_default();
        for &n in &nodes {
            let point = self.graph.nodes[n].point.clone();
            self.also_is(
                n,
                StageId {
                    figure: Some(site.figure.to_string()),
                    stage: st.name.clone(),
                    point,
                },
            );
        }
        Ok(nodes)
    }

    /// The instances of a stage declared with its kind: one per group of its
    /// inputs and per combination of its sweep.
    fn declared(
        &mut self,
        site: Site,
        planned: &HashMap<String, Vec<usize>>,
    ) -> Result<Vec<usize>> {
        let st = &site.stage.value;
        if st.kind.is_empty() {
            return Err(site.err(format!(
                "stage '{}' has no `kind`: give `kind: KIND`, or `from: FIGURE/STAGE` to read another figure's stage",
                st.name
            )));
        }
        let mut src_nodes: Vec<Vec<usize>> = Vec::new();
        for src in sources(site)? {
            let nodes = if self.cat.experiments.contains_key(&src) {
                self.experiment(&src)?
            } else {
                planned[&src].clone()
            };
            src_nodes.push(nodes);
        }
        let params = stage_params(site, &self.graph.profile)?;
        let groups = self.input_groups(site, &src_nodes)?;
        let sweeps = combinations(&st.sweep);
        let mut mine = Vec::new();
        for (gpoint, inputs) in &groups {
            for sw in &sweeps {
                mine.push(self.instance(site, &params, gpoint, sw, inputs)?);
            }
        }
        Ok(mine)
    }

    /// Groups of input nodes, each with the point it carries downstream: one
    /// per source instance (`map`), or per equal `by` values (`gather`).
    fn input_groups(
        &self,
        site: Site,
        src_nodes: &[Vec<usize>],
    ) -> Result<Vec<(Point, Vec<usize>)>> {
        let st = &site.stage.value;
        if st.map.is_some() {
            return Ok(src_nodes[0]
                .iter()
                .map(|&n| (self.graph.nodes[n].point.clone(), vec![n]))
                .collect());
        }
        let mut g: BTreeMap<String, (Point, Vec<usize>)> = BTreeMap::new();
        let mut order = Vec::new();
        for &n in src_nodes.iter().flatten() {
            let pt = &self.graph.nodes[n].point;
            let mut key = Point::new();
            for b in &st.by {
                let v = pt.get(b).ok_or_else(|| {
                    site.err(format!(
                        "stage '{}': cannot group by '{b}': input {} has no such point key (it has: {})",
                        st.name,
                        self.graph.nodes[n].label(),
                        pt.keys().cloned().collect::<Vec<_>>().join(", ")
                    ))
                })?;
                key.insert(b.clone(), v.clone());
            }
            let kc = canonical(&Value::Object(key.clone().into_iter().collect()));
            if !g.contains_key(&kc) {
                order.push(kc.clone());
            }
            g.entry(kc).or_insert_with(|| (key, Vec::new())).1.push(n);
        }
        Ok(order.into_iter().map(|k| g.remove(&k).unwrap()).collect())
    }

    /// One instance of a declared stage: its parameters parsed and checked
    /// against its planned inputs, then added (or found) as a node.
    fn instance(
        &mut self,
        site: Site,
        params: &serde_json::Map<String, Value>,
        gpoint: &Point,
        sweep: &Point,
        inputs: &[usize],
    ) -> Result<usize> {
        let st = &site.stage.value;
        let mut point = gpoint.clone();
        for (k, v) in sweep {
            if point.contains_key(k) {
                return Err(site.err(format!(
                    "stage '{}': swept key '{k}' is already a point key of its input; rename it",
                    st.name
                )));
            }
            point.insert(k.clone(), v.clone());
        }
        let mut p = params.clone();
        p.extend(sweep.clone());
        if st.kind == "plot" {
            p.insert("build".into(), self.build_info(inputs));
        }
        let profile = self.graph.profile.clone();
        let locate = |e: anyhow::Error| site.param_error(&profile, &e);
        let parsed = self.parse(&st.kind, &p).map_err(locate)?;
        // What the stage asks of its planned inputs (lags long enough, ...).
        let upstream: Vec<PlannedInput> = inputs
            .iter()
            .map(|&n| self.graph.nodes[n].planned(self.reg))
            .collect();
        self.reg
            .get(&st.kind)?
            .check_inputs(&parsed, &upstream)
            .map_err(locate)?;
        let sid = StageId {
            figure: Some(site.figure.to_string()),
            stage: st.name.clone(),
            point: point.clone(),
        };
        let origin = (site.file.to_path_buf(), site.stage.referenced.line());
        Ok(self.add(
            &st.kind,
            sid,
            p,
            parsed,
            point,
            inputs.to_vec(),
            None,
            origin,
        ))
    }
}

/// A pipeline's stages as planned: instances by stage name, what it
/// publishes and what its stages are in the paper.
#[derive(Default)]
struct Stages {
    instances: HashMap<String, Vec<usize>>,
    publish: Vec<(String, usize)>,
    describes: BTreeMap<String, String>,
}

/// Where a stage is declared: its figure, file, pipeline and entry.
#[derive(Clone, Copy)]
struct Site<'s> {
    figure: &'s str,
    file: &'s Path,
    spec: &'s PipelineSpec,
    stage: &'s Spanned<StageSpec>,
}

impl Site<'_> {
    /// An error located at the stage's entry.
    fn err(&self, msg: String) -> anyhow::Error {
        err(self.file, self.stage, msg)
    }

    /// A parameter error located at its key under the stage's `sweep`, this
    /// profile's overrides or `params`.
    fn param_error(&self, profile: &str, e: &anyhow::Error) -> anyhow::Error {
        let st = &self.stage.value;
        let i = self
            .spec
            .stages
            .iter()
            .position(|x| x.value.name == st.name)
            .unwrap_or(0)
            .to_string();
        let at = |p: &[&str]| p.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        spec::param_error(
            self.file,
            &[
                at(&["stages", &i, "sweep"]),
                at(&["stages", &i, "profiles", profile]),
                at(&["stages", &i, "params"]),
            ],
            mark(self.stage),
            &format!("stage '{}' (kind {})", st.name, st.kind),
            e,
        )
        .into()
    }
}

/// The stages of a pipeline by name; an error for a name used twice or also
/// an experiment's.
fn stage_names<'s>(
    file: &Path,
    spec: &'s PipelineSpec,
    cat: &Catalogue,
) -> Result<BTreeMap<&'s str, &'s Spanned<StageSpec>>> {
    let mut by_name: BTreeMap<&str, &Spanned<StageSpec>> = BTreeMap::new();
    for s in &spec.stages {
        if cat.experiments.contains_key(&s.value.name) {
            return Err(err(
                file,
                s,
                format!(
                    "stage name '{}' is also an experiment name; rename the stage",
                    s.value.name
                ),
            ));
        }
        if by_name.insert(&s.value.name, s).is_some() {
            return Err(err(
                file,
                s,
                format!(
                    "two stages are called '{}'; stage names must be unique",
                    s.value.name
                ),
            ));
        }
    }
    Ok(by_name)
}

/// What a declared stage reads: its `map` source or its `gather` list.
fn sources(site: Site) -> Result<Vec<String>> {
    let st = &site.stage.value;
    let sources = match (&st.map, &st.gather) {
        (Some(m), None) => vec![m.clone()],
        (None, Some(g)) if !g.is_empty() => g.clone(),
        (None, Some(_)) => {
            return Err(site.err(format!("stage '{}': `gather` lists no source", st.name)));
        }
        (Some(_), Some(_)) => {
            return Err(site.err(format!(
                "stage '{}' has both `map` and `gather`; give exactly one",
                st.name
            )));
        }
        (None, None) => {
            return Err(site.err(format!(
                "stage '{}' reads nothing: give `map: SOURCE` (one instance per source instance) or `gather: [SOURCES]` (one instance reading them all)",
                st.name
            )));
        }
    };
    if st.map.is_some() && !st.by.is_empty() {
        return Err(site.err(format!(
            "stage '{}': `by` only applies to `gather`",
            st.name
        )));
    }
    Ok(sources)
}

/// A declared stage's parameters at `profile`: common, then the profile's
/// overrides; checks its profile names and its sweep.
fn stage_params(site: Site, profile: &str) -> Result<serde_json::Map<String, Value>> {
    let st = &site.stage.value;
    if let Some(p) = st.profiles.keys().find(|p| !PROFILES.contains(&p.as_str())) {
        return Err(site.err(format!(
            "stage '{}': unknown profile '{p}' under `profiles`; valid: {PROFILES:?}",
            st.name
        )));
    }
    let mut params: serde_json::Map<String, Value> = st.params.clone().into_iter().collect();
    if let Some(o) = st.profiles.get(profile) {
        params.extend(o.clone());
    }
    for (k, v) in &st.sweep {
        if v.is_empty() {
            return Err(site.err(format!(
                "stage '{}': sweep over '{k}' has an empty list of values; give at least one value",
                st.name
            )));
        }
        if params.contains_key(k) {
            return Err(site.err(format!(
                "stage '{}': '{k}' is both a fixed parameter and swept; keep one",
                st.name
            )));
        }
    }
    Ok(params)
}

/// The node a stage publishes into `results/ID/`: its one instance, unless
/// `publish: false`; an error when `publish: true` asks it of several.
fn published(site: Site, mine: &[usize]) -> Result<Option<usize>> {
    let st = &site.stage.value;
    match (st.publish, mine) {
        (Some(true), m) if m.len() != 1 => Err(site.err(format!(
            "stage '{}' has {} instances; only a single-instance stage can be published (gather it first)",
            st.name,
            mine.len()
        ))),
        (Some(true) | None, [one]) => Ok(Some(*one)),
        _ => Ok(None),
    }
}

/// Order the stages (all, or `root` and what it reads) so each comes after
/// what it reads; detect unknown names and cycles.
fn topological<'s>(
    file: &Path,
    spec: &'s PipelineSpec,
    by_name: &BTreeMap<&'s str, &'s Spanned<StageSpec>>,
    cat: &Catalogue,
    root: Option<&str>,
) -> Result<Vec<&'s Spanned<StageSpec>>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let mut mark: HashMap<&str, Mark> = by_name.keys().map(|k| (*k, Mark::New)).collect();
    let mut out = Vec::new();
    fn sources(s: &StageSpec) -> Vec<&String> {
        s.map.iter().chain(s.gather.iter().flatten()).collect()
    }
    fn visit<'s>(
        name: &'s str,
        path: &mut Vec<&'s str>,
        file: &Path,
        by_name: &BTreeMap<&'s str, &'s Spanned<StageSpec>>,
        cat: &Catalogue,
        mark: &mut HashMap<&'s str, Mark>,
        out: &mut Vec<&'s Spanned<StageSpec>>,
    ) -> Result<()> {
        let s = by_name[name];
        match mark[name] {
            Mark::Done => return Ok(()),
            Mark::Open => {
                let start = path.iter().position(|p| *p == name).unwrap_or(0);
                let mut cycle: Vec<&str> = path[start..].to_vec();
                cycle.push(name);
                return Err(err(
                    file,
                    s,
                    format!(
                        "stages form a cycle: {}; a stage cannot (indirectly) read itself",
                        cycle.join(" -> ")
                    ),
                ));
            }
            Mark::New => {}
        }
        mark.insert(name, Mark::Open);
        path.push(name);
        for src in sources(&s.value) {
            if cat.experiments.contains_key(src) {
                continue;
            }
            match by_name.get_key_value(src.as_str()) {
                Some((k, _)) => visit(k, path, file, by_name, cat, mark, out)?,
                None => {
                    return Err(err(
                        file,
                        s,
                        format!(
                            "stage '{}' reads '{src}', which is neither an experiment (known: {}) nor a stage of this pipeline (known: {})",
                            s.value.name,
                            cat.experiments
                                .keys()
                                .cloned()
                                .collect::<Vec<_>>()
                                .join(", "),
                            by_name.keys().copied().collect::<Vec<_>>().join(", ")
                        ),
                    ));
                }
            }
        }
        path.pop();
        mark.insert(name, Mark::Done);
        out.push(s);
        Ok(())
    }
    let roots = spec
        .stages
        .iter()
        .filter(|s| root.is_none_or(|r| s.value.name == r));
    for s in roots {
        visit(
            &s.value.name,
            &mut Vec::new(),
            file,
            by_name,
            cat,
            &mut mark,
            &mut out,
        )?;
    }
    Ok(out)
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
            m.contains("takes only `name`, `publish` and `describes`"),
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
