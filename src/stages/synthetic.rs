//! Synthetic data with known truth, as experiment kinds (one instance per grid
//! point, seeded like a simulation): the stability map of the fits
//! (`src/fit/stability.rs`).
//! - `synthetic_coverage`: every catalogue form fitted to noisy copies of its
//!   example at one noise level, number of points and noise correlation; the
//!   coverage of each parameter's quoted error.
//! - `synthetic_divergence`: the power-law divergence fitted to data that stop
//!   at a distance d below phi_c; the bias of phi_c and how often the fit calls
//!   itself unreliable.

use anyhow::{Result, bail};
use serde::Deserialize;
use serde_json::Value;

use crate::fit::catalogue::FORMS;
use crate::fit::stability::{self, EXAMPLES, Errors, Setting};
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::{f64_batch, to_parquet_bytes};

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CoverageParams {
    /// Relative 1-sigma noise of each point.
    pub level: f64,
    pub points: usize,
    /// Lag-one correlation of the noise of neighbouring points (0: independent).
    #[serde(default)]
    pub rho: f64,
    /// Noise realisations per form.
    pub realisations: usize,
    pub seed: u64,
    /// The quoted error: `covariance` (default) or `{replica_jackknife:
    /// {replicas: R}}`, the delete-one jackknife over R replicas of the fit.
    #[serde(default)]
    pub errors: Errors,
}

pub struct SyntheticCoverage;

impl StageKind for SyntheticCoverage {
    type Params = CoverageParams;
    fn name(&self) -> &str {
        "synthetic_coverage"
    }
    fn describe(&self) -> &str {
        "every fit form on noisy synthetic data with known truth: the coverage of each parameter's quoted 1-sigma error"
    }
    fn details(&self) -> String {
        format!(
            "parameters: level (relative noise), points, rho (lag-one noise correlation, default 0), realisations, seed (given by the experiment), errors (covariance, the default, or {{replica_jackknife: {{replicas: R}}}})\n\
             columns: form_id (index in: {}), param_id (-1: the mean over the form's parameters), fits, failed, coverage, coverage_err, ratio (rms quoted error / spread about the truth), bias (in units of that spread)",
            FORMS.iter().map(|f| f.name).collect::<Vec<_>>().join(", ")
        )
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<CoverageParams> {
        let p: CoverageParams = typed("synthetic_coverage", params)?;
        if !(p.level > 0.0 && p.level.is_finite()) {
            bail!("synthetic_coverage: level = {} must be > 0", p.level);
        }
        if !(0.0..1.0).contains(&p.rho) {
            bail!("synthetic_coverage: rho = {} must be in [0, 1)", p.rho);
        }
        if let Errors::ReplicaJackknife { replicas } = p.errors
            && replicas < 3
        {
            bail!(
                "synthetic_coverage: errors.replica_jackknife.replicas = {replicas} must be >= 3"
            );
        }
        if p.points < 4 || p.realisations < 10 {
            bail!(
                "synthetic_coverage: need points >= 4 and realisations >= 10 (got {} and {})",
                p.points,
                p.realisations
            );
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &CoverageParams, _inputs: &[Artifact]) -> Result<Output> {
        let setting = Setting {
            level: p.level,
            points: p.points,
            rho: p.rho,
            errors: p.errors,
        };
        let mut cols: [Vec<f64>; 8] = Default::default();
        for (j, ex) in EXAMPLES.iter().enumerate() {
            let rows =
                stability::coverage(ex, setting, p.realisations, p.seed.wrapping_add(j as u64));
            let form = stability::form_index(ex.form) as f64;
            // The form as a whole: its parameters' mean coverage, ratio and bias.
            let k = rows.len() as f64;
            let mean =
                |f: fn(&stability::ParamCoverage) -> f64| rows.iter().map(f).sum::<f64>() / k;
            let all = stability::ParamCoverage {
                coverage: mean(|r| r.coverage),
                ratio: mean(|r| r.ratio),
                bias: mean(|r| r.bias),
                ..rows[0].clone()
            };
            let numbered = rows.into_iter().enumerate().map(|(k, r)| (k as f64, r));
            for (k, r) in numbered.chain(std::iter::once((-1.0, all))) {
                let n = r.fits.max(1) as f64;
                let row = [
                    form,
                    k,
                    r.fits as f64,
                    r.failed,
                    r.coverage,
                    (r.coverage * (1.0 - r.coverage) / n).sqrt().max(0.5 / n),
                    r.ratio,
                    r.bias,
                ];
                for (c, v) in cols.iter_mut().zip(row) {
                    c.push(v);
                }
            }
        }
        let names = [
            "form_id",
            "param_id",
            "fits",
            "failed",
            "coverage",
            "coverage_err",
            "ratio",
            "bias",
        ];
        let b = f64_batch(
            &names
                .iter()
                .zip(cols)
                .map(|(n, c)| (*n, c))
                .collect::<Vec<_>>(),
        )?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DivergenceParams {
    /// Distance of the last data point below phi_c.
    pub d: f64,
    /// Spacing of the packing fractions.
    pub step: f64,
    pub points: usize,
    /// Relative 1-sigma noise of tau.
    pub level: f64,
    pub realisations: usize,
    pub seed: u64,
}

pub struct SyntheticDivergence;

impl StageKind for SyntheticDivergence {
    type Params = DivergenceParams;
    fn name(&self) -> &str {
        "synthetic_divergence"
    }
    fn describe(&self) -> &str {
        "tau = A (phi_c - phi)^-gamma fitted to noisy data stopping at d below phi_c: the bias of phi_c and how often the fit reports `unreliable`"
    }
    fn details(&self) -> String {
        "parameters: d, step, points, level, realisations, seed (given by the experiment)\n\
         columns: d_steps (d / step), fits, bias (fitted - true phi_c), spread, quoted (rms quoted error), bias_over_spread, coverage, unreliable (fraction flagged or failed)"
            .into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<DivergenceParams> {
        let p: DivergenceParams = typed("synthetic_divergence", params)?;
        if !(p.d > 0.0 && p.step > 0.0 && p.level > 0.0) {
            bail!(
                "synthetic_divergence: d, step and level must be > 0 (got {}, {}, {})",
                p.d,
                p.step,
                p.level
            );
        }
        if p.points < 4 || p.realisations < 10 {
            bail!(
                "synthetic_divergence: need points >= 4 and realisations >= 10 (got {} and {})",
                p.points,
                p.realisations
            );
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &DivergenceParams, _inputs: &[Artifact]) -> Result<Output> {
        let r =
            stability::divergence_bias(&[p.d], p.step, p.points, p.level, p.realisations, p.seed)
                .remove(0);
        let b = f64_batch(&[
            ("d_steps", vec![r.d_steps]),
            ("fits", vec![r.fits as f64]),
            ("bias", vec![r.bias]),
            ("spread", vec![r.spread]),
            ("quoted", vec![r.quoted]),
            ("bias_over_spread", vec![r.bias / r.spread]),
            ("coverage", vec![r.coverage]),
            ("unreliable", vec![r.unreliable]),
        ])?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}
