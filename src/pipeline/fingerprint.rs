//! Source fingerprints: a blake3 hash of the source files of every module folder and
//! `.rs` file under `src/`, keyed like "sim", "stages/simulate" or "lib". build.rs
//! compiles this same file to write them into the binary; tests call it on an
//! edited copy of the sources to check what an edit reruns.
//!
//! Only `std` and `blake3` here: build.rs includes this file with `#[path]`.

use std::fs;
use std::path::{Path, PathBuf};

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn hash_files(src: &Path, files: &mut [PathBuf]) -> String {
    files.sort();
    let mut h = blake3::Hasher::new();
    for f in files.iter() {
        // Hash the path relative to src/ too, so a renamed file changes the fingerprint.
        h.update(f.strip_prefix(src).unwrap().to_string_lossy().as_bytes());
        h.update(&[0]);
        h.update(&fs::read(f).expect("source file readable"));
        h.update(&[0]);
    }
    h.finalize().to_hex().to_string()
}

/// Every folder and every `.rs` file below `dir` gets an entry, keyed by its path
/// relative to src/ without the extension ("sim", "stages/simulate", "lib").
fn walk(src: &Path, dir: &Path, entries: &mut Vec<(String, String)>) {
    let mut paths: Vec<PathBuf> = fs::read_dir(dir)
        .expect("source folder readable")
        .flatten()
        .map(|e| e.path())
        .collect();
    paths.sort();
    for p in paths {
        let rel = p.strip_prefix(src).unwrap().with_extension("");
        let key = rel.to_string_lossy().replace('\\', "/");
        if p.is_dir() {
            let mut files = Vec::new();
            collect(&p, &mut files);
            entries.push((key, hash_files(src, &mut files)));
            walk(src, &p, entries);
        } else if p.extension().is_some_and(|x| x == "rs") {
            entries.push((key, hash_files(src, &mut [p.clone()])));
        }
    }
}

/// (module key, blake3 hex of its sources) for every folder and `.rs` file under
/// `src`, in path order.
pub fn module_fingerprints(src: &Path) -> Vec<(String, String)> {
    let mut entries = Vec::new();
    walk(src, src, &mut entries);
    entries
}
