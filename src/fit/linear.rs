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

/// A trend in ln x that reaches zero at x_0: y = slope ln(x / x_0) (a number
/// against the box size N, and the N where it would change sign). Fitted as the
/// line y = a + slope ln x, then x_0 = exp(-a / slope), its covariance carried
/// by the Jacobian. Parameters: `slope`, `x_0`. A trend whose slope is within
/// one error of 0 has no crossing the data can place: the fit says so in its
/// warnings.
pub fn log_trend(data: Data<'_>) -> Result<FitResult, FitError> {
    if let Some(x) = data.x.iter().find(|x| !(**x > 0.0)) {
        return Err(FitError::InvalidInput {
            form: "log_trend".into(),
            what: format!("x must be > 0 (it is taken as ln x), got {x}"),
        });
    }
    let mut f = linear_least_squares(
        "log_trend",
        &["intercept", "slope"],
        &|x, b| {
            b[0] = 1.0;
            b[1] = x.ln();
        },
        data,
    )?;
    let (a, s) = (f.params[0], f.params[1]);
    let x0 = (-a / s).exp();
    if !(x0.is_finite() && x0 > 0.0) {
        // The slope is still measured; only where the trend reaches 0 is not.
        let e = f.covariance[1][1].sqrt();
        f.warnings.push(format!(
            "{}x_0: the trend is flat (slope {s:.3e} +- {e:.3e}), so y does not reach 0 at any representable x",
            crate::fit::result::UNRELIABLE
        ));
        f.names = vec!["slope".into(), "x_0".into()];
        f.params = vec![s, f64::NAN];
        f.covariance = vec![vec![f.covariance[1][1], f64::NAN], vec![f64::NAN, f64::NAN]];
        f.stderr = vec![e, f64::NAN];
        return Ok(f);
    }
    // d x0 / d(a, s), then x0's row and column of the covariance.
    let j = [-x0 / s, x0 * a / (s * s)];
    let c = &f.covariance;
    let cov_ss = c[1][1];
    let cov_sx = j[0] * c[1][0] + j[1] * c[1][1];
    let cov_xx = j[0] * j[0] * c[0][0] + 2.0 * j[0] * j[1] * c[0][1] + j[1] * j[1] * c[1][1];
    if s.abs() < cov_ss.sqrt() {
        f.warnings.push(format!(
            "the slope ({s:.3}) is within one error ({:.3}) of 0: x_0 is not placed by the data",
            cov_ss.sqrt()
        ));
    }
    f.names = vec!["slope".into(), "x_0".into()];
    f.params = vec![s, x0];
    f.covariance = vec![vec![cov_ss, cov_sx], vec![cov_sx, cov_xx]];
    f.stderr = vec![cov_ss.sqrt(), cov_xx.sqrt()];
    Ok(f)
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
    fn log_trend_places_the_crossing_and_carries_its_error() {
        // y = 0.5 ln(x / 20000) exactly: slope 0.5, x_0 = 20000.
        let x = [1000.0, 2000.0, 4000.0, 8000.0, 16000.0];
        let y: Vec<f64> = x.iter().map(|x: &f64| 0.5 * (x / 20000.0).ln()).collect();
        let s = [0.1; 5];
        let f = log_trend(Data::new(&x, &y, &s)).unwrap();
        assert!((f.value("slope") - 0.5).abs() < 1e-12);
        assert!((f.value("x_0") / 20000.0 - 1.0).abs() < 1e-9);
        assert!(f.warnings.is_empty());
        // The error of x_0 against a Monte Carlo over the same noise: the
        // Jacobian is exact to first order, within 15% at this noise.
        let lf = line(Data::new(&x.map(f64::ln), &y, &s)).unwrap();
        assert!((lf.error("slope") - f.error("slope")).abs() < 1e-12);
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12345);
        let mut gauss = || -> f64 { StandardNormal.sample(&mut rng) };
        let sigma = 0.02;
        let fits: Vec<f64> = (0..2000)
            .map(|_| {
                let yn: Vec<f64> = y.iter().map(|v| v + sigma * gauss()).collect();
                log_trend(Data::new(&x, &yn, &[sigma; 5]))
                    .unwrap()
                    .value("x_0")
                    .ln()
            })
            .collect();
        let m = fits.iter().sum::<f64>() / fits.len() as f64;
        let sd =
            (fits.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (fits.len() - 1) as f64).sqrt();
        let quoted = log_trend(Data::new(&x, &y, &[sigma; 5])).unwrap();
        // ln x_0's spread against the quoted relative error of x_0.
        let rel = quoted.error("x_0") / quoted.value("x_0");
        assert!((sd / rel - 1.0).abs() < 0.15, "spread {sd}, quoted {rel}");
        // A flat trend: no crossing to place.
        let flat = log_trend(Data::new(&x, &[-0.3, -0.31, -0.29, -0.3, -0.3], &s)).unwrap();
        assert!(
            flat.warnings.iter().any(|w| w.contains("not placed")),
            "{:?}",
            flat.warnings
        );
        // So flat that the crossing is beyond any representable x: the slope
        // is still reported, x_0 is NaN and the fit says it is unreliable.
        let level = log_trend(Data::new(&x, &[-1.3, -1.3, -1.3, -1.3, -1.3001], &s)).unwrap();
        assert!(level.value("slope").abs() < 1e-3 && level.error("slope") > 0.0);
        assert!(level.value("x_0").is_nan());
        assert!(
            level
                .warnings
                .iter()
                .any(|w| w.starts_with(crate::fit::result::UNRELIABLE))
        );
        assert!(log_trend(Data::new(&[0.0, 1.0, 2.0], &[1.0, 2.0, 3.0], &[1.0; 3])).is_err());
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
