//! Code fingerprints derived from the sources: the import graph of `src/` (file
//! to file), each file's blake3, the external crates each file names and their
//! `Cargo.lock` entries. A stage kind names its own file(s); its fingerprint
//! hashes every module its files reach through `crate::`/`super::`/`self::`
//! paths (closed transitively) and the lock entries of every external crate
//! those modules name, with the crates those depend on.
//!
//! build.rs compiles this same file (`#[path]`) to read the sources once and
//! write them into the binary as text ([`Sources::to_text`]); the library parses
//! that text back ([`Sources::from_text`]) and derives each kind's fingerprint
//! with [`Sources::fingerprint`]. Tests run [`Sources::read`] on an edited copy
//! of the sources and call the same derivation. tests/import_cycles.rs checks
//! the same graph for cycles.
//!
//! Only `std` and `blake3` here: build.rs includes this file with `#[path]`.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// One source file as a module of the crate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Module {
    /// blake3 of the file (and of the files it includes with
    /// `include_bytes!`/`include_str!`).
    pub hash: String,
    /// The modules its non-test code uses (keys, see [`module_key`]).
    pub deps: BTreeSet<String>,
    /// The external crates its non-test code names (`serde`, `arrow_array`, ...),
    /// as the code spells them; only those with a `Cargo.lock` entry count.
    pub crates: BTreeSet<String>,
}

/// One `[[package]]` of `Cargo.lock`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Package {
    pub name: String,
    pub version: String,
    pub source: String,
    pub checksum: String,
    /// Its dependencies as the lock lists them: `name` or `name version ...`.
    pub deps: Vec<String>,
}

/// The crate's sources as the fingerprints see them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sources {
    /// Module key -> module, for every non-test file of the library.
    pub modules: BTreeMap<String, Module>,
    pub lock: Vec<Package>,
    /// The compiler (`rustc --version`, set by build.rs): in every key, since
    /// another compiler may round floating point differently.
    pub rustc: String,
}

/// Whether module `key` belongs to the harness, which no key covers: the
/// framework (`src/pipeline`: planner, store, registry, this parser, progress,
/// canonical parameters, checkpoint plumbing, the stage trait), which hands a
/// kind its parameters and inputs and stores its output, and the code around it
/// (`study`, `cli`, the crate root). A kind's key covers its own modules and
/// what they reach without passing through the harness ([`Sources::closure`]).
pub fn is_harness(key: &str) -> bool {
    let top = key.split('/').next().unwrap_or(key);
    matches!(top, "pipeline" | "study" | "cli" | "lib" | "main")
}

/// A kind's fingerprint and what it covers.
#[derive(Clone, Debug, PartialEq)]
pub struct Fingerprint {
    pub hash: String,
    /// Every module of the closure, sorted.
    pub modules: Vec<String>,
    /// `name version` of every lock entry hashed, sorted.
    pub crates: Vec<String>,
}

/// The key of a module: its path under `src/` without `.rs`, a folder's
/// `mod.rs` as the folder (`stages/simulate`, `sim/engine`, `lib`). Accepts what
/// `file!()` gives too (`src/stages/simulate.rs`).
pub fn module_key(path: &str) -> String {
    let p = path.replace('\\', "/");
    let p = p.strip_prefix("src/").unwrap_or(&p);
    let p = p.strip_suffix(".rs").unwrap_or(p);
    let p = p.strip_suffix("/mod").unwrap_or(p);
    p.to_string()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn indent(line: &str) -> usize {
    line.len() - line.trim_start().len()
}

/// The code of a file without comments and without items under `#[cfg(test)]`
/// (one line for `item;`, else up to the `}` at the item's indentation), and the
/// names of the child modules declared under `#[cfg(test)]` (`mod tests;`).
pub fn non_test_code(text: &str) -> (String, Vec<String>) {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = String::new();
    let mut test_mods = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        if line.trim() == "#[cfg(test)]" {
            let at = indent(line);
            i += 1;
            // Further attributes of the same item.
            while i < lines.len() && lines[i].trim_start().starts_with("#[") {
                i += 1;
            }
            if i < lines.len() && lines[i].trim_end().ends_with(';') {
                let words: Vec<&str> = lines[i].split_whitespace().collect();
                if let Some(k) = words.iter().position(|w| *w == "mod")
                    && let Some(name) = words.get(k + 1)
                {
                    test_mods.push(name.trim_end_matches(';').to_string());
                }
            } else {
                while i < lines.len()
                    && !(indent(lines[i]) == at && lines[i].trim_start().starts_with('}'))
                {
                    i += 1;
                }
            }
            i += 1;
            continue;
        }
        let code = match line.find("//") {
            Some(c) => &line[..c],
            None => line,
        };
        out.push_str(code);
        out.push('\n');
        i += 1;
    }
    (out, test_mods)
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// `a::{b::C, d}` -> [`a::b::C`, `a::d`]; `a::{self, e}` -> [`a`, `a::e`];
/// `a::B as C` stays whole (see [`alias`]). Spaces only around `as`.
pub fn expand(decl: &str) -> Vec<String> {
    let decl = decl.trim();
    let Some(open) = decl.find('{') else {
        return vec![decl.to_string()];
    };
    let prefix = decl[..open].trim_end_matches("::");
    let inner = &decl[open + 1..decl.rfind('}').unwrap_or(decl.len())];
    // Split on top-level commas.
    let (mut parts, mut depth, mut cur) = (Vec::new(), 0, String::new());
    for c in inner.chars() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(std::mem::take(&mut cur));
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    parts.push(cur);
    parts
        .into_iter()
        .map(|p| p.trim().to_string())
        .filter(|p| !p.is_empty())
        .flat_map(|p| expand(&p))
        .map(|p| match p.as_str() {
            "self" => prefix.to_string(),
            _ if prefix.is_empty() => p,
            _ => format!("{prefix}::{p}"),
        })
        .collect()
}

/// A path of a `use` without its alias, and the name it brings into scope.
fn alias(p: &str) -> (String, String) {
    match p.split_once(" as ") {
        Some((path, name)) => (path.trim().to_string(), name.trim().to_string()),
        None => {
            let name = p.rsplit("::").next().unwrap_or(p).to_string();
            (p.to_string(), name)
        }
    }
}

/// A `use` declaration with its whitespace normalised: none around `::`, `{`,
/// `}` and `,`, one space elsewhere (`as`).
fn normalise(decl: &str) -> String {
    let words: Vec<&str> = decl.split_whitespace().collect();
    let mut s = words.join(" ");
    for t in ["::", "{", "}", ","] {
        s = s.replace(&format!(" {t}"), t).replace(&format!("{t} "), t);
    }
    s
}

/// One path a file names: its segments; for a `pub use`, the name it
/// re-exports; and whether the file's own code uses it (a path only
/// re-exported is no dependency of the file).
struct Named {
    segs: Vec<String>,
    reexport: Option<String>,
    used: bool,
}

/// Every path the code names that starts with `crate`, `super` or `self`, with
/// `use` groups expanded; bare `use child::...` lines of a module are given as
/// `self::child::...`. Also the first segment of every other path (external
/// crates) in `crates`.
fn paths(code: &str, crates: &mut BTreeSet<String>) -> Vec<Named> {
    let mut out = Vec::new();
    // The code without `use` declarations and `mod x;` lines: where a
    // re-exported name would be used by the file itself.
    let mut own = String::new();
    let mut decls: Vec<(bool, String)> = Vec::new();
    let mut rest = code;
    loop {
        let Some(at) = find_word(rest, "use") else {
            own.push_str(rest);
            break;
        };
        let after = &rest[at + 3..];
        let Some(end) = after.find(';') else {
            own.push_str(rest);
            break;
        };
        let before = &rest[..at];
        let b = before.trim_end();
        let public = b.ends_with("pub")
            || b.ends_with(')') && b.rfind("pub(").is_some_and(|k| !b[k..].contains('\n'));
        // A declaration starts a statement; `use` in a string or a word does not.
        let declaration = public || b.is_empty() || b.ends_with([';', '{', '}', ']']);
        if !declaration {
            own.push_str(&rest[..at + 3]);
            rest = after;
            continue;
        }
        own.push_str(before);
        decls.push((public, normalise(&after[..end])));
        rest = &after[end + 1..];
    }
    let own: String = own
        .lines()
        .filter(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            !(w.contains(&"mod") && l.trim_end().ends_with(';'))
        })
        .collect::<Vec<_>>()
        .join("\n");
    // Names an inline path may start with: the child modules the file
    // declares and the names its `use` declarations bring into scope.
    let mut scope: BTreeMap<String, Vec<String>> = child_modules(code)
        .into_iter()
        .map(|c| (c.clone(), vec!["self".to_string(), c]))
        .collect();
    for (public, decl) in decls {
        for p in expand(&decl) {
            let (path, name) = alias(&p);
            let mut segs: Vec<String> = path.split("::").map(str::to_string).collect();
            if !matches!(segs[0].as_str(), "crate" | "super" | "self") {
                if let Some(local) = scope.get(&segs[0]) {
                    // `use columns::f;` of a file declaring `mod columns;`.
                    segs.splice(0..1, local.clone());
                } else {
                    crates.insert(segs[0].clone());
                    segs.insert(0, "self".into());
                }
            }
            if name != "*" && name != "_" {
                scope.insert(name.clone(), segs.clone());
            }
            let used = !public || name == "*" || find_word(&own, &name).is_some();
            let reexport = public.then_some(name);
            out.push(Named {
                segs,
                reexport,
                used,
            });
        }
    }
    // Inline paths (`crate::stages::simulate::config(..)`, `super::kinds::Table`),
    // but not visibilities (`pub(in crate::plot)`).
    let bytes = own.as_bytes();
    let mut from = 0;
    while let Some(k) = own[from..].find("::") {
        let colon = from + k;
        from = colon + 2;
        let start = own[..colon]
            .rfind(|c: char| !is_ident(c))
            .map_or(0, |s| s + 1);
        if start == colon || (start > 0 && bytes[start - 1] == b':') {
            continue;
        }
        let len = own[start..]
            .find(|c: char| !(is_ident(c) || c == ':'))
            .unwrap_or(own.len() - start);
        let segs: Vec<String> = own[start..start + len]
            .split("::")
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect();
        if own[..start].trim_end().ends_with(" in") || own[..start].trim_end().ends_with("(in") {
            continue;
        }
        if matches!(segs[0].as_str(), "crate" | "super" | "self") {
            out.push(Named {
                segs,
                reexport: None,
                used: true,
            });
        } else if let Some(local) = scope.get(&segs[0]) {
            // `columns::f()` in a file declaring `mod columns;`, `pool::g()`
            // after `use super::pool;`.
            let mut full = local.clone();
            full.extend(segs[1..].iter().cloned());
            out.push(Named {
                segs: full,
                reexport: None,
                used: true,
            });
        } else {
            crates.insert(segs[0].clone());
        }
    }
    out
}

/// The child modules a file declares (`mod x;`, `pub mod x;`, `pub(crate) mod
/// x;`), test modules already removed by [`non_test_code`].
fn child_modules(code: &str) -> Vec<String> {
    code.lines()
        .filter_map(|l| {
            let l = l.trim();
            let w: Vec<&str> = l.split_whitespace().collect();
            let k = w.iter().position(|x| *x == "mod")?;
            let visibility = w[..k].iter().all(|x| x.starts_with("pub"));
            let name = w.get(k + 1)?.trim_end_matches(';');
            (visibility && l.ends_with(';') && name.chars().all(is_ident)).then(|| name.to_string())
        })
        .collect()
}

/// The first place `word` stands alone in `text`.
fn find_word(text: &str, word: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(k) = text[from..].find(word) {
        let at = from + k;
        from = at + word.len();
        let before = text[..at].chars().next_back();
        let after = text[at + word.len()..].chars().next();
        if !before.is_some_and(is_ident) && !after.is_some_and(is_ident) {
            return Some(at);
        }
    }
    None
}

/// Module paths as segment lists, and the names each re-exports.
struct Parsed {
    module: Vec<String>,
    named: Vec<Named>,
}

fn segments(key: &str) -> Vec<String> {
    if key == "lib" {
        Vec::new()
    } else {
        key.split('/').map(str::to_string).collect()
    }
}

fn key_of(segs: &[String]) -> String {
    if segs.is_empty() {
        "lib".into()
    } else {
        segs.join("/")
    }
}

/// Per module, its re-exported names to their paths; the globs (`pub use
/// x::*`) under `*`, each path ending in `*`.
type Reexports = BTreeMap<Vec<String>, BTreeMap<String, Vec<Vec<String>>>>;

/// The file module `path` (relative to module `m`) lands in: the longest prefix
/// of its absolute form that is a module, following re-exports (`pub use
/// x::Y` in that module) to the module that defines the name.
fn resolve(
    m: &[String],
    path: &[String],
    modules: &BTreeSet<Vec<String>>,
    reexports: &Reexports,
    depth: usize,
) -> Option<Vec<String>> {
    let mut abs: Vec<String> = match path.first()?.as_str() {
        "crate" => Vec::new(),
        "self" => m.to_vec(),
        "super" => m[..m.len().checked_sub(1)?].to_vec(),
        _ => return None,
    };
    for s in &path[1..] {
        if s == "super" {
            abs.pop()?;
        } else {
            abs.push(s.clone());
        }
    }
    let n = (0..=abs.len())
        .rev()
        .find(|&n| modules.contains(&abs[..n]))?;
    let (module, rest) = (abs[..n].to_vec(), &abs[n..]);
    if depth < 8
        && let Some(first) = rest.first()
        && let Some(named) = reexports.get(&module)
    {
        // A name re-exported by name, else through the first glob (`pub use
        // x::*`) that leads further.
        let targets: Vec<Vec<String>> = match named.get(first) {
            Some(target) => target
                .iter()
                .map(|t| {
                    let mut p = t.clone();
                    p.extend(rest[1..].iter().cloned());
                    p
                })
                .collect(),
            None => named
                .get("*")
                .into_iter()
                .flatten()
                .map(|glob| {
                    let mut p = glob[..glob.len() - 1].to_vec();
                    p.extend(rest.iter().cloned());
                    p
                })
                .collect(),
        };
        for p in targets {
            if let Some(r) = resolve(&module, &p, modules, reexports, depth + 1) {
                return Some(r);
            }
        }
    }
    Some(module)
}

fn hash_bytes(h: &mut blake3::Hasher, b: &[u8]) {
    h.update(&(b.len() as u64).to_le_bytes());
    h.update(b);
}

/// The files a source includes with `include_bytes!("...")` or
/// `include_str!("...")` (string literals, relative to the file).
pub fn included_files(file: &Path, code: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for mac in ["include_bytes!(\"", "include_str!(\""] {
        let mut from = 0;
        while let Some(k) = code[from..].find(mac) {
            let at = from + k + mac.len();
            from = at;
            if let Some(end) = code[at..].find('"') {
                let rel = &code[at..at + end];
                out.push(file.parent().unwrap_or(Path::new(".")).join(rel));
            }
        }
    }
    out
}

/// `Cargo.lock`'s packages.
pub fn parse_lock(text: &str) -> Vec<Package> {
    let mut out: Vec<Package> = Vec::new();
    let mut in_deps = false;
    for line in text.lines() {
        let l = line.trim();
        if l == "[[package]]" {
            out.push(Package::default());
            in_deps = false;
            continue;
        }
        let Some(p) = out.last_mut() else { continue };
        if in_deps {
            if l.starts_with(']') {
                in_deps = false;
            } else if let Some(d) = l.trim_end_matches(',').strip_prefix('"') {
                p.deps.push(d.trim_end_matches('"').to_string());
            }
            continue;
        }
        let Some((k, v)) = l.split_once(" = ") else {
            continue;
        };
        let v = v.trim_matches('"').to_string();
        match k {
            "name" => p.name = v,
            "version" => p.version = v,
            "source" => p.source = v,
            "checksum" => p.checksum = v,
            "dependencies" => {
                in_deps = !l.ends_with(']');
                // `dependencies = ["a", "b"]` on one line.
                if !in_deps {
                    let inner = v.trim_start_matches('[').trim_end_matches(']');
                    p.deps.extend(
                        inner
                            .split(',')
                            .map(|d| d.trim().trim_matches('"').to_string())
                            .filter(|d| !d.is_empty()),
                    );
                }
            }
            _ => {}
        }
    }
    out
}

impl Sources {
    /// Read the library's sources under `src` (not `main.rs`, not modules
    /// declared under `#[cfg(test)]`) and the lock file `lock`. Panics on an
    /// unreadable file: build.rs and tests only.
    pub fn read(src: &Path, lock: &Path) -> Sources {
        let mut files = Vec::new();
        rust_files(src, &mut files);
        files.sort();
        files.retain(|f| f.strip_prefix(src).is_ok_and(|r| r != Path::new("main.rs")));
        let mut parsed: Vec<(Parsed, String, BTreeSet<String>)> = Vec::new();
        let mut test_only: BTreeSet<Vec<String>> = BTreeSet::new();
        for f in &files {
            let rel = f.strip_prefix(src).unwrap().to_string_lossy().into_owned();
            let module = segments(&module_key(&rel));
            let text = fs::read_to_string(f).expect("source file readable");
            let (code, test_mods) = non_test_code(&text);
            for t in test_mods {
                let mut m = module.clone();
                m.push(t);
                test_only.insert(m);
            }
            let mut h = blake3::Hasher::new();
            // The path too, so that a renamed file changes the hash.
            hash_bytes(&mut h, rel.replace('\\', "/").as_bytes());
            hash_bytes(&mut h, text.as_bytes());
            for inc in included_files(f, &code) {
                hash_bytes(&mut h, &fs::read(&inc).expect("included file readable"));
            }
            let mut crates = BTreeSet::new();
            let named = paths(&code, &mut crates);
            parsed.push((
                Parsed { module, named },
                h.finalize().to_hex().to_string(),
                crates,
            ));
        }
        let is_test = |m: &[String]| (1..=m.len()).any(|n| test_only.contains(&m[..n]));
        parsed.retain(|(p, _, _)| !is_test(&p.module));
        let modules: BTreeSet<Vec<String>> =
            parsed.iter().map(|(p, _, _)| p.module.clone()).collect();
        // Re-exports first: `pub use` names the file itself does not use.
        let mut reexports: Reexports = BTreeMap::new();
        for (p, _, _) in &parsed {
            for n in &p.named {
                if let Some(name) = &n.reexport {
                    reexports
                        .entry(p.module.clone())
                        .or_default()
                        .entry(name.clone())
                        .or_default()
                        .push(n.segs.clone());
                }
            }
        }
        let mut out = BTreeMap::new();
        for (p, hash, crates) in parsed {
            let deps: BTreeSet<String> = p
                .named
                .iter()
                .filter(|n| n.used)
                .filter_map(|n| resolve(&p.module, &n.segs, &modules, &reexports, 0))
                .filter(|d| *d != p.module && !is_test(d))
                .map(|d| key_of(&d))
                .collect();
            out.insert(key_of(&p.module), Module { hash, deps, crates });
        }
        let lock = parse_lock(&fs::read_to_string(lock).expect("Cargo.lock readable"));
        Sources {
            modules: out,
            lock,
            rustc: String::new(),
        }
    }

    /// As text, one record a line (what build.rs writes into the binary).
    pub fn to_text(&self) -> String {
        let mut s = format!("R\t{}\n", self.rustc);
        for (k, m) in &self.modules {
            s.push_str(&format!("M\t{k}\t{}\n", m.hash));
            for d in &m.deps {
                s.push_str(&format!("D\t{d}\n"));
            }
            for c in &m.crates {
                s.push_str(&format!("C\t{c}\n"));
            }
        }
        for p in &self.lock {
            s.push_str(&format!(
                "P\t{}\t{}\t{}\t{}\n",
                p.name, p.version, p.source, p.checksum
            ));
            for d in &p.deps {
                s.push_str(&format!("PD\t{d}\n"));
            }
        }
        s
    }

    /// [`Sources::to_text`] read back.
    pub fn from_text(text: &str) -> Sources {
        let mut s = Sources::default();
        let mut module: Option<String> = None;
        for line in text.lines() {
            let f: Vec<&str> = line.split('\t').collect();
            match f.as_slice() {
                ["R", rustc] => s.rustc = rustc.to_string(),
                ["M", k, h] => {
                    s.modules.insert(
                        k.to_string(),
                        Module {
                            hash: h.to_string(),
                            ..Module::default()
                        },
                    );
                    module = Some(k.to_string());
                }
                ["D", d] => {
                    if let Some(m) = module.as_ref().and_then(|k| s.modules.get_mut(k)) {
                        m.deps.insert(d.to_string());
                    }
                }
                ["C", c] => {
                    if let Some(m) = module.as_ref().and_then(|k| s.modules.get_mut(k)) {
                        m.crates.insert(c.to_string());
                    }
                }
                ["P", name, version, source, checksum] => s.lock.push(Package {
                    name: name.to_string(),
                    version: version.to_string(),
                    source: source.to_string(),
                    checksum: checksum.to_string(),
                    deps: Vec::new(),
                }),
                ["PD", d] => {
                    if let Some(p) = s.lock.last_mut() {
                        p.deps.push(d.to_string());
                    }
                }
                _ => {}
            }
        }
        s
    }

    /// Every module reachable from `roots` (module keys or `file!()` paths)
    /// without entering the harness ([`is_harness`]), roots included; an error
    /// names a root that is no module.
    pub fn closure(&self, roots: &[&str]) -> Result<BTreeSet<String>, String> {
        self.closure_cut(roots, &[])
    }

    /// [`Sources::closure`] without following the import edges `cut` (`(from,
    /// to)`, module keys or paths): a catalogue that names every member of a
    /// family to dispatch by name reaches, for one member, only that member's
    /// modules. An edge that is no import is an error: a renamed module must
    /// not leave a cut that no longer cuts, nor one that names nothing.
    pub fn closure_cut(
        &self,
        roots: &[&str],
        cut: &[(&str, &str)],
    ) -> Result<BTreeSet<String>, String> {
        let mut cut_keys = BTreeSet::new();
        for (from, to) in cut {
            let (f, t) = (module_key(from), module_key(to));
            if !self.modules.get(&f).is_some_and(|m| m.deps.contains(&t)) {
                return Err(format!(
                    "the cut edge '{f}' -> '{t}' is no import of the sources"
                ));
            }
            cut_keys.insert((f, t));
        }
        let mut seen = BTreeSet::new();
        let mut todo: Vec<String> = Vec::new();
        for r in roots {
            let k = module_key(r);
            if !self.modules.contains_key(&k) {
                return Err(format!(
                    "'{r}' is not a source file under src/ (module '{k}')"
                ));
            }
            todo.push(k);
        }
        while let Some(k) = todo.pop() {
            if !seen.insert(k.clone()) {
                continue;
            }
            if let Some(m) = self.modules.get(&k) {
                todo.extend(
                    m.deps
                        .iter()
                        .filter(|d| {
                            !seen.contains(*d)
                                && !is_harness(d)
                                && !cut_keys.contains(&(k.clone(), (*d).clone()))
                        })
                        .cloned(),
                );
            }
        }
        Ok(seen)
    }

    /// The lock entries of the external crates `modules` name, closed over the
    /// lock's dependencies.
    pub fn packages(&self, modules: &BTreeSet<String>) -> Vec<&Package> {
        let norm = |n: &str| n.replace('-', "_");
        let named: BTreeSet<String> = modules
            .iter()
            .filter_map(|k| self.modules.get(k))
            .flat_map(|m| m.crates.iter().map(|c| norm(c)))
            .collect();
        let mut seen: BTreeSet<usize> = BTreeSet::new();
        let mut todo: Vec<usize> = (0..self.lock.len())
            .filter(|&i| named.contains(&norm(&self.lock[i].name)))
            .collect();
        while let Some(i) = todo.pop() {
            if !seen.insert(i) {
                continue;
            }
            for d in &self.lock[i].deps {
                let mut w = d.split_whitespace();
                let name = w.next().unwrap_or("");
                let version = w.next();
                todo.extend((0..self.lock.len()).filter(|&j| {
                    self.lock[j].name == name && version.is_none_or(|v| self.lock[j].version == v)
                }));
            }
        }
        seen.into_iter().map(|i| &self.lock[i]).collect()
    }

    /// The fingerprint of kind `name` whose own files are `roots`: blake3 of its
    /// name, every module of their closure with its hash, and every lock entry
    /// of the crates the closure names.
    pub fn fingerprint(&self, name: &str, roots: &[&str]) -> Result<Fingerprint, String> {
        self.fingerprint_cut(name, roots, &[])
    }

    /// [`Sources::fingerprint`] over [`Sources::closure_cut`]: the edges `cut`
    /// are not followed.
    pub fn fingerprint_cut(
        &self,
        name: &str,
        roots: &[&str],
        cut: &[(&str, &str)],
    ) -> Result<Fingerprint, String> {
        if roots.is_empty() {
            return Err(format!("stage kind '{name}' names no source file"));
        }
        let closure = self
            .closure_cut(roots, cut)
            .map_err(|e| format!("stage kind '{name}': {e}"))?;
        let mut h = blake3::Hasher::new();
        // v3: the harness left out, inline paths resolved in their module, the
        // compiler hashed.
        hash_bytes(&mut h, b"repro-code-v3");
        hash_bytes(&mut h, self.rustc.as_bytes());
        hash_bytes(&mut h, name.as_bytes());
        for k in &closure {
            hash_bytes(&mut h, k.as_bytes());
            hash_bytes(&mut h, self.modules[k].hash.as_bytes());
        }
        let mut crates = Vec::new();
        for p in self.packages(&closure) {
            for f in [&p.name, &p.version, &p.source, &p.checksum] {
                hash_bytes(&mut h, f.as_bytes());
            }
            crates.push(format!("{} {}", p.name, p.version));
        }
        crates.sort();
        Ok(Fingerprint {
            hash: h.finalize().to_hex().to_string(),
            modules: closure.into_iter().collect(),
            crates,
        })
    }

    /// A cycle of the import graph between the nodes `group` maps modules to
    /// (others left out), as the chain of its nodes, first repeated at the end.
    pub fn cycle(&self, group: impl Fn(&str) -> Option<String>) -> Option<Vec<String>> {
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (k, m) in &self.modules {
            let Some(from) = group(k) else { continue };
            let e = graph.entry(from.clone()).or_default();
            e.extend(
                m.deps
                    .iter()
                    .filter_map(|d| group(d))
                    .filter(|d| *d != from),
            );
        }
        find_cycle(&graph)
    }
}

/// A cycle of `graph` as the chain of its nodes (first repeated at the end).
pub fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        done: &mut BTreeSet<String>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = stack.iter().position(|s| s == n) {
            let mut cycle = stack[at..].to_vec();
            cycle.push(n.to_string());
            return Some(cycle);
        }
        if !done.insert(n.to_string()) {
            return None;
        }
        stack.push(n.to_string());
        for d in graph.get(n).into_iter().flatten() {
            if let Some(c) = visit(d, graph, done, stack) {
                return Some(c);
            }
        }
        stack.pop();
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|n| visit(n, graph, &mut done, &mut Vec::new()))
}

#[cfg(test)]
#[path = "fingerprint_tests.rs"]
mod tests;
