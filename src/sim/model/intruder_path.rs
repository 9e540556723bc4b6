//! The intruder of paper I: its exact path under a constant force F along +x
//! and viscous friction -gamma m0 v (Eqs. 3-4), and the root finder for its
//! contact and shell-exit times against a bath disk.
//!
//! In real time tau from a common instant, the intruder moves by
//! v0 E(tau) + (F/m0) G(tau) x, with E = (1 - exp(-gamma tau)) / gamma and
//! G = (tau - E) / gamma (G = tau^2 / 2 at gamma = 0); a bath disk moves by
//! vj E(tau). Their separation D(tau) = d + w E + (F/m0) G x, w = v0 - vj, is
//! not straight in any clock, so times come from a stepping root finder.
//! D' = w exp(-gamma tau) + (F/m0) E x, so on [tau, h]
//! |D'| <= L(tau) = |w| exp(-gamma tau) + |F/m0| E(h): a step of
//! (|D| - sigma) / L(tau) never passes the first contact, and the steps grow
//! as friction slows a pair that cannot reach. Contact is accepted at a
//! gap <= [`GAP_TOL`] sigma while approaching; after [`MAX_STEPS`] steps the
//! finder gives up with a time before which no contact can happen, at which
//! the caller schedules a re-prediction.

use super::friction::Clock;

/// Contact is accepted at a gap of at most this fraction of sigma.
pub const GAP_TOL: f64 = 1e-10;
/// Steps after which the root finder gives up (the caller re-predicts then).
pub const MAX_STEPS: u32 = 10_000;

/// The intruder's motion law: friction rate and the force per mass F/m0 (along +x).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pull {
    pub gamma: f64,
    /// F / m0.
    pub accel: f64,
}

/// What the root finder found within its horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Root {
    /// The event happens at this tau.
    At(f64),
    /// No event before the horizon.
    Never,
    /// Gave up after [`MAX_STEPS`]: nothing happens before this tau; re-predict there.
    GaveUp(f64),
}

impl Pull {
    /// E(tau) = (1 - exp(-gamma tau)) / gamma: the distance per unit initial
    /// velocity under friction alone (Eq. 8); tau at gamma = 0.
    #[inline]
    pub fn e(&self, tau: f64) -> f64 {
        Clock {
            gamma: self.gamma,
            t0: 0.0,
        }
        .s(tau)
    }

    /// G(tau) = (tau - E(tau)) / gamma: the distance per unit F/m0 from rest;
    /// tau^2 / 2 at gamma = 0. A series near gamma tau = 0 avoids the cancellation.
    #[inline]
    pub fn g(&self, tau: f64) -> f64 {
        let x = self.gamma * tau;
        if x < 1e-3 {
            // tau^2 (1/2 - x/6 + x^2/24 - x^3/120 + x^4/720)
            tau * tau * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0 - x / 720.0))))
        } else {
            (x + (-x).exp_m1()) / (self.gamma * self.gamma)
        }
    }

    /// The intruder's displacement after tau from velocity v0.
    pub fn displacement(&self, v0: [f64; 2], tau: f64) -> [f64; 2] {
        let e = self.e(tau);
        [v0[0] * e + self.accel * self.g(tau), v0[1] * e]
    }

    /// The intruder's velocity after tau from v0: F/(gamma m0) + (v0 - F/(gamma m0)) exp(-gamma tau).
    pub fn velocity(&self, v0: [f64; 2], tau: f64) -> [f64; 2] {
        let decay = (-self.gamma * tau).exp();
        [v0[0] * decay + self.accel * self.e(tau), v0[1] * decay]
    }

    /// Separation D(tau) and its rate D'(tau) from a bath disk, given the
    /// separation `d` (intruder minus disk) and the velocity difference `w` at tau = 0.
    #[inline]
    fn separation(&self, d: [f64; 2], w: [f64; 2], tau: f64) -> ([f64; 2], [f64; 2]) {
        let e = self.e(tau);
        let decay = (-self.gamma * tau).exp();
        let g = self.g(tau);
        (
            [d[0] + w[0] * e + self.accel * g, d[1] + w[1] * e],
            [w[0] * decay + self.accel * e, w[1] * decay],
        )
    }

    /// A bound on |D'| over [tau, h]: the friction-decayed |w| plus the force's share.
    #[inline]
    fn speed_bound(&self, wn: f64, tau: f64, h: f64) -> f64 {
        wn * (-self.gamma * tau).exp() + self.accel.abs() * self.e(h)
    }

    /// First contact |D| = sigma within [0, h], approaching; see the module doc.
    /// Returns the root and the number of steps taken.
    pub fn contact_time(&self, d: [f64; 2], w: [f64; 2], sigma: f64, h: f64) -> (Root, u32) {
        let wn = w[0].hypot(w[1]);
        let tol = GAP_TOL * sigma;
        let mut tau = 0.0;
        for step in 0..MAX_STEPS {
            let (dd, dv) = self.separation(d, w, tau);
            let gap = dd[0].hypot(dd[1]) - sigma;
            let approaching = dd[0] * dv[0] + dd[1] * dv[1] < 0.0;
            if gap <= tol && approaching {
                return (Root::At(tau), step);
            }
            let l = self.speed_bound(wn, tau, h);
            if l == 0.0 {
                return (Root::Never, step);
            }
            // Touching but separating (just after a collision): a minimal step,
            // over which the gap changes by at most tol.
            tau += gap.max(tol) / l;
            if tau >= h {
                return (Root::Never, step + 1);
            }
        }
        (Root::GaveUp(tau), MAX_STEPS)
    }

    /// First time within [0, h] at which the intruder's x, from `x0` with
    /// velocity `v0` along x, reaches `lo` moving down or `hi` moving up (its
    /// centre's range between walls in x). The 1D member of the family of
    /// [`Self::contact_time`], with a local bound: x'' = F/m0 - gamma x' only
    /// shrinks in size from tau on, so with A = |F/m0 - gamma x'(tau)| the gap
    /// g to the nearer wall cannot close before the root of
    /// g = |x'(tau)| d + A d^2 / 2: a step of that d never passes a wall, and
    /// near a rebound's apex it stays long (the straight bound of
    /// `contact_time` would crawl). Accepted at a gap <= GAP_TOL (hi - lo)
    /// while approaching.
    pub fn wall_time(&self, x0: f64, v0: f64, lo: f64, hi: f64, h: f64) -> (Root, u32) {
        let tol = GAP_TOL * (hi - lo);
        let mut tau = 0.0;
        for step in 0..MAX_STEPS {
            let x = x0 + v0 * self.e(tau) + self.accel * self.g(tau);
            let v = v0 * (-self.gamma * tau).exp() + self.accel * self.e(tau);
            let (gap_lo, gap_hi) = (x - lo, hi - x);
            if (gap_hi <= tol && v > 0.0) || (gap_lo <= tol && v < 0.0) {
                return (Root::At(tau), step);
            }
            let a = (self.accel - self.gamma * v).abs();
            if v == 0.0 && a == 0.0 {
                return (Root::Never, step);
            }
            // At a wall but leaving it: a minimal step (the force may bring it back).
            let g = gap_lo.min(gap_hi).max(tol);
            tau += 2.0 * g / (v.abs() + (v * v + 2.0 * a * g).sqrt());
            if tau >= h {
                return (Root::Never, step + 1);
            }
        }
        (Root::GaveUp(tau), MAX_STEPS)
    }

    /// First time within [0, h] at which |D| reaches `radius` from inside (the
    /// intruder leaves a disk's neighbour shell), never late: accepted within
    /// GAP_TOL radius before the crossing.
    pub fn exit_time(&self, d: [f64; 2], w: [f64; 2], radius: f64, h: f64) -> (Root, u32) {
        let wn = w[0].hypot(w[1]);
        let tol = GAP_TOL * radius;
        let mut tau = 0.0;
        for step in 0..MAX_STEPS {
            let (dd, _) = self.separation(d, w, tau);
            let room = radius - dd[0].hypot(dd[1]);
            if room <= tol {
                return (Root::At(tau), step);
            }
            let l = self.speed_bound(wn, tau, h);
            if l == 0.0 {
                return (Root::Never, step);
            }
            tau += room / l;
            if tau >= h {
                return (Root::Never, step + 1);
            }
        }
        (Root::GaveUp(tau), MAX_STEPS)
    }
}

#[cfg(test)]
mod unit {
    use super::{GAP_TOL, MAX_STEPS, Pull, Root};

    /// Brute force: RK4 on m dv/dt = F - gamma m v with tiny steps.
    fn integrate(p: Pull, v0: [f64; 2], tau: f64, n: usize) -> ([f64; 2], [f64; 2]) {
        let h = tau / n as f64;
        let (mut x, mut v) = ([0.0, 0.0], v0);
        let f = |v: [f64; 2]| [p.accel - p.gamma * v[0], -p.gamma * v[1]];
        for _ in 0..n {
            let k1 = f(v);
            let v2 = [v[0] + 0.5 * h * k1[0], v[1] + 0.5 * h * k1[1]];
            let k2 = f(v2);
            let v3 = [v[0] + 0.5 * h * k2[0], v[1] + 0.5 * h * k2[1]];
            let k3 = f(v3);
            let v4 = [v[0] + h * k3[0], v[1] + h * k3[1]];
            let k4 = f(v4);
            for a in 0..2 {
                x[a] += h / 6.0 * (v[a] + 2.0 * v2[a] + 2.0 * v3[a] + v4[a]);
                v[a] += h / 6.0 * (k1[a] + 2.0 * k2[a] + 2.0 * k3[a] + k4[a]);
            }
        }
        (x, v)
    }

    #[test]
    fn path_matches_the_integrated_equation_of_motion() {
        for (gamma, accel) in [(0.0, 3.0), (1.0, 2.0), (0.3, -1.5), (1e-6, 4.0)] {
            let p = Pull { gamma, accel };
            let v0 = [0.7, -1.2];
            for tau in [1e-5, 0.01, 0.5, 3.0] {
                let (x, v) = integrate(p, v0, tau, 4000);
                let (xa, va) = (p.displacement(v0, tau), p.velocity(v0, tau));
                for a in 0..2 {
                    assert!(
                        (xa[a] - x[a]).abs() < 1e-11 * (1.0 + x[a].abs()),
                        "{gamma} {tau} x"
                    );
                    assert!(
                        (va[a] - v[a]).abs() < 1e-11 * (1.0 + v[a].abs()),
                        "{gamma} {tau} v"
                    );
                }
            }
        }
    }

    #[test]
    fn lone_intruder_reaches_terminal_velocity() {
        let p = Pull {
            gamma: 1.0,
            accel: 250.0,
        };
        let v = p.velocity([-3.0, 2.0], 40.0);
        assert!((v[0] - 250.0).abs() < 1e-10 * 250.0, "{v:?}");
        assert!(v[1].abs() < 1e-10);
        // gamma = 0: v = v0 + F t / m0 and x = v0 t + F t^2 / (2 m0) exactly
        let p0 = Pull {
            gamma: 0.0,
            accel: 2.5,
        };
        assert_eq!(p0.velocity([1.0, 0.0], 4.0), [11.0, 0.0]);
        assert_eq!(p0.displacement([1.0, 0.0], 4.0), [24.0, 0.0]);
    }

    /// The first tau with |D| <= sigma, by a dense scan and bisection.
    fn brute_contact(p: Pull, d: [f64; 2], w: [f64; 2], sigma: f64, h: f64) -> Option<f64> {
        let n = 200_000;
        let dist = |t: f64| {
            let (dd, _) = p.separation(d, w, t);
            dd[0].hypot(dd[1]) - sigma
        };
        let mut prev = 0.0;
        for i in 1..=n {
            let t = h * i as f64 / n as f64;
            if dist(t) <= 0.0 {
                let (mut lo, mut hi) = (prev, t);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if dist(mid) <= 0.0 { hi = mid } else { lo = mid }
                }
                return Some(hi);
            }
            prev = t;
        }
        None
    }

    #[test]
    fn contact_time_matches_brute_force_and_never_passes_first_contact() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut hits, mut misses) = (0, 0);
        for case in 0..300 {
            let gamma = if case % 3 == 0 { 0.0 } else { 2.0 * rnd() };
            let p = Pull {
                gamma,
                accel: 20.0 * (rnd() - 0.3),
            };
            let sigma = 3.0;
            let ang = std::f64::consts::TAU * rnd();
            let r = sigma + 0.05 + 2.0 * rnd();
            let d = [r * ang.cos(), r * ang.sin()];
            let w = [4.0 * (rnd() - 0.5), 4.0 * (rnd() - 0.5)];
            let h = 2.0;
            let (root, _) = p.contact_time(d, w, sigma, h);
            match (root, brute_contact(p, d, w, sigma, h)) {
                (Root::At(t), Some(b)) => {
                    hits += 1;
                    assert!(t <= b + 1e-9, "case {case}: {t} past {b}");
                    assert!((t - b).abs() < 1e-4, "case {case}: {t} vs {b}");
                    let (dd, _) = p.separation(d, w, t);
                    let gap = dd[0].hypot(dd[1]) - sigma;
                    assert!(
                        gap.abs() <= GAP_TOL * sigma * 1.01,
                        "case {case}: gap {gap}"
                    );
                }
                (Root::Never, None) => misses += 1,
                other => panic!("case {case}: {other:?}"),
            }
        }
        assert!(hits > 50 && misses > 50, "{hits} {misses}");
    }

    #[test]
    fn without_force_contact_is_the_friction_clock_root() {
        // Head-on, F = 0: D = d - g E, contact at E = (d - sigma) / g, tau = -ln(1 - gamma E) / gamma.
        let p = Pull {
            gamma: 0.5,
            accel: 0.0,
        };
        let (d, g, sigma) = (5.0, 2.0, 2.0);
        let e = (d - sigma) / g;
        let want = -(-p.gamma * e).ln_1p() / p.gamma;
        let (root, _) = p.contact_time([d, 0.0], [-g, 0.0], sigma, 100.0);
        let Root::At(t) = root else {
            panic!("{root:?}")
        };
        assert!((t - want).abs() < 1e-9 * want, "{t} {want}");
        // Out of reach (d - sigma > g / gamma): never.
        let (root, _) = p.contact_time([sigma + 1.001 * g / p.gamma, 0.0], [-g, 0.0], sigma, 100.0);
        assert_eq!(root, Root::Never);
    }

    #[test]
    fn a_touching_separating_pair_is_not_a_contact_but_the_force_brings_it_back() {
        // Intruder just bounced off a disk ahead of it (d = -sigma x), moving
        // back at 1; the force turns it round: recontact at tau = 2 / accel at gamma = 0.
        let p = Pull {
            gamma: 0.0,
            accel: 4.0,
        };
        let (root, _) = p.contact_time([-2.0, 0.0], [-1.0, 0.0], 2.0, 10.0);
        let Root::At(t) = root else {
            panic!("{root:?}")
        };
        assert!((t - 0.5).abs() < 1e-6, "{t}");
        assert!(t <= 0.5 + 1e-12);
    }

    #[test]
    fn gives_up_with_a_safe_time_on_a_near_graze() {
        // A nearly tangential approach: tiny gaps over a long stretch.
        let p = Pull {
            gamma: 0.0,
            accel: 0.0,
        };
        let sigma = 1.0;
        let d = [-1e3, sigma * (1.0 - 1e-13)];
        let (root, steps) = p.contact_time(d, [1.0, 0.0], sigma, 1e4);
        let Root::GaveUp(t) = root else {
            panic!("{root:?}")
        };
        assert_eq!(steps, MAX_STEPS);
        let b = 1e3 - (sigma * sigma - d[1] * d[1]).sqrt();
        assert!(t <= b && t > 0.99 * b, "{t} vs contact at {b}");
    }

    #[test]
    fn wall_time_matches_bisection_and_never_passes_the_wall() {
        for (gamma, accel, v0) in [
            (0.0, 25.0, 0.0),
            (1.0, 25.0, -3.0),
            (0.5, 2.0, -1e-3),
            (2.0, 0.0, 4.0),
        ] {
            let p = Pull { gamma, accel };
            let (lo, hi, x0) = (2.0, 98.0, 97.0);
            let x = |t: f64| x0 + v0 * p.e(t) + accel * p.g(t);
            let (root, _) = p.wall_time(x0, v0, lo, hi, 1e3);
            let Root::At(t) = root else {
                panic!("{gamma} {accel}: {root:?}")
            };
            // The first crossing of hi, by a dense scan and bisection.
            let n = 1_000_000;
            let first = (1..=n)
                .map(|i| 50.0 * i as f64 / n as f64)
                .find(|&t| x(t) >= hi);
            let b = first.map(|t1| {
                let (mut a, mut b) = (t1 - 50.0 / n as f64, t1);
                for _ in 0..200 {
                    let m = 0.5 * (a + b);
                    if x(m) >= hi { b = m } else { a = m }
                }
                b
            });
            let b = b.expect("reaches the wall");
            assert!(
                t <= b + 1e-12 && (t - b).abs() < 1e-6,
                "{gamma} {accel}: {t} vs {b}"
            );
        }
        // Pulled away from the lower wall and too slow to reach the upper: never.
        let p = Pull {
            gamma: 1.0,
            accel: -1.0,
        };
        assert_eq!(p.wall_time(50.0, 0.5, 2.0, 98.0, 10.0).0, Root::Never);
    }

    #[test]
    fn exit_time_matches_brute_force() {
        let p = Pull {
            gamma: 1.0,
            accel: 6.0,
        };
        let (d, w, radius) = ([0.5, -0.3], [-0.2, 0.9], 4.0);
        let (root, _) = p.exit_time(d, w, radius, 50.0);
        let Root::At(t) = root else {
            panic!("{root:?}")
        };
        let (mut lo, mut hi) = (0.0, 50.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            let (dd, _) = p.separation(d, w, mid);
            if dd[0].hypot(dd[1]) >= radius {
                hi = mid
            } else {
                lo = mid
            }
        }
        assert!(t <= hi && hi - t < 1e-8, "{t} {hi}");
        // Stays inside for ever (no force, slow, friction): never.
        let p = Pull {
            gamma: 1.0,
            accel: 0.0,
        };
        assert_eq!(p.exit_time([0.0, 0.0], [1.0, 0.0], 4.0, 1e3).0, Root::Never);
    }
}
