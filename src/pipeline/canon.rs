//! Canonical parameters and the hashes built on them (stage keys, recipes, seeds).
//!
//! Parameters are JSON objects. `serde_json::Map` keeps keys sorted (no
//! `preserve_order`), and floats print shortest-roundtrip, so the serialised text is
//! canonical: equal parameters give equal bytes, hence equal hashes.

use std::collections::BTreeMap;

use serde_json::Value;

/// A parameter point: the grid and sweep values that label one stage instance
/// (e.g. `{phi: 0.78, replica: 2, N_sub: 400}`).
pub type Point = BTreeMap<String, Value>;

/// An error about one parameter of a stage kind, with the path of the offending key
/// or value inside the parameters (`["tau_guess", "A"]`), so the planner can point at
/// it in the YAML file.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    pub path: Vec<String>,
    pub message: String,
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for ParamError {}

/// An error about the parameter at `path` (keys, outermost first).
pub fn param_error(path: &[&str], message: impl Into<String>) -> anyhow::Error {
    ParamError {
        path: path.iter().map(|s| s.to_string()).collect(),
        message: message.into(),
    }
    .into()
}

/// Canonical text of a JSON value (sorted keys, shortest-roundtrip floats).
pub fn canonical(v: &Value) -> String {
    serde_json::to_string(v).expect("a serde_json::Value always serialises")
}

/// Hash a sequence of labelled fields unambiguously (each field is length-prefixed,
/// so ("ab","c") and ("a","bc") differ).
pub fn hash_fields(domain: &str, fields: &[&[u8]]) -> blake3::Hash {
    let mut h = blake3::Hasher::new();
    h.update(domain.as_bytes());
    for f in fields {
        h.update(&(f.len() as u64).to_le_bytes());
        h.update(f);
    }
    h.finalize()
}

/// The seed of one replica of one ensemble point: a hash of (master seed, point,
/// replica). Independent of the order in which points are listed or run.
pub fn derive_seed(master: u64, point_without_replica: &Point, replica: u64) -> u64 {
    let point = canonical(&Value::Object(
        point_without_replica
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect(),
    ));
    let h = hash_fields(
        "repro-seed-v1",
        &[
            &master.to_le_bytes(),
            point.as_bytes(),
            &replica.to_le_bytes(),
        ],
    );
    u64::from_le_bytes(h.as_bytes()[..8].try_into().unwrap())
}

/// Short, human-readable rendering of a point: `phi=0.78,replica=2`.
pub fn point_label(p: &Point) -> String {
    p.iter()
        .map(|(k, v)| match v {
            Value::String(s) => format!("{k}={s}"),
            other => format!("{k}={other}"),
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// Per-key differences between two parameter objects, as readable lines.
pub fn diff_params(old: &Value, new: &Value) -> Vec<String> {
    let empty = serde_json::Map::new();
    let o = old.as_object().unwrap_or(&empty);
    let n = new.as_object().unwrap_or(&empty);
    let mut keys: Vec<&String> = o.keys().chain(n.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter_map(|k| match (o.get(k), n.get(k)) {
            (Some(a), Some(b)) if a == b => None,
            (Some(a), Some(b)) => Some(format!("parameter {k}: {a} -> {b}")),
            (Some(a), None) => Some(format!("parameter {k} removed (was {a})")),
            (None, Some(b)) => Some(format!("parameter {k} added ({b})")),
            (None, None) => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn canonical_sorts_keys_and_prints_shortest_floats() {
        let a: Value =
            serde_json::from_str(r#"{"b": 0.1, "a": 1e-7, "c": [3, 0.30000000000000004]}"#)
                .unwrap();
        assert_eq!(
            canonical(&a),
            r#"{"a":1e-7,"b":0.1,"c":[3,0.30000000000000004]}"#
        );
    }

    #[test]
    fn seeds_depend_on_every_part_and_nothing_else() {
        let mut p = Point::new();
        p.insert("phi".into(), json!(0.78));
        let s = derive_seed(7, &p, 0);
        assert_eq!(s, derive_seed(7, &p.clone(), 0));
        assert_ne!(s, derive_seed(8, &p, 0));
        assert_ne!(s, derive_seed(7, &p, 1));
        p.insert("phi".into(), json!(0.79));
        assert_ne!(s, derive_seed(7, &p, 0));
    }

    #[test]
    fn field_hash_is_unambiguous() {
        assert_ne!(
            hash_fields("d", &[b"ab", b"c"]),
            hash_fields("d", &[b"a", b"bc"])
        );
    }

    #[test]
    fn diff_names_changed_added_removed_keys() {
        let d = diff_params(&json!({"a": 1, "b": 2}), &json!({"a": 1, "b": 3, "c": 4}));
        assert_eq!(d, vec!["parameter b: 2 -> 3", "parameter c added (4)"]);
    }
}
