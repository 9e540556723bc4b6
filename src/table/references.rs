//! Numbers in texts (docs/spec.md, "Numbers in texts"): `{=...}` references to
//! a build's tables and parameters, `{paper:...}` quotations of the paper, and
//! the rule that finds a number typed by hand. Parsing and printing live here;
//! where a value comes from is the caller's [`Lookup`]: a plot's gathered
//! tables ([`crate::stages::plot`]), or the store for `repro report` and
//! `repro coverage` ([`crate::study::built`]).

use anyhow::{Context, Result, bail};
use serde_json::Value;

/// One `{=...}`: `[PROFILE:][FIGURE/]NAME.FIELD[@COLUMN=VALUE,...][:FORMAT]`, or
/// `{=profile}`.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    /// Another profile's build (`small:`); None: the text's own profile.
    pub profile: Option<String>,
    /// Another figure's build (`fig4/`); None: the text's own figure.
    pub figure: Option<String>,
    pub target: Target,
    pub format: Format,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// `{=profile}`: the build's profile.
    Profile,
    /// `NAME.FIELD`: an experiment's parameter, or a stage's quantity (a fit
    /// table's row) or column, at the row whose columns equal the values of
    /// `row` (empty: the table's one row).
    Field {
        name: String,
        field: String,
        row: Vec<(String, f64)>,
    },
}

/// How a number prints: `:value` drops the error, `:.N` fixes the decimals.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Format {
    pub value_only: bool,
    pub decimals: Option<usize>,
}

/// What a [`Lookup`] found for a reference.
#[derive(Clone, Debug, PartialEq)]
pub enum Resolved {
    /// A table's value and its error (NaN: the table has none).
    Number { value: f64, error: f64 },
    /// A parameter (a number or a list of them), printed as written.
    Param(Value),
    /// The profile's name.
    Text(String),
    /// That build is not in the store: said so in the text, never an old number.
    NotBuilt { profile: String, figure: String },
}

/// Where the values of references come from.
pub trait Lookup {
    /// The value of `r`, or an error saying why `r` cannot be right (an unknown
    /// stage, quantity or row); a build not in the store is [`Resolved::NotBuilt`].
    fn resolve(&self, r: &Reference) -> Result<Resolved>;
}

impl Reference {
    /// Parse the inside of `{=...}`.
    pub fn parse(key: &str) -> Result<Reference> {
        let bad = |why: &str| {
            anyhow::anyhow!(
                "`{{={key}}}`: {why} (the form is [PROFILE:][FIGURE/]NAME.FIELD[@COLUMN=VALUE,...][:FORMAT], docs/spec.md)"
            )
        };
        let mut rest = key;
        let mut profile = None;
        if let Some((p, r)) = rest.split_once(':')
            && !p.contains(['.', '/', '@'])
        {
            profile = Some(word(p).ok_or_else(|| bad("the profile is not a name"))?);
            rest = r;
        }
        let mut format = Format::default();
        if let Some((r, f)) = rest.split_once(':') {
            format = Format::parse(f)
                .ok_or_else(|| bad("the format is `value`, `.N` or `value.N` (N decimals)"))?;
            rest = r;
        }
        let mut row = Vec::new();
        if let Some((r, sel)) = rest.split_once('@') {
            for one in sel.split(',') {
                let (col, v) = one
                    .split_once('=')
                    .ok_or_else(|| bad("a row is selected as @COLUMN=VALUE[,COLUMN=VALUE]"))?;
                let v: f64 = v
                    .trim()
                    .parse()
                    .map_err(|_| bad("the row's VALUE is not a number"))?;
                row.push((
                    word(col.trim()).ok_or_else(|| bad("the row's COLUMN is not a name"))?,
                    v,
                ));
            }
            rest = r;
        }
        let mut figure = None;
        if let Some((f, r)) = rest.split_once('/') {
            figure = Some(word(f).ok_or_else(|| bad("the figure is not a name"))?);
            rest = r;
        }
        let target = if rest == "profile" && row.is_empty() {
            Target::Profile
        } else {
            let (name, field) = rest
                .split_once('.')
                .ok_or_else(|| bad("no `.` between the stage (or experiment) and the quantity"))?;
            Target::Field {
                name: word(name).ok_or_else(|| bad("the stage is not a name"))?,
                field: word(field).ok_or_else(|| bad("the quantity is not a name"))?,
                row,
            }
        };
        Ok(Reference {
            profile,
            figure,
            target,
            format,
        })
    }

    /// Whether it names the text's own build (no other profile or figure).
    pub fn is_local(&self) -> bool {
        self.profile.is_none() && self.figure.is_none()
    }
}

/// `s` if it is a name: letters, digits, `_` and `-`.
fn word(s: &str) -> Option<String> {
    let ok = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    ok.then(|| s.to_string())
}

impl Format {
    fn parse(f: &str) -> Option<Format> {
        let (value_only, rest) = match f.strip_prefix("value") {
            Some(r) => (true, r),
            None => (false, f),
        };
        let decimals = match rest {
            "" => None,
            r => Some(r.strip_prefix('.')?.parse().ok()?),
        };
        (value_only || decimals.is_some()).then_some(Format {
            value_only,
            decimals,
        })
    }

    fn number(self, v: f64, e: f64) -> String {
        match (self.value_only, self.decimals) {
            (true, None) => format!("{v}"),
            (true, Some(d)) => format!("{v:.d$}"),
            (false, Some(d)) if e.is_finite() && e > 0.0 => format!("{v:.d$} ± {e:.d$}"),
            (false, Some(d)) => format!("{v:.d$}"),
            (false, None) => value_with_error(v, e),
        }
    }
}

/// A group value as a legend shows it: three decimals tell phi (0.785) or t0 apart,
/// and values below 10 keep two (0.60, 0.65) so a column of phi reads evenly.
pub fn legend_number(v: f64) -> String {
    let r = (v * 1e3).round() / 1e3;
    if r.abs() >= 10.0 {
        // Times and sizes: to the unit (t0 = 29, not 29.333).
        format!("{v:.0}")
    } else if r == 0.0 {
        format!("{r}")
    } else if ((r * 1e2).round() / 1e2 - r).abs() < 1e-12 {
        format!("{r:.2}")
    } else if r.abs() >= 1.0 {
        // A time between 1 and 10 off a round value (t0 = 7.333): one decimal.
        format!("{r:.1}")
    } else {
        format!("{r:.3}")
    }
}

/// A fitted value as a legend shows it: the error to one significant digit (two
/// when that digit is 1) and the value to the same decimal (`0.80 ± 0.01`).
pub fn value_with_error(v: f64, e: f64) -> String {
    // A fit that failed at this profile has no number to print.
    if !v.is_finite() {
        return "(no fit)".into();
    }
    // No error, or one at the floating-point rounding of the value (an
    // identity such as S4(q = 0) / chi4): the value alone, not fifteen digits.
    // Without an error the legend's rounding could hide a miss (1.044 printed
    // as 1.0 against a tolerance of 0.04): four significant digits where it
    // moves the value by more than 0.2%.
    if !(e.is_finite() && e > 1e-9 * v.abs()) {
        let short = legend_number(v);
        if short
            .parse::<f64>()
            .is_ok_and(|x| (x - v).abs() <= 2e-3 * v.abs())
            || v == 0.0
        {
            return short;
        }
        let d = (3.0 - v.abs().log10().floor()).max(0.0) as usize;
        return format!("{v:.d$}").replacen('-', "−", 1);
    }
    // A value far below one (a precision, an energy drift): mantissas with a
    // common power of ten, not a run of zeros.
    if v.abs().max(e) < 1e-4 {
        let p = v.abs().max(e).log10().floor();
        let s = 10f64.powf(-p);
        let power = format!("{}", p as i64).replacen('-', "−", 1);
        return format!("({}) × 10^{{{power}}}", value_with_error(v * s, e * s));
    }
    let mut digits = -e.log10().floor();
    if e * 10f64.powf(digits) < 2.0 {
        digits += 1.0;
    }
    let d = digits.max(0.0) as usize;
    // A typeset minus, as in the axis labels.
    format!("{v:.d$} ± {e:.d$}").replacen('-', "−", 1)
}

/// A parameter as a text states it: integers as integers (N = 1000), a list
/// joined by commas.
pub fn param_text(v: &Value) -> String {
    match v {
        Value::Array(xs) => xs.iter().map(param_text).collect::<Vec<_>>().join(", "),
        Value::String(s) => s.clone(),
        _ => match v.as_f64() {
            Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => format!("{}", x as i64),
            Some(x) => format!("{x}"),
            None => v.to_string(),
        },
    }
}

/// The text a resolved reference prints.
fn print(r: &Reference, found: Resolved) -> String {
    match found {
        Resolved::Number { value, error } => r.format.number(value, error),
        Resolved::Param(v) => match (v.as_f64(), r.format.decimals) {
            (Some(x), Some(d)) => format!("{x:.d$}"),
            _ => param_text(&v),
        },
        Resolved::Text(t) => t,
        Resolved::NotBuilt { profile, figure } => format!("[{profile}: {figure} not built]"),
    }
}

/// `text` with every `{=...}` resolved by `lookup` and every `{paper:X}`
/// printed as X (which must be a number as the paper writes it).
pub fn render(text: &str, lookup: &dyn Lookup) -> Result<String> {
    // A quotation prints a number, never a brace: one pass per kind is the same
    // as one over both.
    let quoted = replace_marked(text, "{paper:", |inner| {
        if inner.trim().parse::<f64>().is_err() {
            bail!("`{{paper:{inner}}}`: a quotation is one number as the paper writes it");
        }
        Ok(inner.to_string())
    });
    replace_marked(&quoted?, "{=", |inner| {
        let r = Reference::parse(inner)?;
        let found = lookup
            .resolve(&r)
            .with_context(|| format!("`{{={inner}}}`"))?;
        Ok(print(&r, found))
    })
    .with_context(|| format!("in \"{text}\""))
}

/// `text` with each `OPEN...}` replaced by `f` of what stands between.
fn replace_marked(
    text: &str,
    open: &str,
    mut f: impl FnMut(&str) -> Result<String>,
) -> Result<String> {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find(open) {
        let end = rest[i..]
            .find('}')
            .with_context(|| format!("`{open}` without `}}`"))?;
        out.push_str(&rest[..i]);
        out.push_str(&f(&rest[i + open.len()..i + end])?);
        rest = &rest[i + end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// `text` with its `{paper:X}` quotations printed, for a text that names no
/// build (a pipeline's `description`, a stage's `describes`): a `{=...}` there
/// is an error.
pub fn quotations(text: &str) -> Result<String> {
    struct NoBuild;
    impl Lookup for NoBuild {
        fn resolve(&self, _: &Reference) -> Result<Resolved> {
            bail!("a description names no build: state a measured number in a reason or a note")
        }
    }
    render(text, &NoBuild)
}

/// Every `{=...}` of `text`, parsed (for a check before anything is built).
pub fn references(text: &str) -> Result<Vec<Reference>> {
    let mut out = Vec::new();
    replace_marked(text, "{=", |inner| {
        out.push(Reference::parse(inner)?);
        Ok(String::new())
    })
    .with_context(|| format!("in \"{text}\""))?;
    Ok(out)
}

/// `text` with `{reason:ID}` replaced by `reasons[ID]` (a pipeline's shared
/// paragraphs); the ids used are added to `used`.
pub fn expand_reasons(
    text: &str,
    reasons: &std::collections::BTreeMap<String, String>,
    used: &mut std::collections::BTreeSet<String>,
) -> Result<String> {
    replace_marked(text, "{reason:", |id| {
        let body = reasons.get(id).with_context(|| {
            format!(
                "`{{reason:{id}}}`: no such id in `reasons:` (it has: {})",
                reasons.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })?;
        used.insert(id.to_string());
        Ok(body.clone())
    })
}

/// The keys whose texts are prose: every string below them states no number
/// by hand ([`typed_numbers`]).
pub const PROSE_KEYS: &[&str] = &[
    "description",
    "describes",
    "title",
    "label",
    "notes",
    "absent",
    "out_of_reach",
    "caveats",
    "error_coverage",
    "reasons",
];

/// Words after which numbers name a part of a paper, not a measurement.
const PART_WORDS: &[&str] = &["Eq", "Eqs", "Fig", "Figs", "Sec", "Section", "Table", "Ref"];

/// Part words whose numbers may have decimal parts: a subsection (`Sec. 4.1`).
const SECTION_WORDS: &[&str] = &["Sec", "Section"];

/// The numbers typed by hand into `text`: after removing `{=...}`,
/// `{paper:...}`, `{reason:...}` and code spans in backticks, every number
/// that is not part of a word, except single digits, the numbers of
/// [`PART_WORDS`] (`Eqs. 14 and 15`; a subsection after [`SECTION_WORDS`],
/// `Sec. 4.1`) and a year in parentheses (docs/spec.md).
pub fn typed_numbers(text: &str) -> Vec<String> {
    let c: Vec<char> = strip_marked(text).chars().collect();
    let is_word = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut out = Vec::new();
    // Inside the list of numbers after a part word (`Figs. 4, 5 and 7`).
    let mut in_parts = false;
    // Inside the list after a section word, where a subsection is a part too
    // (`Section 3.2 and 4.1`).
    let mut in_sections = false;
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch.is_ascii_digit() {
            let mut j = i;
            while j < c.len() && c[j].is_ascii_digit() {
                j += 1;
            }
            let integer = j;
            if j + 1 < c.len() && c[j] == '.' && c[j + 1].is_ascii_digit() {
                j += 1;
                while j < c.len() && c[j].is_ascii_digit() {
                    j += 1;
                }
            }
            let sign = usize::from(j + 1 < c.len() && matches!(c[j + 1], '-' | '+'));
            if j + 1 + sign < c.len()
                && matches!(c[j], 'e' | 'E')
                && c[j + 1 + sign].is_ascii_digit()
            {
                j += 1 + sign;
                while j < c.len() && c[j].is_ascii_digit() {
                    j += 1;
                }
            }
            if j < c.len() && is_word(c[j]) {
                // A word that starts with a digit (`2D`, `4a`, a commit hash).
                while j < c.len() && is_word(c[j]) {
                    j += 1;
                }
                i = j;
                continue;
            }
            let token: String = c[i..j].iter().collect();
            let plain_integer = integer == j;
            let year = plain_integer
                && token.len() == 4
                && (1900..=2099).contains(&token.parse::<u32>().unwrap_or(0))
                && i > 0
                && c[i - 1] == '('
                && c.get(j) == Some(&')');
            let section = in_sections && !token.contains(['e', 'E']);
            let allowed = (plain_integer && (token.len() == 1 || in_parts)) || section || year;
            if !allowed {
                out.push(token);
            }
            i = j;
        } else if is_word(ch) {
            let mut j = i;
            while j < c.len() && is_word(c[j]) {
                j += 1;
            }
            let w: String = c[i..j].iter().collect();
            in_parts = PART_WORDS.contains(&w.as_str()) || (in_parts && w == "and");
            in_sections = SECTION_WORDS.contains(&w.as_str()) || (in_sections && w == "and");
            i = j;
        } else {
            // Separators continue a list of parts; anything else ends it.
            if !(ch.is_whitespace() || matches!(ch, '.' | ',' | '-' | '–' | '(' | ')')) {
                in_parts = false;
                in_sections = false;
            }
            i += 1;
        }
    }
    out
}

/// `text` with its references, quotations, shared reasons and code spans
/// blanked (each replaced by a space).
fn strip_marked(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    loop {
        let next = ["{=", "{paper:", "{reason:", "`"]
            .iter()
            .filter_map(|m| rest.find(m).map(|i| (i, *m)))
            .min();
        let Some((i, m)) = next else { break };
        let close = if m == "`" { '`' } else { '}' };
        out.push_str(&rest[..i]);
        out.push(' ');
        match rest[i + m.len()..].find(close) {
            Some(e) => rest = &rest[i + m.len() + e + 1..],
            None => {
                rest = "";
                break;
            }
        }
    }
    out.push_str(rest);
    out
}

/// Every prose string of a pipeline (strings below [`PROSE_KEYS`], at any
/// depth), with its path (`stages.figure.params.panels.notes`).
pub fn prose(doc: &Value) -> Vec<(String, String)> {
    fn walk(v: &Value, path: &str, prose: bool, out: &mut Vec<(String, String)>) {
        match v {
            Value::String(s) if prose => out.push((path.to_string(), s.clone())),
            Value::Array(xs) => {
                for x in xs {
                    // A stage is named in the path by its name, not its index.
                    match x.get("name").and_then(Value::as_str) {
                        Some(n) => walk(x, &format!("{path}[{n}]"), prose, out),
                        None => walk(x, path, prose, out),
                    }
                }
            }
            Value::Object(m) => {
                for (k, x) in m {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    walk(x, &p, prose || PROSE_KEYS.contains(&k.as_str()), out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(doc, "", false, &mut out);
    out
}

#[cfg(test)]
#[path = "references_tests.rs"]
mod tests;
