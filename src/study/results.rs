//! Reading a built figure: `results/ID/compare.parquet`, its fit tables and
//! `provenance.json`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde_json::Value;

use crate::table::results;

pub use crate::table::results::{Compared, Verdict};

/// How many key numbers have each verdict.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    counts: [usize; 5],
}

impl Tally {
    pub fn of<'a>(compared: impl IntoIterator<Item = &'a Compared>) -> Tally {
        let mut t = Tally::default();
        for c in compared {
            t.counts[c.verdict as usize] += 1;
        }
        t
    }

    pub fn get(&self, v: Verdict) -> usize {
        self.counts[v as usize]
    }

    pub fn total(&self) -> usize {
        self.counts.iter().sum()
    }

    pub fn add(&mut self, other: &Tally) {
        for (a, b) in self.counts.iter_mut().zip(other.counts) {
            *a += b;
        }
    }

    /// `3 agree, 1 disagree, 0 out of reach, 0 unreliable, 0 missing`: the line
    /// `repro regress` prints and the HTML report's totals are checked against.
    pub fn line(&self) -> String {
        Verdict::ALL
            .iter()
            .map(|v| format!("{} {}", self.get(*v), v.label()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Read `DIR/compare.parquet`.
pub fn read_compare(dir: &Path) -> Result<Vec<Compared>> {
    let path = dir.join("compare.parquet");
    let (batches, _) = crate::table::read_parquet(&path)?;
    let mut out = Vec::new();
    for b in batches {
        out.extend(results::read_compare(&b).with_context(|| path.display().to_string())?);
    }
    Ok(out)
}

/// A fitted number with its quoted error, from a published fit table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fitted {
    pub value: f64,
    pub error: f64,
    /// The paper verdict, for a number the figure compares with its paper.
    pub verdict: Option<Verdict>,
    /// Where it agrees: how far inside the agreement it lies, | tolerance -
    /// |ours - paper| | (for a value, the distance to the tolerance's edge; for
    /// a claim, the distance beyond the bound's margin). NaN otherwise.
    pub margin: f64,
}

/// Every published fit table's rows (quantity, value, error) of a built figure,
/// by name; compare.parquet is not one of them.
pub fn fitted(dir: &Path) -> Result<BTreeMap<String, Fitted>> {
    let mut out = BTreeMap::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            // A fit's own table only: not its range scan (`fit.ranges.parquet`,
            // whose windows carry the same quantity names and, read after it,
            // would stand for the fit), jackknife refits or drawn curve.
            let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("");
            p.extension().is_some_and(|x| x == "parquet")
                && !p.ends_with("compare.parquet")
                && !stem.contains('.')
        })
        .collect();
    files.sort();
    for f in files {
        let (batches, _) = crate::table::read_parquet(&f)?;
        for b in batches {
            for r in results::read_quantities(&b).unwrap_or_default() {
                out.insert(
                    r.quantity,
                    Fitted {
                        value: r.value,
                        error: r.error,
                        verdict: None,
                        margin: f64::NAN,
                    },
                );
            }
        }
    }
    Ok(out)
}

/// The fitted quantities of a built figure that a fit table reports once per
/// group (a `group_by` fit: one row per phi, eta, ...): [`fitted`] keeps one of
/// their rows only, so a listing of single numbers must leave them out.
pub fn grouped_quantities(dir: &Path) -> Result<std::collections::BTreeSet<String>> {
    let mut out = std::collections::BTreeSet::new();
    for f in std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .flatten()
        .map(|e| e.path())
    {
        let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if f.extension().is_none_or(|x| x != "parquet")
            || f.ends_with("compare.parquet")
            || stem.contains('.')
        {
            continue;
        }
        let (batches, _) = crate::table::read_parquet(&f)?;
        let mut seen = std::collections::BTreeSet::new();
        for b in batches {
            for r in results::read_quantities(&b).unwrap_or_default() {
                if !seen.insert(r.quantity.clone()) {
                    out.insert(r.quantity);
                }
            }
        }
    }
    Ok(out)
}

/// Every key number of a built figure with its quoted error: every published fit
/// table's rows and the `ours`, `ours_err` columns of compare.parquet, by name.
pub fn key_numbers_with_errors(dir: &Path) -> Result<BTreeMap<String, Fitted>> {
    let mut out = fitted(dir)?;
    if dir.join("compare.parquet").exists() {
        for c in read_compare(dir)? {
            out.insert(
                c.quantity,
                Fitted {
                    value: c.ours,
                    error: c.ours_err,
                    verdict: Some(c.verdict),
                    margin: (c.tolerance - (c.ours - c.paper).abs()).abs(),
                },
            );
        }
    }
    Ok(out)
}

/// Every key number of a built figure (see [`key_numbers_with_errors`]).
pub fn key_numbers(dir: &Path) -> Result<BTreeMap<String, f64>> {
    Ok(key_numbers_with_errors(dir)?
        .into_iter()
        .map(|(q, f)| (q, f.value))
        .collect())
}

/// What `provenance.json` says about a built figure.
#[derive(Clone, Debug)]
pub struct Provenance {
    pub profile: String,
    pub description: String,
    /// The git commit of the checkout that built it, if any.
    pub commit: Option<String>,
    /// The version of repro that built it.
    pub version: String,
    /// CPU seconds of all its stages (as first computed, cached or not).
    pub cpu_s: f64,
    /// When it was published (the file's modification time).
    pub written: std::time::SystemTime,
    pub stages: Vec<StageRun>,
    /// The files the pipeline published into the figure's directory.
    pub published: Vec<String>,
}

/// One stage instance of a built figure, from `provenance.json`.
#[derive(Clone, Debug)]
pub struct StageRun {
    pub label: String,
    pub kind: String,
    /// The cache key: hash of the stage's spec, inputs and code.
    pub key: Option<String>,
    pub seed: Option<u64>,
    /// CPU seconds when it was computed (NaN if not recorded).
    pub cpu_s: f64,
    pub wall_s: f64,
    /// Taken from the cache by the run that published the figure.
    pub cached: bool,
}

/// Read `DIR/provenance.json`.
pub fn provenance(dir: &Path) -> Result<Provenance> {
    let path = dir.join("provenance.json");
    let bytes = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    let v: Value =
        serde_json::from_slice(&bytes).with_context(|| format!("parsing {}", path.display()))?;
    let cpu_s = v["stages"]
        .as_array()
        .map(|s| s.iter().filter_map(|x| x["cpu_s"].as_f64()).sum())
        .unwrap_or(f64::NAN);
    let stages = v["stages"]
        .as_array()
        .map(|s| {
            s.iter()
                .map(|x| StageRun {
                    label: x["label"].as_str().unwrap_or("").to_string(),
                    kind: x["kind"].as_str().unwrap_or("").to_string(),
                    key: x["key"].as_str().map(String::from),
                    seed: x["seed"].as_u64(),
                    cpu_s: x["cpu_s"].as_f64().unwrap_or(f64::NAN),
                    wall_s: x["wall_s"].as_f64().unwrap_or(f64::NAN),
                    cached: x["executed_in_this_run"].as_bool() == Some(false),
                })
                .collect()
        })
        .unwrap_or_default();
    let published = v["published"]
        .as_object()
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default();
    Ok(Provenance {
        profile: v["profile"].as_str().unwrap_or("").to_string(),
        description: v["description"].as_str().unwrap_or("").to_string(),
        commit: v["git_commit"].as_str().map(String::from),
        version: v["repro_version"].as_str().unwrap_or("").to_string(),
        cpu_s,
        written: std::fs::metadata(&path)?.modified()?,
        stages,
        published,
    })
}

/// JSON has no NaN: serde_json writes it as `null`, which must read back as NaN
/// (a seed whose fit gave no number).
pub mod nan_as_null {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let o: Vec<Option<f64>> = v.iter().map(|x| x.is_finite().then_some(*x)).collect();
        o.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let o = Vec::<Option<f64>>::deserialize(d)?;
        Ok(o.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
    }

    /// One number: `null` reads back as NaN.
    pub fn one<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

#[cfg(test)]
mod fitted_tests {
    use crate::table::results::quantity_batch;
    use crate::table::to_parquet_bytes;

    /// A fit's key numbers come from its own table, not from its range scan's
    /// windows, which carry the same names and sort after it.
    #[test]
    fn a_range_scan_does_not_stand_for_its_fit() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, a: f64| {
            let b = quantity_batch(&[], &[("A".into(), a, 0.1)], "", None).unwrap();
            std::fs::write(dir.path().join(name), to_parquet_bytes(&[b], &[]).unwrap()).unwrap();
        };
        write("fit.parquet", 1.0);
        write("fit.ranges.parquet", 2.0);
        write("fit.jackknife.parquet", 3.0);
        let f = super::fitted(dir.path()).unwrap();
        assert_eq!(f["A"].value, 1.0);
    }
}
