//! Do the quoted errors mean what they say? Over several master seeds, the
//! fraction of seeds whose quoted 1-sigma interval covers the all-seed mean
//! (about 68% for honest Gaussian errors; a little more with few seeds, since
//! the mean shares each seed's noise: 71% with ten) and the ratio of the typical
//! quoted error to the seed-to-seed standard deviation (about 1 when honest).

use serde::{Deserialize, Serialize};

use std::collections::BTreeMap;

use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use super::golden::{GoldenFile, SeedCheck, SeedNumbers, check_numbers};
use super::report::number;
use super::results::Fitted;
use super::results::Verdict;
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

/// Each key number's value, quoted error and paper verdict per seed, as a
/// survey stores them (NaN as null), so that it can be read again without
/// rebuilding ([`read_stored`]).
pub fn per_seed_json(per_seed: &SeedNumbers) -> serde_json::Map<String, serde_json::Value> {
    let num = |x: f64| x.is_finite().then_some(x);
    per_seed
        .iter()
        .map(|((f, q), v)| {
            (
                format!("{f}:{q}"),
                serde_json::json!({
                    "values": v.iter().map(|x| num(x.value)).collect::<Vec<_>>(),
                    "errors": v.iter().map(|x| num(x.error)).collect::<Vec<_>>(),
                    "verdicts": v.iter().map(|x| x.verdict.map(|d| d.as_str())).collect::<Vec<_>>(),
                }),
            )
        })
        .collect()
}

/// The seeds and per-seed numbers of stored surveys (results/coverage-*.json),
/// merged: every file must be of the same seeds, and a number in several is
/// taken from the last. Surveys written before verdicts were stored have none.
/// Also the commits the surveys were built at, as each file records it
/// ("unrecorded" for older files), once each.
pub fn read_stored(files: &[PathBuf]) -> Result<(Vec<u64>, SeedNumbers, Vec<String>)> {
    #[derive(Deserialize)]
    struct Stored {
        seeds: Vec<u64>,
        per_seed: BTreeMap<String, PerSeed>,
        /// One survey's commit; `commits` where surveys were merged.
        #[serde(default)]
        commit: Option<String>,
        #[serde(default)]
        commits: Vec<String>,
    }
    #[derive(Deserialize)]
    struct PerSeed {
        values: Vec<Option<f64>>,
        errors: Vec<Option<f64>>,
        #[serde(default)]
        verdicts: Vec<Option<String>>,
    }
    let mut seeds: Option<Vec<u64>> = None;
    let mut out: SeedNumbers = BTreeMap::new();
    let mut built: Vec<String> = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(f).with_context(|| {
            format!(
                "reading the stored survey {} (made by `repro coverage --label LABEL`)",
                f.display()
            )
        })?;
        let s: Stored = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a survey of `repro coverage`", f.display()))?;
        let mut commits = s.commits.clone();
        commits.extend(s.commit.clone());
        if commits.is_empty() {
            commits.push("unrecorded".into());
        }
        for c in commits {
            if !built.contains(&c) {
                built.push(c);
            }
        }
        match &seeds {
            Some(first) if *first != s.seeds => bail!(
                "{} is of the master seeds {:?}, the first survey of {first:?}: merge surveys of the same seeds",
                f.display(),
                s.seeds
            ),
            _ => seeds = Some(s.seeds.clone()),
        }
        for (key, v) in s.per_seed {
            let Some((fig, q)) = key.split_once(':') else {
                bail!("{}: key number '{key}' is not FIGURE:QUANTITY", f.display());
            };
            if v.values.len() != s.seeds.len() || v.errors.len() != s.seeds.len() {
                bail!(
                    "{}: {key} has {} values and {} errors for {} seeds",
                    f.display(),
                    v.values.len(),
                    v.errors.len(),
                    s.seeds.len()
                );
            }
            let fitted = (0..s.seeds.len())
                .map(|k| Fitted {
                    value: v.values[k].unwrap_or(f64::NAN),
                    error: v.errors[k].unwrap_or(f64::NAN),
                    verdict: v
                        .verdicts
                        .get(k)
                        .cloned()
                        .flatten()
                        .and_then(|d| Verdict::parse(&d)),
                    margin: f64::NAN,
                })
                .collect();
            out.insert((fig.to_string(), q.to_string()), fitted);
        }
    }
    Ok((seeds.unwrap_or_default(), out, built))
}

/// Each stored seed checked against `g` as `repro regress` would check its
/// build: the figures of `ids` (every figure the survey holds if empty) that
/// the golden file has numbers of.
pub fn check_stored(
    g: &GoldenFile,
    seeds: &[u64],
    per_seed: &SeedNumbers,
    ids: &[String],
) -> Vec<SeedCheck> {
    let figures: Vec<String> = per_seed
        .keys()
        .map(|(f, _)| f.clone())
        .filter(|f| ids.is_empty() || ids.contains(f))
        .filter(|f| g.quantities.iter().any(|q| &q.figure == f))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    seeds
        .iter()
        .enumerate()
        .map(|(k, &seed)| {
            let mut numbers: BTreeMap<String, BTreeMap<String, Fitted>> = BTreeMap::new();
            for ((f, q), v) in per_seed {
                if figures.contains(f) && v[k].value.is_finite() {
                    numbers
                        .entry(f.clone())
                        .or_default()
                        .insert(q.clone(), v[k]);
                }
            }
            let (_, failures) = check_numbers(g, &numbers, &figures);
            SeedCheck { seed, failures }
        })
        .collect()
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

/// How a coverage row reads against the rule for quoted errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flag {
    Ok,
    /// Held by a fit (phi_c fixed at the paper's 0.82): equal at every seed
    /// but for rounding, so the ratio means nothing.
    Constant,
    /// The typical seed's error below half the spread.
    UnderQuoted,
    /// The typical seed's error above twice the spread.
    OverQuoted,
    /// A seed further than [`OUTLIER_ERRORS`] of its own errors from the median.
    OutlierSeed,
}

/// A seed this many of its own quoted errors from the median value is an
/// outlier: 1 in 1.7 million for Gaussian errors, so with honest errors no
/// survey of twenty seeds shows one.
pub const OUTLIER_ERRORS: f64 = 5.0;

impl Flag {
    pub fn as_str(self) -> &'static str {
        match self {
            Flag::Ok => "ok",
            Flag::Constant => "constant",
            Flag::UnderQuoted => "under-quoted",
            Flag::OverQuoted => "over-quoted",
            Flag::OutlierSeed => "outlier seed",
        }
    }
    /// A number flagged so needs a reason in its figure's `error_coverage`.
    pub fn needs_reason(self) -> bool {
        !matches!(self, Flag::Ok | Flag::Constant)
    }
}

/// How a coverage row reads against the rule for quoted errors: the typical
/// seed's error (the median) within 0.5-2 of the spread, and no seed further
/// than [`OUTLIER_ERRORS`] of its own errors from the median.
pub fn flag(c: &Coverage) -> Flag {
    if c.spread <= 1e-9 * c.mean.abs() {
        Flag::Constant
    } else if c.median_ratio < 0.5 {
        Flag::UnderQuoted
    } else if c.median_ratio > 2.0 {
        Flag::OverQuoted
    } else if c.max_from_median > OUTLIER_ERRORS {
        Flag::OutlierSeed
    } else {
        Flag::Ok
    }
}

/// Every figure's `error_coverage` at `profile` ((figure, quantity) ->
/// reason), its references resolved from the builds in the store under
/// `root` (docs/spec.md, "Numbers in texts").
pub fn reasons(
    root: &std::path::Path,
    profile: &str,
) -> Result<BTreeMap<(String, String), String>> {
    let reg = crate::stages::registry();
    let builds = super::built::Built::open(root, &reg, profile)?;
    crate::pipeline::Catalogue::load(root)?
        .error_coverage(profile)
        .into_iter()
        .map(|((fig, q), why)| {
            let text = builds
                .render(&fig, &why)
                .with_context(|| format!("error_coverage of {q}"))?;
            Ok(((fig, q), text))
        })
        .collect()
}

/// The coverage study as Markdown: what was built, the false alarms of
/// `repro regress` on these seeds, one row per key number, and why each
/// flagged number is flagged. `gates` names each number's gate in the golden
/// file (band, one-sided, joint only, or why it is ungated); `reasons` are the
/// figures' `error_coverage` of this profile. `built`: the commits a stored
/// survey was built at, when it is read back.
pub fn markdown(
    command: &str,
    commit: Option<&str>,
    built: &[String],
    seeds: &[u64],
    rows: &[Coverage],
    gates: &BTreeMap<(String, String), String>,
    reasons: &BTreeMap<(String, String), String>,
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
    // A full hash is shortened; anything else ("unrecorded") stays as it is.
    let short = |c: &str| match c.get(..7) {
        Some(h) if c.len() == 40 && c.bytes().all(|b| b.is_ascii_hexdigit()) => h.to_string(),
        _ => c.to_string(),
    };
    let read_back = if built.is_empty() {
        String::new()
    } else {
        let b: Vec<String> = built.iter().map(|c| short(c)).collect();
        format!(
            ", read back from a survey built at commit {}",
            b.join(" and ")
        )
    };
    m.push_str(&format!(
        "Generated by `{command}` at commit {}{read_back} over the master seeds {}.\n\n",
        commit.map_or("(unknown)".to_string(), short),
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
         in that seed's quoted errors; flag: median quoted / spread outside 0.5-2, or a seed beyond 5 errors; \
         a flagged number's reason, from its figure's `error_coverage`, is in the next section.\n\n",
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
            flag(c).as_str()
        ));
    }
    m.push_str(&flagged_section(rows, reasons));
    m
}

/// Why each flagged number is flagged, from the figures' `error_coverage`:
/// the explained ones, those still without a reason, and reasons the survey
/// no longer needs (their numbers pass, or were not surveyed).
fn flagged_section(rows: &[Coverage], reasons: &BTreeMap<(String, String), String>) -> String {
    let key = |c: &Coverage| (c.figure.clone(), c.quantity.clone());
    let flagged: Vec<&Coverage> = rows.iter().filter(|c| flag(c).needs_reason()).collect();
    let (explained, bare): (Vec<&Coverage>, Vec<&Coverage>) =
        flagged.iter().partition(|c| reasons.contains_key(&key(c)));
    let mut m = format!(
        "\n## Why the flagged numbers are flagged\n\n{} of {} key numbers are flagged; {} have a reason in their figure's `error_coverage`, {} have none.\n\n",
        flagged.len(),
        rows.len(),
        explained.len(),
        bare.len()
    );
    for c in &explained {
        m.push_str(&format!(
            "- {} {} ({}): {}\n",
            c.figure,
            c.quantity,
            flag(c).as_str(),
            reasons[&key(c)]
        ));
    }
    if !bare.is_empty() {
        m.push_str("\nWithout a reason:\n\n");
        for c in &bare {
            m.push_str(&format!(
                "- {} {} ({})\n",
                c.figure,
                c.quantity,
                flag(c).as_str()
            ));
        }
    }
    let stale: Vec<String> = reasons
        .keys()
        .filter(|(f, q)| {
            rows.iter().any(|c| &c.figure == f)
                && !flagged.iter().any(|c| &c.figure == f && &c.quantity == q)
        })
        .map(|(f, q)| format!("{f} {q}"))
        .collect();
    if !stale.is_empty() {
        m.push_str(&format!(
            "\nReasons given for numbers this survey does not flag (they pass, or are not key numbers): {}.\n",
            stale.join(", ")
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
        assert_eq!(flag(&honest), Flag::Ok);
        assert_eq!(flag(&small), Flag::UnderQuoted);
        assert_eq!(flag(&tail), Flag::UnderQuoted);
        // A value held by a fit, equal but for rounding: constant, not
        // under-quoted.
        let held = 0.82 + 1e-16;
        let h = coverage("f", "q", &[f(0.82, 1e-17), f(held, 1e-17), f(0.82, 1e-17)]).unwrap();
        assert_eq!(flag(&h), Flag::Constant);
    }

    #[test]
    fn flagged_numbers_list_their_reasons_and_those_without_one() {
        let spread3 = [f(-1.0, 0.1), f(0.0, 0.1), f(1.0, 0.1)];
        let honest = [f(-1.0, 1.0), f(0.0, 1.0), f(1.0, 1.0)];
        // Median 0: the seed at 1 quoting 0.1 is 10 of its errors away.
        let outlier = [f(-1.0, 1.0), f(0.0, 1.0), f(0.0, 1.0), f(1.0, 0.1)];
        let rows: Vec<Coverage> = [
            ("fig_a", "explained", &spread3[..]),
            ("fig_a", "bare", &spread3[..]),
            ("fig_a", "fine", &honest[..]),
            ("fig_b", "far", &outlier[..]),
        ]
        .iter()
        .map(|(fig, q, v)| coverage(fig, q, v).unwrap())
        .collect();
        assert_eq!(flag(&rows[3]), Flag::OutlierSeed);
        let reasons: BTreeMap<(String, String), String> = [
            ("fig_a", "explained", "two replicas"),
            ("fig_a", "fine", "an old reason"),
            ("fig_b", "far", "one seed's fit in another minimum"),
            ("fig_c", "unsurveyed", "not in this survey"),
        ]
        .iter()
        .map(|(f, q, r)| ((f.to_string(), q.to_string()), r.to_string()))
        .collect();
        let m = markdown(
            "repro coverage",
            None,
            &[],
            &[1, 2, 3],
            &rows,
            &BTreeMap::new(),
            &reasons,
            &[],
        );
        assert!(
            m.contains("3 of 4 key numbers are flagged; 2 have a reason"),
            "{m}"
        );
        assert!(
            m.contains("- fig_a explained (under-quoted): two replicas"),
            "{m}"
        );
        assert!(
            m.contains("- fig_b far (outlier seed): one seed's fit"),
            "{m}"
        );
        assert!(
            m.contains("Without a reason:\n\n- fig_a bare (under-quoted)"),
            "{m}"
        );
        // A reason for a number that passes is stale; a figure outside the
        // survey is not judged.
        assert!(
            m.contains("does not flag (they pass, or are not key numbers): fig_a fine."),
            "{m}"
        );
        assert!(!m.contains("unsurveyed"), "{m}");
    }

    #[test]
    fn a_stored_survey_reads_back_and_is_checked_as_its_builds_would_be() {
        use crate::study::golden::golden;
        let recorded: Vec<f64> = (0..8).map(|k| 10.0 + 0.1 * (k as f64 - 3.5)).collect();
        let g = GoldenFile {
            profile: "ci".into(),
            how: String::new(),
            sigmas: 6.0,
            relative_floor: 0.0,
            seeds: (1..=8).collect(),
            ungated: Default::default(),
            quantities: vec![golden(
                "fig_a",
                "x",
                &(1..=8).collect::<Vec<_>>(),
                &recorded,
                6.0,
                0.0,
            )],
        };
        let fitted = |value: f64| Fitted {
            value,
            error: 0.1,
            verdict: Some(Verdict::Agree),
            margin: f64::NAN,
        };
        // Seed 21 within the band, seed 22 far outside it (10 spreads).
        let mut per_seed = SeedNumbers::new();
        per_seed.insert(
            ("fig_a".into(), "x".into()),
            vec![fitted(10.05), fitted(12.5)],
        );
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("coverage-ci-a.json");
        let json = serde_json::json!({"seeds": [21, 22], "per_seed": per_seed_json(&per_seed)});
        std::fs::write(&file, json.to_string()).unwrap();
        let (seeds, back, built) = read_stored(std::slice::from_ref(&file)).unwrap();
        assert_eq!(built, vec!["unrecorded".to_string()]);
        assert_eq!(seeds, vec![21, 22]);
        assert_eq!(back[&("fig_a".to_string(), "x".to_string())][1].value, 12.5);
        assert_eq!(
            back[&("fig_a".to_string(), "x".to_string())][0].verdict,
            Some(Verdict::Agree)
        );
        let checks = check_stored(&g, &seeds, &back, &[]);
        assert!(checks[0].failures.is_empty(), "{:?}", checks[0]);
        assert!(
            checks[1]
                .failures
                .iter()
                .any(|f| f.contains("regression in fig_a: x")),
            "{:?}",
            checks[1]
        );
        // Surveys of other seeds do not merge.
        let other = dir.path().join("coverage-ci-b.json");
        std::fs::write(
            &other,
            serde_json::json!({"seeds": [23, 24], "per_seed": {}}).to_string(),
        )
        .unwrap();
        let e = read_stored(&[file, other]).unwrap_err();
        assert!(format!("{e:#}").contains("same seeds"), "{e:#}");
    }

    /// A survey records the commit it was built at; read back (and merged
    /// with others), the page names each commit once, shortened.
    #[test]
    fn a_read_back_survey_names_the_commits_it_was_built_at() {
        let dir = tempfile::tempdir().unwrap();
        let hash = "c9282a3".to_string() + &"0".repeat(33);
        let write = |name: &str, json: serde_json::Value| {
            let f = dir.path().join(name);
            std::fs::write(&f, json.to_string()).unwrap();
            f
        };
        let a = write(
            "a.json",
            serde_json::json!({"seeds": [1], "per_seed": {}, "commits": [hash]}),
        );
        let b = write(
            "b.json",
            serde_json::json!({"seeds": [1], "per_seed": {}, "commit": hash}),
        );
        let c = write("c.json", serde_json::json!({"seeds": [1], "per_seed": {}}));
        let (_, _, built) = read_stored(&[a, b, c]).unwrap();
        assert_eq!(built, vec![hash.clone(), "unrecorded".to_string()]);
        let m = markdown(
            "repro coverage",
            Some(&hash),
            &built,
            &[1],
            &[],
            &BTreeMap::new(),
            &BTreeMap::new(),
            &[],
        );
        assert!(
            m.contains("at commit c9282a3, read back from a survey built at commit c9282a3 and unrecorded over"),
            "{m}"
        );
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
