//! Viscous friction F = -gamma m v (paper I), exactly, as a clock.
//!
//! Under friction alone a disk's velocity decays as v(t) = v0 exp(-gamma t) and
//! it moves by v0 (1 - exp(-gamma t)) / gamma (Eq. 8): it is ballistic in the
//! clock s = (1 - exp(-gamma (t - t0))) / gamma, with the constant velocity
//! u = v / lambda, lambda = 1 - gamma s = exp(-gamma (t - t0)). With one gamma
//! for every particle the engine runs in s unchanged (pair times, lists,
//! calendar); a contact at clock s happens at t = t0 - ln(1 - gamma s) / gamma
//! (Eq. 9), and never if s >= 1 / gamma. Collisions (Eq. 1 is homogeneous in
//! the velocities) act on u; a momentum change dp is du = dp / (m lambda).
//!
//! When lambda falls below [`REANCHOR_LAMBDA`] the clock is re-anchored at the
//! current time (s' = (s - s_a) / lambda_a, u' = lambda_a u), so that s stays
//! well inside [0, 1/gamma) and u keeps the magnitude of v.

/// Re-anchor the clock when lambda = exp(-gamma (t - t0)) would fall below this.
pub const REANCHOR_LAMBDA: f64 = 0.125;

/// The friction clock: rate `gamma` and the time `t0` at which s = 0. With
/// gamma = 0, s = t - t0 (the identity for [`Clock::NONE`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Clock {
    pub gamma: f64,
    pub t0: f64,
}

impl Clock {
    pub const NONE: Clock = Clock {
        gamma: 0.0,
        t0: 0.0,
    };

    /// The clock reading s at time t (Eq. 8's factor (1 - exp(-gamma (t - t0))) / gamma).
    #[inline]
    pub fn s(&self, t: f64) -> f64 {
        if self.gamma == 0.0 {
            t - self.t0
        } else {
            -(-self.gamma * (t - self.t0)).exp_m1() / self.gamma
        }
    }

    /// The time at clock reading s (Eq. 9); infinity from s = 1/gamma on.
    #[inline]
    pub fn t(&self, s: f64) -> f64 {
        if self.gamma == 0.0 {
            s + self.t0
        } else if self.gamma * s >= 1.0 {
            f64::INFINITY
        } else {
            self.t0 - (-self.gamma * s).ln_1p() / self.gamma
        }
    }

    /// lambda = v / u = exp(-gamma (t - t0)) at clock reading s.
    #[inline]
    pub fn lambda(&self, s: f64) -> f64 {
        1.0 - self.gamma * s
    }

    /// The clock reading past which the clock is re-anchored (infinite without friction).
    pub fn s_max(&self) -> f64 {
        if self.gamma == 0.0 {
            f64::INFINITY
        } else {
            (1.0 - REANCHOR_LAMBDA) / self.gamma
        }
    }

    /// The same clock anchored at reading `s` (time t(s)): s' = (s_old - s) / lambda(s).
    pub fn reanchored(&self, s: f64) -> Clock {
        Clock {
            gamma: self.gamma,
            t0: self.t(s),
        }
    }
}

#[cfg(test)]
mod unit {
    use super::Clock;

    #[test]
    fn clock_and_time_are_inverse_and_reanchoring_is_affine() {
        let c = Clock {
            gamma: 2.0,
            t0: 3.0,
        };
        for t in [3.0, 3.1, 4.0, 10.0] {
            let s = c.s(t);
            assert!((c.t(s) - t).abs() < 1e-12 * t, "{t}");
            assert!((c.lambda(s) - (-2.0 * (t - 3.0)).exp()).abs() < 1e-15);
        }
        assert_eq!(c.t(0.5), f64::INFINITY);
        let sa = c.s(3.7);
        let r = c.reanchored(sa);
        for t in [3.7, 4.0, 9.0] {
            let want = (c.s(t) - sa) / c.lambda(sa);
            assert!((r.s(t) - want).abs() < 1e-14, "{t}");
        }
        assert_eq!(Clock::NONE.s(1.25), 1.25);
        assert_eq!(Clock::NONE.t(1.25), 1.25);
    }
}
