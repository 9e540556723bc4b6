//! The `fit` stage kind: its parameters checked and explained, the rows split
//! into groups, each group fitted, and the groups' tables written as one.

use std::collections::BTreeMap;

use anyhow::{Context, Result, bail};
use serde_json::Value;

use super::group::{TakenNumbers, fit_group};
use super::params::{FitForm, FitParams};
use super::pooling::pool_one_unit_errors;
use super::quantities::same_columns;
use super::{ERROR_METHOD, JACKKNIFE_FILE};

/// The share of a taken number's quoted variance its replica refits may leave
/// out before the rest is passed on (rounding between the two is not a rest).
const HELD_REST: f64 = 0.01;
use crate::fit::catalogue;
use crate::fit::uncertainty::replicas::refits_variance;
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::stages::tables::{Columns, inputs_of, source_stages};
use crate::table::to_parquet_bytes;

pub struct Fit;

impl StageKind for Fit {
    type Params = FitParams;
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
        let form = match p.form {
            FitForm::Named(f) => format!("`{}`: {}", f.name, f.describe),
            FitForm::Value => "`value`: the mean of y over the selected rows".into(),
            FitForm::Drift => "`drift`: relative change of y over the x range, from a line".into(),
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
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<FitParams> {
        let p: FitParams = typed("fit", params)?;
        let form = p.form.named();
        if !p.ranges.is_empty() && form.is_none() {
            bail!(
                "fit: `ranges` scans the fit of a named form; form `{}` fits none",
                p.form.name()
            );
        }
        if let Some(sc) = &p.scatter
            && (sc != "relative" || p.y_err.is_none() || form.is_none())
        {
            bail!(
                "fit: `scatter: {sc}`: the only model scatter is `relative`, for a named form with `y_err` (without y_err the errors are scaled to the scatter already)"
            );
        }
        if let Some(xe) = &p.x_err
            && (p.y_err.is_none() || form.is_none())
        {
            bail!(
                "fit: `x_err: {xe}` widens the y errors by the model's slope: it needs a named form and `y_err`"
            );
        }
        let name = p.form.name();
        if crate::fit::catalogue::HOLD_NONE.contains(&name)
            && !(p.fixed.is_empty() && p.fixed_from.is_empty())
        {
            bail!(
                "fit: form `{name}` fits every parameter at once and cannot hold one (`fixed`, `fixed_from`); hold it in a form that can (e.g. `power_law_offset`), or divide the data by the held law (a `join` with `derive`)"
            );
        }
        for (lo, hi) in &p.ranges {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                bail!(
                    "fit: the range [{lo}, {hi}] of `ranges` is empty; give [x_min, x_max] with x_min < x_max"
                );
            }
        }
        Ok(p)
    }
    fn run(&self, ctx: &StageCtx, p: &FitParams, inputs: &[Artifact]) -> Result<Output> {
        let c = Columns::read_file(&data_inputs(&p, inputs)?, &p.file)?;
        let rows = c.select(&p.filter)?;
        let mut fixed: Vec<(String, f64)> = p.fixed.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let mut taken = TakenNumbers::default();
        for (name, from) in &p.fixed_from {
            let (value, err) = from.get("fit", inputs)?;
            fixed.push((name.clone(), value));
            if let Some(why) = from.inherited_unreliable(name, "fit", inputs)? {
                taken.unreliable = Some(why);
            }
            match from.jackknife("fit", inputs)? {
                Some(r) => {
                    // Its refits carry the replicas' share of its error; what its
                    // fit quotes beyond them (a model scatter, a pooled error) is
                    // passed on as a held number's, or the held number and all
                    // fitted with it would quote the replica spread alone.
                    let rest = err * err - refits_variance(&r);
                    if err.is_finite() && rest > HELD_REST * err * err {
                        taken.held.push((name.clone(), value, rest.sqrt()));
                    }
                    taken.refits.push((name.clone(), r));
                }
                None => taken.held.push((name.clone(), value, err)),
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
            for (name, x0) in &p.fixed_at_x {
                fixed.push((name.clone(), value_at_x(&p, &c, &keys, &key, *x0)?));
            }
            fitted.push(fit_group(ctx, &p, &c, &rows, &group, &fixed, &taken)?);
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

/// The y of the row of group `key` (the `group_by` columns `keys`) whose x is
/// `x0`, from every row of the table (not only those the filter keeps).
fn value_at_x(p: &FitParams, c: &Columns, keys: &[&[f64]], key: &[u64], x0: f64) -> Result<f64> {
    let (x, y) = (c.col(&p.x)?, c.col(&p.y)?);
    (0..c.rows)
        .find(|&i| x[i] == x0 && keys.iter().zip(key).all(|(k, &v)| ordered(k[i]) == v))
        .map(|i| y[i])
        .with_context(|| {
            format!(
                "fit: `fixed_at_x` asks for {} at {} = {x0}, and the group {:?} has no such row",
                p.y,
                p.x,
                key.iter().map(|&v| unordered(v)).collect::<Vec<_>>()
            )
        })
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
