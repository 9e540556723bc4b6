//! The Enskog collision frequency of a bidisperse disk fluid.
//!
//! omega = sum_i x_i sum_j n_j sigma_ij g_ij sqrt(2 pi T / mu_ij): collisions per
//! particle per unit time for Maxwellian velocities at temperature T (kinetic
//! energy per particle, 2D), with sigma_ij = r_i + r_j, mu_ij the reduced mass and
//! the contact values g_ij of Jenkins & Mancini (1987) for disk mixtures,
//! g_ij = 1/(1-phi) + (9/16) phi/(1-phi)^2 * (s_i s_j / s_ij) (M1/M2), with
//! s = diameters, s_ij = (s_i+s_j)/2, M_k = sum_l x_l s_l^k. For one species this is
//! Henderson's g(sigma) = (1 - 7 phi/16)/(1 - phi)^2.

use std::f64::consts::PI;

/// Contact value g_ij of species i and j.
pub fn contact_value(phi: f64, radii: &[f64], fractions: &[f64], i: usize, j: usize) -> f64 {
    let m1: f64 = fractions.iter().zip(radii).map(|(x, r)| x * 2.0 * r).sum();
    let m2: f64 = fractions
        .iter()
        .zip(radii)
        .map(|(x, r)| x * 4.0 * r * r)
        .sum();
    let (si, sj) = (2.0 * radii[i], 2.0 * radii[j]);
    let sij = 0.5 * (si + sj);
    1.0 / (1.0 - phi) + 9.0 / 16.0 * phi / (1.0 - phi).powi(2) * (si * sj / sij) * (m1 / m2)
}

/// Enskog collision frequency per particle (collisions each particle undergoes
/// per unit time) at packing fraction `phi` and temperature `t`.
pub fn collision_frequency(
    phi: f64,
    radii: &[f64],
    masses: &[f64],
    fractions: &[f64],
    t: f64,
) -> f64 {
    let area_per_particle: f64 = fractions
        .iter()
        .zip(radii)
        .map(|(x, r)| x * PI * r * r)
        .sum();
    let n = phi / area_per_particle;
    let mut omega = 0.0;
    for i in 0..radii.len() {
        for j in 0..radii.len() {
            let mu = masses[i] * masses[j] / (masses[i] + masses[j]);
            let sig = radii[i] + radii[j];
            omega += fractions[i]
                * fractions[j]
                * n
                * sig
                * contact_value(phi, radii, fractions, i, j)
                * (2.0 * PI * t / mu).sqrt();
        }
    }
    omega
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_species_is_henderson_and_the_known_frequency() {
        let phi: f64 = 0.4;
        let g = contact_value(phi, &[1.0], &[1.0], 0, 0);
        assert!((g - (1.0 - 7.0 * phi / 16.0) / (1.0 - phi).powi(2)).abs() < 1e-12);
        // 2D monodisperse: omega = 2 n sigma g sqrt(pi T/m), n = phi/(pi r^2), sigma = 2.
        let w = collision_frequency(phi, &[1.0], &[1.0], &[1.0], 1.0);
        let expect = 2.0 * phi / PI * 2.0 * g * PI.sqrt();
        assert!((w - expect).abs() < 1e-12 * expect);
    }
}
