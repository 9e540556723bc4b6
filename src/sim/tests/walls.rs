//! Hard walls: an elastic gas in a closed box conserves energy, shares it
//! equally between species and directions, obeys the virial theorem exactly,
//! and pushes on the walls with its virial pressure; disks never cross a wall.

use crate::sim::{Drive, KickRate, SimConfig, initial_state, run};
use crate::traj::Schedule;

fn quiet(_: crate::sim::Progress) {}

fn boxed(n: usize, phi: f64, walls: [bool; 2]) -> SimConfig {
    SimConfig {
        n,
        phi,
        eps: 1.0,
        drive: Drive::None,
        walls,
        relax_time: 5.0,
        samples: 100,
        schedule: Schedule {
            start: 0.0,
            origins: 1,
            origin_spacing: 0.0,
            lags: vec![30.0],
        },
        ..SimConfig::default()
    }
}

/// Virial theorem, exact for impulsive forces: the change of G = sum m r . v
/// over [0, t] is 2 K t (K constant, elastic) plus the sum of r . dp over the
/// pair collisions and over the wall collisions.
#[test]
fn closed_elastic_box_obeys_the_virial_theorem_exactly() {
    let c = boxed(800, 0.5, [true, true]);
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    e.set_restitution(1.0, e.tc());
    let g = |e: &crate::sim::engine::Engine| {
        let ((x, y), (vx, vy)) = (e.unwrapped_positions(), e.velocities());
        (0..e.n())
            .map(|i| e.masses()[e.species()[i] as usize] * (x[i] * vx[i] + y[i] * vy[i]))
            .sum::<f64>()
    };
    let (g0, k, t0, s0) = (g(&e), e.kinetic_energy(), e.time(), *e.stats());
    e.run_until(t0 + 20.0, u64::MAX);
    let t = e.time() - t0;
    let lhs = g(&e) - g0;
    let rhs =
        2.0 * k * t + (e.stats().virial - s0.virial) + (e.stats().wall_virial - s0.wall_virial);
    assert!(
        e.stats().wall_collisions - s0.wall_collisions > 500,
        "{} wall collisions",
        e.stats().wall_collisions - s0.wall_collisions
    );
    assert!(
        (lhs - rhs).abs() < 1e-9 * (2.0 * k * t),
        "dG = {lhs}, 2Kt + virials = {rhs}"
    );
    assert!((e.kinetic_energy() - k).abs() < 1e-10 * k);
    assert!(e.worst_overlap(1e-9).is_none());
    // Directions: the walls reflect x and y alike, so the kinetic energy splits
    // evenly (a single snapshot of 800 disks: within 15%).
    let (vx, vy) = e.velocities();
    let m = |i: usize| e.masses()[e.species()[i] as usize];
    let kx: f64 = (0..e.n()).map(|i| m(i) * vx[i] * vx[i]).sum();
    let ky: f64 = (0..e.n()).map(|i| m(i) * vy[i] * vy[i]).sum();
    assert!((kx / ky - 1.0).abs() < 0.15, "{kx} vs {ky}");
}

/// The elastic gas between walls: energy conserved, equipartition between
/// species and directions, and the same pressure on every wall as the virial
/// pressure of the bulk (within statistics and the O(r/L) offset of the
/// centres' box).
#[test]
fn elastic_gas_in_a_box_has_equipartition_and_its_virial_pressure_on_the_walls() {
    let c = boxed(3000, 0.5, [true, true]);
    let (_, s) = run(&c, &quiet).unwrap();
    assert!(s.energy_balance_error < 1e-10, "{}", s.energy_balance_error);
    assert_eq!(s.kicks, 0);
    let t = s.temperature;
    for (k, ts) in s.species_temperature.iter().enumerate() {
        assert!((ts / t - 1.0).abs() < 0.02, "species {k}: {ts} vs {t}");
    }
    let [px, py] = s.wall_pressure;
    assert!((px / py - 1.0).abs() < 0.03, "x walls {px}, y walls {py}");
    let [lx, ly] = c.box_size();
    let p_virial = s.z * c.n as f64 * t / (lx * ly);
    let p_wall = 0.5 * (px + py);
    assert!(
        (p_wall / p_virial - 1.0).abs() < 0.05,
        "walls {p_wall}, virial {p_virial}"
    );
}

/// Compression against the walls, then paper I's driving with friction in a
/// channel (walls in y): no overlap, no disk beyond a wall, after every event.
#[test]
fn driven_channel_with_friction_keeps_every_disk_between_the_walls() {
    let c = SimConfig {
        eps: 0.9,
        gamma: 1.0,
        radius_ratio: 1.25,
        drive: Drive::Single,
        kick_rate: KickRate::Enskog { prefactor: 1.0 },
        aspect: 0.5,
        ..boxed(400, 0.8, [false, true])
    };
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    e.set_restitution(c.eps, c.collapse_tc);
    e.set_friction(c.gamma);
    let (kicks, rate, p_dr) = crate::sim::run::drive(&c, 20.0);
    e.set_kicks(kicks, rate, p_dr);
    let ly = c.box_size()[1];
    for ev in 0..50_000 {
        e.run_until(f64::INFINITY, 1);
        if ev % 50 == 0 {
            if let Some((i, j, ov)) = e.worst_overlap(1e-9) {
                panic!("event {ev}: {i} and {j} overlap by {ov:e}");
            }
            let (_, y) = e.unwrapped_positions();
            for (i, &yi) in y.iter().enumerate() {
                let r = e.radii()[e.species()[i] as usize];
                assert!(
                    yi >= r * (1.0 - 1e-9) && yi <= ly - r * (1.0 - 1e-9),
                    "event {ev}: disk {i} at y = {yi} outside [{r}, {}]",
                    ly - r
                );
            }
        }
    }
    assert!(e.stats().wall_collisions > 500 && e.stats().collisions > 10_000);
}

#[test]
fn walls_that_cannot_fit_are_named() {
    let c = SimConfig {
        aspect: 0.01,
        ..boxed(400, 0.8, [false, true])
    };
    let msg = c.validate().unwrap_err().to_string();
    assert!(
        msg.contains("cannot fit") && msg.contains("axis y"),
        "{msg}"
    );
}
