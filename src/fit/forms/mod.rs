//! The named fit forms of papers H and I. Each function documents its parameter
//! names (the column names tables carry) and accepts `fixed`: a list of
//! (parameter name, value) pairs held fixed during the fit.

mod distributions;
mod oz;
mod power_law;
mod relaxation;
mod singular;

pub use distributions::{exponential_tail, gaussian_van_hove, log_normal};
pub use oz::{oz, oz_quartic};
pub use power_law::{crossover, power_law};
pub use relaxation::q_relaxation;
pub use singular::{
    AIC_MARGIN, DivergenceShape, Shape, UNRELIABLE, joint_power_law_offset, on_last_point,
    power_law_offset, vft,
};

use super::least_squares::Model;
use super::result::require_positive;
use super::{Data, FitError, FitOptions, FitResult, least_squares};

/// Parameters held fixed: (name, value).
pub type Fixed<'a> = &'a [(&'a str, f64)];

/// Fits a named form: applies `fixed` by name to the start values, then runs
/// [`least_squares`] with the given bounds.
fn fit_form(
    form: &str,
    names: &[&str],
    model: Model<'_>,
    data: Data<'_>,
    mut p0: Vec<f64>,
    bounds: Vec<(f64, f64)>,
    fixed: Fixed<'_>,
) -> Result<FitResult, FitError> {
    let mask = fixed_mask(form, names, fixed, &mut p0)?;
    // A fixed value may legitimately sit outside the bounds meant for fitting
    // (those exist to guide the minimiser): drop the bound of a fixed parameter.
    let bounds = bounds
        .into_iter()
        .zip(&mask)
        .map(|(b, &f)| {
            if f {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                b
            }
        })
        .collect();
    let opts = FitOptions {
        bounds,
        fixed: mask,
        ..FitOptions::default()
    };
    least_squares(form, names, model, data, &p0, &opts)
}

/// Writes the fixed values into `p0` and returns which parameters are fixed.
fn fixed_mask(
    form: &str,
    names: &[&str],
    fixed: Fixed<'_>,
    p0: &mut [f64],
) -> Result<Vec<bool>, FitError> {
    let mut mask = vec![false; names.len()];
    for &(name, value) in fixed {
        let Some(j) = names.iter().position(|n| *n == name) else {
            return Err(FitError::invalid(
                form,
                format!("cannot fix unknown parameter `{name}`; parameters are {names:?}"),
            ));
        };
        if !value.is_finite() {
            return Err(FitError::invalid(
                form,
                format!("fixed value of `{name}` is {value}"),
            ));
        }
        mask[j] = true;
        p0[j] = value;
    }
    Ok(mask)
}

/// The value given for a parameter in `fixed`, if any.
fn fixed_value(fixed: Fixed<'_>, name: &str) -> Option<f64> {
    fixed.iter().find(|(n, _)| *n == name).map(|&(_, v)| v)
}

/// (ln y, sigma / y) for positive y: the log-space data used for starting values.
fn log_y(form: &str, data: Data<'_>) -> Result<(Vec<f64>, Vec<f64>), FitError> {
    require_positive(form, "y", data.y)?;
    Ok((
        data.y.iter().map(|y| y.ln()).collect(),
        data.y.iter().zip(data.sigma).map(|(y, s)| s / y).collect(),
    ))
}
