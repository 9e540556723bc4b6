//! The analysed window per phi (paper H: "for each packing fraction we select
//! for the analysis the time window such that the system is in a steady
//! state"). `steady_window` applies the rule of [`crate::analysis::window`] to
//! the trends of tau_alpha(t0) (the `drift` fits over every origin and over the
//! late ones) and of T and P (every run's samples); `window` keeps its choice
//! alone, the table an experiment names as its `window` and every analysis of
//! its runs reads: its digest changes only when a window moves, so a new digit
//! of a drift reruns no analysis.

use std::collections::BTreeMap;

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use serde_json::Value;

use super::tables::{Columns, inputs_of};
use crate::analysis::window::{Trends, halves_drift, steady_window};
use crate::pipeline::registry::typed;
use crate::pipeline::stage::Holds;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RuleParams {
    /// The `drift` fit of tau_alpha(t0) over every origin, grouped by phi.
    pub drift: String,
    /// The same fit over the late origins (an aging stage with `skip_origins: late_skip`).
    pub drift_late: String,
    /// Every run's samples: phi, replica, time (production from 0), T, P.
    pub series: String,
    /// The fraction of origins the late fit leaves out.
    pub late_skip: f64,
    #[serde(default = "tau_quantity")]
    pub quantity: String,
    #[serde(default = "tau_late_quantity")]
    pub late_quantity: String,
    /// Blocks in time per run for the error of T's and P's change.
    #[serde(default = "eight")]
    pub blocks: usize,
    /// A trend is one beyond this many errors of zero.
    #[serde(default = "three")]
    pub threshold: f64,
}

fn tau_quantity() -> String {
    "tau_alpha_drift".into()
}
fn tau_late_quantity() -> String {
    "tau_alpha_drift_late".into()
}
fn eight() -> usize {
    8
}
fn three() -> f64 {
    3.0
}

pub struct SteadyWindow;

/// T's and P's relative change between the halves of `[from x end, end]` of
/// production, per phi: the mean over its runs, with the error of that mean
/// from each run's block error.
fn run_changes(
    s: &Columns,
    col: &str,
    from: f64,
    blocks: usize,
) -> Result<BTreeMap<u64, (f64, f64)>> {
    let (phi, rep, t, x) = (
        s.col("phi")?,
        s.col("replica")?,
        s.col("time")?,
        s.col(col)?,
    );
    let mut runs: BTreeMap<(u64, u64), (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for i in 0..s.rows {
        if t[i] >= 0.0 {
            let e = runs
                .entry((phi[i].to_bits(), rep[i].to_bits()))
                .or_default();
            e.0.push(t[i]);
            e.1.push(x[i]);
        }
    }
    let mut per_phi: BTreeMap<u64, Vec<(f64, f64)>> = BTreeMap::new();
    for ((p, r), (t, x)) in &runs {
        let end = t.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let d = halves_drift(t, x, from * end, end, blocks).with_context(|| {
            format!(
                "steady_window: the run at phi = {}, replica {} has a block of its production without a sample of {col} ({} samples, {blocks} blocks): give fewer `blocks`",
                f64::from_bits(*p),
                f64::from_bits(*r),
                t.len()
            )
        })?;
        per_phi.entry(*p).or_default().push(d);
    }
    Ok(per_phi
        .into_iter()
        .map(|(p, v)| {
            let n = v.len() as f64;
            let mean = v.iter().map(|d| d.0).sum::<f64>() / n;
            let err = v.iter().map(|d| d.1 * d.1).sum::<f64>().sqrt() / n;
            (p, (mean, err))
        })
        .collect())
}

impl StageKind for SteadyWindow {
    type Params = RuleParams;
    fn name(&self) -> &str {
        "steady_window"
    }
    fn describe(&self) -> &str {
        "the analysed window per phi by the steady-state rule (src/analysis/window.rs): every origin when tau_alpha(t0), T and P show no trend beyond `threshold` errors, else the late origins; one row per phi with each trend over its error"
    }
    fn details(&self) -> String {
        "  parameters: drift, drift_late (fit stages of tau_alpha(t0) over every and over the late origins), series (every run's samples of T and P), late_skip (the late fit's skip_origins), quantity (tau_alpha_drift), late_quantity (tau_alpha_drift_late), blocks (8), threshold (3)\n  example (pipelines/stationarity.yaml):\n    - {name: window_rule, kind: steady_window, gather: [drift, drift_late, series_table], params: {drift: drift, drift_late: drift_late, series: series_table, late_skip: 0.5}}".into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<RuleParams> {
        let p: RuleParams = typed("steady_window", params)?;
        if !(p.late_skip > 0.0 && p.late_skip < 1.0) {
            bail!(
                "steady_window: `late_skip` is a fraction of the origins in (0, 1); got {}",
                p.late_skip
            );
        }
        if p.blocks < 4 || p.blocks % 2 != 0 {
            bail!(
                "steady_window: `blocks` must be even and at least 4 (two halves of at least two blocks); got {}",
                p.blocks
            );
        }
        if !(p.threshold.is_finite() && p.threshold > 0.0) {
            bail!(
                "steady_window: `threshold` (errors) must be > 0; got {}",
                p.threshold
            );
        }
        Ok(p)
    }
    fn run(&self, ctx: &StageCtx, p: &RuleParams, inputs: &[Artifact]) -> Result<Output> {
        let kind = "steady_window";
        let drift = Columns::read(&inputs_of(kind, inputs, &p.drift)?)?;
        let late = Columns::read(&inputs_of(kind, inputs, &p.drift_late)?)?;
        let series = Columns::read(&inputs_of(kind, inputs, &p.series)?)?;
        let changes = |col: &str, from: f64| run_changes(&series, col, from, p.blocks);
        let (t_all, p_all) = (changes("T", 0.0)?, changes("P", 0.0)?);
        let (t_late, p_late) = (changes("T", 0.5)?, changes("P", 0.5)?);
        let z = |(v, e): (f64, f64)| v / e;
        let mut cols: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for (&bits, &t_change) in &t_all {
            let phi = f64::from_bits(bits);
            let group = [("phi".to_string(), phi)];
            let tau = drift.quantity_in(&p.quantity, &group).map_or(f64::NAN, z);
            let tau_late = late
                .quantity_in(&p.late_quantity, &group)
                .map_or(f64::NAN, z);
            let whole = Trends {
                tau_alpha: tau,
                temperature: z(t_change),
                pressure: z(p_all[&bits]),
            };
            let later = Trends {
                tau_alpha: tau_late,
                temperature: z(t_late[&bits]),
                pressure: z(p_late[&bits]),
            };
            let w = steady_window(&whole, &later, p.late_skip, p.threshold);
            ctx.log(format!(
                "phi = {phi}: trends/error over the whole production {:.2} (tau_alpha {tau:.2}, T {:.2}, P {:.2}), over the late part {:.2}: skip_origins {}{}",
                whole.largest(),
                whole.temperature,
                whole.pressure,
                later.largest(),
                w.skip_origins,
                if w.steady { "" } else { ", not steady" }
            ));
            for (k, v) in [
                ("phi", phi),
                ("z_tau_alpha", tau),
                ("z_T", whole.temperature),
                ("z_P", whole.pressure),
                ("T_change", t_change.0),
                ("T_change_err", t_change.1),
                ("P_change", p_all[&bits].0),
                ("P_change_err", p_all[&bits].1),
                ("z_tau_alpha_late", tau_late),
                ("z_T_late", later.temperature),
                ("z_P_late", later.pressure),
                ("trend", whole.largest()),
                ("trend_late", later.largest()),
                ("threshold", p.threshold),
                ("skip_origins", w.skip_origins),
                ("steady", f64::from(u8::from(w.steady))),
            ] {
                cols.entry(k).or_default().push(v);
            }
        }
        let cols: Vec<(&str, Vec<f64>)> = cols.into_iter().collect();
        Ok(Output::single(
            "parquet",
            to_parquet_bytes(&[f64_batch(&cols)?], &[])?,
        ))
    }
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ChoiceParams {
    /// The `steady_window` stage whose choice this keeps.
    pub rule: String,
}

pub struct Window;

impl StageKind for Window {
    type Params = ChoiceParams;
    fn name(&self) -> &str {
        "window"
    }
    fn describe(&self) -> &str {
        "the analysed window per phi alone (phi, skip_origins), from a `steady_window` stage: what an experiment's `window` names and every analysis of its runs reads"
    }
    fn details(&self) -> String {
        "  parameters: rule (the steady_window stage)\n  example (pipelines/stationarity.yaml):\n    - {name: window, kind: window, gather: [window_rule], params: {rule: window_rule}}\n  and in experiments/eps09.yaml: `window: stationarity/window`".into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn holds(&self) -> Holds {
        Holds::Window
    }
    fn parse(&self, params: &Value) -> Result<ChoiceParams> {
        typed("window", params)
    }
    fn run(&self, _ctx: &StageCtx, p: &ChoiceParams, inputs: &[Artifact]) -> Result<Output> {
        let rule = Columns::read(&inputs_of("window", inputs, &p.rule)?)?;
        let b = f64_batch(&[
            ("phi", rule.col("phi")?.to_vec()),
            ("skip_origins", rule.col("skip_origins")?.to_vec()),
        ])?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}
