//! Do the quoted errors mean what they say? Over several master seeds, the
//! fraction of seeds whose quoted 1-sigma interval covers the all-seed mean
//! (about 68% for honest Gaussian errors; a little more with few seeds, since
//! the mean shares each seed's noise: 71% with ten) and the ratio of the typical
//! quoted error to the seed-to-seed standard deviation (about 1 when honest).

use serde::{Deserialize, Serialize};

use super::results::Fitted;
use crate::analysis::stats::mean_std;

/// Coverage of one key number over the seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Coverage {
    pub figure: String,
    pub quantity: String,
    /// Seeds with a value and a finite quoted error.
    pub seeds: usize,
    pub mean: f64,
    /// Seed-to-seed standard deviation.
    pub spread: f64,
    /// Root mean square of the quoted errors.
    pub quoted: f64,
    /// Fraction of seeds with |value - mean| <= quoted error.
    pub coverage: f64,
    /// quoted / spread.
    pub ratio: f64,
}

/// Coverage of one quantity from its per-seed values and quoted errors; None
/// with fewer than two seeds that quote an error.
pub fn coverage(figure: &str, quantity: &str, per_seed: &[Fitted]) -> Option<Coverage> {
    let ok: Vec<&Fitted> = per_seed
        .iter()
        .filter(|f| f.value.is_finite() && f.error.is_finite() && f.error > 0.0)
        .collect();
    if ok.len() < 2 {
        return None;
    }
    let values: Vec<f64> = ok.iter().map(|f| f.value).collect();
    let (mean, spread) = mean_std(&values);
    let n = ok.len() as f64;
    let quoted = (ok.iter().map(|f| f.error * f.error).sum::<f64>() / n).sqrt();
    let covered = ok
        .iter()
        .filter(|f| (f.value - mean).abs() <= f.error)
        .count() as f64;
    Some(Coverage {
        figure: figure.into(),
        quantity: quantity.into(),
        seeds: ok.len(),
        mean,
        spread,
        quoted,
        coverage: covered / n,
        ratio: quoted / spread,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(value: f64, error: f64) -> Fitted {
        Fitted { value, error }
    }

    #[test]
    fn honest_errors_cover_and_small_ones_do_not() {
        // Values -1, 0, 1 (+ mean 0, spread 1): errors of 1 cover all three,
        // errors of 0.1 only the middle one.
        let honest = coverage("f", "q", &[f(-1.0, 1.0), f(0.0, 1.0), f(1.0, 1.0)]).unwrap();
        assert_eq!(honest.coverage, 1.0);
        assert!((honest.ratio - 1.0).abs() < 1e-12);
        let small = coverage("f", "q", &[f(-1.0, 0.1), f(0.0, 0.1), f(1.0, 0.1)]).unwrap();
        assert!((small.coverage - 1.0 / 3.0).abs() < 1e-12);
        assert!((small.ratio - 0.1).abs() < 1e-12);
        // Seeds without an error are left out; one seed is not enough.
        assert!(coverage("f", "q", &[f(1.0, f64::NAN), f(2.0, 0.5)]).is_none());
    }
}
