//! `fit` and `collapse`: fitted numbers as tables `quantity, value, error, note`
//! (what `compare` reads), plus the drawn fit line or the rescaled data.
//!
//! A fit that fails (no divergence found, too few points, curves that do not
//! overlap) does not fail the stage: its quantities are NaN and `note` says why,
//! so the figure is still drawn and `compare` reports the number as missing.

use std::collections::BTreeMap;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray};
use serde::Deserialize;
use serde_json::Value;

use super::tables::{Columns, Where, inputs_of, pick, source_stages};
use crate::analysis::pool;
use crate::fit::catalogue::{self, Form};
use crate::fit::collapse::{self, Curve};
use crate::fit::ranges::range_scan;
use crate::fit::rescalings::{self, At, Rescaling};
use crate::fit::{Data, FitError, FitResult, linear};
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};

const MODULES: &[&str] = &[
    "fit",
    "table",
    "stages/fits",
    "stages/tables",
    "analysis/pool",
];

/// A number taken from another fit table of the same stage's inputs.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FromQuantity {
    pub stage: String,
    pub quantity: String,
}

impl FromQuantity {
    fn get(&self, kind: &str, inputs: &[Artifact]) -> Result<f64> {
        let c = Columns::read(&inputs_of(kind, inputs, &self.stage)?)?;
        Ok(c.quantity(&self.quantity)?.0)
    }

    /// The number's replica jackknife refits (`jackknife.parquet` of its fit), if
    /// it has them: its value with each replica of each unit left out.
    fn jackknife(&self, kind: &str, inputs: &[Artifact]) -> Result<Option<Refits>> {
        let arts = inputs_of(kind, inputs, &self.stage)?;
        if arts.iter().any(|a| !a.files.contains_key(JACKKNIFE_FILE)) {
            return Ok(None);
        }
        let c = Columns::read_file(&arts, JACKKNIFE_FILE)?;
        let Some(q) = c.str.get("quantity") else {
            return Ok(None);
        };
        let (unit, replica, value) = (c.col(pool::JK_UNIT)?, c.col("replica")?, c.col("value")?);
        let refits: Refits = (0..c.rows)
            .filter(|&i| q[i] == self.quantity)
            .map(|i| ((unit[i].to_bits(), replica[i] as usize), value[i]))
            .collect();
        Ok((!refits.is_empty()).then_some(refits))
    }
}

/// A number's jackknife refits by (unit bits, replica left out).
type Refits = BTreeMap<(u64, usize), f64>;

/// File of a fit's replica jackknife refits: `jk_unit`, `replica` (the one left
/// out), `quantity`, `value` (and the group's columns); a fit that takes one of
/// its numbers (`fixed_from`) refits with the same replica left out.
pub const JACKKNIFE_FILE: &str = "jackknife.parquet";

/// Where the fitted line is drawn.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    #[serde(default)]
    pub x_min: Option<f64>,
    #[serde(default)]
    pub x_max: Option<f64>,
    #[serde(default = "default_points")]
    pub points: usize,
}

fn default_file() -> String {
    "parquet".into()
}

fn default_points() -> usize {
    200
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FitParams {
    /// `power_law_offset`, `vft`, `power_law`, `line`, `drift` (a line whose
    /// slope is reported as the relative change of y over the x range) or `value`
    /// (no fit: the mean of y over the selected rows, e.g. tau_alpha at one phi).
    pub form: String,
    /// Stage whose table holds the data; may be left out when every input comes
    /// from one stage (`gather: [tau_table]`).
    #[serde(default)]
    pub data: Option<String>,
    /// Which of its files (default `parquet`).
    #[serde(default = "default_file")]
    pub file: String,
    pub x: String,
    pub y: String,
    /// Column of 1-sigma errors of y; without it the errors are scaled to the scatter.
    #[serde(default)]
    pub y_err: Option<String>,
    #[serde(default, rename = "where")]
    pub filter: Where,
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    #[serde(default)]
    pub fixed_from: BTreeMap<String, FromQuantity>,
    /// Quantity names for the parameters (default: the form's own names).
    #[serde(default)]
    pub rename: BTreeMap<String, String>,
    #[serde(default)]
    pub curve: Option<CurveSpec>,
    /// One fit per distinct value of these columns (e.g. `[phi]`), each a row
    /// group of the output with these columns; a column `t` among them is also the
    /// lag of a `gaussian` fit.
    #[serde(default)]
    pub group_by: Vec<String>,
    /// Range scan (paper H, Appendix, Fig. 25): the same fit again over each
    /// window `[x_min, x_max]` of x; `ranges.parquet` holds every window's fit and
    /// the main table gains `<parameter>_range_std`, its spread between windows.
    #[serde(default)]
    pub ranges: Vec<(f64, f64)>,
    /// `relative`: where the model does not describe the points within their
    /// errors (reduced chi^2 > 1, e.g. curves of several eta that collapse only
    /// roughly), a relative model scatter s_m |y| is added in quadrature to every
    /// point's error, s_m chosen so that the reduced chi^2 is 1. Without it the
    /// few points with the smallest errors set the fit, and which points those
    /// are changes from seed to seed. The table gains `scatter` (s_m); its
    /// `reduced_chi2` stays that of the errors alone.
    #[serde(default)]
    pub scatter: Option<String>,
}

/// Errors `s` widened by a relative model scatter `m |y|` in quadrature.
fn widened(s: &[f64], y: &[f64], m: f64) -> Vec<f64> {
    s.iter().zip(y).map(|(e, v)| e.hypot(m * v.abs())).collect()
}

/// The relative model scatter s_m that brings the fit's reduced chi^2 to 1
/// (`scatter: relative`), 0 when it is at most 1 already: doubling from 1e-3
/// until the reduced chi^2 falls to 1 (capped at 10), then bisection in log
/// s_m (the reduced chi^2 falls as s_m grows). Growing from small s_m keeps
/// away from errors so large that a nonlinear fit no longer converges.
/// Returns s_m and the reduced chi^2 with the errors alone.
fn relative_scatter(
    p: &FitParams,
    x: &[f64],
    y: &[f64],
    s: &[f64],
    fixed: &[(&str, f64)],
) -> Result<(f64, f64)> {
    // A fit that fails on the way (a parameter on its bound while a few
    // precise points still dominate) counts as a scatter too small.
    let chi2 = |m: f64| {
        fit_form(p, x, y, &widened(s, y, m), fixed).map_or(f64::INFINITY, |f| f.reduced_chi2)
    };
    let alone = chi2(0.0);
    if alone <= 1.0 {
        return Ok((0.0, alone));
    }
    let (mut lo, mut hi) = (0.0, 1e-3);
    while chi2(hi) > 1.0 {
        if hi >= 10.0 {
            // Still above 1 at the cap: usable only if the fit converges there.
            fit_form(p, x, y, &widened(s, y, hi), fixed)?;
            return Ok((hi, alone));
        }
        (lo, hi) = (hi, 2.0 * hi);
    }
    let (mut lo, mut hi) = (lo.max(1e-6).ln(), hi.ln());
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if chi2(mid.exp()) > 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok((hi.exp(), alone))
}

/// The named form of `p`, or None for `drift` (a line) and `value` (no fit).
fn named_form(p: &FitParams) -> Result<Option<&'static Form>> {
    match p.form.as_str() {
        "drift" | "value" => Ok(None),
        f => catalogue::find(f).map(Some).map_err(anyhow::Error::msg),
    }
}

/// The fit itself; the data are finite points with positive errors.
fn fit_form(
    p: &FitParams,
    x: &[f64],
    y: &[f64],
    s: &[f64],
    fixed: &[(&str, f64)],
) -> Result<FitResult> {
    Ok(fit_data(p, named_form(p)?, Data::new(x, y, s), fixed)?)
}

/// The fit of `form` (a line for `drift`), errors scaled to the scatter without `y_err`.
fn fit_data(
    p: &FitParams,
    form: Option<&Form>,
    d: Data<'_>,
    fixed: &[(&str, f64)],
) -> Result<FitResult, FitError> {
    let f = match form {
        Some(form) => (form.fit)(d, fixed)?,
        None => linear::line(d)?,
    };
    Ok(if p.y_err.is_none() {
        linear::scale_errors(f)
    } else {
        f
    })
}

/// Table quantity, value, error, note, with the group's values as leading columns.
fn quantity_table(
    group: &[(String, f64)],
    rows: &[(String, f64, f64)],
    note: &str,
) -> Result<RecordBatch> {
    quantity_table_with(group, rows, note, None)
}

/// Replica samples of a fit on the rows of one unit: the unit and, per replica
/// k, every reported number refitted with replica k left out.
type UnitSamples = (f64, Vec<Vec<f64>>);

/// Column of a fit table holding each quantity refitted with replica k left
/// out (`join` turns it into `NAME_jkK`).
fn value_jk(k: usize) -> String {
    pool::jk_column("value", k)
}

/// [`quantity_table`] with the replica samples of a fit on one unit's rows:
/// `jk_unit` and `value_jk0 ..` (NaN for rows without a refit, such as the
/// reduced chi-square).
fn quantity_table_with(
    group: &[(String, f64)],
    rows: &[(String, f64, f64)],
    note: &str,
    samples: Option<&UnitSamples>,
) -> Result<RecordBatch> {
    let mut cols: Vec<(String, ArrayRef)> = group
        .iter()
        .map(|(k, v)| {
            (
                k.clone(),
                Arc::new(Float64Array::from(vec![*v; rows.len()])) as ArrayRef,
            )
        })
        .collect();
    let rest = RecordBatch::try_from_iter([
        (
            "quantity",
            Arc::new(StringArray::from(
                rows.iter().map(|r| r.0.clone()).collect::<Vec<_>>(),
            )) as ArrayRef,
        ),
        (
            "value",
            Arc::new(Float64Array::from(
                rows.iter().map(|r| r.1).collect::<Vec<_>>(),
            )),
        ),
        (
            "error",
            Arc::new(Float64Array::from(
                rows.iter().map(|r| r.2).collect::<Vec<_>>(),
            )),
        ),
        ("note", Arc::new(StringArray::from(vec![note; rows.len()]))),
    ])?;
    for (f, c) in rest.schema().fields().iter().zip(rest.columns()) {
        cols.push((f.name().clone(), c.clone()));
    }
    if let Some((unit, per_replica)) = samples {
        cols.push((
            pool::JK_UNIT.to_string(),
            Arc::new(Float64Array::from(vec![*unit; rows.len()])),
        ));
        for (k, v) in per_replica.iter().enumerate() {
            let v: Vec<f64> = (0..rows.len())
                .map(|i| v.get(i).copied().unwrap_or(f64::NAN))
                .collect();
            cols.push((value_jk(k), Arc::new(Float64Array::from(v))));
        }
    }
    Ok(RecordBatch::try_from_iter(cols)?)
}

/// Finite points only; missing or non-positive errors replaced by the largest
/// valid one (conservative), logged.
fn clean(ctx: &StageCtx, x: Vec<f64>, y: Vec<f64>, s: Vec<f64>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let keep: Vec<usize> = (0..x.len())
        .filter(|&i| x[i].is_finite() && y[i].is_finite())
        .collect();
    if keep.len() < x.len() {
        ctx.log(format!(
            "dropped {} point(s) with non-finite x or y",
            x.len() - keep.len()
        ));
    }
    let smax = keep
        .iter()
        .map(|&i| s[i])
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold(0.0, f64::max);
    let fill = if smax > 0.0 { smax } else { 1.0 };
    (
        pick(&x, &keep),
        pick(&y, &keep),
        keep.iter()
            .map(|&i| {
                if s[i].is_finite() && s[i] > 0.0 {
                    s[i]
                } else {
                    fill
                }
            })
            .collect(),
    )
}

pub struct Fit;

impl StageKind for Fit {
    fn name(&self) -> &str {
        "fit"
    }
    fn details(&self) -> String {
        let keys =
            crate::pipeline::registry::param_keys(|v| typed::<FitParams>("fit", v).map(drop));
        let mut s = format!(
            "parameters: {}\n  \
             ranges: [[x_min, x_max], ...]  the same fit over each window (ranges.parquet) and <parameter>_range_std\nforms:\n",
            keys.join(", ")
        );
        for f in catalogue::FORMS {
            s.push_str(&format!(
                "  {:<17} {} [{}]\n",
                f.name,
                f.describe,
                f.params.join(", ")
            ));
        }
        s.push_str(
            "  drift             relative change of y over the x range, from a line [drift]\n",
        );
        s.push_str("  value             no fit: the mean of y over the selected rows [value]\n");
        s.push_str("example: {name: relax, kind: fit, gather: [q_table], params: {form: q_relaxation, data: q_table, x: t, y: Q, y_err: Q_err, group_by: [phi], curve: {}}}");
        s
    }
    fn describe(&self) -> &str {
        "fit a named form to two columns of a table, one fit per group; a failed fit is a row of NaN with its reason in `note`"
    }
    fn explain(&self, params: &Value) -> String {
        let Ok(p) = typed::<FitParams>("fit", params) else {
            return self.describe().to_string();
        };
        let form = match named_form(&p) {
            Ok(Some(f)) => format!("`{}`: {}", f.name, f.describe),
            _ if p.form == "value" => "`value`: the mean of y over the selected rows".into(),
            _ => "`drift`: relative change of y over the x range, from a line".into(),
        };
        let table = match &p.data {
            Some(d) => format!("the table of stage `{d}`"),
            None => "the gathered table".into(),
        };
        let mut s = format!(
            "fit of {} against {} ({table}) to the form {form}; one row per fitted quantity (quantity, value, error, note; a failed fit has NaN values and its reason in note)",
            p.y, p.x
        );
        if !p.group_by.is_empty() {
            s.push_str(&format!(", one fit per {}", p.group_by.join(", ")));
        }
        if p.curve.is_some() {
            s.push_str(&format!(
                "; curve.parquet: the fitted curve, columns {} and {}",
                p.x, p.y
            ));
        }
        if !p.ranges.is_empty() {
            s.push_str(&format!(
                "; ranges.parquet: the same fit over each of the {} windows [x_min, x_max] of {} (paper H, Appendix), whose spread is <parameter>_range_std",
                p.ranges.len(),
                p.x
            ));
        }
        s
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, params: &Value) -> Result<()> {
        let p: FitParams = typed("fit", params)?;
        let form = named_form(&p).map_err(|e| anyhow::anyhow!("fit: {e}"))?;
        if !p.ranges.is_empty() && form.is_none() {
            bail!(
                "fit: `ranges` scans the fit of a named form; form `{}` fits none",
                p.form
            );
        }
        if let Some(sc) = &p.scatter
            && (sc != "relative" || p.y_err.is_none() || form.is_none())
        {
            bail!(
                "fit: `scatter: {sc}`: the only model scatter is `relative`, for a named form with `y_err` (without y_err the errors are scaled to the scatter already)"
            );
        }
        for (lo, hi) in &p.ranges {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                bail!(
                    "fit: the range [{lo}, {hi}] of `ranges` is empty; give [x_min, x_max] with x_min < x_max"
                );
            }
        }
        Ok(())
    }
    fn run(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let p: FitParams = typed("fit", params)?;
        let c = Columns::read_file(&data_inputs(&p, inputs)?, &p.file)?;
        let rows = c.select(&p.filter)?;
        let mut fixed: Vec<(String, f64)> = p.fixed.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let mut shifted: Vec<(String, Refits)> = Vec::new();
        for (name, from) in &p.fixed_from {
            fixed.push((name.clone(), from.get("fit", inputs)?));
            if let Some(r) = from.jackknife("fit", inputs)? {
                shifted.push((name.clone(), r));
            }
        }
        // Rows per group, groups in ascending order of their values.
        let keys: Vec<&[f64]> = p.group_by.iter().map(|k| c.col(k)).collect::<Result<_>>()?;
        let mut groups: BTreeMap<Vec<u64>, Vec<usize>> = BTreeMap::new();
        for &i in &rows {
            let key = keys.iter().map(|k| ordered(k[i])).collect();
            groups.entry(key).or_default().push(i);
        }
        if groups.is_empty() {
            groups.insert(vec![], vec![]);
        }
        let mut fitted = Vec::new();
        for (key, rows) in groups {
            let group: Vec<(String, f64)> = p
                .group_by
                .iter()
                .zip(&key)
                .map(|(k, &v)| (k.clone(), unordered(v)))
                .collect();
            let mut fixed = fixed.clone();
            fixed.extend(group.iter().filter(|(k, _)| k == "t").cloned());
            fitted.push(fit_group(ctx, &p, &c, &rows, &group, &fixed, &shifted)?);
        }
        let pooled = pool_one_unit_errors(&mut fitted)?;
        let (mut tables, mut curves, mut scans, mut methods, mut jackknives) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for g in fitted {
            tables.push(g.table);
            curves.extend(g.curve);
            scans.extend(g.scan);
            jackknives.extend(g.jackknife);
            if !methods.contains(&g.method) {
                methods.push(g.method);
            }
        }
        let method = methods.join("; ") + pooled.as_deref().unwrap_or("");
        let tables = same_columns(tables)?;
        let mut out = Output::single(
            "parquet",
            to_parquet_bytes(&tables, &[(ERROR_METHOD, method.as_str())])?,
        );
        if p.curve.is_some() {
            out = out.with("curve.parquet", to_parquet_bytes(&curves, &[])?);
        }
        if !scans.is_empty() {
            out = out.with("ranges.parquet", to_parquet_bytes(&scans, &[])?);
        }
        if !jackknives.is_empty() {
            out = out.with(JACKKNIFE_FILE, to_parquet_bytes(&jackknives, &[])?);
        }
        Ok(out)
    }
}

/// The groups' quantity tables with one set of columns: a group whose rows carry
/// no replica samples (other units, a refit impossible) lacks the `value_jkK`
/// columns of the others; they are NaN there.
fn same_columns(tables: Vec<RecordBatch>) -> Result<Vec<RecordBatch>> {
    let Some(widest) = tables.iter().max_by_key(|t| t.num_columns()).cloned() else {
        return Ok(tables);
    };
    let schema = widest.schema();
    tables
        .into_iter()
        .map(|t| {
            if t.schema() == schema {
                return Ok(t);
            }
            let cols: Vec<(String, ArrayRef)> = schema
                .fields()
                .iter()
                .map(|f| {
                    let c = t.column_by_name(f.name()).cloned().unwrap_or_else(|| {
                        Arc::new(Float64Array::from(vec![f64::NAN; t.num_rows()])) as ArrayRef
                    });
                    (f.name().clone(), c)
                })
                .collect();
            Ok(RecordBatch::try_from_iter(cols)?)
        })
        .collect()
}

/// The inputs holding the data: from stage `data`, or every input when they all
/// come from one stage and `data` is left out.
fn data_inputs<'a>(p: &FitParams, inputs: &'a [Artifact]) -> Result<Vec<&'a Artifact>> {
    if let Some(d) = &p.data {
        return inputs_of("fit", inputs, d);
    }
    // One source stage: a name every input shares (a node shared between
    // figures carries each figure's name for it).
    let common = inputs
        .iter()
        .map(|a| {
            a.ids
                .iter()
                .map(|id| id.stage.as_str())
                .collect::<std::collections::BTreeSet<_>>()
        })
        .reduce(|a, b| &a & &b)
        .unwrap_or_default();
    if common.is_empty() {
        let stages = source_stages(inputs);
        bail!(
            "fit: the inputs come from {} stages ({}); say which holds the data with `data: STAGE`",
            stages.len(),
            stages.join(", ")
        );
    }
    Ok(inputs.iter().collect())
}

/// A float as a sortable key (groups of equal values, in ascending order).
fn ordered(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 { !b } else { b | (1 << 63) }
}

fn unordered(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// One fit of `p` over `rows` of `c`: its quantity table, its curve (named after
/// the fitted columns, with the group's values) and its range scan, if asked for.
fn fit_group(
    ctx: &StageCtx,
    p: &FitParams,
    c: &Columns,
    rows: &[usize],
    group: &[(String, f64)],
    fixed: &[(String, f64)],
    shifted: &[(String, Refits)],
) -> Result<Group> {
    let x = pick(c.col(&p.x)?, rows);
    let y = pick(c.col(&p.y)?, rows);
    let s = match &p.y_err {
        Some(e) => pick(c.col(e)?, rows),
        None => vec![1.0; rows.len()],
    };
    // The replica jackknife runs over the rows the fit uses: a row without a
    // value (a state point whose own fit failed) has no replica samples either.
    let used: Vec<usize> = (0..rows.len())
        .filter(|&i| x[i].is_finite() && y[i].is_finite())
        .collect();
    let used_rows = pick_rows(rows, &used);
    let jk = replica_columns(c, &used_rows, &p.x, &p.y);
    let one_unit = unit_columns(c, &used_rows, &p.y);
    let raw = (pick(&x, &used), pick(&y, &used), pick(&s, &used));
    let (x, y, s) = clean(ctx, x, y, s);
    let fixed_ref: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    // `scatter: relative`: s_m and the reduced chi^2 of the errors alone; the
    // fit, its refits and its range scan then weight by the widened errors.
    let scatter = match &p.scatter {
        Some(_) => match relative_scatter(p, &x, &y, &s, &fixed_ref) {
            Ok(m) => Some(m),
            Err(e) => {
                ctx.log(format!(
                    "no relative model scatter: a fit on the way failed: {e:#}"
                ));
                None
            }
        },
        None => None,
    };
    let m_scatter = scatter.map_or(0.0, |(m, _)| m);
    let widen = |e: f64, v: f64| e.hypot(m_scatter * v.abs());
    let s = widened(&s, &y, m_scatter);
    let name = |n: &str| p.rename.get(n).cloned().unwrap_or_else(|| n.to_string());
    if p.form == "value" {
        let k = y.len() as f64;
        let (mean, err) = if y.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            (
                y.iter().sum::<f64>() / k,
                s.iter().map(|e| e * e).sum::<f64>().sqrt() / k,
            )
        };
        let note = if y.is_empty() {
            "no row passes `where`"
        } else {
            ""
        };
        let mut method = match &p.y_err {
            Some(e) => format!("the per-point errors {e}, combined"),
            None => "none (no y_err)".to_string(),
        };
        // Rows of one unit with replica samples: the replica jackknife of the
        // value counts what per-point errors miss (the lag of `at` moving with
        // the measured tau_alpha); with few replicas it is noisy, so the larger
        // of the two is quoted.
        let mut err = err;
        if let Some((_, y_jk)) = &one_unit {
            let per: Vec<f64> = y_jk
                .iter()
                .map(|v| {
                    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
                    f.iter().sum::<f64>() / f.len() as f64
                })
                .collect();
            let r = per.len() as f64;
            let m = per.iter().sum::<f64>() / r;
            let jk = ((r - 1.0) / r * per.iter().map(|v| (v - m).powi(2)).sum::<f64>()).sqrt();
            if jk.is_finite() && (err.is_nan() || jk > err) {
                err = jk;
                method = format!(
                    "delete-one jackknife over {} replicas (larger than {method})",
                    y_jk.len()
                );
            }
        }
        return Ok(Group {
            table: quantity_table(group, &[(name("value"), mean, err)], note)?,
            curve: None,
            scan: Vec::new(),
            method,
            jackknife: None,
            pooled: None,
        });
    }
    let mut method = covariance_method(p);
    let form = named_form(p)?;
    let mut jackknife = None;
    let mut pooled = None;
    let (rows, note, curve, samples) = match fit_form(p, &x, &y, &s, &fixed_ref) {
        Ok(f) => {
            let mut refits = None;
            let mut rows: Vec<(String, f64, f64)> = if p.form == "drift" {
                // Relative change of y across the x range, from the slope.
                let span = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                    - x.iter().cloned().fold(f64::INFINITY, f64::min);
                let mean = y.iter().sum::<f64>() / y.len() as f64;
                let (b, db) = f.expect("slope");
                vec![(name("drift"), b * span / mean, db * span / mean.abs())]
            } else {
                f.names
                    .iter()
                    .zip(f.params.iter().zip(&f.stderr))
                    .map(|(n, (v, e))| (name(n), *v, *e))
                    .collect()
            };
            // Errors from independent replicas where the rows span several units;
            // numbers taken from other fits (`fixed_from`) are refitted on the same
            // replicas, so that their share of the variance is counted.
            let also = also_units(shifted);
            let fixed_at = |left: pool::LeftOut| -> Vec<(String, f64)> {
                fixed
                    .iter()
                    .map(|(n, v)| {
                        let at = shifted
                            .iter()
                            .find(|(m, _)| m == n)
                            .and_then(|(_, r)| r.get(&(left.unit.to_bits(), left.replica)));
                        (n.clone(), at.copied().unwrap_or(*v))
                    })
                    .collect()
            };
            // One refit with replica `left.replica` of unit `left.unit` left out,
            // the numbers taken from other fits at the same replica.
            let (rx, ry, rs) = &raw;
            // Only where every row comes from the one unit: all weights then
            // change together. Across units the sample's larger errors would
            // down-weight the unit left out and damp its refit's shift.
            let s_jk: Vec<Vec<f64>> = match (&p.y_err, &jk) {
                (Some(e), Some((_, _, y_jk))) if one_unit.is_some() => {
                    let v = jk_samples(c, &used_rows, e);
                    if v.len() == y_jk.len() { v } else { Vec::new() }
                }
                _ => Vec::new(),
            };
            // A replica sample passes the same `where` on x and y as the pooled
            // data (e.g. P > 0 of a tail: a bin one replica never reached).
            let passes = |col: &str, v: f64| p.filter.get(col).is_none_or(|c| c.accepts(v));
            let refit = |left: pool::LeftOut, xs: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                let keep: Vec<usize> = (0..xs.len())
                    .filter(|&i| {
                        xs[i].is_finite()
                            && ys[i].is_finite()
                            && passes(&p.x, xs[i])
                            && passes(&p.y, ys[i])
                    })
                    .collect();
                let (xk, yk) = (pick(xs, &keep), pick(ys, &keep));
                let fill = s.iter().cloned().fold(0.0, f64::max);
                // The rows of the unit left out carry the per-point errors of
                // that sample, so that each refit is the whole estimator (its
                // weights included) applied to the data without the replica.
                let own = s_jk.get(left.replica);
                let err = |i: usize| match (own, &jk) {
                    (Some(e), Some((units, _, _))) if units[i].to_bits() == left.unit.to_bits() => {
                        e[i]
                    }
                    _ => rs[i],
                };
                let sk: Vec<f64> = keep
                    .iter()
                    .map(|&i| {
                        let e = err(i);
                        widen(if e.is_finite() && e > 0.0 { e } else { fill }, ys[i])
                    })
                    .collect();
                let fixed = fixed_at(left);
                let fixed: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
                let g = fit_form(p, &xk, &yk, &sk, &fixed).ok()?;
                Some(reported(p, &xk, &yk, &g))
            };
            if let Some((units, x_jk, y_jk)) = &jk {
                match pool::replica_jackknife_with(units, rx, ry, x_jk, y_jk, &also, &refit) {
                    Some(j) => {
                        if one_unit.is_some() && also.is_empty() {
                            pooled = Some(rows.iter().map(|r| r.2).zip(j.errors.clone()).collect());
                        }
                        for (row, e) in rows.iter_mut().zip(&j.errors) {
                            row.2 = *e;
                        }
                        method =
                            jackknife_method(j.refits.len(), &from_note(&p.fixed_from, shifted));
                        refits = Some(j.refits);
                    }
                    None => {
                        method.push_str(JK_IMPOSSIBLE);
                    }
                }
            } else if !also.is_empty() {
                // Data without replica columns (e.g. xi from a fit per state
                // point): their errors from the fit covariance, plus in quadrature
                // the variance that the numbers taken from other fits bring.
                let refit = |left: pool::LeftOut, xs: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                    let fixed = fixed_at(left);
                    let fixed: Vec<(&str, f64)> =
                        fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
                    let g = fit_form(p, xs, ys, &s, &fixed).ok()?;
                    Some(reported(p, xs, ys, &g))
                };
                match pool::replica_jackknife_with(&[], &x, &y, &[], &[], &also, refit) {
                    Some(j) => {
                        for (row, e) in rows.iter_mut().zip(&j.errors) {
                            row.2 = row.2.hypot(*e);
                        }
                        method.push_str(&format!(
                            ", plus in quadrature the replica jackknife of {} ({} refits with the same replica left out there)",
                            from_names(&p.fixed_from),
                            j.refits.len()
                        ));
                        refits = Some(j.refits);
                    }
                    None => method.push_str(JK_IMPOSSIBLE),
                }
            } else if let Some(replica) = object_replicas(c, &used_rows) {
                // One row per object (cluster) of every replica: refit with the
                // rows of each replica left out. Objects of one replica share
                // its frames, so they are not independent points.
                let mut labels = replica.clone();
                labels.sort_by(f64::total_cmp);
                labels.dedup();
                let thetas: Option<Vec<Vec<f64>>> = labels
                    .iter()
                    .map(|&r| {
                        let ys: Vec<f64> = ry
                            .iter()
                            .zip(&replica)
                            .map(|(&y, &k)| if k == r { f64::NAN } else { y })
                            .collect();
                        let left = pool::LeftOut {
                            unit: f64::NAN,
                            replica: 0,
                        };
                        refit(left, rx, &ys)
                    })
                    .collect();
                match thetas {
                    Some(t) => {
                        let n = t.len() as f64;
                        let errors: Vec<f64> = (0..t[0].len())
                            .map(|q| {
                                let mean = t.iter().map(|v| v[q]).sum::<f64>() / n;
                                ((n - 1.0) / n
                                    * t.iter().map(|v| (v[q] - mean).powi(2)).sum::<f64>())
                                .sqrt()
                            })
                            .collect();
                        if also.is_empty() {
                            pooled = Some(rows.iter().map(|r| r.2).zip(errors.clone()).collect());
                        }
                        for (row, e) in rows.iter_mut().zip(&errors) {
                            row.2 = *e;
                        }
                        method = format!(
                            "delete-one jackknife over replicas: refit with the rows of each of {} replicas left out",
                            labels.len()
                        );
                    }
                    None => method.push_str(
                        " (the jackknife over the rows' replicas was not possible: a refit failed)",
                    ),
                }
            }
            if let Some(r) = refits {
                let names: Vec<String> = rows.iter().map(|row| row.0.clone()).collect();
                jackknife = Some(jackknife_table(group, &names, &r)?);
            }
            // A fit on one unit's rows (the OZ fit of one state point's S4
            // over q) takes no error from two replicas, but carries its numbers
            // refitted with each replica left out, so that a fit across state
            // points (xi against phi, the collapse) refits them on the same
            // replicas instead of holding them at their values.
            let samples = one_unit.as_ref().map(|(unit, y_jk)| {
                let per_replica = y_jk
                    .iter()
                    .enumerate()
                    .map(|(k, ys)| {
                        let left = pool::LeftOut {
                            unit: *unit,
                            replica: k,
                        };
                        let xs = match &jk {
                            Some((_, x_jk, _)) if x_jk.len() == y_jk.len() => &x_jk[k],
                            _ => rx,
                        };
                        refit(left, xs, ys).unwrap_or_default()
                    })
                    .collect();
                (*unit, per_replica)
            });
            match scatter {
                Some((m, alone)) => {
                    rows.push((name("reduced_chi2"), alone, f64::NAN));
                    rows.push((name("points"), x.len() as f64, 0.0));
                    rows.push((name("scatter"), m, f64::NAN));
                    if m > 0.0 {
                        method.push_str(&format!(
                            "; each point's error widened by a relative model scatter {m:.3} |y| in quadrature (reduced chi2 {alone:.1} -> 1)"
                        ));
                    }
                }
                None => {
                    rows.push((name("reduced_chi2"), f.reduced_chi2, f64::NAN));
                    rows.push((name("points"), x.len() as f64, 0.0));
                    if p.scatter.is_some() {
                        rows.push((name("scatter"), f64::NAN, f64::NAN));
                        method.push_str(
                            "; no relative model scatter: a fit while searching for it failed (the errors alone)",
                        );
                    }
                }
            }
            let curve = p.curve.as_ref().map(|cs| {
                let lo = cs
                    .x_min
                    .unwrap_or_else(|| x.iter().cloned().fold(f64::INFINITY, f64::min));
                let hi = cs
                    .x_max
                    .unwrap_or_else(|| x.iter().cloned().fold(f64::NEG_INFINITY, f64::max));
                let n = cs.points.max(2);
                let log = form.is_some_and(|f| f.log_x) && lo > 0.0;
                let xs: Vec<f64> = (0..n)
                    .map(|i| {
                        let u = i as f64 / (n - 1) as f64;
                        if log {
                            lo * (hi / lo).powf(u)
                        } else {
                            lo + u * (hi - lo)
                        }
                    })
                    .collect();
                let ys: Vec<f64> = match form {
                    Some(fm) => xs
                        .iter()
                        .map(|&v| (fm.model)(&f.params, &fixed_ref, v))
                        .collect(),
                    None => xs.iter().map(|&v| f.params[0] + f.params[1] * v).collect(),
                };
                (xs, ys)
            });
            (rows, f.warnings.join("; "), curve, samples)
        }
        Err(e) => {
            let msg = format!("{e:#}");
            ctx.log(format!("fit failed: {msg}"));
            let names: &[&str] = match (form, p.form.as_str()) {
                (Some(f), _) => f.params,
                (None, "drift") => &["drift"],
                (None, _) => &["intercept", "slope"],
            };
            let rows = names
                .iter()
                .map(|n| (name(n), f64::NAN, f64::NAN))
                .collect();
            (
                rows,
                format!("fit failed: {msg}"),
                p.curve.as_ref().map(|_| (vec![], vec![])),
                None,
            )
        }
    };
    let (mut rows, mut note) = (rows, note);
    let scan = match form {
        Some(fm) if !p.ranges.is_empty() => scan_ranges(
            p,
            fm,
            Data::new(&x, &y, &s),
            &fixed_ref,
            group,
            &mut rows,
            &mut note,
        )?,
        _ => Vec::new(),
    };
    let table = quantity_table_with(group, &rows, &note, samples.as_ref())?;
    let curve = match curve {
        Some((cx, cy)) => {
            let n = cx.len();
            let mut cols: Vec<(String, ArrayRef)> = group
                .iter()
                .filter(|(k, _)| *k != p.x && *k != p.y)
                .map(|(k, v)| {
                    (
                        k.clone(),
                        Arc::new(Float64Array::from(vec![*v; n])) as ArrayRef,
                    )
                })
                .collect();
            cols.push((p.x.clone(), Arc::new(Float64Array::from(cx))));
            cols.push((p.y.clone(), Arc::new(Float64Array::from(cy))));
            Some(RecordBatch::try_from_iter(cols)?)
        }
        None => None,
    };
    Ok(Group {
        table,
        curve,
        scan,
        method,
        jackknife,
        pooled,
    })
}

/// What one fit of a group writes: its quantity table, its curve, its range
/// scan, how its errors were estimated and its replica jackknife refits.
struct Group {
    table: RecordBatch,
    curve: Option<RecordBatch>,
    scan: Vec<RecordBatch>,
    method: String,
    jackknife: Option<RecordBatch>,
    /// A fit on one unit's rows with a replica jackknife: per fitted number,
    /// (covariance error, jackknife error), for [`pool_one_unit_errors`].
    pooled: Option<Vec<(f64, f64)>>,
}

/// Fits on one state point each (a curve over lags, bins or q) whose replica
/// jackknife has R - 1 degrees of freedom: every such fit of the stage quotes
/// its covariance error times f, per fitted number f^2 = the mean over those
/// fits of (jackknife / covariance)^2. The scale then rests on G (R - 1)
/// degrees of freedom, and the errors keep the covariance's smooth dependence
/// on the state point: a fit downstream weighting by them (beta against tau0,
/// xi against phi) is not steered by one-degree-of-freedom noise. With one such
/// fit this is its jackknife error. Returns the method line, if any fit took part.
fn pool_one_unit_errors(groups: &mut [Group]) -> Result<Option<String>> {
    let with: Vec<usize> = (0..groups.len())
        .filter(|&g| groups[g].pooled.is_some())
        .collect();
    if with.is_empty() {
        return Ok(None);
    }
    let n = with
        .iter()
        .map(|&g| groups[g].pooled.as_ref().map_or(0, Vec::len))
        .max()
        .unwrap_or(0);
    let factor: Vec<f64> = (0..n)
        .map(|p| {
            let r2: Vec<f64> = with
                .iter()
                .filter_map(|&g| groups[g].pooled.as_ref()?.get(p).copied())
                .filter(|(cov, jk)| cov.is_finite() && *cov > 0.0 && jk.is_finite())
                .map(|(cov, jk)| (jk / cov).powi(2))
                .collect();
            (r2.iter().sum::<f64>() / r2.len() as f64).sqrt()
        })
        .collect();
    for &g in &with {
        let pairs = groups[g].pooled.take().unwrap_or_default();
        let errors: Vec<f64> = pairs
            .iter()
            .zip(&factor)
            .map(|(&(cov, jk), f)| {
                if cov.is_finite() && cov > 0.0 && f.is_finite() {
                    cov * f
                } else {
                    jk
                }
            })
            .collect();
        groups[g].table = with_errors(&groups[g].table, &errors)?;
    }
    Ok(Some(format!(
        "; the {} fit(s) on one state point each quote their covariance error times sqrt(mean over them of (jackknife / covariance)^2)",
        with.len()
    )))
}

/// `table` with the first `errors.len()` entries of its `error` column replaced.
fn with_errors(table: &RecordBatch, errors: &[f64]) -> Result<RecordBatch> {
    let schema = table.schema();
    let (i, _) = schema
        .column_with_name("error")
        .context("a quantity table has an `error` column")?;
    let old = table
        .column(i)
        .as_any()
        .downcast_ref::<Float64Array>()
        .context("`error` is a float column")?;
    let new: Vec<f64> = (0..old.len())
        .map(|k| errors.get(k).copied().unwrap_or(old.value(k)))
        .collect();
    let mut cols = table.columns().to_vec();
    cols[i] = Arc::new(Float64Array::from(new));
    Ok(RecordBatch::try_new(schema, cols)?)
}

/// The units (with their replica counts) whose refits move the numbers taken
/// from other fits.
fn also_units(shifted: &[(String, Refits)]) -> Vec<(f64, usize)> {
    let mut n: BTreeMap<u64, usize> = BTreeMap::new();
    for (_, r) in shifted {
        for &(u, k) in r.keys() {
            let e = n.entry(u).or_default();
            *e = (*e).max(k + 1);
        }
    }
    n.into_iter().map(|(u, r)| (f64::from_bits(u), r)).collect()
}

/// "phi_c of power_law, ...": the numbers taken from other fits.
fn from_names(from: &BTreeMap<String, FromQuantity>) -> String {
    from.values()
        .map(|f| format!("{} of {}", f.quantity, f.stage))
        .collect::<Vec<_>>()
        .join(", ")
}

/// [`JACKKNIFE_FILE`]: one row per refit and reported number.
fn jackknife_table(
    group: &[(String, f64)],
    names: &[String],
    refits: &[(pool::LeftOut, Vec<f64>)],
) -> Result<RecordBatch> {
    let (mut unit, mut replica, mut quantity, mut value) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (left, theta) in refits {
        for (n, v) in names.iter().zip(theta) {
            unit.push(left.unit);
            replica.push(left.replica as f64);
            quantity.push(n.clone());
            value.push(*v);
        }
    }
    let rows = value.len();
    let mut cols: Vec<(String, ArrayRef)> = group
        .iter()
        .map(|(k, v)| {
            (
                k.clone(),
                Arc::new(Float64Array::from(vec![*v; rows])) as ArrayRef,
            )
        })
        .collect();
    cols.push((pool::JK_UNIT.into(), Arc::new(Float64Array::from(unit))));
    cols.push(("replica".into(), Arc::new(Float64Array::from(replica))));
    cols.push(("quantity".into(), Arc::new(StringArray::from(quantity))));
    cols.push(("value".into(), Arc::new(Float64Array::from(value))));
    Ok(RecordBatch::try_from_iter(cols)?)
}

/// The range scan of one group: every window's fit as rows of `ranges.parquet`
/// (the group's values, x_min, x_max, n_points, then quantity, value, error,
/// note), and each parameter's spread between windows appended to `rows` as
/// `<parameter>_range_std` (NaN, with the reason in `note`, when no window fits).
fn scan_ranges(
    p: &FitParams,
    form: &Form,
    data: Data<'_>,
    fixed: &[(&str, f64)],
    group: &[(String, f64)],
    rows: &mut Vec<(String, f64, f64)>,
    note: &mut String,
) -> Result<Vec<RecordBatch>> {
    let name = |n: &str| p.rename.get(n).cloned().unwrap_or_else(|| n.to_string());
    let fit = |d: Data<'_>| fit_data(p, Some(form), d, fixed);
    let scan = range_scan(data, &p.ranges, &fit);
    let mut windows = Vec::new();
    for (k, &(lo, hi)) in p.ranges.iter().enumerate() {
        let (points, result) = match &scan {
            Ok(s) => (s.fits[k].points, s.fits[k].result.clone()),
            Err(_) => (data.window(lo, hi).0.len(), Err("no window fits".into())),
        };
        let mut key = group.to_vec();
        key.extend([
            ("x_min".to_string(), lo),
            ("x_max".to_string(), hi),
            ("n_points".to_string(), points as f64),
        ]);
        let (quantities, why) = match result {
            Ok(f) => (
                f.names
                    .iter()
                    .zip(f.params.iter().zip(&f.stderr))
                    .map(|(n, (v, e))| (name(n), *v, *e))
                    .collect::<Vec<_>>(),
                f.warnings.join("; "),
            ),
            Err(e) => (
                form.params
                    .iter()
                    .map(|n| (name(n), f64::NAN, f64::NAN))
                    .collect(),
                format!("fit failed: {e}"),
            ),
        };
        windows.push(quantity_table(&key, &quantities, &why)?);
    }
    match &scan {
        Ok(s) => {
            rows.extend(
                s.spread
                    .iter()
                    .map(|sp| (format!("{}_range_std", name(&sp.name)), sp.std, f64::NAN)),
            );
            if s.spread.iter().any(|sp| sp.std.is_nan()) {
                let sep = if note.is_empty() { "" } else { "; " };
                note.push_str(&format!(
                    "{sep}range scan: fewer than two of the {} windows fit distinct sets of points, so no spread (NaN)",
                    s.fits.len()
                ));
            }
        }
        Err(e) => {
            rows.extend(
                form.params
                    .iter()
                    .map(|n| (format!("{}_range_std", name(n)), f64::NAN, f64::NAN)),
            );
            let sep = if note.is_empty() { "" } else { "; " };
            note.push_str(&format!("{sep}range scan failed: {e}"));
        }
    }
    Ok(windows)
}

/// Appended to the error method when the replica jackknife could not be done.
const JK_IMPOSSIBLE: &str = " (the replica jackknife was not possible: a refit failed or a state point has fewer than two complete replica samples)";

/// Parquet metadata key of a fit table: how its errors were estimated.
pub const ERROR_METHOD: &str = "error_method";

fn covariance_method(p: &FitParams) -> String {
    match &p.y_err {
        Some(e) => format!("fit covariance with the per-point errors {e}"),
        None => "fit covariance scaled to the scatter of the points".to_string(),
    }
}

fn jackknife_method(refits: usize, note: &str) -> String {
    format!(
        "delete-one jackknife over replicas: refit with each replica of each state point left out ({refits} refits){note}"
    )
}

/// How a collapse treats the measured xi it rescales with.
const HELD: &str = "; numbers taken from other fits held at their values";
const XI_REFITTED: &str =
    "; the measured xi of the state point refitted with the same replica left out";

/// What the jackknife of a fit did with the numbers it takes from other fits.
fn from_note(from: &BTreeMap<String, FromQuantity>, shifted: &[(String, Refits)]) -> String {
    let held: BTreeMap<String, FromQuantity> = from
        .iter()
        .filter(|(n, _)| !shifted.iter().any(|(m, _)| m == *n))
        .map(|(n, f)| (n.clone(), f.clone()))
        .collect();
    let mut s = String::new();
    if held.len() < from.len() {
        s.push_str("; numbers taken from other fits refitted with the same replica left out");
    }
    if !held.is_empty() {
        s.push_str(&format!(
            "; {} held at its value (no replica jackknife there)",
            from_names(&held)
        ));
    }
    s
}

/// The numbers a fit reports, in the order of its quantity rows (`drift`: the
/// relative change of y across the x range).
fn reported(p: &FitParams, x: &[f64], y: &[f64], f: &FitResult) -> Vec<f64> {
    if p.form == "drift" {
        let span = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - x.iter().cloned().fold(f64::INFINITY, f64::min);
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        vec![f.params[1] * span / mean]
    } else {
        f.params.clone()
    }
}

/// The replica jackknife inputs of `rows` (`pool::with_replica_samples`): unit
/// per row, and the leave-one-out columns of x (empty when x is a key such as
/// phi) and y. None unless y has them. Rows of one state point (a curve over
/// lags, bins or q) count too: R replicas give only R - 1 degrees of freedom,
/// but the per-point errors of such a curve's correlated points make a fit
/// covariance 3 to 30 times too small (docs/accuracy.md).
type Replicas = (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>);
fn replica_columns(c: &Columns, rows: &[usize], x: &str, y: &str) -> Option<Replicas> {
    let units = pick(c.col(pool::JK_UNIT).ok()?, rows);
    if units.is_empty() || units.iter().any(|u| !u.is_finite()) {
        return None;
    }
    let (x_jk, y_jk) = (jk_samples(c, rows, x), jk_samples(c, rows, y));
    if y_jk.len() < 2 || !(x_jk.is_empty() || x_jk.len() == y_jk.len()) {
        return None;
    }
    Some((units, x_jk, y_jk))
}

/// The `replica` of rows that are objects of several replicas (clusters of
/// every replica, `Errors::Rows`), when there are at least two replicas among
/// them; None for tables without the column.
fn object_replicas(c: &Columns, rows: &[usize]) -> Option<Vec<f64>> {
    let r = pick(c.col("replica").ok()?, rows);
    let mut d = r.clone();
    d.sort_by(f64::total_cmp);
    d.dedup();
    (d.len() >= 2 && d.iter().all(|v| v.is_finite())).then_some(r)
}

/// The entries `at` of a list of row indices.
fn pick_rows(rows: &[usize], at: &[usize]) -> Vec<usize> {
    at.iter().map(|&i| rows[i]).collect()
}

/// The replica samples of rows that all come from one unit (one state point's
/// S4 over q): that unit and the leave-one-out columns of y. None unless every
/// row has the same finite unit and y has at least two samples (x may have its
/// own: the lags of `at` in units of a time measured without the replica).
fn unit_columns(c: &Columns, rows: &[usize], y: &str) -> Option<(f64, Vec<Vec<f64>>)> {
    let units = pick(c.col(pool::JK_UNIT).ok()?, rows);
    let unit = *units.first()?;
    if !unit.is_finite() || units.iter().any(|u| u.to_bits() != unit.to_bits()) {
        return None;
    }
    let y_jk = jk_samples(c, rows, y);
    (y_jk.len() >= 2).then_some((unit, y_jk))
}

/// The replica samples `NAME_jk0 ..` of column `name` at `rows` (none if absent).
fn jk_samples(c: &Columns, rows: &[usize], name: &str) -> Vec<Vec<f64>> {
    (0..pool::MAX_JK_REPLICAS)
        .map_while(|k| c.col(&pool::jk_column(name, k)).ok().map(|v| pick(v, rows)))
        .collect()
}

/// `collapse`: finite-size scaling of Fig. 19. Curves y(x) labelled by `curve_by`
/// (phi) rescale as X = sqrt(x)/xi, Y = y xi^-g with xi = (phi_c - phi)^-gamma_xi;
/// g = gamma_chi/gamma_xi and gamma_xi are fitted, phi_c is given or taken from a fit.
/// With `xi: COLUMN` the measured xi of each curve is used and only g is fitted.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CollapseParams {
    pub data: String,
    pub x: String,
    pub y: String,
    pub y_err: String,
    pub curve_by: String,
    #[serde(default, rename = "where")]
    pub filter: Where,
    #[serde(default)]
    pub phi_c: Option<f64>,
    #[serde(default)]
    pub phi_c_from: Option<FromQuantity>,
    /// Column of the data holding a measured xi per curve (e.g. the OZ xi joined
    /// in): then xi is not a power law of phi, and only `g` is fitted.
    #[serde(default)]
    pub xi: Option<String>,
    /// Search ranges of `g` and `gamma_xi` (only `g` with `xi`), or of the
    /// `rescaling`'s fitted parameters.
    #[serde(default)]
    pub bounds: BTreeMap<String, (f64, f64)>,
    /// A named rescaling of [`crate::fit::rescalings`] instead of Fig. 19's
    /// finite-size scaling (e.g. `cluster_cutoff`, `log_normal`).
    #[serde(default)]
    pub rescaling: Option<String>,
}

pub struct Collapse;

/// The curves of a collapse, one per value of `by` with at least two points of
/// positive x, y and error, in ascending order of that value.
fn collapse_curves(by_name: &str, x: &[f64], y: &[f64], e: &[f64], by: &[f64]) -> Vec<Curve> {
    let mut m: BTreeMap<u64, Curve> = BTreeMap::new();
    for i in 0..x.len() {
        let ok = x[i] > 0.0 && y[i] > 0.0 && e[i] > 0.0 && y[i].is_finite() && e[i].is_finite();
        if !ok {
            continue;
        }
        let cv = m.entry(by[i].to_bits()).or_insert_with(|| Curve {
            label: format!("{by_name}={}", by[i]),
            param: by[i],
            x: vec![],
            y: vec![],
            sigma: vec![],
        });
        cv.x.push(x[i]);
        cv.y.push(y[i]);
        cv.sigma.push(e[i]);
    }
    let mut curves: Vec<Curve> = m.into_values().filter(|c| c.x.len() >= 2).collect();
    curves.sort_by(|a, b| a.param.total_cmp(&b.param));
    curves
}

fn xi(phi_c: f64, phi: f64, gamma_xi: f64) -> f64 {
    (phi_c - phi).powf(-gamma_xi)
}

impl StageKind for Collapse {
    fn name(&self) -> &str {
        "collapse"
    }
    fn describe(&self) -> &str {
        "finite-size-scaling collapse y xi^-g vs sqrt(x)/xi, xi = (phi_c - phi)^-gamma_xi"
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, params: &Value) -> Result<()> {
        let p: CollapseParams = typed("collapse", params)?;
        if let Some(name) = &p.rescaling {
            return validate_named(&p, name);
        }
        let keys: &[&str] = if p.xi.is_some() {
            if p.phi_c.is_some() || p.phi_c_from.is_some() {
                bail!(
                    "collapse: with a measured `xi` column, give neither `phi_c` nor `phi_c_from`"
                );
            }
            &["g"]
        } else {
            if p.phi_c.is_some() == p.phi_c_from.is_some() {
                bail!(
                    "collapse: give exactly one of `phi_c` (a number) and `phi_c_from` ({{stage, quantity}})"
                );
            }
            &["g", "gamma_xi"]
        };
        for k in keys {
            if !p.bounds.contains_key(*k) {
                bail!("collapse: `bounds` needs a search range for '{k}', e.g. {k}: [0.5, 3.0]");
            }
        }
        if p.bounds.len() != keys.len() {
            bail!(
                "collapse: `bounds` takes exactly the keys {}",
                keys.join(" and ")
            );
        }
        Ok(())
    }
    fn run(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let p: CollapseParams = typed("collapse", params)?;
        if let Some(name) = &p.rescaling {
            let r = rescalings::find(name).map_err(|e| anyhow::anyhow!("collapse: {e}"))?;
            return run_named(ctx, &p, r, inputs);
        }
        let phi_c = match (&p.phi_c, &p.phi_c_from) {
            (Some(v), _) => *v,
            (None, Some(f)) => f.get("collapse", inputs)?,
            _ => f64::NAN, // validated: a measured xi column instead
        };
        let c = Columns::read(&inputs_of("collapse", inputs, &p.data)?)?;
        // A measured xi per curve (its first row), when given.
        let measured: Option<BTreeMap<u64, f64>> = match &p.xi {
            Some(col) => {
                let (v, b) = (c.col(col)?, c.col(&p.curve_by)?);
                let mut m = BTreeMap::new();
                for i in 0..c.rows {
                    m.entry(b[i].to_bits()).or_insert(v[i]);
                }
                Some(m)
            }
            None => None,
        };
        let rows = c.select(&p.filter)?;
        let rows_in = rows.clone();
        let (xc, yc, ec, bc) = (
            c.col(&p.x)?,
            c.col(&p.y)?,
            c.col(&p.y_err)?,
            c.col(&p.curve_by)?,
        );
        let x_all = pick(xc, &rows);
        let y_all = pick(yc, &rows);
        let (e_all, b_all) = (pick(ec, &rows), pick(bc, &rows));
        // Curves without a usable measured xi are left out.
        let has_xi = |c: &Curve| {
            measured
                .as_ref()
                .is_none_or(|m| m[&c.param.to_bits()].is_finite() && m[&c.param.to_bits()] > 0.0)
        };
        let curves_of = |ys: &[f64]| -> Vec<Curve> {
            collapse_curves(&p.curve_by, &x_all, ys, &e_all, &b_all)
                .into_iter()
                .filter(|c| has_xi(c))
                .collect()
        };
        let curves = curves_of(&y_all);
        let fitted: &[&str] = if measured.is_some() {
            &["g"]
        } else {
            &["g", "gamma_xi"]
        };
        let bounds: Vec<(f64, f64)> = fitted.iter().map(|k| p.bounds[*k]).collect();
        // The measured xi of each curve with one replica of one unit left out
        // (`XI_jkK` with `jk_unit`, from a fit per state point that carries
        // them): the refits rescale with it, so that xi's share of the variance
        // is counted rather than held at its value.
        let measured_jk: Option<BTreeMap<(u64, usize), (u64, f64)>> = match &p.xi {
            Some(col) => {
                let b = c.col(&p.curve_by)?;
                let units = c.col(pool::JK_UNIT).ok();
                let samples: Vec<&[f64]> = (0..pool::MAX_JK_REPLICAS)
                    .map_while(|k| c.col(&pool::jk_column(col, k)).ok())
                    .collect();
                units.filter(|_| samples.len() >= 2).map(|u| {
                    let mut m = BTreeMap::new();
                    for i in 0..c.rows {
                        for (k, v) in samples.iter().enumerate() {
                            m.entry((u[i].to_bits(), k))
                                .or_insert((b[i].to_bits(), v[i]));
                        }
                    }
                    m
                })
            }
            None => None,
        };
        let rescale_with = |by_xi: Option<BTreeMap<u64, f64>>| {
            move |q: &[f64], cv: &Curve, x: f64, y: f64, s: f64| {
                let l = match &by_xi {
                    Some(m) => m[&cv.param.to_bits()],
                    None => xi(phi_c, cv.param, q[1]),
                };
                let f = l.powf(-q[0]);
                (x.sqrt() / l, y * f, s * f)
            }
        };
        let rescale = rescale_with(measured.clone());
        // The measured xi with replica `left` of its unit left out.
        let xi_left_out = |left: pool::LeftOut| -> Option<BTreeMap<u64, f64>> {
            let mut m = measured.clone()?;
            if let Some((curve, v)) = measured_jk
                .as_ref()
                .and_then(|j| j.get(&(left.unit.to_bits(), left.replica)))
                && v.is_finite()
                && *v > 0.0
            {
                m.insert(*curve, *v);
            }
            Some(m)
        };
        let result = if measured.is_none() && curves.iter().any(|c| c.param >= phi_c) {
            Err(anyhow::anyhow!(
                "phi_c = {phi_c} is not above every {} of the data",
                p.curve_by
            ))
        } else {
            collapse::collapse(&curves, fitted, &bounds, &rescale).map_err(anyhow::Error::from)
        };
        let mut method = "fit covariance of the collapse".to_string();
        let (rows, note, best) = match result {
            Ok(r) if measured.is_some() => {
                let (g, mut dg) = r.get("g").expect("named");
                // Errors from refits with one replica of one phi left out, in
                // chi4P and, where the data carry its replica samples, in the
                // measured xi of that phi (else xi is held at its value).
                if let Some((units, _, y_jk)) = replica_columns(&c, &rows_in, &p.x, &p.y) {
                    let refit = |left: pool::LeftOut, _: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                        let curves = curves_of(ys);
                        let rescale = rescale_with(xi_left_out(left));
                        collapse::best(&curves, fitted, &bounds, &rescale)
                            .map_err(|e| {
                                ctx.log(format!("jackknife refit of the collapse failed: {e:#}"))
                            })
                            .ok()
                            .map(|b| vec![b[0]])
                    };
                    match pool::replica_jackknife_with(
                        &units,
                        &x_all,
                        &y_all,
                        &[],
                        &y_jk,
                        &[],
                        refit,
                    ) {
                        Some(j) => {
                            dg = j.errors[0];
                            let note = if measured_jk.is_some() {
                                XI_REFITTED
                            } else {
                                HELD
                            };
                            method = jackknife_method(j.refits.len(), note);
                        }
                        None => method.push_str(JK_IMPOSSIBLE),
                    }
                }
                (
                    vec![
                        ("gamma_chi_over_gamma_xi".to_string(), g, dg),
                        ("collapse_S".to_string(), r.quality.s, f64::NAN),
                        ("curves".to_string(), curves.len() as f64, 0.0),
                    ],
                    String::new(),
                    Some([g, f64::NAN]),
                )
            }
            Ok(r) => {
                let (g, mut dg) = r.get("g").expect("named");
                let (gx, mut dgx) = r.get("gamma_xi").expect("named");
                let cov = r.covariance[0][1];
                let mut dgc = (gx * gx * dg * dg + g * g * dgx * dgx + 2.0 * g * gx * cov)
                    .max(0.0)
                    .sqrt();
                // The sub-box sizes of one phi come from the same runs: errors
                // from refits with one replica of one phi left out.
                if let Some((units, _, y_jk)) = replica_columns(&c, &rows_in, &p.x, &p.y) {
                    let refit = |_: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                        let b = collapse::best(&curves_of(ys), fitted, &bounds, &rescale)
                            .map_err(|e| {
                                ctx.log(format!("jackknife refit of the collapse failed: {e:#}"))
                            })
                            .ok()?;
                        let (g, gx) = (b[0], b[1]);
                        Some(vec![g, gx, g * gx])
                    };
                    match pool::replica_jackknife(&units, &x_all, &y_all, &[], &y_jk, refit) {
                        Some((e, refits)) => {
                            (dg, dgx, dgc) = (e[0], e[1], e[2]);
                            method = jackknife_method(refits, HELD);
                        }
                        None => method.push_str(JK_IMPOSSIBLE),
                    }
                }
                (
                    vec![
                        ("gamma_chi_over_gamma_xi".to_string(), g, dg),
                        ("gamma_xi".to_string(), gx, dgx),
                        ("gamma_chi".to_string(), g * gx, dgc),
                        ("collapse_S".to_string(), r.quality.s, f64::NAN),
                        ("phi_c_used".to_string(), phi_c, 0.0),
                        ("curves".to_string(), curves.len() as f64, 0.0),
                    ],
                    String::new(),
                    Some([g, gx]),
                )
            }
            Err(e) => {
                let msg = format!("collapse failed: {e:#}");
                ctx.log(msg.clone());
                let names = [
                    "gamma_chi_over_gamma_xi",
                    "gamma_xi",
                    "gamma_chi",
                    "collapse_S",
                ];
                let mut rows: Vec<(String, f64, f64)> = names
                    .iter()
                    .filter(|n| {
                        measured.is_none() || !n.starts_with("gamma_x") && **n != "gamma_chi"
                    })
                    .map(|n| (n.to_string(), f64::NAN, f64::NAN))
                    .collect();
                if measured.is_none() {
                    rows.push(("phi_c_used".to_string(), phi_c, 0.0));
                }
                (rows, msg, None)
            }
        };
        let best = best.map(|q| q.to_vec());
        collapse_output(
            &p,
            &curves,
            best.as_deref(),
            &rescale,
            &rows,
            &note,
            &method,
        )
    }
}

/// A collapse's outputs: the quantity table and the curves rescaled at the best
/// parameters (none when the collapse failed).
fn collapse_output(
    p: &CollapseParams,
    curves: &[Curve],
    best: Option<&[f64]>,
    rescale: collapse::Rescale<'_>,
    rows: &[(String, f64, f64)],
    note: &str,
    method: &str,
) -> Result<Output> {
    let mut cols: [Vec<f64>; 5] = Default::default();
    if let Some(q) = best {
        for cv in curves {
            for k in 0..cv.x.len() {
                let (x, y, s) = rescale(q, cv, cv.x[k], cv.y[k], cv.sigma[k]);
                for (col, v) in cols.iter_mut().zip([cv.param, cv.x[k], x, y, s]) {
                    col.push(v);
                }
            }
        }
    }
    let [phi, n, x, y, s] = cols;
    let resc = f64_batch(&[
        (p.curve_by.as_str(), phi),
        (p.x.as_str(), n),
        ("X", x),
        ("Y", y),
        ("Y_err", s),
    ])?;
    Ok(Output::single(
        "parquet",
        to_parquet_bytes(
            &[quantity_table(&[], rows, note)?],
            &[(ERROR_METHOD, method)],
        )?,
    )
    .with("rescaled.parquet", to_parquet_bytes(&[resc], &[])?))
}

/// The keys of a named rescaling: its fitted parameters in `bounds`, phi_c when it
/// needs one, no measured `xi`.
fn validate_named(p: &CollapseParams, name: &str) -> Result<()> {
    let r = rescalings::find(name).map_err(|e| anyhow::anyhow!("collapse: {e}"))?;
    if p.xi.is_some() {
        bail!(
            "collapse: `xi` belongs to the finite-size scaling of Fig. 19, not to rescaling `{name}`"
        );
    }
    if r.needs_phi_c && p.phi_c.is_some() == p.phi_c_from.is_some() {
        bail!(
            "collapse: rescaling `{name}` needs exactly one of `phi_c` (a number) and `phi_c_from` ({{stage, quantity}})"
        );
    }
    if !r.needs_phi_c && (p.phi_c.is_some() || p.phi_c_from.is_some()) {
        bail!("collapse: rescaling `{name}` does not use phi_c; remove `phi_c`/`phi_c_from`");
    }
    let want: Vec<&str> = r.fitted.to_vec();
    let got: Vec<&str> = p.bounds.keys().map(String::as_str).collect();
    let mut sorted = want.clone();
    sorted.sort();
    if got != sorted {
        bail!(
            "collapse: rescaling `{name}` takes `bounds` for exactly [{}] (got [{}])",
            want.join(", "),
            got.join(", ")
        );
    }
    Ok(())
}

/// A collapse with a named rescaling: the fitted parameters with errors (fit
/// covariance, or replica jackknife when the data carry replica columns), the
/// quality S and the rescaled curves.
fn run_named(
    ctx: &StageCtx,
    p: &CollapseParams,
    r: &'static Rescaling,
    inputs: &[Artifact],
) -> Result<Output> {
    let phi_c = match (&p.phi_c, &p.phi_c_from) {
        (Some(v), _) => *v,
        (None, Some(f)) => f.get("collapse", inputs)?,
        _ => f64::NAN,
    };
    let c = Columns::read(&inputs_of("collapse", inputs, &p.data)?)?;
    // The per-curve numbers (first row of each curve), e.g. a joined per-phi fit.
    let by_all = c.col(&p.curve_by)?;
    let cols: Vec<&[f64]> = r
        .per_curve
        .iter()
        .map(|name| {
            c.col(name).map_err(|e| {
                anyhow::anyhow!(
                    "collapse: rescaling `{}` reads column `{name}` per curve: {e:#}",
                    r.name
                )
            })
        })
        .collect::<Result<_>>()?;
    let mut per_curve: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for i in 0..c.rows {
        per_curve
            .entry(by_all[i].to_bits())
            .or_insert_with(|| cols.iter().map(|v| v[i]).collect());
    }
    let rows_in = c.select(&p.filter)?;
    let x_all = pick(c.col(&p.x)?, &rows_in);
    let y_all = pick(c.col(&p.y)?, &rows_in);
    let e_all = pick(c.col(&p.y_err)?, &rows_in);
    let b_all = pick(by_all, &rows_in);
    let none: Vec<f64> = vec![];
    let columns_of =
        |phi: f64| -> &[f64] { per_curve.get(&phi.to_bits()).map_or(&none[..], |v| &v[..]) };
    // Curves whose per-curve numbers are missing or not finite are left out.
    let usable = |cv: &Curve| {
        let v = columns_of(cv.param);
        v.len() == r.per_curve.len() && v.iter().all(|u| u.is_finite() && *u > 0.0)
    };
    let curves_of = |ys: &[f64]| -> Vec<Curve> {
        collapse_curves(&p.curve_by, &x_all, ys, &e_all, &b_all)
            .into_iter()
            .filter(|cv| usable(cv))
            .collect()
    };
    let curves = curves_of(&y_all);
    let bounds: Vec<(f64, f64)> = r.fitted.iter().map(|k| p.bounds[*k]).collect();
    let columns_of = &columns_of;
    let rescale_at = |phi_c: f64| {
        move |q: &[f64], cv: &Curve, x: f64, y: f64, s: f64| {
            let at = At {
                param: cv.param,
                phi_c,
                columns: columns_of(cv.param),
            };
            (r.map)(q, &at, x, y, s)
        }
    };
    let rescale = rescale_at(phi_c);
    // phi_c with each replica of each unit left out, where its fit carries
    // refits (`jackknife.parquet`): the collapse is redone with it, so that
    // phi_c's share of the variance is counted (N* of the cluster cut-off
    // moves most with phi_c at the densest points).
    let phi_c_refits = match &p.phi_c_from {
        Some(f) if r.needs_phi_c && !r.fitted.is_empty() => f.jackknife("collapse", inputs)?,
        _ => None,
    };
    let result: Result<(Vec<f64>, Vec<f64>, f64)> =
        if r.needs_phi_c && curves.iter().any(|cv| cv.param >= phi_c) {
            Err(anyhow::anyhow!(
                "phi_c = {phi_c} is not above every {} of the data",
                p.curve_by
            ))
        } else if r.fitted.is_empty() {
            collapse::quality(&curves, &rescale, &[])
                .map(|q| (vec![], vec![], q.s))
                .map_err(anyhow::Error::from)
        } else {
            collapse::collapse(&curves, r.fitted, &bounds, &rescale)
                .map(|res| (res.params, res.stderr, res.quality.s))
                .map_err(anyhow::Error::from)
        };
    let mut method = "fit covariance of the collapse".to_string();
    let (rows, note, best) = match result {
        Ok((q, mut dq, s)) => {
            let jk = replica_columns(&c, &rows_in, &p.x, &p.y);
            let also = match &phi_c_refits {
                Some(refits) => also_units(&[("phi_c".to_string(), refits.clone())]),
                None => Vec::new(),
            };
            if !r.fitted.is_empty() && (jk.is_some() || !also.is_empty()) {
                let refit = |left: pool::LeftOut, _: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                    let pc = phi_c_refits
                        .as_ref()
                        .and_then(|m| m.get(&(left.unit.to_bits(), left.replica)))
                        .copied()
                        .unwrap_or(phi_c);
                    let curves = curves_of(ys);
                    if r.needs_phi_c && curves.iter().any(|cv| cv.param >= pc) {
                        return None;
                    }
                    collapse::best(&curves, r.fitted, &bounds, &rescale_at(pc))
                        .map_err(|e| {
                            ctx.log(format!("jackknife refit of the collapse failed: {e:#}"))
                        })
                        .ok()
                };
                let (units, y_jk) = match &jk {
                    Some((u, _, y)) => (u.clone(), y.clone()),
                    None => (Vec::new(), Vec::new()),
                };
                let from = match &p.phi_c_from {
                    Some(f) if !also.is_empty() => format!(
                        "; phi_c ({} of {}) refitted with the same replica left out",
                        f.quantity, f.stage
                    ),
                    _ => HELD.to_string(),
                };
                match pool::replica_jackknife_with(&units, &x_all, &y_all, &[], &y_jk, &also, refit)
                {
                    Some(j) if jk.is_some() => {
                        dq = j.errors;
                        method = jackknife_method(j.refits.len(), &from);
                    }
                    Some(j) => {
                        // Rows without replica samples (cluster sizes): the
                        // covariance error, plus in quadrature phi_c's share.
                        for (d, e) in dq.iter_mut().zip(&j.errors) {
                            *d = d.hypot(*e);
                        }
                        method.push_str(&format!(
                            ", plus in quadrature the replica jackknife of phi_c ({} refits of the collapse with phi_c from the same replica left out)",
                            j.refits.len()
                        ));
                    }
                    None => method.push_str(JK_IMPOSSIBLE),
                }
            }
            let mut rows: Vec<(String, f64, f64)> = r
                .fitted
                .iter()
                .zip(q.iter().zip(&dq))
                .map(|(n, (v, e))| (n.to_string(), *v, *e))
                .collect();
            rows.push(("collapse_S".to_string(), s, f64::NAN));
            if r.needs_phi_c {
                rows.push(("phi_c_used".to_string(), phi_c, 0.0));
            }
            rows.push(("curves".to_string(), curves.len() as f64, 0.0));
            (rows, String::new(), Some(q))
        }
        Err(e) => {
            let msg = format!("collapse failed: {e:#}");
            ctx.log(msg.clone());
            let mut rows: Vec<(String, f64, f64)> = r
                .fitted
                .iter()
                .chain(&["collapse_S"])
                .map(|n| (n.to_string(), f64::NAN, f64::NAN))
                .collect();
            if r.needs_phi_c {
                rows.push(("phi_c_used".to_string(), phi_c, 0.0));
            }
            (rows, msg, None)
        }
    };
    collapse_output(p, &curves, best.as_deref(), &rescale, &rows, &note, &method)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::pipeline::graph::StageId;
    use arrow_array::Array;

    /// A table artifact of stage `stage`, written under `dir`.
    pub(crate) fn artifact(dir: &std::path::Path, stage: &str, b: RecordBatch) -> Artifact {
        let path = dir.join(format!("{stage}.parquet"));
        std::fs::write(&path, to_parquet_bytes(&[b], &[]).unwrap()).unwrap();
        Artifact {
            label: stage.into(),
            ids: vec![StageId {
                figure: Some("test".into()),
                stage: stage.into(),
                point: Default::default(),
            }],
            kind: "table".into(),
            point: Default::default(),
            params: Value::Null,
            digest: String::new(),
            files: [("parquet".to_string(), (String::new(), path))].into(),
        }
    }

    fn yaml(s: &str) -> Value {
        serde_saphyr::from_str(s).unwrap()
    }

    /// (quantity, value) pairs and notes of one table.
    fn quantities(bytes: &[u8]) -> (Vec<(String, f64)>, Vec<String>) {
        let (b, _) = crate::table::read_parquet_bytes(bytes.to_vec()).unwrap();
        let c = Columns::from_batch(&b[0]).unwrap();
        let q = c.str["quantity"].clone();
        let v = c.col("value").unwrap().to_vec();
        (q.into_iter().zip(v).collect(), c.str["note"].clone())
    }

    /// The range scan from YAML: an exact power law gives the same exponent in
    /// every window (spread ~ 0); a crossover from x^-1 to x^-2 at x = 10 gives
    /// each window its own slope (spread ~ 0.5); a window too narrow to fit is a
    /// row with its reason, not a failed stage.
    #[test]
    fn range_scan_reports_every_window_and_the_spread_of_each_parameter() {
        let dir = tempfile::tempdir().unwrap();
        let x: Vec<f64> = (0..41).map(|i| 10f64.powf(i as f64 / 20.0)).collect();
        let exact: Vec<f64> = x.iter().map(|v| 3.0 * v.powf(-1.5)).collect();
        let cross: Vec<f64> = x
            .iter()
            .map(|&v| if v <= 10.0 { 1.0 / v } else { 10.0 / (v * v) })
            .collect();
        let err: Vec<f64> = exact.iter().map(|y| 1e-3 * y).collect();
        let b = f64_batch(&[
            ("x", x.clone()),
            ("exact", exact),
            ("cross", cross.clone()),
            ("cross_err", cross.iter().map(|y| 1e-3 * y).collect()),
            ("exact_err", err),
        ])
        .unwrap();
        let inputs = [artifact(dir.path(), "data", b)];
        let ctx = StageCtx::new(0, "scan".into(), None);
        let run = |y: &str| {
            let params = yaml(&format!(
                "{{form: power_law, data: data, x: x, y: {y}, y_err: {y}_err, \
                 rename: {{exponent: slope}}, ranges: [[1, 10], [10, 100], [1, 100], [50, 50.5]]}}"
            ));
            Fit.validate(&params).unwrap();
            Fit.run(&ctx, &params, &inputs).unwrap()
        };
        let std_of = |out: &Output| {
            let (q, _) = quantities(&out.files["parquet"]);
            q.iter().find(|(n, _)| n == "slope_range_std").unwrap().1
        };
        let exact = run("exact");
        assert!(std_of(&exact) < 1e-6, "{}", std_of(&exact));
        let cross = run("cross");
        // Slopes -1, -2 and about -1.5 over the three windows that fit: std 0.5.
        assert!((std_of(&cross) - 0.5).abs() < 0.05, "{}", std_of(&cross));
        let (b, _) =
            crate::table::read_parquet_bytes(cross.files["ranges.parquet"].clone()).unwrap();
        let n = b[0].column_by_name("n_points").unwrap();
        assert_eq!(n.data_type(), &arrow_schema::DataType::Int64);
        let c = Columns::from_batch(&b[0]).unwrap();
        assert_eq!(c.rows, 4 * 2, "four windows, two parameters each");
        let (lo, hi, np) = (
            c.col("x_min").unwrap(),
            c.col("x_max").unwrap(),
            c.col("n_points").unwrap(),
        );
        let (q, v, note) = (&c.str["quantity"], c.col("value").unwrap(), &c.str["note"]);
        let i = (0..c.rows)
            .find(|&i| lo[i] == 1.0 && hi[i] == 10.0 && q[i] == "slope")
            .unwrap();
        assert!(
            (v[i] + 1.0).abs() < 1e-6 && np[i] == 21.0,
            "{} {}",
            v[i],
            np[i]
        );
        let narrow: Vec<usize> = (0..c.rows).filter(|&i| lo[i] == 50.0).collect();
        assert_eq!(narrow.len(), 2);
        for i in narrow {
            assert!(v[i].is_nan() && np[i] == 1.0, "{} {}", v[i], np[i]);
            assert!(note[i].starts_with("fit failed:"), "{}", note[i]);
        }
        // One window that fits has no spread: NaN and a note, not a 0 that
        // would read as a fit independent of its range.
        let params = yaml(
            "{form: power_law, data: data, x: x, y: exact, y_err: exact_err, \
             rename: {exponent: slope}, ranges: [[1, 10], [50, 50.5]]}",
        );
        let one = Fit.run(&ctx, &params, &inputs).unwrap();
        assert!(std_of(&one).is_nan(), "{}", std_of(&one));
        // Two windows around the same points are one window.
        let params = yaml(
            "{form: power_law, data: data, x: x, y: cross, y_err: cross_err, \
             rename: {exponent: slope}, ranges: [[0.99, 10.5], [0.999, 10.6]]}",
        );
        let same = Fit.run(&ctx, &params, &inputs).unwrap();
        assert!(std_of(&same).is_nan(), "{}", std_of(&same));
        let (_, notes) = quantities(&one.files["parquet"]);
        assert!(
            notes
                .iter()
                .any(|n| n.contains("fewer than two of the 2 windows")),
            "{notes:?}"
        );
        // Bad windows and scans of no form are refused before anything runs.
        let e = Fit
            .validate(&yaml(
                "{form: power_law, data: d, x: t, y: Q, ranges: [[2, 1]]}",
            ))
            .unwrap_err();
        assert!(e.to_string().contains("[2, 1]"), "{e}");
        let e = Fit
            .validate(&yaml(
                "{form: value, data: d, x: t, y: Q, ranges: [[1, 2]]}",
            ))
            .unwrap_err();
        assert!(e.to_string().contains("`ranges`"), "{e}");
        let e = Fit
            .validate(&yaml(
                "{form: power_law, data: d, x: t, y: Q, ranges: [1, 2]}",
            ))
            .unwrap_err();
        // Located: the planner points at `ranges` in the YAML.
        let at = &e
            .downcast_ref::<crate::pipeline::canon::ParamError>()
            .unwrap()
            .path;
        assert_eq!(at.first().map(String::as_str), Some("ranges"), "{e:#}");
    }

    /// The output of a stage as an input artifact of stage `stage`; `skip`: a
    /// file left out.
    fn output_artifact(dir: &std::path::Path, stage: &str, out: &Output, skip: &str) -> Artifact {
        let mut a = artifact(dir, stage, f64_batch(&[("x", vec![0.0])]).unwrap());
        a.files.clear();
        for (ext, bytes) in out.files.iter().filter(|(e, _)| *e != skip) {
            let path = dir.join(format!("{stage}.{ext}"));
            std::fs::write(&path, bytes).unwrap();
            a.files.insert(ext.clone(), (String::new(), path));
        }
        a
    }

    /// chi4(tau_alpha) = A (phi_c - phi)^-gamma_chi with phi_c from the
    /// tau_alpha fit of the same replicas (Fig. 15): synthetic replicas with known
    /// truth, many realisations. Holding phi_c at its value in the refits quotes
    /// less than half the true spread of gamma_chi; refitting it with the same
    /// replica left out (the tau fit's `jackknife.parquet`) quotes the spread.
    #[test]
    fn a_number_taken_from_another_fit_is_refitted_on_the_same_replicas() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let phi = [0.60, 0.66, 0.70, 0.73, 0.75, 0.76, 0.77, 0.78];
        let (phi_c, replicas, noise) = (0.80, 4, 0.15);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        // Table of y = truth(phi) x lognormal noise per replica, pooled, with the
        // replica jackknife columns; unit = state point.
        let mut table = |y: &str, truth: &dyn Fn(f64) -> f64| -> RecordBatch {
            let mut cols: Vec<(String, Vec<f64>)> = vec![
                ("phi".into(), phi.to_vec()),
                (y.into(), vec![]),
                (format!("{y}_err"), vec![]),
                (
                    pool::JK_UNIT.into(),
                    (1..=phi.len()).map(|u| u as f64).collect(),
                ),
            ];
            let mut jk = vec![vec![]; replicas];
            for &p in &phi {
                let r: Vec<f64> = (0..replicas)
                    .map(|_| {
                        let z: f64 = StandardNormal.sample(&mut rng);
                        truth(p) * (noise * z).exp()
                    })
                    .collect();
                let (mean, std) = crate::analysis::stats::mean_std(&r);
                cols[1].1.push(mean);
                cols[2].1.push(std / (replicas as f64).sqrt());
                for (k, jk) in jk.iter_mut().enumerate() {
                    jk.push((mean * replicas as f64 - r[k]) / (replicas - 1) as f64);
                }
            }
            for (k, v) in jk.into_iter().enumerate() {
                cols.push((pool::jk_column(y, k), v));
            }
            let cols: Vec<(&str, Vec<f64>)> =
                cols.iter().map(|(n, v)| (n.as_str(), v.clone())).collect();
            f64_batch(&cols).unwrap()
        };
        let tau_fit =
            yaml("{form: power_law_offset, data: tau, x: phi, y: tau_alpha, y_err: tau_alpha_err}");
        let chi_fit = yaml(
            "{form: power_law_offset, data: peaks, x: phi, y: chi4, y_err: chi4_err, \
             fixed_from: {phi_c: {stage: power_law, quantity: phi_c}}, rename: {gamma: gamma_chi}}",
        );
        let (mut values, mut with, mut held) = (vec![], vec![], vec![]);
        for _ in 0..60 {
            let tau = table("tau_alpha", &|p| 0.05 * (phi_c - p).powf(-1.5));
            let chi = table("chi4", &|p| 2.0 * (phi_c - p).powf(-0.8));
            let tau = artifact(dir.path(), "tau", tau);
            let out = Fit.run(&ctx, &tau_fit, &[tau]).unwrap();
            assert!(out.files.contains_key(JACKKNIFE_FILE));
            let peaks = artifact(dir.path(), "peaks", chi);
            let gamma = |skip: &str| {
                let source = output_artifact(dir.path(), "power_law", &out, skip);
                let o = Fit.run(&ctx, &chi_fit, &[peaks.clone(), source]).unwrap();
                let c = Columns::read_file(&[&artifact_of(dir.path(), &o)], "parquet").unwrap();
                c.quantity("gamma_chi").unwrap()
            };
            let (v, e) = gamma("");
            values.push(v);
            with.push(e);
            held.push(gamma(JACKKNIFE_FILE).1);
        }
        let (_, spread) = crate::analysis::stats::mean_std(&values);
        let rms = |e: &[f64]| (e.iter().map(|e| e * e).sum::<f64>() / e.len() as f64).sqrt();
        let (with, held) = (rms(&with) / spread, rms(&held) / spread);
        eprintln!("gamma_chi: quoted/spread {with:.2} refitted, {held:.2} held");
        assert!(
            (0.75..1.35).contains(&with),
            "quoted/spread {with} (held: {held})"
        );
        assert!(held < 0.6, "quoted/spread with phi_c held {held}");
    }

    /// The cluster cut-off collapse (Fig. 13) takes phi_c from the tau_alpha
    /// fit: its refits with a replica left out move N* = (phi_c - phi)^(-1/rho)
    /// most at the densest points, so rho's error must count them. Curves that
    /// collapse exactly (covariance error tiny) and a tau fit whose two
    /// replicas disagree: rho's value is the same either way, its error grows
    /// far beyond the covariance's when the refits are used.
    #[test]
    fn the_cluster_collapse_counts_the_replica_spread_of_phi_c() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let (phi_c, kappa, rho): (f64, f64, f64) = (0.80, 1.8, 1.63);
        let phis = [0.62, 0.66, 0.70, 0.73, 0.75, 0.76, 0.77, 0.78];
        // tau_alpha per phi from two replicas 10% apart, alternating in sign.
        let (mut tau, mut t0, mut t1) = (vec![], vec![], vec![]);
        for (i, p) in phis.iter().enumerate() {
            let t = 0.05 * (phi_c - p).powf(-1.5);
            let d = if i % 2 == 0 { 0.1 } else { -0.1 };
            tau.push(t);
            t0.push(t * (1.0 + d));
            t1.push(t * (1.0 - d));
        }
        let tau_table = f64_batch(&[
            ("phi", phis.to_vec()),
            ("tau_alpha", tau.clone()),
            ("tau_alpha_err", tau.iter().map(|t| 0.1 * t).collect()),
            (pool::JK_UNIT, (1..=phis.len()).map(|u| u as f64).collect()),
            ("tau_alpha_jk0", t0),
            ("tau_alpha_jk1", t1),
        ])
        .unwrap();
        let tau_fit =
            yaml("{form: power_law_offset, data: tau, x: phi, y: tau_alpha, y_err: tau_alpha_err}");
        let out = Fit
            .run(&ctx, &tau_fit, &[artifact(dir.path(), "tau", tau_table)])
            .unwrap();
        let fitted_phi_c = Columns::read_file(&[&artifact_of(dir.path(), &out)], "parquet")
            .unwrap()
            .quantity("phi_c")
            .unwrap()
            .0;
        // P(Nc) = Nc^-kappa exp(-Nc / N*), N* from the fitted phi_c: an exact collapse.
        let (mut phi, mut nc, mut p, mut e) = (vec![], vec![], vec![], vec![]);
        for &f in &phis[..7] {
            let n_star = (fitted_phi_c - f).powf(-1.0 / rho);
            for k in 0..12 {
                let n = 2f64.powf(0.5 * k as f64);
                let v = n.powf(-kappa) * (-n / n_star).exp();
                phi.push(f);
                nc.push(n);
                p.push(v);
                e.push(0.01 * v);
            }
        }
        let sizes = artifact(
            dir.path(),
            "sizes",
            f64_batch(&[("phi", phi), ("Nc", nc), ("P", p), ("P_err", e)]).unwrap(),
        );
        let collapse = yaml(
            "{rescaling: cluster_cutoff, data: sizes, x: Nc, y: P, y_err: P_err, curve_by: phi, \
             phi_c_from: {stage: power_law, quantity: phi_c}, bounds: {kappa: [1.0, 3.0], rho: [0.5, 5.0]}}",
        );
        let rho_of = |skip: &str| {
            let source = output_artifact(dir.path(), "power_law", &out, skip);
            let o = Collapse
                .run(&ctx, &collapse, &[sizes.clone(), source])
                .unwrap();
            let (_, meta) = crate::table::read_parquet_bytes(o.files["parquet"].clone()).unwrap();
            let method = meta
                .into_iter()
                .find(|(k, _)| k == ERROR_METHOD)
                .map(|(_, v)| v)
                .unwrap_or_default();
            let c = fitted(dir.path(), &o);
            (c.quantity("rho").unwrap(), method)
        };
        let ((v_held, e_held), _) = rho_of(JACKKNIFE_FILE);
        let ((v, e), method) = rho_of("");
        assert!((v_held - rho).abs() < 0.03, "rho {v_held}");
        assert_eq!(v.to_bits(), v_held.to_bits(), "the value does not change");
        assert!(
            e > 5.0 * e_held,
            "rho error {e} with phi_c refitted, {e_held} held"
        );
        assert!(method.contains("phi_c"), "error method: {method}");
    }

    /// `scatter: relative` on points that scatter 20% about a power law with
    /// errors of 0.1% (reduced chi^2 in the thousands): the fit is the same as
    /// one told the widened errors sqrt(e^2 + (s_m y)^2) directly, whose reduced
    /// chi^2 is 1; the table keeps the reduced chi^2 of the errors alone. A
    /// scatter other than `relative`, or without `y_err`, is refused.
    #[test]
    fn a_relative_model_scatter_brings_the_reduced_chi2_to_one() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "scatter".into(), None);
        let x: Vec<f64> = (0..12).map(|i| 10f64.powf(0.25 * i as f64)).collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, x)| 2.0 * x.powf(0.5) * if i % 2 == 0 { 1.2 } else { 0.8 })
            .collect();
        let e: Vec<f64> = y.iter().map(|v| 1e-3 * v).collect();
        let data = |e: Vec<f64>| {
            artifact(
                dir.path(),
                "v",
                f64_batch(&[("F", x.clone()), ("v", y.clone()), ("v_err", e)]).unwrap(),
            )
        };
        let with = fitted(
            dir.path(),
            &Fit.run(
                &ctx,
                &yaml("{form: power_law, x: F, y: v, y_err: v_err, scatter: relative}"),
                &[data(e.clone())],
            )
            .unwrap(),
        );
        let m = with.quantity("scatter").unwrap().0;
        assert!((0.1..0.4).contains(&m), "scatter {m}");
        assert!(with.quantity("reduced_chi2").unwrap().0 > 1000.0);
        let widened: Vec<f64> = e.iter().zip(&y).map(|(e, v)| e.hypot(m * v)).collect();
        let direct = fitted(
            dir.path(),
            &Fit.run(
                &ctx,
                &yaml("{form: power_law, x: F, y: v, y_err: v_err}"),
                &[data(widened)],
            )
            .unwrap(),
        );
        assert!((direct.quantity("reduced_chi2").unwrap().0 - 1.0).abs() < 1e-6);
        for q in ["A", "exponent"] {
            let (a, b) = (with.quantity(q).unwrap(), direct.quantity(q).unwrap());
            assert!(
                (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9,
                "{q}: {a:?} {b:?}"
            );
        }
        for bad in [
            "{form: power_law, x: F, y: v, y_err: v_err, scatter: absolute}",
            "{form: power_law, x: F, y: v, scatter: relative}",
        ] {
            let err = Fit.validate(&yaml(bad)).unwrap_err().to_string();
            assert!(err.contains("scatter"), "{bad}: {err}");
        }
    }

    /// The fitted numbers of a fit's output: (quantity, value, error) by name.
    fn fitted(dir: &std::path::Path, out: &Output) -> Columns {
        Columns::read_file(&[&artifact_of(dir, out)], "parquet").unwrap()
    }

    /// A curve on one state point whose replicas differ as a whole (an offset
    /// and a slope per replica, shared by every point) while each point's
    /// error counts only the small independent part: the fit covariance says
    /// the slope is known far better than it is; the replica jackknife says
    /// how well. 60 realisations, 4 replicas, 10 points.
    #[test]
    fn a_fit_on_one_state_point_takes_its_error_from_the_replicas() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let (replicas, shared, own) = (4usize, 0.2, 0.01);
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let fit = yaml("{form: line, data: c, x: lag, y: Q, y_err: Q_err}");
        let (mut values, mut jk, mut cov) = (vec![], vec![], vec![]);
        for _ in 0..60 {
            let mut z = || -> f64 { StandardNormal.sample(&mut rng) };
            let curves: Vec<Vec<f64>> = (0..replicas)
                .map(|_| {
                    let (a, b) = (shared * z(), shared * z());
                    x.iter()
                        .map(|x| 1.0 + a + (2.0 + b) * x + own * z())
                        .collect()
                })
                .collect();
            let mean = |skip: Option<usize>| -> Vec<f64> {
                let n = replicas - usize::from(skip.is_some());
                (0..x.len())
                    .map(|i| {
                        (0..replicas)
                            .filter(|&r| Some(r) != skip)
                            .map(|r| curves[r][i])
                            .sum::<f64>()
                            / n as f64
                    })
                    .collect()
            };
            let mut cols: Vec<(String, Vec<f64>)> = vec![
                ("lag".into(), x.clone()),
                ("Q".into(), mean(None)),
                (
                    "Q_err".into(),
                    vec![own / (replicas as f64).sqrt(); x.len()],
                ),
            ];
            let plain = {
                let c: Vec<(&str, Vec<f64>)> =
                    cols.iter().map(|(n, v)| (n.as_str(), v.clone())).collect();
                f64_batch(&c).unwrap()
            };
            cols.push((pool::JK_UNIT.into(), vec![7.0; x.len()]));
            for k in 0..replicas {
                cols.push((pool::jk_column("Q", k), mean(Some(k))));
            }
            let c: Vec<(&str, Vec<f64>)> =
                cols.iter().map(|(n, v)| (n.as_str(), v.clone())).collect();
            let with = f64_batch(&c).unwrap();
            let o = Fit
                .run(&ctx, &fit, &[artifact(dir.path(), "c", with)])
                .unwrap();
            let (v, e) = fitted(dir.path(), &o).quantity("slope").unwrap();
            values.push(v);
            jk.push(e);
            let o = Fit
                .run(&ctx, &fit, &[artifact(dir.path(), "c", plain)])
                .unwrap();
            cov.push(fitted(dir.path(), &o).quantity("slope").unwrap().1);
        }
        let (_, spread) = crate::analysis::stats::mean_std(&values);
        let rms = |e: &[f64]| (e.iter().map(|e| e * e).sum::<f64>() / e.len() as f64).sqrt();
        let (jk, cov) = (rms(&jk) / spread, rms(&cov) / spread);
        eprintln!("slope: quoted/spread {jk:.2} jackknife, {cov:.3} covariance");
        assert!((0.75..1.35).contains(&jk), "jackknife quoted/spread {jk}");
        assert!(cov < 0.2, "covariance quoted/spread {cov}");
    }

    /// Fits on one state point each (one per phi) quote their covariance
    /// error times one factor per fitted number, from the mean square of
    /// jackknife / covariance over the stage's fits: two lines whose two
    /// replicas move the slope by +-0.1 and +-0.3, same points and errors,
    /// both quote sqrt((0.1^2 + 0.3^2) / 2).
    #[test]
    fn one_state_point_fits_pool_their_jackknife_scale() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let q = [0.1, 0.2, 0.3, 0.4];
        let (mut x, mut phi, mut unit, mut y, mut y0, mut y1) =
            (vec![], vec![], vec![], vec![], vec![], vec![]);
        for (p, d, u) in [(0.70, 0.1, 1.0), (0.76, 0.3, 2.0)] {
            for &v in &q {
                x.push(v);
                phi.push(p);
                unit.push(u);
                y.push(1.0 + 2.0 * v);
                y0.push(1.0 + (2.0 + d) * v);
                y1.push(1.0 + (2.0 - d) * v);
            }
        }
        let t = f64_batch(&[
            ("phi", phi),
            ("q", x),
            ("S4", y),
            ("S4_err", vec![0.01; 8]),
            (pool::JK_UNIT, unit),
            ("S4_jk0", y0),
            ("S4_jk1", y1),
        ])
        .unwrap();
        let fit = yaml("{form: line, data: s4, x: q, y: S4, y_err: S4_err, group_by: [phi]}");
        let out = Fit
            .run(&ctx, &fit, &[artifact(dir.path(), "s4", t)])
            .unwrap();
        let c = fitted(dir.path(), &out);
        let want = ((0.1f64.powi(2) + 0.3f64.powi(2)) / 2.0).sqrt();
        let (phi, name, err) = (
            c.col("phi").unwrap(),
            &c.str["quantity"],
            c.col("error").unwrap(),
        );
        for p in [0.70, 0.76] {
            let i = (0..c.rows)
                .find(|&i| phi[i] == p && name[i] == "slope")
                .unwrap();
            assert!(
                (err[i] - want).abs() < 1e-9,
                "phi {p}: error {} want {want}",
                err[i]
            );
        }
    }

    /// Each replica sample of a fit on one state point is refitted with its
    /// own per-point errors (`y_err_jkK`) and passes the fit's `where` on y:
    /// sample 0's last two points carry huge errors (it barely saw them), so
    /// its refit follows the first four; sample 1 has an empty bin (P = 0)
    /// that `P > 0` drops, where a log fit would fail.
    #[test]
    fn replica_samples_are_refitted_with_their_own_errors_and_the_fits_where() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let dx = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let tail = |x0: f64| -> Vec<f64> { dx.iter().map(|x: &f64| (-x / x0).exp()).collect() };
        let mut p0 = tail(1.2);
        p0[4] *= 5.0;
        p0[5] *= 5.0;
        let mut p1 = tail(0.8);
        p1[5] = 0.0;
        let rel = |p: &[f64], r: f64| -> Vec<f64> { p.iter().map(|v| r * v).collect() };
        let mut e0 = rel(&p0, 0.01);
        e0[4] = 100.0;
        e0[5] = 100.0;
        let t = f64_batch(&[
            ("dx", dx.to_vec()),
            ("P", tail(1.0)),
            ("P_err", rel(&tail(1.0), 0.01)),
            (pool::JK_UNIT, vec![3.0; 6]),
            ("P_jk0", p0),
            ("P_jk1", p1.clone()),
            ("P_err_jk0", e0),
            ("P_err_jk1", rel(&p1, 0.01)),
        ])
        .unwrap();
        let fit = yaml(
            "{form: exponential_tail, data: vh, x: dx, y: P, y_err: P_err, where: {P: {min: 1.0e-10}}}",
        );
        let out = Fit
            .run(&ctx, &fit, &[artifact(dir.path(), "vh", t)])
            .unwrap();
        let c = fitted(dir.path(), &out);
        let i = (0..c.rows).find(|&i| c.str["quantity"][i] == "x0").unwrap();
        let (jk0, jk1) = (
            c.col("value_jk0").unwrap()[i],
            c.col("value_jk1").unwrap()[i],
        );
        assert!((jk0 - 1.2).abs() < 1e-3, "sample 0 refit x0 = {jk0}");
        assert!((jk1 - 0.8).abs() < 1e-6, "sample 1 refit x0 = {jk1}");
        let err = c.col("error").unwrap()[i];
        assert!((err - (jk0 - jk1).abs() / 2.0).abs() < 1e-9, "error {err}");
    }

    /// A fit per state point on the rows of one unit (xi from the OZ fit of
    /// one phi's S4 over q) carries its numbers refitted with each replica left
    /// out; `join` turns them into `NAME_jkK` beside `jk_unit`, so that a fit
    /// across state points (xi against phi) takes its error from the replicas.
    #[test]
    fn a_fit_per_state_point_carries_its_replica_refits_through_the_join() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let states = [(0.70, 2.0, 11.0), (0.73, 3.0, 12.0), (0.76, 4.0, 13.0)];
        let (mut q, mut phi, mut unit) = (vec![], vec![], vec![]);
        for &(p, _, u) in &states {
            for x in [0.1, 0.2, 0.3, 0.4] {
                q.push(x);
                phi.push(p);
                unit.push(u);
            }
        }
        // Per phi the pooled line has slope 2, 3, 4; replica 0 left out gives
        // slope +1, replica 1 left out slope -1.
        let line = |q: &[f64], phi: &[f64], d: f64| -> Vec<f64> {
            q.iter()
                .zip(phi)
                .map(|(q, p)| {
                    let b = states.iter().find(|s| s.0 == *p).unwrap().1;
                    1.0 + (b + d) * q
                })
                .collect()
        };
        let s4 = f64_batch(&[
            ("phi", phi.clone()),
            ("q", q.clone()),
            ("S4", line(&q, &phi, 0.0)),
            ("S4_err", vec![0.01; 12]),
            (pool::JK_UNIT, unit.clone()),
            ("S4_jk0", line(&q, &phi, 1.0)),
            ("S4_jk1", line(&q, &phi, -1.0)),
        ])
        .unwrap();
        let fit = yaml("{form: line, data: s4, x: q, y: S4, y_err: S4_err, group_by: [phi]}");
        let out = Fit
            .run(&ctx, &fit, &[artifact(dir.path(), "s4", s4)])
            .unwrap();
        let fitted = output_artifact(dir.path(), "oz", &out, JACKKNIFE_FILE);
        let tau = f64_batch(&[
            ("phi", vec![0.70, 0.73, 0.76]),
            ("tau_alpha", vec![2.5, 3.6, 6.3]),
            (pool::JK_UNIT, vec![11.0, 12.0, 13.0]),
        ])
        .unwrap();
        let join = yaml("{left: tau, right: oz, on: [phi]}");
        let joined = crate::stages::join::Join
            .run(&ctx, &join, &[artifact(dir.path(), "tau", tau), fitted])
            .unwrap();
        let c = Columns::read_file(&[&artifact_of(dir.path(), &joined)], "parquet").unwrap();
        let near = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(a, b)| (a - b).abs() < 1e-9);
        assert!(near(c.col("slope").unwrap(), &[2.0, 3.0, 4.0]));
        assert!(near(c.col("slope_jk0").unwrap(), &[3.0, 4.0, 5.0]));
        assert!(near(c.col("slope_jk1").unwrap(), &[1.0, 2.0, 3.0]));
        assert!(near(c.col("intercept_jk0").unwrap(), &[1.0; 3]));
        assert_eq!(c.col(pool::JK_UNIT).unwrap(), &[11.0, 12.0, 13.0]);
        // Downstream the slope across phi has a replica jackknife error: a
        // state's slope moves by +-1 per replica left out, the fitted slope by
        // +-(phi - mean phi) / Sxx, zero for the middle state.
        let across = yaml("{form: line, data: xi_table, x: phi, y: slope, y_err: slope_err}");
        let xi_table = output_artifact(dir.path(), "xi_table", &joined, "");
        let o = Fit.run(&ctx, &across, &[xi_table]).unwrap();
        let c = Columns::read_file(&[&artifact_of(dir.path(), &o)], "parquet").unwrap();
        let (b, db) = c.quantity("slope").unwrap();
        assert!((b - 1.0 / 0.03).abs() < 1e-6, "slope {b}");
        // Per end state (R - 1)/R sum_k (theta_k - mean)^2 = (0.03 / Sxx)^2.
        let expected = 2.0f64.sqrt() * 0.03 / (2.0 * 0.03 * 0.03);
        assert!(
            (db - expected).abs() < 1e-6 * expected,
            "error {db}, expected {expected}"
        );
    }

    /// A grouped fit where one group's fit fails (too few points): the groups
    /// with replica samples and the failed one still make one table, the failed
    /// one's samples NaN.
    #[test]
    fn groups_with_and_without_replica_samples_make_one_table() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let line = |d: f64| vec![1.0, 1.0 + 0.1 * (2.0 + d), 1.0 + 0.2 * (2.0 + d), 1.0];
        let s4 = f64_batch(&[
            ("phi", vec![0.70, 0.70, 0.70, 0.76]),
            ("q", vec![0.0, 0.1, 0.2, 0.1]),
            ("S4", line(0.0)),
            ("S4_err", vec![0.01; 4]),
            (pool::JK_UNIT, vec![11.0, 11.0, 11.0, 12.0]),
            ("S4_jk0", line(1.0)),
            ("S4_jk1", line(-1.0)),
        ])
        .unwrap();
        let fit = yaml("{form: line, data: s4, x: q, y: S4, y_err: S4_err, group_by: [phi]}");
        let out = Fit
            .run(&ctx, &fit, &[artifact(dir.path(), "s4", s4)])
            .unwrap();
        let c = Columns::read_file(&[&artifact_of(dir.path(), &out)], "parquet").unwrap();
        let (phi, q, jk0) = (
            c.col("phi").unwrap(),
            &c.str["quantity"],
            c.col("value_jk0").unwrap(),
        );
        let at = |p: f64, name: &str| (0..c.rows).find(|&i| phi[i] == p && q[i] == name).unwrap();
        assert!((jk0[at(0.70, "slope")] - 3.0).abs() < 1e-9);
        assert!(jk0[at(0.76, "slope")].is_nan());
    }

    /// Fig. 19's collapse with the measured xi: where the data carry xi's
    /// replica samples, the refits rescale with the xi of the same replica left
    /// out. Here chi4P is the same in every replica, so only xi can give g an
    /// error: held at its value it gives none.
    #[test]
    fn the_collapse_refits_the_measured_xi_on_the_same_replicas() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "jk".into(), None);
        let (g, sizes) = (1.5, [8.0, 16.0, 32.0, 64.0, 125.0, 250.0, 500.0, 1000.0]);
        let states = [(0.70, 2.0, 1.0), (0.74, 3.0, 2.0), (0.78, 4.5, 3.0)];
        let mut cols: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for &(phi, xi, unit) in &states {
            for &n in &sizes {
                let u: f64 = f64::sqrt(n) / xi;
                let chi = xi.powf(g) * u.powf(1.2) / (1.0 + u.powf(1.2));
                for (k, v) in [
                    ("phi", phi),
                    ("N", n),
                    ("chi4P", chi),
                    ("chi4P_err", 0.02 * chi),
                    ("chi4P_jk0", chi),
                    ("chi4P_jk1", chi),
                    (pool::JK_UNIT, unit),
                    ("xi", xi),
                    ("xi_jk0", xi * 1.1),
                    ("xi_jk1", xi * 0.9),
                ] {
                    cols.entry(k).or_default().push(v);
                }
            }
        }
        let run = |skip: &[&str]| -> (f64, f64, String) {
            let b: Vec<(&str, Vec<f64>)> = cols
                .iter()
                .filter(|(k, _)| !skip.contains(k))
                .map(|(k, v)| (*k, v.clone()))
                .collect();
            let data = artifact(dir.path(), "peaks_xi", f64_batch(&b).unwrap());
            let params = yaml(
                "{data: peaks_xi, x: 'N', y: chi4P, y_err: chi4P_err, curve_by: phi, xi: xi,                  bounds: {g: [0.2, 4.0]}}",
            );
            let out = Collapse.run(&ctx, &params, &[data]).unwrap();
            let a = artifact_of(dir.path(), &out);
            let (_, meta) =
                crate::table::read_parquet_bytes(std::fs::read(&a.files["parquet"].1).unwrap())
                    .unwrap();
            let c = Columns::read_file(&[&a], "parquet").unwrap();
            let (v, e) = c.quantity("gamma_chi_over_gamma_xi").unwrap();
            (v, e, format!("{meta:?}"))
        };
        let (v, e, method) = run(&[]);
        assert!((v - g).abs() < 0.02, "g = {v}");
        assert!(e > 0.05, "error of g {e} with xi refitted ({method})");
        assert!(method.contains("measured xi"), "{method}");
        let (v_held, e_held, _) = run(&["xi_jk0", "xi_jk1"]);
        assert_eq!(v_held, v);
        assert!(e_held < 1e-6, "error of g {e_held} with xi held");
    }

    /// The main table of an output, as an artifact.
    fn artifact_of(dir: &std::path::Path, out: &Output) -> Artifact {
        output_artifact(dir, "out", out, JACKKNIFE_FILE)
    }

    /// The Gaussian draws its curve at its group's lag t, named after the columns.
    #[test]
    fn the_gaussian_draws_its_fitted_curve() {
        let dir = tempfile::tempdir().unwrap();
        let d = 0.4;
        let mut cols: [Vec<f64>; 3] = Default::default();
        for t in [1.0, 4.0] {
            for i in 0..61 {
                let dx = -6.0 + 0.2 * i as f64;
                let w = 4.0 * d * t;
                cols[0].push(t);
                cols[1].push(dx);
                cols[2].push((-dx * dx / w).exp() / (std::f64::consts::PI * w).sqrt());
            }
        }
        let [t, dx, p] = cols;
        let b = f64_batch(&[("t", t), ("dx", dx), ("P", p)]).unwrap();
        let inputs = [artifact(dir.path(), "vh", b)];
        let ctx = StageCtx::new(0, "gauss".into(), None);
        let params =
            yaml("{form: gaussian, data: vh, x: dx, y: P, group_by: [t], curve: {points: 11}}");
        let out = Fit.run(&ctx, &params, &inputs).unwrap();
        let (c, _) = crate::table::read_parquet_bytes(out.files["curve.parquet"].clone()).unwrap();
        let c = Columns::from_batch(&c[0]).unwrap();
        let (t, dx, p) = (
            c.col("t").unwrap(),
            c.col("dx").unwrap(),
            c.col("P").unwrap(),
        );
        assert_eq!(p.len(), 22);
        for i in 0..p.len() {
            let w = 4.0 * d * t[i];
            let truth = (-dx[i] * dx[i] / w).exp() / (std::f64::consts::PI * w).sqrt();
            assert!(
                (p[i] - truth).abs() < 1e-6 * truth.max(1e-3),
                "{i}: {} vs {truth}",
                p[i]
            );
        }
    }
}
