//! The collision rule: Eqs. (1)-(3) of paper H (Eq. 1 of paper I), normal
//! restitution with the collapse guard of the TC model, as small pure functions.

/// The restitution coefficient of a collision and whether the collapse guard
/// made it elastic. `since_i`, `since_j`: time since either disk's previous
/// collision; `tc`: the guard's window (0 disables it). Collisions are elastic
/// while radii grow (`compressing`), and when `eps` = 1 nothing is guarded.
#[inline]
pub fn coefficient(
    eps: f64,
    compressing: bool,
    since_i: f64,
    since_j: f64,
    tc: f64,
) -> (f64, bool) {
    if compressing || eps == 1.0 {
        (1.0, false)
    } else if since_i < tc || since_j < tc {
        (1.0, true)
    } else {
        (eps, false)
    }
}

/// The normal impulse that turns an approach speed `g` of the surfaces into
/// -e g (Eq. 1): mu (1 + e) g, with mu the reduced mass.
#[inline]
pub fn normal_impulse(mu: f64, e: f64, g: f64) -> f64 {
    mu * (1.0 + e) * g
}

/// Kinetic energy a collision with approach speed `g` and coefficient `e`
/// removes: (1 - e^2) mu g^2 / 2.
#[inline]
pub fn energy_loss(mu: f64, e: f64, g: f64) -> f64 {
    0.5 * (1.0 - e * e) * mu * g * g
}

#[cfg(test)]
mod unit {
    use super::*;

    /// A head-on collision: the relative normal velocity is reversed and scaled
    /// by e, momentum is conserved and the energy lost is `energy_loss`.
    #[test]
    fn impulse_reverses_the_normal_speed_and_loses_the_stated_energy() {
        let (m1, m2, v1, v2, e) = (1.0, 1.5625, 2.0, -0.5, 0.9);
        let mu = m1 * m2 / (m1 + m2);
        let g = v1 - v2;
        let imp = normal_impulse(mu, e, g);
        let (w1, w2) = (v1 - imp / m1, v2 + imp / m2);
        assert!(((w1 - w2) + e * g).abs() < 1e-14);
        assert!((m1 * w1 + m2 * w2 - (m1 * v1 + m2 * v2)).abs() < 1e-14);
        let ke = |a: f64, b: f64| 0.5 * (m1 * a * a + m2 * b * b);
        assert!((ke(v1, v2) - ke(w1, w2) - energy_loss(mu, e, g)).abs() < 1e-13);
    }

    #[test]
    fn guard_makes_a_quick_recollision_elastic() {
        assert_eq!(coefficient(0.9, false, 1.0, 1.0, 1e-6), (0.9, false));
        assert_eq!(coefficient(0.9, false, 1e-7, 1.0, 1e-6), (1.0, true));
        assert_eq!(coefficient(0.9, false, 1.0, 1e-7, 1e-6), (1.0, true));
        assert_eq!(coefficient(0.9, true, 1e-7, 1.0, 1e-6), (1.0, false));
        assert_eq!(coefficient(1.0, false, 1e-7, 1.0, 1e-6), (1.0, false));
        assert_eq!(coefficient(0.9, false, 0.0, 0.0, 0.0), (0.9, false));
    }
}
