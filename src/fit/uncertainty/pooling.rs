//! Errors of fits on one state point each, pooled over the fits of a stage.

/// Fits on one state point each (a curve over lags, bins or q) whose replica
/// jackknife has R - 1 degrees of freedom: every such fit quotes its covariance
/// error times f, per fitted number f^2 = the mean over those fits of
/// (jackknife / covariance)^2. The scale then rests on G (R - 1) degrees of
/// freedom, and the errors keep the covariance's smooth dependence on the state
/// point: a fit downstream weighting by them (beta against tau0, xi against
/// phi) is not steered by one-degree-of-freedom noise. With one such fit this is
/// its jackknife error.
///
/// `fits` holds, per fit, (covariance error, jackknife error) of each fitted
/// number; returns each fit's pooled errors, in the same order.
pub fn pooled_errors(fits: &[Vec<(f64, f64)>]) -> Vec<Vec<f64>> {
    let n = fits.iter().map(Vec::len).max().unwrap_or(0);
    let factor: Vec<f64> = (0..n)
        .map(|p| {
            let r2: Vec<f64> = fits
                .iter()
                .filter_map(|f| f.get(p).copied())
                .filter(|(cov, jk)| cov.is_finite() && *cov > 0.0 && jk.is_finite())
                .map(|(cov, jk)| (jk / cov).powi(2))
                .collect();
            (r2.iter().sum::<f64>() / r2.len() as f64).sqrt()
        })
        .collect();
    fits.iter()
        .map(|pairs| {
            pairs
                .iter()
                .zip(&factor)
                .map(|(&(cov, jk), f)| {
                    if cov.is_finite() && cov > 0.0 && f.is_finite() {
                        cov * f
                    } else {
                        jk
                    }
                })
                .collect()
        })
        .collect()
}

/// The account of [`pooled_errors`] over `fits` fits, appended to the method.
pub fn pooled_method(fits: usize) -> String {
    format!(
        "; the {fits} fit(s) on one state point each quote their covariance error times sqrt(mean over them of (jackknife / covariance)^2)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two fits whose jackknife errors are 1 and 3 times their covariance
    /// errors: both quote their covariance error times sqrt(5); a number
    /// without a covariance error keeps its jackknife error.
    #[test]
    fn one_scale_for_every_fit_of_the_stage() {
        let e = pooled_errors(&[
            vec![(1.0, 1.0), (f64::NAN, 0.7)],
            vec![(2.0, 6.0), (1.0, 1.0)],
        ]);
        let f = 5f64.sqrt();
        assert!((e[0][0] - f).abs() < 1e-12 && (e[1][0] - 2.0 * f).abs() < 1e-12);
        assert_eq!(e[0][1], 0.7);
        assert_eq!(e[1][1], 1.0);
    }
}
