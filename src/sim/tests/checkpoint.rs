//! Checkpoints: a run stopped at a checkpoint and resumed from its bytes in a
//! fresh engine gives the same bits as one that passed it without stopping;
//! a damaged newest checkpoint falls back to the one before. (The clock's
//! precision at t ~ 10^7 is tested with the exactness checks, in
//! `analysis::run_summary`.)

use anyhow::{Result, bail};

use super::intruder::{bath, quiet};
use crate::sim::run::checkpoint::Keeper;
use crate::sim::run::simulation::run_kept;
use crate::sim::{RunSummary, SimConfig, run};
use crate::traj::{Schedule, Trajectory};

/// Checkpoints kept in memory; the run stops (an error) after `stop_after` saves.
#[derive(Default)]
struct Memory {
    saved: Vec<(f64, Vec<u8>)>,
    stop_after: Option<usize>,
    rejected: Vec<String>,
    resumed_at: Option<f64>,
}

impl Keeper for Memory {
    fn saved(&mut self) -> Vec<String> {
        (0..self.saved.len()).rev().map(|k| k.to_string()).collect()
    }
    fn read(&mut self, name: &str) -> Result<Vec<u8>> {
        Ok(self.saved[name.parse::<usize>()?].1.clone())
    }
    fn reject(&mut self, name: &str, why: &str) {
        self.rejected.push(format!("{name}: {why}"));
    }
    fn resumed(&mut self, _name: &str, time: f64) {
        self.resumed_at = Some(time);
    }
    fn save(&mut self, time: f64, bytes: &[u8]) -> Result<()> {
        self.saved.push((time, bytes.to_vec()));
        if Some(self.saved.len()) == self.stop_after {
            bail!("stopped after checkpoint {}", self.saved.len());
        }
        Ok(())
    }
}

/// A run's results as bytes: the trajectory's Parquet and the summary's JSON
/// without the machine's measurements.
fn bits(out: (Trajectory, RunSummary)) -> (Vec<u8>, String) {
    let (traj, mut s) = out;
    (
        s.cpu_seconds,
        s.collisions_per_second,
        s.events_per_second,
        s.peak_rss_bytes,
    ) = (0.0, 0.0, 0.0, 0);
    (
        crate::table::trajectory::to_parquet_bytes(&traj).unwrap(),
        serde_json::to_string(&s).unwrap(),
    )
}

/// Paper H's driven fluid with the balanced rate, frames with velocities,
/// checkpoints every 3.1 (in the balancing windows and in production).
fn paper_h() -> SimConfig {
    SimConfig {
        n: 1000,
        phi: 0.75,
        relax_time: 10.0,
        samples: 30,
        record_velocities: true,
        schedule: Schedule {
            start: 0.0,
            origins: 2,
            origin_spacing: 3.0,
            lags: vec![0.5, 2.0],
        },
        checkpoint_every: Some(3.1),
        seed: 5,
        ..SimConfig::default()
    }
}

/// Paper I: friction, single kicks, the pulled intruder, walls in y.
fn paper_i() -> SimConfig {
    let mut c = bath(600, 0.7, 1.0, 10.0);
    c.walls = [false, true];
    c.aspect = 0.5;
    c.schedule = Schedule {
        start: 0.0,
        origins: 1,
        origin_spacing: 0.0,
        lags: vec![1.0, 4.0],
    };
    c.checkpoint_every = Some(0.7);
    c
}

/// Stopped after checkpoint `k` and resumed from its bytes: the same bits as
/// the uninterrupted run, with or without a keeper.
fn resumes_bit_identically(c: &SimConfig, k: usize) {
    let mut a = Memory::default();
    let whole = bits(run_kept(c, &quiet, Some(&mut a)).unwrap());
    assert!(a.saved.len() > k + 1, "{} checkpoints", a.saved.len());
    assert!(
        whole == bits(run(c, &quiet).unwrap()),
        "a keeper changes the run"
    );
    let mut b = Memory {
        stop_after: Some(k),
        ..Memory::default()
    };
    let stopped = run_kept(c, &quiet, Some(&mut b)).unwrap_err();
    assert!(format!("{stopped}").contains("stopped"), "{stopped}");
    b.stop_after = None;
    let resumed = bits(run_kept(c, &quiet, Some(&mut b)).unwrap());
    assert_eq!(b.resumed_at, Some(a.saved[k - 1].0));
    assert!(b.rejected.is_empty(), "{:?}", b.rejected);
    assert!(
        resumed.1 == whole.1,
        "summaries differ:\n{}\n{}",
        resumed.1,
        whole.1
    );
    assert!(resumed.0 == whole.0, "trajectories differ");
    // The resumed run checkpoints at the uninterrupted one's times (the
    // bytes differ by the CPU seconds they record).
    let times = |m: &Memory| m.saved.iter().map(|s| s.0).collect::<Vec<_>>();
    assert_eq!(times(&b), times(&a));
}

#[test]
fn paper_h_resumes_bit_identically() {
    resumes_bit_identically(&paper_h(), 2);
}

#[test]
fn paper_i_resumes_bit_identically() {
    resumes_bit_identically(&paper_i(), 5);
}

/// The newest checkpoint truncated: it is rejected with the reason, and the
/// run goes on from the one before, to the same bits.
#[test]
fn a_truncated_checkpoint_falls_back_to_the_previous_one() {
    let c = paper_h();
    let whole = bits(run(&c, &quiet).unwrap());
    let mut m = Memory {
        stop_after: Some(2),
        ..Memory::default()
    };
    run_kept(&c, &quiet, Some(&mut m)).unwrap_err();
    let last = &mut m.saved[1].1;
    last.truncate(last.len() / 2);
    m.stop_after = None;
    let resumed = bits(run_kept(&c, &quiet, Some(&mut m)).unwrap());
    assert_eq!(m.rejected.len(), 1, "{:?}", m.rejected);
    assert!(
        m.rejected[0].starts_with("1: truncated"),
        "{:?}",
        m.rejected
    );
    assert_eq!(m.resumed_at, Some(m.saved[0].0));
    assert!(resumed == whole);
    // A checkpoint of another configuration is refused by name.
    let other = SimConfig { seed: 6, ..c };
    let mut m2 = Memory {
        saved: vec![m.saved[0].clone()],
        ..Memory::default()
    };
    run_kept(&other, &quiet, Some(&mut m2)).unwrap();
    assert!(
        m2.rejected[0].contains("another configuration"),
        "{:?}",
        m2.rejected
    );
}
