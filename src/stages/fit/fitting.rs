//! The fit of a form to one group's points as the parameters ask for it (a
//! line for `drift`, errors scaled to the scatter without `y_err`), and the
//! numbers it reports.

use anyhow::Result;

use super::params::{FitForm, FitParams, drift_scale};
use crate::fit::catalogue::Form;
use crate::fit::{Data, FitError, FitResult, linear};

/// The fit itself; the data are finite points with positive errors.
pub(super) fn fit_form(
    p: &FitParams,
    x: &[f64],
    y: &[f64],
    s: &[f64],
    fixed: &[(&str, f64)],
) -> Result<FitResult> {
    Ok(fit_data(p, p.form.named(), Data::new(x, y, s), fixed)?)
}

/// The fit of `form` (a line for `drift`), errors scaled to the scatter without `y_err`.
pub(super) fn fit_data(
    p: &FitParams,
    form: Option<&Form>,
    d: Data<'_>,
    fixed: &[(&str, f64)],
) -> Result<FitResult, FitError> {
    let f = match form {
        Some(form) => (form.fit)(d, fixed)?,
        None => linear::line(d)?,
    };
    Ok(if p.y_err.is_none() {
        linear::scale_errors(f)
    } else {
        f
    })
}

/// The numbers a fit reports, in the order of its quantity rows (`drift`: the
/// relative change of y across the x range).
pub(super) fn reported(p: &FitParams, x: &[f64], y: &[f64], f: &FitResult) -> Vec<f64> {
    match p.form {
        FitForm::Drift => {
            let (span, mean) = drift_scale(x, y);
            vec![f.params[1] * span / mean]
        }
        FitForm::Named(_) | FitForm::Value => f.params.clone(),
    }
}
