//! The verdict line a figure prints under its panels for each compared
//! number (docs/plot.md, "The verdict line"): the paper's value and where it
//! comes from, ours with its error, the verdict and a short reason.

use serde::Deserialize;

use crate::table::references::{legend_number, value_with_error};

/// What a figure's compared values are, as its verdict lines name them.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Against {
    #[default]
    Paper,
    Target,
}

impl Against {
    fn word(self) -> &'static str {
        match self {
            Against::Paper => "paper",
            Against::Target => "target",
        }
    }
}

/// A paper's value as the paper writes it: the legend's short form where that
/// is the same number (1.00, 0.82), else every digit (16.51, not 17).
fn paper_number(v: f64) -> String {
    let short = legend_number(v);
    if short.parse::<f64>().is_ok_and(|x| x == v) {
        short
    } else {
        format!("{v}")
    }
}

/// The longest short reason a verdict line prints, in characters; a longer
/// first clause is cut at a word and ends in "…". A `short` must fit
/// (tests/texts.rs).
pub const SHORT_CHARS: usize = 90;

/// Where a paper value comes from, as a verdict line says it: quoted in paper
/// H from its reference 12; nothing for a value it measures in a figure.
pub(super) fn provenance(source: crate::table::results::Source) -> &'static str {
    match source {
        crate::table::results::Source::Figure => "",
        crate::table::results::Source::Ref12 => "quoted, ref. 12",
    }
}

/// `quantity: paper P (provenance); ours V ± E; verdict[: short reason]`,
/// the reason only where the verdict is not `agree`: the given short form,
/// else the reason's first clause (up to "; "), cut to [`SHORT_CHARS`].
pub(super) fn verdict_line(
    c: &crate::table::results::Compared,
    short: &str,
    provenance: &str,
    against: Against,
) -> String {
    use crate::table::results::Verdict;
    let word = against.word();
    // A claim names what it is against: `paper > chi4P_a06 (3.3)`, `paper < 3`.
    // A bound of the project's own reading says so, not "paper".
    let word = if super::compare::is_criterion(&c.reason) {
        "criterion"
    } else {
        word
    };
    let paper = match super::compare::claim_in(&c.reason) {
        Some(claim)
            if claim
                .split_once(' ')
                .is_some_and(|(_, b)| b.parse::<f64>().is_ok()) =>
        {
            format!("{word} {claim}")
        }
        // Against another of our numbers: printed as ours are, not as a
        // paper's value is written.
        Some(claim) => format!("{word} {claim} ({})", legend_number(c.paper)),
        None => format!("{word} {}", paper_number(c.paper)),
    };
    let paper = if provenance.is_empty() {
        paper
    } else {
        format!("{paper} ({provenance})")
    };
    let ours = if c.ours.is_finite() {
        format!("ours {}", value_with_error(c.ours, c.ours_err))
    } else {
        "ours: none".to_string()
    };
    let mut line = format!("{}: {paper}; {ours}; {}", c.quantity, c.verdict.label());
    if c.verdict != Verdict::Agree {
        // A miss opens with its arithmetic (`|ours - paper| = d > tol`), on the
        // line already: the reason is the clause after it, where there is one.
        let reason = match c.reason.split_once("; ") {
            Some((miss, rest)) if miss.starts_with('|') && !rest.trim().is_empty() => rest,
            _ => c.reason.as_str(),
        };
        let why = if short.is_empty() {
            first_clause(reason)
        } else {
            short.to_string()
        };
        // A fit's own note may open with the verdict ("unreliable: ..."): once.
        let label = c.verdict.label();
        let why = why
            .trim()
            .strip_prefix(label)
            .and_then(|w| w.strip_prefix(':'))
            .map_or(why.clone(), |w| w.trim().to_string());
        // A claim's own statement is already the line's `paper` part; an
        // order it does not resolve says so (its reason's last clause).
        let why = match c.reason.rsplit_once("; ") {
            Some((_, last))
                if super::compare::opens_claim(why.trim()) && last.contains("not resolved") =>
            {
                last.to_string()
            }
            _ => why,
        };
        // A value outside the tolerance by less than twice its error says
        // so before its reason (its miss, on the line, does not).
        let miss = c
            .reason
            .split_once("; ")
            .map_or(c.reason.as_str(), |(m, _)| m);
        let why = match (
            miss.starts_with('|') && miss.contains("not resolved"),
            why.trim(),
        ) {
            (false, _) => why,
            // Nothing beyond the miss itself: its verdict is the reason.
            (true, w) if w.is_empty() || w.starts_with('|') => "not resolved".to_string(),
            (true, w) => format!("not resolved; {w}"),
        };
        if !super::compare::opens_claim(why.trim()) {
            line.push_str(": ");
            line.push_str(&cut(&before_reference(why.trim()), SHORT_CHARS));
        }
    } else if !short.is_empty() {
        // An agreement a reader must not take at face value (a held input)
        // says why, where the pipeline gives a short reason for it.
        line.push_str(": ");
        line.push_str(&cut(short.trim(), SHORT_CHARS));
    }
    line
}

/// The first clause of a reason: its text up to the first ";" outside
/// brackets, without the bracketed asides (the commands and details the
/// report keeps).
fn first_clause(reason: &str) -> String {
    let mut out = String::new();
    let mut depth = 0usize;
    for ch in reason.chars() {
        match ch {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            ';' if depth == 0 => break,
            c if depth == 0 => out.push(c),
            _ => {}
        }
    }
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A reason with its quotations of the paper printed and cut before its first
/// reference to a build (`{=...}`: the report resolves those, a figure's face
/// must not show them raw).
fn before_reference(text: &str) -> String {
    let (head, cut) = match text.find("{=") {
        Some(k) => (text[..k].trim_end_matches([',', ':', ' ', '(']), true),
        None => (text, false),
    };
    let head = crate::table::references::quotations(head).unwrap_or_else(|_| head.to_string());
    if cut { format!("{head}…") } else { head }
}

/// `text` cut to at most `n` characters at a word, ending in "…" if cut.
fn cut(text: &str, n: usize) -> String {
    if text.chars().count() <= n {
        return text.to_string();
    }
    let head: String = text.chars().take(n).collect();
    let at = head.rfind(' ').unwrap_or(head.len());
    format!("{}…", head[..at].trim_end_matches([',', ':', ' ']))
}
