//! Viscous friction (paper I) against its exact solutions: a free disk, a
//! head-on pair at the edge of its reach, the map t -> s of an undriven run,
//! the dilute driven gas and the energy ledger.

use crate::sim::engine::{Engine, Setup, rng_from_seed};
use crate::sim::{Drive, KickRate, SimConfig, initial_state, run};
use crate::traj::Schedule;

fn quiet(_: crate::sim::Progress) {}

/// Two unit disks (mass 1) in a 100 x 100 periodic box.
fn two_disks(x: [f64; 2], vx: [f64; 2]) -> Engine {
    let setup = Setup {
        lx: 100.0,
        ly: 100.0,
        walls: [false, false],
        radii: vec![1.0],
        masses: vec![1.0],
        species: vec![0, 0],
        x: x.to_vec(),
        y: vec![50.0, 50.0],
        vx: vx.to_vec(),
        vy: vec![0.0, 0.0],
    };
    Engine::new(setup, 1.0, 0.0, rng_from_seed(1)).unwrap()
}

/// v = v0 exp(-gamma t), x = x0 + v0 (1 - exp(-gamma t)) / gamma, stopping at
/// x0 + v0 / gamma; the friction ledger holds the lost kinetic energy.
#[test]
fn free_disk_decays_and_stops_at_v0_over_gamma() {
    let (gamma, v0, x0) = (0.5, 3.0, 20.0);
    // The other disk sits out of the way (y differs by 0; x far behind).
    let mut e = two_disks([x0, 80.0], [v0, 0.0]);
    e.set_friction(gamma);
    let ke0 = e.kinetic_energy();
    for t in [0.5, 2.0, 7.0, 30.0, 100.0] {
        assert!(e.run_until(t, u64::MAX));
        assert_eq!(e.time(), t);
        let v = e.velocities().0[0];
        let want = v0 * (-gamma * t).exp();
        assert!(
            (v - want).abs() <= 1e-12 * v0,
            "t = {t}: v = {v}, want {want}"
        );
        let x = e.unwrapped_positions().0[0];
        let want = x0 + v0 * (1.0 - (-gamma * t).exp()) / gamma;
        assert!(
            (x - want).abs() < 1e-12 * x0,
            "t = {t}: x = {x}, want {want}"
        );
        let lost = ke0 - e.kinetic_energy();
        assert!((e.stats().friction - lost).abs() < 1e-12 * ke0);
    }
    assert!((e.unwrapped_positions().0[0] - (x0 + v0 / gamma)).abs() < 1e-12 * x0);
    assert!(
        e.stats().reanchors >= 20,
        "re-anchored {}",
        e.stats().reanchors
    );
    assert_eq!(e.stats().collisions, 0);
}

/// Disk 0 approaches disk 1 (at rest) with speed g across a surface gap d:
/// they touch at t = -ln(1 - gamma d / g) / gamma if d < g / gamma, never
/// otherwise. At d = (1 -/+ 1e-9) g / gamma: at 20.72 / gamma, or never.
#[test]
fn head_on_pair_just_inside_and_just_outside_reach() {
    let (gamma, g) = (1.0, 2.0);
    for (rel, hits) in [(1.0 - 1e-9, true), (1.0 + 1e-9, false)] {
        let d = rel * g / gamma;
        let mut e = two_disks([30.0, 30.0 + 2.0 + d], [g, 0.0]);
        e.set_friction(gamma);
        while e.stats().collisions == 0 && e.time() < 60.0 {
            e.run_until(60.0, 1);
        }
        if hits {
            let want = -(1.0 - gamma * d / g).ln() / gamma;
            assert!((want - 20.72).abs() < 0.01);
            assert_eq!(e.stats().collisions, 1, "gap {d}: no collision");
            assert!(
                (e.time() - want).abs() < 1e-3,
                "collided at {}, want {want}",
                e.time()
            );
        } else {
            assert_eq!(e.stats().collisions, 0, "gap {d}: collided at {}", e.time());
            // The gap left is (rel - 1) g / gamma + (g / gamma) exp(-gamma t).
            let (x, _) = e.unwrapped_positions();
            let gap = x[1] - x[0] - 2.0;
            assert!(gap > 0.0 && gap < 1e-8, "gap {gap}");
        }
    }
}

/// Guard off and undriven, friction changes only the clock: the run with
/// gamma > 0 up to time t is the frictionless run up to s(t), event for event,
/// with velocities scaled by lambda = 1 - gamma s.
#[test]
fn undriven_friction_run_is_the_frictionless_run_in_s() {
    let c = SimConfig {
        n: 600,
        phi: 0.6,
        eps: 0.8,
        collapse_tc: 0.0,
        ..SimConfig::default()
    };
    let gamma = 2.0;
    let mut a = initial_state::prepare(&c, &quiet).unwrap();
    let mut b = initial_state::prepare(&c, &quiet).unwrap();
    for e in [&mut a, &mut b] {
        e.set_restitution(c.eps, 0.0);
    }
    let t0 = a.time();
    // Anchor both clocks here (s = 0 now), the second with friction.
    a.set_friction(0.0);
    b.set_friction(gamma);
    // Stay below lambda = 1/8 (no re-anchoring: s is the same number in both).
    let s = 0.4;
    let t = t0 - (1.0 - gamma * s).ln() / gamma;
    a.run_until(t0 + s, u64::MAX);
    b.run_until(t, u64::MAX);
    assert_eq!(b.stats().reanchors, 0);
    assert!(a.stats().collisions > 1000, "{}", a.stats().collisions);
    assert_eq!(a.stats().collisions, b.stats().collisions);
    assert_eq!(a.stats().shell_exits, b.stats().shell_exits);
    let lam = 1.0 - gamma * s;
    let ((xa, ya), (xb, yb)) = (a.unwrapped_positions(), b.unwrapped_positions());
    let ((ua, wa), (vb, zb)) = (a.velocities(), b.velocities());
    for i in 0..c.n {
        assert!((xa[i] - xb[i]).abs() < 1e-9 && (ya[i] - yb[i]).abs() < 1e-9);
        assert!((ua[i] * lam - vb[i]).abs() < 1e-9 && (wa[i] * lam - zb[i]).abs() < 1e-9);
    }
    let diss = a.stats().dissipated;
    assert!(b.stats().dissipated < diss && b.stats().dissipated > lam * lam * diss);
}

fn paper_i(n: usize, phi: f64, eps: f64, gamma: f64) -> SimConfig {
    SimConfig {
        n,
        phi,
        eps,
        gamma,
        radius_ratio: 1.25,
        drive: Drive::Single,
        kick_rate: KickRate::Enskog { prefactor: 1.0 },
        relax_time: 5.0,
        samples: 200,
        schedule: Schedule {
            start: 0.0,
            origins: 1,
            origin_spacing: 0.0,
            lags: vec![20.0],
        },
        ..SimConfig::default()
    }
}

/// A dilute gas kicked at rate f per particle against friction: each species
/// holds T_i = f p_dr^2 / (2 gamma m_i) (collisions are too rare to matter).
#[test]
fn dilute_driven_gas_holds_the_friction_temperature_per_species() {
    let f = 0.1;
    let c = SimConfig {
        kick_rate: KickRate::PerParticle(f),
        ..paper_i(4000, 0.001, 1.0, 1.0)
    };
    let (_, s) = run(&c, &quiet).unwrap();
    let masses = c.species_masses();
    assert!(
        s.collision_rate < 0.01 * c.gamma,
        "not dilute: {}",
        s.collision_rate
    );
    for (k, m) in masses.iter().enumerate() {
        let want = f * s.kick_amplitude.powi(2) / (2.0 * c.gamma * m);
        let got = s.species_temperature[k];
        assert!(
            (got / want - 1.0).abs() < 0.03,
            "species {k}: T = {got}, want {want}"
        );
    }
    assert!(s.energy_balance_error < 1e-9, "{}", s.energy_balance_error);
}

/// A dense driven run with friction: the ledger (kicks in, collisions and
/// friction out) closes on the kinetic energy, and Eq. (7) holds T near its target.
#[test]
fn dense_driven_run_with_friction_closes_its_energy_ledger() {
    let c = paper_i(1000, 0.6, 0.9, 1.0);
    let (_, s) = run(&c, &quiet).unwrap();
    assert!(s.collisions > 40_000 && s.kicks > 40_000, "{s:?}");
    assert!(s.energy_friction > 0.0 && s.energy_dissipated > 0.0);
    assert!(s.energy_balance_error < 1e-9, "{}", s.energy_balance_error);
    // Eq. (7) is a mean-field balance: T within 25% of the target.
    assert!((s.temperature - 1.0).abs() < 0.25, "T = {}", s.temperature);
}

/// Eq. (11) of paper I without the force: collisions conserve momentum and
/// friction decays it, so P(t) = P(0) exp(-gamma t) + sum_k dp_k exp(-gamma (t - t_k))
/// over the single kicks, exactly (through re-anchorings).
#[test]
fn momentum_decays_as_eq_11_plus_the_decayed_kicks() {
    let c = paper_i(1000, 0.6, 0.9, 1.0);
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    e.set_restitution(c.eps, c.collapse_tc);
    e.set_friction(c.gamma);
    let (kicks, rate, p_dr) = crate::sim::run::drive(&c, 4.9);
    e.set_kicks(kicks, rate, p_dr);
    let (p0, t0) = (e.momentum(), e.time());
    for dt in [0.5, 3.0, 10.0] {
        e.run_until(t0 + dt, u64::MAX);
        let (p, k) = (e.momentum(), e.kick_momentum());
        let decay = (-c.gamma * dt).exp();
        let scale = e.momentum_scale();
        for a in 0..2 {
            let want = p0[a] * decay + k[a];
            assert!(
                (p[a] - want).abs() < 1e-10 * scale,
                "t = {dt}, axis {a}: P = {}, Eq. (11) {want}",
                p[a]
            );
        }
    }
    assert!(e.stats().reanchors >= 4 && e.stats().kicks > 40_000 && e.stats().collisions > 40_000);
}

#[test]
fn impossible_friction_settings_are_named() {
    let bad = |c: SimConfig| c.validate().unwrap_err().to_string();
    let c = paper_i(1000, 0.6, 0.9, 1.0);
    assert!(
        bad(SimConfig {
            gamma: -1.0,
            ..c.clone()
        })
        .starts_with("gamma = -1 is invalid")
    );
    assert!(
        bad(SimConfig {
            gamma: 0.0,
            ..c.clone()
        })
        .starts_with("drive: single with gamma = 0")
    );
    assert!(
        bad(SimConfig {
            kick_rate: KickRate::Balanced,
            ..c.clone()
        })
        .starts_with("kick_rate: balanced with gamma = 1")
    );
    assert!(
        bad(SimConfig {
            temperature: 0.0,
            ..c
        })
        .starts_with("temperature = 0 is invalid")
    );
}
