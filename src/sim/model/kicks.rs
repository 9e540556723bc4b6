//! Driving by random kicks: Eq. (4) of paper H (pairs of opposite momenta) and
//! Eq. (2) of paper I (single particles, when friction removes the momentum),
//! with the amplitude of Eq. (7) of paper I.

/// Which particles a kick moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Kicks {
    /// No driving.
    Off,
    /// A random particle and a random particle from its 3x3 cell neighbourhood
    /// (local momentum conservation).
    NeighbourPairs,
    /// Two random particles anywhere in the box.
    RandomPairs,
    /// One random particle (momentum is not conserved; friction takes it out).
    Single,
}

/// The kick amplitude p_dr of Eq. (7) of paper I,
/// p_dr^2 / (2 m_eff) = 2 gamma T / omega_E + (1 - eps^2) T / 2,
/// with m_eff = m1 m2 / (m1 + m2) and omega_E the Enskog collision frequency
/// at T: kicks at rate omega_E per particle then hold the temperature T against
/// friction (first term) and inelastic collisions (second). At gamma = 0 and
/// T = 1 it is paper H's p_dr = sqrt((1 - eps^2) m1 m2 / (m1 + m2)).
pub fn amplitude(eps: f64, gamma: f64, temperature: f64, omega_e: f64, m1: f64, m2: f64) -> f64 {
    let friction = if gamma > 0.0 {
        4.0 * gamma * temperature / omega_e
    } else {
        0.0
    };
    let a = (1.0 - eps * eps) * temperature + friction;
    (a * m1 * m2 / (m1 + m2)).sqrt()
}

#[cfg(test)]
mod unit {
    use super::amplitude;

    /// The values of Eq. (7) for paper I's bath (m_s = 1, m_b = 25/16, eps = 0.9)
    /// at the Enskog rates of eta = 0.3, 0.6, 0.8 (T = gamma = 1), and at
    /// gamma = 0, T = 0.1.
    #[test]
    fn eq7_amplitudes() {
        let mb = 25.0 / 16.0;
        for (omega, p) in [(0.9423, 1.6445), (4.876, 0.7849), (22.82, 0.4720)] {
            let a = amplitude(0.9, 1.0, 1.0, omega, 1.0, mb);
            assert!((a - p).abs() < 1e-4, "omega {omega}: {a} vs {p}");
        }
        let a = amplitude(0.9, 0.0, 0.1, 5.0, 1.0, mb);
        assert!((a - 0.1076).abs() < 1e-4, "{a}");
    }

    /// Paper H's amplitude, bit for bit (its trajectories depend on it).
    #[test]
    fn paper_h_amplitude_is_unchanged() {
        let (m1, m2, eps) = (1.0f64, 1.43f64 * 1.43, 0.9f64);
        let old = ((1.0 - eps * eps) * m1 * m2 / (m1 + m2)).sqrt();
        assert_eq!(
            amplitude(eps, 0.0, 1.0, 15.0, m1, m2).to_bits(),
            old.to_bits()
        );
    }
}
