//! The exact force's resting-contact rule (paper I): an intruder the force
//! presses on disks used to stop the run in simulated time (its rebounds off
//! a disk shrank until the collapse guard made them elastic, at approach
//! speeds of 10^-12 and 3 x 10^9 collisions per unit time). A rebound the
//! force would bring back within `WALL_REST_TIME` is now lifted to the speed
//! that returns then: the runs that stalled finish within a bounded number of
//! events, agree with the force as kicks, and keep the ledgers exact.

use super::intruder::{bath, mean_and_error, pulled};
use crate::sim::config::{ForceMode, Intruder};
use crate::sim::{Drive, KickRate, Progress, RunSummary, SimConfig, run};
use crate::traj::Schedule;

/// The channel the defect showed in: paper I's bath at eps = 0.7, single
/// kicks, gamma = 1, aspect 2, walls in y, the intruder pulled by `force`.
fn channel(n: usize, phi: f64, force: f64, seed: u64, relax: f64, time: f64) -> SimConfig {
    SimConfig {
        n,
        phi,
        eps: 0.7,
        radius_ratio: 1.25,
        drive: Drive::Single,
        kick_rate: KickRate::Enskog { prefactor: 1.0 },
        gamma: 1.0,
        aspect: 2.0,
        walls: [false, true],
        intruder: Some(Intruder::paper(force)),
        seed,
        relax_time: relax,
        schedule: Schedule {
            start: time,
            origins: 0,
            origin_spacing: 0.0,
            lags: vec![],
        },
        ..SimConfig::default()
    }
}

/// `run`, stopped by a panic once more than `max` collisions were made (the
/// progress report comes every 2^20 events): a stalled run fails instead of hanging.
fn bounded(c: &SimConfig, max: u64) -> RunSummary {
    let check = |p: Progress| {
        assert!(
            p.collisions <= max,
            "{:?} at t = {} of {}: {} collisions",
            p.stage,
            p.time,
            p.end,
            p.collisions
        )
    };
    run(c, &check).unwrap().1
}

/// The runs that stalled (phi = 0.3, F = 4, seed 2: no progress past
/// t = 58.18; phi = 0.6, F = 32; phi = 0.75, F = 100) finish with at most
/// twice the Enskog collision rate, lifts under 10% of the collisions, the
/// ledger (with the lifted energy) closed.
#[test]
fn pressed_intruder_finishes_within_an_event_bound() {
    for (phi, force, seed, relax, time) in [
        (0.3, 4.0, 2, 20.0, 80.0),
        (0.6, 32.0, 1, 5.0, 10.0),
        (0.75, 100.0, 1, 3.0, 3.0),
    ] {
        let c = channel(500, phi, force, seed, relax, time);
        let s = bounded(&c, 5_000_000);
        let i = s.intruder.clone().unwrap();
        let what = format!(
            "phi {phi} F {force}: {} collisions, {} lifts",
            s.collisions, i.lifts
        );
        assert!(
            s.collision_rate < 2.0 * s.enskog_collision_rate,
            "{what}: rate {} vs Enskog {}",
            s.collision_rate,
            s.enskog_collision_rate
        );
        assert!((i.lifts as f64) < 0.1 * s.collisions as f64, "{what}");
        assert!(
            s.energy_balance_error < 1e-9,
            "{what}: {}",
            s.energy_balance_error
        );
        assert!(i.energy_lifted >= 0.0, "{what}");
        assert!(
            i.velocity[0] > 0.0 && i.velocity[0] < force / 4.0,
            "{what}: {:?}",
            i.velocity
        );
    }
}

/// In the formerly stalling range the exact force and the force as kicks (at
/// 10^4 times the collision rate) give the same mean intruder velocity within
/// the statistics (4 seeds, error from their spread).
#[test]
fn pressed_intruder_exact_and_kicks_agree() {
    for (phi, force) in [(0.3, 4.0), (0.6, 32.0), (0.75, 100.0)] {
        let velocities = |mode: ForceMode| -> Vec<f64> {
            (1..=4)
                .map(|seed| {
                    let mut c = channel(500, phi, force, seed, 5.0, 15.0);
                    c.intruder = Some(Intruder {
                        force_mode: mode,
                        ..Intruder::paper(force)
                    });
                    let s = bounded(&c, 20_000_000);
                    assert!(s.energy_balance_error < 1e-9, "{mode:?}");
                    s.intruder.unwrap().velocity[0]
                })
                .collect()
        };
        let (exact, kicks) = (velocities(ForceMode::Exact), velocities(ForceMode::Kicks));
        let ((me, se), (mk, sk)) = (mean_and_error(&exact), mean_and_error(&kicks));
        eprintln!("phi {phi} F {force}: exact {me:.4} +- {se:.4}, kicks {mk:.4} +- {sk:.4}");
        assert!(
            (me - mk).abs() < 4.0 * (se * se + sk * sk).sqrt(),
            "phi {phi} F {force}: exact {exact:?}, kicks {kicks:?}"
        );
    }
}

/// Without friction (pair kicks, phi = 0.75, F = 100, eps = 0.7) the lifts
/// are internal impulses: the total momentum stays P(0) + F t x to 1e-10,
/// no overlap beyond 1e-10 sigma, and the ledger with the lifted energy closes.
#[test]
fn lifts_keep_momentum_ledger_and_no_overlap() {
    let mut c = bath(500, 0.75, 0.0, 100.0);
    c.eps = 0.7;
    let mut e = pulled(&c);
    let (t0, p0, ke0, s0) = (e.time(), e.momentum(), e.kinetic_energy(), *e.stats());
    let mut t = t0;
    for _ in 0..20 {
        t += 0.1;
        assert!(e.run_until(t, 2_000_000), "stalled at t = {}", e.time());
        let p = e.momentum();
        let want = [p0[0] + 100.0 * (t - t0), p0[1]];
        for a in 0..2 {
            assert!(
                (p[a] - want[a]).abs() < 1e-10 * e.momentum_scale(),
                "t {t}: P {p:?}, want {want:?}"
            );
        }
        assert_eq!(e.worst_overlap(1e-10), None, "t {t}");
    }
    let s = *e.stats();
    assert!(s.lifts > s0.lifts, "the rule never acted: {s:?}");
    let ledger = (s.injected - s0.injected) - (s.dissipated - s0.dissipated)
        + (s.work - s0.work)
        + (s.lifted - s0.lifted);
    let ke = e.kinetic_energy();
    assert!(
        ((ke - ke0) - ledger).abs() < 1e-9 * ke.max(ke0),
        "dKE {} ledger {ledger}",
        ke - ke0
    );
}
