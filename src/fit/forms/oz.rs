//! Ornstein-Zernike fits of the four-point structure factor (paper H):
//! S4(q) = chi0 / (1 + (q xi)^2) (Eq. 18) and its extension
//! S4(q) = chi0 / (1 + (q xi)^2 + A^2 (q xi)^4) (Eq. 20).
//!
//! Both need wavevectors below 1/xi: when xi approaches the box size no q
//! reaches the plateau, only chi0/xi^2 is determined, and the fit fails with a
//! clear error instead of returning a number. Before that, from q_min xi =
//! [`MAX_QMIN_XI`] on, xi is biased low by more than the paper's precision: the
//! fit keeps its numbers but its warning starts with `unreliable: ` (the compare
//! verdict, and the mark in the figures).

use super::{Data, FitError, FitResult, Fixed, UNRELIABLE, fit_form};
use crate::fit::linear::linear_least_squares;
use crate::fit::result::require_positive;

/// S4 = chi0 / (1 + (q xi)^2). Parameters: `chi0`, `xi`. `data.x` is q > 0.
pub fn oz(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    const FORM: &str = "oz";
    let c = inverse_polynomial(FORM, data, 2, fixed.len())?;
    let (chi0, xi) = if c[0] > 0.0 && c[1] > 0.0 {
        (1.0 / c[0], (c[1] / c[0]).sqrt())
    } else {
        rough_start(data)
    };
    let model = |q: f64, p: &[f64]| p[0] / (1.0 + (q * p[1]).powi(2));
    let bounds = vec![(0.0, f64::INFINITY), (0.0, f64::INFINITY)];
    let mut fit = fit_form(
        FORM,
        &["chi0", "xi"],
        &model,
        data,
        vec![chi0, xi],
        bounds,
        fixed,
    )?;
    check_plateau(FORM, data, fixed, &mut fit)?;
    Ok(fit)
}

/// S4 = chi0 / (1 + (q xi)^2 + A^2 (q xi)^4). Parameters: `chi0`, `xi`, `A` (>= 0).
pub fn oz_quartic(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    const FORM: &str = "oz_quartic";
    let c = inverse_polynomial(FORM, data, 3, fixed.len())?;
    let (chi0, xi, a) = if c[0] > 0.0 && c[1] > 0.0 {
        // 1/S4 = (1 + (q xi)^2 + A^2 (q xi)^4) / chi0.
        let a2 = c[2] * c[0] / (c[1] * c[1]);
        (1.0 / c[0], (c[1] / c[0]).sqrt(), a2.max(0.01).sqrt())
    } else {
        let (chi0, xi) = rough_start(data);
        (chi0, xi, 0.1)
    };
    let model = |q: f64, p: &[f64]| {
        let u = (q * p[1]).powi(2);
        p[0] / (1.0 + u + p[2] * p[2] * u * u)
    };
    let bounds = vec![
        (0.0, f64::INFINITY),
        (0.0, f64::INFINITY),
        (0.0, f64::INFINITY),
    ];
    let names = ["chi0", "xi", "A"];
    let mut fit = match fit_form(
        FORM,
        &names,
        &model,
        data,
        vec![chi0, xi, a],
        bounds.clone(),
        fixed,
    ) {
        // A^2 >= 0 is the form's domain: where the data show no q^4 term the
        // best fit inside it is A = 0, i.e. the plain OZ fit (paper H, Fig. 25:
        // "in almost all cases the two values fall on top of each other").
        Err(FitError::AtBound { parameter, .. }) if parameter == "A" => {
            let mut at_zero: Vec<(&str, f64)> = fixed.to_vec();
            at_zero.push(("A", 0.0));
            let mut f = fit_form(
                FORM,
                &names,
                &model,
                data,
                vec![chi0, xi, 0.0],
                bounds,
                &at_zero,
            )?;
            f.warnings.push(
                "A = 0: the data show no q^4 term, so chi0 and xi are those of the plain OZ form"
                    .to_string(),
            );
            f
        }
        r => r?,
    };
    check_plateau(FORM, data, fixed, &mut fit)?;
    Ok(fit)
}

/// Coefficients of 1/S4 = c0 + c1 q^2 + c2 q^4 + ... (`terms` of them), a
/// linear fit that gives starting values; also validates the data.
fn inverse_polynomial(
    form: &str,
    data: Data<'_>,
    terms: usize,
    n_fixed: usize,
) -> Result<Vec<f64>, FitError> {
    data.validate(form, terms.saturating_sub(n_fixed))?;
    require_positive(form, "q", data.x)?;
    require_positive(form, "S4", data.y)?;
    let inv: Vec<f64> = data.y.iter().map(|s| 1.0 / s).collect();
    let sig: Vec<f64> = data
        .y
        .iter()
        .zip(data.sigma)
        .map(|(s, e)| e / (s * s))
        .collect();
    let names = ["c0", "c1", "c2", "c3"];
    let basis = |q: f64, b: &mut [f64]| {
        let mut v = 1.0;
        for bk in b.iter_mut() {
            *bk = v;
            v *= q * q;
        }
    };
    match linear_least_squares(form, &names[..terms], &basis, Data::new(data.x, &inv, &sig)) {
        Ok(f) => Ok(f.params),
        // Too few points for the start polynomial: fall back to a rough start.
        Err(_) => Ok(vec![-1.0; terms]),
    }
}

/// chi0 from the largest S4, xi from the q where S4 halves.
fn rough_start(data: Data<'_>) -> (f64, f64) {
    let chi0 = data.y.iter().copied().fold(0.0, f64::max);
    let half = data
        .x
        .iter()
        .zip(data.y)
        .filter(|(_, s)| **s <= 0.5 * chi0)
        .map(|(q, _)| *q)
        .fold(f64::INFINITY, f64::min);
    let qmin = data.x.iter().copied().fold(f64::INFINITY, f64::min);
    let q_half = if half.is_finite() { half } else { qmin };
    (chi0, 1.0 / q_half)
}

/// Largest q_min xi (q_min the smallest fitted wavevector, 1.21 x 2 pi / L for
/// the first shell of a square box) at which xi is still within the paper's ~10%:
/// measured with a phi sweep at N = 250 against N = 1000 (docs/figures.md, "Where
/// the OZ fit fails"): xi is 8% low at q_min xi = 0.73 and 15% low at 0.96, and
/// the fit fails beyond 1. In units of the box, xi/L = 0.75 / 7.6 = 0.10.
pub const MAX_QMIN_XI: f64 = 0.75;

/// The fit is only meaningful if some q resolves the plateau (q xi < 1).
/// With fewer than 3 such points the fit is kept but carries a warning; from
/// q_min xi = [`MAX_QMIN_XI`] on it is marked unreliable. With chi0 held (paper
/// H's fit with chi0 = chi4, S4 at q = 0) the plateau is given, not fitted: each
/// q then fixes xi, and only the warning on few points q xi < 1 applies.
fn check_plateau(
    form: &str,
    data: Data<'_>,
    fixed: Fixed<'_>,
    fit: &mut FitResult,
) -> Result<(), FitError> {
    let xi = fit.value("xi");
    let qmin = data.x.iter().copied().fold(f64::INFINITY, f64::min);
    let plateau_held = fixed.iter().any(|(name, _)| *name == "chi0");
    if !plateau_held && qmin * xi >= 1.0 {
        return Err(FitError::unreliable(
            form,
            format!(
                "xi = {xi:.4} but the smallest q = {qmin:.4} gives q xi = {:.2} >= 1: no wavevector \
                 resolves the plateau, only chi0/xi^2 is determined (xi approaches the box size \
                 2 pi / q_min = {:.4}; use a larger system)",
                qmin * xi,
                std::f64::consts::TAU / qmin
            ),
        ));
    }
    if !plateau_held && qmin * xi > MAX_QMIN_XI {
        fit.warnings.push(format!(
            "{UNRELIABLE}q_min xi = {:.2} > {MAX_QMIN_XI} (xi/L ~ {:.3}): xi approaches the box \
             (2 pi / q_min = {:.4}) and is biased low by more than 10% (measured); use a \
             larger system",
            qmin * xi,
            qmin * xi / (1.21 * std::f64::consts::TAU),
            std::f64::consts::TAU / qmin
        ));
    }
    let on_plateau = data.x.iter().filter(|&&q| q * xi < 1.0).count();
    if on_plateau < 3 {
        fit.warnings.push(format!(
            "only {on_plateau} wavevector(s) with q xi < 1: chi0 and xi rest on few points"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact OZ data from q_min = 0.1 on: xi = 5 (q_min xi = 0.5) is reliable,
    /// xi = 8.5 (0.85) is kept but unreliable, xi = 12 (1.2) fails.
    #[test]
    fn xi_near_the_box_is_unreliable_then_fails() {
        let q: Vec<f64> = (1..=8).map(|k| 0.1 * k as f64).collect();
        let fit = |xi: f64| {
            let s: Vec<f64> = q.iter().map(|q| 2.0 / (1.0 + (q * xi).powi(2))).collect();
            let e: Vec<f64> = s.iter().map(|s| 1e-3 * s).collect();
            oz(Data::new(&q, &s, &e), &[])
        };
        let ok = fit(5.0).unwrap();
        assert!((ok.value("xi") - 5.0).abs() < 1e-3);
        assert!(
            ok.warnings.iter().all(|w| !w.contains("unreliable")),
            "{:?}",
            ok.warnings
        );
        let near = fit(8.5).unwrap();
        assert!((near.value("xi") - 8.5).abs() < 1e-2);
        let w = near.warnings.join("; ");
        assert!(
            w.starts_with(UNRELIABLE) && w.contains("q_min xi = 0.85"),
            "{w}"
        );
        let e = fit(12.0).unwrap_err().to_string();
        assert!(e.contains("unreliable") && e.contains("plateau"), "{e}");
    }

    /// With chi0 held at its true value (paper H's fit with chi0 = chi4), xi is
    /// recovered even where no q reaches the plateau (q_min xi = 1.2, 2): the
    /// failure above is for a fitted amplitude only.
    #[test]
    fn held_amplitude_recovers_xi_beyond_the_plateau() {
        let q: Vec<f64> = (1..=8).map(|k| 0.1 * k as f64).collect();
        for xi in [12.0, 20.0] {
            let s: Vec<f64> = q.iter().map(|q| 2.0 / (1.0 + (q * xi).powi(2))).collect();
            let e: Vec<f64> = s.iter().map(|s| 1e-3 * s).collect();
            let fit = oz(Data::new(&q, &s, &e), &[("chi0", 2.0)]).unwrap();
            assert!(
                (fit.value("xi") - xi).abs() < 1e-3 * xi,
                "xi = {}",
                fit.value("xi")
            );
            let w = fit.warnings.join("; ");
            assert!(!w.contains(UNRELIABLE) && w.contains("few points"), "{w}");
        }
    }
}
