//! One group's fit: its points, the fit or the mean (`value`), the rows of its
//! quantity table, its drawn curve and its range scan.

use std::sync::Arc;

use anyhow::Result;
use arrow_array::{ArrayRef, Float64Array, RecordBatch};

use super::fitting::{fit_data, fit_form, reported};
use super::params::{CurveSpec, FitForm, FitParams, drift_scale};
use super::ranges::scan_ranges;
use super::samples::{
    jackknife_table, jk_samples, object_replicas, pick_rows, replica_columns, unit_columns,
};
use crate::fit::catalogue::Form;
use crate::fit::uncertainty::held::{add_in_quadrature, held_shifts};
use crate::fit::uncertainty::leverage::{CARRIED, Carried, carried_errors, leverages};
use crate::fit::uncertainty::replicas::{
    FitPoints, Refits, Replicas, covariance_method, mean_jackknife, replica_errors,
};
use crate::fit::uncertainty::scatter::{clean, relative_scatter, widened};
use crate::fit::uncertainty::x_errors::effective_variance;
use crate::fit::{Data, FitResult};
use crate::pipeline::StageCtx;
use crate::stages::tables::{Columns, pick};
use crate::table::results::{UnitSamples, quantity_batch};

/// What one fit of a group writes: its quantity table, its curve, its range
/// scan, how its errors were estimated and its replica jackknife refits.
pub(super) struct Group {
    pub(super) table: RecordBatch,
    pub(super) curve: Option<RecordBatch>,
    pub(super) scan: Vec<RecordBatch>,
    pub(super) method: String,
    pub(super) jackknife: Option<RecordBatch>,
    /// A fit on one unit's rows with a replica jackknife: per fitted number,
    /// (covariance error, jackknife error), for [`super::pooling::pool_one_unit_errors`].
    pub(super) pooled: Option<Vec<(f64, f64)>>,
}

/// The numbers a fit takes from other fits (`fixed_from`): the replica refits
/// of those whose fit has them (its jackknife refits them with the same replica
/// left out), and the value and quoted error of those whose fit has none, or
/// the part of it their refits do not carry (held, their error passed on by
/// [`held_shifts`]).
#[derive(Default)]
pub(super) struct TakenNumbers {
    pub refits: Vec<(String, Refits)>,
    pub held: Vec<(String, f64, f64)>,
    /// A taken number its own fit marks unreliable (a phi_c on its last
    /// point), said so: every number fitted with it inherits the mark.
    pub unreliable: Option<String>,
}

/// One fit of `p` over `rows` of `c`: its quantity table, its curve (named after
/// the fitted columns, with the group's values) and its range scan, if asked for.
pub(super) fn fit_group(
    ctx: &StageCtx,
    p: &FitParams,
    c: &Columns,
    rows: &[usize],
    group: &[(String, f64)],
    fixed: &[(String, f64)],
    from_other: &TakenNumbers,
) -> Result<Group> {
    let pts = group_points(ctx, p, c, rows)?;
    let (x, y) = (&pts.x, &pts.y);
    let fixed_ref: Vec<(&str, f64)> = fixed.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    // `scatter: relative`: s_m and the reduced chi^2 of the errors alone; the
    // fit, its refits and its range scan then weight by the widened errors.
    // `x_err`: the y errors widened by x's first, so that a model scatter is
    // the misfit beyond both.
    let s_xy = match &p.x_err {
        Some(_) => carried_x_errors(p, x, y, &pts.s, &pts.s_x, &fixed_ref)?,
        None => pts.s.clone(),
    };
    let scatter = model_scatter(ctx, p, x, y, &s_xy, &fixed_ref);
    let m_scatter = scatter.map_or(0.0, |(m, _)| m);
    let s = widened(&s_xy, y, m_scatter);
    if let FitForm::Value = p.form {
        // Rows whose x has replica samples too (a lag t = m tau_alpha,
        // remeasured in each replica sample) are not at a fixed x.
        let x_moves = !jk_samples(c, &pts.used_rows, &p.x).is_empty();
        return fit_value(p, group, y, &s, pts.one_unit.as_ref(), x_moves);
    }
    let s_jk = unit_error_samples(p, c, &pts);
    let taken = p.taken();
    let fit_points = FitPoints {
        raw: (&pts.raw.0, &pts.raw.1, &pts.raw.2),
        x,
        y,
        s: &s,
        m_scatter,
        jk: pts.jk.as_ref(),
        one_unit: pts.one_unit.as_ref(),
        s_jk: &s_jk,
        object_replicas: object_replicas(c, &pts.used_rows),
        fixed,
        shifted: &from_other.refits,
        taken: &taken,
    };
    let mut method = covariance_method(p.y_err.as_deref());
    let form = p.form.named();
    let fitting = Fitting {
        ctx,
        p,
        group,
        fixed_ref: &fixed_ref,
        held: &from_other.held,
        scatter,
    };
    let Fitted {
        mut rows,
        mut note,
        curve,
        samples,
        jackknife,
        pooled,
    } = match fit_form(p, x, y, &s, &fixed_ref) {
        Ok(f) => converged(&fitting, &f, &fit_points, &mut method)?,
        Err(e) => failed_fit(ctx, p, &e),
    };
    let scan = match form {
        Some(fm) if !p.ranges.is_empty() => scan_ranges(
            p,
            fm,
            Data::new(x, y, &s),
            &fixed_ref,
            group,
            &mut rows,
            &mut note,
        )?,
        _ => Vec::new(),
    };
    if let Some(why) = &from_other.unreliable
        && !note.contains("unreliable")
    {
        note = if note.is_empty() {
            why.clone()
        } else {
            format!("{why}; {note}")
        };
    }
    let table = quantity_batch(group, &rows, &note, samples.as_ref())?;
    let curve = match curve {
        Some((cx, cy)) => Some(curve_table(p, group, cx, cy)?),
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

/// A group's points as the fit takes them: the rows it uses, their replica
/// samples, and the points before and after cleaning.
struct GroupPoints {
    /// The rows of the table with a finite x and y: a row without a value (a
    /// state point whose own fit failed) has no replica samples either, so
    /// the replica jackknife runs over these.
    used_rows: Vec<usize>,
    /// The replica jackknife inputs of the used rows, if y has them.
    jk: Option<Replicas>,
    /// Their unit and the replica samples of y, when they all come from one unit.
    one_unit: Option<(f64, Vec<Vec<f64>>)>,
    /// The used points before cleaning: x, y and errors.
    raw: (Vec<f64>, Vec<f64>, Vec<f64>),
    /// The cleaned points and their errors (unit errors without `y_err`),
    /// before any model scatter widens them.
    x: Vec<f64>,
    y: Vec<f64>,
    s: Vec<f64>,
    /// The errors of x of the cleaned points (`x_err`; empty without it).
    s_x: Vec<f64>,
}

/// The y errors `s` widened by the x errors `s_x` through the model's slope
/// (`x_err`, effective variance).
fn carried_x_errors(
    p: &FitParams,
    x: &[f64],
    y: &[f64],
    s: &[f64],
    s_x: &[f64],
    fixed: &[(&str, f64)],
) -> Result<Vec<f64>> {
    let form = p
        .form
        .named()
        .ok_or_else(|| anyhow::anyhow!("fit: `x_err` needs a named form"))?;
    let fit = |e: &[f64]| fit_data(p, Some(form), Data::new(x, y, e), fixed);
    let model = |params: &[f64], v: f64| (form.model)(params, fixed, v);
    // A fit that fails here fails again on the errors of y, where its failure
    // becomes the table's note as any other's.
    Ok(effective_variance(x, s, s_x, fit, model).map_or_else(|_| s.to_vec(), |(e, _)| e))
}

/// The points of `rows` of `c` for fit `p`; logs how many were dropped for a
/// non-finite x or y.
fn group_points(ctx: &StageCtx, p: &FitParams, c: &Columns, rows: &[usize]) -> Result<GroupPoints> {
    let x = pick(c.col(&p.x)?, rows);
    let y = pick(c.col(&p.y)?, rows);
    let s = match &p.y_err {
        Some(e) => pick(c.col(e)?, rows),
        None => vec![1.0; rows.len()],
    };
    let used: Vec<usize> = (0..rows.len())
        .filter(|&i| x[i].is_finite() && y[i].is_finite())
        .collect();
    let used_rows = pick_rows(rows, &used);
    let jk = replica_columns(c, &used_rows, &p.x, &p.y);
    let one_unit = unit_columns(c, &used_rows, &p.y);
    let raw = (pick(&x, &used), pick(&y, &used), pick(&s, &used));
    // The x errors of the points `clean` keeps (finite x and y).
    let s_x = match &p.x_err {
        Some(e) => pick(&pick(c.col(e)?, rows), &used),
        None => Vec::new(),
    };
    let cleaned = clean(&x, &y, &s);
    if cleaned.dropped > 0 {
        ctx.log(format!(
            "dropped {} point(s) with non-finite x or y",
            cleaned.dropped
        ));
    }
    Ok(GroupPoints {
        used_rows,
        jk,
        one_unit,
        raw,
        x: cleaned.x,
        y: cleaned.y,
        s: cleaned.s,
        s_x,
    })
}

/// The per-point errors (`y_err`) of each replica sample, for refits that
/// weight by their own sample's; empty unless every used row comes from one
/// unit. Only there do all weights change together: across units the
/// sample's larger errors would down-weight the unit left out and damp its
/// refit's shift.
fn unit_error_samples(p: &FitParams, c: &Columns, pts: &GroupPoints) -> Vec<Vec<f64>> {
    match (&p.y_err, &pts.jk) {
        (Some(e), Some((_, _, y_jk))) if pts.one_unit.is_some() => {
            let v = jk_samples(c, &pts.used_rows, e);
            if v.len() == y_jk.len() { v } else { Vec::new() }
        }
        _ => Vec::new(),
    }
}

/// What every step of one group's fit after its points reads: the stage, the
/// fit's parameters, the group's values, the numbers held fixed (those held at
/// another fit's value without replica refits with that value and its error)
/// and the relative model scatter, if searched for.
struct Fitting<'a> {
    ctx: &'a StageCtx,
    p: &'a FitParams,
    group: &'a [(String, f64)],
    fixed_ref: &'a [(&'a str, f64)],
    held: &'a [(String, f64, f64)],
    scatter: Option<(f64, f64)>,
}

/// What one fit of a group gives before its tables are written: its rows
/// (name, value, error), its note, the drawn curve's points, the replica
/// samples of its numbers, the table of its replica refits and, on one unit's
/// rows, its pooled errors.
struct Fitted {
    rows: Vec<(String, f64, f64)>,
    note: String,
    curve: Option<(Vec<f64>, Vec<f64>)>,
    samples: Option<UnitSamples>,
    jackknife: Option<RecordBatch>,
    pooled: Option<Vec<(f64, f64)>>,
}

/// A fit that converged: its numbers, each error then from the replica
/// jackknife where the points have replica samples, at least the
/// delete-one-point jackknife's when one point carries the fit, and widened by
/// the errors of numbers held at other fits' values; its diagnostic rows and
/// its curve. `method` says how the errors were estimated.
fn converged(fg: &Fitting, f: &FitResult, pts: &FitPoints, method: &mut String) -> Result<Fitted> {
    let p = fg.p;
    let (x, y, s) = (pts.x, pts.y, pts.s);
    let mut rows = fitted_rows(p, f, x, y);
    // A replica sample passes the same `where` on x and y as the
    // pooled data (e.g. P > 0 of a tail: a bin one replica never reached).
    let passes_on = |col: &str, v: f64| p.filter.get(col).is_none_or(|c| c.accepts(v));
    let passes = |x: f64, y: f64| passes_on(&p.x, x) && passes_on(&p.y, y);
    let refit = |x: &[f64], y: &[f64], s: &[f64], fixed: &[(&str, f64)]| {
        let g = fit_form(p, x, y, s, fixed).ok()?;
        Some(reported(p, x, y, &g))
    };
    let replicated = replica_errors(pts, &mut rows, method, passes, refit);
    let max_leverage = leverage_floor(fg, f, (x, y, s), &mut rows, method);
    held_errors(fg, f, (x, y, s), &mut rows, method);
    let jackknife = match &replicated.refits {
        Some(r) => Some(jackknife_table(fg.group, &rows, r)?),
        None => None,
    };
    let fit_quality = (f.reduced_chi2, x.len(), max_leverage);
    diagnostic_rows(p, fg.scatter, fit_quality, &mut rows, method);
    let curve = p
        .curve
        .as_ref()
        .map(|cs| curve_points(cs, p.form.named(), &f.params, fg.fixed_ref, x));
    Ok(Fitted {
        rows,
        note: f.warnings.join("; "),
        curve,
        samples: replicated.samples,
        jackknife,
        pooled: replicated.pooled,
    })
}

/// A converged fit's numbers with their fit covariance errors: its parameters
/// or, for `drift`, the relative change of y across the x range from the slope.
fn fitted_rows(p: &FitParams, f: &FitResult, x: &[f64], y: &[f64]) -> Vec<(String, f64, f64)> {
    if let FitForm::Drift = p.form {
        let (span, mean) = drift_scale(x, y);
        let (b, db) = f.expect("slope");
        vec![(
            p.quantity_name("drift"),
            b * span / mean,
            db * span / mean.abs(),
        )]
    } else {
        f.names
            .iter()
            .zip(f.params.iter().zip(&f.stderr))
            .map(|(n, (v, e))| (p.quantity_name(n), *v, *e))
            .collect()
    }
}

/// What a failed fit writes: its numbers as NaN, the error as its note, an
/// empty curve if one was asked for.
fn failed_fit(ctx: &StageCtx, p: &FitParams, e: &anyhow::Error) -> Fitted {
    let msg = format!("{e:#}");
    ctx.log(format!("fit failed: {msg}"));
    let rows = p
        .form
        .params()
        .iter()
        .map(|n| (p.quantity_name(n), f64::NAN, f64::NAN))
        .collect();
    Fitted {
        rows,
        note: format!("fit failed: {msg}"),
        curve: p.curve.as_ref().map(|_| (vec![], vec![])),
        samples: None,
        jackknife: None,
        pooled: None,
    }
}

/// `scatter: relative`: the relative model scatter s_m and the reduced chi^2 of
/// the errors alone; `None` without it, or when a fit on the way failed.
fn model_scatter(
    ctx: &StageCtx,
    p: &FitParams,
    x: &[f64],
    y: &[f64],
    s: &[f64],
    fixed_ref: &[(&str, f64)],
) -> Option<(f64, f64)> {
    p.scatter.as_ref()?;
    let fit = |s: &[f64]| fit_data(p, p.form.named(), Data::new(x, y, s), fixed_ref);
    match relative_scatter(y, s, fit) {
        Ok(m) => Some(m),
        Err(e) => {
            let e = anyhow::Error::from(e);
            ctx.log(format!(
                "no relative model scatter: a fit on the way failed: {e:#}"
            ));
            None
        }
    }
}

/// The largest leverage of the fit's points, and each error raised to at
/// least the delete-one-point jackknife's when one point carries the fit.
fn leverage_floor(
    fg: &Fitting,
    f: &FitResult,
    (x, y, s): (&[f64], &[f64], &[f64]),
    rows: &mut [(String, f64, f64)],
    method: &mut String,
) -> f64 {
    let (ctx, p, fixed_ref) = (fg.ctx, fg.p, fg.fixed_ref);
    let Some(fm) = p.form.named() else {
        return f64::NAN;
    };
    let free: Vec<bool> = f.stderr.iter().map(|e| e.is_finite() && *e > 0.0).collect();
    let model = |par: &[f64], x: f64| (fm.model)(par, fixed_ref, x);
    let Some(h) = leverages(x, s, &f.params, &free, model) else {
        return f64::NAN;
    };
    let max_leverage = h.iter().copied().fold(f64::NAN, f64::max);
    let refit =
        |x: &[f64], y: &[f64], s: &[f64]| fit_form(p, x, y, s, fixed_ref).ok().map(|f| f.params);
    let n_free = free.iter().filter(|b| **b).count();
    match carried_errors(x, y, s, &h, n_free, refit) {
        Carried::No => {}
        Carried::Errors(jk) => {
            for (row, e) in rows.iter_mut().zip(&jk) {
                row.2 = crate::analysis::stats::at_least(row.2, *e);
            }
            method.push_str(&format!(
                "; one point's leverage is {max_leverage:.3} (> {CARRIED}): it carries the fit, so each error is at least the delete-one-point jackknife's"
            ));
            ctx.log(format!(
                "fit carried by one point (leverage {max_leverage:.3}): errors at least the delete-one-point jackknife's"
            ));
        }
        Carried::RefitFailed { point } => {
            let at = x[point];
            method.push_str(&format!(
                "; one point's leverage is {max_leverage:.3} (> {CARRIED}): it carries the fit, but the refit without the point at x = {at} failed, so the errors lack the delete-one-point jackknife's floor"
            ));
            ctx.log(format!(
                "fit carried by one point (leverage {max_leverage:.3}); the refit without x = {at} failed: no delete-one-point floor under its errors"
            ));
        }
    }
    max_leverage
}

/// A number held at another fit's value: its error (all of it when that fit
/// has no replica refits, else the part they do not carry) passed on by
/// refits at its value +- that error.
fn held_errors(
    fg: &Fitting,
    f: &FitResult,
    (x, y, s): (&[f64], &[f64], &[f64]),
    rows: &mut [(String, f64, f64)],
    method: &mut String,
) {
    let (p, fixed_ref) = (fg.p, fg.fixed_ref);
    let center = reported(p, x, y, f);
    for (name, value, err) in fg.held {
        let refit_at = |v: f64| {
            let at: Vec<(&str, f64)> = fixed_ref
                .iter()
                .map(|&(k, w)| (k, if k == name { v } else { w }))
                .collect();
            let g = fit_form(p, x, y, s, &at).ok()?;
            Some(reported(p, x, y, &g))
        };
        if let Some(d) = held_shifts(&center, *value, *err, refit_at) {
            let mut e: Vec<f64> = rows.iter().map(|r| r.2).collect();
            add_in_quadrature(&mut e, &d);
            for (row, e) in rows.iter_mut().zip(e) {
                row.2 = e;
            }
            method.push_str(&format!(
                "; {name} held at {value:.6} +- {err:.2e} (its fit's quoted error, or the part of it its replica refits do not carry): each error adds in quadrature half the change between the refits at {name} +- {err:.2e}"
            ));
        }
    }
}

/// The fit's diagnostic rows: reduced chi^2 (of the errors alone under a
/// model scatter), points, largest leverage and the scatter itself.
fn diagnostic_rows(
    p: &FitParams,
    scatter: Option<(f64, f64)>,
    (reduced_chi2, points, max_leverage): (f64, usize, f64),
    rows: &mut Vec<(String, f64, f64)>,
    method: &mut String,
) {
    if let Some(xe) = &p.x_err {
        method.push_str(&format!(
            "; each y error widened in quadrature by the model's slope times the x error `{xe}` (effective variance)"
        ));
    }
    match scatter {
        Some((m, alone)) => {
            rows.push((p.quantity_name("reduced_chi2"), alone, f64::NAN));
            rows.push((p.quantity_name("points"), points as f64, 0.0));
            rows.push((p.leverage_name(), max_leverage, f64::NAN));
            rows.push((p.quantity_name("scatter"), m, f64::NAN));
            if m > 0.0 {
                method.push_str(&format!(
                    "; each point's error widened by a relative model scatter {m:.3} |y| in quadrature (reduced chi2 {alone:.1} -> 1)"
                ));
            }
        }
        None => {
            rows.push((p.quantity_name("reduced_chi2"), reduced_chi2, f64::NAN));
            rows.push((p.quantity_name("points"), points as f64, 0.0));
            rows.push((p.leverage_name(), max_leverage, f64::NAN));
            if p.scatter.is_some() {
                rows.push((p.quantity_name("scatter"), f64::NAN, f64::NAN));
                method.push_str(
                    "; no relative model scatter: a fit while searching for it failed (the errors alone)",
                );
            }
        }
    }
}

/// `value`: the mean of y over the group's points, with the combined per-point
/// errors or, for rows of one unit, the replica jackknife if that is larger.
fn fit_value(
    p: &FitParams,
    group: &[(String, f64)],
    y: &[f64],
    s: &[f64],
    one_unit: Option<&(f64, Vec<Vec<f64>>)>,
    x_moves: bool,
) -> Result<Group> {
    let k = y.len() as f64;
    // Without y_err the points carry unit stand-in errors (for the fits'
    // weights): combining them would quote 1/sqrt(k), a number about nothing.
    // As for the other forms, the error is then scaled to the points' scatter:
    // the standard error of their mean (independent runs: one row per replica).
    let (mean, err) = if y.is_empty() {
        (f64::NAN, f64::NAN)
    } else if p.y_err.is_none() {
        let sd = crate::analysis::stats::mean_std(y).1;
        (y.iter().sum::<f64>() / k, sd / k.sqrt())
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
        None if y.len() >= 2 => format!(
            "the scatter of the {} points: standard error of their mean (the points taken as independent runs)",
            y.len()
        ),
        None => "none (no y_err, one point)".to_string(),
    };
    // Rows of one unit with replica samples: the replica jackknife of the
    // value counts what per-point errors miss; with few replicas it is noisy,
    // so the larger of the two is quoted. Where the rows' x moves with the
    // replicas (y read at t = m tau_alpha, tau_alpha remeasured in each
    // sample), the per-point error is that of a fixed lag and misses the
    // lag's covariance with y (Q(tau_alpha) = 1/e pins the MSD there): the
    // jackknife alone is quoted (fig7's MSD at tau_alpha quoted 2.8-4 times
    // its seed-to-seed spread with the larger of the two, docs/accuracy.md).
    let mut err = err;
    if let Some((_, y_jk)) = &one_unit {
        let jk = mean_jackknife(y_jk);
        if jk.is_finite() && x_moves {
            err = jk;
            method = format!(
                "delete-one jackknife over {} replicas, x remeasured in each (not {method}, which holds x fixed)",
                y_jk.len()
            );
        } else if jk.is_finite() && (err.is_nan() || jk > err) {
            err = jk;
            method = format!(
                "delete-one jackknife over {} replicas (larger than {method})",
                y_jk.len()
            );
        }
    }
    return Ok(Group {
        table: quantity_batch(group, &[(p.quantity_name("value"), mean, err)], note, None)?,
        curve: None,
        scan: Vec::new(),
        method,
        jackknife: None,
        pooled: None,
    });
}

/// The fitted curve at `cs.points` values of x over the data's range (or the
/// one given), log-spaced for a form drawn on log x; a line for `drift`.
fn curve_points(
    cs: &CurveSpec,
    form: Option<&Form>,
    params: &[f64],
    fixed: &[(&str, f64)],
    x: &[f64],
) -> (Vec<f64>, Vec<f64>) {
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
        Some(fm) => xs.iter().map(|&v| (fm.model)(params, fixed, v)).collect(),
        None => xs.iter().map(|&v| params[0] + params[1] * v).collect(),
    };
    (xs, ys)
}

/// The curve's table: the group's values (but x and y), x and y.
fn curve_table(
    p: &FitParams,
    group: &[(String, f64)],
    cx: Vec<f64>,
    cy: Vec<f64>,
) -> Result<RecordBatch> {
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
    Ok(RecordBatch::try_from_iter(cols)?)
}
