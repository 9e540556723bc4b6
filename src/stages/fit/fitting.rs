//! The fit of a form to one group's points: the points cleaned, the fit (a
//! line for `drift`), a relative model scatter, and the numbers it reports.

use anyhow::Result;

use super::params::{FitForm, FitParams, drift_scale};
use crate::fit::catalogue::Form;
use crate::fit::{Data, FitError, FitResult, linear};
use crate::pipeline::StageCtx;
use crate::stages::tables::pick;

/// Errors `s` widened by a relative model scatter `m |y|` in quadrature.
pub(super) fn widened(s: &[f64], y: &[f64], m: f64) -> Vec<f64> {
    s.iter().zip(y).map(|(e, v)| e.hypot(m * v.abs())).collect()
}

/// The relative model scatter s_m that brings the fit's reduced chi^2 to 1
/// (`scatter: relative`), 0 when it is at most 1 already: doubling from 1e-3
/// until the reduced chi^2 falls to 1 (capped at 10), then bisection in log
/// s_m (the reduced chi^2 falls as s_m grows). Growing from small s_m keeps
/// away from errors so large that a nonlinear fit no longer converges.
/// Returns s_m and the reduced chi^2 with the errors alone.
pub(super) fn relative_scatter(
    p: &FitParams,
    x: &[f64],
    y: &[f64],
    s: &[f64],
    fixed: &[(&str, f64)],
) -> Result<(f64, f64)> {
    // A fit that fails on the way (a parameter on its bound while a few
    // precise points still dominate) counts as a scatter too small.
    let chi2 = |m: f64| {
        fit_form(p, x, y, &widened(s, y, m), fixed).map_or(f64::INFINITY, |f| f.reduced_chi2)
    };
    let alone = chi2(0.0);
    if alone <= 1.0 {
        return Ok((0.0, alone));
    }
    let (mut lo, mut hi) = (0.0, 1e-3);
    while chi2(hi) > 1.0 {
        if hi >= 10.0 {
            // Still above 1 at the cap: usable only if the fit converges there.
            fit_form(p, x, y, &widened(s, y, hi), fixed)?;
            return Ok((hi, alone));
        }
        (lo, hi) = (hi, 2.0 * hi);
    }
    let (mut lo, mut hi) = (lo.max(1e-6).ln(), hi.ln());
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if chi2(mid.exp()) > 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok((hi.exp(), alone))
}

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

/// Finite points only; missing or non-positive errors replaced by the largest
/// valid one (conservative), logged. So are errors below 10^-9 of the largest:
/// a jackknife over replicas that agree exactly (a histogram bin with the same
/// count in each) leaves rounding, 10^-17, which would weight that point 10^30
/// times the others and steer the fit by itself.
pub(super) fn clean(
    ctx: &StageCtx,
    x: Vec<f64>,
    y: Vec<f64>,
    s: Vec<f64>,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let keep: Vec<usize> = (0..x.len())
        .filter(|&i| x[i].is_finite() && y[i].is_finite())
        .collect();
    if keep.len() < x.len() {
        ctx.log(format!(
            "dropped {} point(s) with non-finite x or y",
            x.len() - keep.len()
        ));
    }
    let smax = keep
        .iter()
        .map(|&i| s[i])
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold(0.0, f64::max);
    let fill = if smax > 0.0 { smax } else { 1.0 };
    let resolved = 1e-9 * smax;
    (
        pick(&x, &keep),
        pick(&y, &keep),
        keep.iter()
            .map(|&i| {
                if s[i].is_finite() && s[i] > resolved {
                    s[i]
                } else {
                    fill
                }
            })
            .collect(),
    )
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
