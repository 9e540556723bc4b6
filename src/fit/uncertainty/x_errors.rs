//! Errors in x as well as y (effective variance, Orear, Am. J. Phys. 50, 912
//! (1982)): each point's y error widened by the model's slope times its x error,
//! s_eff^2 = s_y^2 + (f'(x) s_x)^2, with f' taken from the fit itself and the fit
//! repeated until the widened errors settle. Used where x is measured with an
//! error comparable in effect to y's (fig9: D against tau_alpha, both measured).

use crate::fit::{FitError, FitResult};

/// Refits at most this many times; the slope moves little after the first.
const ROUNDS: usize = 5;

/// The y errors widened by the x errors, and the fit made with them: starting
/// from `s`, fit, widen each error by |f'(x)| s_x (the slope of `model` at the
/// fitted parameters, by a central difference), refit, until no error moves by
/// more than a part in 10^6 or after [`ROUNDS`] refits. `fit` fits the points
/// with the errors it is given; `model(params, x)` is the fitted curve.
pub fn effective_variance(
    x: &[f64],
    s: &[f64],
    s_x: &[f64],
    fit: impl Fn(&[f64]) -> Result<FitResult, FitError>,
    model: impl Fn(&[f64], f64) -> f64,
) -> Result<(Vec<f64>, FitResult), FitError> {
    let mut s_eff = s.to_vec();
    let mut f = fit(&s_eff)?;
    for _ in 0..ROUNDS {
        let next: Vec<f64> = (0..x.len())
            .map(|i| {
                let sx = if s_x[i].is_finite() { s_x[i] } else { 0.0 };
                let h = 1e-6 * x[i].abs().max(1e-12);
                let slope = (model(&f.params, x[i] + h) - model(&f.params, x[i] - h)) / (2.0 * h);
                let w = slope * sx;
                if w.is_finite() { s[i].hypot(w) } else { s[i] }
            })
            .collect();
        let moved = next
            .iter()
            .zip(&s_eff)
            .any(|(a, b)| (a - b).abs() > 1e-6 * b.abs());
        s_eff = next;
        f = fit(&s_eff)?;
        if !moved {
            break;
        }
    }
    Ok((s_eff, f))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{Data, linear};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A line y = 2 x whose points are scattered in x only: the fit with the y
    /// errors alone (tiny) has a reduced chi^2 far above 1; with the x errors
    /// carried, the reduced chi^2 is near 1 and the slope within its error of 2.
    #[test]
    fn x_errors_carried_bring_the_reduced_chi2_of_a_line_to_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 200;
        let (sx, sy) = (0.05, 0.001);
        let unit = Normal::new(0.0, 1.0).unwrap();
        let x_true: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 / 50.0).collect();
        let x: Vec<f64> = x_true
            .iter()
            .map(|v| v + sx * unit.sample(&mut rng))
            .collect();
        let y: Vec<f64> = x_true
            .iter()
            .map(|v| 2.0 * v + sy * unit.sample(&mut rng))
            .collect();
        let s = vec![sy; n];
        let s_x = vec![sx; n];
        let fit = |e: &[f64]| linear::line(Data::new(&x, &y, e));
        let alone = fit(&s).unwrap();
        let (s_eff, carried) =
            effective_variance(&x, &s, &s_x, fit, |p, v| p[0] + p[1] * v).unwrap();
        assert!(
            alone.reduced_chi2 > 100.0,
            "y errors alone: {}",
            alone.reduced_chi2
        );
        assert!(
            (carried.reduced_chi2 - 1.0).abs() < 0.25,
            "x errors carried: reduced chi2 {}",
            carried.reduced_chi2
        );
        // sqrt(sy^2 + (2 sx)^2) for every point.
        let expect = sy.hypot(2.0 * sx);
        assert!(s_eff.iter().all(|e| (e / expect - 1.0).abs() < 0.01));
        let (b, eb) = (carried.params[1], carried.stderr[1]);
        assert!((b - 2.0).abs() < 3.0 * eb, "slope {b} +- {eb}");
    }
}
