//! The force as paper I applies it, a train of momentum kicks F dt
//! (`force_mode: kicks`), against the exact force: the lone intruder's path
//! converges as the kick rate grows, its terminal velocity and the work
//! ledger are exact, the momentum balance holds kick by kick, and in a bath
//! both modes give the same mean velocity.

use super::intruder::{bath, lone, mean_and_error, quiet};
use crate::sim::config::{ForceMode, Intruder};
use crate::sim::model::intruder_path::Pull;
use crate::sim::{initial_state, run};

/// Position error at time `t` of a lone intruder pushed by kicks every `dt`,
/// against the exact path; also checks the work ledger.
fn lone_kicks_error(gamma: f64, force: f64, dt: f64, t: f64) -> f64 {
    let v0 = [-1.5, 0.25];
    let mut e = lone(v0);
    e.set_friction(gamma);
    e.set_force_kicks(force, dt).unwrap();
    let ke0 = e.kinetic_energy();
    assert!(e.run_until(t, 100_000_000));
    let p = Pull {
        gamma,
        accel: force / 4.0,
    };
    let (x, _) = e.particle(0);
    let dx = p.displacement(v0, t);
    let gained = e.kinetic_energy() - ke0;
    let ledger = e.stats().work - e.stats().friction;
    assert!(
        (gained - ledger).abs() < 1e-10 * (ke0 + e.stats().work),
        "gamma {gamma} dt {dt}: gained {gained}, ledger {ledger}"
    );
    let kicks = e.force_kicks();
    assert_eq!(kicks, (t / dt + 0.5).floor() as u64, "dt {dt}");
    ((x[0] - 10.0 - dx[0]).powi(2) + (x[1] - 20.0 - dx[1]).powi(2)).sqrt()
}

/// A lone intruder pushed by kicks: the path converges to the exact one as
/// the kick rate grows (at least as 1/rate; the kicks sit mid-interval, so
/// measured ~1/rate^2), at gamma = 0 it is exact at the kick boundaries, the
/// time-averaged velocity is the terminal F/(gamma m0) for any rate, and
/// every kick's work is in the ledger (checked in `lone_kicks_error`).
#[test]
fn lone_intruder_kicks_converge_to_the_exact_path() {
    for (gamma, force) in [(1.0, 8.0), (0.5, 100.0)] {
        for t in [3.0037, 7.5] {
            let errs: Vec<f64> = [1e-2, 2.5e-3, 6.25e-4]
                .iter()
                .map(|&dt| lone_kicks_error(gamma, force, dt, t))
                .collect();
            let scale = Pull {
                gamma,
                accel: force / 4.0,
            }
            .g(t)
                * force
                / 4.0;
            assert!(errs[0] > 1e-9 * scale, "gamma {gamma} t {t}: {errs:?}");
            for k in 1..errs.len() {
                assert!(
                    errs[k] < errs[k - 1] / 3.0,
                    "gamma {gamma} t {t}: not converging {errs:?}"
                );
            }
            assert!(errs[2] < 1e-7 * scale, "gamma {gamma} t {t}: {errs:?}");
        }
    }
    // gamma = 0: x(k dt) = a (k dt)^2 / 2 exactly (mid-interval kicks).
    assert!(lone_kicks_error(0.0, 0.5, 1e-2, 7.5) < 1e-10);
    // The terminal velocity: the time average over whole periods is F/(gamma m0)
    // at any rate (the sawtooth around it averages out).
    let mut e = lone([0.0, 0.0]);
    e.set_friction(1.0);
    e.set_force_kicks(8.0, 0.1).unwrap();
    assert!(e.run_until(40.0, 100_000_000));
    let x0 = e.particle(0).0[0];
    assert!(e.run_until(60.0, 100_000_000));
    let v = (e.particle(0).0[0] - x0) / 20.0;
    assert!((v - 2.0).abs() < 1e-9, "{v}");
}

/// gamma = 0, pair kicks: the total momentum is P(0) + F dt times the number
/// of force kicks, to 1e-10, in a dense driven bath; no overlap.
#[test]
fn momentum_grows_by_f_dt_per_kick() {
    let mut c = bath(500, 0.6, 0.0, 10.0);
    if let Some(i) = c.intruder.as_mut() {
        i.force_mode = ForceMode::Kicks;
    }
    let mut e = initial_state::prepare(&c, &quiet).unwrap();
    e.set_restitution(c.eps, c.collapse_tc);
    let (kicks, rate, p_dr) = run::drive(&c, 5.0);
    e.set_kicks(kicks, rate, p_dr);
    let dt = 1e-3;
    e.set_force_kicks(10.0, dt).unwrap();
    let (t0, p0) = (e.time(), e.momentum());
    let mut t = t0;
    for _ in 0..20 {
        t += 0.1;
        assert!(e.run_until(t, 10_000_000));
        let p = e.momentum();
        let want = [p0[0] + 10.0 * dt * e.force_kicks() as f64, p0[1]];
        let scale = e.momentum_scale();
        for a in 0..2 {
            assert!(
                (p[a] - want[a]).abs() < 1e-10 * scale,
                "t {t}: P {p:?}, want {want:?}"
            );
        }
        assert!(e.worst_overlap(1e-10).is_none());
    }
    assert_eq!(e.force_kicks(), 2000);
    assert!(e.stats().collisions > 3000, "{:?}", e.stats());
}

/// In a bath (N = 500, phi = 0.6, gamma = 1, single kicks, F = 30), the
/// intruder's mean velocity with the force as kicks at 10^4 times the
/// collision rate equals the exact force's within the statistics (mean over
/// seeds, error from their spread); both ledgers close.
#[test]
fn bath_kicks_agree_with_the_exact_force() {
    let runs = |mode: ForceMode| -> Vec<f64> {
        (0..4)
            .map(|seed| {
                let mut c = bath(500, 0.6, 1.0, 30.0);
                c.seed = seed;
                c.intruder = Some(Intruder {
                    force_mode: mode,
                    ..Intruder::paper(30.0)
                });
                let (_, s) = run(&c, &quiet).unwrap();
                assert!(
                    s.energy_balance_error < 1e-9,
                    "{mode:?}: {}",
                    s.energy_balance_error
                );
                let i = s.intruder.unwrap();
                assert_eq!(i.force_mode, mode);
                if mode == ForceMode::Kicks {
                    // 10^4 x the Enskog rate over the production time.
                    let want = s.sim_time / i.force_kick_interval;
                    assert!(
                        (i.force_kicks as f64 - want).abs() <= 1.0,
                        "{} {want}",
                        i.force_kicks
                    );
                } else {
                    assert_eq!(i.force_kicks, 0);
                }
                i.velocity[0]
            })
            .collect()
    };
    let (exact, kicks) = (runs(ForceMode::Exact), runs(ForceMode::Kicks));
    let ((me, se), (mk, sk)) = (mean_and_error(&exact), mean_and_error(&kicks));
    eprintln!("exact {exact:?} kicks {kicks:?}");
    let err = (se * se + sk * sk).sqrt();
    assert!(me > 0.5 && me < 7.5, "{exact:?}");
    assert!(
        (me - mk).abs() < 4.0 * err,
        "exact {me} +- {se}, kicks {mk} +- {sk}"
    );
}
