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
//!
//! Each kind names exactly the source modules it depends on, so editing a plot
//! adapter never reruns a simulation.

pub mod analyse;
pub mod compare;
pub mod compression;
pub mod fit;
pub mod join;
pub mod joint_fit;
pub mod plot;
pub mod run_summary;
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
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    use crate::pipeline::fingerprint::module_fingerprints;
    use crate::pipeline::registry::code_fingerprint_in;

    /// Every `.rs` file under `dir`, as (key relative to `root` without extension, path).
    fn files(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf)>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                files(root, &p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let key = p.strip_prefix(root).unwrap().with_extension("");
                out.push((key.to_string_lossy().replace('\\', "/"), p));
            }
        }
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

    fn covers(module: &str, key: &str) -> bool {
        key == module || key.starts_with(&format!("{module}/"))
    }

    /// A kind's fingerprint computed as build.rs would from the tree at `src`.
    fn fingerprint(src: &Path, name: &str, modules: &[&str]) -> String {
        let table: BTreeMap<String, String> = module_fingerprints(src).into_iter().collect();
        code_fingerprint_in(name, modules, |m| table.get(m).map(|s| s.as_str())).unwrap()
    }

    /// Append a comment to `file`, compute, restore.
    fn edited(src: &Path, file: &Path, name: &str, modules: &[&str]) -> String {
        let before = std::fs::read(file).unwrap();
        let mut after = before.clone();
        after.extend_from_slice(b"\n// an edit\n");
        std::fs::write(file, &after).unwrap();
        let fp = fingerprint(src, name, modules);
        std::fs::write(file, &before).unwrap();
        fp
    }

    /// The cache's promise, on a copy of the real sources with the real kinds: an
    /// edit to any file of a kind's modules reruns that kind, an edit to a file
    /// outside them does not.
    #[test]
    fn each_kind_reruns_on_its_own_sources_only() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("src");
        copy_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &src);
        let mut all = Vec::new();
        files(&src, &src, &mut all);
        all.sort();
        let reg = super::registry();
        for name in reg.names() {
            let kind = reg.get(&name).unwrap();
            let modules = kind.modules();
            let base = fingerprint(&src, &name, modules);
            // The shipped table agrees with build.rs's hashing of the same sources.
            assert_eq!(base, reg.fingerprint(&name), "{name}");
            for m in modules {
                let (_, file) = all
                    .iter()
                    .find(|(k, _)| covers(m, k))
                    .unwrap_or_else(|| panic!("{name}: module {m} has no source file"));
                assert_ne!(
                    edited(&src, file, &name, modules),
                    base,
                    "{name}: editing {} (module {m}) left the fingerprint unchanged",
                    file.display()
                );
            }
            let (_, other) = all
                .iter()
                .find(|(k, _)| !modules.iter().any(|m| covers(m, k)))
                .unwrap();
            assert_eq!(
                edited(&src, other, &name, modules),
                base,
                "{name}: editing unrelated {} changed the fingerprint",
                other.display()
            );
        }
    }
}
