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
//! quarantine/<blake3>[.N] damaged objects, moved aside (never deleted by repro)
//! checkpoints/<key>/      a running stage's checkpoints and progress (not part of
//!                         any hash; removed when the stage is done, see
//!                         super::checkpoints)
//! ```
//!
//! Every object read from the store is checked against its name: a cache hit is a
//! hit only if each of its files still hashes to the blake3 it was stored under
//! ([`Store::find`]). A file that does not is *damaged*: it is moved to
//! `quarantine/` and the stage is recomputed; `repro verify` checks the whole store.
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

use super::checkpoints::Checkpoints;
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
    /// The stage's side record: measurements of how it ran (CPU seconds, speeds,
    /// memory) that are not a pure function of its inputs, hence kept out of
    /// `digest` so that a rerun with identical files is cut off early.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<Value>,
}

/// What a cache lookup found.
#[derive(Debug, Clone, PartialEq)]
pub enum Found {
    /// Every file of the entry is present and hashes to its recorded blake3.
    Hit(Entry),
    /// No entry, an unreadable entry, or a file removed (gc, an interrupted run).
    Miss,
    /// A file of the entry is damaged (or was quarantined): one line per file.
    Damaged { entry: Entry, problems: Vec<Damage> },
}

/// One damaged object of a cache entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Damage {
    pub hash: String,
    /// Where the object is (or was, if already quarantined).
    pub path: PathBuf,
    /// Label of the stage it belongs to.
    pub label: String,
    /// What is wrong with it.
    pub what: String,
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "damaged artifact {} of stage {}: {}",
            self.path.display(),
            self.label,
            self.what
        )
    }
}

/// Blake3 of a file's bytes, and its size.
pub fn hash_file(path: &Path) -> std::io::Result<(String, u64)> {
    let mut h = blake3::Hasher::new();
    h.update_reader(File::open(path)?)?;
    Ok((h.finalize().to_hex().to_string(), h.count()))
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
        for sub in ["objects", "entries", "labels", "locks", "quarantine"] {
            std::fs::create_dir_all(dir.join(sub))?;
        }
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(dir.join("store.lock"))?;
        if exclusive {
            // A process forked by this one (git, a plotter) holds a copy of a
            // just-dropped store's lock until it calls exec: wait that out
            // (milliseconds) before calling it another repro's.
            let mut waited = std::time::Duration::ZERO;
            loop {
                match lock.try_lock() {
                    Ok(()) => break,
                    Err(std::fs::TryLockError::WouldBlock)
                        if waited < std::time::Duration::from_secs(2) =>
                    {
                        let step = std::time::Duration::from_millis(20);
                        std::thread::sleep(step);
                        waited += step;
                    }
                    Err(std::fs::TryLockError::WouldBlock) => bail!(
                        "another repro process is using the store {}; run gc when it has finished",
                        dir.display()
                    ),
                    Err(std::fs::TryLockError::Error(e)) => return Err(e.into()),
                }
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

    /// The checkpoint directory of the stage with key `key`.
    pub fn checkpoints(&self, key: &str) -> Checkpoints {
        Checkpoints::new(
            self.dir.join("checkpoints").join(key),
            self.dir.join("quarantine"),
        )
    }

    /// The checkpoint directories of every stage that has any: (key, directory).
    pub fn all_checkpoints(&self) -> Vec<(String, Checkpoints)> {
        let mut v: Vec<(String, Checkpoints)> = std::fs::read_dir(self.dir.join("checkpoints"))
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let key = e.file_name().into_string().ok()?;
                let c = self.checkpoints(&key);
                Some((key, c))
            })
            .collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
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

    /// The entry for `key` if it exists and every file of it is intact.
    pub fn lookup(&self, key: &str) -> Option<Entry> {
        match self.find(key) {
            Found::Hit(e) => Some(e),
            _ => None,
        }
    }

    /// Look `key` up and check every file of its entry against its hash
    /// (read-only: see [`Store::quarantine`] for what a run does with damage).
    pub fn find(&self, key: &str) -> Found {
        let Some(e) = std::fs::read(self.entry_path(key))
            .ok()
            .and_then(|t| serde_json::from_slice::<Entry>(&t).ok())
        else {
            return Found::Miss;
        };
        let mut problems = Vec::new();
        for hash in e.files.values() {
            let path = self.object_path(hash);
            let what = match hash_file(&path) {
                Ok((h, _)) if h == *hash => continue,
                Ok((h, size)) => {
                    format!("its {size} bytes hash to {h}, not to the recorded blake3 {hash}")
                }
                Err(err) if err.kind() == std::io::ErrorKind::NotFound => {
                    if self.quarantined(hash).is_empty() {
                        // Removed by gc or never written: an ordinary miss.
                        return Found::Miss;
                    }
                    format!(
                        "it was found damaged earlier and moved to {}",
                        self.dir.join("quarantine").display()
                    )
                }
                Err(err) => format!("cannot be read: {err}"),
            };
            problems.push(Damage {
                hash: hash.clone(),
                path,
                label: e.label.clone(),
                what,
            });
        }
        if problems.is_empty() {
            Found::Hit(e)
        } else {
            Found::Damaged { entry: e, problems }
        }
    }

    /// Quarantined copies of object `hash`.
    fn quarantined(&self, hash: &str) -> Vec<PathBuf> {
        let Ok(rd) = std::fs::read_dir(self.dir.join("quarantine")) else {
            return Vec::new();
        };
        rd.flatten()
            .map(|e| e.path())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with(hash))
            })
            .collect()
    }

    /// Move a damaged object aside to `quarantine/` (never deleted), so that the
    /// next write of that hash stores good bytes. Returns where it went (`None` if
    /// it was already gone).
    pub fn quarantine(&self, hash: &str) -> Result<Option<PathBuf>> {
        let from = self.object_path(hash);
        if !from.exists() {
            return Ok(None);
        }
        let dir = self.dir.join("quarantine");
        std::fs::create_dir_all(&dir)?;
        let mut to = dir.join(hash);
        let mut k = 1;
        while to.exists() {
            to = dir.join(format!("{hash}.{k}"));
            k += 1;
        }
        std::fs::rename(&from, &to).with_context(|| {
            format!("moving the damaged {} to {}", from.display(), to.display())
        })?;
        Ok(Some(to))
    }

    /// Read object `hash` of stage `label`, checking its bytes against the hash.
    pub fn read_verified(&self, hash: &str, label: &str) -> Result<Vec<u8>> {
        let path = self.object_path(hash);
        let bytes = std::fs::read(&path)
            .with_context(|| format!("reading {} of {label}", path.display()))?;
        let h = blake3::hash(&bytes).to_hex();
        if h.as_str() != hash {
            bail!(
                "{}",
                Damage {
                    hash: hash.to_string(),
                    path,
                    label: label.to_string(),
                    what: format!(
                        "its {} bytes hash to {h}, not to the recorded blake3 {hash}",
                        bytes.len()
                    ),
                }
            );
        }
        Ok(bytes)
    }

    /// Check every object of the store against its name; quarantine the damaged
    /// ones. Each damage names the stages (entries) that use the object.
    pub fn verify(&self) -> Result<VerifyReport> {
        let mut users: std::collections::HashMap<String, Vec<String>> = Default::default();
        for e in self.entries() {
            for h in e.files.values() {
                users.entry(h.clone()).or_default().push(e.label.clone());
            }
        }
        let mut report = VerifyReport::default();
        for p in walk_files(&self.dir.join("objects")) {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if name.starts_with(".tmp") {
                continue;
            }
            report.objects += 1;
            let what = match hash_file(&p) {
                Ok((h, size)) => {
                    report.bytes += size;
                    if h == name {
                        continue;
                    }
                    format!("its {size} bytes hash to {h}")
                }
                Err(e) => format!("cannot be read: {e}"),
            };
            let mut labels = users.get(name).cloned().unwrap_or_default();
            labels.sort();
            labels.dedup();
            let label = if labels.is_empty() {
                "(no entry)".to_string()
            } else {
                labels.join(", ")
            };
            let moved = self.quarantine(name)?;
            report.damaged.push(format!(
                "{}{}",
                Damage {
                    hash: name.to_string(),
                    path: p.clone(),
                    label,
                    what,
                },
                moved
                    .map(|m| format!("; moved to {}", m.display()))
                    .unwrap_or_default()
            ));
        }
        Ok(report)
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

    /// Bytes of the files of `e` as stored (a file gone counts nothing).
    pub fn entry_bytes(&self, e: &Entry) -> u64 {
        e.files
            .values()
            .filter_map(|h| std::fs::metadata(self.object_path(h)).ok())
            .map(|m| m.len())
            .sum()
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
        // Checkpoints of stages that are done (their removal was cut short).
        for (key, c) in self.all_checkpoints() {
            if self.entry_path(&key).exists() {
                report.checkpoints += 1;
                if !dry_run {
                    c.remove()?;
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

/// What `repro verify` checked and found.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct VerifyReport {
    pub objects: usize,
    pub bytes: u64,
    /// One line per damaged object (path, stages, what, where it was moved).
    pub damaged: Vec<String>,
}

/// What gc freed (or would free).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct GcReport {
    pub entries: usize,
    pub objects: usize,
    pub bytes: u64,
    /// Checkpoint directories of stages that are done.
    pub checkpoints: usize,
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
            side: None,
        }
    }

    /// gc removes the checkpoints of a stage that is done (its removal was
    /// cut short) and keeps those of one still to finish.
    #[test]
    fn gc_removes_the_checkpoints_of_finished_stages_only() {
        let d = tempfile::tempdir().unwrap();
        let s = Store::open_exclusive(d.path()).unwrap();
        let (done, running) = ("ab".repeat(32), "cd".repeat(32));
        s.put_entry(&entry(&done, BTreeMap::new())).unwrap();
        for key in [&done, &running] {
            s.checkpoints(key).save(8.0, b"state").unwrap();
        }
        let keep = std::collections::HashSet::from([done.clone()]);
        assert_eq!(s.gc(&keep, true).unwrap().checkpoints, 1);
        assert_eq!(s.all_checkpoints().len(), 2, "a dry run removes nothing");
        assert_eq!(s.gc(&keep, false).unwrap().checkpoints, 1);
        let left: Vec<String> = s.all_checkpoints().into_iter().map(|c| c.0).collect();
        assert_eq!(left, [running]);
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
