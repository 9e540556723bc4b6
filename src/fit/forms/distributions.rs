//! Distributions: the Gaussian van Hove function and its exponential tails
//! (paper H, Fig. 8) and the log-normal cluster-size distribution (Eq. 12-13).

use super::{Data, FitError, FitResult, Fixed, fit_form, log_y};
use crate::fit::linear::{line, linear_least_squares};
use crate::fit::result::{positive, require_positive};

/// Gaussian self part of the van Hove function at lag `t`,
/// P(dx) = exp(-dx^2 / (4 D t)) / sqrt(4 pi D t), with the diffusion coefficient
/// `D` the only parameter (the paper's dotted-dashed lines).
pub fn gaussian_van_hove(data: Data<'_>, t: f64) -> Result<FitResult, FitError> {
    const FORM: &str = "gaussian_van_hove";
    data.validate(FORM, 1)?;
    if !(t > 0.0 && t.is_finite()) {
        return Err(FitError::invalid(
            FORM,
            format!("lag time t = {t} must be > 0"),
        ));
    }
    // Start from the second moment of the histogram (equal bins assumed): <dx^2> = 2 D t.
    let norm: f64 = data.y.iter().map(|p| p.max(0.0)).sum();
    let m2: f64 = data
        .x
        .iter()
        .zip(data.y)
        .map(|(x, p)| x * x * p.max(0.0))
        .sum::<f64>()
        / norm;
    if !positive(m2) {
        return Err(FitError::unreliable(
            FORM,
            "the distribution has no positive weight off dx = 0",
        ));
    }
    let model = move |x: f64, p: &[f64]| {
        let w = 4.0 * p[0] * t;
        (-x * x / w).exp() / (std::f64::consts::PI * w).sqrt()
    };
    fit_form(
        FORM,
        &["D"],
        &model,
        data,
        vec![m2 / (2.0 * t)],
        vec![(0.0, f64::INFINITY)],
        &[],
    )
}

/// Exponential tail P(dx) = A exp(-|dx| / x0). Parameters: `A`, `x0`.
/// Pass only the tail points (e.g. |dx| beyond a few Gaussian widths).
pub fn exponential_tail(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    const FORM: &str = "exponential_tail";
    data.validate(FORM, 2usize.saturating_sub(fixed.len()))?;
    let (ly, ls) = log_y(FORM, data)?;
    let ax: Vec<f64> = data.x.iter().map(|x| x.abs()).collect();
    let start = line(Data::new(&ax, &ly, &ls))
        .map_err(|_| FitError::invalid(FORM, "all |dx| are equal; the tail needs a range of dx"))?;
    let slope = start.value("slope");
    if !positive(-slope) {
        return Err(FitError::unreliable(
            FORM,
            "P does not decrease with |dx| in the given range",
        ));
    }
    let model = |x: f64, p: &[f64]| p[0] * (-x.abs() / p[1]).exp();
    let p0 = vec![start.value("intercept").exp(), -1.0 / slope];
    let bounds = vec![(0.0, f64::INFINITY), (0.0, f64::INFINITY)];
    fit_form(FORM, &["A", "x0"], &model, data, p0, bounds, fixed)
}

/// Log-normal cluster-size distribution in the form of Eq. (13),
/// P(Nc) = P0 exp(-[ln(Nc / N_sigma)]^2 / (2 sigma^2)), equivalent to Eq. (12)
/// P ~ Nc^-1 exp(-[ln Nc - ln N0]^2 / (2 sigma^2)) with N_sigma = N0 exp(-sigma^2).
/// Parameters: `P0`, `N_sigma`, `sigma`. `data.x` is Nc > 0.
pub fn log_normal(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    const FORM: &str = "log_normal";
    data.validate(FORM, 3usize.saturating_sub(fixed.len()))?;
    require_positive(FORM, "Nc", data.x)?;
    // ln P = c0 + c1 u + c2 u^2 with u = ln Nc: a parabola on log-log axes.
    let (ly, ls) = log_y(FORM, data)?;
    let u: Vec<f64> = data.x.iter().map(|n| n.ln()).collect();
    let basis = |u: f64, b: &mut [f64]| {
        b[0] = 1.0;
        b[1] = u;
        b[2] = u * u;
    };
    let c = linear_least_squares(FORM, &["c0", "c1", "c2"], &basis, Data::new(&u, &ly, &ls))
        .map(|f| f.params)
        .unwrap_or_default();
    let p0 = match c.as_slice() {
        [c0, c1, c2] if *c2 < 0.0 => vec![
            (c0 - c1 * c1 / (4.0 * c2)).exp(),
            (-c1 / (2.0 * c2)).exp(),
            (-1.0 / (2.0 * c2)).sqrt(),
        ],
        _ => {
            return Err(FitError::unreliable(
                FORM,
                "ln P is not concave in ln Nc: no log-normal maximum in the data",
            ));
        }
    };
    let model = |n: f64, p: &[f64]| p[0] * (-(n / p[1]).ln().powi(2) / (2.0 * p[2] * p[2])).exp();
    let bounds = vec![(0.0, f64::INFINITY); 3];
    fit_form(
        FORM,
        &["P0", "N_sigma", "sigma"],
        &model,
        data,
        p0,
        bounds,
        fixed,
    )
}
