//! The CI regression: golden bands of every key number from several master
//! seeds, and the check of built figures against them (`repro regress`).
//!
//! Band rule (docs/figures.md, "CI regression"): mean +- max(sigmas x seed-to-seed
//! standard deviation, relative_floor x |mean|) over the recorded seeds.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};

use super::results::{Fitted, key_numbers, key_numbers_with_errors, provenance};
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
    pub mean: f64,
    pub std: f64,
    pub band: [f64; 2],
}

/// `tests/golden/PROFILE.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GoldenFile {
    pub profile: String,
    pub how: String,
    pub sigmas: f64,
    pub relative_floor: f64,
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

/// Band = mean +- max(sigmas x seed-to-seed standard deviation, floor x |mean|);
/// seeds without a number (NaN) are left out.
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
    Golden {
        figure: figure.into(),
        quantity: quantity.into(),
        seeds: seeds.to_vec(),
        values: values.to_vec(),
        mean,
        std,
        band: [mean - half, mean + half],
    }
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
        let got = key_numbers(&dir)?;
        for q in qs {
            let v = got.get(&q.quantity).copied().unwrap_or(f64::NAN);
            let inside = v >= q.band[0] && v <= q.band[1];
            lines.push(format!(
                "{fig} {}: {v:.5} {} band [{:.5}, {:.5}] (golden mean {:.5}, seed-to-seed std {:.5})",
                q.quantity,
                if inside { "inside" } else { "OUTSIDE" },
                q.band[0],
                q.band[1],
                q.mean,
                q.std
            ));
            if !inside {
                failures.push(format!(
                    "regression in {fig}: {} = {v:.5} is outside the band [{:.5}, {:.5}]",
                    q.quantity, q.band[0], q.band[1]
                ));
            }
        }
    }
    Ok((lines, failures))
}

/// The band rule's constants.
pub const SIGMAS: f64 = 4.0;
pub const FLOOR: f64 = 0.01;

/// What `repro regress --record` builds.
pub struct Recording<'a> {
    pub root: &'a Path,
    pub experiment: &'a str,
    pub profile: &'a str,
    pub ids: &'a [String],
    pub seeds: &'a [u64],
    /// FIGURE:QUANTITY left out of the bands.
    pub ungated: &'a [String],
}

/// Build the figures at every master seed (in-memory variants of the catalogue)
/// and derive the golden file.
pub fn record(r: &Recording, opts: &RunOptions) -> Result<GoldenFile> {
    let values: BTreeMap<(String, String), Vec<f64>> = seed_numbers(
        r.root,
        r.experiment,
        r.profile,
        r.ids,
        r.seeds,
        &Variant::default(),
        opts,
    )?
    .into_iter()
    .map(|(k, v)| (k, v.iter().map(|f| f.value).collect()))
    .collect();
    // A number no seed produced (a fit failing at this profile) has no band.
    let quantities = values
        .iter()
        .filter(|(_, v)| v.iter().filter(|x| x.is_finite()).count() >= 2)
        .filter(|((f, q), _)| !r.ungated.contains(&format!("{f}:{q}")))
        .map(|((f, q), v)| golden(f, q, r.seeds, v, SIGMAS, FLOOR))
        .collect();
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    Ok(GoldenFile {
        profile: r.profile.to_string(),
        how: format!(
            "`repro regress --record --profile {} --seeds {}`: the figures built with experiment '{}' at each master seed; \
             band = mean +- max({SIGMAS} x seed-to-seed standard deviation, {FLOOR} x |mean|); not gated: {}",
            r.profile,
            r.seeds
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(","),
            r.experiment,
            list(r.ungated)
        ),
        sigmas: SIGMAS,
        relative_floor: FLOOR,
        quantities,
    })
}

/// Every key number of figures `ids` with its quoted error at each master seed:
/// (figure, quantity) -> one entry per seed (NaN where that seed gave none);
/// `base` changes the experiment besides the seed.
pub fn seed_numbers(
    root: &Path,
    experiment: &str,
    profile: &str,
    ids: &[String],
    seeds: &[u64],
    base: &Variant,
    opts: &RunOptions,
) -> Result<BTreeMap<(String, String), Vec<Fitted>>> {
    let none = Fitted {
        value: f64::NAN,
        error: f64::NAN,
    };
    let mut values: BTreeMap<(String, String), Vec<Fitted>> = BTreeMap::new();
    for (k, &seed) in seeds.iter().enumerate() {
        eprintln!("master seed {seed}");
        let v = Variant {
            seed: Some(seed),
            ..base.clone()
        };
        let built = variant::build(root, experiment, profile, &v, ids, opts)?;
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
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_band_is_four_sigma_or_the_floor() {
        let g = golden("fig4", "phi_c", &[1, 2, 3], &[1.0, 2.0, 3.0], 4.0, 0.01);
        assert!((g.mean - 2.0).abs() < 1e-12 && (g.std - 1.0).abs() < 1e-12);
        assert_eq!(g.band, [-2.0, 6.0]);
        let flat = golden("fig4", "phi_c", &[1, 2], &[0.8, 0.8], 4.0, 0.01);
        assert!(
            (flat.band[1] - 0.808).abs() < 1e-12,
            "floor applies when seeds agree"
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
}
