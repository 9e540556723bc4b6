//! Resources of a Slurm job from the planned cost: memory from a long stage's
//! cost model (a simulation's bytes per disk times N) or from the bytes an
//! analysis reads, the time limit from the planned CPU seconds
//! ([`cost`](super::super::cost)), one CPU per stage; each times a margin from the profile's
//! `slurm:` settings.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::super::cost;
use super::super::graph::Graph;
use super::super::spec::{Catalogue, SlurmSpec, SpecError};
use super::super::stage::Planned;

/// Process baseline (binary, allocator, Parquet writer), MiB.
pub const BASE_MIB: f64 = 64.0;

/// Settings of one job: where it goes and the margins on its resources.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    pub partition: Option<String>,
    pub account: Option<String>,
    pub qos: Option<String>,
    pub extra: Vec<String>,
    pub mem_margin: f64,
    pub time_margin: f64,
    /// The longest time limit a job may ask, minutes (`None`: the partition's).
    pub max_time_min: Option<u64>,
    /// Planned CPU seconds a task is filled up to with short stages
    /// (`None`: [`Settings::pack_seconds`]'s default).
    pub pack_s: Option<f64>,
}

pub const DEFAULT_MEM_MARGIN: f64 = 1.5;
/// The time limit over the plan. The plans of every kind are within a factor
/// 2 of the recorded CPU time for 98% of the stages (`repro plan --check`); a
/// stage that runs out of time is resubmitted with twice the limit (a
/// simulation resumes from its checkpoint), so the margin need not cover the
/// last few percent, and 2.5 keeps the requested time under 3x the plan.
pub const DEFAULT_TIME_MARGIN: f64 = 2.5;

impl Default for Settings {
    fn default() -> Self {
        Settings {
            partition: None,
            account: None,
            qos: None,
            extra: Vec::new(),
            mem_margin: DEFAULT_MEM_MARGIN,
            time_margin: DEFAULT_TIME_MARGIN,
            max_time_min: None,
            pack_s: None,
        }
    }
}

impl Settings {
    /// Planned CPU seconds a task of a job is filled up to with short stages:
    /// by default what fits under Slurm's two-minute floor at the time margin
    /// after the start-up ([`JOB_START_S`]), 38 s at the margin 2.5.
    pub fn pack_seconds(&self) -> f64 {
        self.pack_s
            .unwrap_or(((2.0 * 60.0) / self.time_margin - JOB_START_S).max(0.0))
    }

    /// The settings of a `slurm:` block; a margin below 1 (or not finite) is an
    /// error at its line in `file`.
    pub fn from_spec(file: &Path, s: &SlurmSpec) -> Result<Settings, SpecError> {
        let margin = |m: &Option<serde_saphyr::Spanned<f64>>, name: &str, default: f64| match m {
            None => Ok(default),
            Some(v) if v.value.is_finite() && v.value >= 1.0 => Ok(v.value),
            Some(v) => Err(SpecError::at(
                file,
                v,
                format!(
                    "slurm.{name} = {} must be a number >= 1 (it multiplies the planned resources)",
                    v.value
                ),
            )),
        };
        Ok(Settings {
            partition: s.partition.clone(),
            account: s.account.clone(),
            qos: s.qos.clone(),
            extra: s.extra.clone(),
            mem_margin: margin(&s.mem_margin, "mem_margin", DEFAULT_MEM_MARGIN)?,
            time_margin: margin(&s.time_margin, "time_margin", DEFAULT_TIME_MARGIN)?,
            pack_s: match &s.pack_seconds {
                None => None,
                Some(v) if v.value.is_finite() && v.value >= 0.0 => Some(v.value),
                Some(v) => {
                    return Err(SpecError::at(
                        file,
                        v,
                        format!(
                            "slurm.pack_seconds = {} must be a number >= 0 (planned CPU seconds a task is filled up to; 0: one stage per task)",
                            v.value
                        ),
                    ));
                }
            },
            max_time_min: match &s.max_time {
                None => None,
                Some(v) => match minutes(&v.value) {
                    Some(Some(m)) if m > 0 => Some(m),
                    _ => {
                        return Err(SpecError::at(
                            file,
                            v,
                            format!(
                                "slurm.max_time = '{}' is not a finite Slurm time limit (MM, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS)",
                                v.value
                            ),
                        ));
                    }
                },
            },
        })
    }

    /// sbatch options for these settings.
    pub fn sbatch_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        for (flag, val) in [
            ("--partition", &self.partition),
            ("--account", &self.account),
            ("--qos", &self.qos),
        ] {
            if let Some(x) = val {
                v.push(format!("{flag}={x}"));
            }
        }
        v.extend(self.extra.iter().cloned());
        v
    }
}

/// The settings of every node of `graph`: a simulation takes its experiment
/// profile's `slurm:` block; a pipeline stage that of the first experiment it
/// reads (through its inputs); defaults where there is none. Bad values are
/// located errors.
pub fn settings(cat: &Catalogue, graph: &Graph) -> Result<Vec<Settings>, SpecError> {
    let mut by_exp = std::collections::BTreeMap::new();
    for (name, (file, spec)) in &cat.experiments {
        if let Some(p) = spec.profiles.get(&graph.profile)
            && let Some(s) = &p.value.slurm
        {
            by_exp.insert(name.clone(), Settings::from_spec(file, &s.value)?);
        }
    }
    // Nodes are in topological order: inputs come first.
    let mut out: Vec<Option<Settings>> = Vec::with_capacity(graph.nodes.len());
    for node in &graph.nodes {
        let own = node
            .ids
            .iter()
            .find(|id| id.figure.is_none())
            .and_then(|id| by_exp.get(&id.stage).cloned());
        let s = own.or_else(|| node.inputs.iter().find_map(|&j| out[j].clone()));
        out.push(s);
    }
    Ok(out.into_iter().map(Option::unwrap_or_default).collect())
}

/// What one job asks of Slurm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Resources {
    pub cpus: u32,
    pub mem_mib: u64,
    pub time_min: u64,
    /// Expected CPU seconds (without margin), for the core-hour estimate.
    pub expected_s: f64,
}

/// Analyses, fits and plots: memory from the bytes they read. Measured on the
/// ci profile (2026-11-24, docs/measurements.md): `aging` peaked at 25 MB of RSS
/// for 2.5 MB of input over an 11 MB process baseline (5.6 bytes per input
/// byte); 6 bytes per input byte over the baseline [`BASE_MIB`].
pub const ANALYSIS_MEM_PER_INPUT_BYTE: f64 = 6.0;

/// Start-up of a job that runs an analysis, seconds (on a busy node).
pub const JOB_START_S: f64 = 10.0;

/// Resources of a stage with a `planned` cost (simulations) or of `kind` with
/// `params` reading `input_bytes` from `inputs` inputs (everything else).
pub fn resources(
    kind: &str,
    params: &serde_json::Value,
    planned: Option<&Planned>,
    (input_bytes, inputs): (u64, usize),
    s: &Settings,
) -> Resources {
    let mem_bytes = match planned {
        Some(p) => p.memory_bytes,
        None => input_bytes as f64 * ANALYSIS_MEM_PER_INPUT_BYTE,
    };
    let secs = cost::seconds(planned, kind, params, input_bytes, inputs);
    let mem_mib = (BASE_MIB + mem_bytes / (1024.0 * 1024.0)) * s.mem_margin;
    let mut r = Resources {
        cpus: 1,
        mem_mib: mem_mib.ceil() as u64,
        time_min: 0,
        expected_s: secs,
    };
    r.time_min = task_minutes(&[&r], planned.is_some(), s);
    r
}

/// Stages of one job (their planned CPU seconds `expected`) packed into
/// tasks, each run by one array task one stage after the other: first fit in
/// decreasing order into tasks of `fill_s` planned seconds, or of the longest
/// stage if that is longer (a task never asks more than the longest stage
/// alone would). Slurm's time limits count whole minutes, two at least, so
/// one stage of a few seconds per task would ask tens of times its plan.
/// Returns the tasks as indices into `expected`, each in increasing order,
/// the tasks ordered by their first stage.
pub fn pack(expected: &[f64], fill_s: f64) -> Vec<Vec<usize>> {
    let longest = expected.iter().copied().fold(0.0, f64::max);
    let cap = fill_s.max(longest);
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[b].total_cmp(&expected[a]).then(a.cmp(&b)));
    let mut tasks: Vec<(f64, Vec<usize>)> = Vec::new();
    for i in order {
        match tasks
            .iter_mut()
            .find(|(sum, t)| fill_s > 0.0 && !t.is_empty() && sum + expected[i] <= cap)
        {
            Some((sum, t)) => {
                *sum += expected[i];
                t.push(i);
            }
            None => tasks.push((expected[i], vec![i])),
        }
    }
    let mut out: Vec<Vec<usize>> = tasks
        .into_iter()
        .map(|(_, mut t)| {
            t.sort_unstable();
            t
        })
        .collect();
    out.sort();
    out
}

/// The time limit of a task running stages of `resources` one after the
/// other, minutes: their planned CPU seconds, plus one start-up for a task of
/// analyses (it loads the binary and the store on its node), times the
/// margin; two at least (Slurm counts minutes; start-up on a busy node).
pub fn task_minutes(resources: &[&Resources], simulations: bool, s: &Settings) -> u64 {
    (task_seconds(resources, simulations) * s.time_margin / 60.0)
        .ceil()
        .max(2.0) as u64
}

/// The tasks of one job of stages with `resources` and the time limit the job
/// asks, minutes: the stages packed ([`pack`]), except those with a `factor`
/// above 1 on their limit (they ran out of time once: their plan was short),
/// each of which goes alone; the limit is the longest task's, times the
/// largest factor in it. Also where each stage went (its task, by stage).
pub struct JobTasks {
    pub tasks: Vec<Vec<usize>>,
    pub task_of: Vec<usize>,
    pub time_min: u64,
}

pub fn job_tasks(
    resources: &[Resources],
    factor: &[f64],
    simulations: bool,
    s: &Settings,
) -> JobTasks {
    let (again, first): (Vec<usize>, Vec<usize>) =
        (0..resources.len()).partition(|&m| factor[m] > 1.0);
    let expected: Vec<f64> = first.iter().map(|&m| resources[m].expected_s).collect();
    let mut tasks: Vec<Vec<usize>> = pack(&expected, s.pack_seconds())
        .into_iter()
        .map(|t| t.into_iter().map(|j| first[j]).collect())
        .collect();
    tasks.extend(again.into_iter().map(|m| vec![m]));
    let time_min = tasks
        .iter()
        .map(|t| {
            let rs: Vec<&Resources> = t.iter().map(|&m| &resources[m]).collect();
            let f = t.iter().map(|&m| factor[m]).fold(1.0, f64::max);
            (task_minutes(&rs, simulations, s) as f64 * f).ceil() as u64
        })
        .max()
        .unwrap_or(2);
    let mut task_of = vec![0; resources.len()];
    for (t, members) in tasks.iter().enumerate() {
        for &m in members {
            task_of[m] = t;
        }
    }
    JobTasks {
        tasks,
        task_of,
        time_min,
    }
}

/// Planned seconds of a task running stages of `resources` one after the
/// other, with its start-up if they are analyses.
pub fn task_seconds(resources: &[&Resources], simulations: bool) -> f64 {
    let sum: f64 = resources.iter().map(|r| r.expected_s).sum();
    sum + if simulations { 0.0 } else { JOB_START_S }
}

/// A Slurm time limit in minutes (seconds rounded up): `MM`, `MM:SS`,
/// `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS`; `Some(None)` for `infinite`
/// or `UNLIMITED`; `None` if it is none of these.
pub fn minutes(s: &str) -> Option<Option<u64>> {
    let s = s.trim();
    if s.eq_ignore_ascii_case("infinite") || s.eq_ignore_ascii_case("unlimited") {
        return Some(None);
    }
    let (days, rest) = match s.split_once('-') {
        Some((d, r)) => (Some(d.parse::<u64>().ok()?), r),
        None => (None, s),
    };
    let f: Vec<u64> = rest
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    // [hours, minutes, seconds] from the fields present.
    let [h, m, sec] = match (days.is_some(), f.as_slice()) {
        (false, [m]) => [0, *m, 0],
        (false, [m, s]) => [0, *m, *s],
        (_, [h, m, s]) => [*h, *m, *s],
        (true, [h]) => [*h, 0, 0],
        (true, [h, m]) => [*h, *m, 0],
        _ => return None,
    };
    Some(Some(
        days.unwrap_or(0) * 1440 + h * 60 + m + sec.div_ceil(60),
    ))
}

/// A job's time limit `time_min` under a longest limit `max_min`: the limit
/// each job of the chain asks and the number of jobs (1: no chain). Each job
/// resumes from the last checkpoint of the one before; a stage that does not
/// checkpoint (`resumable` false: only simulations do) gets one job at the
/// longest limit.
pub fn chain(time_min: u64, max_min: Option<u64>, resumable: bool) -> (u64, u64) {
    match max_min {
        Some(m) if time_min > m && resumable => (m, time_min.div_ceil(m)),
        Some(m) if time_min > m => (m, 1),
        _ => (time_min, 1),
    }
}

/// `H:MM:SS`-free Slurm time limit: minutes as `D-HH:MM:00`.
pub fn time_limit(minutes: u64) -> String {
    let (d, h, m) = (minutes / 1440, (minutes % 1440) / 60, minutes % 60);
    format!("{d}-{h:02}:{m:02}:00")
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::pipeline::spec::{ExperimentSpec, parse};

    const EXP: &str = "description: e\nkind: simulate\nseed: 1\nprofiles:\n  paper:\n    replicas: 1\n    slurm:\n";

    fn slurm_of(block: &str) -> Result<Settings, String> {
        let file = Path::new("experiments/e.yaml");
        let spec: ExperimentSpec =
            parse(file, &format!("{EXP}{block}")).map_err(|e| e.to_string())?;
        let s = spec.profiles["paper"]
            .value
            .slurm
            .clone()
            .expect("slurm block");
        Settings::from_spec(file, &s.value).map_err(|e| e.to_string())
    }

    #[test]
    fn slurm_keys_are_read_and_bad_ones_located() {
        let s = slurm_of("      partition: p\n      account: a\n      qos: q\n      extra: [\"--x=1\"]\n      mem_margin: 2\n")
            .unwrap();
        assert_eq!(
            s.sbatch_args(),
            ["--partition=p", "--account=a", "--qos=q", "--x=1"]
        );
        assert_eq!((s.mem_margin, s.time_margin), (2.0, DEFAULT_TIME_MARGIN));
        // An unknown key: file, line and column of the key.
        let e = slurm_of("      partition: p\n      memory: 4G\n").unwrap_err();
        assert!(
            e.starts_with("experiments/e.yaml:9:") && e.contains("memory"),
            "{e}"
        );
        // A margin below 1: at its value.
        let e = slurm_of("      time_margin: 0.5\n").unwrap_err();
        assert!(
            e.starts_with("experiments/e.yaml:8:20") && e.contains("time_margin"),
            "{e}"
        );
    }

    #[test]
    fn time_limits_parse_and_long_jobs_chain() {
        assert_eq!(minutes("2-00:00:00"), Some(Some(2880)));
        assert_eq!(minutes("1:00:00"), Some(Some(60)));
        assert_eq!(minutes("30"), Some(Some(30)));
        assert_eq!(minutes("5:01"), Some(Some(6)));
        assert_eq!(minutes("1-12"), Some(Some(2160)));
        assert_eq!(minutes("infinite"), Some(None));
        assert_eq!(minutes("two days"), None);
        assert_eq!(chain(9, Some(1), true), (1, 9));
        assert_eq!(chain(10, Some(4), true), (4, 3));
        assert_eq!(chain(10, Some(4), false), (4, 1));
        assert_eq!(chain(10, Some(60), true), (10, 1));
        assert_eq!(chain(10, None, true), (10, 1));
        let e = slurm_of("      max_time: soon\n").unwrap_err();
        assert!(
            e.starts_with("experiments/e.yaml:8:") && e.contains("max_time"),
            "{e}"
        );
        assert_eq!(
            slurm_of("      max_time: \"1-00:00:00\"\n")
                .unwrap()
                .max_time_min,
            Some(1440)
        );
    }

    #[test]
    fn resources_scale_with_the_plan_with_margins() {
        let s = Settings::default();
        let w = Planned {
            cpu_seconds: 3600.0,
            memory_bytes: 1e6 * 198.0,
            output_bytes: 0,
            counts: Vec::new(),
        };
        let r = resources("simulate", &serde_json::Value::Null, Some(&w), (0, 0), &s);
        // One planned hour, times the margin 2.5.
        assert!((r.expected_s - 3600.0).abs() < 1e-6);
        assert_eq!(r.time_min, 150);
        let mib: f64 = (64.0 + 1e6 * 198.0 / 1048576.0) * 1.5;
        assert_eq!(r.mem_mib, mib.ceil() as u64);
        assert_eq!(r.cpus, 1);
        let tight = Settings {
            mem_margin: 1.0,
            time_margin: 1.0,
            ..s
        };
        let r1 = resources(
            "simulate",
            &serde_json::Value::Null,
            Some(&w),
            (0, 0),
            &tight,
        );
        assert_eq!(r1.time_min, 60);
        assert!(r1.mem_mib < r.mem_mib);
        assert_eq!(time_limit(60 * 24 + 61), "1-01:01:00");
    }

    #[test]
    fn short_stages_share_a_task_and_long_ones_run_alone() {
        // 30 s tasks, longest first: the 25 s stage takes the 4 s, the 20 s
        // the 10 s, and the 3 s and 2 s fit in neither (31, 32 s).
        let e = [2.0, 25.0, 10.0, 20.0, 3.0, 4.0];
        assert_eq!(pack(&e, 30.0), vec![vec![0, 4], vec![1, 5], vec![2, 3]]);
        // A stage longer than the fill sets the size: nothing asks more than it.
        assert_eq!(
            pack(&[100.0, 30.0, 40.0, 20.0], 30.0),
            vec![vec![0], vec![1, 2, 3]]
        );
        // 0: one stage per task.
        assert_eq!(pack(&[1.0, 2.0], 0.0), vec![vec![0], vec![1]]);
        // Every stage lands in exactly one task.
        let many: Vec<f64> = (0..200).map(|i| (i % 17) as f64 * 0.7).collect();
        let mut seen: Vec<usize> = pack(&many, 30.0).concat();
        seen.sort_unstable();
        assert_eq!(seen, (0..200).collect::<Vec<_>>());
        // The default fill: two minutes at the margin, less the start-up.
        assert_eq!(Settings::default().pack_seconds(), 38.0);
    }

    #[test]
    fn a_task_of_analyses_counts_one_start_up() {
        let s = Settings::default();
        let r = Resources {
            cpus: 1,
            mem_mib: 100,
            time_min: 2,
            expected_s: 5.0,
        };
        // Forty stages of 5 s and one start-up of 10 s: 210 s x 2.5 = 8.75 min.
        assert_eq!(task_seconds(&vec![&r; 40], false), 210.0);
        assert_eq!(task_minutes(&vec![&r; 40], false, &s), 9);
        // Simulations start nothing beyond their own work.
        assert_eq!(task_seconds(&vec![&r; 40], true), 200.0);
        // One short stage: Slurm's two minutes.
        assert_eq!(task_minutes(&[&r], false, &s), 2);
        let a = resources("aging", &serde_json::Value::Null, None, (0, 0), &s);
        assert_eq!(a.time_min, task_minutes(&[&a], false, &s));
    }
}
