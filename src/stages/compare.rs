//! `compare`: our fitted numbers against the paper's, with a verdict each.

use anyhow::{Context, Result, bail};
use arrow_array::{Array, Float64Array, RecordBatch, StringArray};
use serde::Deserialize;
use serde_json::Value;

use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{read_parquet_bytes, results, to_parquet_bytes};

/// `compare`: one row per paper value: quantity, ours, ours_err, paper, tolerance,
/// source (`figure` or `ref12`), verdict (`agree`, `disagree`, `out_of_reach`, `unreliable` when the fit's note
/// says its data cannot support the number, `missing`) and the reason.
pub struct Compare;

/// One number from the paper to check.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PaperValue {
    quantity: String,
    value: f64,
    /// Largest accepted |ours - paper|.
    tolerance: f64,
    /// A qualitative claim instead of a number: `above` (the paper states the
    /// quantity exceeds `value`; agree when ours > value + tolerance) or `below`.
    #[serde(default)]
    claim: Option<Claim>,
    /// With `claim`: compare with this other quantity of ours instead of `value`
    /// (e.g. a tail length that grows with phi: x0 at 0.78 above x0 at 0.60).
    #[serde(default)]
    than: Option<String>,
    /// Whether paper H measures the value in a figure (default) or quotes it
    /// from its reference 12; a column of the output, so a reader can tell.
    #[serde(default)]
    source: results::Source,
    /// The bound (with `claim`) or value is the project's own, not the
    /// paper's: a reading of a statement the paper makes without a number
    /// (`t06_drift < 0` for "no good collapse"), or a cross-check (mu / mu_E
    /// = 1); the reason and the verdict line say "criterion".
    #[serde(default)]
    criterion: bool,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Claim {
    Above,
    Below,
}

impl Claim {
    fn symbol(self) -> &'static str {
        match self {
            Claim::Above => ">",
            Claim::Below => "<",
        }
    }
}

/// The claim as a reason states it (`paper states > phi_c_10 (margin 0)`):
/// [`claim_in`] finds it there, so a verdict line names what it is against.
fn claim_text(c: Claim, name: &str, pval: &PaperValue) -> String {
    let opens = if pval.criterion {
        CRITERION_OPENS
    } else {
        CLAIM_OPENS
    };
    format!(
        "{opens}{} {name}{CLAIM_ENDS}{})",
        c.symbol(),
        pval.tolerance
    )
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareParams {
    paper: Vec<PaperValue>,
    /// Why this profile cannot reach a paper value (quantity -> explanation), set
    /// per profile in the spec. A disagreeing quantity listed here gets the verdict
    /// `out_of_reach` and the explanation in `reason`, so a small run says honestly
    /// that it is too small rather than that the physics is wrong.
    #[serde(default)]
    out_of_reach: std::collections::BTreeMap<String, String>,
    /// What a reader should know whatever the verdict (quantity -> note, e.g. that
    /// a fresh seed can land four quoted errors out), set per profile like
    /// `out_of_reach`: appended to the reason.
    #[serde(default)]
    caveats: std::collections::BTreeMap<String, String>,
    /// A short form of a quantity's reason (quantity -> text), set per
    /// profile like `out_of_reach`: what the figure's verdict line prints
    /// (column `short`; docs/plot.md).
    #[serde(default)]
    short: std::collections::BTreeMap<String, String>,
}

/// How a claim's reason states it: `paper states > chi4P_a06 (margin 0); ...`.
pub const CLAIM_OPENS: &str = "paper states ";
/// How a claim's reason states a bound of the project's own (`criterion`).
pub const CRITERION_OPENS: &str = "our criterion ";
const CLAIM_ENDS: &str = " (margin ";

/// The claim a row's reason states (`> chi4P_a06`, `< 3`), if it is a claim's:
/// a figure's verdict line names it instead of the bound's number alone.
pub fn claim_in(reason: &str) -> Option<&str> {
    let (_, rest) = reason
        .split_once(CLAIM_OPENS)
        .or_else(|| reason.split_once(CRITERION_OPENS))?;
    let (claim, _) = rest.split_once(CLAIM_ENDS)?;
    Some(claim)
}

/// Whether `text` opens with a claim's statement (the paper's or ours).
pub fn opens_claim(text: &str) -> bool {
    text.starts_with(CLAIM_OPENS) || text.starts_with(CRITERION_OPENS)
}

/// Whether a row's claim is a bound of the project's own (`criterion`).
pub fn is_criterion(reason: &str) -> bool {
    reason.contains(CRITERION_OPENS)
}

/// Where a row's paper value comes from, as the report prints it: the
/// paper's figure, its reference 12, or a criterion of our own.
pub fn source_label(c: &results::Compared) -> &'static str {
    if is_criterion(&c.reason) {
        "our criterion"
    } else {
        c.source.label()
    }
}

/// The column of the short reasons (empty where none is given).
pub const SHORT: &str = "short";

/// A column of `b` as f64 or strings, with a clear error.
fn f64_col<'a>(b: &'a RecordBatch, name: &str, label: &str) -> Result<&'a Float64Array> {
    b.column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
        .with_context(|| format!("input {label} has no float column '{name}' (fit tables need quantity, value, error)"))
}

fn str_col<'a>(b: &'a RecordBatch, name: &str, label: &str) -> Result<&'a StringArray> {
    b.column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<StringArray>())
        .with_context(|| format!("input {label} has no string column '{name}' (fit tables need quantity, value, error)"))
}

impl StageKind for Compare {
    type Params = CompareParams;
    fn name(&self) -> &str {
        "compare"
    }
    fn describe(&self) -> &str {
        "compare fitted quantities (tables quantity/value/error) with the paper's values"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<CompareParams> {
        let p: CompareParams = typed("compare", params)?;
        for (field, q) in p
            .out_of_reach
            .keys()
            .map(|q| ("out_of_reach", q))
            .chain(p.caveats.keys().map(|q| ("caveats", q)))
            .chain(p.short.keys().map(|q| ("short", q)))
        {
            if !p.paper.iter().any(|v| &v.quantity == q) {
                bail!("compare: {field} names '{q}', which is not one of the paper values");
            }
        }
        // Kept verbatim in `reason` and resolved by the report, from the store
        // (docs/spec.md, "Numbers in texts"): only their form is checked here.
        for (q, text) in p.out_of_reach.iter().chain(&p.caveats) {
            crate::table::references::references(text)
                .with_context(|| format!("compare: the reason of '{q}'"))?;
        }
        for v in &p.paper {
            if v.than.is_some() && v.claim.is_none() {
                bail!(
                    "compare: '{}' names `than` without a `claim` (above or below)",
                    v.quantity
                );
            }
            if !(v.tolerance >= 0.0 && v.tolerance.is_finite()) {
                bail!(
                    "compare: tolerance of '{}' must be a finite number >= 0, got {}",
                    v.quantity,
                    v.tolerance
                );
            }
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &CompareParams, inputs: &[Artifact]) -> Result<Output> {
        // (quantity, value, error, note); a note saying `unreliable` (a fit that
        // ran but whose numbers its data cannot support) makes the verdict.
        let mut ours: Vec<Ours> = Vec::new();
        for a in inputs {
            for b in read_parquet_bytes(a.read("parquet")?)?.0 {
                let (q, v, e) = (
                    str_col(&b, results::QUANTITY, &a.label)?,
                    f64_col(&b, results::VALUE, &a.label)?,
                    f64_col(&b, results::ERROR, &a.label)?,
                );
                let note = str_col(&b, results::NOTE, &a.label).ok();
                for r in 0..b.num_rows() {
                    let n = note.map_or(String::new(), |n| n.value(r).to_string());
                    ours.push((q.value(r).to_string(), v.value(r), e.value(r), n));
                }
            }
        }
        let (mut q, mut o, mut oe, mut pv, mut tol, mut verdict, mut reason) =
            (vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
        let source = p.paper.iter().map(|v| v.source).collect();
        for pval in &p.paper {
            let found = ours.iter().find(|(name, ..)| *name == pval.quantity);
            let (v, e, ver, why) = match found {
                None => (
                    f64::NAN,
                    f64::NAN,
                    "missing",
                    format!("no input reports '{}'", pval.quantity),
                ),
                Some((_, v, e, note)) if note.contains("unreliable") => {
                    let mut why = match p.out_of_reach.get(&pval.quantity) {
                        Some(reach) => format!("{note}; {reach}"),
                        None => note.clone(),
                    };
                    // An unreliable number of a claim still says what it was claimed against.
                    if let Some(c) = pval.claim {
                        let name = pval.than.clone().unwrap_or_else(|| pval.value.to_string());
                        why = format!("{why}; {}", claim_text(c, &name, pval));
                    }
                    (*v, *e, "unreliable", why)
                }
                Some(&(_, v, e, _)) => {
                    let d = (v - pval.value).abs();
                    if let Some(c) = pval.claim {
                        let (ver, why) =
                            judge_claim(c, pval, (v, e), &ours, p.out_of_reach.get(&pval.quantity));
                        (v, e, ver, why)
                    } else if d <= pval.tolerance {
                        (
                            v,
                            e,
                            "agree",
                            format!(
                                "|{} - {}| = {} <= {}",
                                significant(v),
                                pval.value,
                                digits(d, 3),
                                pval.tolerance
                            ),
                        )
                    } else {
                        let miss = format!(
                            "|{} - {}| = {} > {}",
                            significant(v),
                            pval.value,
                            digits(d, 3),
                            pval.tolerance
                        );
                        // Outside the tolerance by less than twice our error,
                        // the value may still lie inside it: as for a claim's
                        // order, such a miss is not resolved.
                        let beyond = d - pval.tolerance;
                        match p.out_of_reach.get(&pval.quantity) {
                            Some(why) => (v, e, "out_of_reach", format!("{why}; {miss}")),
                            None if e.is_finite() && e > 0.0 && beyond <= 2.0 * e => (
                                v,
                                e,
                                "unreliable",
                                format!(
                                    "{miss}, by {} ± {}, within twice its error: the disagreement is not resolved",
                                    digits(beyond, 2),
                                    digits(e, 2)
                                ),
                            ),
                            None => (v, e, "disagree", miss),
                        }
                    }
                }
            };
            // A value of our own choosing (a cross-check's 1) says so, as a
            // claim's criterion does.
            let why = if pval.criterion && pval.claim.is_none() {
                format!(
                    "{why}; {CRITERION_OPENS}{}, not a number of the paper",
                    pval.value
                )
            } else {
                why
            };
            q.push(pval.quantity.clone());
            o.push(v);
            oe.push(e);
            // A claim against another quantity shows that quantity as the paper's bound.
            let other = pval.than.as_ref().map(|q| ours.iter().find(|o| &o.0 == q));
            pv.push(other.map_or(pval.value, |o| o.map_or(f64::NAN, |o| o.1)));
            tol.push(pval.tolerance);
            verdict.push(ver.to_string());
            reason.push(match p.caveats.get(&pval.quantity) {
                Some(c) => format!("{why}; {c}"),
                None => why,
            });
        }
        let b = results::CompareColumns {
            quantity: q,
            ours: o,
            ours_err: oe,
            paper: pv,
            tolerance: tol,
            verdict,
            reason,
            source,
        }
        .batch()?;
        let short: Vec<String> = p
            .paper
            .iter()
            .map(|v| p.short.get(&v.quantity).cloned().unwrap_or_default())
            .collect();
        let mut fields: Vec<_> = b.schema().fields().iter().cloned().collect();
        fields.push(std::sync::Arc::new(arrow_schema::Field::new(
            SHORT,
            arrow_schema::DataType::Utf8,
            false,
        )));
        let mut columns = b.columns().to_vec();
        columns.push(std::sync::Arc::new(StringArray::from(short)));
        let b = RecordBatch::try_new(
            std::sync::Arc::new(arrow_schema::Schema::new(fields)),
            columns,
        )?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}

/// One of our numbers: (quantity, value, error, the fit's note).
type Ours = (String, f64, f64, String);

/// The verdict and reason of a claim (`above`/`below` a value or another of
/// our numbers) on our value `v` with error `e`.
fn judge_claim(
    c: Claim,
    pval: &PaperValue,
    (v, e): (f64, f64),
    ours: &[Ours],
    out_of_reach: Option<&String>,
) -> (&'static str, String) {
    let other = pval
        .than
        .as_ref()
        .and_then(|q| ours.iter().find(|o| &o.0 == q));
    let (bound, name) = match &pval.than {
        Some(q) => (other.map_or(f64::NAN, |o| o.1), q.clone()),
        None => (pval.value, pval.value.to_string()),
    };
    let ok = match c {
        Claim::Above => v > bound + pval.tolerance,
        Claim::Below => v < bound - pval.tolerance,
    };
    // An order of two of our numbers within twice their combined error is
    // not resolved, whichever way the central values fall. A bound given as
    // a value (no overlap: a gap above 0) is judged as stated.
    let sigma = other.map_or(f64::NAN, |o| e.hypot(o.2));
    let margin = match c {
        Claim::Above => v - bound - pval.tolerance,
        Claim::Below => bound - pval.tolerance - v,
    };
    let unresolved = sigma.is_finite() && sigma > 0.0 && margin.abs() <= 2.0 * sigma;
    let why = format!(
        "{}; ours {} against {}",
        claim_text(c, &name, pval),
        significant(v),
        significant(bound)
    );
    // A claim against a number its data cannot support (a phi_c on the last
    // point) cannot be judged either.
    let bound_note = other
        .map(|o| o.3.as_str())
        .filter(|n| n.contains("unreliable"));
    match (ok, out_of_reach) {
        _ if bound_note.is_some() => (
            "unreliable",
            format!("{name} is {}; {why}", bound_note.unwrap_or_default()),
        ),
        _ if unresolved => (
            "unreliable",
            format!(
                "{why}; the difference, {} ± {}, lies within twice its error: the order is not resolved",
                digits(margin, 2),
                digits(sigma, 2)
            ),
        ),
        (true, _) => ("agree", why),
        (false, Some(r)) => ("out_of_reach", format!("{r}; {why}")),
        (false, None) => ("disagree", why),
    }
}

/// `v` to five significant digits for the reason text (the full value is in the
/// `ours` column): 1.4581683449 -> 1.4582, 0.000123456 -> 0.00012346.
fn significant(v: f64) -> String {
    digits(v, 5)
}

/// `v` to `n` significant digits: plain decimals from 0.001 to 10^6, otherwise
/// `1.93e-14` (trailing zeros of the mantissa dropped), never 17 digits.
pub(super) fn digits(v: f64, n: i32) -> String {
    if !v.is_finite() || v == 0.0 {
        return (v + 0.0).to_string();
    }
    let e = v.abs().log10().floor() as i32;
    if !(-3..6).contains(&e) {
        let m = format!("{:.*e}", (n - 1).max(0) as usize, v);
        return match m.split_once('e') {
            Some((mant, exp)) if mant.contains('.') => {
                format!("{}e{exp}", mant.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => m,
        };
    }
    let decimals = (n - 1 - e).clamp(0, 17) as usize;
    format!("{v:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::{Compare, claim_in, digits, significant};
    use crate::pipeline::{Kind, StageCtx};
    use crate::stages::tables::Columns;
    use crate::stages::test_support::{artifact, yaml};
    use crate::table::read_parquet_bytes;
    use crate::table::results::{REASON, SOURCE, VERDICT, quantity_batch};

    /// Verdicts against the paper: inside the tolerance agrees, outside
    /// disagrees unless the profile says it is out of reach; a caveat is
    /// appended to the reason whatever the verdict.
    /// The compare table of `params` over `inputs`, as columns.
    fn compared(params: &serde_json::Value, inputs: &[crate::pipeline::Artifact]) -> Columns {
        let ctx = StageCtx::new(0, "compare".into(), None);
        let out = Compare.run_params(&ctx, params, inputs).unwrap();
        let (b, _) = read_parquet_bytes(out.files["parquet"].clone()).unwrap();
        Columns::from_batch(&b[0]).unwrap()
    }

    #[test]
    fn verdicts_follow_the_tolerance_and_caveats_reach_the_reason() {
        let dir = tempfile::tempdir().unwrap();
        let rows = [
            ("a".to_string(), 1.55, 0.1),
            ("b".to_string(), 2.0, 0.1),
            ("c".to_string(), 3.0, 0.1),
        ];
        let fit = artifact(
            dir.path(),
            "fit",
            quantity_batch(&[], &rows, "", None).unwrap(),
        );
        let params = yaml(
            "paper:\n\
             - {quantity: a, value: 1.6, tolerance: 0.3, source: ref12}\n\
             - {quantity: b, value: 1.0, tolerance: 0.3}\n\
             - {quantity: c, value: 1.0, tolerance: 0.3}\n\
             - {quantity: d, value: 1.0, tolerance: 0.3}\n\
             out_of_reach: {c: needs a bigger box}\n\
             caveats: {a: one seed in twenty lands 4 errors out}\n",
        );
        Compare.validate(&params).unwrap();
        let mut bad = params.clone();
        bad["caveats"] = yaml("{e: x}");
        let e = Compare.validate(&bad).unwrap_err().to_string();
        assert!(e.contains("caveats names 'e'"), "{e}");
        let mut bad = params.clone();
        bad["paper"][0]["source"] = yaml("ref13");
        let e = format!("{:#}", Compare.validate(&bad).unwrap_err());
        assert!(e.contains("ref13") && e.contains("ref12"), "{e}");
        let c = compared(&params, &[fit]);
        assert_eq!(
            c.str[VERDICT],
            ["agree", "disagree", "out_of_reach", "missing"]
        );
        // The source column: ref12 where the value says so, figure by default.
        assert_eq!(c.str[SOURCE], ["ref12", "figure", "figure", "figure"]);
        let reason = &c.str[REASON];
        assert!(
            reason[0].starts_with("|1.5500 - 1.6| = 0.0500 <= 0.3; one seed in twenty"),
            "{}",
            reason[0]
        );
        assert!(
            reason[2].starts_with("needs a bigger box; |3.0000 - 1|"),
            "{}",
            reason[2]
        );
        assert!(reason[3].contains("no input reports 'd'"), "{}", reason[3]);
    }

    /// A claim against a bound that is itself unreliable (phi_c_08 > phi_c_09
    /// while phi_c_09 falls on the last point) is unreliable, whichever way
    /// the numbers lie; against a reliable bound it is judged.
    #[test]
    fn a_claim_against_an_unreliable_bound_is_unreliable() {
        let dir = tempfile::tempdir().unwrap();
        let on_last = "unreliable: phi_c = 0.783: it falls on the last point";
        let weak = artifact(
            dir.path(),
            "weak",
            quantity_batch(&[], &[("c10".to_string(), 0.783, 0.001)], on_last, None).unwrap(),
        );
        let firm = artifact(
            dir.path(),
            "firm",
            quantity_batch(
                &[],
                &[
                    ("c09".to_string(), 0.80, 0.002),
                    ("c08".to_string(), 0.81, 0.002),
                ],
                "",
                None,
            )
            .unwrap(),
        );
        let params = yaml(
            "paper:\n\
             - {quantity: c09, claim: above, than: c10, value: 0, tolerance: 0}\n\
             - {quantity: c08, claim: above, than: c09, value: 0, tolerance: 0}\n",
        );
        let c = compared(&params, &[weak, firm]);
        assert_eq!(c.str[VERDICT], ["unreliable", "agree"]);
        assert!(
            c.str[REASON][0].starts_with("c10 is unreliable: phi_c = 0.783"),
            "{}",
            c.str[REASON][0]
        );
        // Each reason names its claim, for the figure's verdict line.
        assert_eq!(claim_in(&c.str[REASON][0]), Some("> c10"));
        assert_eq!(claim_in(&c.str[REASON][1]), Some("> c09"));
    }

    /// An order within twice the combined errors is not resolved, whichever
    /// way the central values fall: 0.81 +- 0.02 above 0.80 +- 0.002 is
    /// unreliable, 0.81 +- 0.002 above it agrees, 0.79 +- 0.002 disagrees.
    #[test]
    fn a_claim_within_twice_the_errors_is_not_resolved() {
        let dir = tempfile::tempdir().unwrap();
        let fit = artifact(
            dir.path(),
            "fit",
            quantity_batch(
                &[],
                &[
                    ("base".to_string(), 0.80, 0.002),
                    ("close".to_string(), 0.81, 0.02),
                    ("far".to_string(), 0.81, 0.002),
                    ("under".to_string(), 0.79, 0.002),
                ],
                "",
                None,
            )
            .unwrap(),
        );
        let params = yaml(
            "paper:\n\
             - {quantity: close, claim: above, than: base, value: 0, tolerance: 0}\n\
             - {quantity: far, claim: above, than: base, value: 0, tolerance: 0}\n\
             - {quantity: under, claim: above, than: base, value: 0, tolerance: 0}\n",
        );
        let c = compared(&params, &[fit]);
        assert_eq!(c.str[VERDICT], ["unreliable", "agree", "disagree"]);
        assert!(
            c.str[REASON][0].contains("not resolved"),
            "{}",
            c.str[REASON][0]
        );
        assert_eq!(claim_in(&c.str[REASON][0]), Some("> base"));
    }

    /// A value outside the tolerance disagrees only when it lies outside by
    /// more than twice its error: 1.13 +- 0.31 against 1.6 +- 0.3 is not
    /// resolved, 1.13 +- 0.05 disagrees, 1.5 +- 0.31 agrees, and a value
    /// without an error is judged as stated.
    #[test]
    fn a_value_outside_the_tolerance_within_twice_its_error_is_not_resolved() {
        let dir = tempfile::tempdir().unwrap();
        let fit = artifact(
            dir.path(),
            "fit",
            quantity_batch(
                &[],
                &[
                    ("wide".to_string(), 1.13, 0.31),
                    ("narrow".to_string(), 1.13, 0.05),
                    ("inside".to_string(), 1.5, 0.31),
                    ("exact".to_string(), 1.13, f64::NAN),
                ],
                "",
                None,
            )
            .unwrap(),
        );
        let params = yaml(
            "paper:\n\
             - {quantity: wide, value: 1.6, tolerance: 0.3}\n\
             - {quantity: narrow, value: 1.6, tolerance: 0.3}\n\
             - {quantity: inside, value: 1.6, tolerance: 0.3}\n\
             - {quantity: exact, value: 1.6, tolerance: 0.3}\n",
        );
        let c = compared(&params, &[fit]);
        assert_eq!(
            c.str[VERDICT],
            ["unreliable", "disagree", "agree", "disagree"]
        );
        assert!(
            c.str[REASON][0].contains("not resolved"),
            "{}",
            c.str[REASON][0]
        );
    }

    /// A claim whose own number is unreliable (phi_c_09 on its last point,
    /// claimed above phi_c_10) keeps the fit's note and still names the claim.
    #[test]
    fn an_unreliable_claim_names_what_it_is_against() {
        let dir = tempfile::tempdir().unwrap();
        let on_last = "unreliable: phi_c = 0.789: it falls on the last point";
        let weak = artifact(
            dir.path(),
            "weak",
            quantity_batch(&[], &[("c09".to_string(), 0.789, 0.003)], on_last, None).unwrap(),
        );
        let firm = artifact(
            dir.path(),
            "firm",
            quantity_batch(&[], &[("c10".to_string(), 0.783, 0.002)], "", None).unwrap(),
        );
        let params =
            yaml("paper:\n- {quantity: c09, claim: above, than: c10, value: 0, tolerance: 0}\n");
        let c = compared(&params, &[weak, firm]);
        assert_eq!(c.str[VERDICT], ["unreliable"]);
        assert!(
            c.str[REASON][0].starts_with(on_last),
            "{}",
            c.str[REASON][0]
        );
        assert_eq!(claim_in(&c.str[REASON][0]), Some("> c10"));
    }

    #[test]
    fn reasons_quote_five_significant_digits() {
        assert_eq!(significant(1.458168344974518), "1.4582");
        assert_eq!(significant(-0.000123456789), "-1.2346e-4");
        assert_eq!(significant(1.93e-14), "1.93e-14");
        assert_eq!(significant(-1e-10), "-1e-10");
        assert_eq!(significant(0.0123456), "0.012346");
        assert_eq!(digits(2.518e-2, 3), "0.0252");
        assert_eq!(digits(12.83, 3), "12.8");
        assert_eq!(significant(3.364382336836832), "3.3644");
        assert_eq!(significant(12345.678), "12346");
        assert_eq!(significant(0.0), "0");
        assert_eq!(significant(f64::NAN), "NaN");
    }
}
