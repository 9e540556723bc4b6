//! No import cycles: the module graph read from the sources (every `crate::`,
//! `super::` and `self::` path of non-test code, in `use` lines and inline) is
//! acyclic between the files of `src/pipeline` and between the top-level modules.
//! A cycle is printed as the chain of modules that closes it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The top-level modules whose dependencies must form a DAG.
const TOP_LEVEL: &[&str] = &[
    "sim", "analysis", "fit", "table", "plot", "pipeline", "stages", "study", "cli", "traj",
];

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module a file under `src/` defines: `pipeline/graph.rs` -> [pipeline, graph],
/// `pipeline/mod.rs` -> [pipeline], `lib.rs` -> [].
fn module_of(rel: &Path) -> Vec<String> {
    let mut m: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if m.last().is_some_and(|l| l == "mod" || l == "lib") {
        m.pop();
    }
    m
}

fn indent(line: &str) -> usize {
    line.len() - line.trim_start().len()
}

/// The code of a file without comments and without items under `#[cfg(test)]`
/// (one line for `item;`, else up to the `}` at the item's indentation).
fn non_test_code(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = String::new();
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
            if i < lines.len() && !lines[i].trim_end().ends_with(';') {
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
    out
}

/// Every path the code names that starts with `crate`, `super` or `self`, with
/// `use` groups (`use super::{a::B, c}`) expanded; bare `use child::...` lines of a
/// module are given as `self::child::...`.
fn paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    // `use` declarations, possibly spanning lines.
    let mut rest = code;
    while let Some(at) = rest.find("use ") {
        let before = rest[..at].chars().last();
        let tail = &rest[at + 4..];
        rest = tail;
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let Some(end) = tail.find(';') else { break };
        let decl: String = tail[..end].chars().filter(|c| !c.is_whitespace()).collect();
        for p in expand(&decl) {
            let mut segs: Vec<String> = p.split("::").map(str::to_string).collect();
            if !matches!(segs[0].as_str(), "crate" | "super" | "self") {
                segs.insert(0, "self".into());
            }
            out.push(segs);
        }
    }
    // Inline paths (`crate::stages::simulate::config(..)`, `super::kinds::Table`).
    let bytes = code.as_bytes();
    for start in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(k) = code[from..].find(start) {
            let at = from + k;
            from = at + start.len();
            if at > 0
                && (bytes[at - 1].is_ascii_alphanumeric()
                    || bytes[at - 1] == b'_'
                    || bytes[at - 1] == b':')
            {
                continue;
            }
            let len = code[at..]
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(code.len() - at);
            let segs: Vec<String> = code[at..at + len]
                .split("::")
                .filter(|s| !s.is_empty())
                .map(str::to_string)
                .collect();
            out.push(segs);
        }
    }
    out
}

/// `a::{b::C, d}` -> [`a::b::C`, `a::d`]; `a::{self, e}` -> [`a`, `a::e`].
fn expand(decl: &str) -> Vec<String> {
    let decl = decl
        .trim_start_matches("pub(crate)")
        .trim_start_matches("pub");
    let Some(open) = decl.find('{') else {
        return vec![decl.split(" as ").next().unwrap_or(decl).to_string()];
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
        .filter(|p| !p.is_empty())
        .flat_map(|p| expand(&p))
        .map(|p| match p.as_str() {
            "self" => prefix.to_string(),
            _ => format!("{prefix}::{p}"),
        })
        .collect()
}

/// The file module `path` (relative to module `m`) lands in: the longest prefix of
/// its absolute form that is a module of `modules`.
fn resolve(m: &[String], path: &[String], modules: &BTreeSet<Vec<String>>) -> Option<Vec<String>> {
    let mut abs: Vec<String> = match path.first()?.as_str() {
        "crate" => Vec::new(),
        "self" => m.to_vec(),
        "super" => m[..m.len().checked_sub(1)?].to_vec(),
        _ => return None,
    };
    let mut segs = path[1..].iter();
    for s in segs.by_ref() {
        if s == "super" {
            abs.pop()?;
        } else {
            abs.push(s.clone());
        }
    }
    (0..=abs.len())
        .rev()
        .map(|n| abs[..n].to_vec())
        .find(|p| modules.contains(p))
}

/// Module -> the modules it uses, for every file module under `src/` (the binary's
/// `main.rs` is another crate and left out).
fn module_graph() -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.retain(|f| f.file_name().is_some_and(|n| n != "main.rs"));
    let modules: BTreeSet<Vec<String>> = files
        .iter()
        .map(|f| module_of(f.strip_prefix(&src).unwrap()))
        .collect();
    let mut graph = BTreeMap::new();
    for f in &files {
        let m = module_of(f.strip_prefix(&src).unwrap());
        let code = non_test_code(&std::fs::read_to_string(f).unwrap());
        let deps: BTreeSet<Vec<String>> = paths(&code)
            .iter()
            .filter_map(|p| resolve(&m, p, &modules))
            .filter(|d| *d != m)
            .collect();
        graph.insert(m, deps);
    }
    graph
}

/// A cycle of `graph` as the chain of its nodes (first repeated at the end).
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
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

/// The graph between the modules that `group` maps to a name (others left out).
fn collapse(group: impl Fn(&[String]) -> Option<String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, deps) in module_graph() {
        let Some(from) = group(&m) else { continue };
        let entry = out.entry(from.clone()).or_default();
        entry.extend(deps.iter().filter_map(|d| group(d)).filter(|d| *d != from));
    }
    out
}

fn assert_acyclic(what: &str, graph: &BTreeMap<String, BTreeSet<String>>) {
    if let Some(c) = find_cycle(graph) {
        panic!("import cycle {what}: {}", c.join(" -> "));
    }
}

#[test]
fn the_files_of_the_pipeline_framework_import_without_cycles() {
    let graph = collapse(|m| (m.first()? == "pipeline").then(|| m.join("/")));
    assert!(
        graph.len() > 5 && graph.contains_key("pipeline/graph"),
        "{graph:?}"
    );
    assert_acyclic("between files of src/pipeline", &graph);
}

#[test]
fn the_top_level_modules_import_without_cycles() {
    let graph = collapse(|m| {
        let top = m.first()?;
        TOP_LEVEL.contains(&top.as_str()).then(|| top.clone())
    });
    assert_eq!(graph.len(), TOP_LEVEL.len(), "{graph:?}");
    assert_acyclic("between top-level modules", &graph);
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
    // Groups, `self` and nested paths expand; relative paths resolve.
    assert_eq!(
        expand("super::{a::B,c::{self,D}}"),
        ["super::a::B", "super::c", "super::c::D"]
    );
    let modules: BTreeSet<Vec<String>> = [vec!["p".into()], vec!["p".into(), "g".into()]].into();
    let m = vec!["p".to_string(), "r".to_string()];
    let path = |s: &str| s.split("::").map(str::to_string).collect::<Vec<_>>();
    assert_eq!(
        resolve(&m, &path("super::g::Node"), &modules),
        Some(vec!["p".into(), "g".into()])
    );
    assert_eq!(
        resolve(&m, &path("crate::p::Registry"), &modules),
        Some(vec!["p".into()])
    );
    let code = non_test_code("use super::g;\n#[cfg(test)]\nmod tests {\n    use super::x;\n}\n");
    let mut found = paths(&code);
    found.dedup();
    assert_eq!(found, [path("super::g")]);
}
