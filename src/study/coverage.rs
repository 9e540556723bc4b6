//! Do the quoted errors mean what they say? Over several master seeds, the
//! fraction of seeds whose quoted 1-sigma interval covers the all-seed mean
//! (about 68% for honest Gaussian errors; a little more with few seeds, since
//! the mean shares each seed's noise: 71% with ten) and the ratio of the typical
//! quoted error to the seed-to-seed standard deviation (about 1 when honest).

use serde::{Deserialize, Serialize};

use super::golden::GoldenFile;
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
    /// Median quoted error / spread: the typical seed's error, which a few seeds
    /// quoting huge errors (a refit jumping to another minimum) cannot inflate.
    #[serde(default)]
    pub median_ratio: f64,
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
    let mut errors: Vec<f64> = ok.iter().map(|f| f.error).collect();
    errors.sort_by(f64::total_cmp);
    let m = errors.len();
    let median = if m % 2 == 1 {
        errors[m / 2]
    } else {
        0.5 * (errors[m / 2 - 1] + errors[m / 2])
    };
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
        median_ratio: median / spread,
    })
}

/// Coverage of every key number a golden file recorded with per-seed quoted
/// errors (`repro regress --record`), restricted to the figures `ids` if any:
/// the same table as building the seeds again, without a run.
pub fn from_golden(g: &GoldenFile, ids: &[String]) -> Vec<Coverage> {
    g.quantities
        .iter()
        .filter(|q| ids.is_empty() || ids.contains(&q.figure))
        .filter(|q| q.errors.len() == q.values.len())
        .filter_map(|q| {
            let per_seed: Vec<Fitted> = q
                .values
                .iter()
                .zip(&q.errors)
                .map(|(&value, &error)| Fitted {
                    value,
                    error,
                    verdict: None,
                })
                .collect();
            coverage(&q.figure, &q.quantity, &per_seed)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(value: f64, error: f64) -> Fitted {
        Fitted {
            value,
            error,
            verdict: None,
        }
    }

    #[test]
    fn honest_errors_cover_and_small_ones_do_not() {
        // Values -1, 0, 1 (+ mean 0, spread 1): errors of 1 cover all three,
        // errors of 0.1 only the middle one.
        let honest = coverage("f", "q", &[f(-1.0, 1.0), f(0.0, 1.0), f(1.0, 1.0)]).unwrap();
        assert_eq!(honest.coverage, 1.0);
        assert!((honest.ratio - 1.0).abs() < 1e-12);
        // One seed quoting a huge error inflates the rms, not the median.
        let tail = coverage("f", "q", &[f(-1.0, 0.1), f(0.0, 0.1), f(1.0, 3.0)]).unwrap();
        assert!((tail.ratio - (9.02f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((tail.median_ratio - 0.1).abs() < 1e-12);
        let small = coverage("f", "q", &[f(-1.0, 0.1), f(0.0, 0.1), f(1.0, 0.1)]).unwrap();
        assert!((small.coverage - 1.0 / 3.0).abs() < 1e-12);
        assert!((small.ratio - 0.1).abs() < 1e-12);
        // Seeds without an error are left out; one seed is not enough.
        assert!(coverage("f", "q", &[f(1.0, f64::NAN), f(2.0, 0.5)]).is_none());
    }

    #[test]
    fn a_golden_file_gives_the_coverage_of_its_recorded_seeds() {
        use crate::study::golden::Golden;
        let q = |figure: &str, errors: Vec<f64>| Golden {
            figure: figure.into(),
            quantity: "x".into(),
            seeds: vec![1, 2, 3],
            values: vec![-1.0, 0.0, 1.0],
            errors,
            mean: 0.0,
            std: 1.0,
            band: [-4.0, 4.0],
            gate: Default::default(),
            always_agree: false,
        };
        let g = GoldenFile {
            profile: "ci".into(),
            how: String::new(),
            sigmas: 4.0,
            relative_floor: 0.01,
            seeds: vec![1, 2, 3],
            ungated: Default::default(),
            // fig_b was recorded without per-seed errors: no row.
            quantities: vec![q("fig_a", vec![0.1; 3]), q("fig_b", vec![])],
        };
        let all = from_golden(&g, &[]);
        assert_eq!(all.len(), 1);
        assert!((all[0].coverage - 1.0 / 3.0).abs() < 1e-12);
        assert!((all[0].ratio - 0.1).abs() < 1e-12);
        assert!(from_golden(&g, &["fig_b".to_string()]).is_empty());
    }
}
