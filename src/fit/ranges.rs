//! Fit-range robustness (paper H, Appendix, Fig. 25): the same fit over several
//! x ranges, and how much each parameter moves between them.

use serde::Serialize;

use super::{Data, FitError, FitResult};

/// One range and what the fit gave there.
#[derive(Debug, Clone, Serialize)]
pub struct RangeFit {
    pub lo: f64,
    pub hi: f64,
    pub points: usize,
    /// The fit, or the error message if it failed in this range.
    pub result: Result<FitResult, String>,
}

/// Spread of one parameter over the ranges whose fit succeeded (each distinct
/// set of points once).
#[derive(Debug, Clone, Serialize)]
pub struct ParamSpread {
    pub name: String,
    pub mean: f64,
    pub min: f64,
    pub max: f64,
    /// Standard deviation of the values between ranges with distinct point
    /// sets; NaN when fewer than two such ranges fit (one window has no spread
    /// to measure, and a 0 would read as a fit that does not depend on its
    /// range).
    pub std: f64,
    /// Largest statistical error of a single fit, to compare the spread with.
    pub max_stderr: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct RangeScan {
    pub fits: Vec<RangeFit>,
    pub spread: Vec<ParamSpread>,
}

/// Runs `fit` on the points with lo <= x <= hi for each range in `ranges`.
/// Fails only if no range gives a fit; failed ranges are kept with their error.
pub fn range_scan(
    data: Data<'_>,
    ranges: &[(f64, f64)],
    fit: &dyn Fn(Data<'_>) -> Result<FitResult, FitError>,
) -> Result<RangeScan, FitError> {
    if ranges.is_empty() {
        return Err(FitError::invalid("range_scan", "no fit ranges given"));
    }
    // Each window's fit, and the points it selected.
    let (fits, points): (Vec<RangeFit>, Vec<Vec<u64>>) = ranges
        .iter()
        .map(|&(lo, hi)| {
            let (x, y, s) = data.window(lo, hi);
            let fit = RangeFit {
                lo,
                hi,
                points: x.len(),
                result: fit(Data::new(&x, &y, &s)).map_err(|e| e.to_string()),
            };
            (fit, x.iter().map(|v| v.to_bits()).collect())
        })
        .unzip();
    // Windows that select the same points give the same fit: the spread is
    // taken over distinct point sets, so two such windows do not read as a fit
    // independent of its range.
    let mut sets: Vec<&Vec<u64>> = Vec::new();
    let ok: Vec<&FitResult> = fits
        .iter()
        .zip(&points)
        .filter_map(|(f, key)| {
            let r = f.result.as_ref().ok()?;
            if sets.contains(&key) {
                return None;
            }
            sets.push(key);
            Some(r)
        })
        .collect();
    let Some(first) = ok.first() else {
        let why: Vec<String> = fits
            .iter()
            .map(|f| format!("[{}, {}]: {}", f.lo, f.hi, f.result.as_ref().unwrap_err()))
            .collect();
        return Err(FitError::unreliable(
            "range_scan",
            format!("the fit failed in every range: {}", why.join("; ")),
        ));
    };
    let spread = (0..first.params.len())
        .map(|j| {
            let v: Vec<f64> = ok.iter().map(|f| f.params[j]).collect();
            let n = v.len() as f64;
            let mean = v.iter().sum::<f64>() / n;
            let var = if v.len() < 2 {
                f64::NAN
            } else {
                v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
            };
            ParamSpread {
                name: first.names[j].clone(),
                mean,
                min: v.iter().copied().fold(f64::INFINITY, f64::min),
                max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                std: var.sqrt(),
                max_stderr: ok.iter().map(|f| f.stderr[j]).fold(0.0, f64::max),
            }
        })
        .collect();
    Ok(RangeScan { fits, spread })
}
