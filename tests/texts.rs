//! Numbers in texts (docs/spec.md, "Numbers in texts"): no pipeline's prose
//! (description, notes, labels, titles, compare reasons, `error_coverage`,
//! shared `reasons`) states a number typed by hand; each is a reference to a
//! build, a `{paper:...}` quotation, or inside a backticked command. Every
//! reference parses, and a plot's texts reference only its own build.

use std::path::PathBuf;

use repro::table::references::{prose, references, typed_numbers};
use serde_json::Value;

/// The pipelines whose texts are checked: every file of `pipelines/`, so a new
/// pipeline is checked too.
fn enforced() -> Vec<String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut ids: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .map(|p| {
            p.file_stem()
                .expect("a file name")
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    ids.sort();
    assert!(!ids.is_empty(), "no pipeline in {}", dir.display());
    ids
}

fn pipeline(id: &str) -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("pipelines")
        .join(format!("{id}.yaml"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_saphyr::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every typed number of `doc`'s prose: (path of the text, the number, the text).
fn typed(doc: &Value) -> Vec<(String, String, String)> {
    prose(doc)
        .into_iter()
        .flat_map(|(path, text)| {
            typed_numbers(&text)
                .into_iter()
                .map(move |n| (path.clone(), n, text.clone()))
        })
        .collect()
}

#[test]
fn no_enforced_pipeline_types_a_number_into_its_texts() {
    let mut bad = Vec::new();
    for id in &enforced() {
        for (path, n, text) in typed(&pipeline(id)) {
            let head: String = text.chars().take(100).collect();
            bad.push(format!(
                "pipelines/{id}.yaml {path}: `{n}` in \"{head}...\""
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "{} numbers typed by hand (write {{=STAGE.QUANTITY}}, {{paper:X}} or drop them; docs/spec.md, \"Numbers in texts\"):\n{}",
        bad.len(),
        bad.join("\n")
    );
}

/// The check itself: a pipeline text with a measured number typed in fails,
/// the same text with a reference and a quotation passes.
#[test]
fn the_check_finds_a_typed_number_in_a_pipeline_text() {
    let doc: Value = serde_saphyr::from_str(
        "description: x\nstages:\n  - name: compare\n    profiles:\n      small:\n        caveats:\n          phi_c: \"phi_c lies at 0.8053, short of 0.82\"\n",
    )
    .unwrap();
    let found = typed(&doc);
    assert_eq!(found.len(), 2, "{found:?}");
    assert_eq!(found[0].0, "stages[compare].profiles.small.caveats.phi_c");
    assert_eq!(
        (found[0].1.as_str(), found[1].1.as_str()),
        ("0.8053", "0.82")
    );
    let fixed: Value = serde_saphyr::from_str(
        "description: x\nstages:\n  - name: compare\n    profiles:\n      small:\n        caveats:\n          phi_c: \"phi_c lies at {=joint.phi_c}, short of {paper:0.82}\"\n",
    )
    .unwrap();
    assert!(typed(&fixed).is_empty());
}

#[test]
fn every_reference_parses_and_a_plot_names_only_its_own_build() {
    let mut bad = Vec::new();
    for id in &enforced() {
        let doc = pipeline(id);
        for (path, text) in prose(&doc) {
            match references(&text) {
                Err(e) => bad.push(format!("pipelines/{id}.yaml {path}: {e:#}")),
                Ok(refs) => {
                    let plot = doc["stages"].as_array().into_iter().flatten().any(|s| {
                        s["kind"] == "plot"
                            && path.starts_with(&format!(
                                "stages[{}]",
                                s["name"].as_str().unwrap_or("")
                            ))
                    });
                    if plot && refs.iter().any(|r| !r.is_local()) {
                        bad.push(format!(
                            "pipelines/{id}.yaml {path}: a plot's text references another figure or profile: \"{text}\""
                        ));
                    }
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Every string below a `short` key (a compare's short reasons, per profile),
/// with its path. `short` is no prose key of the library's walk, so the test
/// walks the document itself.
fn shorts(doc: &Value) -> Vec<(String, String)> {
    fn walk(v: &Value, path: &str, below: bool, out: &mut Vec<(String, String)>) {
        match v {
            Value::String(s) if below => out.push((path.to_string(), s.clone())),
            Value::Array(xs) => xs.iter().for_each(|x| walk(x, path, below, out)),
            Value::Object(m) => {
                for (k, x) in m {
                    walk(x, &format!("{path}.{k}"), below || k == "short", out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(doc, "", false, &mut out);
    out
}

#[test]
fn the_short_walk_finds_every_profile_s_short_reasons() {
    let doc: Value = serde_saphyr::from_str(
        "stages:\n  - name: compare\n    params:\n      short: {a: top}\n      profiles:\n        small:\n          short: {b: one, c: two}\n",
    )
    .unwrap();
    let mut found: Vec<String> = shorts(&doc).into_iter().map(|(_, t)| t).collect();
    found.sort();
    assert_eq!(found, ["one", "top", "two"]);
}

/// A compare's `short` reason is printed whole on the image: one longer than a
/// verdict line holds would be cut mid-sentence.
#[test]
fn every_short_reason_fits_its_verdict_line() {
    let limit = repro::stages::plot::SHORT_CHARS;
    let mut bad = Vec::new();
    for id in &enforced() {
        for (path, text) in shorts(&pipeline(id)) {
            // The raw text: a reference to a number is longer than the
            // number it prints, so the raw length bounds the printed one.
            if text.chars().count() > limit {
                bad.push(format!(
                    "pipelines/{id}.yaml {path}: {} characters (at most {limit}): \"{text}\"",
                    text.chars().count()
                ));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// method-intruder-heating turns the drift's total kinetic energy into one per
/// disk with a factor 1 / (2 N) written as a number (a join's operand is a
/// column or a number): it must equal 1 / (2 N) of its runs at every profile.
#[test]
fn the_drift_energy_factor_is_one_over_two_n_of_its_runs() {
    let doc = pipeline("method-intruder-heating");
    let factor = doc["stages"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|s| {
            s["params"]["derive"]
                .as_array()
                .cloned()
                .unwrap_or_default()
        })
        .find(|d| d["name"] == "drift_energy")
        .and_then(|d| d["b"].as_f64())
        .expect("a derive `drift_energy` with a number `b`");
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("experiments/intruder_eps09.yaml");
    let exp: Value = serde_saphyr::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let profiles = exp["profiles"].as_object().unwrap();
    assert!(!profiles.is_empty());
    for (name, p) in profiles {
        let n = p["params"]["n"]
            .as_f64()
            .unwrap_or_else(|| panic!("{name}: no n"));
        assert!(
            (factor - 1.0 / (2.0 * n)).abs() < 1e-12,
            "{name}: N = {n}, so the factor must be {}, not {factor}",
            1.0 / (2.0 * n)
        );
    }
}
