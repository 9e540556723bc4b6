//! Checkpoints: a run stopped at a checkpoint and resumed from its bytes in a
//! fresh engine gives the same bits as one that passed it without stopping;
//! a damaged newest checkpoint falls back to the one before. At the engine's
//! level: an engine resumed from its state's bytes at every checkpoint ends
//! with the same state bytes as one that never stopped, so nothing that
//! determines the future can be left out of the state, nor history kept in
//! what is rebuilt from it. (The clock's
//! precision at t ~ 10^7 is tested with the exactness checks, in
//! `analysis::run_summary`.)

use anyhow::{Result, bail};

use super::intruder::{bath, quiet};
use crate::sim::engine::Engine;
use crate::sim::engine::state::EngineState;
use crate::sim::model::config::ForceMode;
use crate::sim::run::checkpoint::Keeper;
use crate::sim::run::engine_for_run;
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

/// What a run has produced by now, as bytes: unwrapped positions,
/// velocities, time and every counter and ledger.
fn outcome(e: &Engine) -> Vec<u8> {
    postcard::to_stdvec(&(e.unwrapped_positions(), e.velocities(), e.time(), e.stats())).unwrap()
}

/// `c`'s engine run for `stops` intervals `dt` from the start of its
/// relaxation, checkpointing at the end of each; the run `resumed` goes on
/// from each checkpoint's bytes in a new engine. Returns the bytes of every
/// checkpoint's state, of the outcome before it and of the state after it,
/// then of the outcome and the state at the end.
fn run_in_intervals(c: &SimConfig, dt: f64, stops: usize, resumed: bool) -> Vec<Vec<u8>> {
    let mut e = engine_for_run::build(c, &quiet).unwrap().0;
    let t0 = e.time();
    let mut out = Vec::new();
    for k in 1..=stops {
        assert!(e.run_until(t0 + k as f64 * dt, u64::MAX));
        out.push(outcome(&e));
        let state = e.checkpoint(true).unwrap().to_bytes().unwrap();
        if resumed {
            let back: EngineState = postcard::from_bytes(&state).unwrap();
            e = Engine::restore(back).unwrap();
        }
        out.push(state);
        // The state the run goes on from (the checkpoint's, with every event
        // predicted anew).
        out.push(e.state().to_bytes().unwrap());
    }
    // On to a time between checkpoints, with events pending.
    assert!(e.run_until(t0 + (stops as f64 + 0.5) * dt, u64::MAX));
    out.push(outcome(&e));
    out.push(e.state().to_bytes().unwrap());
    out
}

/// Resumed at every checkpoint, `c`'s engine gives the bytes of the
/// uninterrupted run at each checkpoint (its state, the outcome just before,
/// the state it goes on from) and at the end (the outcome and the whole state), after at least
/// `min_collisions`.
fn engine_resumes_bit_identically(c: &SimConfig, dt: f64, min_collisions: u64) {
    let stops = 4;
    let whole = run_in_intervals(c, dt, stops, false);
    let resumed = run_in_intervals(c, dt, stops, true);
    assert_eq!(whole.len(), resumed.len());
    for (k, (a, b)) in whole.iter().zip(&resumed).enumerate() {
        let what = ["outcome", "checkpoint", "state going on"][k % 3];
        assert!(a == b, "{what} {} differs after resuming", k / 3 + 1);
    }
    let last: EngineState = postcard::from_bytes(whole.last().unwrap()).unwrap();
    let e = Engine::restore(last).unwrap();
    assert!(
        e.stats().collisions >= min_collisions,
        "{} collisions",
        e.stats().collisions
    );
}

#[test]
fn the_driven_bath_engine_resumes_bit_identically() {
    engine_resumes_bit_identically(&paper_h(), 0.37, 20_000);
}

/// The pulled intruder between walls on both axes, with friction.
#[test]
fn the_pulled_intruder_engine_resumes_bit_identically() {
    let mut c = paper_i();
    c.walls = [true, true];
    engine_resumes_bit_identically(&c, 0.23, 5_000);
}

/// The force on the intruder as a train of kicks.
#[test]
fn the_force_kick_engine_resumes_bit_identically() {
    let mut c = paper_i();
    c.intruder.as_mut().unwrap().force_mode = ForceMode::Kicks;
    engine_resumes_bit_identically(&c, 0.23, 5_000);
}
