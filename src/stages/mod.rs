//! The real stage kinds: thin adapters from the pipeline framework to the library.
//!
//! - [`simulate`]: one seeded simulation (one replica at one packing fraction) with
//!   run lengths set in units of an estimated tau_alpha(phi); [`simulate_cost`]
//!   what one is planned to cost.
//! - [`analyse`]: every observable of `src/analysis` (Q(t), tau_alpha, aging, chi4,
//!   S4, MSD, van Hove, g_ab, clusters, intruder, ...) as a stage kind of its name,
//!   pooling the gathered replicas.
//! - [`fit`]: fits of a table column (power law, VFT, ...) and the finite-size
//!   scaling collapse.
//! - [`join`]: two tables joined by key columns, with derived columns.
//! - [`compare`]: fitted numbers against the paper's values, with a verdict.
//! - [`plot`]: a figure drawn from tables.
//! - [`synthetic`]: synthetic data with known truth (the fits' stability map).
//! - [`compression`]: how far the initial compression gets (stability maps).
//! - [`run_summary`]: a simulation's own measurements as a row (stability maps).
//! - [`script`]: one's own analysis or plot as a command in any language.
//!
//! Each kind names its own file (`file!()`); its code fingerprint hashes every
//! module that file reaches through the import graph, and the lock entries of
//! the crates they use (`pipeline::fingerprint`), so editing a plot adapter
//! never reruns a simulation and no module a kind runs is left out of its key.
//! The statistics of the fits live in the library ([`crate::fit::uncertainty`]);
//! these files read parameters and tables, call it and write tables.

pub mod analyse;
pub mod compare;
pub mod compression;
pub mod fit;
pub mod join;
pub mod joint_fit;
pub mod plot;
pub mod run_summary;
pub mod script;
pub mod simulate;
pub mod simulate_cost;
pub mod synthetic;
pub mod tables;
#[cfg(test)]
pub(crate) mod test_support;

use crate::pipeline::Registry;

/// The registry the binary runs with: the framework's kind (`table`) and every
/// kind of the library.
pub fn registry() -> Registry {
    let mut r = Registry::framework();
    register(&mut r);
    r
}

/// Register every real stage kind.
pub fn register(r: &mut Registry) {
    r.register(simulate::Simulate);
    analyse::register(r);
    r.register(fit::Fit);
    r.register(fit::Collapse);
    r.register(join::Join);
    r.register(joint_fit::JointFit);
    r.register(compare::Compare);
    r.register(plot::Plot);
    r.register(synthetic::SyntheticCoverage);
    r.register(synthetic::SyntheticDivergence);
    r.register(run_summary::RunSummary);
    r.register(compression::Compression);
    r.register(script::Script);
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    use crate::pipeline::fingerprint::Sources;

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

    /// The file of module `key` under `src`.
    fn file_of(src: &Path, key: &str) -> PathBuf {
        if key == "lib" {
            return src.join("lib.rs");
        }
        let file = src.join(format!("{key}.rs"));
        if file.exists() {
            file
        } else {
            src.join(key).join("mod.rs")
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
            let root = Path::new(env!("CARGO_MANIFEST_DIR"));
            let src = dir.path().join("src");
            copy_tree(&root.join("src"), &src);
            let lock = dir.path().join("Cargo.lock");
            std::fs::copy(root.join("Cargo.lock"), &lock).unwrap();
            // What `include_bytes!` of the sources reaches.
            copy_tree(&root.join("assets"), &dir.path().join("assets"));
            Copy {
                _dir: dir,
                src,
                lock,
            }
        }

        fn sources(&self) -> Sources {
            Sources::read(&self.src, &self.lock)
        }

        /// Every kind's fingerprint with `file` edited as `edit` says, then restored.
        fn edited(
            &self,
            file: &Path,
            edit: impl Fn(&str) -> String,
            kinds: &[(String, Vec<&str>)],
        ) -> Vec<String> {
            let before = std::fs::read_to_string(file).unwrap();
            std::fs::write(file, edit(&before)).unwrap();
            let s = self.sources();
            std::fs::write(file, &before).unwrap();
            kinds
                .iter()
                .map(|(name, roots)| s.fingerprint(name, roots).unwrap().hash)
                .collect()
        }
    }

    /// The cache's promise, on a copy of the real sources with the real kinds
    /// and the derivation build.rs runs: an edit to any module of a kind's
    /// import closure reruns that kind, an edit to a module outside it does not.
    #[test]
    fn each_kind_reruns_on_the_code_it_runs_only() {
        let copy = Copy::new();
        let reg = super::registry();
        let base_sources = copy.sources();
        let kinds: Vec<(String, Vec<&str>)> = reg
            .names()
            .into_iter()
            .map(|n| {
                let roots = reg.get(&n).unwrap().modules().to_vec();
                (n, roots)
            })
            .collect();
        let mut closures = BTreeMap::new();
        let mut base = Vec::new();
        for (name, roots) in &kinds {
            let f = base_sources.fingerprint(name, roots).unwrap();
            // The shipped fingerprint is build.rs's derivation of the same sources.
            assert_eq!(f.hash, reg.fingerprint(name), "{name}");
            assert_eq!(f.modules, reg.modules(name), "{name}");
            closures.insert(name.clone(), f.modules.clone());
            base.push(f.hash);
        }
        // What the hand-kept lists missed: the plot kind draws guide curves
        // of the fit catalogue, the join kind pools replicas.
        assert!(closures["plot"].contains(&"fit/catalogue".to_string()));
        assert!(closures["join"].contains(&"analysis/pool".to_string()));
        assert!(!closures["simulate"].contains(&"plot/palette".to_string()));
        for key in base_sources.modules.keys() {
            let file = file_of(&copy.src, key);
            let after = copy.edited(&file, |t| format!("{t}\n// an edit\n"), &kinds);
            for (((name, _), b), a) in kinds.iter().zip(&base).zip(&after) {
                let inside = closures[name].contains(key);
                assert_eq!(
                    a != b,
                    inside,
                    "{name}: editing {} ({}in its closure) {} its fingerprint",
                    file.display(),
                    if inside { "" } else { "not " },
                    if a != b { "changed" } else { "left" }
                );
            }
        }
    }

    /// An import is what puts a module into a kind's code: simulate's key does
    /// not move when the plot palette changes, and moves once the simulator
    /// imports it. A crate version in `Cargo.lock` moves the kinds that use
    /// the crate only.
    #[test]
    fn imports_and_crate_versions_move_the_kinds_that_use_them() {
        let copy = Copy::new();
        let kinds: Vec<(String, Vec<&str>)> = vec![
            ("simulate".into(), vec!["stages/simulate"]),
            ("fit".into(), vec!["stages/fit/kind"]),
        ];
        let base: Vec<String> = {
            let s = copy.sources();
            kinds
                .iter()
                .map(|(n, r)| s.fingerprint(n, r).unwrap().hash)
                .collect()
        };
        let palette = copy.src.join("plot/palette.rs");
        let edit = |t: &str| format!("{t}\npub fn an_edit() {{}}\n");
        assert_eq!(copy.edited(&palette, edit, &kinds)[0], base[0]);
        let engine = copy.src.join("sim/engine/mod.rs");
        let import =
            |t: &str| format!("{t}\n#[allow(unused_imports)]\nuse crate::plot::viridis;\n");
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
    }
}
