//! A figure's pipeline expanded into nodes: each stage declared with its kind
//! *maps* over the instances of one source or *gathers* those of its sources
//! (one node, or one per group of equal `by` values), times its sweep; a stage
//! `from` another figure is that figure's nodes ([`super::reference`]).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use anyhow::Result;
use serde_json::Value;
use serde_saphyr::Spanned;

use super::super::canon::{Point, canonical};
use super::super::spec::{self, PROFILES, PipelineSpec, StageSpec};
use super::super::stage::PlannedInput;
use super::order::{stage_names, topological};
use super::{FigurePlan, Planner, StageId, combinations, err, mark};

impl Planner<'_> {
    /// Plan figure `id`: every stage of its pipeline and what they read.
    pub(super) fn pipeline(
        &mut self,
        id: &str,
        file: &Path,
        spec: &PipelineSpec,
    ) -> Result<FigurePlan> {
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
            columns: planned.columns,
        })
    }

    /// Plan the stages of figure `id` (only `root` and what it reads, when given).
    pub(super) fn stages(
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
            if !st.columns.is_empty() {
                out.columns.insert(st.name.clone(), st.columns.clone());
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
        // An analysis of runs whose experiment names its window reads it too.
        let mut inputs = inputs.to_vec();
        if self.reg.get(&st.kind)?.takes_window(&parsed) {
            for w in self.windows(site, &inputs)? {
                if !inputs.contains(&w) {
                    inputs.push(w);
                }
            }
        }
        let inputs = &inputs[..];
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
pub(super) struct Stages {
    pub(super) instances: HashMap<String, Vec<usize>>,
    publish: Vec<(String, usize)>,
    describes: BTreeMap<String, String>,
    columns: BTreeMap<String, BTreeMap<String, String>>,
}

/// Where a stage is declared: its figure, file, pipeline and entry.
#[derive(Clone, Copy)]
pub(super) struct Site<'s> {
    pub(super) figure: &'s str,
    file: &'s Path,
    spec: &'s PipelineSpec,
    pub(super) stage: &'s Spanned<StageSpec>,
}

impl Site<'_> {
    /// An error located at the stage's entry.
    pub(super) fn err(&self, msg: String) -> anyhow::Error {
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
