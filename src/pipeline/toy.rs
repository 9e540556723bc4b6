//! Toy stage kinds, for testing the framework only: the command line registers
//! them only when `REPRO_TOY_KINDS` is set (the integration tests set it), so a
//! user never meets them. They are small but honest pure
//! functions of their parameters, inputs and seed, so the cache, seeding and
//! parallelism are exercised exactly as the real kinds will be.

use std::sync::Arc;

use anyhow::{Context, Result, bail};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;
use serde_json::Value;

use super::canon::param_error;
use super::registry::{Registry, typed};
use super::stage::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, read_parquet_bytes, results, to_parquet_bytes};

/// Register every toy kind.
pub fn register(r: &mut Registry) {
    r.register(ToySimulate);
    r.register(ToyAnalyse);
    r.register(ToyFit);
    r.register(ToyPlot);
    r.register(ToyFail);
    r.register(ToyWindow);
}

fn column(b: &RecordBatch, name: &str, label: &str) -> Result<Vec<f64>> {
    let c = b
        .column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
        .with_context(|| format!("input {label} has no float column '{name}'"))?;
    Ok(c.values().to_vec())
}

/// All rows of column `name` over all inputs' Parquet files.
fn gather_column(inputs: &[Artifact], name: &str) -> Result<Vec<f64>> {
    let mut v = Vec::new();
    for a in inputs {
        for b in read_parquet_bytes(a.read("parquet")?)?.0 {
            v.extend(column(&b, name, &a.label)?);
        }
    }
    Ok(v)
}

/// `toy_simulate`: `n` seeded Gaussian numbers of standard deviation `phi`, each the
/// rescaled mean of `1 + work` draws (so `work` costs CPU without changing the law);
/// `sleep_ms` makes it slow for kill tests.
pub struct ToySimulate;

#[derive(Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SimParams {
    n: usize,
    seed: u64,
    #[serde(default = "one")]
    phi: f64,
    #[serde(default = "one")]
    eps: f64,
    #[serde(default)]
    work: u64,
    #[serde(default)]
    sleep_ms: u64,
}

fn one() -> f64 {
    1.0
}

impl StageKind for ToySimulate {
    type Params = SimParams;
    fn name(&self) -> &str {
        "toy_simulate"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<SimParams> {
        let p: SimParams = typed("toy_simulate", params)?;
        if p.n == 0 {
            return Err(param_error(&["n"], "toy_simulate: n must be at least 1"));
        }
        Ok(p)
    }
    fn resolved(&self, p: &SimParams) -> Option<serde_json::Map<String, Value>> {
        match serde_json::to_value(p) {
            Ok(Value::Object(m)) => Some(m),
            _ => None,
        }
    }
    fn run(&self, ctx: &StageCtx, p: &SimParams, _inputs: &[Artifact]) -> Result<Output> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(p.seed);
        let draws = 1 + p.work;
        let mut x = Vec::with_capacity(p.n);
        for i in 0..p.n {
            let s: f64 = (0..draws)
                .map(|_| -> f64 { StandardNormal.sample(&mut rng) })
                .sum::<f64>();
            x.push(p.phi * s / (draws as f64).sqrt());
            if i % 64 == 0 {
                ctx.progress(i as f64, p.n as f64, &format!("{i} of {} values", p.n));
            }
        }
        if p.sleep_ms > 0 {
            std::thread::sleep(std::time::Duration::from_millis(p.sleep_ms));
        }
        ctx.log(format!("drew {} values, eps = {}", p.n, p.eps));
        let t: Vec<f64> = (0..p.n).map(|i| i as f64).collect();
        Ok(Output::single(
            "parquet",
            to_parquet_bytes(&[f64_batch(&[("t", t), ("x", x)])?], &[])?,
        ))
    }
}

/// `toy_analyse`: fraction of |x| < a (an "overlap") and the mean of x, over the
/// first `n_sub` values (all if absent); one row.
pub struct ToyAnalyse;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalyseParams {
    a: f64,
    #[serde(default)]
    n_sub: Option<usize>,
}

impl StageKind for ToyAnalyse {
    type Params = AnalyseParams;
    fn name(&self) -> &str {
        "toy_analyse"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn takes_window(&self, _p: &AnalyseParams) -> bool {
        true
    }
    fn parse(&self, params: &Value) -> Result<AnalyseParams> {
        let p: AnalyseParams = typed("toy_analyse", params)?;
        if p.a.is_nan() || p.a <= 0.0 {
            return Err(param_error(
                &["a"],
                format!("toy_analyse: cutoff a must be > 0, got {}", p.a),
            ));
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &AnalyseParams, inputs: &[Artifact]) -> Result<Output> {
        let mut x = gather_column(inputs, "x")?;
        if let Some(n) = p.n_sub {
            x.truncate(n);
        }
        let n = x.len() as f64;
        let overlap = x.iter().filter(|v| v.abs() < p.a).count() as f64 / n;
        let mean = x.iter().sum::<f64>() / n;
        Ok(Output::single(
            "parquet",
            to_parquet_bytes(
                &[f64_batch(&[
                    ("overlap", vec![overlap]),
                    ("mean", vec![mean]),
                ])?],
                &[],
            )?,
        ))
    }
}

/// `toy_window`: an experiment's analysed window, every origin at every phi
/// of its inputs (phi, skip_origins = 0).
pub struct ToyWindow;

impl StageKind for ToyWindow {
    type Params = Value;
    fn name(&self) -> &str {
        "toy_window"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn holds(&self) -> super::stage::Holds {
        super::stage::Holds::Window
    }
    fn parse(&self, params: &Value) -> Result<Value> {
        Ok(params.clone())
    }
    fn run(&self, _ctx: &StageCtx, _p: &Value, inputs: &[Artifact]) -> Result<Output> {
        let mut phi: Vec<f64> = inputs
            .iter()
            .filter_map(|a| a.point.get("phi").and_then(Value::as_f64))
            .collect();
        phi.sort_by(f64::total_cmp);
        phi.dedup();
        let zero = vec![0.0; phi.len()];
        Ok(Output::single(
            "parquet",
            to_parquet_bytes(&[f64_batch(&[("phi", phi), ("skip_origins", zero)])?], &[])?,
        ))
    }
}

/// `toy_fit`: the mean of a column with its standard error, as a fit table
/// (quantity = `mean_<column>`, value, error).
pub struct ToyFit;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitParams {
    column: String,
}

impl StageKind for ToyFit {
    type Params = FitParams;
    fn name(&self) -> &str {
        "toy_fit"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<FitParams> {
        typed("toy_fit", params)
    }
    fn run(&self, _ctx: &StageCtx, p: &FitParams, inputs: &[Artifact]) -> Result<Output> {
        let v = gather_column(inputs, &p.column)?;
        if v.len() < 2 {
            bail!(
                "toy_fit: need at least 2 rows of '{}', got {}",
                p.column,
                v.len()
            );
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let b = RecordBatch::try_from_iter([
            (
                results::QUANTITY,
                Arc::new(StringArray::from(vec![format!("mean_{}", p.column)])) as ArrayRef,
            ),
            (results::VALUE, Arc::new(Float64Array::from(vec![mean]))),
            (
                results::ERROR,
                Arc::new(Float64Array::from(vec![(var / n).sqrt()])),
            ),
        ])?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}

/// `toy_plot`: a minimal SVG scatter of column `y` against column `x`.
pub struct ToyPlot;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotParams {
    x: String,
    y: String,
}

impl StageKind for ToyPlot {
    type Params = PlotParams;
    fn name(&self) -> &str {
        "toy_plot"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<PlotParams> {
        typed("toy_plot", params)
    }
    fn run(&self, _ctx: &StageCtx, p: &PlotParams, inputs: &[Artifact]) -> Result<Output> {
        let (x, y) = (gather_column(inputs, &p.x)?, gather_column(inputs, &p.y)?);
        let span = |v: &[f64]| {
            let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            (lo, if hi > lo { hi - lo } else { 1.0 })
        };
        let ((x0, dx), (y0, dy)) = (span(&x), span(&y));
        let mut svg = String::from(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"200\" height=\"200\">\n",
        );
        for (a, b) in x.iter().zip(&y) {
            svg += &format!(
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"2\"/>\n",
                10.0 + 180.0 * (a - x0) / dx,
                190.0 - 180.0 * (b - y0) / dy
            );
        }
        svg += &format!(
            "<text x=\"10\" y=\"10\">{} vs {}</text>\n</svg>\n",
            p.y, p.x
        );
        Ok(Output::single("svg", svg.into_bytes()))
    }
}

/// `toy_fail`: logs a line, then fails when `fail` is true (tests failure isolation).
pub struct ToyFail;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailParams {
    fail: bool,
}

impl StageKind for ToyFail {
    type Params = FailParams;
    fn name(&self) -> &str {
        "toy_fail"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<FailParams> {
        typed("toy_fail", params)
    }
    fn run(&self, ctx: &StageCtx, p: &FailParams, inputs: &[Artifact]) -> Result<Output> {
        ctx.log(format!("read {} inputs", inputs.len()));
        if p.fail {
            bail!("toy_fail was asked to fail");
        }
        Ok(Output::single("txt", b"ok\n".to_vec()))
    }
}
