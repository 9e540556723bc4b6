//! `overlap`, `tau_alpha`, `aging`: the overlap Q(t) of paper H (Eq. 5-7) from the
//! replicas gathered into one stage (typically `by: [phi]`), pooled over time
//! origins and replicas.

use std::collections::BTreeMap;

use anyhow::Result;
use serde_json::Value;

use super::tables::{every_origin_lags, trajectories};
use crate::analysis::overlap::{self, Params};
use crate::analysis::stats::crossing_time;
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};
use crate::traj::Trajectory;

const MODULES: &[&str] = &[
    "analysis/overlap",
    "analysis/lags",
    "analysis/stats",
    "analysis/subbox",
    "analysis/mod",
    "traj",
    "table",
    "stages/overlap",
    "stages/tables",
];

fn refs(t: &[Trajectory]) -> Vec<&Trajectory> {
    t.iter().collect()
}

fn parquet(b: arrow_array::RecordBatch) -> Result<Output> {
    Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
}

/// `overlap`: table t, Q, Q_err, n_origins (pooled replicas).
pub struct Overlap;

impl StageKind for Overlap {
    fn name(&self) -> &str {
        "overlap"
    }
    fn describe(&self) -> &str {
        "Q(t) pooled over the gathered replicas and time origins (t, Q, Q_err, n_origins)"
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, params: &Value) -> Result<()> {
        typed::<Params>("overlap", params).map(|_| ())
    }
    fn run(&self, _ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let mut p: Params = typed("overlap", params)?;
        let trajs = trajectories("overlap", inputs)?;
        p.lags = every_origin_lags(&trajs, p.lags.take(), p.rel_tol)?;
        let (t, q, n) = overlap::q_curve(&refs(&trajs), &p)?;
        parquet(f64_batch(&[
            ("t", t),
            ("Q", q.iter().map(|e| e.value).collect()),
            ("Q_err", q.iter().map(|e| e.err).collect()),
            ("n_origins", n.iter().map(|&k| k as f64).collect()),
        ])?)
    }
}

/// `tau_alpha`: one row tau_alpha, tau_alpha_err, replicas (Q(tau_alpha) = 1/e).
pub struct TauAlpha;

impl StageKind for TauAlpha {
    fn name(&self) -> &str {
        "tau_alpha"
    }
    fn describe(&self) -> &str {
        "tau_alpha where Q = 1/e, pooled replicas, jackknife error (one row)"
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, params: &Value) -> Result<()> {
        typed::<Params>("tau_alpha", params).map(|_| ())
    }
    fn run(&self, _ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let mut p: Params = typed("tau_alpha", params)?;
        let trajs = trajectories("tau_alpha", inputs)?;
        p.lags = every_origin_lags(&trajs, p.lags.take(), p.rel_tol)?;
        let tau = overlap::tau_alpha(&refs(&trajs), &p)?;
        parquet(f64_batch(&[
            ("tau_alpha", vec![tau.value]),
            ("tau_alpha_err", vec![tau.err]),
            ("replicas", vec![trajs.len() as f64]),
        ])?)
    }
}

/// `aging` (Fig. 2): Q(t; t0) per waiting time t0, averaged over replicas (which
/// share one schedule): table t0, t, Q; and `tau.parquet`: t0, tau_alpha(t0).
pub struct Aging;

/// One waiting time t0 with its lags and Q(t; t0).
pub type AgingCurve = (f64, Vec<f64>, Vec<f64>);

/// Per waiting time: (t0, lags, Q averaged over replicas).
pub fn aging_curves(trajs: &[Trajectory], p: &Params) -> Result<Vec<AgingCurve>> {
    let mut acc: BTreeMap<u64, (f64, Vec<f64>, Vec<f64>, usize)> = BTreeMap::new();
    for tr in trajs {
        for (t0, t, q) in overlap::per_origin(tr, p)? {
            // Waiting times agree across replicas up to rounding: key them on 1e-9.
            let key = (t0 * 1e9).round() as u64;
            let e = acc
                .entry(key)
                .or_insert_with(|| (t0, t.clone(), vec![0.0; q.len()], 0));
            if e.1 == t {
                e.2.iter_mut().zip(&q).for_each(|(s, v)| *s += v);
                e.3 += 1;
            }
        }
    }
    // True time origins are the frames the shortest lag is realised from (the
    // schedule's lags are log-spaced, so no frame inside a block is 0.05 after
    // another); frames pairing only with other origins' frames are not waiting times.
    let shortest = acc
        .values()
        .filter_map(|e| e.1.first().copied())
        .fold(f64::INFINITY, f64::min);
    Ok(acc
        .into_values()
        .filter(|e| {
            e.1.first()
                .is_some_and(|&t| (t - shortest).abs() <= 1e-9 * shortest)
        })
        .map(|(t0, t, s, k)| (t0, t, s.into_iter().map(|v| v / k as f64).collect()))
        .collect())
}

impl StageKind for Aging {
    fn name(&self) -> &str {
        "aging"
    }
    fn describe(&self) -> &str {
        "Q(t; t0) per waiting time t0, replica-averaged (t0, t, Q); tau.parquet: t0, tau_alpha"
    }
    fn modules(&self) -> &[&str] {
        MODULES
    }
    fn validate(&self, params: &Value) -> Result<()> {
        typed::<Params>("aging", params).map(|_| ())
    }
    fn run(&self, _ctx: &StageCtx, params: &Value, inputs: &[Artifact]) -> Result<Output> {
        let mut p: Params = typed("aging", params)?;
        let trajs = trajectories("aging", inputs)?;
        p.lags = every_origin_lags(&trajs, p.lags.take(), p.rel_tol)?;
        let level = (-1f64).exp();
        let mut cols: [Vec<f64>; 3] = Default::default();
        let (mut t0s, mut taus) = (Vec::new(), Vec::new());
        for (t0, t, q) in aging_curves(&trajs, &p)? {
            t0s.push(t0);
            taus.push(crossing_time(&t, &q, level).unwrap_or(f64::NAN));
            cols[0].extend(std::iter::repeat_n(t0, t.len()));
            cols[1].extend(t);
            cols[2].extend(q);
        }
        let [t0, t, q] = cols;
        let tau = f64_batch(&[("t0", t0s), ("tau_alpha", taus)])?;
        Ok(parquet(f64_batch(&[("t0", t0), ("t", t), ("Q", q)])?)?
            .with("tau.parquet", to_parquet_bytes(&[tau], &[])?))
    }
}
