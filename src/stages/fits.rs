//! `fit` and `collapse`: fitted numbers as tables `quantity, value, error, note`
//! (what `compare` reads), plus the drawn fit line or the rescaled data.
//!
//! A fit that fails (no divergence found, too few points, curves that do not
//! overlap) does not fail the stage: its quantities are NaN and `note` says why,
//! so the figure is still drawn and `compare` reports the number as missing.

use std::collections::BTreeMap;
use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray};
use serde::Deserialize;
use serde_json::Value;

use super::tables::{Columns, Where, inputs_of, pick};
use crate::fit::catalogue::{self, Form};
use crate::fit::collapse::{self, Curve};
use crate::fit::{Data, FitResult, linear};
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};

const MODULES: &[&str] = &["fit", "table", "stages/fits", "stages/tables"];

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
}

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
    /// Stage whose table holds the data.
    pub data: String,
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
    let d = Data::new(x, y, s);
    let f = match named_form(p)? {
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
        let mut s = String::from(
            "parameters: form, data (stage), file, x, y, y_err, where, fixed, fixed_from, rename, curve, group_by\nforms:\n",
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
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, params: &Value) -> Result<()> {
        let p: FitParams = typed("fit", params)?;
        named_form(&p).map_err(|e| anyhow::anyhow!("fit: {e}"))?;
        Ok(())
    }
    fn run(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let p: FitParams = typed("fit", params)?;
        let c = Columns::read_file(&inputs_of("fit", inputs, &p.data)?, &p.file)?;
        let rows = c.select(&p.filter)?;
        let mut fixed: Vec<(String, f64)> = p.fixed.iter().map(|(k, v)| (k.clone(), *v)).collect();
        for (name, from) in &p.fixed_from {
            fixed.push((name.clone(), from.get("fit", inputs)?));
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
        let (mut tables, mut curves) = (Vec::new(), Vec::new());
        for (key, rows) in groups {
            let group: Vec<(String, f64)> = p
                .group_by
                .iter()
                .zip(&key)
                .map(|(k, &v)| (k.clone(), unordered(v)))
                .collect();
            let mut fixed = fixed.clone();
            fixed.extend(group.iter().filter(|(k, _)| k == "t").cloned());
            let (t, curve) = fit_group(ctx, &p, &c, &rows, &group, &fixed)?;
            tables.push(t);
            curves.extend(curve);
        }
        let mut out = Output::single("parquet", to_parquet_bytes(&tables, &[])?);
        if p.curve.is_some() {
            out = out.with("curve.parquet", to_parquet_bytes(&curves, &[])?);
        }
        Ok(out)
    }
}

/// A float as a sortable key (groups of equal values, in ascending order).
fn ordered(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 { !b } else { b | (1 << 63) }
}

fn unordered(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// One fit of `p` over `rows` of `c`: its quantity table and its curve (named
/// after the fitted columns, with the group's values).
fn fit_group(
    ctx: &StageCtx,
    p: &FitParams,
    c: &Columns,
    rows: &[usize],
    group: &[(String, f64)],
    fixed: &[(String, f64)],
) -> Result<(RecordBatch, Option<RecordBatch>)> {
    let x = pick(c.col(&p.x)?, rows);
    let y = pick(c.col(&p.y)?, rows);
    let s = match &p.y_err {
        Some(e) => pick(c.col(e)?, rows),
        None => vec![1.0; rows.len()],
    };
    let (x, y, s) = clean(ctx, x, y, s);
    let fixed_ref: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
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
        return Ok((
            quantity_table(group, &[(name("value"), mean, err)], note)?,
            None,
        ));
    }
    let form = named_form(p)?;
    let (rows, note, curve) = match fit_form(p, &x, &y, &s, &fixed_ref) {
        Ok(f) => {
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
            rows.push((name("reduced_chi2"), f.reduced_chi2, f64::NAN));
            rows.push((name("points"), x.len() as f64, 0.0));
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
                    Some(fm) => xs.iter().map(|&v| (fm.model)(&f.params, v)).collect(),
                    None => xs.iter().map(|&v| f.params[0] + f.params[1] * v).collect(),
                };
                (xs, ys)
            });
            (rows, f.warnings.join("; "), curve)
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
            )
        }
    };
    let table = quantity_table(group, &rows, &note)?;
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
    Ok((table, curve))
}

/// `collapse`: finite-size scaling of Fig. 19. Curves y(x) labelled by `curve_by`
/// (phi) rescale as X = sqrt(x)/xi, Y = y xi^-g with xi = (phi_c - phi)^-gamma_xi;
/// g = gamma_chi/gamma_xi and gamma_xi are fitted, phi_c is given or taken from a fit.
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
    /// Search ranges of `g` and `gamma_xi`.
    pub bounds: BTreeMap<String, (f64, f64)>,
}

pub struct Collapse;

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
        if p.phi_c.is_some() == p.phi_c_from.is_some() {
            bail!(
                "collapse: give exactly one of `phi_c` (a number) and `phi_c_from` ({{stage, quantity}})"
            );
        }
        for k in ["g", "gamma_xi"] {
            if !p.bounds.contains_key(k) {
                bail!("collapse: `bounds` needs a search range for '{k}', e.g. {k}: [0.5, 3.0]");
            }
        }
        if p.bounds.len() != 2 {
            bail!("collapse: `bounds` takes exactly the keys g and gamma_xi");
        }
        Ok(())
    }
    fn run(&self, ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let p: CollapseParams = typed("collapse", params)?;
        let phi_c = match (&p.phi_c, &p.phi_c_from) {
            (Some(v), _) => *v,
            (None, Some(f)) => f.get("collapse", inputs)?,
            _ => unreachable!("validated: one of phi_c and phi_c_from"),
        };
        let c = Columns::read(&inputs_of("collapse", inputs, &p.data)?)?;
        let rows = c.select(&p.filter)?;
        let (xc, yc, ec, bc) = (
            c.col(&p.x)?,
            c.col(&p.y)?,
            c.col(&p.y_err)?,
            c.col(&p.curve_by)?,
        );
        let mut by: BTreeMap<u64, Curve> = BTreeMap::new();
        for &i in &rows {
            let ok =
                xc[i] > 0.0 && yc[i] > 0.0 && ec[i] > 0.0 && yc[i].is_finite() && ec[i].is_finite();
            if !ok {
                continue;
            }
            let cv = by.entry(bc[i].to_bits()).or_insert_with(|| Curve {
                label: format!("{}={}", p.curve_by, bc[i]),
                param: bc[i],
                x: vec![],
                y: vec![],
                sigma: vec![],
            });
            cv.x.push(xc[i]);
            cv.y.push(yc[i]);
            cv.sigma.push(ec[i]);
        }
        let mut curves: Vec<Curve> = by.into_values().filter(|c| c.x.len() >= 2).collect();
        curves.sort_by(|a, b| a.param.total_cmp(&b.param));
        let bounds = [p.bounds["g"], p.bounds["gamma_xi"]];
        let rescale = move |q: &[f64], cv: &Curve, x: f64, y: f64, s: f64| {
            let l = xi(phi_c, cv.param, q[1]);
            let f = l.powf(-q[0]);
            (x.sqrt() / l, y * f, s * f)
        };
        let result = if curves.iter().any(|c| c.param >= phi_c) {
            Err(anyhow::anyhow!(
                "phi_c = {phi_c} is not above every {} of the data",
                p.curve_by
            ))
        } else {
            collapse::collapse(&curves, &["g", "gamma_xi"], &bounds, &rescale)
                .map_err(anyhow::Error::from)
        };
        let (rows, note, best) = match result {
            Ok(r) => {
                let (g, dg) = r.get("g").expect("named");
                let (gx, dgx) = r.get("gamma_xi").expect("named");
                let cov = r.covariance[0][1];
                let dgc = (gx * gx * dg * dg + g * g * dgx * dgx + 2.0 * g * gx * cov)
                    .max(0.0)
                    .sqrt();
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
                    .map(|n| (n.to_string(), f64::NAN, f64::NAN))
                    .collect();
                rows.push(("phi_c_used".to_string(), phi_c, 0.0));
                (rows, msg, None)
            }
        };
        let mut cols: [Vec<f64>; 5] = Default::default();
        if let Some(q) = best {
            for cv in &curves {
                for k in 0..cv.x.len() {
                    let (x, y, s) = rescale(&q, cv, cv.x[k], cv.y[k], cv.sigma[k]);
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
            to_parquet_bytes(&[quantity_table(&[], &rows, &note)?], &[])?,
        )
        .with("rescaled.parquet", to_parquet_bytes(&[resc], &[])?))
    }
}
