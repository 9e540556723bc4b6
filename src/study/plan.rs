//! `repro plan`: the planned cost of a build, per simulation configuration, from
//! the cost model ([`crate::pipeline::cost`]), and with `--check` beside the CPU
//! time its built replicas took in the store.

use anyhow::Result;

use crate::pipeline::cost::simulation_seconds;
use crate::pipeline::stage::Work;
use crate::pipeline::{Registry, State, Store, Workspace, figure_status};

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
    work: Work,
    planned: f64,
    replicas: usize,
    measured: Vec<f64>,
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

/// The plan of the simulations of `ids` (all figures if empty) at `profile`:
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
    ids: &[String],
    profile: &str,
    check: Option<&Check>,
) -> Result<PlanReport> {
    let (graph, st) = figure_status(ws, reg, ids, profile, &[])?;
    let store = Store::open(&ws.store)?;
    let mut rows: Vec<Row> = Vec::new();
    let mut at = std::collections::HashMap::new();
    for (i, s) in &st {
        let node = &graph.nodes[*i];
        let Some(work) = reg.work(&node.kind, &node.params) else {
            continue;
        };
        let measured = match s {
            State::Cached { key } => store.lookup(key).and_then(|e| e.cpu_s),
            _ => None,
        };
        let label = configuration(node.label());
        let k = *at.entry(label.clone()).or_insert_with(|| {
            rows.push(Row {
                label,
                planned: simulation_seconds(&work),
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
    let mut r = PlanReport::default();
    let mut out = format!(
        "{:<56} {:>4} {:>6} {:>10} {:>10} {:>10} {:>10}{}\n",
        "simulation (per run)",
        "runs",
        "N",
        "collisions",
        "kicks",
        "force kicks",
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
    for row in &rows {
        planned_all += row.planned * row.replicas as f64;
        runs += row.replicas;
        let w = &row.work;
        let mut line = format!(
            "{:<56} {:>4} {:>6} {:>10.3e} {:>10.3e} {:>10.3e} {:>10.1}",
            row.label, row.replicas, w.n, w.collisions, w.drive_kicks, w.force_kicks, row.planned
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
    r.text = out;
    Ok(r)
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
