//! The documentation agrees with itself and with the repository.
//!
//! - The README stays under 8 KB, points to every docs/*.md and lists every
//!   subcommand of `repro --help`; every `repro X` a doc shows as code is a
//!   subcommand.
//! - Every link of README.md and docs/*.md resolves to a file of the repository,
//!   no doc points outside it, and every source path a doc names (`src/...`)
//!   exists, so a moved module shows up as a doc to update.
//! - No doc quotes a key number of docs/report-ci.md (generated from a build by
//!   `repro report --profile ci --docs`) with another value. A quote is a table
//!   row whose first two cells are the report's figure and quantity, or inline
//!   text of the form ``fig9's `D_078` = 0.0107`` (also `fig9 D_078 is ...`) or
//!   ``D_078 (fig9) = ...``. Values agree when they are equal to the rounding of
//!   the digits either side prints. A line that describes a change (it holds
//!   ` -> `, as the sensitivity tables' `eps 0.90 -> 0.88` rows do) compares
//!   another build and is not checked; neither is docs/measurements.md, the dated
//!   log of past builds.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const REPORT: &str = "docs/report-ci.md";
const DATED_LOG: &str = "docs/measurements.md";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every docs/*.md, as (path relative to the root, text).
fn docs() -> Vec<(String, String)> {
    let root = root();
    let mut paths = vec!["README.md".to_string()];
    let mut in_docs: Vec<String> = fs::read_dir(root.join("docs"))
        .expect("docs/")
        .map(|e| {
            e.expect("docs/ entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .filter(|name| name.ends_with(".md"))
        .map(|name| format!("docs/{name}"))
        .collect();
    in_docs.sort();
    paths.extend(in_docs);
    paths
        .into_iter()
        .map(|p| {
            let text = fs::read_to_string(root.join(&p)).unwrap_or_else(|e| panic!("{p}: {e}"));
            (p, text)
        })
        .collect()
}

/// The targets of the Markdown links and images of `text`: `](target)`.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            out.push((n + 1, after[..end].trim().to_string()));
            rest = &after[end..];
        }
    }
    out
}

#[test]
fn every_link_resolves_to_a_file_of_the_repository() {
    let root = root().canonicalize().expect("root");
    let mut broken = Vec::new();
    for (path, text) in docs() {
        let dir = Path::new(&path)
            .parent()
            .unwrap_or(Path::new(""))
            .to_path_buf();
        for (line, target) in link_targets(&text) {
            if target.starts_with("http://")
                || target.starts_with("https://")
                || target.starts_with("mailto:")
                || target.starts_with('#')
            {
                continue;
            }
            let file = target.split('#').next().unwrap_or("");
            let resolved = root.join(&dir).join(file);
            match resolved.canonicalize() {
                Ok(p) if p.starts_with(&root) && p.is_file() => {}
                _ => broken.push(format!("{path}:{line}: {target}")),
            }
        }
    }
    assert!(
        broken.is_empty(),
        "links that do not resolve to a file of the repository:\n{}",
        broken.join("\n")
    );
}

#[test]
fn every_source_path_a_doc_names_exists() {
    let root = root();
    let mut missing = Vec::new();
    for (path, text) in docs() {
        if path == DATED_LOG {
            continue;
        }
        for (n, line) in text.lines().enumerate() {
            for (i, _) in line.match_indices("src/") {
                if line[..i]
                    .chars()
                    .next_back()
                    .is_some_and(|c| c.is_ascii_alphanumeric() || c == '/')
                {
                    continue;
                }
                let len = line[i..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '/' | '.' | '-'))
                    .count();
                let named = line[i..i + len].trim_end_matches(['.', '/']);
                if !root.join(named).exists() {
                    missing.push(format!("{path}:{}: {named}", n + 1));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "source paths named in docs that do not exist:\n{}",
        missing.join("\n")
    );
}

/// The subcommands `repro --help` lists (without `help`), and the hidden one the
/// Slurm jobs run.
fn subcommands() -> (Vec<String>, Vec<String>) {
    let out = Command::new(env!("CARGO_BIN_EXE_repro"))
        .arg("--help")
        .output()
        .expect("repro --help");
    let help = String::from_utf8(out.stdout).expect("utf-8 help");
    let listed = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect();
    (listed, vec!["worker".to_string()])
}

/// The words after `repro ` in the code of `text`: backtick spans and indented lines.
fn commands_shown(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let code: Vec<&str> = if line.starts_with("    ") {
            vec![line]
        } else {
            line.split('`').skip(1).step_by(2).collect()
        };
        for span in code {
            for (i, _) in span.match_indices("repro ") {
                if span[..i]
                    .chars()
                    .next_back()
                    .is_some_and(|c| c.is_ascii_alphanumeric() || matches!(c, '/' | '-' | '_'))
                {
                    continue;
                }
                let word: String = span[i + 6..]
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase())
                    .collect();
                if !word.is_empty() {
                    out.push((n + 1, word));
                }
            }
        }
    }
    out
}

#[test]
fn the_readme_lists_every_subcommand_and_docs_use_no_other() {
    let (listed, hidden) = subcommands();
    assert!(listed.len() >= 10, "repro --help lists {listed:?}");
    let readme = fs::read_to_string(root().join("README.md")).expect("README.md");
    let unlisted: Vec<&String> = listed
        .iter()
        .filter(|c| !readme.contains(&format!("`{c}")))
        .collect();
    assert!(unlisted.is_empty(), "README.md does not list: {unlisted:?}");
    let mut unknown = Vec::new();
    for (path, text) in docs() {
        if path == DATED_LOG {
            continue;
        }
        for (line, word) in commands_shown(&text) {
            if !listed.contains(&word) && !hidden.contains(&word) {
                unknown.push(format!("{path}:{line}: repro {word}"));
            }
        }
    }
    assert!(
        unknown.is_empty(),
        "docs show commands repro does not have:\n{}",
        unknown.join("\n")
    );
}

#[test]
fn the_readme_points_to_every_doc() {
    let readme = fs::read_to_string(root().join("README.md")).expect("README.md");
    let missing: Vec<String> = docs()
        .into_iter()
        .map(|(p, _)| p)
        .filter(|p| p != "README.md" && !readme.contains(&format!("]({p})")))
        .collect();
    assert!(
        missing.is_empty(),
        "README.md's reading list leaves out {missing:?}"
    );
}

#[test]
fn the_readme_stays_a_short_page() {
    let len = fs::metadata(root().join("README.md"))
        .expect("README.md")
        .len();
    assert!(
        len <= 8192,
        "README.md is {len} bytes: move details to docs/"
    );
}

#[test]
fn no_doc_points_outside_the_repository() {
    let mut found = Vec::new();
    for (path, text) in docs() {
        for (n, line) in text.lines().enumerate() {
            for outside in ["../shared", "/work/"] {
                if line.contains(outside) {
                    found.push(format!("{path}:{}: {outside}", n + 1));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "paths outside the repository:\n{}",
        found.join("\n")
    );
}

/// The cells of a Markdown table row, or None for any other line.
fn cells(line: &str) -> Option<Vec<&str>> {
    let t = line.trim();
    if !t.starts_with('|') {
        return None;
    }
    Some(t.trim_matches('|').split('|').map(str::trim).collect())
}

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The length of a figure id at the start of `s` (`fig9`, `intruder-fig3`,
/// `stability-drive`).
fn figure_len(s: &str) -> Option<usize> {
    let digits_after = |prefix: &str| {
        s.strip_prefix(prefix).and_then(|r| {
            let n = r.chars().take_while(char::is_ascii_digit).count();
            (n > 0).then_some(prefix.len() + n)
        })
    };
    if let Some(n) = digits_after("intruder-fig") {
        return Some(n);
    }
    if let Some(r) = s.strip_prefix("stability-") {
        let n = r.chars().take_while(char::is_ascii_lowercase).count();
        return (n > 0).then_some("stability-".len() + n);
    }
    digits_after("fig")
}

fn identifier_len(s: &str) -> usize {
    s.chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .count()
}

/// The number at the start of `s`: sign, digits, decimals, exponent.
fn number_len(s: &str) -> usize {
    let b = s.as_bytes();
    let mut i = 0;
    if b.first() == Some(&b'-') {
        i += 1;
    }
    let digits = |i: &mut usize| {
        let start = *i;
        while *i < b.len() && b[*i].is_ascii_digit() {
            *i += 1;
        }
        *i > start
    };
    if !digits(&mut i) {
        return 0;
    }
    if b.get(i) == Some(&b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit) {
        i += 1;
        digits(&mut i);
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        let mut j = i + 1;
        if matches!(b.get(j), Some(b'-' | b'+')) {
            j += 1;
        }
        if digits(&mut j) {
            i = j;
        }
    }
    i
}

/// `= NUMBER` or `is NUMBER` at the start of `s` (after spaces): the number.
fn quoted_value(s: &str) -> Option<&str> {
    let s = s.trim_start();
    let s = s
        .strip_prefix('=')
        .or_else(|| s.strip_prefix("is "))?
        .trim_start();
    let n = number_len(s);
    (n > 0).then(|| &s[..n])
}

/// Inline quotes of a line: (figure, quantity, value).
fn inline_quotes(line: &str) -> Vec<(String, String, String)> {
    let mut out = Vec::new();
    let boundary = |i: usize| {
        i == 0
            || !line[..i]
                .chars()
                .next_back()
                .is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    for (i, _) in line.char_indices() {
        if !boundary(i) {
            continue;
        }
        let Some(flen) = figure_len(&line[i..]) else {
            continue;
        };
        let figure = &line[i..i + flen];
        let after = &line[i + flen..];
        // `fig9's `D_078` = 0.0107`, `fig9 D_078 is 0.0107`
        let rest = after.strip_prefix("'s").unwrap_or(after);
        if rest.starts_with(' ') {
            let rest = rest.trim_start();
            let rest = rest.strip_prefix('`').unwrap_or(rest);
            let qlen = identifier_len(rest);
            let quantity = &rest[..qlen];
            let rest = rest[qlen..].strip_prefix('`').unwrap_or(&rest[qlen..]);
            if is_identifier(quantity)
                && let Some(v) = quoted_value(rest)
            {
                out.push((figure.to_string(), quantity.to_string(), v.to_string()));
            }
        }
        // `D_078 (fig9) = 0.0107`
        if i >= 1 && line[..i].ends_with('(') && after.starts_with(')') {
            let before = line[..i - 1].trim_end();
            let before = before.strip_suffix('`').unwrap_or(before);
            let qlen = before
                .chars()
                .rev()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .count();
            let quantity = &before[before.len() - qlen..];
            if is_identifier(quantity)
                && let Some(v) = quoted_value(&after[1..])
            {
                out.push((figure.to_string(), quantity.to_string(), v.to_string()));
            }
        }
    }
    out
}

/// Half a unit of the last digit `s` prints: the rounding it stands for.
fn half_unit(s: &str) -> f64 {
    let (mantissa, exponent) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().unwrap_or(0)),
        None => (s, 0),
    };
    let decimals = mantissa.find('.').map_or(0, |i| mantissa.len() - i - 1) as i32;
    0.5 * 10f64.powi(exponent - decimals)
}

/// Whether a quoted value and the report's agree within both roundings.
fn agrees(quoted: &str, reported: &str) -> bool {
    match (quoted.parse::<f64>(), reported.parse::<f64>()) {
        (Ok(q), Ok(r)) => {
            (q - r).abs() <= half_unit(quoted) + half_unit(reported) + 1e-12 * r.abs()
        }
        _ => false,
    }
}

/// (figure, quantity) -> value, from the report's tables.
fn report_values(report: &str) -> BTreeMap<(String, String), String> {
    let mut values = BTreeMap::new();
    for line in report.lines() {
        let Some(c) = cells(line) else { continue };
        if c.len() >= 3 && figure_len(c[0]) == Some(c[0].len()) && is_identifier(c[1]) {
            values
                .entry((c[0].to_string(), c[1].to_string()))
                .or_insert_with(|| c[2].to_string());
        }
    }
    values
}

/// Every quote of `text` that disagrees with the report: "path:line: ...".
fn disagreements(
    path: &str,
    text: &str,
    report: &BTreeMap<(String, String), String>,
) -> Vec<String> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if line.contains(" -> ") {
            continue;
        }
        let mut quotes = inline_quotes(line);
        if let Some(c) = cells(line)
            && c.len() >= 3
            && !c[2].is_empty()
            && number_len(c[2]) == c[2].len()
        {
            quotes.push((c[0].to_string(), c[1].to_string(), c[2].to_string()));
        }
        for (figure, quantity, value) in quotes {
            if let Some(reported) = report.get(&(figure.clone(), quantity.clone()))
                && !agrees(&value, reported)
            {
                out.push(format!(
                    "{path}:{}: {figure} {quantity} = {value}, report-ci.md says {reported}",
                    n + 1
                ));
            }
        }
    }
    out
}

#[test]
fn no_doc_quotes_a_key_number_other_than_the_report() {
    let root = root();
    let report = report_values(&fs::read_to_string(root.join(REPORT)).expect("report"));
    assert!(
        report.len() > 100,
        "report-ci.md lists {} numbers: its tables were not read",
        report.len()
    );
    let mut found = Vec::new();
    for (path, text) in docs() {
        // The generated reports are each their own profile's source.
        let generated = path.starts_with("docs/report-") && path.ends_with(".md");
        if path == REPORT || path == DATED_LOG || generated {
            continue;
        }
        found.extend(disagreements(&path, &text, &report));
    }
    assert!(
        found.is_empty(),
        "docs disagree with docs/report-ci.md:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_number_check_catches_a_stale_quote() {
    let report = report_values(
        "| figure | quantity | ours | error |\n|---|---|---|---|\n| fig9 | minus_theta | -1.405 | 0.036 |\n\
         | fig9 | D_078 | 0.01071 | 0.00048 |\n| intruder-fig2 | V_cm | 29.3 | 1.8 |\n",
    );
    let doc = "At ci fig9's `minus_theta` = -1.35 here.\n\
               fig9 D_078 is 0.0107, rounded.\n\
               `V_cm` (intruder-fig2) = 29 at ci.\n\
               | fig9 | minus_theta | -1.41 | 0.04 |\n\
               | fig9 | D_078 | 0.0120 | 0.0005 |\n\
               | eps 0.90 -> 0.89 | fig9's D_078 = 0.01406 |\n";
    let found = disagreements("doc.md", doc, &report);
    assert_eq!(
        found,
        vec![
            "doc.md:1: fig9 minus_theta = -1.35, report-ci.md says -1.405".to_string(),
            "doc.md:5: fig9 D_078 = 0.0120, report-ci.md says 0.01071".to_string(),
        ]
    );
}

/// `(what, K, N)` of every "PHRASE K of N TAIL" in `text`, `what` the word
/// before the phrase (a change such as `eps=0.88:`).
fn rates(text: &str, phrase: &str, tail: &str) -> Vec<(String, String, String)> {
    let mut out = Vec::new();
    for line in text.lines() {
        let mut rest = line;
        while let Some(i) = rest.find(phrase) {
            let before = rest[..i].trim_end();
            let what = before
                .rsplit(|c: char| c.is_whitespace() || c == '(' || c == '`')
                .next()
                .unwrap_or("")
                .trim_end_matches(':')
                .to_string();
            let after = &rest[i + phrase.len()..];
            let words: Vec<&str> = after.split_whitespace().collect();
            let tail_words: Vec<&str> = tail.split_whitespace().collect();
            let nums = &words[..words.len().min(3)];
            if nums.len() == 3
                && nums[1] == "of"
                && words[3..]
                    .iter()
                    .map(|w| w.trim_end_matches(|c: char| c.is_ascii_punctuation()))
                    .take(tail_words.len())
                    .eq(tail_words.iter().copied())
            {
                out.push((what, nums[0].to_string(), nums[2].to_string()));
            }
            rest = after;
        }
    }
    out
}

/// The README and docs/accuracy.md quote the CI gate's measured false-alarm
/// and detection rates as the generated measurements say (docs/coverage-ci-fresh20.md
/// from `repro coverage --docs` on seeds the goldens were not recorded at,
/// docs/sensitivity-ci.md from `make sensitivity`).
#[test]
fn the_gate_rates_quoted_are_the_measured_ones() {
    let root = root();
    let read = |p: &str| fs::read_to_string(root.join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let alarm_rates = |text: &str| -> Vec<(String, String, String)> {
        text.lines()
            .filter(|l| l.contains("fresh master seeds"))
            .flat_map(|l| rates(l, "fails at ", "fresh master seeds"))
            .collect()
    };
    let alarms = alarm_rates(&read("docs/coverage-ci-fresh20.md"));
    let alarm = alarms
        .first()
        .expect("docs/coverage-ci-fresh20.md states its false alarms");
    let sensitivity = rates(
        &read("docs/sensitivity-ci.md"),
        "CI fails at ",
        "fresh seeds",
    );
    assert!(
        !sensitivity.is_empty(),
        "docs/sensitivity-ci.md states no rate"
    );
    for doc in ["README.md", "docs/accuracy.md"] {
        let text = read(doc);
        let quoted_alarms = alarm_rates(&text);
        assert!(
            !quoted_alarms.is_empty(),
            "{doc} does not state the false-alarm rate"
        );
        for (_, k, n) in &quoted_alarms {
            assert_eq!((k, n), (&alarm.1, &alarm.2), "{doc}: false alarms");
        }
        let quoted = rates(&text, "CI fails at ", "fresh seeds");
        // The README quotes the headline changes; docs/accuracy.md every one
        // (the power curve's too).
        let headline = ["eps=0.88", "radius_ratio=1.40", "none"];
        for (what, k, n) in &sensitivity {
            if doc == "README.md" && !headline.contains(&what.as_str()) {
                continue;
            }
            assert!(
                quoted
                    .iter()
                    .any(|(w, kk, nn)| w == what && kk == k && nn == n),
                "{doc} does not say `{what}: CI fails at {k} of {n}` (docs/sensitivity-ci.md)"
            );
        }
        for q in &quoted {
            assert!(
                sensitivity.contains(q),
                "{doc}: {q:?} is not in docs/sensitivity-ci.md"
            );
        }
    }
}

/// docs/spec.md's schema examples are the files docs/examples/*.yaml, included
/// verbatim, and they plan at every profile they define: pasted into a
/// project, they work.
#[test]
fn the_spec_examples_are_real_files_that_plan() {
    let root = root();
    let spec = fs::read_to_string(root.join("docs/spec.md")).unwrap();
    let example = |name: &str| fs::read_to_string(root.join("docs/examples").join(name)).unwrap();
    for name in ["experiment.yaml", "pipeline.yaml"] {
        let marker = format!("<!-- docs/examples/{name}: included verbatim");
        let at = spec
            .find(&marker)
            .unwrap_or_else(|| panic!("docs/spec.md does not include docs/examples/{name}"));
        let body = &spec[at..];
        let start = body.find("```yaml\n").unwrap() + "```yaml\n".len();
        let end = start + body[start..].find("```\n").unwrap();
        assert_eq!(
            &body[start..end],
            example(name),
            "docs/spec.md's copy of docs/examples/{name}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir_all(dir.path().join("experiments")).unwrap();
    fs::create_dir_all(dir.path().join("pipelines")).unwrap();
    fs::write(
        dir.path().join("experiments/eps09_sweep.yaml"),
        example("experiment.yaml"),
    )
    .unwrap();
    fs::write(
        dir.path().join("pipelines/example.yaml"),
        example("pipeline.yaml"),
    )
    .unwrap();
    let cat = repro::pipeline::Catalogue::load(dir.path()).unwrap();
    let reg = repro::stages::registry();
    for profile in ["ci", "small", "paper"] {
        let g = repro::pipeline::graph::plan(&cat, &["example".to_string()], profile, &reg)
            .unwrap_or_else(|e| panic!("docs/examples at profile {profile}: {e:#}"));
        assert!(
            g.nodes.iter().any(|n| n.kind == "plot"),
            "{profile}: no plot planned"
        );
    }
}
