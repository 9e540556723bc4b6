//! The CI regression: golden bands of every key number from several master
//! seeds, and the check of built figures against them (`repro regress`).
//!
//! Band rule (docs/figures.md, "CI regression"): mean +- max(sigmas x seed-to-seed
//! standard deviation, relative_floor x |mean|) over the recorded seeds; one-sided
//! for numbers where smaller is better (drifts, precision, gaps). A number whose
//! band would be wider than the value itself stays in the joint test only; a
//! number that is constant, missing at some seed or a goodness-of-fit diagnostic
//! is not gated, with its reason in the file. A number the paper agreed with at
//! every recorded seed fails when it turns `disagree`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};

use super::results::{Fitted, Verdict, key_numbers_with_errors, provenance};
use super::variant::{self, Variant};
use crate::pipeline::RunOptions;

/// Golden values of one quantity of one figure.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Golden {
    pub figure: String,
    pub quantity: String,
    pub seeds: Vec<u64>,
    /// Per seed; a seed whose fit gave no number is NaN, written as `null`.
    #[serde(with = "super::results::nan_as_null")]
    pub values: Vec<f64>,
    /// The 1-sigma error each seed's figure quoted for its value (what the
    /// coverage test checks against the seed-to-seed scatter); empty in goldens
    /// recorded without them.
    #[serde(default, with = "super::results::nan_as_null")]
    pub errors: Vec<f64>,
    pub mean: f64,
    pub std: f64,
    pub band: [f64; 2],
    /// How the band gates the number.
    #[serde(default)]
    pub gate: Gate,
    /// The figure's compare verdict was `agree` at every recorded seed: turning
    /// `disagree` is a regression.
    #[serde(default)]
    pub always_agree: bool,
}

/// How a golden band gates its number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Gate {
    /// The value must lie in the band.
    #[default]
    Band,
    /// Smaller is better (a drift, a precision): |value| at most the band's top.
    AtMost,
    /// A gap: at least 0 (disks never overlap) and at most the band's top.
    NonNegative,
    /// Its band would be wider than the value itself, so it could not fail: the
    /// number counts in the joint test only.
    JointOnly,
}

impl std::fmt::Display for Gate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Gate::Band => "band",
            Gate::AtMost => "one-sided (at most)",
            Gate::NonNegative => "one-sided (gap)",
            Gate::JointOnly => "joint only",
        })
    }
}

impl Gate {
    /// Whether `v` passes (NaN never does, except in the joint test only).
    pub fn passes(self, v: f64, band: [f64; 2]) -> bool {
        match self {
            Gate::Band => v >= band[0] && v <= band[1],
            Gate::AtMost => v.abs() <= band[1],
            Gate::NonNegative => v >= 0.0 && v <= band[1],
            Gate::JointOnly => true,
        }
    }

    /// The gate of a quantity, by what it measures: drifts and precision are
    /// better smaller, a closest gap must not be negative.
    fn of(quantity: &str) -> Gate {
        if quantity.starts_with("closest_gap") {
            Gate::NonNegative
        } else if quantity.contains("drift") || quantity.contains("precision") {
            Gate::AtMost
        } else {
            Gate::Band
        }
    }
}

/// `tests/golden/PROFILE.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GoldenFile {
    pub profile: String,
    pub how: String,
    pub sigmas: f64,
    pub relative_floor: f64,
    /// The master seeds every band was recorded at (empty in older files).
    #[serde(default)]
    pub seeds: Vec<u64>,
    /// FIGURE:QUANTITY left out of the bands, with the reason.
    #[serde(default)]
    pub ungated: BTreeMap<String, String>,
    pub quantities: Vec<Golden>,
}

impl GoldenFile {
    pub fn read(path: &Path) -> Result<GoldenFile> {
        serde_json::from_slice(
            &std::fs::read(path)
                .with_context(|| format!("reading the golden file {}", path.display()))?,
        )
        .with_context(|| format!("parsing {}", path.display()))
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        crate::table::write_atomic(path, serde_json::to_string_pretty(self)?.as_bytes())
    }
}

/// Band = mean +- max(sigmas x seed-to-seed standard deviation, floor x |mean|),
/// gated by the quantity's [`Gate`] (one-sided: [-top, top] or [0, top] with top
/// = |mean| + the half-width; [`Gate::JointOnly`] when the half-width exceeds
/// |mean|); seeds without a number (NaN) are left out.
pub fn golden(
    figure: &str,
    quantity: &str,
    seeds: &[u64],
    values: &[f64],
    sigmas: f64,
    floor: f64,
) -> Golden {
    let (mean, std) = crate::analysis::stats::mean_std(values);
    let half = (sigmas * std).max(floor * mean.abs());
    let top = mean.abs() + half;
    let (gate, band) = match Gate::of(quantity) {
        Gate::AtMost => (Gate::AtMost, [-top, top]),
        Gate::NonNegative => (Gate::NonNegative, [0.0, top]),
        _ if half > mean.abs() => (Gate::JointOnly, [mean - half, mean + half]),
        g => (g, [mean - half, mean + half]),
    };
    Golden {
        figure: figure.into(),
        quantity: quantity.into(),
        seeds: seeds.to_vec(),
        values: values.to_vec(),
        errors: Vec::new(),
        mean,
        std,
        band,
        gate,
        always_agree: false,
    }
}

/// Why a recorded number gets no band, if it gets none: missing at some seed,
/// the same at every seed, or a goodness-of-fit diagnostic.
pub fn ungated_reason(quantity: &str, values: &[f64]) -> Option<String> {
    let n = values.len();
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.len() < n {
        return Some(format!(
            "no number at {} of {n} recorded seeds (its fit fails at this profile): a band would fail on such a seed",
            n - finite.len()
        ));
    }
    let (mean, std) = crate::analysis::stats::mean_std(&finite);
    if std <= 1e-12 * mean.abs().max(1.0) {
        return Some(format!(
            "{mean} at every seed: fixed by construction (a count or a normalisation), nothing for a band to detect"
        ));
    }
    // Constant but for a solver's tolerance (a collapse normalised to 1, found
    // to 1e-8): a band that narrow would fire on a change of tolerance.
    if std <= 1e-6 * mean.abs().max(1.0) {
        return Some(format!(
            "{mean:.6} at every seed to a relative {:.0e}: fixed by construction up to the solver's tolerance: a band would test the tolerance, not the physics",
            std / mean.abs().max(1.0)
        ));
    }
    if ["reduced_chi2", "leverage", "scatter"]
        .iter()
        .any(|d| quantity.starts_with(d))
    {
        return Some(
            "a goodness-of-fit diagnostic: reported with the fit, heavy-tailed across seeds".into(),
        );
    }
    None
}

/// Check the figures `ids` (every figure of the golden file if empty) built under
/// `results` against `g`: one line per quantity, and one line per quantity
/// outside its band (figure, quantity, value, band).
pub fn check(g: &GoldenFile, results: &Path, ids: &[String]) -> Result<(Vec<String>, Vec<String>)> {
    let mut lines = Vec::new();
    let mut failures = Vec::new();
    let mut by_fig: BTreeMap<&str, Vec<&Golden>> = BTreeMap::new();
    for q in &g.quantities {
        if ids.is_empty() || ids.contains(&q.figure) {
            by_fig.entry(&q.figure).or_default().push(q);
        }
    }
    for id in ids {
        if !by_fig.contains_key(id.as_str()) {
            bail!("the golden file has no quantity of figure '{id}'");
        }
    }
    let mut checked: Vec<(&Golden, f64)> = Vec::new();
    for (fig, qs) in by_fig {
        let dir = results.join(fig);
        let prov = provenance(&dir).with_context(|| {
            format!(
                "{fig}: no built figure in {}; run `repro figure {fig} --profile {}` first",
                dir.display(),
                g.profile
            )
        })?;
        if prov.profile != g.profile {
            bail!(
                "{fig}: {} was built at profile '{}', the goldens are for '{}'; run `repro figure {fig} --profile {}`",
                dir.display(),
                prov.profile,
                g.profile,
                g.profile
            );
        }
        let got = key_numbers_with_errors(&dir)?;
        for q in &qs {
            let now = got.get(&q.quantity);
            let v = now.map_or(f64::NAN, |f| f.value);
            checked.push((*q, v));
            let inside = q.gate.passes(v, q.band);
            let band = match q.gate {
                Gate::Band => format!("band [{:.5}, {:.5}]", q.band[0], q.band[1]),
                Gate::AtMost => format!("one-sided band |value| <= {:.5}", q.band[1]),
                Gate::NonNegative => format!("one-sided band [0, {:.5}]", q.band[1]),
                Gate::JointOnly => format!(
                    "joint test only (a band [{:.5}, {:.5}] would be wider than the value)",
                    q.band[0], q.band[1]
                ),
            };
            lines.push(format!(
                "{fig} {}: {v:.5} {} {band} (golden mean {:.5}, seed-to-seed std {:.5})",
                q.quantity,
                if inside { "inside" } else { "OUTSIDE" },
                q.mean,
                q.std
            ));
            if !inside {
                failures.push(format!(
                    "regression in {fig}: {} = {v:.5} is outside its {band}",
                    q.quantity
                ));
            }
            if q.always_agree && now.and_then(|f| f.verdict) == Some(Verdict::Disagree) {
                failures.push(format!(
                    "regression in {fig}: {} agreed with the paper, with room to spare, at every recorded seed and now disagrees ({v:.5})",
                    q.quantity
                ));
            }
        }
        // A key number with neither a band nor a reason would not be checked at
        // all: refuse it until it is recorded.
        for name in got.keys() {
            let fq = format!("{fig}:{name}");
            if !qs.iter().any(|q| &q.quantity == name) && !g.ungated.contains_key(&fq) {
                failures.push(format!(
                    "{fig}: key number {name} has neither a golden band nor an ungated entry in the golden file; record it with `repro regress --record --profile {} {fig}`",
                    g.profile
                ));
            }
        }
    }
    let agree: Vec<String> = g
        .quantities
        .iter()
        .filter(|q| q.always_agree && (ids.is_empty() || ids.contains(&q.figure)))
        .map(|q| format!("{}:{}", q.figure, q.quantity))
        .collect();
    lines.push(format!(
        "agreed with the paper, with room to spare (median margin >= {AGREE_SIGMAS} x its scatter), at every recorded seed, so gated on staying agreed ({}): {}",
        agree.len(),
        if agree.is_empty() {
            "none".to_string()
        } else {
            agree.join(", ")
        }
    ));
    let j = joint(&checked);
    let pass = j.chi2 <= j.threshold;
    lines.push(format!(
        "joint: sum of z^2 = {:.1} over {} distinct key numbers, threshold {:.1} (false alarm {JOINT_FALSE_ALARM}; {}) {}",
        j.chi2,
        j.terms,
        j.threshold,
        if j.from_seeds {
            "from the recorded seeds' leave-one-out sums: the numbers are correlated"
        } else {
            "as for independent numbers"
        },
        if pass { "inside" } else { "OUTSIDE" }
    ));
    if !pass {
        failures.push(format!(
            "regression of the key numbers jointly: sum of z^2 = {:.1} over {} numbers exceeds {:.1}              (z = (value - golden mean) / seed-to-seed std; no single number need leave its band)",
            j.chi2, j.terms, j.threshold
        ));
    }
    Ok((lines, failures))
}

/// Refuse a CI figure (`ci: true`) whose built results hold key numbers that
/// the golden file has no band for: a new CI figure is recorded before it is
/// gated, never silently left unchecked. Figures without key numbers (curves
/// only, such as fig3) need none, nor do figures whose every key number is
/// `ungated` with its reason (fig24 at ci, whose fits fail on some seeds).
pub fn all_recorded(g: &GoldenFile, file: &Path, ci: &[String], results: &Path) -> Result<()> {
    let mut missing = Vec::new();
    for f in ci {
        if g.quantities.iter().any(|q| &q.figure == f) {
            continue;
        }
        let dir = results.join(f);
        if dir.exists()
            && super::results::key_numbers(&dir)?
                .keys()
                .any(|q| !g.ungated.contains_key(&format!("{f}:{q}")))
        {
            missing.push(f.clone());
        }
    }
    if missing.is_empty() {
        return Ok(());
    }
    let seeds: Vec<String> = g.seeds.iter().map(|s| s.to_string()).collect();
    bail!(
        "{} {} marked `ci: true` and {} key numbers, but {} has no band for them; record them with `repro regress --record --profile {} --seeds {} {}`",
        missing.join(", "),
        if missing.len() == 1 { "is" } else { "are" },
        if missing.len() == 1 { "has" } else { "have" },
        file.display(),
        g.profile,
        seeds.join(","),
        missing.join(" ")
    )
}

/// Nominal false-alarm probability of the joint test.
pub const JOINT_FALSE_ALARM: f64 = 0.001;

/// The joint test: sum over the checked key numbers of z^2, z = (value - mean)/std
/// with the golden's seed-to-seed mean and std. A change of the physics (eps, the
/// radius ratio) moves many numbers by a fraction of their band each; their
/// squares add up. Numbers identical to one already counted in every seed (phi_c
/// of the one tau_alpha fit, published by three figures) count once;
/// goodness-of-fit numbers not at all. Each term is capped at
/// `JOINT_TERM_CAP`: a number beyond 4 sigma already fails its own band, and
/// the joint test is for many small shifts. Without the cap one heavy-tailed
/// fit (fig23's B at eps = 0.7, a seed where intruder-fig5's crossover fit
/// fails) fired it at 3 of the 10 recorded seeds left out in turn; with it, at
/// none (docs/accuracy.md).
///
/// The key numbers are not independent (tau_alpha at 0.78 moves fig7's MSD
/// times and fig8's tails with it), so the sum's spread is wider than for
/// independent terms: the threshold is the larger of the independent-term one
/// and the same quantile of the sums the recorded seeds themselves give, each
/// left out in turn against the others' mean and std (their mean and variance
/// matched by a scaled chi-square). With twenty recorded seeds the independent
/// threshold (230.5 over 134 numbers) fired on a fresh seed whose sum was 243.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub chi2: f64,
    pub terms: usize,
    pub threshold: f64,
    /// The threshold came from the recorded seeds' own leave-one-out sums.
    pub from_seeds: bool,
}

/// Largest contribution of one key number to the joint sum (4 sigma squared).
pub const JOINT_TERM_CAP: f64 = 16.0;

pub fn joint(checked: &[(&Golden, f64)]) -> Joint {
    let mut seen: Vec<&[f64]> = Vec::new();
    let mut counted: Vec<&Golden> = Vec::new();
    let (mut chi2, mut terms, mut n_seeds) = (0.0, 0usize, usize::MAX);
    for (q, v) in checked {
        let dup = seen.iter().any(|s| {
            s.len() == q.values.len()
                && s.iter()
                    .zip(&q.values)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
        });
        if dup || goodness_of_fit(&q.quantity) || !(q.std.is_finite() && q.std > 0.0) {
            continue;
        }
        // A number most seeds could not give (too few for its own spread)
        // keeps its band but stays out: it would make the threshold infinite.
        let n = q.values.iter().filter(|x| x.is_finite()).count();
        if n < 6 {
            continue;
        }
        seen.push(&q.values);
        counted.push(q);
        n_seeds = n_seeds.min(n);
        // A NaN value fails its band already; here it counts as far out.
        let z = if v.is_finite() {
            (v - q.mean) / q.std
        } else {
            10.0
        };
        chi2 += (z * z).min(JOINT_TERM_CAP);
        terms += 1;
    }
    let independent = joint_threshold(terms, n_seeds, JOINT_FALSE_ALARM);
    let sums = leave_one_out_sums(&counted);
    let from_seeds = if sums.len() >= 6 {
        let m = sums.iter().sum::<f64>() / sums.len() as f64;
        let v = sums.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (sums.len() - 1) as f64;
        scaled_chi2_quantile(m, v, JOINT_FALSE_ALARM)
    } else {
        f64::NAN
    };
    Joint {
        chi2,
        terms,
        threshold: independent.max(from_seeds),
        from_seeds: from_seeds > independent,
    }
}

/// The joint sum at each recorded seed, that seed left out of the mean and std
/// of every counted number (a number the seed could not give does not count).
fn leave_one_out_sums(counted: &[&Golden]) -> Vec<f64> {
    let n = counted.iter().map(|q| q.values.len()).min().unwrap_or(0);
    (0..n)
        .map(|k| {
            counted
                .iter()
                .filter_map(|q| {
                    let rest: Vec<f64> = (0..q.values.len())
                        .filter(|&i| i != k)
                        .map(|i| q.values[i])
                        .filter(|x| x.is_finite())
                        .collect();
                    let x = q.values[k];
                    if !x.is_finite() || rest.len() < 3 {
                        return None;
                    }
                    let m = rest.iter().sum::<f64>() / rest.len() as f64;
                    let sd = (rest.iter().map(|r| (r - m).powi(2)).sum::<f64>()
                        / (rest.len() - 1) as f64)
                        .sqrt();
                    (sd > 0.0).then(|| (((x - m) / sd).powi(2)).min(JOINT_TERM_CAP))
                })
                .sum()
        })
        .collect()
}

/// Upper `alpha` quantile of the scaled chi-square c chi2(d) with mean `m` and
/// variance `v` (Satterthwaite), by the Wilson-Hilferty approximation.
fn scaled_chi2_quantile(m: f64, v: f64, alpha: f64) -> f64 {
    if !(m > 0.0 && v > 0.0) {
        return f64::NAN;
    }
    let c = v / (2.0 * m);
    let d = m / c;
    let z = normal_upper_quantile(alpha);
    let h = 2.0 / (9.0 * d);
    c * d * (1.0 - h + z * h.sqrt()).powi(3)
}

/// Goodness-of-fit numbers (reduced chi-square, collapse quality, point and
/// curve counts) keep their bands but stay out of the joint test: their seed
/// to seed distribution has tails far heavier than Gaussian.
fn goodness_of_fit(quantity: &str) -> bool {
    quantity.starts_with("reduced_chi2")
        || quantity.starts_with("points")
        || matches!(quantity, "curves" | "collapse_S")
}

/// Threshold of the sum of `k` squared z's whose mean and std come from `n`
/// seeds: each term is (1 + 1/n) F(1, n - 1) under no change (a heavier tail
/// than chi-square), matched in mean and variance by a scaled chi-square
/// c chi2(d) (Satterthwaite), whose upper quantile is taken by the
/// Wilson-Hilferty approximation.
pub fn joint_threshold(k: usize, n: usize, alpha: f64) -> f64 {
    if k == 0 || n < 6 {
        return f64::INFINITY;
    }
    let nu = (n - 1) as f64;
    let scale = 1.0 + 1.0 / n as f64;
    let mean = scale * nu / (nu - 2.0);
    let var = scale * scale * 2.0 * nu * nu * (nu - 1.0) / ((nu - 2.0).powi(2) * (nu - 4.0));
    scaled_chi2_quantile(k as f64 * mean, k as f64 * var, alpha)
}

/// z with P(Z > z) = alpha for a standard normal (Acklam's rational
/// approximation of the tail, |error| < 1e-8 for alpha < 0.02).
fn normal_upper_quantile(alpha: f64) -> f64 {
    let q = (-2.0 * alpha.ln()).sqrt();
    let c = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    let d = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
        / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
}

/// The band rule's constants.
/// Six standard deviations of ten seeds: with some 130 gated numbers, a
/// Student-t tail (9 degrees of freedom) leaves about one false alarm of the
/// whole CI in twenty fresh seeds, where four gave one in two.
pub const SIGMAS: f64 = 6.0;
pub const FLOOR: f64 = 0.01;

/// How many standard deviations inside its agreement with the paper a number
/// must lie to be gated on it.
pub const AGREE_SIGMAS: f64 = 3.0;

/// A number gated on its paper agreement: `agree` at every recorded seed, and
/// its median margin at least [`AGREE_SIGMAS`] times its scatter (the larger of
/// the seed-to-seed spread and the median quoted error, which a spread of a few
/// seeds can underestimate), so that a fresh seed's scatter alone rarely takes
/// it out: agreeing by a hair at every recorded seed is luck, not a property.
pub fn always_agrees(v: &[Fitted]) -> bool {
    if v.is_empty() || !v.iter().all(|x| x.verdict == Some(Verdict::Agree)) {
        return false;
    }
    let median = |mut x: Vec<f64>| {
        x.retain(|x| x.is_finite());
        x.sort_by(f64::total_cmp);
        x.get(x.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let values: Vec<f64> = v.iter().map(|x| x.value).collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let spread = (values.iter().map(|x| (x - mean).powi(2)).sum::<f64>()
        / (values.len().max(2) - 1) as f64)
        .sqrt();
    let quoted = median(v.iter().map(|x| x.error).collect());
    let scatter = if quoted.is_finite() {
        spread.max(quoted)
    } else {
        spread
    };
    median(v.iter().map(|x| x.margin).collect()) >= AGREE_SIGMAS * scatter
}

/// What `repro regress --record` builds.
pub struct Recording<'a> {
    pub root: &'a Path,
    pub experiment: &'a str,
    pub profile: &'a str,
    pub ids: &'a [String],
    pub seeds: &'a [u64],
    /// FIGURE:QUANTITY left out of the bands by hand, with the reason.
    pub ungated: &'a BTreeMap<String, String>,
}

/// Build the figures at every master seed (in-memory variants of the catalogue)
/// and derive the golden file: a band for every key number but those left out
/// by hand or by [`ungated_reason`], each with its reason.
pub fn record(r: &Recording, opts: &RunOptions) -> Result<GoldenFile> {
    let numbers = seed_numbers(
        r.root,
        r.experiment,
        r.profile,
        r.ids,
        r.seeds,
        &Variant::default(),
        None,
        opts,
    )?
    .0;
    let mut ungated = r.ungated.clone();
    let mut quantities = Vec::new();
    for ((f, q), v) in &numbers {
        let fq = format!("{f}:{q}");
        let values: Vec<f64> = v.iter().map(|x| x.value).collect();
        if ungated.contains_key(&fq) {
            continue;
        }
        if let Some(why) = ungated_reason(q, &values) {
            ungated.insert(fq, why);
            continue;
        }
        quantities.push(Golden {
            errors: v.iter().map(|x| x.error).collect(),
            always_agree: always_agrees(v),
            ..golden(f, q, r.seeds, &values, SIGMAS, FLOOR)
        });
    }
    Ok(GoldenFile {
        profile: r.profile.to_string(),
        how: how(r.profile, r.seeds, r.experiment),
        sigmas: SIGMAS,
        relative_floor: FLOOR,
        seeds: r.seeds.to_vec(),
        ungated,
        quantities,
    })
}

fn how(profile: &str, seeds: &[u64], experiment: &str) -> String {
    let seeds: Vec<String> = seeds.iter().map(|s| s.to_string()).collect();
    format!(
        "`repro regress --record --profile {profile} --seeds {}`: the figures built at each master seed (every experiment; parameters of '{experiment}'); \
         band = mean +- max({SIGMAS} x seed-to-seed standard deviation, {FLOOR} x |mean|), one-sided for drifts, precision and gaps, \
         joint test only where it would be wider than the value; `ungated` lists the numbers without a band and why",
        seeds.join(",")
    )
}

/// The golden file after recording the figures `ids` anew: `new`'s bands for
/// them, `old`'s for every other figure (recording one figure must not drop the
/// others'). Both must be of one profile and one set of master seeds, so that
/// every band means the same.
pub fn merge(
    old: GoldenFile,
    new: GoldenFile,
    ids: &[String],
    experiment: &str,
) -> Result<GoldenFile> {
    if old.profile != new.profile {
        bail!(
            "the golden file is for profile '{}', the recording for '{}'",
            old.profile,
            new.profile
        );
    }
    if old.seeds != new.seeds {
        bail!(
            "the golden file was recorded at master seeds {:?} (none listed: an older file), this recording at {:?}; record every figure at once (no figure ids) or use the same --seeds",
            old.seeds,
            new.seeds
        );
    }
    let other = |fq: &str| {
        !ids.iter()
            .any(|id| fq.split(':').next() == Some(id.as_str()))
    };
    let mut ungated: BTreeMap<String, String> =
        old.ungated.into_iter().filter(|(u, _)| other(u)).collect();
    ungated.extend(new.ungated);
    let mut quantities: Vec<Golden> = old
        .quantities
        .into_iter()
        .filter(|q| !ids.contains(&q.figure))
        .collect();
    quantities.extend(new.quantities);
    Ok(GoldenFile {
        how: how(&new.profile, &new.seeds, experiment),
        ungated,
        quantities,
        ..new
    })
}

/// (figure, quantity) -> its value and quoted error at each master seed.
pub type SeedNumbers = BTreeMap<(String, String), Vec<Fitted>>;

/// What `repro regress` said of one master seed's build: the failures (none
/// when it passed).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SeedCheck {
    pub seed: u64,
    pub failures: Vec<String>,
}

/// Every key number of figures `ids` with its quoted error at each master seed:
/// (figure, quantity) -> one entry per seed (NaN where that seed gave none);
/// `base` changes the experiment besides the seed. With `gate`, each seed's
/// build is checked against that golden file as `repro regress` would (the
/// figures of `ids` it has bands for): on seeds it was not recorded at, a
/// failure is a false alarm.
#[allow(clippy::too_many_arguments)]
pub fn seed_numbers(
    root: &Path,
    experiment: &str,
    profile: &str,
    ids: &[String],
    seeds: &[u64],
    base: &Variant,
    gate: Option<&GoldenFile>,
    opts: &RunOptions,
) -> Result<(SeedNumbers, Vec<SeedCheck>)> {
    let none = Fitted {
        value: f64::NAN,
        error: f64::NAN,
        verdict: None,
        margin: f64::NAN,
    };
    let mut values: SeedNumbers = BTreeMap::new();
    let mut checks = Vec::new();
    for (k, &seed) in seeds.iter().enumerate() {
        eprintln!("master seed {seed}");
        let v = Variant {
            seed: Some(seed),
            ..base.clone()
        };
        // A seed whose build fails (a stage that cannot run at that seed, e.g.
        // a compression that jams) is a result, not the end of the survey: CI
        // at that seed would fail, so under a gate it counts as a false alarm,
        // and its numbers are missing (NaN) like those of a failed fit.
        let built = match variant::build(root, experiment, profile, &v, ids, opts) {
            Ok(b) => b,
            Err(e) => {
                // The first stage that failed names the cause; the summary
                // line only counts them.
                let text = format!("{e:#}");
                let first = text
                    .lines()
                    .find(|l| l.contains(" failed: "))
                    .or_else(|| text.lines().next())
                    .unwrap_or_default()
                    .trim()
                    .to_string();
                eprintln!("master seed {seed}: the build failed: {first}");
                if gate.is_some() {
                    checks.push(SeedCheck {
                        seed,
                        failures: vec![format!("the build failed: {first}")],
                    });
                }
                for e in values.values_mut() {
                    e.resize(k + 1, none);
                }
                continue;
            }
        };
        if let Some(g) = gate.filter(|g| {
            ids.iter()
                .any(|id| g.quantities.iter().any(|q| &q.figure == id))
        }) {
            let gated: Vec<String> = ids
                .iter()
                .filter(|id| g.quantities.iter().any(|q| &q.figure == *id))
                .cloned()
                .collect();
            let (_, failures) = check(g, &built.results, &gated)?;
            eprintln!(
                "master seed {seed}: regress {}",
                if failures.is_empty() {
                    "passes".to_string()
                } else {
                    format!("fails on {}", failures.len())
                }
            );
            checks.push(SeedCheck { seed, failures });
        }
        for id in ids {
            for (q, v) in key_numbers_with_errors(&built.results.join(id))? {
                let e = values
                    .entry((id.clone(), q))
                    .or_insert_with(|| vec![none; k]);
                e.push(v);
            }
        }
        for e in values.values_mut() {
            e.resize(k + 1, none);
        }
    }
    Ok((values, checks))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(seeds: &[u64], figs: &[&str], ungated: &[&str]) -> GoldenFile {
        GoldenFile {
            profile: "ci".into(),
            how: String::new(),
            sigmas: SIGMAS,
            relative_floor: FLOOR,
            seeds: seeds.to_vec(),
            ungated: ungated
                .iter()
                .map(|u| (u.to_string(), "by hand".to_string()))
                .collect(),
            quantities: figs
                .iter()
                .map(|f| golden(f, "q", seeds, &[1.0, 2.0], SIGMAS, FLOOR))
                .collect(),
        }
    }

    /// The paper gate takes a number that agrees with room to spare, not one
    /// that agreed by less than three of its errors at every recorded seed
    /// (fig9's theta at ci: 0.088 inside a tolerance of 0.1 with errors of 0.03
    /// turned `disagree` on a fresh seed).
    #[test]
    fn only_numbers_agreeing_with_room_to_spare_are_gated_on_the_paper() {
        let seeds = |paper: f64, tol: f64, values: &[f64], err: f64| -> Vec<Fitted> {
            values
                .iter()
                .map(|&v| {
                    let d = (v - paper).abs();
                    Fitted {
                        value: v,
                        error: err,
                        verdict: Some(if d <= tol {
                            Verdict::Agree
                        } else {
                            Verdict::Disagree
                        }),
                        margin: (tol - d).abs(),
                    }
                })
                .collect()
        };
        let theta = [
            -1.443, -1.442, -1.443, -1.473, -1.499, -1.443, -1.461, -1.455,
        ];
        assert!(!always_agrees(&seeds(-1.47, 0.1, &theta, 0.03)));
        assert!(always_agrees(&seeds(-1.47, 0.3, &theta, 0.03)));
        // A tight spread does not hide a large quoted error.
        assert!(!always_agrees(&seeds(-1.47, 0.3, &theta, 0.1)));
        let one_out = [-1.45, -1.46, -1.2];
        assert!(!always_agrees(&seeds(-1.47, 0.3, &one_out, 0.01)));
        assert!(!always_agrees(&[]));
    }

    /// A seed whose build fails is a CI failure at that seed, with the cause,
    /// and the survey goes on to the next seed instead of losing the table.
    #[test]
    fn a_seed_whose_build_fails_is_a_ci_failure_and_the_survey_goes_on() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("experiments")).unwrap();
        std::fs::write(
            dir.path().join("experiments/e.yaml"),
            "description: t\nkind: simulate\nseed: 3\nparams: {eps: 0.9}\n\
             profiles:\n  ci:\n    grid: {phi: [0.6]}\n    replicas: 2\n    params: {n: 100}\n",
        )
        .unwrap();
        let gate = file(&[1, 2], &["nofig"], &[]);
        let ids = vec!["nofig".to_string()];
        let opts = RunOptions {
            progress: false,
            ..RunOptions::default()
        };
        let (values, checks) = seed_numbers(
            dir.path(),
            "e",
            "ci",
            &ids,
            &[7, 8],
            &Variant::default(),
            Some(&gate),
            &opts,
        )
        .unwrap();
        assert!(values.is_empty(), "{values:?}");
        assert_eq!(checks.iter().map(|c| c.seed).collect::<Vec<_>>(), [7, 8]);
        for c in &checks {
            assert!(
                c.failures.len() == 1
                    && c.failures[0].starts_with("the build failed: ")
                    && c.failures[0].contains("nofig"),
                "{:?}",
                c.failures
            );
        }
    }

    /// Recording one figure replaces its bands and keeps every other figure's;
    /// bands of other master seeds are not mixed in.
    #[test]
    fn recording_some_figures_keeps_the_others() {
        let old = file(&[1, 2], &["fig2", "fig4"], &["fig4:q", "fig2:q"]);
        let new = file(&[1, 2], &["fig4", "fig9"], &["fig9:q", "fig2:q"]);
        let ids = vec!["fig4".to_string(), "fig9".to_string()];
        let m = merge(old.clone(), new, &ids, "eps09").unwrap();
        let figs: Vec<&str> = m.quantities.iter().map(|q| q.figure.as_str()).collect();
        assert_eq!(figs, ["fig2", "fig4", "fig9"]);
        let names: Vec<&str> = m.ungated.keys().map(|k| k.as_str()).collect();
        assert_eq!(names, ["fig2:q", "fig9:q"]);
        let e = merge(old, file(&[3, 4], &["fig4"], &[]), &ids, "eps09").unwrap_err();
        assert!(format!("{e}").contains("same --seeds"), "{e}");
    }

    #[test]
    fn golden_band_is_four_sigma_or_the_floor() {
        let g = golden("fig4", "phi_c", &[1, 2, 3], &[1.0, 2.0, 3.0], 4.0, 0.01);
        assert!((g.mean - 2.0).abs() < 1e-12 && (g.std - 1.0).abs() < 1e-12);
        assert_eq!(g.band, [-2.0, 6.0]);
        // Wider than the value: it could not fail, so the joint test only.
        assert_eq!(g.gate, Gate::JointOnly);
        assert!(g.gate.passes(100.0, g.band));
        let g = golden("fig4", "phi_c", &[1, 2, 3], &[1.0, 1.1, 1.2], 4.0, 0.01);
        assert_eq!(g.gate, Gate::Band);
        assert!(g.gate.passes(1.45, g.band) && !g.gate.passes(1.55, g.band));
        assert!(!g.gate.passes(f64::NAN, g.band));
        let flat = golden("fig4", "phi_c", &[1, 2], &[0.8, 0.8], 4.0, 0.01);
        assert!(
            (flat.band[1] - 0.808).abs() < 1e-12,
            "floor applies when seeds agree"
        );
    }

    #[test]
    fn the_normal_quantile_and_the_joint_threshold_are_right() {
        assert!((normal_upper_quantile(0.001) - 3.090_232).abs() < 1e-5);
        assert!((normal_upper_quantile(0.01) - 2.326_348).abs() < 1e-5);
        // With many seeds each term tends to chi-square(1): the threshold of 20
        // terms tends to the chi-square quantile 45.31 (0.1%).
        let t = joint_threshold(20, 100_000, 0.001);
        assert!((t - 45.31).abs() < 0.3, "{t}");
        // Ten seeds: heavier tails, a higher threshold.
        assert!(joint_threshold(20, 10, 0.001) > 1.5 * t);
    }

    /// `n` seeds of `k` numbers: independent draws (a sum of uniforms from a
    /// fixed xorshift stream), or one shared draw per seed (fully correlated).
    fn seed_values(k: usize, n: usize, correlated: bool) -> Vec<Vec<f64>> {
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        let mut draw = || {
            (0..12)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    (x >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        let shared: Vec<f64> = (0..n).map(|_| draw()).collect();
        (0..k)
            .map(|q| {
                (0..n)
                    .map(|s| if correlated { shared[s] } else { draw() } + 0.01 * q as f64)
                    .collect()
            })
            .collect()
    }

    /// Many numbers each 2.2 sigma off fail jointly though all are inside 4
    /// sigma; a number published by two figures counts once.
    #[test]
    fn small_shifts_of_many_numbers_fail_jointly() {
        let seeds: Vec<u64> = (1..=10).collect();
        let gs: Vec<Golden> = seed_values(20, 10, false)
            .iter()
            .enumerate()
            .map(|(k, v)| golden("f", &format!("q{k}"), &seeds, v, 4.0, 0.01))
            .collect();
        let off = |z: f64| -> Vec<(&Golden, f64)> {
            gs.iter().map(|g| (g, g.mean + z * g.std)).collect()
        };
        let j = joint(&off(2.2));
        assert_eq!(j.terms, 20);
        assert!(j.chi2 > j.threshold, "{j:?}");
        assert!(joint(&off(0.5)).chi2 < j.threshold);
        // One number far out (a fit that jumped) fails its band, not the
        // joint test: its term is capped at 4 sigma squared.
        let mut one_far = off(0.5);
        one_far[0].1 = gs[0].mean + 40.0 * gs[0].std;
        let jf = joint(&one_far);
        assert!(jf.chi2 < jf.threshold, "{jf:?}");
        assert!((jf.chi2 - joint(&off(0.5)).chi2 - (16.0 - 0.25)).abs() < 1e-9);
        let twice: Vec<(&Golden, f64)> = vec![(&gs[0], gs[0].mean), (&gs[0], gs[0].mean)];
        assert_eq!(joint(&twice).terms, 1);
        // A number only three seeds could give stays out of the joint test
        // and leaves its threshold finite.
        let mut v = vec![f64::NAN; 10];
        v[..3].copy_from_slice(&[1.0, 2.0, 3.0]);
        let sparse = golden("f", "sparse", &seeds, &v, 4.0, 0.01);
        let mut with = off(2.2);
        with.push((&sparse, sparse.mean));
        let js = joint(&with);
        assert_eq!(js.terms, 20);
        assert!(js.threshold.is_finite() && js.chi2 > js.threshold, "{js:?}");
    }

    /// Correlated numbers: twenty copies of one number (shifted, so not
    /// identical) all 2.2 sigma off are one number 2.2 sigma off, not a
    /// regression. The recorded seeds' own leave-one-out sums show the
    /// correlation and raise the threshold; independent ones leave it.
    #[test]
    fn correlated_numbers_raise_the_joint_threshold_from_the_recorded_seeds() {
        let seeds: Vec<u64> = (1..=20).collect();
        let build = |correlated| -> Vec<Golden> {
            seed_values(40, 20, correlated)
                .iter()
                .enumerate()
                .map(|(k, v)| golden("f", &format!("q{k}"), &seeds, v, 6.0, 0.01))
                .collect()
        };
        let (ind, cor) = (build(false), build(true));
        let off = |gs: &[Golden], z: f64| -> Joint {
            let c: Vec<(&Golden, f64)> = gs.iter().map(|g| (g, g.mean + z * g.std)).collect();
            joint(&c)
        };
        let (ji, jc) = (off(&ind, 2.2), off(&cor, 2.2));
        assert!(ji.chi2 > ji.threshold, "{ji:?}");
        assert!(jc.from_seeds && jc.chi2 < jc.threshold, "{jc:?}");
        assert!(jc.threshold > 3.0 * ji.threshold, "{ji:?} {jc:?}");
        // Independent numbers: the leave-one-out sums scatter as the
        // independent-term threshold assumes, within sampling (20 sums).
        assert!(
            ji.threshold < 1.3 * joint_threshold(40, 20, JOINT_FALSE_ALARM),
            "{ji:?}"
        );
    }

    /// A seed whose fit failed (NaN) is left out of the band, written as
    /// `null`, and read back as NaN.
    #[test]
    fn a_failed_seed_round_trips_as_null() {
        let g = golden(
            "fig19",
            "gamma_xi",
            &[1, 2, 3],
            &[1.0, f64::NAN, 3.0],
            4.0,
            0.01,
        );
        assert!((g.mean - 2.0).abs() < 1e-12);
        let json = serde_json::to_string(&g).unwrap();
        assert!(json.contains("[1.0,null,3.0]"), "{json}");
        let back: Golden = serde_json::from_str(&json).unwrap();
        assert_eq!(back.values[0], 1.0);
        assert!(back.values[1].is_nan());
        assert_eq!(back.band, g.band);
    }

    /// Smaller is better for drifts and precision (a more exact simulator must
    /// pass), and a gap must not be negative (overlapping disks fail).
    #[test]
    fn drifts_and_gaps_are_gated_one_sided() {
        let seeds = [1, 2, 3, 4];
        let d = golden(
            "s",
            "energy_drift_mean",
            &seeds,
            &[1e-9, 2e-9, 3e-9, 2e-9],
            6.0,
            0.01,
        );
        assert_eq!(d.gate, Gate::AtMost);
        assert!(d.gate.passes(0.0, d.band) && d.gate.passes(-1e-9, d.band));
        assert!(!d.gate.passes(1e-7, d.band));
        let g = golden(
            "s",
            "closest_gap_mean",
            &seeds,
            &[1e-5, 2e-5, 1e-5, 3e-5],
            6.0,
            0.01,
        );
        assert_eq!(g.gate, Gate::NonNegative);
        assert!(g.gate.passes(0.0, g.band) && g.gate.passes(1e-6, g.band));
        assert!(!g.gate.passes(-1e-6, g.band) && !g.gate.passes(1e-3, g.band));
    }

    /// Constants, numbers missing at some seed and diagnostics get no band,
    /// with a reason; an ordinary number gets one.
    #[test]
    fn numbers_without_a_band_say_why() {
        let r = |q: &str, v: &[f64]| ungated_reason(q, v);
        assert!(
            r("points_tau4", &[7.0, 7.0, 7.0])
                .unwrap()
                .contains("at every seed")
        );
        assert!(
            r("gamma_xi", &[1.0, f64::NAN, 2.0])
                .unwrap()
                .contains("1 of 3")
        );
        assert!(
            r("reduced_chi2_xi", &[1.0, 3.0])
                .unwrap()
                .contains("diagnostic")
        );
        assert!(r("gamma_xi", &[1.0, 1.1, 1.2]).is_none());
    }
}
