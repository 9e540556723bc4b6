//! The analysed window of an experiment's runs (`window: FIGURE/STAGE` in its
//! YAML): a stage of a kind that takes it gets that stage's table as one more
//! input, planned as its figure plans it. The figure that chooses the window
//! measures the whole runs and reads none.

use anyhow::Result;

use super::super::spec::SpecError;
use super::super::stage::Holds;
use super::Planner;
use super::stages::Site;

impl Planner<'_> {
    /// The window nodes of the experiments whose runs are among `inputs`, for
    /// a stage declared at `site` in a figure other than the window's.
    pub(super) fn windows(&mut self, site: Site, inputs: &[usize]) -> Result<Vec<usize>> {
        let mut experiments: Vec<String> = inputs
            .iter()
            .flat_map(|&n| self.graph.nodes[n].ids.iter())
            .filter(|id| id.figure.is_none() && self.cat.experiments.contains_key(&id.stage))
            .map(|id| id.stage.clone())
            .collect();
        experiments.sort();
        experiments.dedup();
        let mut out = Vec::new();
        for name in experiments {
            let (file, spec) = &self.cat.experiments[&name];
            let Some(target) = &spec.window else {
                continue;
            };
            let bad = |msg: String| -> anyhow::Error { SpecError::at(file, target, msg).into() };
            let Some((fig, stage)) = target.value.split_once('/') else {
                return Err(bad(format!(
                    "experiment '{name}': `window` wants FIGURE/STAGE (e.g. stationarity/window); got '{}'",
                    target.value
                )));
            };
            if fig == site.figure {
                continue;
            }
            if let Some(&n) = self.windows.get(&target.value) {
                out.push(n);
                continue;
            }
            if self.open.iter().any(|f| f == fig) {
                return Err(bad(format!(
                    "experiment '{name}': `window: {}` is planned from figure '{}', which that window's own stages need (a cycle: {} -> {fig}); the window's figure must not read a windowed analysis of another figure",
                    target.value,
                    site.figure,
                    self.open.join(" -> ")
                )));
            }
            let (pfile, pspec) = self.cat.pipeline(fig).map_err(|e| {
                bad(format!(
                    "experiment '{name}': `window: {}`: {e}",
                    target.value
                ))
            })?;
            if !pspec.stages.iter().any(|s| s.value.name == stage) {
                return Err(bad(format!(
                    "experiment '{name}': `window: {}`: figure '{fig}' ({}) has no stage '{stage}'",
                    target.value,
                    pfile.display()
                )));
            }
            self.open.push(fig.to_string());
            let planned = self.stages(fig, pfile, pspec, Some(stage));
            self.open.pop();
            let nodes = planned?.instances.remove(stage).unwrap_or_default();
            for &n in &nodes {
                let kind = &self.graph.nodes[n].kind;
                if self.reg.get(kind)?.holds() != Holds::Window {
                    return Err(bad(format!(
                        "experiment '{name}': `window: {}` is a stage of kind '{kind}', which holds no window; give a stage of kind `window`",
                        target.value
                    )));
                }
            }
            let [n] = nodes[..] else {
                return Err(bad(format!(
                    "experiment '{name}': `window: {}` is {} stages; it must be one table over the state points",
                    target.value,
                    nodes.len()
                )));
            };
            self.windows.insert(target.value.clone(), n);
            out.push(n);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::super::plan;
    use crate::pipeline::spec::{Catalogue, parse};
    use crate::pipeline::{Graph, Registry};

    const EXP: &str = "description: e\nkind: toy_simulate\nseed: 5\nprofiles:\n  ci:\n    grid:\n      phi: [0.7, 0.8]\n    replicas: 2\n    params: {n: 4}\n";
    /// The figure that chooses the window, with an analysis of its own.
    const CHOOSER: &str = "description: w\nstages:\n  - {name: own, kind: toy_analyse, map: e, params: {a: 1.0}}\n  - {name: win, kind: toy_window, gather: [e]}\n";
    /// A figure analysing the runs, and fitting the analysis.
    const USER: &str = "description: p\nstages:\n  - {name: s, kind: toy_analyse, map: e, params: {a: 1.0}}\n  - {name: f, kind: toy_fit, gather: [s], params: {column: mean}}\n";

    fn planned(window: &str) -> anyhow::Result<Graph> {
        let mut c = Catalogue::default();
        let f = PathBuf::from("experiments/e.yaml");
        let text = format!("{EXP}{window}");
        c.experiments
            .insert("e".into(), (f.clone(), parse(&f, &text).unwrap()));
        for (id, text) in [("w", CHOOSER), ("p", USER)] {
            let f = PathBuf::from(format!("pipelines/{id}.yaml"));
            c.pipelines
                .insert(id.into(), (f.clone(), parse(&f, text).unwrap()));
        }
        let mut r = Registry::framework();
        crate::pipeline::toy::register(&mut r);
        plan(&c, &["p".into(), "w".into()], "ci", &r)
    }

    fn reads_window(g: &Graph, figure: &str, stage: &str) -> Vec<bool> {
        g.nodes
            .iter()
            .filter(|n| {
                n.ids
                    .iter()
                    .any(|id| id.figure.as_deref() == Some(figure) && id.stage == stage)
            })
            .map(|n| n.inputs.iter().any(|&i| g.nodes[i].kind == "toy_window"))
            .collect()
    }

    /// Every analysis of the runs outside the chooser's figure reads the
    /// window, once; the chooser's own analyses and the fits do not; without
    /// `window` nothing does.
    #[test]
    fn an_experiments_window_reaches_every_analysis_of_its_runs_but_its_own_figures() {
        let g = planned("window: w/win\n").unwrap();
        assert_eq!(reads_window(&g, "p", "s"), vec![true; 4]);
        assert_eq!(reads_window(&g, "w", "own"), vec![false; 4]);
        assert_eq!(reads_window(&g, "p", "f"), vec![false]);
        assert_eq!(g.nodes.iter().filter(|n| n.kind == "toy_window").count(), 1);
        let g = planned("").unwrap();
        assert_eq!(reads_window(&g, "p", "s"), vec![false; 4]);
    }

    /// A window that is no `FIGURE/STAGE`, names no stage, or names a stage
    /// holding no window is an error naming the experiment's file and what to give.
    #[test]
    fn a_bad_window_is_an_error_naming_what_to_give() {
        for (w, says) in [
            ("window: win\n", "FIGURE/STAGE"),
            ("window: w/nothing\n", "has no stage 'nothing'"),
            ("window: w/own\n", "holds no window"),
        ] {
            let e = format!("{:#}", planned(w).unwrap_err());
            assert!(
                e.contains(says) && e.contains("experiments/e.yaml"),
                "{w}: {e}"
            );
        }
    }
}
