//! General weighted nonlinear least squares: MPFIT (Levenberg-Marquardt with
//! bounds and fixed parameters, crate `rmpfit`) finds the minimum; the
//! covariance is computed here from a central-difference Jacobian so that a
//! singular J^T J is reported by name instead of silently giving zero errors.

use rmpfit::{MPConfig, MPError, MPFitter, MPPar, MPResult, MPSuccess};

use super::linalg::spd_inverse;
use super::{Data, FitError, FitResult};

/// A model y = f(x; p).
pub type Model<'a> = &'a dyn Fn(f64, &[f64]) -> f64;

/// Bounds, fixed parameters and error treatment for [`least_squares`].
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Per-parameter (lower, upper); use +-infinity for an open side. Empty = no bounds.
    pub bounds: Vec<(f64, f64)>,
    /// Per-parameter: held at its starting value. Empty = all free.
    pub fixed: Vec<bool>,
    /// Multiply the covariance by the reduced chi-square (when the data errors
    /// are only relative weights).
    pub scale_errors: bool,
    pub max_iter: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            bounds: Vec::new(),
            fixed: Vec::new(),
            scale_errors: false,
            max_iter: 500,
        }
    }
}

struct Problem<'a> {
    model: Model<'a>,
    data: Data<'a>,
    pars: Vec<MPPar>,
    config: MPConfig,
    bad_params: Option<Vec<f64>>,
}

impl MPFitter for Problem<'_> {
    fn eval(&mut self, p: &[f64], dev: &mut [f64]) -> MPResult<()> {
        let d = self.data;
        for (i, dev) in dev.iter_mut().enumerate() {
            *dev = (d.y[i] - (self.model)(d.x[i], p)) / d.sigma[i];
            if !dev.is_finite() {
                self.bad_params = Some(p.to_vec());
                return Err(MPError::Nan);
            }
        }
        Ok(())
    }

    fn number_of_points(&self) -> usize {
        self.data.len()
    }

    fn config(&self) -> &MPConfig {
        &self.config
    }

    fn parameters(&self) -> &[MPPar] {
        &self.pars
    }
}

/// Weighted least-squares fit of `model` to `data`, starting from `p0`.
///
/// `form` names the fit in errors and in the result; `names` name the
/// parameters. Errors are 1-sigma from the inverse of J^T J (times the reduced
/// chi-square when `opts.scale_errors`).
pub fn least_squares(
    form: &str,
    names: &[&str],
    model: Model<'_>,
    data: Data<'_>,
    p0: &[f64],
    opts: &FitOptions,
) -> Result<FitResult, FitError> {
    let setup = checked_setup(form, names, data, p0, opts)?;
    let free = setup.fixed.iter().filter(|f| !**f).count();
    let (p, iterations) = minimise(form, names, model, data, p0, opts, &setup)?;
    let residual = |q: &[f64]| -> Vec<f64> {
        (0..data.len())
            .map(|i| (data.y[i] - model(data.x[i], q)) / data.sigma[i])
            .collect()
    };
    let r0 = residual(&p);
    let chi2: f64 = r0.iter().map(|r| r * r).sum();
    let dof = data.len() - free;
    let reduced_chi2 = chi2 / dof as f64;
    let scale = if opts.scale_errors { reduced_chi2 } else { 1.0 };
    let covariance = covariance_at(form, names, &residual, &p, p0, &setup, scale)?;
    let stderr = (0..p.len()).map(|j| covariance[j][j].sqrt()).collect();
    Ok(FitResult {
        form: form.to_string(),
        names: names.iter().map(|s| s.to_string()).collect(),
        params: p,
        stderr,
        covariance,
        fixed: setup.fixed,
        chi2,
        dof,
        reduced_chi2,
        converged: true,
        iterations,
        errors_scaled: opts.scale_errors,
        warnings: Vec::new(),
    })
}

/// Per parameter: held at its start value, and its (lower, upper) bounds.
struct Setup {
    fixed: Vec<bool>,
    bounds: Vec<(f64, f64)>,
}

/// The per-parameter fixed flags and bounds of `opts`, after checking that
/// names, options, data and start values fit together.
fn checked_setup(
    form: &str,
    names: &[&str],
    data: Data<'_>,
    p0: &[f64],
    opts: &FitOptions,
) -> Result<Setup, FitError> {
    let np = p0.len();
    if names.len() != np {
        return Err(FitError::invalid(
            form,
            format!("{} parameter names for {} starting values", names.len(), np),
        ));
    }
    for (what, len) in [("bounds", opts.bounds.len()), ("fixed", opts.fixed.len())] {
        if len != 0 && len != np {
            return Err(FitError::invalid(
                form,
                format!("{what} has {len} entries; give none or one per parameter ({np})"),
            ));
        }
    }
    let fixed: Vec<bool> = (0..np)
        .map(|j| opts.fixed.get(j).copied().unwrap_or(false))
        .collect();
    let bounds: Vec<(f64, f64)> = (0..np)
        .map(|j| {
            opts.bounds
                .get(j)
                .copied()
                .unwrap_or((f64::NEG_INFINITY, f64::INFINITY))
        })
        .collect();
    let free = fixed.iter().filter(|f| !**f).count();
    if free == 0 {
        return Err(FitError::invalid(
            form,
            "every parameter is fixed; nothing to fit",
        ));
    }
    data.validate(form, free)?;
    for j in 0..np {
        let (lo, hi) = bounds[j];
        if !p0[j].is_finite() || p0[j] < lo || p0[j] > hi || lo.is_nan() || hi.is_nan() {
            return Err(FitError::invalid(
                form,
                format!(
                    "start value {} = {} is not finite or outside its bounds [{lo}, {hi}]",
                    names[j], p0[j]
                ),
            ));
        }
    }
    Ok(Setup { fixed, bounds })
}

/// MPFIT's minimum and its iteration count; a minimum on a bound of a free
/// parameter is an error (its error bar would be meaningless).
fn minimise(
    form: &str,
    names: &[&str],
    model: Model<'_>,
    data: Data<'_>,
    p0: &[f64],
    opts: &FitOptions,
    setup: &Setup,
) -> Result<(Vec<f64>, usize), FitError> {
    let (fixed, bounds) = (&setup.fixed, &setup.bounds);
    let np = p0.len();
    let pars = (0..np)
        .map(|j| {
            let mut p = MPPar::new();
            p.fixed = fixed[j];
            let (lo, hi) = bounds[j];
            p.limited_low = lo.is_finite();
            p.limited_up = hi.is_finite();
            p.limit_low = if lo.is_finite() { lo } else { 0.0 };
            p.limit_up = if hi.is_finite() { hi } else { 0.0 };
            p
        })
        .collect();
    let mut config = MPConfig::new();
    config.max_iter = opts.max_iter;
    let mut problem = Problem {
        model,
        data,
        pars,
        config,
        bad_params: None,
    };
    let mut p = p0.to_vec();
    let status = match problem.mpfit(&mut p) {
        Ok(s) => s,
        Err(MPError::Nan) => {
            let at = problem.bad_params.unwrap_or_else(|| p0.to_vec());
            return Err(FitError::unreliable(
                form,
                format!(
                    "the model is not finite at parameters {at:?}; give bounds that keep it defined \
                     or better starting values"
                ),
            ));
        }
        Err(e) => {
            return Err(FitError::invalid(
                form,
                format!("MPFIT rejected the problem: {e}"),
            ));
        }
    };
    let iterations = status.n_iter;
    if status.success == MPSuccess::MaxIter || p.iter().any(|v| !v.is_finite()) {
        return Err(FitError::NotConverged {
            form: form.to_string(),
            iterations,
            hint: "give starting values closer to the solution, add bounds or fix a parameter"
                .to_string(),
        });
    }
    for j in (0..np).filter(|&j| !fixed[j]) {
        let (lo, hi) = bounds[j];
        for b in [lo, hi] {
            if b.is_finite() && (p[j] == b || (p[j] - b).abs() <= 1e-9 * b.abs()) {
                return Err(FitError::AtBound {
                    form: form.to_string(),
                    parameter: names[j].to_string(),
                    value: p[j],
                    bound: b,
                    hint: "the data prefer a value outside the allowed range; its error bar would \
                           be meaningless (fix it, widen the data range or change the form)"
                        .to_string(),
                });
            }
        }
    }
    Ok((p, iterations))
}

/// The covariance of the free parameters at the minimum `p`: the inverse of
/// J^T J of the residuals (times `scale`), zero rows and columns for fixed ones.
fn covariance_at(
    form: &str,
    names: &[&str],
    residual: &dyn Fn(&[f64]) -> Vec<f64>,
    p: &[f64],
    p0: &[f64],
    setup: &Setup,
    scale: f64,
) -> Result<Vec<Vec<f64>>, FitError> {
    let (fixed, bounds) = (&setup.fixed, &setup.bounds);
    let np = p.len();
    let free = fixed.iter().filter(|f| !**f).count();
    let r0 = residual(p);
    // Jacobian of the residuals w.r.t. the free parameters (central differences,
    // one-sided where a bound or the model's domain forbids a side).
    let free_idx: Vec<usize> = (0..np).filter(|&j| !fixed[j]).collect();
    let mut jac = Vec::with_capacity(free);
    for &j in &free_idx {
        let size = p[j].abs().max(p0[j].abs());
        let h = if size > 0.0 { 1e-6 * size } else { 1e-8 };
        let shifted = |delta: f64| -> Option<Vec<f64>> {
            let v = p[j] + delta;
            if v < bounds[j].0 || v > bounds[j].1 {
                return None;
            }
            let mut q = p.to_vec();
            q[j] = v;
            let r = residual(&q);
            r.iter().all(|x| x.is_finite()).then_some(r)
        };
        let col: Vec<f64> = match (shifted(h), shifted(-h)) {
            (Some(a), Some(b)) => a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect(),
            (Some(a), None) => a.iter().zip(&r0).map(|(a, b)| (a - b) / h).collect(),
            (None, Some(b)) => r0.iter().zip(&b).map(|(a, b)| (a - b) / h).collect(),
            (None, None) => {
                return Err(FitError::unreliable(
                    form,
                    format!(
                        "cannot differentiate with respect to `{}` at {}",
                        names[j], p[j]
                    ),
                ));
            }
        };
        jac.push(col);
    }
    let jtj: Vec<Vec<f64>> = jac
        .iter()
        .map(|a| {
            jac.iter()
                .map(|b| a.iter().zip(b).map(|(x, y)| x * y).sum())
                .collect()
        })
        .collect();
    let inv = spd_inverse(&jtj).map_err(|k| FitError::IllConditioned {
        form: form.to_string(),
        parameter: names[free_idx[k]].to_string(),
        hint: "J^T J is singular; fix this parameter, add data where it matters, or drop it from \
               the form"
            .to_string(),
    })?;
    let mut covariance = vec![vec![0.0; np]; np];
    for (a, &i) in free_idx.iter().enumerate() {
        for (b, &j) in free_idx.iter().enumerate() {
            covariance[i][j] = inv[a][b] * scale;
        }
    }
    Ok(covariance)
}
