//! `repro figure --executor slurm --dry-run`: the stale stages of a build
//! grouped into the jobs the driver would submit, with their resources and
//! core-hours, nothing submitted.

use std::collections::BTreeMap;

use anyhow::Result;

use super::super::Workspace;
use super::super::exec::State;
use super::super::graph::Node;
use super::super::registry::Registry;
use super::super::spec::Catalogue;
use super::super::stage::Planned;
use super::super::store::Store;
use super::plan::{self, Resources};
use super::state;

/// What `--executor slurm` would submit now for figures `ids`: the stale stages
/// grouped into jobs, with resources, and the total core-hours. Stages behind a
/// stale one are planned with the bytes their inputs are expected to have.
pub fn dry_run(
    ws: &Workspace,
    reg: &Registry,
    ids: &[String],
    profile: &str,
    force: &[String],
) -> Result<String> {
    let cat = Catalogue::load(&ws.root)?;
    let (graph, st) = super::super::figure_status(ws, reg, ids, profile, force)?;
    let settings = plan::settings(&cat, &graph)?;
    let store = Store::open(&ws.store)?;
    let mut groups: BTreeMap<(String, String), Vec<(usize, Resources)>> = BTreeMap::new();
    let mut cached = 0;
    let planned = |n: &Node| reg.planned(&n.kind, &n.parsed);
    for (i, s) in &st {
        let node = &graph.nodes[*i];
        let key = match s {
            State::Cached { .. } => {
                cached += 1;
                continue;
            }
            _ => node.kind.clone(),
        };
        // Input sizes: cached inputs as stored; simulations to come from their
        // planned frames (x, y as f64 per disk); other stages' outputs are small.
        let bytes: u64 = node
            .inputs
            .iter()
            .map(|&j| {
                let d = match st.iter().find(|(k, _)| *k == j) {
                    Some((_, State::Cached { key })) => store.lookup(key),
                    _ => None,
                };
                match d {
                    Some(e) => store.entry_bytes(&e),
                    None => planned(&graph.nodes[j]).map_or(0, |p| p.output_bytes),
                }
            })
            .sum();
        let r = plan::resources(
            &node.kind,
            &node.params,
            planned(node).as_ref(),
            (bytes, node.inputs.len()),
            &settings[*i],
        );
        let s = serde_json::to_string(&settings[*i].sbatch_args())?;
        groups.entry((key, s)).or_default().push((*i, r));
    }
    let mut out = String::new();
    let (mut expected, mut limit, mut longest) = (0.0f64, 0.0, 0.0f64);
    let mut task_count = 0;
    for ((kind, sargs), members) in &groups {
        let mem = members.iter().map(|(_, r)| r.mem_mib).max().unwrap_or(0);
        let first = members[0].0;
        let resumable = planned(&graph.nodes[first]).is_some();
        // As submitted: short stages share a task.
        let res: Vec<Resources> = members.iter().map(|(_, r)| r.clone()).collect();
        let plan::JobTasks {
            tasks,
            task_of,
            time_min: time,
        } = plan::job_tasks(&res, &vec![1.0; res.len()], resumable, &settings[first]);
        let (time, links) = plan::chain(time, state::max_minutes(&settings[first]), resumable);
        task_count += tasks.len();
        // Each task of analyses starts once (it loads the binary and the store).
        if !resumable {
            expected += tasks.len() as f64 * plan::JOB_START_S / 3600.0;
        }
        // Slurm holds each task of an array to the array's limit.
        limit += (tasks.len() * links as usize) as f64 * time as f64 / 60.0;
        out += &format!(
            "job {kind}: {} stage(s) in {} task(s){}, 1 CPU, --mem={mem}M --time={} {}{}\n",
            members.len(),
            tasks.len(),
            if tasks.len() > 1 { " (array)" } else { "" },
            plan::time_limit(time),
            sargs,
            if links > 1 {
                format!(
                    " as a chain of {links} jobs (each after the one before, resuming from the last checkpoint)"
                )
            } else {
                String::new()
            }
        );
        for (m, (i, r)) in members.iter().enumerate() {
            let work = planned(&graph.nodes[*i]).map_or(String::new(), |p| {
                p.counts
                    .iter()
                    .take(2)
                    .map(|(name, v)| format!("{name} = {}, ", Planned::count_text(*v)))
                    .collect()
            });
            let cpu = if r.expected_s < 3600.0 {
                format!("{:.1} CPU s", r.expected_s)
            } else {
                format!("{:.2} core-h", r.expected_s / 3600.0)
            };
            out += &format!(
                "    {}  ({work}expected {cpu}, asks {} MiB, task {})\n",
                graph.nodes[*i].label(),
                r.mem_mib,
                task_of[m]
            );
            expected += r.expected_s / 3600.0 * r.cpus as f64;
            longest = longest.max(r.expected_s / 3600.0);
        }
    }
    let jobs: usize = groups.values().map(|m| m.len()).sum();
    out += &format!(
        "{jobs} stage(s) to run in {} job(s) of {task_count} task(s) (waves: stages are submitted when their inputs are done), {cached} cached\n\
         total: {expected:.2} core-hours expected, {limit:.2} core-hours requested (time limits, {:.1}x); longest stage {longest:.2} h\n",
        groups.len(),
        limit / expected.max(1e-9)
    );
    Ok(out)
}
