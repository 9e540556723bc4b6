//! What a stage is planned to cost in CPU seconds, from the work it plans
//! ([`Work`]: collisions, kicks of the drive, force kicks, stored frames) or, for
//! analyses, fits and plots, from the bytes it reads. One model for the Slurm
//! executor's time limits, the core-hour totals of `--dry-run`, the local
//! executor's estimate of the end, and `repro plan --check`, which compares it
//! with the CPU time every recorded stage took.

use anyhow::Result;

use super::exec::State;
use super::registry::Registry;
use super::stage::Work;
use super::store::Store;
use super::{Workspace, figure_status};

/// Measured driven collisions per CPU second at phi = 0.78 (docs/measurements.md,
/// `repro bench` at 10^4 disks and more, 2026-11-22 and 11-23, the lower end of
/// each range; 10^3: the recorded runs of N = 500-4000, 2026-11-26): (N, rate).
const SPEED: &[(f64, f64)] = &[
    (1e3, 1.3e6),
    (1e4, 1.0e6),
    (1e5, 0.75e6),
    (1e6, 0.46e6),
    (4e6, 0.40e6),
];

/// CPU seconds per kick of the drive and per force kick of an intruder, and per
/// disk of a stored frame (the Parquet encoding and write), fitted by least
/// squares to the recorded simulations of the ci profile (docs/measurements.md,
/// 2026-11-26): a kick draws random numbers and repredicts its disks' events; a
/// force kick repredicts the intruder's only.
pub const SECONDS_PER_DRIVE_KICK: f64 = 0.35e-6;
pub const SECONDS_PER_FORCE_KICK: f64 = 0.15e-6;
pub const SECONDS_PER_FRAME_DISK: f64 = 0.15e-6;

/// Collisions per CPU second at N disks: log-linear between the measured sizes,
/// the end values outside them.
pub fn collisions_per_second(n: f64) -> f64 {
    if n <= SPEED[0].0 {
        return SPEED[0].1;
    }
    for w in SPEED.windows(2) {
        let ((n0, r0), (n1, r1)) = (w[0], w[1]);
        if n <= n1 {
            let f = (n / n0).ln() / (n1 / n0).ln();
            return r0 + f * (r1 - r0);
        }
    }
    SPEED[SPEED.len() - 1].1
}

/// How much more a collision of a driven run costs at packing fraction `phi`
/// than below 0.805: near jamming a collision comes with more cell crossings and
/// stale events. Recorded runs of the small profile (2026-11-26): driven runs at
/// phi = 0.84 (N = 2000) take 2.0 us per collision against 0.8 us at 0.78-0.805;
/// elastic runs without a drive stay at 0.6-0.8 us up to 0.82.
pub fn density_factor(phi: f64) -> f64 {
    1.0 + 1.4 * ((phi - 0.805) / 0.035).clamp(0.0, 1.0)
}

/// Planned CPU seconds of a simulation doing `w`.
pub fn simulation_seconds(w: &Work) -> f64 {
    let n = w.n as f64;
    let dense = if w.drive_kicks > 0.0 {
        density_factor(w.phi)
    } else {
        1.0
    };
    w.collisions * dense / collisions_per_second(n)
        + w.drive_kicks * SECONDS_PER_DRIVE_KICK
        + w.force_kicks * SECONDS_PER_FORCE_KICK
        + n * w.frames as f64 * SECONDS_PER_FRAME_DISK
}

/// Analyses, fits and plots: time from the bytes they read (their work is not
/// modelled per kind). Measured on the ci profile (2026-11-24,
/// docs/measurements.md): the slowest per input byte was `chi4_peaks` at 4.4 MB/s
/// (tau_alpha 23-69 MB/s); half that speed, plus 0.2 s (the median stage of a
/// ci build).
pub const ANALYSIS_BYTES_PER_SECOND: f64 = 2e6;
pub const ANALYSIS_SECONDS: f64 = 0.2;

/// Planned CPU seconds of a stage: a simulation from its work, anything else from
/// the bytes it reads.
pub fn seconds(work: Option<&Work>, input_bytes: u64) -> f64 {
    match work {
        Some(w) => simulation_seconds(w),
        None => ANALYSIS_SECONDS + input_bytes as f64 / ANALYSIS_BYTES_PER_SECOND,
    }
}

/// Bytes a simulation's trajectory is planned to hold: x and y (f64) per disk
/// and frame (what a stage reading it reads, before it exists).
pub fn trajectory_bytes(w: &Work) -> u64 {
    w.n * w.frames * 16
}

/// Planned CPU seconds of every node of `graph`, an input not built yet counted
/// at its planned trajectory size: what the progress line's estimate of the end
/// starts from.
pub fn node_seconds(graph: &super::Graph, reg: &Registry) -> Vec<f64> {
    let work: Vec<Option<Work>> = graph
        .nodes
        .iter()
        .map(|n| reg.work(&n.kind, &n.params))
        .collect();
    graph
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let bytes = n
                .inputs
                .iter()
                .filter_map(|&j| work[j].as_ref().map(trajectory_bytes))
                .sum();
            seconds(work[i].as_ref(), bytes)
        })
        .collect()
}

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
    fn speed_interpolates_between_measured_sizes() {
        assert_eq!(collisions_per_second(500.0), 1.3e6);
        assert_eq!(collisions_per_second(1e4), 1.0e6);
        assert_eq!(collisions_per_second(1e6), 0.46e6);
        assert_eq!(collisions_per_second(1e7), 0.40e6);
        let mid = collisions_per_second(10f64.powf(5.5));
        assert!((mid - 0.605e6).abs() < 1.0, "{mid}");
    }

    #[test]
    fn every_kind_of_work_adds_its_measured_cost() {
        let w = Work {
            n: 1_000_000,
            phi: 0.78,
            collisions: 0.46e6 * 3600.0,
            drive_kicks: 0.0,
            force_kicks: 0.0,
            frames: 0,
        };
        assert!((simulation_seconds(&w) - 3600.0).abs() < 1e-6);
        let more = Work {
            drive_kicks: 1e6,
            force_kicks: 1e6,
            frames: 10,
            ..w
        };
        let extra =
            1e6 * (SECONDS_PER_DRIVE_KICK + SECONDS_PER_FORCE_KICK) + 1e7 * SECONDS_PER_FRAME_DISK;
        assert!((simulation_seconds(&more) - 3600.0 - extra).abs() < 1e-6);
        assert_eq!(seconds(None, 2_000_000), 1.2);
        // Near jamming a driven run's collision costs more; an undriven one's not.
        let dense = Work { phi: 0.84, ..w };
        assert!((simulation_seconds(&dense) - 3600.0).abs() < 1e-6);
        let driven = Work {
            drive_kicks: 1e6,
            ..dense
        };
        let kicks = 1e6 * SECONDS_PER_DRIVE_KICK;
        assert!((simulation_seconds(&driven) - 2.4 * 3600.0 - kicks).abs() < 1e-6);
    }

    #[test]
    fn a_configuration_is_its_label_without_the_replica() {
        assert_eq!(configuration("eps09[phi=0.6,replica=2]"), "eps09[phi=0.6]");
        assert_eq!(configuration("eps09[replica=0]"), "eps09");
        assert_eq!(configuration("fig4/tau[phi=0.6]"), "fig4/tau[phi=0.6]");
        assert_eq!(configuration("fig4/taufit"), "fig4/taufit");
    }
}
