//! Weighted linear least squares: y = sum_k c_k b_k(x), solved exactly through
//! the normal equations. One piece of code for straight lines (D from
//! MSD = 4 D t), power laws on log-log data and polynomial starting values.

use super::linalg::spd_inverse;
use super::{Data, FitError, FitResult};

/// Fits y = sum_k c_k basis(x)[k]; `names` name the coefficients.
pub fn linear_least_squares(
    form: &str,
    names: &[&str],
    basis: &dyn Fn(f64, &mut [f64]),
    data: Data<'_>,
) -> Result<FitResult, FitError> {
    let k = names.len();
    data.validate(form, k)?;
    let mut row = vec![0.0; k];
    let mut ata = vec![vec![0.0; k]; k];
    let mut aty = vec![0.0; k];
    for i in 0..data.len() {
        basis(data.x[i], &mut row);
        let w = 1.0 / (data.sigma[i] * data.sigma[i]);
        for a in 0..k {
            aty[a] += w * row[a] * data.y[i];
            for b in 0..k {
                ata[a][b] += w * row[a] * row[b];
            }
        }
    }
    let cov = spd_inverse(&ata).map_err(|j| FitError::IllConditioned {
        form: form.to_string(),
        parameter: names[j].to_string(),
        hint: "the basis functions are degenerate on these x values (e.g. all x equal)".to_string(),
    })?;
    let params: Vec<f64> = (0..k)
        .map(|a| (0..k).map(|b| cov[a][b] * aty[b]).sum())
        .collect();
    let mut chi2 = 0.0;
    for i in 0..data.len() {
        basis(data.x[i], &mut row);
        let f: f64 = row.iter().zip(&params).map(|(r, c)| r * c).sum();
        chi2 += ((data.y[i] - f) / data.sigma[i]).powi(2);
    }
    let dof = data.len() - k;
    Ok(FitResult {
        form: form.to_string(),
        names: names.iter().map(|s| s.to_string()).collect(),
        stderr: (0..k).map(|a| cov[a][a].sqrt()).collect(),
        params,
        covariance: cov,
        fixed: vec![false; k],
        chi2,
        dof,
        reduced_chi2: chi2 / dof as f64,
        converged: true,
        iterations: 0,
        errors_scaled: false,
        warnings: Vec::new(),
    })
}

/// Straight line y = intercept + slope x. Parameters: `intercept`, `slope`.
pub fn line(data: Data<'_>) -> Result<FitResult, FitError> {
    linear_least_squares(
        "line",
        &["intercept", "slope"],
        &|x, b| {
            b[0] = 1.0;
            b[1] = x;
        },
        data,
    )
}

/// Line through the origin y = slope x (e.g. MSD = 4 D t). Parameter: `slope`.
pub fn proportional(data: Data<'_>) -> Result<FitResult, FitError> {
    linear_least_squares("proportional", &["slope"], &|x, b| b[0] = x, data)
}

/// Multiplies the covariance by the reduced chi-square, for data whose errors
/// are only relative weights (or unknown: pass sigma = 1).
pub fn scale_errors(mut fit: FitResult) -> FitResult {
    if fit.errors_scaled {
        return fit;
    }
    let s = fit.reduced_chi2;
    for row in &mut fit.covariance {
        for c in row.iter_mut() {
            *c *= s;
        }
    }
    fit.stderr = (0..fit.params.len())
        .map(|j| fit.covariance[j][j].sqrt())
        .collect();
    fit.errors_scaled = true;
    fit
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_through_exact_points_matches_textbook_formulas() {
        // Three points, unit errors: slope = S_xy/S_xx, var(slope) = 1/S_xx.
        let x = [0.0, 1.0, 2.0];
        let y = [1.0, 3.0, 5.5];
        let s = [1.0; 3];
        let f = line(Data::new(&x, &y, &s)).unwrap();
        let xm = 1.0;
        let ym = 9.5 / 3.0;
        let sxx: f64 = x.iter().map(|x| (x - xm) * (x - xm)).sum();
        let sxy: f64 = x.iter().zip(&y).map(|(x, y)| (x - xm) * (y - ym)).sum();
        assert!((f.value("slope") - sxy / sxx).abs() < 1e-12);
        assert!((f.value("intercept") - (ym - sxy / sxx * xm)).abs() < 1e-12);
        assert!((f.error("slope") - (1.0 / sxx).sqrt()).abs() < 1e-12);
        // With unit errors chi2 is the plain sum of squared residuals.
        let r: f64 = x
            .iter()
            .zip(&y)
            .map(|(x, y)| (y - f.value("intercept") - f.value("slope") * x).powi(2))
            .sum();
        assert!((f.chi2 - r).abs() < 1e-12);
        assert_eq!(f.dof, 1);
    }

    #[test]
    fn proportional_recovers_diffusion_from_exact_msd() {
        let t: Vec<f64> = (1..10).map(|i| i as f64).collect();
        let msd: Vec<f64> = t.iter().map(|t| 4.0 * 0.25 * t).collect();
        let s = vec![0.1; t.len()];
        let f = proportional(Data::new(&t, &msd, &s)).unwrap();
        assert!((f.value("slope") / 4.0 - 0.25).abs() < 1e-12);
        assert!(f.chi2 < 1e-20);
    }

    #[test]
    fn degenerate_x_is_ill_conditioned_not_nan() {
        let x = [2.0; 4];
        let y = [1.0, 2.0, 3.0, 4.0];
        let s = [1.0; 4];
        let e = line(Data::new(&x, &y, &s)).unwrap_err();
        assert!(matches!(e, FitError::IllConditioned { .. }), "{e}");
    }
}
