//! Do the quoted errors mean what they say? Over several master seeds, the
//! fraction of seeds whose quoted 1-sigma interval covers the all-seed mean
//! (about 68% for honest Gaussian errors; a little more with few seeds, since
//! the mean shares each seed's noise: 71% with ten) and the ratio of the typical
//! quoted error to the seed-to-seed standard deviation (about 1 when honest).

use serde::{Deserialize, Serialize};

use std::collections::BTreeMap;

use super::golden::{GoldenFile, SeedCheck};
use super::report::number;
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
    /// The largest distance of a seed's value from the median value, in that
    /// seed's quoted errors: an outlier seed whose error does not cover it.
    #[serde(default)]
    pub max_from_median: f64,
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
    let median_error = median(&errors);
    let mut sorted = values.clone();
    sorted.sort_by(f64::total_cmp);
    let median_value = median(&sorted);
    let max_from_median = ok
        .iter()
        .map(|f| (f.value - median_value).abs() / f.error)
        .fold(0.0, f64::max);
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
        median_ratio: median_error / spread,
        max_from_median,
    })
}

/// The median of sorted values.
fn median(sorted: &[f64]) -> f64 {
    let m = sorted.len();
    if m % 2 == 1 {
        sorted[m / 2]
    } else {
        0.5 * (sorted[m / 2 - 1] + sorted[m / 2])
    }
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
                    margin: f64::NAN,
                })
                .collect();
            coverage(&q.figure, &q.quantity, &per_seed)
        })
        .collect()
}

/// How a coverage row reads against the rule for quoted errors: the typical
/// seed's error (the median) within 0.5-2 of the spread, and no seed further
/// than 4 of its own errors from the median.
pub fn flag(c: &Coverage) -> &'static str {
    // A number held by a fit (phi_c fixed at the paper's 0.82) differs
    // between seeds by rounding only.
    if c.spread <= 1e-9 * c.mean.abs() {
        "constant"
    } else if c.median_ratio < 0.5 {
        "under-quoted"
    } else if c.median_ratio > 2.0 {
        "over-quoted"
    } else if c.max_from_median > 4.0 {
        "outlier seed"
    } else {
        "ok"
    }
}

/// The coverage study as Markdown: what was built, the false alarms of
/// `repro regress` on these seeds, and one row per key number. `gates` names
/// each number's gate in the golden file (band, one-sided, joint only, or why
/// it is ungated).
pub fn markdown(
    command: &str,
    commit: Option<&str>,
    seeds: &[u64],
    rows: &[Coverage],
    gates: &BTreeMap<(String, String), String>,
    checks: &[SeedCheck],
) -> String {
    let mut m = String::new();
    let seeds_text: Vec<String> = seeds.iter().map(u64::to_string).collect();
    // Only a survey checked against the goldens is on fresh seeds.
    m.push_str(if checks.is_empty() {
        "# Coverage of the quoted errors over master seeds\n\n"
    } else {
        "# Coverage of the quoted errors on fresh master seeds\n\n"
    });
    m.push_str(&format!(
        "Generated by `{command}` at commit {} over the master seeds {}.\n\n",
        commit.map_or("(unknown)".to_string(), |c| c[..c.len().min(7)].to_string()),
        seeds_text.join(", ")
    ));
    if !checks.is_empty() {
        let fired: Vec<&SeedCheck> = checks.iter().filter(|c| !c.failures.is_empty()).collect();
        m.push_str(&format!(
            "## False alarms\n\n`repro regress` against the golden file fails at {} of {} fresh master seeds (none of them was used to record it).\n\n",
            fired.len(),
            checks.len()
        ));
        for c in fired {
            m.push_str(&format!("- master seed {}:\n", c.seed));
            for f in &c.failures {
                m.push_str(&format!(
                    "  - {}\n",
                    f.split_whitespace().collect::<Vec<_>>().join(" ")
                ));
            }
        }
        m.push('\n');
    }
    m.push_str(
        "## Per key number\n\nspread: seed-to-seed standard deviation; quoted / spread: rms and median over the seeds; \
         coverage: seeds whose 1-sigma interval holds the mean; max dist.: the largest distance of a seed from the median value, \
         in that seed's quoted errors; flag: median quoted / spread outside 0.5-2, or a seed beyond 4 errors.\n\n",
    );
    m.push_str("| figure | quantity | gate | seeds | mean | spread | quoted / spread (rms) | median quoted / spread | coverage | max dist. | flag |\n");
    m.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for c in rows {
        let gate = gates
            .get(&(c.figure.clone(), c.quantity.clone()))
            .map_or("-", String::as_str);
        m.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.0}% | {:.1} | {} |\n",
            c.figure,
            c.quantity,
            gate,
            c.seeds,
            number(c.mean, f64::NAN),
            number(c.spread, f64::NAN),
            ratio(c.ratio),
            ratio(c.median_ratio),
            100.0 * c.coverage,
            c.max_from_median,
            flag(c)
        ));
    }
    m
}

fn ratio(r: f64) -> String {
    if r.is_finite() && r <= 100.0 {
        format!("{r:.2}")
    } else {
        ">100".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(value: f64, error: f64) -> Fitted {
        Fitted {
            value,
            error,
            verdict: None,
            margin: f64::NAN,
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
        // Median value 0: the seed at -1 quoting 0.1 is 10 of its errors away.
        assert!((tail.max_from_median - 10.0).abs() < 1e-12);
        assert!((honest.max_from_median - 1.0).abs() < 1e-12);
        let small = coverage("f", "q", &[f(-1.0, 0.1), f(0.0, 0.1), f(1.0, 0.1)]).unwrap();
        assert!((small.coverage - 1.0 / 3.0).abs() < 1e-12);
        assert!((small.ratio - 0.1).abs() < 1e-12);
        // Seeds without an error are left out; one seed is not enough.
        assert!(coverage("f", "q", &[f(1.0, f64::NAN), f(2.0, 0.5)]).is_none());
        assert_eq!(flag(&honest), "ok");
        assert_eq!(flag(&small), "under-quoted");
        // A value held by a fit, equal but for rounding: constant, not
        // under-quoted.
        let held = 0.82 + 1e-16;
        let h = coverage("f", "q", &[f(0.82, 1e-17), f(held, 1e-17), f(0.82, 1e-17)]).unwrap();
        assert_eq!(flag(&h), "constant");
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
