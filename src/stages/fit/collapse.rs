//! The `collapse` stage kind: curves y(x) of several state points rescaled onto
//! one, Fig. 19's finite-size scaling here and the named rescalings in
//! [`super::rescaled`].

use std::collections::BTreeMap;

use anyhow::{Result, bail};
use serde_json::Value;

use super::collapse_output::{CollapseParts, Collapsed, collapse_files, collapse_output};
use super::curve_rows::CurveRows;
use super::params::{CollapseParams, FromQuantity};
use super::rescaled::{run_named, validate_named};
use super::samples::replica_columns;
use crate::analysis::pool;
use crate::fit::collapse::{self, CollapseResult, Curve, Rescale};
use crate::fit::rescalings;
use crate::fit::uncertainty::replicas::{
    HELD, JK_IMPOSSIBLE, Replicas, XI_REFITTED, jackknife_method,
};
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::stages::tables::{Columns, Cond, inputs_of};

pub struct Collapse;

fn xi(phi_c: f64, phi: f64, gamma_xi: f64) -> f64 {
    (phi_c - phi).powf(-gamma_xi)
}

impl StageKind for Collapse {
    type Params = CollapseParams;
    fn name(&self) -> &str {
        "collapse"
    }
    fn describe(&self) -> &str {
        "finite-size-scaling collapse y xi^-g vs sqrt(x)/xi, xi = (phi_c - phi)^-gamma_xi"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<CollapseParams> {
        let p: CollapseParams = typed("collapse", params)?;
        for k in &p.group_by {
            if *k == p.curve_by || *k == p.x {
                bail!("collapse: `group_by` column '{k}' is also `curve_by` or `x`");
            }
        }
        if let Some(name) = &p.rescaling {
            validate_named(&p, name)?;
            return Ok(p);
        }
        if p.g_from.is_some() && p.xi.is_none() {
            bail!("collapse: `g_from` needs a measured `xi` column (g is then the only parameter)");
        }
        let keys: &[&str] = if p.g_from.is_some() {
            &[]
        } else if p.xi.is_some() {
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
            if keys.is_empty() {
                bail!("collapse: with `g_from` nothing is fitted: leave `bounds` out");
            }
            bail!(
                "collapse: `bounds` takes exactly the keys {}",
                keys.join(" and ")
            );
        }
        Ok(p)
    }
    fn run(&self, ctx: &StageCtx, p: &CollapseParams, inputs: &[Artifact]) -> Result<Output> {
        if p.group_by.is_empty() {
            return collapse_files(vec![collapse_group(ctx, p, inputs, &[])?]);
        }
        // One collapse per group: its rows are the group's rows of `where`.
        let c = Columns::read(&inputs_of("collapse", inputs, &p.data)?)?;
        let keys: Vec<&[f64]> = p.group_by.iter().map(|k| c.col(k)).collect::<Result<_>>()?;
        let mut groups: Vec<Vec<f64>> = Vec::new();
        for i in c.select(&p.filter)? {
            let g: Vec<f64> = keys.iter().map(|k| k[i]).collect();
            if !groups.contains(&g) {
                groups.push(g);
            }
        }
        groups.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        if groups.is_empty() {
            bail!("collapse: no rows of '{}' pass `where`", p.data);
        }
        let parts = groups
            .iter()
            .map(|g| {
                let group: Vec<(String, f64)> =
                    p.group_by.iter().cloned().zip(g.iter().copied()).collect();
                let mut one = p.clone();
                one.group_by.clear();
                // The group's value passed `where`, so it replaces any
                // condition there on the same column.
                for (k, v) in &group {
                    one.filter.insert(k.clone(), Cond::Equal(*v));
                }
                collapse_group(ctx, &one, inputs, &group)
            })
            .collect::<Result<Vec<_>>>()?;
        collapse_files(parts)
    }
}

/// The collapse of the rows of `p.filter` (one group's, with `group` its
/// `group_by` values).
fn collapse_group(
    ctx: &StageCtx,
    p: &CollapseParams,
    inputs: &[Artifact],
    group: &[(String, f64)],
) -> Result<CollapseParts> {
    if let Some(name) = &p.rescaling {
        let r = rescalings::find(name).map_err(|e| anyhow::anyhow!("collapse: {e}"))?;
        return run_named(ctx, p, r, inputs, group);
    }
    let phi_c = match (&p.phi_c, &p.phi_c_from) {
        (Some(v), _) => *v,
        (None, Some(f)) => f.get("collapse", inputs)?.0,
        _ => f64::NAN, // validated: a measured xi column instead
    };
    let c = Columns::read(&inputs_of("collapse", inputs, &p.data)?)?;
    let sc = Scaling::read(p, &c, phi_c)?;
    let curves = sc.curves(&sc.points.y);
    let rescale = sc.rescale(sc.measured.clone());
    let mut found = match &p.g_from {
        Some(from) => held_g(inputs, group, from, &curves, &rescale)?,
        None => sc.fit(ctx, &curves, &rescale),
    };
    // A phi_c taken from a fit that marks it unreliable marks this one too.
    if let Some(f) = &p.phi_c_from
        && let Some(why) = f.inherited_unreliable("phi_c", "collapse", inputs)?
        && !found.note.contains("unreliable")
    {
        found.note = if found.note.is_empty() {
            why
        } else {
            format!("{why}; {}", found.note)
        };
    }
    collapse_output(p, &curves, &rescale, &found, group)
}

/// `g_from`: g held at another fit's value, so nothing is fitted: the collapse
/// is a test of the independent exponents, its quality S the verdict; g's
/// error is the source fit's.
fn held_g(
    inputs: &[Artifact],
    group: &[(String, f64)],
    from: &FromQuantity,
    curves: &[Curve],
    rescale: Rescale<'_>,
) -> Result<Collapsed> {
    let (g, dg) = Columns::read(&inputs_of("collapse", inputs, &from.stage)?)?
        .quantity_in(&from.quantity, group)?;
    let (rows, note, best) = match collapse::quality(curves, rescale, &[g]) {
        Ok(q) => (
            vec![
                ("gamma_chi_over_gamma_xi".to_string(), g, dg),
                ("collapse_S".to_string(), q.s, f64::NAN),
                ("curves".to_string(), curves.len() as f64, 0.0),
            ],
            String::new(),
            Some(vec![g, f64::NAN]),
        ),
        Err(e) => (
            vec![
                ("gamma_chi_over_gamma_xi".to_string(), g, dg),
                ("collapse_S".to_string(), f64::NAN, f64::NAN),
            ],
            format!("collapse quality failed: {e:#}"),
            None,
        ),
    };
    let method = format!(
        "g held at {}.{} (its fit's error); no fit",
        from.stage, from.quantity
    );
    Ok(Collapsed {
        rows,
        note,
        best,
        method,
    })
}

/// The error method of a collapse without replica refits.
const COVARIANCE: &str = "fit covariance of the collapse";

/// Fig. 19's finite-size scaling of one collapse: its rows of `where` as
/// curves, xi per curve measured (a column) or (phi_c - phi)^-gamma_xi, and
/// what it fits (g, and gamma_xi without a measured xi) within which bounds.
struct Scaling<'a> {
    p: &'a CollapseParams,
    c: &'a Columns,
    phi_c: f64,
    /// The rows of `where`.
    rows: Vec<usize>,
    points: CurveRows<'a>,
    /// The measured xi per curve (by the bits of its `curve_by` value).
    measured: Option<BTreeMap<u64, f64>>,
    /// The measured xi with one replica of one unit left out, where the data
    /// carry them: (unit, replica) -> (curve, xi).
    measured_jk: Option<BTreeMap<(u64, usize), (u64, f64)>>,
    fitted: &'static [&'static str],
    bounds: Vec<(f64, f64)>,
}

impl<'a> Scaling<'a> {
    fn read(p: &'a CollapseParams, c: &'a Columns, phi_c: f64) -> Result<Self> {
        let rows = c.select(&p.filter)?;
        let measured = measured_xi(p, c, &rows)?;
        let points = CurveRows::read(p, c, &rows)?;
        let fitted: &'static [&'static str] = if measured.is_some() {
            &["g"]
        } else {
            &["g", "gamma_xi"]
        };
        // With `g_from` nothing is fitted and `bounds` is empty (validated).
        let bounds: Vec<(f64, f64)> = fitted
            .iter()
            .map(|k| p.bounds.get(*k).copied().unwrap_or((f64::NAN, f64::NAN)))
            .collect();
        let measured_jk = measured_xi_replicas(p, c, &rows)?;
        Ok(Scaling {
            p,
            c,
            phi_c,
            rows,
            points,
            measured,
            measured_jk,
            fitted,
            bounds,
        })
    }

    /// The curves with y values `ys`; those without a usable measured xi are
    /// left out.
    fn curves(&self, ys: &[f64]) -> Vec<Curve> {
        let has_xi = |c: &Curve| {
            self.measured
                .as_ref()
                .is_none_or(|m| m[&c.param.to_bits()].is_finite() && m[&c.param.to_bits()] > 0.0)
        };
        self.points.curves(ys, has_xi)
    }

    /// The rescaling at q = (g, gamma_xi): x to sqrt(x)/xi, y and its error
    /// times xi^-g, with xi the curve's in `by_xi` or else (phi_c - phi)^-gamma_xi.
    fn rescale(
        &self,
        by_xi: Option<BTreeMap<u64, f64>>,
    ) -> impl Fn(&[f64], &Curve, f64, f64, f64) -> (f64, f64, f64) + use<> {
        let phi_c = self.phi_c;
        move |q: &[f64], cv: &Curve, x: f64, y: f64, s: f64| {
            let l = match &by_xi {
                Some(m) => m[&cv.param.to_bits()],
                None => xi(phi_c, cv.param, q[1]),
            };
            let f = l.powf(-q[0]);
            (x.sqrt() / l, y * f, s * f)
        }
    }

    /// The measured xi with replica `left` of its unit left out.
    fn xi_left_out(&self, left: pool::LeftOut) -> Option<BTreeMap<u64, f64>> {
        let mut m = self.measured.clone()?;
        if let Some((curve, v)) = self
            .measured_jk
            .as_ref()
            .and_then(|j| j.get(&(left.unit.to_bits(), left.replica)))
            && v.is_finite()
            && *v > 0.0
        {
            m.insert(*curve, *v);
        }
        Some(m)
    }

    /// The replica jackknife inputs of the rows, if y has them.
    fn replicas(&self) -> Option<Replicas> {
        replica_columns(self.c, &self.rows, &self.p.x, &self.p.y)
    }

    /// The best parameters of a jackknife refit's collapse of `curves`; a
    /// failure is logged.
    fn refit(&self, ctx: &StageCtx, curves: &[Curve], rescale: Rescale<'_>) -> Option<Vec<f64>> {
        collapse::best(curves, self.fitted, &self.bounds, rescale)
            .map_err(|e| ctx.log(format!("jackknife refit of the collapse failed: {e:#}")))
            .ok()
    }

    /// The fitted collapse of `curves`: its numbers with their errors, or NaN
    /// and why it failed.
    fn fit(&self, ctx: &StageCtx, curves: &[Curve], rescale: Rescale<'_>) -> Collapsed {
        let result = if self.measured.is_none() && curves.iter().any(|c| c.param >= self.phi_c) {
            Err(anyhow::anyhow!(
                "phi_c = {} is not above every {} of the data",
                self.phi_c,
                self.p.curve_by
            ))
        } else {
            collapse::collapse(curves, self.fitted, &self.bounds, rescale)
                .map_err(anyhow::Error::from)
        };
        match result {
            Ok(r) if self.measured.is_some() => self.with_measured_xi(ctx, &r, curves.len()),
            Ok(r) => self.with_gamma_xi(ctx, &r, curves.len(), rescale),
            Err(e) => self.failed(ctx, &e),
        }
    }

    /// g fitted with the measured xi of `n_curves` curves. Its error from
    /// refits with one replica of one phi left out, in chi4P and, where the
    /// data carry its replica samples, in the measured xi of that phi (else xi
    /// is held at its value).
    fn with_measured_xi(&self, ctx: &StageCtx, r: &CollapseResult, n_curves: usize) -> Collapsed {
        let (g, mut dg) = r.get("g").expect("named");
        let mut method = COVARIANCE.to_string();
        if let Some((units, _, y_jk)) = self.replicas() {
            let refit = |left: pool::LeftOut, _: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                let curves = self.curves(ys);
                let rescale = self.rescale(self.xi_left_out(left));
                self.refit(ctx, &curves, &rescale).map(|b| vec![b[0]])
            };
            let (x, y) = (&self.points.x, &self.points.y);
            match pool::replica_jackknife_with(&units, x, y, &[], &y_jk, &[], refit) {
                Some(j) => {
                    dg = j.errors[0];
                    let note = if self.measured_jk.is_some() {
                        XI_REFITTED
                    } else {
                        HELD
                    };
                    method = jackknife_method(j.refits.len(), note);
                }
                None => method.push_str(JK_IMPOSSIBLE),
            }
        }
        Collapsed {
            rows: vec![
                ("gamma_chi_over_gamma_xi".to_string(), g, dg),
                ("collapse_S".to_string(), r.quality.s, f64::NAN),
                ("curves".to_string(), n_curves as f64, 0.0),
            ],
            note: String::new(),
            best: Some(vec![g, f64::NAN]),
            method,
        }
    }

    /// g and gamma_xi fitted, xi = (phi_c - phi)^-gamma_xi, of `n_curves`
    /// curves, and gamma_chi = g gamma_xi. The sub-box sizes of one phi come
    /// from the same runs: errors from refits with one replica of one phi left
    /// out, where the data carry replica samples.
    fn with_gamma_xi(
        &self,
        ctx: &StageCtx,
        r: &CollapseResult,
        n_curves: usize,
        rescale: Rescale<'_>,
    ) -> Collapsed {
        let (g, mut dg) = r.get("g").expect("named");
        let (gx, mut dgx) = r.get("gamma_xi").expect("named");
        let cov = r.covariance[0][1];
        let mut dgc = (gx * gx * dg * dg + g * g * dgx * dgx + 2.0 * g * gx * cov)
            .max(0.0)
            .sqrt();
        let mut method = COVARIANCE.to_string();
        if let Some((units, _, y_jk)) = self.replicas() {
            let refit = |_: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
                let b = self.refit(ctx, &self.curves(ys), rescale)?;
                let (g, gx) = (b[0], b[1]);
                Some(vec![g, gx, g * gx])
            };
            let (x, y) = (&self.points.x, &self.points.y);
            match pool::replica_jackknife(&units, x, y, &[], &y_jk, refit) {
                Some((e, refits)) => {
                    (dg, dgx, dgc) = (e[0], e[1], e[2]);
                    method = jackknife_method(refits, HELD);
                }
                None => method.push_str(JK_IMPOSSIBLE),
            }
        }
        Collapsed {
            rows: vec![
                ("gamma_chi_over_gamma_xi".to_string(), g, dg),
                ("gamma_xi".to_string(), gx, dgx),
                ("gamma_chi".to_string(), g * gx, dgc),
                ("collapse_S".to_string(), r.quality.s, f64::NAN),
                ("phi_c_used".to_string(), self.phi_c, 0.0),
                ("curves".to_string(), n_curves as f64, 0.0),
            ],
            note: String::new(),
            best: Some(vec![g, gx]),
            method,
        }
    }

    /// A collapse that failed: its numbers NaN (those of xi's exponents only
    /// without a measured xi), the error its note.
    fn failed(&self, ctx: &StageCtx, e: &anyhow::Error) -> Collapsed {
        let msg = format!("collapse failed: {e:#}");
        ctx.log(msg.clone());
        let names = [
            "gamma_chi_over_gamma_xi",
            "gamma_xi",
            "gamma_chi",
            "collapse_S",
        ];
        let measured = self.measured.is_some();
        let mut rows: Vec<(String, f64, f64)> = names
            .iter()
            .filter(|n| !measured || !n.starts_with("gamma_x") && **n != "gamma_chi")
            .map(|n| (n.to_string(), f64::NAN, f64::NAN))
            .collect();
        if !measured {
            rows.push(("phi_c_used".to_string(), self.phi_c, 0.0));
        }
        Collapsed {
            rows,
            note: msg,
            best: None,
            method: COVARIANCE.to_string(),
        }
    }
}

/// The measured xi per curve (its first row of `rows`), when `p.xi` names a
/// column.
fn measured_xi(
    p: &CollapseParams,
    c: &Columns,
    rows: &[usize],
) -> Result<Option<BTreeMap<u64, f64>>> {
    let Some(col) = &p.xi else {
        return Ok(None);
    };
    let (v, b) = (c.col(col)?, c.col(&p.curve_by)?);
    let mut m = BTreeMap::new();
    for &i in rows {
        m.entry(b[i].to_bits()).or_insert(v[i]);
    }
    Ok(Some(m))
}

/// The measured xi of each curve with one replica of one unit left out
/// (`XI_jkK` with `jk_unit`, from a fit per state point that carries them),
/// keyed by (unit, replica): the refits rescale with it, so that xi's share of
/// the variance is counted rather than held at its value.
#[allow(clippy::type_complexity)]
fn measured_xi_replicas(
    p: &CollapseParams,
    c: &Columns,
    rows: &[usize],
) -> Result<Option<BTreeMap<(u64, usize), (u64, f64)>>> {
    let Some(col) = &p.xi else {
        return Ok(None);
    };
    let b = c.col(&p.curve_by)?;
    let units = c.col(pool::JK_UNIT).ok();
    let samples: Vec<&[f64]> = (0..pool::MAX_JK_REPLICAS)
        .map_while(|k| c.col(&pool::jk_column(col, k)).ok())
        .collect();
    Ok(units.filter(|_| samples.len() >= 2).map(|u| {
        let mut m = BTreeMap::new();
        for &i in rows {
            for (k, v) in samples.iter().enumerate() {
                m.entry((u[i].to_bits(), k))
                    .or_insert((b[i].to_bits(), v[i]));
            }
        }
        m
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Kind;
    use crate::stages::test_support::{artifact, artifact_of, output_artifact, yaml};
    use crate::table::f64_batch;

    const SIZES: [f64; 8] = [8.0, 16.0, 32.0, 64.0, 125.0, 250.0, 500.0, 1000.0];

    /// A peaks_xi table of Fig. 19's scaling form chi4P = xi^g f(sqrt(N)/xi)
    /// over SIZES: per state, its label columns, xi and g.
    fn scaling_table(dir: &std::path::Path, states: &[(Vec<(&str, f64)>, f64, f64)]) -> Artifact {
        let mut cols: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for (labels, xi, g) in states {
            for &n in &SIZES {
                let u: f64 = f64::sqrt(n) / xi;
                let chi = xi.powf(*g) * u.powf(1.2) / (1.0 + u.powf(1.2));
                let row = [
                    ("N", n),
                    ("chi4P", chi),
                    ("chi4P_err", 0.02 * chi),
                    ("xi", *xi),
                ];
                for &(k, v) in labels.iter().chain(&row) {
                    cols.entry(k).or_default().push(v);
                }
            }
        }
        let b: Vec<(&str, Vec<f64>)> = cols.iter().map(|(k, v)| (*k, v.clone())).collect();
        artifact(dir, "peaks_xi", f64_batch(&b).unwrap())
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
            let out = Collapse.run_params(&ctx, &params, &[data]).unwrap();
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

    /// A convergence sweep: one collapse per total N (`group_by: [n]`), each
    /// recovering its own g, and with `g_from` each group holding the g of its
    /// own row of a grouped source fit (the rescaled points then carry it).
    #[test]
    fn a_grouped_collapse_is_one_collapse_per_group() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "grouped".into(), None);
        let groups = [(1000.0, 1.2), (4000.0, 1.9)];
        let mut states = Vec::new();
        for &(total, g) in &groups {
            for &(phi, xi) in &[(0.70, 2.0), (0.74, 3.0), (0.78, 4.5)] {
                states.push((vec![("n", total), ("phi", phi)], xi, g));
            }
        }
        let data = scaling_table(dir.path(), &states);
        let read = |out: &Output| {
            let c = Columns::read_file(&[&artifact_of(dir.path(), out)], "parquet").unwrap();
            let r = output_artifact(dir.path(), "r", out, "parquet");
            let resc = Columns::read_file(&[&r], "rescaled.parquet").unwrap();
            (c, resc)
        };
        let fitted = yaml(
            "{data: peaks_xi, x: 'N', y: chi4P, y_err: chi4P_err, curve_by: phi, xi: xi, bounds: {g: [0.2, 4.0]}, group_by: ['n']}",
        );
        let (c, resc) = read(&Collapse.run_params(&ctx, &fitted, &[data.clone()]).unwrap());
        for &(total, g) in &groups {
            let group = [("n".to_string(), total)];
            let (v, _) = c.quantity_in("gamma_chi_over_gamma_xi", &group).unwrap();
            assert!((v - g).abs() < 0.02, "N = {total}: g = {v}, want {g}");
            let (s, _) = c.quantity_in("collapse_S", &group).unwrap();
            assert!(s < 0.05, "N = {total}: S = {s}");
        }
        // Pooled, the two groups' curves do not collapse with any one g.
        let pooled = yaml(
            "{data: peaks_xi, x: 'N', y: chi4P, y_err: chi4P_err, curve_by: phi, xi: xi, bounds: {g: [0.2, 4.0]}}",
        );
        let (c1, _) = read(&Collapse.run_params(&ctx, &pooled, &[data.clone()]).unwrap());
        let s1 = c1.quantity("collapse_S").unwrap().0;
        assert!(s1 > 1.0, "pooled S = {s1}");
        assert_eq!(resc.col("n").unwrap().len(), 2 * 3 * SIZES.len());
        // g held per group from a grouped source: the right g collapses each.
        let source = crate::table::results::quantity_batch(
            &[("n".to_string(), 1000.0)],
            &[("d_f".to_string(), 1.2, 0.01)],
            "",
            None,
        )
        .unwrap();
        let source2 = crate::table::results::quantity_batch(
            &[("n".to_string(), 4000.0)],
            &[("d_f".to_string(), 1.9, 0.01)],
            "",
            None,
        )
        .unwrap();
        let src = artifact(
            dir.path(),
            "df",
            arrow_select::concat::concat_batches(&source.schema(), &[source.clone(), source2])
                .unwrap(),
        );
        let held = yaml(
            "{data: peaks_xi, x: 'N', y: chi4P, y_err: chi4P_err, curve_by: phi, xi: xi, g_from: {stage: df, quantity: d_f}, group_by: ['n']}",
        );
        let (c, _) = read(
            &Collapse
                .run_params(&ctx, &held, &[data.clone(), src])
                .unwrap(),
        );
        for &(total, g) in &groups {
            let group = [("n".to_string(), total)];
            assert_eq!(
                c.quantity_in("gamma_chi_over_gamma_xi", &group).unwrap().0,
                g
            );
            assert!(c.quantity_in("collapse_S", &group).unwrap().0 < 0.05);
        }
        // `where` on a group_by column keeps only the groups it accepts.
        let some = yaml(
            "{data: peaks_xi, x: 'N', y: chi4P, y_err: chi4P_err, curve_by: phi, xi: xi, bounds: {g: [0.2, 4.0]}, group_by: ['n'], where: {'n': {max: 2000}}}",
        );
        let (c, _) = read(&Collapse.run_params(&ctx, &some, &[data]).unwrap());
        assert!(c.col("n").unwrap().iter().all(|&n| n == 1000.0));
        assert!(
            c.quantity_in("collapse_S", &[("n".to_string(), 4000.0)])
                .is_err()
        );
    }

    /// Fig. 24: curves by eps in a table that holds every phi; `where` keeps
    /// phi = 0.78, and each eps is rescaled by the xi of those rows, not by
    /// the xi of the first row of its eps in the whole table (here phi =
    /// 0.70, whose xi would spoil the collapse).
    #[test]
    fn the_measured_xi_is_that_of_the_rows_where_keeps() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = StageCtx::new(0, "where-xi".into(), None);
        let g = 1.5;
        let mut states = Vec::new();
        for &(eps, xi78) in &[(0.7, 2.0), (0.9, 3.0), (1.0, 4.5)] {
            for &(phi, xi) in &[(0.70, 1.0), (0.78, xi78)] {
                states.push((vec![("eps", eps), ("phi", phi)], xi, g));
            }
        }
        let data = scaling_table(dir.path(), &states);
        let params = yaml(
            "{data: peaks_xi, x: 'N', y: chi4P, y_err: chi4P_err, curve_by: eps, where: {phi: 0.78}, xi: xi, bounds: {g: [0.2, 4.0]}}",
        );
        let out = Collapse.run_params(&ctx, &params, &[data]).unwrap();
        let c = Columns::read_file(&[&artifact_of(dir.path(), &out)], "parquet").unwrap();
        let (v, _) = c.quantity("gamma_chi_over_gamma_xi").unwrap();
        assert!((v - g).abs() < 0.02, "g = {v}");
        let s = c.quantity("collapse_S").unwrap().0;
        assert!(s < 0.05, "S = {s}");
    }
}
