//! The points a fit weights by: cleaned of non-finite values and of errors too
//! small to mean anything, and widened by a relative model scatter where the
//! model does not describe them within their errors.

use crate::fit::{FitError, FitResult};

/// Errors `s` widened by a relative model scatter `m |y|` in quadrature.
pub fn widened(s: &[f64], y: &[f64], m: f64) -> Vec<f64> {
    s.iter().zip(y).map(|(e, v)| e.hypot(m * v.abs())).collect()
}

/// The relative model scatter s_m that brings the reduced chi^2 of `fit` (the
/// fit of the points with the errors it is given) to 1, 0 when it is at most 1
/// with `s` already: doubling from 1e-3 until the reduced chi^2 falls to 1
/// (capped at 10), then bisection in log s_m (the reduced chi^2 falls as s_m
/// grows). Growing from small s_m keeps away from errors so large that a
/// nonlinear fit no longer converges. Returns s_m and the reduced chi^2 with the
/// errors alone.
pub fn relative_scatter(
    y: &[f64],
    s: &[f64],
    fit: impl Fn(&[f64]) -> Result<FitResult, FitError>,
) -> Result<(f64, f64), FitError> {
    // A fit that fails on the way (a parameter on its bound while a few
    // precise points still dominate) counts as a scatter too small.
    let chi2 = |m: f64| fit(&widened(s, y, m)).map_or(f64::INFINITY, |f| f.reduced_chi2);
    let alone = chi2(0.0);
    if alone <= 1.0 {
        return Ok((0.0, alone));
    }
    let (mut lo, mut hi) = (0.0, 1e-3);
    while chi2(hi) > 1.0 {
        if hi >= 10.0 {
            // Still above 1 at the cap: usable only if the fit converges there.
            fit(&widened(s, y, hi))?;
            return Ok((hi, alone));
        }
        (lo, hi) = (hi, 2.0 * hi);
    }
    let (mut lo, mut hi) = (f64::max(lo, 1e-6).ln(), f64::ln(hi));
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

/// Points cleaned for a fit: finite x and y only, and their errors.
pub struct Cleaned {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub s: Vec<f64>,
    /// How many points were dropped for a non-finite x or y.
    pub dropped: usize,
}

/// Finite points only; missing or non-positive errors replaced by the largest
/// valid one (conservative). So are errors below 10^-9 of the largest: a
/// jackknife over replicas that agree exactly (a histogram bin with the same
/// count in each) leaves rounding, 10^-17, which would weight that point 10^30
/// times the others and steer the fit by itself.
pub fn clean(x: &[f64], y: &[f64], s: &[f64]) -> Cleaned {
    let keep: Vec<usize> = (0..x.len())
        .filter(|&i| x[i].is_finite() && y[i].is_finite())
        .collect();
    let smax = keep
        .iter()
        .map(|&i| s[i])
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold(0.0, f64::max);
    let fill = if smax > 0.0 { smax } else { 1.0 };
    let resolved = 1e-9 * smax;
    Cleaned {
        x: keep.iter().map(|&i| x[i]).collect(),
        y: keep.iter().map(|&i| y[i]).collect(),
        s: keep
            .iter()
            .map(|&i| {
                if s[i].is_finite() && s[i] > resolved {
                    s[i]
                } else {
                    fill
                }
            })
            .collect(),
        dropped: x.len() - keep.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Data;
    use crate::fit::catalogue;

    fn power_law(x: &[f64], y: &[f64], s: &[f64]) -> Result<FitResult, FitError> {
        (catalogue::find("power_law").unwrap().fit)(Data::new(x, y, s), &[])
    }

    /// Points that scatter 15% about a power law (factors 1.15, 1, 0.85 in
    /// turn) with errors of 0.2%: the scatter found makes the reduced chi^2 of
    /// the widened errors 1.
    #[test]
    fn the_relative_scatter_brings_the_reduced_chi2_to_one() {
        let factor = [1.15, 1.0, 0.85];
        let x: Vec<f64> = (1..=15).map(|i| 1.5 * i as f64).collect();
        let y: Vec<f64> = (0..x.len())
            .map(|i| 3.0 * x[i].powf(-0.7) * factor[i % 3])
            .collect();
        let s: Vec<f64> = y.iter().map(|v| 2e-3 * v).collect();
        let (m, alone) = relative_scatter(&y, &s, |s| power_law(&x, &y, s)).unwrap();
        assert!(alone > 1000.0, "{alone}");
        assert!((0.05..0.3).contains(&m), "{m}");
        let f = power_law(&x, &y, &widened(&s, &y, m)).unwrap();
        assert!((f.reduced_chi2 - 1.0).abs() < 1e-3, "{}", f.reduced_chi2);
        // Errors that describe the scatter already: none added.
        let big: Vec<f64> = y.iter().map(|v| 0.5 * v).collect();
        assert_eq!(
            relative_scatter(&y, &big, |s| power_law(&x, &y, s))
                .unwrap()
                .0,
            0.0
        );
    }

    /// Non-finite points go; errors that are missing, non-positive or of
    /// rounding size take the largest valid one.
    #[test]
    fn cleaning_drops_non_finite_points_and_fills_meaningless_errors() {
        let c = clean(
            &[1.0, 2.0, f64::NAN, 4.0, 5.0],
            &[1.0, 2.0, 3.0, 4.0, 5.0],
            &[0.1, f64::NAN, 0.1, 1e-20, 0.3],
        );
        assert_eq!(c.dropped, 1);
        assert_eq!(c.x, [1.0, 2.0, 4.0, 5.0]);
        assert_eq!(c.s, [0.1, 0.3, 0.3, 0.3]);
    }
}
