//! Errors of fits on one state point each, pooled over a stage's fits.

use anyhow::Result;

use super::group::Group;
use super::quantities::with_errors;

/// Fits on one state point each (a curve over lags, bins or q) whose replica
/// jackknife has R - 1 degrees of freedom: every such fit of the stage quotes
/// its covariance error times f, per fitted number f^2 = the mean over those
/// fits of (jackknife / covariance)^2. The scale then rests on G (R - 1)
/// degrees of freedom, and the errors keep the covariance's smooth dependence
/// on the state point: a fit downstream weighting by them (beta against tau0,
/// xi against phi) is not steered by one-degree-of-freedom noise. With one such
/// fit this is its jackknife error. Returns the method line, if any fit took part.
pub(super) fn pool_one_unit_errors(groups: &mut [Group]) -> Result<Option<String>> {
    let with: Vec<usize> = (0..groups.len())
        .filter(|&g| groups[g].pooled.is_some())
        .collect();
    if with.is_empty() {
        return Ok(None);
    }
    let n = with
        .iter()
        .map(|&g| groups[g].pooled.as_ref().map_or(0, Vec::len))
        .max()
        .unwrap_or(0);
    let factor: Vec<f64> = (0..n)
        .map(|p| {
            let r2: Vec<f64> = with
                .iter()
                .filter_map(|&g| groups[g].pooled.as_ref()?.get(p).copied())
                .filter(|(cov, jk)| cov.is_finite() && *cov > 0.0 && jk.is_finite())
                .map(|(cov, jk)| (jk / cov).powi(2))
                .collect();
            (r2.iter().sum::<f64>() / r2.len() as f64).sqrt()
        })
        .collect();
    for &g in &with {
        let pairs = groups[g].pooled.take().unwrap_or_default();
        let errors: Vec<f64> = pairs
            .iter()
            .zip(&factor)
            .map(|(&(cov, jk), f)| {
                if cov.is_finite() && cov > 0.0 && f.is_finite() {
                    cov * f
                } else {
                    jk
                }
            })
            .collect();
        groups[g].table = with_errors(&groups[g].table, &errors)?;
    }
    Ok(Some(format!(
        "; the {} fit(s) on one state point each quote their covariance error times sqrt(mean over them of (jackknife / covariance)^2)",
        with.len()
    )))
}
