//! The content-addressed store: artifacts, cache entries, locks.
//!
//! Layout under the store directory:
//!
//! ```text
//! VERSION                 cache-format version; another version is refused
//! store.lock              shared by runs, exclusive for `repro gc`
//! objects/ab/<blake3>     artifact files, named by the hash of their bytes
//! entries/ab/<key>.json   one cache entry per stage key
//! labels/<hash>.json      latest key per stage label (for `status`/`why`)
//! locks/<key>.lock        held while a process computes that stage
//! ```
//!
//! Every file is written to a temporary name and renamed, objects before the entry
//! that names them, so a run killed at any point leaves only complete files (and
//! temporary `.tmp*` files that `gc` removes). Locks are OS file locks
//! (`File::lock`): the kernel releases them when a process dies, so a killed run
//! never leaves a stale lock behind.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::table::write_atomic;

/// Version of the store layout and entry format.
pub const STORE_VERSION: &str = "repro-store-v1";

/// One cached stage result.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Entry {
    pub key: String,
    pub kind: String,
    pub label: String,
    pub params: Value,
    pub fingerprint: String,
    /// (input label, input digest), in input order.
    pub inputs: Vec<(String, String)>,
    /// Extension -> blake3 of the file.
    pub files: BTreeMap<String, String>,
    /// Hash of all files: what dependents' keys are built from.
    pub digest: String,
    pub seed: u64,
    pub wall_s: f64,
    pub cpu_s: Option<f64>,
    pub log: Vec<String>,
}

/// An open store. Holding it holds a shared lock on the store (gc holds it
/// exclusively), released on drop.
pub struct Store {
    pub dir: PathBuf,
    _lock: File,
}

fn shard(dir: &Path, sub: &str, name: &str, ext: &str) -> PathBuf {
    dir.join(sub).join(&name[..2]).join(format!("{name}{ext}"))
}

impl Store {
    /// Open (creating if needed) the store at `dir` for a run.
    pub fn open(dir: &Path) -> Result<Store> {
        Self::open_with(dir, false)
    }

    /// Open the store exclusively (for gc): fails if another `repro` uses it.
    pub fn open_exclusive(dir: &Path) -> Result<Store> {
        Self::open_with(dir, true)
    }

    fn open_with(dir: &Path, exclusive: bool) -> Result<Store> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating the store directory {}", dir.display()))?;
        let vfile = dir.join("VERSION");
        match std::fs::read_to_string(&vfile) {
            Ok(v) if v.trim() == STORE_VERSION => {}
            Ok(v) => bail!(
                "the store {} has format '{}', but this repro uses '{STORE_VERSION}'; \
                 remove that directory to start a fresh cache (or use the matching repro version)",
                dir.display(),
                v.trim()
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                write_atomic(&vfile, format!("{STORE_VERSION}\n").as_bytes())?;
            }
            Err(e) => bail!("cannot read {}: {e}", vfile.display()),
        }
        for sub in ["objects", "entries", "labels", "locks"] {
            std::fs::create_dir_all(dir.join(sub))?;
        }
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(dir.join("store.lock"))?;
        if exclusive {
            match lock.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => bail!(
                    "another repro process is using the store {}; run gc when it has finished",
                    dir.display()
                ),
                Err(std::fs::TryLockError::Error(e)) => return Err(e.into()),
            }
        } else {
            lock.lock_shared()?;
        }
        Ok(Store {
            dir: dir.to_path_buf(),
            _lock: lock,
        })
    }

    pub fn object_path(&self, hash: &str) -> PathBuf {
        shard(&self.dir, "objects", hash, "")
    }

    fn entry_path(&self, key: &str) -> PathBuf {
        shard(&self.dir, "entries", key, ".json")
    }

    fn label_path(&self, label: &str) -> PathBuf {
        let h = blake3::hash(label.as_bytes()).to_hex();
        self.dir.join("labels").join(format!("{h}.json"))
    }

    /// Store bytes under their hash; returns the hash.
    pub fn put_object(&self, bytes: &[u8]) -> Result<String> {
        let hash = blake3::hash(bytes).to_hex().to_string();
        let path = self.object_path(&hash);
        if !path.exists() {
            write_atomic(&path, bytes)?;
        }
        Ok(hash)
    }

    /// The entry for `key`, if it exists and all its files are present.
    pub fn lookup(&self, key: &str) -> Option<Entry> {
        let text = std::fs::read(self.entry_path(key)).ok()?;
        let e: Entry = serde_json::from_slice(&text).ok()?;
        e.files
            .values()
            .all(|h| self.object_path(h).exists())
            .then_some(e)
    }

    /// Record an entry (after its objects) and point its label at it.
    pub fn put_entry(&self, e: &Entry) -> Result<()> {
        write_atomic(&self.entry_path(&e.key), &serde_json::to_vec_pretty(e)?)?;
        self.set_label(&e.label, &e.key)
    }

    /// Point `label` at `key` (the latest result of that stage).
    pub fn set_label(&self, label: &str, key: &str) -> Result<()> {
        let path = self.label_path(label);
        let body = serde_json::json!({"label": label, "key": key});
        if std::fs::read(&path)
            .ok()
            .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
            == Some(body.clone())
        {
            return Ok(());
        }
        write_atomic(&path, &serde_json::to_vec(&body)?)
    }

    /// The latest entry recorded for `label`.
    pub fn latest(&self, label: &str) -> Option<Entry> {
        let b = std::fs::read(self.label_path(label)).ok()?;
        let v: Value = serde_json::from_slice(&b).ok()?;
        let key = v.get("key")?.as_str()?;
        let text = std::fs::read(self.entry_path(key)).ok()?;
        serde_json::from_slice(&text).ok()
    }

    /// Block until this process holds the lock of stage `key`.
    pub fn lock_key(&self, key: &str) -> Result<File> {
        let f = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(self.dir.join("locks").join(format!("{key}.lock")))?;
        f.lock()?;
        Ok(f)
    }

    /// Every entry in the store.
    pub fn entries(&self) -> Vec<Entry> {
        walk_files(&self.dir.join("entries"))
            .into_iter()
            .filter(|p| p.extension().is_some_and(|x| x == "json"))
            .filter_map(|p| serde_json::from_slice(&std::fs::read(p).ok()?).ok())
            .collect()
    }

    /// Remove every entry whose key is not in `keep`, every object no kept entry
    /// names, leftover temporary files and lock files. Needs [`Store::open_exclusive`].
    /// Returns (entries, objects, bytes) freed.
    pub fn gc(&self, keep: &std::collections::HashSet<String>, dry_run: bool) -> Result<GcReport> {
        let mut report = GcReport::default();
        let mut live_objects = std::collections::HashSet::new();
        for p in walk_files(&self.dir.join("entries")) {
            let entry: Option<Entry> = std::fs::read(&p)
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok());
            match entry {
                Some(e) if keep.contains(&e.key) => live_objects.extend(e.files.values().cloned()),
                _ => {
                    report.entries += 1;
                    report.bytes += p.metadata().map(|m| m.len()).unwrap_or(0);
                    if !dry_run {
                        std::fs::remove_file(&p)?;
                    }
                }
            }
        }
        for p in walk_files(&self.dir.join("objects")) {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if !live_objects.contains(name) {
                report.objects += 1;
                report.bytes += p.metadata().map(|m| m.len()).unwrap_or(0);
                if !dry_run {
                    std::fs::remove_file(&p)?;
                }
            }
        }
        if !dry_run {
            for p in walk_files(&self.dir.join("locks")) {
                std::fs::remove_file(p)?;
            }
            for p in walk_files(&self.dir.join("labels")) {
                let stale = std::fs::read(&p)
                    .ok()
                    .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
                    .and_then(|v| v.get("key")?.as_str().map(|k| !keep.contains(k)))
                    .unwrap_or(true);
                if stale {
                    std::fs::remove_file(p)?;
                }
            }
        }
        Ok(report)
    }
}

/// What gc freed (or would free).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct GcReport {
    pub entries: usize,
    pub objects: usize,
    pub bytes: u64,
}

fn walk_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(key: &str, files: BTreeMap<String, String>) -> Entry {
        Entry {
            key: key.into(),
            kind: "k".into(),
            label: "l".into(),
            params: serde_json::json!({}),
            fingerprint: "f".into(),
            inputs: vec![],
            files,
            digest: "d".into(),
            seed: 0,
            wall_s: 0.0,
            cpu_s: None,
            log: vec![],
        }
    }

    #[test]
    fn objects_are_content_addressed_and_entries_need_their_objects() {
        let d = tempfile::tempdir().unwrap();
        let s = Store::open(d.path()).unwrap();
        let h = s.put_object(b"abc").unwrap();
        assert_eq!(h, blake3::hash(b"abc").to_hex().as_str());
        assert_eq!(s.put_object(b"abc").unwrap(), h);
        let key = "ab".repeat(32);
        let e = entry(&key, [("parquet".to_string(), h.clone())].into());
        s.put_entry(&e).unwrap();
        assert_eq!(s.lookup(&key), Some(e.clone()));
        assert_eq!(s.latest("l"), Some(e));
        // An entry whose artifact vanished is not a cache hit.
        std::fs::remove_file(s.object_path(&h)).unwrap();
        assert_eq!(s.lookup(&key), None);
    }

    #[test]
    fn gc_cannot_start_while_a_run_holds_the_store() {
        let d = tempfile::tempdir().unwrap();
        let _run = Store::open(d.path()).unwrap();
        let e = Store::open_exclusive(d.path()).err().unwrap();
        assert!(
            format!("{e:#}").contains("another repro process is using the store"),
            "{e:#}"
        );
    }
}
