//! Cache keys cover exactly the code a stage runs. For every file of `src/`,
//! the kinds whose key moves when the file is edited (the derivation build.rs
//! runs, `Sources::read` on an edited copy) are exactly the kinds whose import
//! closure reaches the file, the closure computed a second way ([`syn_graph`]).
//! Editing the framework reruns no simulation; editing what a kind runs reruns
//! it.

mod syn_graph;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use repro::pipeline::fingerprint::{Sources, module_key};
use repro::pipeline::{Catalogue, Registry};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_tree(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// A copy of the sources and the lock in a temporary directory.
struct Copy {
    _dir: tempfile::TempDir,
    src: PathBuf,
    lock: PathBuf,
}

impl Copy {
    fn new() -> Copy {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("src");
        copy_tree(&root().join("src"), &src);
        let lock = dir.path().join("Cargo.lock");
        std::fs::copy(root().join("Cargo.lock"), &lock).unwrap();
        // What `include_bytes!` of the sources reaches.
        copy_tree(&root().join("assets"), &dir.path().join("assets"));
        Copy {
            _dir: dir,
            src,
            lock,
        }
    }

    /// The sources as build.rs reads them, with the compiler of this build.
    fn sources(&self) -> Sources {
        let mut s = Sources::read(&self.src, &self.lock);
        s.rustc = repro::fingerprints::sources().rustc.clone();
        s
    }

    /// Every kind's fingerprint with `file` edited as `edit` says, then restored.
    fn edited(&self, file: &Path, edit: impl Fn(&str) -> String, kinds: &Kinds<'_>) -> Vec<String> {
        let before = std::fs::read_to_string(file).unwrap();
        std::fs::write(file, edit(&before)).unwrap();
        let s = self.sources();
        std::fs::write(file, &before).unwrap();
        kinds
            .iter()
            .map(|(name, roots, cut)| s.fingerprint_cut(name, roots, cut).unwrap().hash)
            .collect()
    }
}

/// Every registered kind with its own files and the import edges it does not follow.
type Kinds<'a> = Vec<(String, Vec<&'a str>, Vec<(&'static str, &'static str)>)>;

fn kinds(reg: &Registry) -> Kinds<'_> {
    reg.names()
        .into_iter()
        .map(|n| {
            let k = reg.get(&n).unwrap();
            (n, k.modules().to_vec(), k.not_followed())
        })
        .collect()
}

/// A harmless item, valid at the end of any file.
fn harmless(t: &str) -> String {
    format!("{t}\n#[allow(dead_code)]\nconst AN_EDIT: () = ();\n")
}

/// The cache's promise, on a copy of the real sources with the real kinds and
/// the derivation build.rs runs, against the closure `syn` finds: an edit to
/// any file a kind's code reaches reruns that kind, an edit elsewhere does not.
#[test]
fn every_file_moves_exactly_the_kinds_whose_closure_reaches_it() {
    let copy = Copy::new();
    let reg = repro::stages::registry();
    let kinds = kinds(&reg);
    let graph = syn_graph::syn_graph(&copy.src);
    let base_sources = copy.sources();
    let mut closures = BTreeMap::new();
    let mut base = Vec::new();
    for (name, roots, cut) in &kinds {
        let f = base_sources.fingerprint_cut(name, roots, cut).unwrap();
        // The shipped fingerprint is build.rs's derivation of the same sources.
        assert_eq!(f.hash, reg.fingerprint(name), "{name}");
        assert_eq!(f.modules, reg.modules(name), "{name}");
        let by_syn: Vec<String> = syn_graph::closure(&graph, roots, cut).into_iter().collect();
        assert_eq!(
            f.modules, by_syn,
            "{name}: the key's closure (left) is not syn's (right)"
        );
        closures.insert(name.clone(), by_syn);
        base.push(f.hash);
    }
    // What the import parser once missed: inline child paths of a mod.rs.
    for (name, _, _) in &kinds {
        if closures[name].contains(&"table".to_string()) {
            assert!(
                closures[name].contains(&"table/columns".to_string()),
                "{name}"
            );
        }
    }
    assert!(closures["plot"].contains(&"fit/catalogue".to_string()));
    assert!(closures["join"].contains(&"analysis/pool".to_string()));
    assert!(!closures["simulate"].contains(&"plot/palette".to_string()));
    assert!(
        !closures["tau_alpha"]
            .iter()
            .any(|m| m.starts_with("sim/engine"))
    );
    assert!(closures["tau_alpha"].contains(&"analysis/observables".to_string()));
    // One observable's key covers its own module and what that imports, not
    // the other observables' modules the catalogue names.
    assert!(!closures["tau_alpha"].contains(&"analysis/clusters".to_string()));
    assert!(!closures["clusters"].contains(&"analysis/chi4".to_string()));
    assert!(closures["chi4_peaks"].contains(&"analysis/overlap".to_string()));
    assert!(closures["front"].contains(&"analysis/intruder".to_string()));
    let mut files = Vec::new();
    syn_graph::rust_files(&copy.src, &mut files);
    files.sort();
    assert!(files.len() > 150, "{} files", files.len());
    for file in files {
        let rel = file
            .strip_prefix(&copy.src)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let key = module_key(&rel);
        let after = copy.edited(&file, harmless, &kinds);
        let moved: BTreeSet<&str> = kinds
            .iter()
            .zip(&base)
            .zip(&after)
            .filter(|((_, b), a)| a != b)
            .map(|(((n, _, _), _), _)| n.as_str())
            .collect();
        let reach: BTreeSet<&str> = kinds
            .iter()
            .filter(|(n, _, _)| closures[n].contains(&key))
            .map(|(n, _, _)| n.as_str())
            .collect();
        assert_eq!(
            moved, reach,
            "editing {rel}: kinds whose key moved (left), kinds whose syn closure reaches it (right)"
        );
    }
}

/// An import is what puts a module into a kind's code: simulate's key does
/// not move when the plot palette changes, and moves once the simulator
/// imports it. A crate version in `Cargo.lock` moves the kinds that use the
/// crate only.
#[test]
fn imports_and_crate_versions_move_the_kinds_that_use_them() {
    let copy = Copy::new();
    let kinds: Kinds = vec![
        ("simulate".into(), vec!["stages/simulate"], vec![]),
        ("fit".into(), vec!["stages/fit/kind"], vec![]),
    ];
    let base: Vec<String> = {
        let s = copy.sources();
        kinds
            .iter()
            .map(|(n, r, _)| s.fingerprint(n, r).unwrap().hash)
            .collect()
    };
    let palette = copy.src.join("plot/palette.rs");
    let edit = |t: &str| format!("{t}\npub fn an_edit() {{}}\n");
    assert_eq!(copy.edited(&palette, edit, &kinds)[0], base[0]);
    let engine = copy.src.join("sim/engine/mod.rs");
    let import = |t: &str| format!("{t}\n#[allow(unused_imports)]\nuse crate::plot::viridis;\n");
    assert_ne!(copy.edited(&engine, import, &kinds)[0], base[0]);
    // The fits run rmpfit; the simulator does not.
    let bump = |t: &str| {
        t.replacen(
            "name = \"rmpfit\"\nversion = \"",
            "name = \"rmpfit\"\nversion = \"0.",
            1,
        )
    };
    let after = copy.edited(&copy.lock, bump, &kinds);
    assert_eq!(after[0], base[0], "simulate moved with rmpfit");
    assert_ne!(after[1], base[1], "fit did not move with rmpfit");
    // Another compiler moves every key.
    let mut s = copy.sources();
    s.rustc.push_str(" (another)");
    for ((n, r, _), b) in kinds.iter().zip(&base) {
        assert_ne!(&s.fingerprint(n, r).unwrap().hash, b, "{n}");
    }
}

/// The stages of figure `id` at the ci profile (kind of each) that an edit of
/// `file` (relative to `src/`) makes stale: its kind's key moved, or an input
/// is stale.
fn stale_after(id: &str, file: &str, edit: impl Fn(&str) -> String) -> (usize, Vec<String>) {
    let copy = Copy::new();
    let reg = repro::stages::registry();
    let kinds = kinds(&reg);
    let after = copy.edited(&copy.src.join(file), edit, &kinds);
    let moved: BTreeSet<&str> = kinds
        .iter()
        .zip(&after)
        .filter(|((n, _, _), a)| reg.fingerprint(n) != a.as_str())
        .map(|((n, _, _), _)| n.as_str())
        .collect();
    let cat = Catalogue::load(root()).unwrap();
    let graph = repro::pipeline::graph::plan(&cat, &[id.to_string()], "ci", &reg).unwrap();
    let mut stale = vec![false; graph.nodes.len()];
    // Nodes come in topological order: inputs first.
    for (i, node) in graph.nodes.iter().enumerate() {
        stale[i] = moved.contains(node.kind.as_str()) || node.inputs.iter().any(|&j| stale[j]);
    }
    let kinds_stale = graph
        .nodes
        .iter()
        .zip(&stale)
        .filter(|(_, s)| **s)
        .map(|(n, _)| n.kind.clone())
        .collect();
    (graph.nodes.len(), kinds_stale)
}

/// Editing the framework reruns no simulation (nor anything else): the harness
/// is in no key.
#[test]
fn editing_the_framework_leaves_every_stage_of_fig4_cached() {
    for file in [
        "pipeline/registry.rs",
        "pipeline/progress.rs",
        "pipeline/cost.rs",
        // The simulations' cost model, registered beside the kind: a
        // recalibration changes no output.
        "stages/simulate_cost.rs",
    ] {
        let (nodes, stale) = stale_after("fig4", file, harmless);
        assert!(nodes > 50, "{nodes} stages");
        assert_eq!(stale, Vec::<String>::new(), "editing {file}");
    }
}

/// Editing one observable's code reruns the stages of the observables that
/// run it, not the others the catalogue names: the clusters' module leaves
/// fig4 (tau_alpha, chi4) cached and makes fig12's cluster stages stale, with
/// what reads them, and no simulation.
#[test]
fn editing_one_observable_reruns_its_stages_only() {
    let (nodes, stale) = stale_after("fig4", "analysis/clusters.rs", harmless);
    assert!(nodes > 50, "{nodes} stages");
    assert_eq!(
        stale,
        Vec::<String>::new(),
        "fig4 after an edit of the clusters"
    );
    let (_, stale) = stale_after("fig12", "analysis/clusters.rs", harmless);
    assert!(stale.iter().any(|k| k == "cluster_sizes"), "{stale:?}");
    assert!(
        !stale.iter().any(|k| k == "simulate" || k == "tau_alpha"),
        "{stale:?}"
    );
    // The catalogue itself is in every observable's key.
    let (_, stale) = stale_after("fig4", "analysis/observables.rs", harmless);
    assert!(stale.iter().any(|k| k == "tau_alpha"), "{stale:?}");
}

/// What keeps the cut edges honest: every member module an observable's line
/// in the catalogue names (its types and functions, and those of the helpers
/// it calls) is one of its `modules`, which its key follows. Read from the
/// catalogue's source, a second way from the code itself.
#[test]
fn every_observable_names_the_modules_its_line_runs() {
    use repro::analysis::observables::{MEMBERS, OBSERVABLES};
    let text = std::fs::read_to_string(root().join("src/analysis/observables.rs")).unwrap();
    let (code, _) = repro::pipeline::fingerprint::non_test_code(&text);
    let start = code.find("pub static OBSERVABLES").unwrap();
    let end = start + code[start..].find("\n];").unwrap();
    let names: Vec<&str> = MEMBERS
        .iter()
        .map(|m| m.strip_prefix("analysis/").unwrap())
        .collect();
    let named = |s: &str| -> BTreeSet<String> {
        names
            .iter()
            .filter(|n| {
                s.match_indices(&format!("{n}::")).any(|(i, _)| {
                    !s[..i]
                        .chars()
                        .next_back()
                        .is_some_and(|c| c.is_alphanumeric() || c == '_')
                })
            })
            .map(|n| format!("analysis/{n}"))
            .collect()
    };
    // The helpers outside the list: each top-level `fn`, up to the next.
    let outside = format!("{}{}", &code[..start], &code[end..]);
    let mut helpers: Vec<(String, String)> = Vec::new();
    for part in outside.split("\nfn ").skip(1) {
        let name: String = part
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        helpers.push((name, part.to_string()));
    }
    let calls = |s: &str, h: &str| s.contains(&format!("{h}(")) || s.contains(&format!("{h}::<"));
    let reach = |line: &str| -> BTreeSet<String> {
        let mut seen: BTreeSet<&str> = BTreeSet::new();
        let mut todo = vec![line.to_string()];
        let mut out = BTreeSet::new();
        while let Some(s) = todo.pop() {
            out.extend(named(&s));
            for (h, body) in &helpers {
                if calls(&s, h) && seen.insert(h) {
                    todo.push(body.clone());
                }
            }
        }
        out
    };
    let lines: Vec<&str> = code[start..end]
        .split("\n    Observable {")
        .skip(1)
        .collect();
    assert_eq!(lines.len(), OBSERVABLES.len());
    for (line, obs) in lines.iter().zip(OBSERVABLES) {
        assert!(line.contains(&format!("name: \"{}\"", obs.name)), "{line}");
        let own: BTreeSet<String> = obs.modules.iter().map(|m| m.to_string()).collect();
        assert!(
            own.iter().all(|m| MEMBERS.contains(&m.as_str())),
            "{}: {own:?}",
            obs.name
        );
        let runs = reach(line);
        assert!(
            !runs.is_empty(),
            "{}: its line names no member module",
            obs.name
        );
        assert!(
            runs.is_subset(&own),
            "{}: its line runs {runs:?}, its `modules` are {own:?}",
            obs.name
        );
    }
    // A member the catalogue imports but `MEMBERS` leaves out would be in
    // every key: safe, but the list says what is cut.
    let imports = code
        .lines()
        .find(|l| l.starts_with("use super::{"))
        .unwrap();
    for n in imports
        .trim_start_matches("use super::{")
        .trim_end_matches("};")
        .split(", ")
    {
        if !["lags", "pool"].contains(&n) {
            assert!(
                MEMBERS.contains(&format!("analysis/{n}").as_str()),
                "{n} is no member"
            );
        }
    }
}

/// Editing the Parquet column helpers reruns the table stage of fig12, which
/// writes through them (so do the simulations, which write their
/// trajectories through them too).
#[test]
fn editing_the_table_columns_makes_the_table_stage_of_fig12_stale() {
    let (_, stale) = stale_after("fig12", "table/columns.rs", harmless);
    assert!(stale.iter().any(|k| k == "table"), "{stale:?}");
    assert!(stale.iter().any(|k| k == "simulate"), "{stale:?}");
}

/// A plot is told the `where` of its figure's fits upstream (the build's
/// `windows`), so that fig25's legend prints each fit's q window from the
/// fit itself.
#[test]
fn a_plot_knows_the_windows_of_the_fits_it_draws() {
    let reg = repro::stages::registry();
    let cat = Catalogue::load(root()).unwrap();
    let graph = repro::pipeline::graph::plan(&cat, &["fig25".to_string()], "ci", &reg).unwrap();
    let node = |kind: &str, stage: &str| {
        graph
            .nodes
            .iter()
            .find(|n| n.kind == kind && n.ids.iter().any(|id| id.stage == stage))
            .unwrap_or_else(|| panic!("no {kind} stage {stage} in fig25"))
    };
    let plot = node("plot", "figure");
    for fit in ["oz_04", "oz_06", "oz_10"] {
        let want = &node("fit", fit).params["where"]["q"]["max"];
        assert!(want.is_number(), "{fit}: {want}");
        assert_eq!(
            &plot.params["build"]["windows"][fit]["where_q_max"], want,
            "{fit}"
        );
    }
}
