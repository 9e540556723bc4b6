//! Validation of the simulator against conservation laws, exact relations and
//! known equations of state. Each test fails if the physics is wrong.

use crate::sim::engine::Engine;
use crate::sim::{Drive, KickRate, SimConfig, initial_state, run};
use crate::traj::Schedule;

fn quiet(_: crate::sim::Progress) {}

fn cfg(n: usize, phi: f64, eps: f64) -> SimConfig {
    SimConfig {
        n,
        phi,
        eps,
        relax_time: 5.0,
        schedule: Schedule {
            start: 0.0,
            origins: 1,
            origin_spacing: 0.0,
            lags: vec![5.0],
        },
        ..SimConfig::default()
    }
}

fn monodisperse(n: usize, phi: f64) -> SimConfig {
    SimConfig {
        radius_ratio: 1.0,
        fraction_large: 0.0,
        drive: Drive::None,
        ..cfg(n, phi, 1.0)
    }
}

/// A compressed engine with the driving of `c` switched on.
fn driven_engine(c: &SimConfig) -> Engine {
    let mut e = initial_state::prepare(c, &quiet).unwrap();
    let (kicks, rate, p_dr) = crate::sim::run::drive(c, 15.0);
    e.set_restitution(c.eps, c.collapse_tc);
    e.set_kicks(kicks, rate, p_dr);
    e
}

#[test]
fn no_overlap_after_any_event_at_phi_0_8() {
    let c = cfg(300, 0.8, 0.9);
    let mut e = driven_engine(&c);
    assert!(e.worst_overlap(1e-9).is_none(), "overlap after compression");
    let (c0, s0) = (e.stats().collisions, e.stats().shell_exits);
    for ev in 0..100_000 {
        e.run_until(f64::INFINITY, 1);
        if let Some((i, j, ov)) = e.worst_overlap(1e-9) {
            panic!("event {ev}: disks {i} and {j} overlap by {ov:e} of their contact distance");
        }
        if ev % 1000 == 0
            && let Err(msg) = e.check_lists()
        {
            panic!("event {ev}: {msg}");
        }
    }
    let shell_exits = e.stats().shell_exits - s0;
    assert!(
        e.stats().collisions - c0 > (100_000 - shell_exits) / 2,
        "mostly collisions expected"
    );
    assert!(e.stats().kicks > 1000);
    assert!(shell_exits > 1000, "neighbour lists must be rebuilt");
}

#[test]
fn neighbour_lists_grow_when_full_and_stay_complete() {
    let c = cfg(300, 0.8, 0.9);
    let mut e = driven_engine(&c);
    // Lists of 5-6 disks do not fit in 1 slot: the rebuild doubles it until they do.
    e.set_list_capacity(1);
    assert!(e.list_capacity() >= 4, "capacity {}", e.list_capacity());
    for ev in 0..20_000 {
        e.run_until(f64::INFINITY, 1);
        if let Some((i, j, ov)) = e.worst_overlap(1e-9) {
            panic!("event {ev}: disks {i} and {j} overlap by {ov:e} of their contact distance");
        }
        if ev % 500 == 0
            && let Err(msg) = e.check_lists()
        {
            panic!("event {ev}: {msg}");
        }
    }
}

#[test]
fn elastic_gas_conserves_energy_and_momentum_over_a_million_collisions() {
    let mut c = cfg(2000, 0.7, 1.0);
    c.drive = Drive::None;
    c.collapse_tc = 1e-3; // must never act when eps = 1
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    e.set_restitution(e.eps(), c.collapse_tc);
    let (ke0, p0) = (e.kinetic_energy(), e.momentum());
    let scale = e.momentum_scale();
    let c0 = e.stats().collisions;
    while e.stats().collisions - c0 < 1_000_000 {
        e.run_until(f64::INFINITY, 100_000);
    }
    let (ke1, p1) = (e.kinetic_energy(), e.momentum());
    assert!(
        (ke1 - ke0).abs() / ke0 < 1e-10,
        "energy drift {:e}",
        (ke1 - ke0) / ke0
    );
    for k in 0..2 {
        assert!(
            (p1[k] - p0[k]).abs() / scale < 1e-10,
            "momentum drift {:e}",
            p1[k] - p0[k]
        );
    }
    assert_eq!(e.stats().guard_activations, 0);
    assert_eq!(e.stats().dissipated, 0.0);
}

#[test]
fn elastic_disks_follow_henderson_and_the_enskog_frequency_relation() {
    for (eta, time) in [(0.2f64, 500.0), (0.35, 150.0), (0.5, 40.0)] {
        let mut c = monodisperse(2000, eta);
        c.relax_time = 5.0;
        c.schedule.lags = vec![time];
        c.samples = 40;
        let (_, s) = run(&c, &quiet).unwrap();
        let henderson = (1.0 + eta * eta / 8.0) / (1.0 - eta).powi(2);
        let err = (s.z - henderson).abs();
        assert!(
            err < 0.01 * henderson && err < 0.01 * henderson + 3.0 * s.z_err,
            "eta {eta}: Z = {} +- {}, Henderson {henderson}",
            s.z,
            s.z_err
        );
        assert!(
            s.z_err < 0.004 * s.z,
            "eta {eta}: error bar {} too large to test 1%",
            s.z_err
        );
        // Exact for hard disks in equilibrium: omega = 4 (Z - 1) sqrt(T/(pi m)) / sigma.
        let omega = 4.0 * (s.z - 1.0) * (s.temperature / std::f64::consts::PI).sqrt() / 2.0;
        assert!(
            (s.collision_rate - omega).abs() < 0.01 * omega,
            "eta {eta}: collision rate {} vs 4(Z-1)sqrt(T/pi m)/sigma = {omega}",
            s.collision_rate
        );
        assert!(
            (s.temperature - 1.0).abs() < 1e-9,
            "elastic T must stay 1, got {}",
            s.temperature
        );
    }
}

#[test]
fn free_cooling_follows_haff_in_collisions_per_particle() {
    let eps: f64 = 0.9;
    let mut c = monodisperse(4000, 0.05);
    c.eps = eps;
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    e.set_restitution(eps, 0.0);
    let n = e.n() as f64;
    let t0 = e.kinetic_energy() / n;
    let c0 = e.stats().collisions;
    for target in [1.0, 2.0, 3.0, 4.0] {
        // tau = collisions per particle = 2 N_c / N.
        while 2.0 * (e.stats().collisions - c0) as f64 / n < target {
            e.run_until(f64::INFINITY, 1);
        }
        let tau = 2.0 * (e.stats().collisions - c0) as f64 / n;
        let t = e.kinetic_energy() / n;
        let haff = t0 * (-(1.0 - eps * eps) * tau / 2.0).exp();
        assert!(
            (t - haff).abs() < 0.02 * haff,
            "tau {tau}: T = {t}, Haff {haff}"
        );
    }
    assert_eq!(e.stats().kicks, 0);
}

#[test]
fn driven_steady_state_books_energy_exactly_and_holds_t_near_1() {
    let mut c = cfg(1500, 0.7, 0.9);
    c.relax_time = 20.0;
    c.schedule.lags = vec![20.0];
    let (_, s) = run(&c, &quiet).unwrap();
    assert!(
        s.energy_balance_error < 1e-9,
        "energy ledger off by {:e}",
        s.energy_balance_error
    );
    assert!(s.energy_injected > 0.0 && s.energy_dissipated > 0.0);
    assert!((s.temperature - 1.0).abs() < 0.05, "T = {}", s.temperature);
    let [a, b] = s.temperature_halves;
    assert!(
        (a - b).abs() < 4.0 * s.temperature_std.max(0.005),
        "T drifts: {a} then {b}"
    );
    // The balanced rule converges to about one pair kick per pair collision.
    assert!(
        (s.kick_rate / s.collision_rate - 1.0).abs() < 0.2,
        "{} vs {}",
        s.kick_rate,
        s.collision_rate
    );
}

#[test]
fn fixed_kick_rate_is_honoured() {
    let mut c = cfg(500, 0.5, 0.8);
    c.kick_rate = KickRate::PerParticle(4.0);
    c.drive = Drive::RandomPairs;
    let (_, s) = run(&c, &quiet).unwrap();
    // Poisson count over N t/2 expected kicks: 4 * 500 * 5 / 2 = 5000 +- 71.
    let expect = 4.0 * 500.0 * 5.0 / 2.0;
    assert!(
        (s.kicks as f64 - expect).abs() < 5.0 * expect.sqrt(),
        "{} kicks, expected {expect}",
        s.kicks
    );
}

#[test]
fn same_seed_same_bits_different_seed_different_frames() {
    let mut c = cfg(400, 0.75, 0.9);
    c.schedule = Schedule {
        start: 0.0,
        origins: 3,
        origin_spacing: 2.0,
        lags: Schedule::log_lags(0.1, 1.0, 3),
    };
    let (a, _) = run(&c, &quiet).unwrap();
    let (b, _) = run(&c, &quiet).unwrap();
    let bits = |t: &crate::traj::Trajectory| -> Vec<u64> {
        t.frames
            .iter()
            .flat_map(|f| f.x.iter().chain(&f.y).map(|v| v.to_bits()))
            .collect()
    };
    assert_eq!(a.frames.len(), c.schedule.times().len());
    assert_eq!(bits(&a), bits(&b));
    c.seed = 1;
    let (d, _) = run(&c, &quiet).unwrap();
    assert_ne!(bits(&a), bits(&d));
    // Unwrapped: consecutive frames never jump by a box length.
    for w in a.frames.windows(2) {
        let dt = w[1].time - w[0].time;
        for i in 0..a.n() {
            let d = (w[1].x[i] - w[0].x[i]).hypot(w[1].y[i] - w[0].y[i]);
            assert!(d < 10.0 * dt.max(0.1), "particle {i} jumped {d} in {dt}");
        }
    }
    assert!((a.packing_fraction() - 0.75).abs() < 1e-12);
}

#[test]
fn invalid_configs_are_named() {
    let d = SimConfig::default;
    let cases = [
        (SimConfig { phi: 0.95, ..d() }, "phi = 0.95"),
        (SimConfig { eps: 0.0, ..d() }, "eps = 0"),
        (SimConfig { eps: 1.5, ..d() }, "(0, 1]"),
        (SimConfig { n: 1, ..d() }, "n = 1"),
        (SimConfig { gamma: -0.1, ..d() }, "gamma = -0.1 is invalid"),
        (
            SimConfig {
                walls: [true, false],
                n: 200,
                aspect: 100.0,
                ..d()
            },
            "cannot fit",
        ),
    ];
    let mut empty = d();
    empty.schedule.lags.clear();
    empty.schedule.origins = 1;
    let few_samples = SimConfig { samples: 1, ..d() };
    let extra = [(empty, "records nothing"), (few_samples, "samples = 1")];
    for (c, expect) in cases.into_iter().chain(extra) {
        let msg = c.validate().unwrap_err().to_string();
        assert!(msg.contains(expect), "`{msg}` should name `{expect}`");
    }
    SimConfig::default().validate().unwrap();
    let unknown = serde_json::from_str::<SimConfig>(r#"{"n": 10, "phii": 0.5}"#).unwrap_err();
    assert!(unknown.to_string().contains("phii"));
    // Too few disks for a 3x3 cell list is an error, not a panic.
    let small = SimConfig {
        n: 4,
        ..cfg(4, 0.7, 0.9)
    };
    assert!(
        run(&small, &quiet)
            .unwrap_err()
            .to_string()
            .contains("3 cells")
    );
}

#[test]
fn config_round_trips_and_reads_yaml() {
    let c = SimConfig::default();
    let back: SimConfig = serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
    assert_eq!(back, c);
    let y: SimConfig = serde_saphyr::from_str(
        "n: 500\nphi: 0.7\nmasses: {ratio: 3.0}\ndrive: random_pairs\nkick_rate: {per_particle: 2.5}\n",
    )
    .unwrap();
    assert_eq!(y.n, 500);
    assert_eq!(y.masses, crate::sim::Masses::Ratio(3.0));
    assert_eq!(y.drive, Drive::RandomPairs);
    assert_eq!(y.kick_rate, KickRate::PerParticle(2.5));
    assert_eq!(y.species_masses(), vec![1.0, 3.0]);
    let none: SimConfig = serde_saphyr::from_str("drive: none\nkick_rate: balanced\n").unwrap();
    assert_eq!(none.drive, Drive::None);
}

#[test]
fn a_schedule_without_origins_runs_for_its_start_time_and_records_nothing() {
    let mut c = cfg(300, 0.5, 0.9);
    c.relax_time = 1.0;
    c.schedule = Schedule {
        start: 2.0,
        origins: 0,
        origin_spacing: 0.0,
        lags: vec![],
    };
    let (traj, s) = run(&c, &quiet).unwrap();
    assert!(traj.frames.is_empty());
    assert_eq!(s.sim_time, 2.0);
    assert!(s.collisions > 0);
    c.schedule.start = 0.0;
    let err = run(&c, &quiet).unwrap_err().to_string();
    assert!(err.contains("schedule.origins = 0"), "{err}");
}
