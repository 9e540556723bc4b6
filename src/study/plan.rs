//! `repro plan`: the planned cost of a build, per simulation configuration, from
//! the simulate kind's cost model (`stages::simulate_cost`, through
//! [`crate::pipeline::cost`]), and with `--check` beside the CPU
//! time its built replicas took in the store.

use anyhow::{Context, Result};

use std::collections::BTreeMap;

use crate::pipeline::calibration::{Calibration, samples};
use crate::pipeline::cost::{built_bytes, node_seconds};
use crate::pipeline::{Graph, Planned, Registry, State, Store, Workspace, needed_nodes};

/// What `repro plan --check` judges: a recorded run off by more than `factor`
/// either way, among runs of at least `min_seconds` planned or measured.
#[derive(Debug, Clone, Copy)]
pub struct Check {
    pub factor: f64,
    pub min_seconds: f64,
}

/// The printed plan and, with a check, how many runs it judged and how many it
/// found outside the factor.
#[derive(Debug, Clone, Default)]
pub struct PlanReport {
    pub text: String,
    pub judged: usize,
    pub outside: usize,
}

/// The simulations of one configuration (replicas differ only by their seed,
/// so they share one plan) with the CPU times of those built.
struct Row {
    label: String,
    work: Planned,
    planned: f64,
    replicas: usize,
    measured: Vec<f64>,
}

/// The stages of one kind that is not a simulation: how many, their planned
/// CPU s, and (planned, measured) of those built.
#[derive(Default)]
struct KindRow {
    stages: usize,
    planned: f64,
    built: Vec<(f64, f64)>,
}

/// A simulation's label without its replica (`eps09[phi=0.6,replica=2]` ->
/// `eps09[phi=0.6]`): the configuration it is one sample of.
pub fn configuration(label: &str) -> String {
    let Some((head, rest)) = label.split_once('[') else {
        return label.to_string();
    };
    let inner = rest.trim_end_matches(']');
    let kept: Vec<&str> = inner
        .split(',')
        .filter(|p| !p.starts_with("replica="))
        .collect();
    if kept.is_empty() {
        head.to_string()
    } else {
        format!("{head}[{}]", kept.join(","))
    }
}

/// The plan of the simulations of a planned `graph` (figures of the catalogue,
/// or of a what-if changed in memory):
/// a line per configuration (its work and planned CPU s per run; with `check`,
/// the mean and largest recorded CPU s of its built replicas and the ratio of
/// the mean to the plan), sorted by planned cost, then the totals. A plan
/// predicts a configuration's expected cost, so `check` judges the mean over
/// replicas (one replica can be several times another: at F = 3162, eta = 0.6
/// two replicas of paper I's intruder took 1.8 and 9.5 CPU s); a
/// configuration is judged when its plan or mean reaches `check.min_seconds`.
pub fn plan(
    ws: &Workspace,
    reg: &Registry,
    graph: &Graph,
    check: Option<&Check>,
) -> Result<PlanReport> {
    let stages = planned_stages(ws, reg, graph)?;
    let mut r = PlanReport::default();
    let simulations = simulation_lines(&stages.configurations, check, &mut r);
    let (other_stages, other_planned) = other_lines(&stages.others, check, &mut r);
    r.text += &format!(
        "{other_stages} other stage(s): {:.2} core-hours planned; the build {:.2} core-hours in all\n",
        other_planned / 3600.0,
        (simulations + other_planned) / 3600.0
    );
    if let Some(c) = check {
        r.text += &format!(
            "judged in all (simulation configurations and other stages >= {} CPU s): {}, outside a factor {}: {} ({:.1}% inside)\n",
            c.min_seconds,
            r.judged,
            c.factor,
            r.outside,
            100.0 * (r.judged - r.outside) as f64 / r.judged.max(1) as f64
        );
    }
    Ok(r)
}

/// The stages of a graph as the plan lists them: the simulations by
/// configuration, most expensive first, and the other stages by kind.
struct PlannedStages {
    configurations: Vec<Row>,
    others: BTreeMap<String, KindRow>,
}

/// The planned CPU s of every needed stage of `graph` and the recorded CPU s
/// of those built in the store of `ws`.
fn planned_stages(ws: &Workspace, reg: &Registry, graph: &Graph) -> Result<PlannedStages> {
    let store = Store::open(&ws.store)?;
    let st = crate::pipeline::exec::status(graph, &needed_nodes(graph), reg, &store, &[]);
    let cached = |s: &State| match s {
        State::Cached { key } => Some(key.clone()),
        _ => None,
    };
    let built = built_bytes(
        &store,
        st.iter().filter_map(|(i, s)| match s {
            State::Cached { key } => Some((*i, key.as_str())),
            _ => None,
        }),
    );
    let planned = node_seconds(graph, reg, &built);
    let mut rows: Vec<Row> = Vec::new();
    let mut others: BTreeMap<String, KindRow> = BTreeMap::new();
    let mut at = std::collections::HashMap::new();
    for (i, s) in &st {
        let node = &graph.nodes[*i];
        let Some(work) = reg.planned(&node.kind, &node.parsed) else {
            let k = others.entry(node.kind.clone()).or_default();
            k.stages += 1;
            k.planned += planned[*i];
            if let Some(cpu) = cached(s).and_then(|key| store.lookup(&key)?.cpu_s) {
                k.built.push((planned[*i], cpu));
            }
            continue;
        };
        let measured = cached(s).and_then(|key| store.lookup(&key)?.cpu_s);
        let label = configuration(node.label());
        let k = *at.entry(label.clone()).or_insert_with(|| {
            rows.push(Row {
                label,
                planned: work.cpu_seconds,
                work,
                replicas: 0,
                measured: Vec::new(),
            });
            rows.len() - 1
        });
        rows[k].replicas += 1;
        rows[k].measured.extend(measured);
    }
    rows.sort_by(|a, b| b.planned.total_cmp(&a.planned));
    Ok(PlannedStages {
        configurations: rows,
        others,
    })
}

/// The simulations' table of the plan, written to `r.text`: a line per
/// configuration, then the totals and, with `check`, what was recorded and
/// judged (counted in `r`). Returns the CPU s planned for all of them.
fn simulation_lines(rows: &[Row], check: Option<&Check>, r: &mut PlanReport) -> f64 {
    // The counts the cost model gives (N, collisions, kicks, force kicks).
    let counted: Vec<&str> = rows
        .first()
        .map(|r| r.work.counts.iter().map(|(name, _)| *name).collect())
        .unwrap_or_default();
    let mut out = format!(
        "{:<56} {:>4} {}{:>10}{}\n",
        "simulation (per run)",
        "runs",
        counted
            .iter()
            .map(|c| format!("{c:>10} "))
            .collect::<String>(),
        "planned s",
        if check.is_some() {
            "  built  mean s   max s  mean/plan"
        } else {
            ""
        }
    );
    let (mut planned_all, mut measured_all, mut planned_built) = (0.0, 0.0, 0.0);
    let (mut runs, mut built) = (0, 0);
    let mut worst: Option<(f64, &str)> = None;
    for row in rows {
        planned_all += row.planned * row.replicas as f64;
        runs += row.replicas;
        let counts: String = row
            .work
            .counts
            .iter()
            .map(|(_, v)| format!("{:>10} ", Planned::count_text(*v)))
            .collect();
        let mut line = format!(
            "{:<56} {:>4} {counts}{:>10.1}",
            row.label, row.replicas, row.planned
        );
        if let Some(c) = check
            && !row.measured.is_empty()
        {
            let k = row.measured.len();
            built += k;
            let sum: f64 = row.measured.iter().sum();
            measured_all += sum;
            planned_built += row.planned * k as f64;
            let mean = sum / k as f64;
            let max = row.measured.iter().copied().fold(0.0, f64::max);
            let ratio = mean / row.planned.max(1e-9);
            line += &format!("  {k:>5} {mean:>7.1} {max:>7.1} {ratio:>10.2}");
            if row.planned.max(mean) >= c.min_seconds {
                r.judged += 1;
                let off = ratio.max(1.0 / ratio);
                if off > c.factor {
                    r.outside += 1;
                    line += "  OUTSIDE";
                }
                if worst.is_none_or(|(w, _)| off > w) {
                    worst = Some((off, &row.label));
                }
            }
        } else if check.is_some() {
            line += "  (not built)";
        }
        out += &line;
        out += "\n";
    }
    let longest = rows.first().map_or(0.0, |r| r.planned);
    out += &format!(
        "{runs} simulation(s) in {} configuration(s): {:.2} core-hours planned, the longest {:.1} CPU min\n",
        rows.len(),
        planned_all / 3600.0,
        longest / 60.0
    );
    if let Some(c) = check {
        out += &format!(
            "recorded: {built} built, {:.2} core-hours measured against {:.2} planned; \
             {} configuration(s) judged (>= {} CPU s), {} outside a factor {}{}\n",
            measured_all / 3600.0,
            planned_built / 3600.0,
            r.judged,
            c.min_seconds,
            r.outside,
            c.factor,
            worst.map_or(String::new(), |(w, l)| format!("; the worst {w:.2}x ({l})"))
        );
    }
    r.text += &out;
    planned_all
}

/// The other stages' table of the plan, written to `r.text`: a line per kind,
/// most expensive first; with `check`, its built stages judged one by one, as
/// simulations are (their Slurm time limits come from the same plan), and
/// counted in `r`. Returns how many stages there are and their planned CPU s.
fn other_lines(
    others: &BTreeMap<String, KindRow>,
    check: Option<&Check>,
    r: &mut PlanReport,
) -> (usize, f64) {
    let mut out = format!(
        "\n{:<24} {:>6} {:>10}{}\n",
        "other stages (per kind)",
        "stages",
        "planned s",
        if check.is_some() {
            "  built  measured s  planned s (built)  judged  outside"
        } else {
            ""
        }
    );
    let (mut other_planned, mut other_stages) = (0.0, 0);
    let mut kinds: Vec<(&String, &KindRow)> = others.iter().collect();
    kinds.sort_by(|a, b| b.1.planned.total_cmp(&a.1.planned));
    for (kind, k) in kinds {
        other_planned += k.planned;
        other_stages += k.stages;
        let mut line = format!("{kind:<24} {:>6} {:>10.1}", k.stages, k.planned);
        if let Some(c) = check {
            let (mut judged, mut outside) = (0, 0);
            for &(p, m) in &k.built {
                if p.max(m) >= c.min_seconds {
                    judged += 1;
                    let ratio = m.max(1e-3) / p.max(1e-3);
                    outside += usize::from(ratio.max(1.0 / ratio) > c.factor);
                }
            }
            r.judged += judged;
            r.outside += outside;
            // (0.0 + : an empty sum of f64 is -0.0.)
            let measured: f64 = 0.0 + k.built.iter().map(|b| b.1).sum::<f64>();
            let planned_built: f64 = 0.0 + k.built.iter().map(|b| b.0).sum::<f64>();
            line += &format!(
                "  {:>5} {measured:>10.1} {planned_built:>18.1} {judged:>7} {outside:>8}",
                k.built.len()
            );
        }
        out += &line;
        out += "\n";
    }
    r.text += &out;
    (other_stages, other_planned)
}

/// Fit the cost of every kind that is not a simulation to the stages recorded
/// in the store of `ws` ([`Calibration::fit`]) and write it to `path` as JSON;
/// returns a summary per kind: stages, alpha, and how many of the stages of at
/// least `min_seconds` the fit puts within `factor` of their recorded time.
pub fn calibrate(
    ws: &Workspace,
    reg: &Registry,
    path: &std::path::Path,
    factor: f64,
    min_seconds: f64,
) -> Result<String> {
    let store = Store::open(&ws.store)?;
    let samples = samples(&store, |kind, params| {
        reg.planned_raw(kind, params).is_some()
    });
    if samples.is_empty() {
        anyhow::bail!(
            "no recorded stage to calibrate on in {} (build some figures first)",
            ws.store.display()
        );
    }
    let cal = Calibration::fit(
        &samples,
        format!(
            "{} recorded stages, `repro calibrate` on {}",
            samples.len(),
            super::report::utc(std::time::SystemTime::now())
        ),
    );
    let text = serde_json::to_string_pretty(&cal)? + "\n";
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
    let mut out = format!(
        "{:<24} {:>7} {:>6} {:>6} {:>8} {:>8} {:>11} {:>11}\n",
        "kind", "stages", "alpha", "beta", "judged", "inside", "measured s", "planned s"
    );
    let (mut judged_all, mut inside_all) = (0, 0);
    for (kind, k) in &cal.kinds {
        let (mut judged, mut inside, mut m, mut p) = (0, 0, 0.0, 0.0);
        for s in samples.iter().filter(|s| &s.kind == kind) {
            let plan = k.seconds(&s.signature, s.input_bytes, s.inputs);
            m += s.cpu_s;
            p += plan;
            if plan.max(s.cpu_s) >= min_seconds {
                judged += 1;
                let ratio = s.cpu_s.max(1e-3) / plan;
                inside += usize::from(ratio.max(1.0 / ratio) <= factor);
            }
        }
        judged_all += judged;
        inside_all += inside;
        out += &format!(
            "{kind:<24} {:>7} {:>6.2} {:>6.2} {judged:>8} {inside:>8} {m:>11.1} {p:>11.1}\n",
            k.stages, k.alpha, k.beta
        );
    }
    out += &format!(
        "{} stage(s) of {} kind(s) fitted; of the {judged_all} of >= {min_seconds} CPU s, {inside_all} within a factor {factor}; written to {}\n",
        samples.len(),
        cal.kinds.len(),
        path.display()
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_configuration_is_its_label_without_the_replica() {
        assert_eq!(configuration("eps09[phi=0.6,replica=2]"), "eps09[phi=0.6]");
        assert_eq!(configuration("eps09[replica=0]"), "eps09");
        assert_eq!(configuration("fig4/tau[phi=0.6]"), "fig4/tau[phi=0.6]");
        assert_eq!(configuration("fig4/taufit"), "fig4/taufit");
    }
}
