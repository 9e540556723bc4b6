//! A stage read from another figure (`from: FIGURE/STAGE`): planned as that
//! figure plans it, so that both figures share its nodes.

use anyhow::Result;

use super::stages::Site;
use super::{Planner, StageId};

impl Planner<'_> {
    /// The instances of another figure's stage (`from: FIGURE/STAGE`), planned
    /// as that figure plans them, so that both figures share the nodes.
    pub(super) fn reference(&mut self, site: Site, target: &str) -> Result<Vec<usize>> {
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
                "stage '{}' is `from: {target}`, another figure's stage as that figure declares it: it takes only `name`, `publish`, `describes` and `columns` (no `kind`, `map`, `gather`, `by`, `params`, `sweep` or `profiles`)",
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
}
