//! A pipeline's stages checked by name and ordered so that each comes after
//! the stages it reads.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use anyhow::Result;
use serde_saphyr::Spanned;

use super::super::spec::{Catalogue, PipelineSpec, StageSpec};
use super::err;

/// The stages of a pipeline by name; an error for a name used twice or also
/// an experiment's.
pub(super) fn stage_names<'s>(
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

/// Order the stages (all, or `root` and what it reads) so each comes after
/// what it reads; detect unknown names and cycles.
pub(super) fn topological<'s>(
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
