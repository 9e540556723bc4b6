//! The intruder pulled along x between walls in x (paper I, figs 1-2): the
//! wall times of its curved path, its bounces against the analytic solution,
//! no escape through the wall, rest on the wall under friction, the energy
//! ledger; and a chosen start position.

use super::intruder::{bath, pulled};
use crate::sim::config::Intruder;
use crate::sim::engine::{Engine, Setup, rng_from_seed};
use crate::sim::model::intruder_path::Pull;
use crate::sim::{Drive, KickRate, initial_state};

/// The intruder (radius 2, mass 4) at rest at x = 50 and a small disk far
/// from its path, in a 100 x 100 box with walls at x = 0 and 100.
fn boxed() -> Engine {
    let setup = Setup {
        lx: 100.0,
        ly: 100.0,
        walls: [true, false],
        radii: vec![1.0, 2.0],
        masses: vec![1.0, 4.0],
        species: vec![1, 0],
        x: vec![50.0, 10.0],
        y: vec![50.0, 90.0],
        vx: vec![0.0, 0.0],
        vy: vec![0.0, 0.0],
    };
    let mut e = Engine::new(setup, 1.0, 0.0, rng_from_seed(1)).unwrap();
    e.set_intruder(0);
    e
}

/// The first tau in (lo, hi] where f changes sign from positive, by bisection.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    hi
}

/// The analytic bounces: from rest at gap `d` below the wall, the times of
/// the first `n` wall hits and the arrival speeds (elastic reflection).
fn bounces(p: Pull, d: f64, n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let t1 = bisect(|t| d - p.g(t) * p.accel, 0.0, 100.0);
    let mut t = t1;
    let mut v = p.velocity([0.0, 0.0], t1)[0];
    out.push((t, v));
    for _ in 1..n {
        // Rebound at -v: back at the wall when -v E + a G = 0 again; the
        // apex is at least v / (a + gamma v) later.
        let apex = v / (p.accel + p.gamma * v);
        let tau = bisect(|s| -(-v * p.e(s) + p.accel * p.g(s)), apex, 100.0);
        t += tau;
        v = p.velocity([-v, 0.0], tau)[0];
        out.push((t, v));
    }
    out
}

/// A lone intruder pulled against the wall: the wall hits come at the
/// analytic times (gamma = 0: periodic, t_k = (2k - 1) t_1; gamma > 0:
/// shrinking), its position between hits is the analytic path, it never
/// passes the wall, and the ledger closes (work of F = kinetic energy gained
/// plus friction plus what the rest on the wall absorbed). With friction it ends
/// at rest on the wall, the wall holding F.
#[test]
fn lone_intruder_bounces_on_the_wall_as_the_analytic_solution() {
    for (gamma, force) in [(0.0, 100.0), (1.0, 100.0), (0.5, 8.0)] {
        let mut e = boxed();
        e.set_friction(gamma);
        e.set_force(force).unwrap();
        let p = Pull {
            gamma,
            accel: force / 4.0,
        };
        let hi = 100.0 - 2.0;
        let hits = bounces(p, hi - 50.0, 6);
        let mut prev = 0.0;
        for (k, &(tk, vk)) in hits.iter().enumerate() {
            // Just before and just after the k-th hit.
            for (t, n) in [(tk - 1e-7 * tk, k), (tk + 1e-7 * tk, k + 1)] {
                assert!(e.run_until(t, 10_000_000));
                assert_eq!(e.stats().wall_collisions, n as u64, "gamma {gamma}: t {t}");
            }
            // Midway to the next hit: on the path of the rebound.
            let tm = tk + 0.37 * (hits.get(k + 1).map_or(tk + 1.0, |h| h.0) - tk);
            assert!(e.run_until(tm, 10_000_000));
            let (x, v) = e.particle(0);
            let want = hi + p.displacement([-vk, 0.0], tm - tk)[0];
            let vwant = p.velocity([-vk, 0.0], tm - tk)[0];
            assert!(
                (x[0] - want).abs() < 1e-7 * hi && (v[0] - vwant).abs() < 1e-7 * (1.0 + vk),
                "gamma {gamma} hit {k}: x {} v {} want {want} {vwant}",
                x[0],
                v[0]
            );
            assert!(tk > prev);
            prev = tk;
        }
        if gamma == 0.0 {
            // Elastic and frictionless: a periodic motion, t_k = (2k - 1) t_1.
            for (k, &(tk, vk)) in hits.iter().enumerate() {
                assert!((tk - (2 * k + 1) as f64 * hits[0].0).abs() < 1e-9 * tk);
                assert!((vk - hits[0].1).abs() < 1e-9 * vk);
            }
        }
        // Long after: never past the wall, and with friction at rest on it.
        let (ke0, mut t) = (0.0, prev);
        for _ in 0..200 {
            t += 0.25;
            assert!(e.run_until(t, 100_000_000));
            let x = e.particle(0).0[0];
            assert!(
                (2.0..=hi * (1.0 + 1e-12)).contains(&x),
                "gamma {gamma}: x {x}"
            );
        }
        let s = *e.stats();
        let ke = e.particle_kinetic_energy(0);
        let ledger = s.work - s.friction - s.dissipated;
        assert!(
            ((ke - ke0) - ledger).abs() < 1e-9 * s.work,
            "gamma {gamma}: KE {ke} ledger {ledger} ({s:?})"
        );
        if gamma > 0.0 {
            assert!(e.intruder_resting(), "gamma {gamma}: {s:?}");
            assert_eq!(e.particle(0).1, [0.0, 0.0]);
            assert!((e.particle(0).0[0] - hi).abs() < 1e-8 * hi);
            assert!(s.wall_collisions < 20_000, "{s:?}");
            eprintln!(
                "gamma {gamma} F {force}: {} wall hits, {} root steps",
                s.wall_collisions, s.root_steps
            );
            // Resting, the wall holds F: impulse F per unit time.
            let (w0, t0) = (e.stats().wall_impulse[0], e.time());
            assert!(e.run_until(t0 + 10.0, 1_000_000));
            let held = e.stats().wall_impulse[0] - w0;
            assert!((held - 10.0 * force).abs() < 1e-9 * held, "{held}");
            assert_eq!(e.stats().work, s.work);
        } else {
            assert!(!e.intruder_resting());
            assert_eq!(s.dissipated, 0.0);
        }
    }
}

/// Paper I's figs 1-2: walls on four sides, the intruder started at the left
/// end, at rest (held there during the compression), then pulled to the
/// right by F = 500 through a cold bath (T = 0.1, gamma = 0): it starts
/// where asked, never overlaps, never leaves the box, and reaches the right
/// wall; the ledger closes.
#[test]
fn chosen_start_between_four_walls() {
    let mut c = bath(600, 0.7, 0.0, 500.0);
    c.walls = [true, true];
    c.aspect = 0.5;
    c.temperature = 0.1;
    c.drive = Drive::NeighbourPairs;
    c.kick_rate = KickRate::Enskog { prefactor: 1.0 };
    c.intruder = Some(Intruder {
        start: Some([0.1, 0.5]),
        ..Intruder::paper(500.0)
    });
    c.validate().unwrap();
    let [lx, ly] = c.box_size();
    let e0 = initial_state::prepare(&c, &super::intruder::quiet).unwrap();
    let (x0, v0) = e0.particle(0);
    assert!(
        (x0[0] - 0.1 * lx).abs() < 1e-6 && (x0[1] - 0.5 * ly).abs() < 1e-6,
        "{x0:?} vs {:?}",
        [0.1 * lx, 0.5 * ly]
    );
    assert_eq!(v0, [0.0, 0.0]);
    assert_eq!(e0.particle_kinetic_energy(0), 0.0);
    assert!(e0.worst_overlap(1e-10).is_none());
    let mut e = pulled(&c);
    let (t0, ke0, s0) = (e.time(), e.kinetic_energy(), *e.stats());
    let mut reached = false;
    for k in 0..300 {
        e.run_until(f64::INFINITY, 1000);
        assert!(
            e.worst_overlap(1e-10).is_none(),
            "after {k}: {:?}",
            e.worst_overlap(1e-10)
        );
        let (x, y) = e.unwrapped_positions();
        for i in 0..x.len() {
            let r = e.radii()[e.species()[i] as usize];
            assert!(
                x[i] >= r - 1e-9
                    && x[i] <= lx - r + 1e-9
                    && y[i] >= r - 1e-9
                    && y[i] <= ly - r + 1e-9,
                "after {k}: disk {i} at ({}, {})",
                x[i],
                y[i]
            );
        }
        reached |= x[0] > lx - 2.0 - 0.5;
    }
    assert!(
        reached,
        "the intruder never reached the right wall: x = {:?}",
        e.particle(0)
    );
    let s = *e.stats();
    let ke = e.kinetic_energy();
    let ledger = (s.injected - s0.injected) - (s.dissipated - s0.dissipated)
        + (s.work - s0.work)
        + (s.lifted - s0.lifted);
    assert!(
        ((ke - ke0) - ledger).abs() < 1e-9 * (ke.max(ke0) + s.work - s0.work),
        "dKE {} ledger {ledger}",
        ke - ke0
    );
    assert!(e.time() > t0);
}

/// Frames carry velocities when asked (figs 1-2 need the velocity field):
/// one per particle in every frame, the intruder's along the force; none by
/// default (paper H's frames unchanged).
#[test]
fn frames_carry_velocities_when_asked() {
    let mut c = bath(400, 0.5, 1.0, 50.0);
    c.relax_time = 1.0;
    c.schedule = crate::traj::Schedule {
        start: 0.0,
        origins: 1,
        origin_spacing: 1.0,
        lags: vec![0.5, 1.0],
    };
    let (t, _) = crate::sim::run(&c, &super::intruder::quiet).unwrap();
    assert!(t.frames.iter().all(|f| f.vx.is_empty() && f.vy.is_empty()));
    c.record_velocities = true;
    let (tv, _) = crate::sim::run(&c, &super::intruder::quiet).unwrap();
    assert_eq!(tv.frames.len(), t.frames.len());
    for (f, g) in tv.frames.iter().zip(&t.frames) {
        assert_eq!(f.vx.len(), 401);
        assert_eq!(f.vy.len(), 401);
        // Recording does not change the trajectory.
        assert_eq!(f.x, g.x);
        // The intruder (particle 0) moves along the force.
        assert!(f.vx[0] > 0.0, "{}", f.vx[0]);
    }
}
