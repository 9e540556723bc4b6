//! Checkpoints: a run stopped at a checkpoint and resumed from its bytes in a
//! fresh engine gives the same bits as one that passed it without stopping;
//! a damaged newest checkpoint falls back to the one before; after the time
//! origin moved to t ~ 10^7 the contacts keep the precision of a short run.

use anyhow::{Result, bail};

use super::intruder::{bath, quiet};
use crate::analysis::run_summary::closest_gap;
use crate::sim::config::CONTACT_PRECISION;
use crate::sim::engine::Engine;
use crate::sim::run::checkpoint::Keeper;
use crate::sim::run::simulation::run_kept;
use crate::sim::{RunSummary, SimConfig, initial_state, run};
use crate::traj::{Frame, Schedule, Trajectory};

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

/// The clock at t ~ 10^7: a driven dense fluid whose time origin is moved to
/// 10^7 at a checkpoint runs on, checkpointing every 2 time units, with no
/// pair closer than the contact precision in any frame (the exactness map's
/// closest-gap check).
#[test]
fn the_clock_keeps_its_precision_at_ten_million() {
    let c = SimConfig {
        n: 2000,
        phi: 0.8,
        ..SimConfig::default()
    };
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    (e.eps, e.tc) = (c.eps, c.collapse_tc);
    let (kicks, rate, p_dr) = run::drive(&c, 6.0);
    e.set_kicks(kicks, rate, p_dr);
    e.run_until(e.time() + 1.0, u64::MAX);
    let mut state = e.checkpoint(true).unwrap();
    state.shift_time(1e7);
    let mut e = Engine::restore(state).unwrap();
    let t0 = e.time();
    assert!(t0 > 1e7);
    let mut frames = Vec::new();
    for k in 1..=40 {
        let t = t0 + 0.25 * k as f64;
        assert!(e.run_until(t, u64::MAX));
        if k % 8 == 0 {
            e.checkpoint(false);
        }
        let (x, y) = e.unwrapped_positions();
        frames.push(Frame {
            time: t,
            x,
            y,
            vx: vec![],
            vy: vec![],
        });
    }
    assert!(e.stats.collisions > 100_000, "{:?}", e.stats);
    let traj = Trajectory {
        box_size: c.box_size(),
        periodic: [true, true],
        species: e.species.clone(),
        radii: c.radii(),
        masses: c.species_masses(),
        frames,
        schedule: None,
    };
    let gap = closest_gap(&traj);
    assert!(gap >= -CONTACT_PRECISION, "closest gap {gap:e} at t ~ 1e7");
}
