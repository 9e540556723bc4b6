//! `chi4`, `chi4_peaks`: the dynamic susceptibility chi4(t) = N [<Q_r^2> - <Q_r>^2]
//! (paper H, Eq. 14) for sub-boxes of mean particle number N, pooled over the
//! gathered replicas and time origins; and per N its peak (tau4, chi4P) next to
//! tau_alpha and chi4(tau_alpha) (Fig. 15 inset, Fig. 19).

use anyhow::{Result, bail};
use serde_json::Value;

use super::tables::{every_origin_lags, interp_log_t, trajectories};
use crate::analysis::chi4::{self, Params};
use crate::analysis::overlap;
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};
use crate::traj::Trajectory;

const MODULES: &[&str] = &[
    "analysis/chi4",
    "analysis/overlap",
    "analysis/lags",
    "analysis/stats",
    "analysis/subbox",
    "analysis/mod",
    "traj",
    "table",
    "stages/chi4",
    "stages/tables",
];

fn params(kind: &str, v: &Value) -> Result<Params> {
    let p: Params = typed(kind, v)?;
    if p.n.is_empty() {
        bail!(
            "{kind}: `n` (sub-box particle numbers) is empty; give at least one, e.g. n: [100, 400]"
        );
    }
    Ok(p)
}

/// Sub-box sizes that fit in the system: a request above the particle number
/// becomes the whole system (so one spec serves every profile's N).
fn clamp_sizes(p: &mut Params, trajs: &[Trajectory]) {
    let n_tot = trajs[0].n() as f64;
    for n in &mut p.n {
        *n = n.min(n_tot);
    }
    p.n.dedup();
}

/// `chi4`: table N, t, Q, chi4, chi4_err, n_origins.
pub struct Chi4;

impl StageKind for Chi4 {
    fn name(&self) -> &str {
        "chi4"
    }
    fn describe(&self) -> &str {
        "chi4(t) per sub-box size N, pooled replicas (N, t, Q, chi4, chi4_err, n_origins)"
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, v: &Value) -> Result<()> {
        params("chi4", v).map(|_| ())
    }
    fn run(&self, _ctx: &StageCtx, v: &Value, inputs: &[Artifact]) -> Result<Output> {
        let mut p = params("chi4", v)?;
        let trajs = trajectories("chi4", inputs)?;
        clamp_sizes(&mut p, &trajs);
        p.lags = every_origin_lags(&trajs, p.lags.take(), p.rel_tol)?;
        let refs: Vec<&Trajectory> = trajs.iter().collect();
        let b = chi4::compute_pooled(&refs, &p)?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}

/// `chi4_peaks`: per N: tau4, chi4P (with errors), tau_alpha and chi4(tau_alpha).
pub struct Chi4Peaks;

impl StageKind for Chi4Peaks {
    fn name(&self) -> &str {
        "chi4_peaks"
    }
    fn describe(&self) -> &str {
        "chi4 peak per sub-box size with tau_alpha and chi4(tau_alpha) (N, tau4, chi4P, tau_alpha, chi4_tau_alpha, ...)"
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, v: &Value) -> Result<()> {
        params("chi4_peaks", v).map(|_| ())
    }
    fn run(&self, _ctx: &StageCtx, v: &Value, inputs: &[Artifact]) -> Result<Output> {
        let mut p = params("chi4_peaks", v)?;
        let trajs = trajectories("chi4_peaks", inputs)?;
        clamp_sizes(&mut p, &trajs);
        p.lags = every_origin_lags(&trajs, p.lags.take(), p.rel_tol)?;
        let refs: Vec<&Trajectory> = trajs.iter().collect();
        let peaks = chi4::peaks(&refs, &p)?;
        let op = overlap::Params {
            a: p.a,
            n: None,
            lags: p.lags.clone(),
            rel_tol: p.rel_tol,
        };
        // tau_alpha may be out of reach of a short run: NaN then, not a failure.
        let tau = overlap::tau_alpha(&refs, &op).ok();
        let table = chi4::compute_pooled(&refs, &p)?;
        let cols = super::tables::Columns::from_batch(&table)?;
        let (n_col, t_col, c_col, e_col) = (
            cols.col("N")?,
            cols.col("t")?,
            cols.col("chi4")?,
            cols.col("chi4_err")?,
        );
        let mut at_tau = Vec::new();
        let mut at_tau_err = Vec::new();
        for pk in &peaks {
            let rows: Vec<usize> = (0..cols.rows).filter(|&i| n_col[i] == pk.n).collect();
            let t: Vec<f64> = rows.iter().map(|&i| t_col[i]).collect();
            let c: Vec<f64> = rows.iter().map(|&i| c_col[i]).collect();
            let e: Vec<f64> = rows.iter().map(|&i| e_col[i]).collect();
            let ta = tau.map(|x| x.value).unwrap_or(f64::NAN);
            at_tau.push(interp_log_t(&t, &c, ta).unwrap_or(f64::NAN));
            at_tau_err.push(interp_log_t(&t, &e, ta).unwrap_or(f64::NAN));
        }
        let k = peaks.len();
        let b = f64_batch(&[
            ("N", peaks.iter().map(|x| x.n).collect()),
            ("tau4", peaks.iter().map(|x| x.tau4.value).collect()),
            ("tau4_err", peaks.iter().map(|x| x.tau4.err).collect()),
            ("chi4P", peaks.iter().map(|x| x.chi4p.value).collect()),
            ("chi4P_err", peaks.iter().map(|x| x.chi4p.err).collect()),
            (
                "tau_alpha",
                vec![tau.map(|x| x.value).unwrap_or(f64::NAN); k],
            ),
            (
                "tau_alpha_err",
                vec![tau.map(|x| x.err).unwrap_or(f64::NAN); k],
            ),
            ("chi4_tau_alpha", at_tau),
            ("chi4_tau_alpha_err", at_tau_err),
        ])?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}
