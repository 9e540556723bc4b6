//! Tests of the fingerprint derivation (src/pipeline/fingerprint.rs).

use super::*;

#[test]
fn use_groups_aliases_and_paths_are_read() {
    assert_eq!(
        expand("super::{a::B,c::{self,D}}"),
        ["super::a::B", "super::c", "super::c::D"]
    );
    assert_eq!(normalise("a :: { B as C ,\n d }"), "a::{B as C,d}");
    assert_eq!(alias("a::B as C"), ("a::B".to_string(), "C".to_string()));
    let (code, tests) = non_test_code(
        "use super::g;\n#[cfg(test)]\nmod tests;\n#[cfg(test)]\nmod t {\n    use super::x;\n}\n",
    );
    assert_eq!(tests, ["tests"]);
    let mut crates = BTreeSet::new();
    let named = paths(&code, &mut crates);
    let segs: Vec<String> = named.iter().map(|n| n.segs.join("::")).collect();
    assert_eq!(segs, ["super::g"]);
    let mut crates = BTreeSet::new();
    let named = paths(
        "pub use child::Thing;\npub use other::Used;\nuse serde::Deserialize;\nfn f() -> Used { anyhow::bail!(\"\"); crate::x::y() }\npub(in crate::plot) fn g() {}\n",
        &mut crates,
    );
    let seen: Vec<(String, bool)> = named.iter().map(|n| (n.segs.join("::"), n.used)).collect();
    assert_eq!(
        seen,
        [
            ("self::child::Thing".to_string(), false),
            ("self::other::Used".to_string(), true),
            ("self::serde::Deserialize".to_string(), true),
            ("crate::x::y".to_string(), true),
        ]
    );
    assert!(
        crates.contains("serde") && crates.contains("anyhow"),
        "{crates:?}"
    );
    assert_eq!(module_key("src/stages/fit/mod.rs"), "stages/fit");
    assert_eq!(module_key("stages/simulate"), "stages/simulate");
}

/// `columns::f()` in a file declaring `mod columns;`, `pool::g()` after
/// `use super::pool;`, and a name a glob re-exports.
#[test]
fn inline_paths_resolve_in_their_module() {
    let mut crates = BTreeSet::new();
    let code = "pub mod columns;\nuse super::pool;\nuse columns::Cell;\npub use deep::*;\nfn f() -> Cell { columns::g(); pool::h(); Vec::new() }\n";
    let named = paths(code, &mut crates);
    let segs: Vec<String> = named.iter().map(|n| n.segs.join("::")).collect();
    assert_eq!(
        segs,
        [
            "super::pool",
            "self::columns::Cell",
            "self::deep::*",
            "self::columns::g",
            "super::pool::h"
        ]
    );
    assert!(
        crates.contains("Vec") && !crates.contains("columns"),
        "{crates:?}"
    );
    assert!(is_harness("pipeline/registry") && is_harness("lib") && !is_harness("table"));
    let v = |s: &str| -> Vec<String> {
        s.split('/')
            .filter(|x| !x.is_empty())
            .map(str::to_string)
            .collect()
    };
    let modules: BTreeSet<Vec<String>> = ["", "a", "a/deep", "x"].iter().map(|m| v(m)).collect();
    let mut reexports: Reexports = BTreeMap::new();
    reexports.entry(v("a")).or_default().insert(
        "*".into(),
        vec![vec!["self".into(), "deep".into(), "*".into()]],
    );
    let path: Vec<String> = ["crate", "a", "Thing"].map(str::to_string).to_vec();
    assert_eq!(
        resolve(&v("x"), &path, &modules, &reexports, 0),
        Some(v("a/deep"))
    );
}

/// A catalogue `cat` naming members `m1` and `m2`, each reaching a shared
/// `s`: with the edge to `m2` cut, the key of `m1`'s kind covers the
/// catalogue, `m1` and `s`, not `m2`; a cut that is no import is an error.
#[test]
fn a_cut_edge_is_not_followed() {
    let mut s = Sources::default();
    let m = |deps: &[&str], hash: &str| Module {
        hash: hash.into(),
        deps: deps.iter().map(|d| d.to_string()).collect(),
        ..Module::default()
    };
    s.modules.insert("kind".into(), m(&["cat"], "k"));
    s.modules.insert("cat".into(), m(&["m1", "m2"], "c"));
    s.modules.insert("m1".into(), m(&["s"], "1"));
    s.modules.insert("m2".into(), m(&["s"], "2"));
    s.modules.insert("s".into(), m(&[], "s"));
    let all = s.closure(&["kind"]).unwrap();
    assert_eq!(all.len(), 5);
    let one = s.closure_cut(&["kind"], &[("cat", "m2")]).unwrap();
    assert_eq!(
        one.into_iter().collect::<Vec<_>>(),
        ["cat", "kind", "m1", "s"]
    );
    let f1 = s.fingerprint_cut("k", &["kind"], &[("cat", "m2")]).unwrap();
    s.modules.get_mut("m2").unwrap().hash = "2'".into();
    let f2 = s.fingerprint_cut("k", &["kind"], &[("cat", "m2")]).unwrap();
    assert_eq!(f1, f2, "an edit of the cut member moved the key");
    s.modules.get_mut("m1").unwrap().hash = "1'".into();
    let f3 = s.fingerprint_cut("k", &["kind"], &[("cat", "m2")]).unwrap();
    assert_ne!(f1.hash, f3.hash, "an edit of the own member left the key");
    let e = s.closure_cut(&["kind"], &[("m1", "m2")]).unwrap_err();
    assert!(e.contains("'m1' -> 'm2' is no import"), "{e}");
}

#[test]
fn a_cycle_is_found_and_named() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.insert("a".into(), ["b".into()].into());
    g.insert("b".into(), ["c".into()].into());
    g.insert("c".into(), ["a".into()].into());
    assert_eq!(find_cycle(&g).unwrap().join(" -> "), "a -> b -> c -> a");
    g.get_mut("c").unwrap().clear();
    assert_eq!(find_cycle(&g), None);
}

#[test]
fn the_lock_is_read_and_closed_over_dependencies() {
    let lock = "version = 4\n\n[[package]]\nname = \"a-b\"\nversion = \"1.0.0\"\nsource = \"registry+x\"\nchecksum = \"aa\"\ndependencies = [\n \"c 2.0.0\",\n]\n\n[[package]]\nname = \"c\"\nversion = \"2.0.0\"\n\n[[package]]\nname = \"c\"\nversion = \"3.0.0\"\n\n[[package]]\nname = \"d\"\nversion = \"1.0.0\"\n";
    let mut s = Sources {
        lock: parse_lock(lock),
        ..Sources::default()
    };
    assert_eq!(s.lock.len(), 4);
    assert_eq!(s.lock[0].deps, ["c 2.0.0"]);
    let m = Module {
        crates: ["a_b".to_string()].into(),
        ..Module::default()
    };
    s.modules.insert("x".into(), m);
    let f = s.fingerprint("k", &["x"]).unwrap();
    assert_eq!(f.crates, ["a-b 1.0.0", "c 2.0.0"]);
    assert_eq!(Sources::from_text(&s.to_text()), s);
}
