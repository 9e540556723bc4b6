//! A collapse with a named rescaling of [`crate::fit::rescalings`] (the cluster
//! cut-off, the log-normal, ...) instead of Fig. 19's finite-size scaling.

use std::collections::BTreeMap;

use anyhow::{Result, bail};

use super::collapse_output::{CollapseParts, Collapsed, collapse_output};
use super::curve_rows::CurveRows;
use super::params::CollapseParams;
use super::samples::replica_columns;
use crate::analysis::pool;
use crate::fit::collapse::{self, Curve, Rescale};
use crate::fit::rescalings::{self, At, Rescaling};
use crate::fit::uncertainty::held::{add_in_quadrature, held_shifts};
use crate::fit::uncertainty::replicas::{
    HELD, JK_IMPOSSIBLE, Refits, also_units, jackknife_method,
};
use crate::pipeline::{Artifact, StageCtx};
use crate::stages::tables::{Columns, inputs_of};

/// The keys of a named rescaling: its fitted parameters in `bounds`, phi_c when it
/// needs one, no measured `xi`.
pub(super) fn validate_named(p: &CollapseParams, name: &str) -> Result<()> {
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
pub(super) fn run_named(
    ctx: &StageCtx,
    p: &CollapseParams,
    r: &'static Rescaling,
    inputs: &[Artifact],
    group: &[(String, f64)],
) -> Result<CollapseParts> {
    let named = Named::read(p, r, inputs)?;
    let curves = named.curves(&named.points.y);
    let rescale = named.rescale_at(named.phi_c);
    let found = match named.fit(&curves, &rescale) {
        Ok(fit) => named.fitted(ctx, &curves, fit),
        Err(e) => named.failed(ctx, &e),
    };
    collapse_output(p, &curves, &rescale, &found, group)
}

/// A collapse's result: the fitted parameters, their fit covariance errors
/// and the quality S.
type Fit = (Vec<f64>, Vec<f64>, f64);

/// One collapse with a named rescaling: its rows of `where` as curves, the
/// rescaling's per-curve numbers, its bounds and phi_c.
struct Named<'a> {
    p: &'a CollapseParams,
    r: &'static Rescaling,
    c: Columns,
    /// The rows of `where`.
    rows: Vec<usize>,
    points: CurveRows<'a>,
    /// The rescaling's `per_curve` columns of each curve (its first row), by
    /// the bits of its `curve_by` value: e.g. a joined per-phi fit.
    per_curve: BTreeMap<u64, Vec<f64>>,
    bounds: Vec<(f64, f64)>,
    /// phi_c and its quoted error (none for a number given in the spec).
    phi_c: f64,
    phi_c_err: f64,
    /// phi_c with each replica of each unit left out, where its fit carries
    /// refits (`jackknife.parquet`): the collapse is redone with it, so that
    /// phi_c's share of the variance is counted (N* of the cluster cut-off
    /// moves most with phi_c at the densest points).
    phi_c_refits: Option<Refits>,
}

impl<'a> Named<'a> {
    fn read(p: &'a CollapseParams, r: &'static Rescaling, inputs: &[Artifact]) -> Result<Self> {
        let (phi_c, phi_c_err) = match (&p.phi_c, &p.phi_c_from) {
            (Some(v), _) => (*v, f64::NAN),
            (None, Some(f)) => f.get("collapse", inputs)?,
            _ => (f64::NAN, f64::NAN),
        };
        let c = Columns::read(&inputs_of("collapse", inputs, &p.data)?)?;
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
        let rows = c.select(&p.filter)?;
        let mut per_curve: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
        for &i in &rows {
            per_curve
                .entry(by_all[i].to_bits())
                .or_insert_with(|| cols.iter().map(|v| v[i]).collect());
        }
        let points = CurveRows::read(p, &c, &rows)?;
        let bounds: Vec<(f64, f64)> = r.fitted.iter().map(|k| p.bounds[*k]).collect();
        let phi_c_refits = match &p.phi_c_from {
            Some(f) if r.needs_phi_c && !r.fitted.is_empty() => f.jackknife("collapse", inputs)?,
            _ => None,
        };
        Ok(Named {
            p,
            r,
            c,
            rows,
            points,
            per_curve,
            bounds,
            phi_c,
            phi_c_err,
            phi_c_refits,
        })
    }

    /// The per-curve numbers of the curve at `param` (none if it has no row).
    fn columns_of(&self, param: f64) -> &[f64] {
        self.per_curve
            .get(&param.to_bits())
            .map_or(&[][..], |v| &v[..])
    }

    /// The curves with y values `ys`; those whose per-curve numbers are
    /// missing or not finite are left out.
    fn curves(&self, ys: &[f64]) -> Vec<Curve> {
        let usable = |cv: &Curve| {
            let v = self.columns_of(cv.param);
            v.len() == self.r.per_curve.len() && v.iter().all(|u| u.is_finite() && *u > 0.0)
        };
        self.points.curves(ys, usable)
    }

    /// The rescaling's map with phi_c at `phi_c`.
    fn rescale_at(&self, phi_c: f64) -> impl Fn(&[f64], &Curve, f64, f64, f64) -> (f64, f64, f64) {
        move |q: &[f64], cv: &Curve, x: f64, y: f64, s: f64| {
            let at = At {
                param: cv.param,
                phi_c,
                columns: self.columns_of(cv.param),
            };
            (self.r.map)(q, &at, x, y, s)
        }
    }

    /// Whether phi_c at `pc` is not above every curve's value, as a rescaling
    /// that needs it requires.
    fn phi_c_too_low(&self, curves: &[Curve], pc: f64) -> bool {
        curves.iter().any(|cv| cv.param >= pc)
    }

    /// The collapse of `curves`: the fitted parameters, or for a rescaling
    /// without any the quality S alone.
    fn fit(&self, curves: &[Curve], rescale: Rescale<'_>) -> Result<Fit> {
        let r = self.r;
        if r.needs_phi_c && self.phi_c_too_low(curves, self.phi_c) {
            Err(anyhow::anyhow!(
                "phi_c = {} is not above every {} of the data",
                self.phi_c,
                self.p.curve_by
            ))
        } else if r.fitted.is_empty() {
            collapse::quality(curves, rescale, &[])
                .map(|q| (vec![], vec![], q.s))
                .map_err(anyhow::Error::from)
        } else {
            collapse::collapse(curves, r.fitted, &self.bounds, rescale)
                .map(|res| (res.params, res.stderr, res.quality.s))
                .map_err(anyhow::Error::from)
        }
    }

    /// A collapse that succeeded: its parameters with their errors (the
    /// replica jackknife's and phi_c's share, see [`Self::jackknife_errors`]
    /// and [`Self::held_phi_c_errors`]), S, phi_c and the number of curves.
    fn fitted(&self, ctx: &StageCtx, curves: &[Curve], (q, mut dq, s): Fit) -> Collapsed {
        let r = self.r;
        let mut method = "fit covariance of the collapse".to_string();
        self.jackknife_errors(ctx, &mut dq, &mut method);
        self.held_phi_c_errors(curves, &q, &mut dq, &mut method);
        let mut rows: Vec<(String, f64, f64)> = r
            .fitted
            .iter()
            .zip(q.iter().zip(&dq))
            .map(|(n, (v, e))| (n.to_string(), *v, *e))
            .collect();
        rows.push(("collapse_S".to_string(), s, f64::NAN));
        if r.needs_phi_c {
            rows.push(("phi_c_used".to_string(), self.phi_c, 0.0));
        }
        rows.push(("curves".to_string(), curves.len() as f64, 0.0));
        Collapsed {
            rows,
            note: String::new(),
            best: Some(q),
            method,
        }
    }

    /// The errors `dq` from refits with one replica of one unit left out: of
    /// the data where they carry replica samples, of phi_c where its fit has
    /// refits (rows without replica samples, such as cluster sizes, then keep
    /// their covariance error and add phi_c's share in quadrature).
    fn jackknife_errors(&self, ctx: &StageCtx, dq: &mut Vec<f64>, method: &mut String) {
        let (p, r) = (self.p, self.r);
        let jk = replica_columns(&self.c, &self.rows, &p.x, &p.y);
        let also = match &self.phi_c_refits {
            Some(refits) => also_units(&[("phi_c".to_string(), refits.clone())]),
            None => Vec::new(),
        };
        if r.fitted.is_empty() || (jk.is_none() && also.is_empty()) {
            return;
        }
        let refit = |left: pool::LeftOut, _: &[f64], ys: &[f64]| -> Option<Vec<f64>> {
            let pc = self
                .phi_c_refits
                .as_ref()
                .and_then(|m| m.get(&(left.unit.to_bits(), left.replica)))
                .copied()
                .unwrap_or(self.phi_c);
            let curves = self.curves(ys);
            if r.needs_phi_c && self.phi_c_too_low(&curves, pc) {
                return None;
            }
            collapse::best(&curves, r.fitted, &self.bounds, &self.rescale_at(pc))
                .map_err(|e| ctx.log(format!("jackknife refit of the collapse failed: {e:#}")))
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
        let (x, y) = (&self.points.x, &self.points.y);
        match pool::replica_jackknife_with(&units, x, y, &[], &y_jk, &also, refit) {
            Some(j) if jk.is_some() => {
                *dq = j.errors;
                *method = jackknife_method(j.refits.len(), &from);
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

    /// phi_c from a fit without replica refits (a joint fit) is held in the
    /// jackknife: its quoted error is passed on to the errors `dq` of the
    /// parameters `q` as the fit stage passes it (refits at phi_c +- its error).
    fn held_phi_c_errors(&self, curves: &[Curve], q: &[f64], dq: &mut [f64], method: &mut String) {
        let r = self.r;
        let (phi_c, phi_c_err) = (self.phi_c, self.phi_c_err);
        let (Some(f), None, true) = (
            &self.p.phi_c_from,
            &self.phi_c_refits,
            r.needs_phi_c && !r.fitted.is_empty(),
        ) else {
            return;
        };
        let refit_at = |pc: f64| {
            if self.phi_c_too_low(curves, pc) {
                return None;
            }
            collapse::best(curves, r.fitted, &self.bounds, &self.rescale_at(pc)).ok()
        };
        if let Some(d) = held_shifts(q, phi_c, phi_c_err, refit_at) {
            add_in_quadrature(dq, &d);
            method.push_str(&format!(
                "; phi_c ({} of {}, without replica refits) held at {phi_c:.6} +- {phi_c_err:.2e}: each error adds in quadrature half the change between the collapses at phi_c +- {phi_c_err:.2e}",
                f.quantity, f.stage
            ));
        }
    }

    /// A collapse that failed: its numbers NaN, the error its note.
    fn failed(&self, ctx: &StageCtx, e: &anyhow::Error) -> Collapsed {
        let msg = format!("collapse failed: {e:#}");
        ctx.log(msg.clone());
        let mut rows: Vec<(String, f64, f64)> = self
            .r
            .fitted
            .iter()
            .chain(&["collapse_S"])
            .map(|n| (n.to_string(), f64::NAN, f64::NAN))
            .collect();
        if self.r.needs_phi_c {
            rows.push(("phi_c_used".to_string(), self.phi_c, 0.0));
        }
        Collapsed {
            rows,
            note: msg,
            best: None,
            method: "fit covariance of the collapse".to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Kind;
    use crate::stages::fit::{Collapse, ERROR_METHOD, Fit, JACKKNIFE_FILE};
    use crate::stages::test_support::{artifact, artifact_of, fitted, output_artifact, yaml};
    use crate::table::f64_batch;

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
            .run_params(&ctx, &tau_fit, &[artifact(dir.path(), "tau", tau_table)])
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
                .run_params(&ctx, &collapse, &[sizes.clone(), source])
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
        let ((v_held, e_held), held_method) = rho_of(JACKKNIFE_FILE);
        let ((v, e), method) = rho_of("");
        // phi_c given as a number: no error to pass on, the covariance alone.
        let fixed = yaml(&format!(
            "{{rescaling: cluster_cutoff, data: sizes, x: Nc, y: P, y_err: P_err, curve_by: phi, \
             phi_c: {fitted_phi_c}, bounds: {{kappa: [1.0, 3.0], rho: [0.5, 5.0]}}}}"
        ));
        let o = Collapse.run_params(&ctx, &fixed, &[sizes.clone()]).unwrap();
        let (v_fixed, e_fixed) = fitted(dir.path(), &o).quantity("rho").unwrap();
        assert!((v_held - rho).abs() < 0.03, "rho {v_held}");
        assert_eq!(v.to_bits(), v_held.to_bits(), "the value does not change");
        assert_eq!(v.to_bits(), v_fixed.to_bits(), "the value does not change");
        assert!(
            e > 5.0 * e_fixed,
            "rho error {e} with phi_c refitted, {e_fixed} with phi_c a number"
        );
        assert!(method.contains("phi_c"), "error method: {method}");
        // Without refits phi_c's quoted error is passed on instead: the same
        // share of the variance within a factor of 3.
        assert!(
            e_held > 5.0 * e_fixed && (e_held / e - 1.0).abs() < 2.0 && e / e_held < 3.0,
            "rho error {e_held} with phi_c held at its error, {e} refitted, {e_fixed} fixed"
        );
        assert!(
            held_method.contains("held at"),
            "error method: {held_method}"
        );
    }
}
