//! What a run tells while it goes: bars on a terminal, plain lines otherwise, and
//! the same plain lines in a log file (`.repro/log/LAST-RUN.log`).
//!
//! On a terminal, one bar for the whole run and one per running stage that reports
//! progress. When stderr is not a terminal (CI, a batch job, `| tee`), bars would be
//! invisible until the end, so instead: one line per finished stage, and one line
//! every [`heartbeat`] seconds per stage still running, with its last report (what
//! it does, how far, the rate). Every line also goes to the log file, whatever
//! stderr is.
//!
//! With a plan ([`Progress::plan`]: the planned CPU seconds of each stage,
//! [`cost`](super::cost)), each finished stage's line and a line per heartbeat
//! also say the elapsed time, the planned CPU time left and an estimated end.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};

use super::stage::ProgressSink;

/// Seconds between two plain lines about one running stage: `REPRO_HEARTBEAT_S`,
/// default 30.
pub fn heartbeat() -> Duration {
    let s = std::env::var("REPRO_HEARTBEAT_S")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(30.0);
    Duration::from_secs_f64(s)
}

/// Last report of a running stage: done, total, message, when.
type Last = Arc<Mutex<Option<(f64, f64, String, Instant)>>>;

struct Running {
    label: String,
    started: Instant,
    printed: Instant,
    last: Last,
    bar: Arc<Mutex<Option<ProgressBar>>>,
}

/// Progress of one run.
pub struct Progress {
    bars: Option<MultiProgress>,
    overall: Option<ProgressBar>,
    /// Print plain lines to stderr (stderr is not a terminal).
    plain: bool,
    log: Option<Mutex<File>>,
    total: usize,
    finished: Mutex<usize>,
    running: Mutex<BTreeMap<usize, Running>>,
    t0: Instant,
    plan: Mutex<Option<Plan>>,
    /// When the last heartbeat line with the estimate was printed.
    estimated: Mutex<Instant>,
}

/// The planned CPU seconds of the stages still to finish, the class of each
/// stage, what each class has taken so far against its plan, and how many
/// stages run at once.
struct Plan {
    left: BTreeMap<usize, (usize, f64)>,
    classes: Vec<Pace>,
    /// Wall seconds the finished stages ran, summed: how busy the workers were.
    busy: f64,
    workers: usize,
}

/// What the stages of one class (one experiment's simulations, one analysis
/// stage's instances) took so far: their planned CPU seconds and the wall
/// seconds they ran (one stage is one thread).
#[derive(Clone, Copy, Default, Debug, PartialEq)]
struct Pace {
    planned: f64,
    spent: f64,
}

/// How many planned CPU seconds of its own a class must have done before its
/// pace counts as evidence for the machine's speed, and how much of the
/// machine's pace a class's own is shrunk towards (in planned CPU seconds).
/// A plan is off in two ways that look alike early on: one kind of stage far
/// off its calibration (a pulled intruder at 4x, `make all-figures` at small,
/// 2026-11-28: an end printed 64% late at a tenth of the run when the first
/// stages' pace was taken for all), and a whole machine faster or slower than
/// the calibration's (the same build on a machine 2.2x faster: 37% late at a
/// tenth with the pace shrunk towards the plan). So the pace is measured per
/// class, and the machine's is the median over the classes.
const CLASS_EVIDENCE: f64 = 20.0;
const CLASS_PRIOR: f64 = 30.0;

/// The class of a stage: its kind and its label up to the first `[` (the
/// experiment of a simulation, the stage's name otherwise).
pub fn class_name(kind: &str, label: &str) -> String {
    format!("{kind}:{}", label.split('[').next().unwrap_or(label))
}

impl Progress {
    /// `show`: tell the user (bars on a terminal, else plain lines). `log`: the
    /// file the plain lines also go to (created or truncated; none if it cannot be).
    pub fn new(show: bool, total: usize, log: Option<&Path>) -> Progress {
        let terminal = std::io::IsTerminal::is_terminal(&std::io::stderr());
        let bars = (show && terminal).then(MultiProgress::new);
        let overall = bars.as_ref().map(|mp| {
            let b = mp.add(ProgressBar::new(total as u64));
            b.set_style(
                ProgressStyle::with_template("stages [{bar:30}] {pos}/{len} {msg} ({elapsed})")
                    .unwrap()
                    .progress_chars("=> "),
            );
            b
        });
        let log = log.and_then(|p| open_run_log(p).map(Mutex::new));
        Progress {
            bars,
            overall,
            plain: show && !terminal,
            log,
            total,
            finished: Mutex::new(0),
            running: Mutex::new(BTreeMap::new()),
            t0: Instant::now(),
            plan: Mutex::new(None),
            estimated: Mutex::new(Instant::now()),
        }
    }

    /// The planned CPU seconds of each stage of the run (`seconds[i]` for node
    /// `i` of `nodes`), the class of each (`classes[i]`, see [`class_name`])
    /// and how many run at once: from here on the lines carry an estimate of
    /// the end. A stage found cached drops its share unspent.
    pub fn plan(&self, nodes: &[usize], seconds: &[f64], classes: &[String], workers: usize) {
        let mut names: Vec<&str> = nodes.iter().map(|&i| classes[i].as_str()).collect();
        names.sort_unstable();
        names.dedup();
        let left = nodes
            .iter()
            .map(|&i| {
                let c = names.binary_search(&classes[i].as_str()).unwrap_or(0);
                (i, (c, seconds[i]))
            })
            .collect();
        *self.plan.lock().unwrap() = Some(Plan {
            left,
            classes: vec![Pace::default(); names.len()],
            busy: 0.0,
            workers: workers.max(1),
        });
    }

    /// `elapsed 12 min, planned 1.52 CPU h left, ends ~16:40 UTC`, or nothing
    /// without a plan. A running stage counts the share it has not done (from
    /// its last report) as left and the share done, with its time so far, as
    /// evidence of its class's pace. The planned work left is converted to
    /// CPU time at its class's pace, to wall time over the workers as busy as
    /// they were so far, and the end is the later of that and the longest
    /// stage left ([`wall_left`]).
    fn estimate(&self) -> String {
        let plan = self.plan.lock().unwrap();
        let Some(p) = &*plan else {
            return String::new();
        };
        let running = self.running.lock().unwrap();
        let mut classes = p.classes.clone();
        let mut busy = p.busy;
        let mut left = Vec::with_capacity(p.left.len());
        for (i, &(c, s)) in &p.left {
            let run = running.get(i);
            let (done, whole) = run
                .and_then(|r| {
                    let last = r.last.lock().unwrap();
                    last.as_ref()
                        .map(|l| (fraction(l.0, l.1), of_the_whole_stage(&l.2)))
                })
                .unwrap_or((0.0, false));
            if let Some(r) = run {
                let spent = r.started.elapsed().as_secs_f64();
                busy += spent;
                // Too little done to tell a pace (a run still setting up), or a
                // share of one phase only.
                if done >= 0.02 && whole {
                    classes[c].planned += s * done;
                    classes[c].spent += spent;
                }
            }
            left.push((c, s * (1.0 - done)));
        }
        let elapsed = self.t0.elapsed().as_secs_f64();
        let total: f64 = left.iter().map(|l| l.1).sum();
        let wall = wall_left(&left, &classes, elapsed, busy, p.workers);
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        format!(
            "elapsed {}, planned {} CPU left, ends ~{} UTC",
            span(elapsed),
            span(total),
            clock(now + wall)
        )
    }

    /// Write a line to the log and to stderr (above the bars on a terminal).
    pub fn line(&self, text: &str) {
        self.emit(text, true)
    }

    /// `news`: print it on stderr too (else only in the log).
    fn emit(&self, text: &str, news: bool) {
        let t = self.t0.elapsed().as_secs_f64();
        let line = format!("[{t:7.1} s] {text}");
        if news && self.plain {
            eprintln!("{line}");
        } else if news && let Some(mp) = &self.bars {
            let _ = mp.println(text);
        }
        if let Some(f) = &self.log {
            let _ = writeln!(f.lock().unwrap(), "{line}");
        }
    }

    /// Stage `node` starts: the sink it reports progress to.
    pub fn start(&self, node: usize, label: &str) -> ProgressSink {
        let last: Last = Arc::new(Mutex::new(None));
        let bar: Arc<Mutex<Option<ProgressBar>>> = Arc::new(Mutex::new(None));
        let now = Instant::now();
        self.running.lock().unwrap().insert(
            node,
            Running {
                label: label.to_string(),
                started: now,
                printed: now,
                last: last.clone(),
                bar: bar.clone(),
            },
        );
        let mp = self.bars.clone();
        let label = label.to_string();
        Arc::new(move |done: f64, total: f64, msg: &str| {
            *last.lock().unwrap() = Some((done, total, msg.to_string(), Instant::now()));
            let Some(mp) = &mp else { return };
            let mut b = bar.lock().unwrap();
            let b = b.get_or_insert_with(|| {
                let b = mp.add(ProgressBar::new(1000));
                b.set_style(
                    ProgressStyle::with_template(
                        "{prefix} [{bar:20}] {msg} ({elapsed}, ETA {eta})",
                    )
                    .unwrap()
                    .progress_chars("=> "),
                );
                b.set_prefix(label.clone());
                // Redraw (elapsed time) even while the stage sends no report.
                b.enable_steady_tick(std::time::Duration::from_secs(1));
                b
            });
            b.set_position((fraction(done, total) * 1000.0) as u64);
            b.set_message(msg.to_string());
        })
    }

    /// Stage `node` finished (`what`: executed, cached, failed, ...).
    pub fn finish(&self, node: usize, label: &str, kind: &str, what: &str) {
        let ran = self.running.lock().unwrap().remove(&node);
        if let Some(r) = &ran
            && let Some(b) = r.bar.lock().unwrap().take()
        {
            b.finish_and_clear();
        }
        // A stage found cached spent no work: not part of the pace either.
        let mut planned = None;
        if let Some(p) = &mut *self.plan.lock().unwrap()
            && let Some((c, s)) = p.left.remove(&node)
            && what == "executed"
            && let Some(r) = &ran
        {
            let spent = r.started.elapsed().as_secs_f64();
            p.classes[c].planned += s;
            p.classes[c].spent += spent;
            p.busy += spent;
            planned = Some(s);
        }
        let k = {
            let mut f = self.finished.lock().unwrap();
            *f += 1;
            *f
        };
        if let Some(o) = &self.overall {
            o.inc(1);
        }
        // The plan beside the time taken: a log replays the estimate.
        let took = ran
            .map(|r| {
                let plan = planned.map_or(String::new(), |s| format!(", planned {s:.1} s"));
                format!(" in {:.1} s{plan}", r.started.elapsed().as_secs_f64())
            })
            .unwrap_or_default();
        let estimate = self.estimate();
        if let Some(o) = &self.overall {
            o.set_message(estimate.clone());
        }
        let estimate = if estimate.is_empty() || what == "cached" {
            String::new()
        } else {
            format!("; {estimate}")
        };
        // Cached stages only go to the log: the closing summary counts them.
        self.emit(
            &format!(
                "[{k}/{}] {what} {label} ({kind}){took}{estimate}",
                self.total
            ),
            what != "cached",
        );
    }

    /// One line per stage running for more than a heartbeat since its last line,
    /// and one with the build's estimate per heartbeat.
    pub fn beat(&self, every: Duration) {
        let mut due = Vec::new();
        for r in self.running.lock().unwrap().values_mut() {
            if r.printed.elapsed() < every {
                continue;
            }
            r.printed = Instant::now();
            let how = match &*r.last.lock().unwrap() {
                Some((done, total, msg, at)) => {
                    let ago = at.elapsed();
                    // A stage may go quiet for a while (a phase without reports): say so.
                    let when = if ago >= every {
                        format!(", reported {:.0} s ago", ago.as_secs_f64())
                    } else {
                        String::new()
                    };
                    format!("{:.0}% ({msg}{when})", 100.0 * fraction(*done, *total))
                }
                None => "no progress report yet".to_string(),
            };
            due.push(format!(
                "running {} for {:.0} s: {how}",
                r.label,
                r.started.elapsed().as_secs_f64()
            ));
        }
        // The whole build's estimate once a heartbeat, also while every stage
        // runs elsewhere (Slurm jobs report no progress here).
        let mut last = self.estimated.lock().unwrap();
        if last.elapsed() >= every {
            *last = Instant::now();
            let estimate = self.estimate();
            if !estimate.is_empty() {
                let k = *self.finished.lock().unwrap();
                due.push(format!("[{k}/{}] {estimate}", self.total));
            }
        }
        drop(last);
        for l in due {
            self.line(&l);
        }
    }

    /// Remove the bars.
    pub fn done(&self) {
        if let Some(o) = &self.overall {
            o.finish_and_clear();
        }
    }
}

/// A duration: `42 s`, `12 min`, `3.4 h`.
fn span(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

/// How many runs' logs `.repro/log` keeps.
const KEPT_RUN_LOGS: usize = 20;

/// This run's own log file, `run-UNIXSECONDS-PID.log` beside `last`, with
/// `last` (LAST-RUN.log) made a symlink to it: two runs at once in one project
/// each keep a whole log (one shared file had both truncating and writing it).
/// The oldest logs beyond [`KEPT_RUN_LOGS`] are removed, but never the log of
/// a run still going (a survey starts a run per seed, and a long build beside
/// it would otherwise lose its log while writing it).
fn open_run_log(last: &std::path::Path) -> Option<File> {
    let dir = last.parent()?;
    std::fs::create_dir_all(dir).ok()?;
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let name = format!("run-{secs:011}-{}.log", std::process::id());
    let file = File::create(dir.join(&name)).ok()?;
    let mut old: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("run-") && n.ends_with(".log"))
        })
        .collect();
    old.sort();
    for p in old.iter().take(old.len().saturating_sub(KEPT_RUN_LOGS)) {
        if !log_of_a_running_process(p) {
            let _ = std::fs::remove_file(p);
        }
    }
    // Replace LAST-RUN.log (a file from older versions, or the previous link)
    // atomically by a link to this run's log.
    let tmp = dir.join(format!(".{name}.link"));
    let _ = std::fs::remove_file(&tmp);
    if std::os::unix::fs::symlink(&name, &tmp).is_ok() {
        let _ = std::fs::rename(&tmp, last);
    }
    Some(file)
}

/// Whether the process named by a run log (`run-SECONDS-PID.log`) is running:
/// read from /proc where there is one (Linux); elsewhere no log counts as
/// running.
fn log_of_a_running_process(log: &std::path::Path) -> bool {
    let pid = log
        .file_stem()
        .and_then(|n| n.to_str())
        .and_then(|n| n.rsplit('-').next())
        .and_then(|p| p.parse::<u32>().ok());
    pid.is_some_and(|pid| std::path::Path::new("/proc").join(pid.to_string()).is_dir())
}

/// Unix seconds as the UTC time of day, `HH:MM:SS` (a ci build lasts
/// minutes: the seconds let its log be checked against the actual end).
fn clock(unix: f64) -> String {
    let s = unix.max(0.0) as u64 % 86_400;
    format!("{:02}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Wall seconds left of a run: `left` holds each stage left as (class, planned
/// CPU s not yet done), `classes` what each class took so far against its
/// plan, `busy` the wall seconds stages have run in all, `elapsed` the run's
/// wall seconds, on `workers`.
///
/// The machine's pace (CPU s per planned CPU s) is the median over the classes
/// with [`CLASS_EVIDENCE`] done, the plan's own (1) before there is any; each
/// class's pace is its own shrunk towards the machine's by [`CLASS_PRIOR`].
/// The CPU left is spread over the workers as busy as they have been (a
/// dependency that keeps one waiting counts), and no sooner than its longest
/// stage alone.
fn wall_left(
    left: &[(usize, f64)],
    classes: &[Pace],
    elapsed: f64,
    busy: f64,
    workers: usize,
) -> f64 {
    let mut rates: Vec<f64> = classes
        .iter()
        .filter(|c| c.planned >= CLASS_EVIDENCE)
        .map(|c| c.spent / c.planned)
        .collect();
    rates.sort_by(f64::total_cmp);
    let machine = match rates.len() {
        0 => 1.0,
        n if n % 2 == 1 => rates[n / 2],
        n => 0.5 * (rates[n / 2 - 1] + rates[n / 2]),
    };
    let pace = |c: usize| {
        let k = classes.get(c).copied().unwrap_or_default();
        (k.spent + CLASS_PRIOR * machine) / (k.planned + CLASS_PRIOR)
    };
    let (mut cpu, mut longest) = (0.0, 0.0f64);
    for &(c, s) in left {
        let t = s * pace(c);
        cpu += t;
        longest = longest.max(t);
    }
    let workers = workers as f64;
    // How busy the workers were: a run's first minute counts as fully busy,
    // and so does a run whose stages ran elsewhere (Slurm jobs report no time).
    let busy_share = if elapsed > 60.0 && busy > 0.0 {
        (busy / (elapsed * workers)).clamp(0.5, 1.0)
    } else {
        1.0
    };
    (cpu / (workers * busy_share)).max(longest)
}

/// Whether a running stage's report measures the share of the whole stage done.
/// A simulation reports its relaxation (`Relax t = 120.0/400.0, ...`) as a
/// share of the relaxation alone, which would make the run look as far along
/// as its production later; its production (`Production t = ...`, the time
/// since the relaxation began against the run's end) and every other stage's
/// report are shares of the whole.
fn of_the_whole_stage(msg: &str) -> bool {
    !(msg.starts_with("Relax") || msg.starts_with("Compress"))
}

fn fraction(done: f64, total: f64) -> f64 {
    if total > 0.0 {
        (done / total).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Old logs are trimmed to the newest KEPT_RUN_LOGS, except the log of a
    /// run still going (here this test's own process, the oldest of all).
    #[test]
    fn old_run_logs_are_removed_but_not_a_running_one() {
        let dir = tempfile::tempdir().unwrap();
        let running = dir
            .path()
            .join(format!("run-{:011}-{}.log", 1, std::process::id()));
        std::fs::write(&running, "still writing").unwrap();
        // PIDs far above any kernel's limit: no such process.
        for k in 0..KEPT_RUN_LOGS + 5 {
            let name = format!("run-{:011}-{}.log", 10 + k, 4_000_000_000u32 + k as u32);
            std::fs::write(dir.path().join(name), "").unwrap();
        }
        open_run_log(&dir.path().join("LAST-RUN.log")).unwrap();
        let logs: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|n| n.starts_with("run-"))
            .collect();
        assert!(running.exists(), "{logs:?}");
        // The running one, the newest KEPT_RUN_LOGS - 1 of the others and the new one.
        assert_eq!(logs.len(), KEPT_RUN_LOGS + 1, "{logs:?}");
        assert!(
            !logs.iter().any(|n| n.contains("-00000000010-")),
            "{logs:?}"
        );
    }

    /// Work left as (class, planned CPU s) from per-class lists.
    fn stages(per_class: &[(usize, usize, f64)]) -> Vec<(usize, f64)> {
        per_class
            .iter()
            .flat_map(|&(c, k, s)| std::iter::repeat_n((c, s), k))
            .collect()
    }

    #[test]
    fn the_end_follows_each_class_pace_and_the_machine_median() {
        let close = |a: f64, b: f64| (a - b).abs() <= 0.02 * b.abs().max(1.0);
        let none = [Pace::default(); 3];
        // Nothing done: 100 CPU s on 2 workers take 50 s, unless one stage is longer.
        let even = stages(&[(0, 10, 10.0)]);
        assert!(close(wall_left(&even, &none, 0.0, 0.0, 2), 50.0));
        let long = [(0, 80.0), (1, 20.0)];
        assert!(close(wall_left(&long, &none, 0.0, 0.0, 2), 80.0));
        // A machine 2.2 times faster than the calibration, seen in three
        // classes after a little work each: the rest of every class, those
        // not yet started included, goes at its pace.
        let fast = [
            Pace {
                planned: 100.0,
                spent: 45.0,
            },
            Pace {
                planned: 60.0,
                spent: 27.0,
            },
            Pace {
                planned: 40.0,
                spent: 18.0,
            },
            Pace::default(),
        ];
        let rest = stages(&[(0, 10, 300.0), (1, 10, 300.0), (3, 20, 300.0)]);
        let truth = 12000.0 * 0.45 / 2.0;
        assert!(close(wall_left(&rest, &fast, 100.0, 200.0, 2), truth));
        // One class 4 times over its plan (a pulled intruder) beside three at
        // it: that class's rest takes 4x (shrunk a little), the others do not.
        let one_off = [
            Pace {
                planned: 100.0,
                spent: 400.0,
            },
            Pace {
                planned: 50.0,
                spent: 50.0,
            },
            Pace {
                planned: 50.0,
                spent: 50.0,
            },
            Pace {
                planned: 50.0,
                spent: 50.0,
            },
        ];
        let rest = stages(&[(0, 1, 100.0), (1, 10, 100.0), (2, 10, 100.0)]);
        let intruder = (400.0 + 30.0) / 130.0 * 100.0;
        let expect = (intruder + 2000.0) / 2.0;
        assert!(close(wall_left(&rest, &one_off, 300.0, 600.0, 2), expect));
        // Workers idle half the time (stages waiting on others) double the wall time.
        let at_plan = [Pace {
            planned: 100.0,
            spent: 100.0,
        }];
        let rest = stages(&[(0, 10, 10.0)]);
        assert!(close(wall_left(&rest, &at_plan, 200.0, 200.0, 2), 100.0));
    }

    #[test]
    fn a_class_is_named_by_kind_and_label_before_its_grid() {
        assert_eq!(
            class_name("simulate", "eps09[phi=0.805,replica=1]"),
            "simulate:eps09"
        );
        assert_eq!(class_name("plot", "fig12/figure"), "plot:fig12/figure");
    }
}
