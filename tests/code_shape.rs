//! The shape of the code a reader has to hold in their head: no function of
//! the library or the binary (tests aside) is longer than [`MAX_LINES`] lines,
//! signature to closing brace.
//! Cargo.toml's `[lints]` table asks clippy for `too_many_lines` at the same
//! bound (clippy.toml), for editors; this test holds it in CI, where clippy
//! does not run.

use std::fs;
use std::path::{Path, PathBuf};

const MAX_LINES: usize = 150;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in fs::read_dir(dir).unwrap().flatten() {
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

/// The line after the item that starts at `from` with indentation `at`: a
/// one-line `...;` item, or up to its closing `}` at the same indentation.
fn item_end(lines: &[&str], from: usize, at: usize) -> usize {
    let mut j = from;
    while j < lines.len() && !lines[j].trim_end().ends_with('{') {
        if lines[j].trim_end().ends_with(';') {
            return j + 1;
        }
        j += 1;
    }
    j += 1;
    while j < lines.len() && !(indent(lines[j]) == at && lines[j].trim_start().starts_with('}')) {
        j += 1;
    }
    j + 1
}

/// `fn NAME` at the start of a line (after visibility and qualifiers).
fn fn_name(line: &str) -> Option<&str> {
    let mut words = line.split_whitespace().peekable();
    while let Some(w) = words.next() {
        match w {
            "fn" => {
                return words
                    .next()
                    .map(|n| n.split(['(', '<']).next().unwrap_or(n));
            }
            "pub" | "const" | "async" | "unsafe" | "extern" => {}
            w if w.starts_with("pub(") => {}
            _ => return None,
        }
    }
    None
}

/// Every function of `text` longer than `max` lines outside `#[cfg(test)]`
/// items, as (first line, name, lines).
fn long_functions(text: &str, max: usize) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        if line.trim() == "#[cfg(test)]" {
            let mut j = i + 1;
            while j < lines.len() && lines[j].trim_start().starts_with("#[") {
                j += 1;
            }
            i = item_end(&lines, j, indent(line));
            continue;
        }
        if let Some(name) = fn_name(line) {
            let end = item_end(&lines, i, indent(line));
            let n = end - i;
            if n > max {
                out.push((i + 1, name.to_string(), n));
            }
        }
        i += 1;
    }
    out
}

#[test]
fn the_scanner_finds_a_long_function_and_skips_tests() {
    let body = "    let x = 1;\n".repeat(10);
    let text = format!(
        "pub fn long() {{\n{body}}}\n\nfn short() {{\n}}\n\n#[cfg(test)]\nmod tests {{\n    fn also_long() {{\n{body}    }}\n}}\n"
    );
    let found = long_functions(&text, 5);
    assert_eq!(found, vec![(1, "long".to_string(), 12)]);
}

#[test]
fn no_production_function_is_longer_than_the_bound() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut long = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap().display().to_string();
        // Files that only hold tests.
        if rel.ends_with("tests.rs") || rel.contains("/tests/") || rel.ends_with("test_support.rs")
        {
            continue;
        }
        for (line, name, n) in long_functions(&fs::read_to_string(f).unwrap(), MAX_LINES) {
            long.push(format!("src/{rel}:{line} {name}: {n} lines"));
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_LINES} lines (split them by job):\n{}",
        long.join("\n")
    );
}
