//! No import cycles: the module graph read from the sources (every path of
//! non-test code, in `use` lines and inline, resolved in its module, a
//! re-export followed to the file defining the name; the same graph the code
//! fingerprints close over, `repro::pipeline::fingerprint`) is acyclic file by
//! file, and between the files and subfolders of every folder of `src/`; so is
//! the graph `syn` reads (tests/syn_graph). A cycle is printed as the chain of
//! modules that closes it.

mod syn_graph;

use std::collections::BTreeSet;
use std::path::Path;

use repro::pipeline::fingerprint::{Sources, find_cycle};

/// The top-level modules whose dependencies must form a DAG.
const TOP_LEVEL: &[&str] = &[
    "sim", "analysis", "fit", "table", "plot", "pipeline", "stages", "study", "cli", "traj",
];

fn sources() -> Sources {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Sources::read(&root.join("src"), &root.join("Cargo.lock"))
}

fn assert_acyclic(what: &str, cycle: Option<Vec<String>>) {
    if let Some(c) = cycle {
        panic!("import cycle {what}: {}", c.join(" -> "));
    }
}

#[test]
fn no_two_files_import_each_other_through_any_chain() {
    let s = sources();
    assert!(s.modules.len() > 120, "{} modules", s.modules.len());
    // The graph sees through re-exports: the fit kind reaches the statistics.
    let fit = s.closure(&["stages/fit/kind"]).unwrap();
    assert!(fit.contains("fit/uncertainty/replicas"), "{fit:?}");
    assert_acyclic("between files", s.cycle(|m| Some(m.to_string())));
}

/// The second reading of the sources finds no cycle either (a mod.rs and the
/// children whose paths it names inline, `columns::f()`, included).
#[test]
fn the_graph_syn_reads_has_no_cycle() {
    let g = syn_graph::syn_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(g["table"].contains("table/columns"), "{:?}", g["table"]);
    assert_acyclic("between files (syn)", find_cycle(&g));
}

/// Every folder of `src/` (and `src/` itself): its files and subfolders, a
/// subfolder as one node, import each other without a cycle.
#[test]
fn the_files_and_subfolders_of_every_folder_import_without_cycles() {
    let s = sources();
    let mut folders: BTreeSet<String> = BTreeSet::new();
    folders.insert(String::new());
    for k in s.modules.keys() {
        let segs: Vec<&str> = k.split('/').collect();
        for n in 1..segs.len() {
            folders.insert(segs[..n].join("/"));
        }
    }
    assert!(folders.contains("stages/fit") && folders.contains("sim/engine"));
    for f in &folders {
        let node = |m: &str| -> Option<String> {
            let rest = if f.is_empty() {
                (m != "lib").then_some(m)?
            } else {
                m.strip_prefix(f.as_str())?.strip_prefix('/')?
            };
            Some(rest.split('/').next()?.to_string())
        };
        let name = if f.is_empty() { "src" } else { f.as_str() };
        assert_acyclic(&format!("between the files of {name}/"), s.cycle(node));
    }
}

#[test]
fn the_top_level_modules_import_without_cycles() {
    let s = sources();
    let top = |m: &str| {
        let t = m.split('/').next()?;
        TOP_LEVEL.contains(&t).then(|| t.to_string())
    };
    let tops: BTreeSet<String> = s.modules.keys().filter_map(|m| top(m)).collect();
    assert_eq!(tops.len(), TOP_LEVEL.len(), "{tops:?}");
    assert_acyclic("between top-level modules", s.cycle(top));
}

/// The engine and the event machinery sit below a run: they import nothing
/// of `sim/run`.
#[test]
fn the_engine_and_the_events_do_not_import_the_run() {
    let s = sources();
    for (k, m) in &s.modules {
        if k.starts_with("sim/engine") || k.starts_with("sim/events") {
            let up: Vec<&String> = m.deps.iter().filter(|d| d.starts_with("sim/run")).collect();
            assert!(up.is_empty(), "{k} imports {up:?}");
        }
    }
}
