//! The intruder of paper I in the event loop: its exact path, the momentum
//! balance (Eq. 11), the energy ledger with the work of F, no overlaps, and
//! the configurations it cannot run in.

use crate::sim::config::{ForceMode, Intruder};
use crate::sim::engine::{Engine, Setup, rng_from_seed};
use crate::sim::model::intruder_path::Pull;
use crate::sim::{Drive, KickRate, SimConfig, initial_state, run};
use crate::traj::Schedule;

pub(super) fn quiet(_: crate::sim::Progress) {}

/// Paper I's bath (radius ratio 1.25, m_b = 25/16, eps = 0.9) with paper I's
/// intruder pulled by `force`.
pub(crate) fn bath(n: usize, phi: f64, gamma: f64, force: f64) -> SimConfig {
    SimConfig {
        n,
        phi,
        eps: 0.9,
        radius_ratio: 1.25,
        gamma,
        drive: if gamma > 0.0 {
            Drive::Single
        } else {
            Drive::NeighbourPairs
        },
        kick_rate: KickRate::Enskog { prefactor: 1.0 },
        intruder: Some(Intruder::paper(force)),
        relax_time: 2.0,
        samples: 20,
        schedule: Schedule {
            start: 8.0,
            origins: 0,
            origin_spacing: 0.0,
            lags: vec![],
        },
        ..SimConfig::default()
    }
}

/// A compressed engine with friction, driving and the force on, as `run`
/// starts it (kicks at the rate of an Enskog frequency of 5 per particle).
pub(super) fn pulled(c: &SimConfig) -> Engine {
    let mut e = initial_state::prepare(c, &quiet).unwrap();
    e.set_restitution(c.eps, c.collapse_tc);
    if c.gamma > 0.0 {
        e.set_friction(c.gamma);
    }
    let (kicks, rate, p_dr) = run::drive(c, 5.0);
    e.set_kicks(kicks, rate, p_dr);
    e.set_force(c.intruder.as_ref().unwrap().force).unwrap();
    assert_eq!(e.intruder(), Some(0));
    e
}

/// Mean of `v` and its standard error from the spread (independent seeds).
pub(super) fn mean_and_error(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    (m, (var / v.len() as f64).sqrt())
}

/// The intruder (radius 2, mass 4) and a small disk far from its path, in a
/// 100 x 100 periodic box.
pub(super) fn lone(v0: [f64; 2]) -> Engine {
    let setup = Setup {
        lx: 100.0,
        ly: 100.0,
        walls: [false, false],
        radii: vec![1.0, 2.0],
        masses: vec![1.0, 4.0],
        species: vec![1, 0],
        x: vec![10.0, 50.0],
        y: vec![20.0, 80.0],
        vx: vec![v0[0], 0.0],
        vy: vec![v0[1], 0.0],
    };
    let mut e = Engine::new(setup, 1.0, 0.0, rng_from_seed(1)).unwrap();
    e.set_intruder(0);
    e
}

/// A lone intruder follows x0 + v0 E(t) + (F/m0) G(t) and reaches the
/// terminal velocity F/(gamma m0), to 1e-10, through shell exits, periodic
/// wraps and re-anchorings of the friction clock; its work and friction
/// ledgers hold the kinetic energy it gained. At gamma = 0: v0 + F t / m0.
#[test]
fn lone_intruder_follows_the_analytic_path_to_terminal_velocity() {
    for (gamma, force) in [(1.0, 8.0), (0.5, 100.0), (0.0, 0.5)] {
        let v0 = [-1.5, 0.25];
        let mut e = lone(v0);
        e.set_friction(gamma);
        e.set_force(force).unwrap();
        let p = Pull {
            gamma,
            accel: force / 4.0,
        };
        let ke0 = e.kinetic_energy();
        for t in [0.01, 0.3, 2.0, 7.5, 30.0, 60.0] {
            assert!(e.run_until(t, 10_000_000));
            let (x, v) = e.particle(0);
            let (dx, vw) = (p.displacement(v0, t), p.velocity(v0, t));
            let want = [10.0 + dx[0], 20.0 + dx[1]];
            for a in 0..2 {
                assert!(
                    (x[a] - want[a]).abs() < 1e-10 * (1.0 + dx[a].abs()),
                    "gamma {gamma} t {t}: x {x:?} want {want:?}"
                );
                assert!(
                    (v[a] - vw[a]).abs() < 1e-10 * (1.0 + vw[a].abs()),
                    "gamma {gamma} t {t}: v {v:?} want {vw:?}"
                );
            }
            let gained = e.kinetic_energy() - ke0;
            let ledger = e.stats().work - e.stats().friction;
            assert!(
                (gained - ledger).abs() < 1e-10 * (ke0 + e.stats().work),
                "gamma {gamma} t {t}: gained {gained}, ledger {ledger}"
            );
        }
        if gamma > 0.0 {
            let vt = force / (gamma * 4.0);
            let v = e.particle(0).1;
            assert!((v[0] - vt).abs() < 1e-10 * vt, "{v:?} vs {vt}");
            assert!(e.stats().reanchors > 5, "{:?}", e.stats());
        }
        assert_eq!(e.stats().collisions, 0);
        assert!(e.stats().shell_exits > 10, "{:?}", e.stats());
    }
}

/// gamma = 0, pair kicks (momentum conserving): the total momentum is
/// P(0) + F t x to 1e-10 over a dense driven run with thousands of intruder
/// collisions; no overlap.
#[test]
fn momentum_grows_as_force_times_time_without_friction() {
    let c = bath(500, 0.6, 0.0, 10.0);
    let mut e = pulled(&c);
    let (t0, p0) = (e.time(), e.momentum());
    let mut t = t0;
    for _ in 0..40 {
        t += 0.1;
        assert!(e.run_until(t, 10_000_000));
        let p = e.momentum();
        let want = [p0[0] + 10.0 * (t - t0), p0[1]];
        let scale = e.momentum_scale();
        for a in 0..2 {
            assert!(
                (p[a] - want[a]).abs() < 1e-10 * scale,
                "t {t}: P {p:?}, want {want:?} (scale {scale})"
            );
        }
        assert!(
            e.worst_overlap(1e-10).is_none(),
            "{:?}",
            e.worst_overlap(1e-10)
        );
    }
    assert!(
        e.stats().collisions > 3000 && e.stats().kicks > 1000,
        "{:?}",
        *e.stats()
    );
}

/// gamma > 0, single kicks: Eq. (11) of paper I with the kicks,
/// P(t) = P(0) exp(-gamma t) + F (1 - exp(-gamma t)) / gamma x
/// + sum_k dp_k exp(-gamma (t - t_k)), to 1e-10, through re-anchorings.
#[test]
fn momentum_follows_eq_11_with_force_and_kicks() {
    let (gamma, force) = (1.0, 30.0);
    let c = bath(500, 0.6, gamma, force);
    let mut e = pulled(&c);
    let (t0, p0, k0) = (e.time(), e.momentum(), e.kick_momentum());
    let mut t = t0;
    for _ in 0..16 {
        t += 0.5;
        assert!(e.run_until(t, 10_000_000));
        let decay = (-gamma * (t - t0)).exp();
        let (p, k) = (e.momentum(), e.kick_momentum());
        let pulled = force * (1.0 - decay) / gamma;
        let want = [
            (p0[0] - k0[0]) * decay + pulled + k[0],
            (p0[1] - k0[1]) * decay + k[1],
        ];
        let scale = e.momentum_scale();
        for a in 0..2 {
            assert!(
                (p[a] - want[a]).abs() < 1e-10 * scale,
                "t {t}: P {p:?}, want {want:?} (scale {scale})"
            );
        }
    }
    assert!(e.stats().reanchors >= 2, "{:?}", e.stats());
    assert!(e.stats().kicks > 5000, "{:?}", e.stats());
}

/// Energy ledger: KE(t) - KE(0) = injected - dissipated - friction + work of F
/// plus the lifts of the resting-contact rule, to 1e-9 relative, with and
/// without friction.
#[test]
fn energy_ledger_with_the_work_of_the_force_closes() {
    for (gamma, force) in [(1.0, 100.0), (0.0, 10.0)] {
        let c = bath(500, 0.6, gamma, force);
        let mut e = pulled(&c);
        let (t0, ke0, s0) = (e.time(), e.kinetic_energy(), *e.stats());
        assert!(e.run_until(t0 + 5.0, 100_000_000));
        let s = *e.stats();
        let ke = e.kinetic_energy();
        let ledger = (s.injected - s0.injected)
            - (s.dissipated - s0.dissipated)
            - (s.friction - s0.friction)
            + (s.work - s0.work)
            + (s.lifted - s0.lifted);
        assert!(
            ((ke - ke0) - ledger).abs() < 1e-9 * ke.max(ke0),
            "gamma {gamma}: dKE {} ledger {ledger} ({s:?})",
            ke - ke0
        );
        assert!(s.work - s0.work > 0.0);
    }
}

/// No overlap (gap >= -1e-10 sigma) after every 100 events of dense runs at
/// large forces; the neighbour lists stay exact.
#[test]
fn no_overlap_at_large_force() {
    for force in [1e3, 1e4] {
        let c = bath(500, 0.6, 1.0, force);
        let mut e = pulled(&c);
        for k in 0..300 {
            e.run_until(f64::INFINITY, 100);
            if let Some(w) = e.worst_overlap(1e-10) {
                panic!("F = {force}, after {} events: overlap {w:?}", 100 * (k + 1));
            }
            if k % 50 == 0 {
                e.check_lists().unwrap();
            }
        }
        let v = e.particle(0).1[0];
        assert!(v > 1.0, "F = {force}: intruder at {v}");
        assert!(e.stats().collisions > 5000, "{:?}", e.stats());
    }
}

/// A full run: the intruder moves along the force, slower than alone; the
/// ledger closes; the bath drifts along the force; the summary says so.
#[test]
fn run_reports_the_intruder() {
    let c = bath(500, 0.5, 1.0, 10.0);
    let (_, s) = run(&c, &quiet).unwrap();
    let i = s.intruder.expect("intruder summary");
    assert_eq!(i.terminal_velocity, 2.5);
    assert!(
        i.velocity[0] > 0.05 && i.velocity[0] < 2.5,
        "{:?}",
        i.velocity
    );
    assert!(i.energy_work > 0.0);
    assert!(s.energy_balance_error < 1e-9, "{}", s.energy_balance_error);
    assert!(
        i.bath_drift.iter().all(|v| v.is_finite()),
        "{:?}",
        i.bath_drift
    );
    assert_eq!(i.predicted_drift, 10.0 / (4.0 + 250.0 * (1.0 + 1.5625)));
    assert_eq!(s.species_temperature.len(), 3);
    // The bath's temperature leaves the intruder out: near T = 1.
    assert!((s.temperature - 1.0).abs() < 0.3, "{}", s.temperature);
}

/// Compression to phi = 0.7 with the intruder present, in a channel (walls in
/// y), then pulled: no overlap, every centre between the walls.
#[test]
fn compression_with_intruder_and_walls() {
    let mut c = bath(600, 0.7, 1.0, 50.0);
    c.walls = [false, true];
    c.aspect = 0.5;
    let mut e = pulled(&c);
    let ly = c.box_size()[1];
    for k in 0..100 {
        e.run_until(f64::INFINITY, 200);
        assert!(
            e.worst_overlap(1e-10).is_none(),
            "after {k}: {:?}",
            e.worst_overlap(1e-10)
        );
        let (_, y) = e.unwrapped_positions();
        for (i, &yi) in y.iter().enumerate() {
            let r = e.radii()[e.species()[i] as usize];
            assert!(
                yi >= r - 1e-9 && yi <= ly - r + 1e-9,
                "disk {i} at y = {yi}"
            );
        }
    }
    assert!(e.stats().wall_collisions > 0);
    assert!(e.particle(0).1[0] > 0.0);
}

/// Impossible intruders are errors naming the key.
#[test]
fn invalid_intruders_name_the_key() {
    let err = |c: SimConfig| c.validate().unwrap_err().to_string();
    let mut c = bath(500, 0.6, 1.0, -1.0);
    assert!(
        err(c.clone()).contains("intruder.force = -1 is invalid"),
        "{}",
        err(c.clone())
    );
    c.intruder = Some(Intruder::paper(f64::NAN));
    assert!(err(c.clone()).contains("intruder.force = NaN"));
    c.intruder = Some(Intruder {
        radius: 30.0,
        ..Intruder::paper(1.0)
    });
    assert!(err(c.clone()).contains("intruder.radius = 30 is too large for the box"));
    c.intruder = Some(Intruder {
        mass: 0.0,
        ..Intruder::paper(1.0)
    });
    assert!(err(c.clone()).contains("intruder.mass = 0 is invalid"));
    c.intruder = Some(Intruder {
        kick_rate_factor: 0.5,
        ..Intruder::paper(1.0)
    });
    assert!(err(c.clone()).contains("intruder.kick_rate_factor = 0.5 is invalid"));
    // Pulled between walls in x (paper I figs 1-2): allowed; a start must
    // keep R_0 from the walls and lie in the box.
    c.walls = [true, true];
    c.intruder = Some(Intruder {
        start: Some([0.01, 0.5]),
        ..Intruder::paper(10.0)
    });
    assert!(
        err(c.clone()).contains("overlaps a wall of axis x"),
        "{}",
        err(c.clone())
    );
    c.intruder = Some(Intruder {
        start: Some([0.5, 1.0]),
        ..Intruder::paper(10.0)
    });
    assert!(err(c.clone()).contains("the y fraction 1 must be in [0, 1)"));
    c.intruder = Some(Intruder {
        start: Some([0.1, 0.5]),
        ..Intruder::paper(10.0)
    });
    c.validate().unwrap();
    // From YAML, R_0 and m_0 default to paper I's, the force is exact.
    let y: SimConfig = serde_saphyr::from_str("intruder: {force: 5}").unwrap();
    assert_eq!(y.intruder, Some(Intruder::paper(5.0)));
    let y: SimConfig = serde_saphyr::from_str(
        "intruder: {force: 5, force_mode: kicks, kick_rate_factor: 100, start: [0.1, 0.5]}",
    )
    .unwrap();
    let i = y.intruder.unwrap();
    assert_eq!(
        (i.force_mode, i.kick_rate_factor, i.start),
        (ForceMode::Kicks, 100.0, Some([0.1, 0.5]))
    );
}
