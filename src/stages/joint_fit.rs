//! `joint_fit`: power laws of several columns of one table that share their
//! divergence, y_k = A_k (phi_c - phi)^(-gamma_k) (paper H: phi_c = 0.82 "from
//! the simultaneous fit of tau_alpha, chi4 and xi"); the library's
//! [`crate::fit::forms::joint_power_law_offset`].

use std::collections::BTreeMap;

use anyhow::{Result, bail};
use serde::Deserialize;
use serde_json::Value;

use super::fit::ERROR_METHOD;
use super::tables::{Columns, Where, inputs_of, pick};
use crate::fit::Data;
use crate::fit::forms::joint_power_law_offset;
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::results::quantity_batch;
use crate::table::to_parquet_bytes;

/// One series: a column of y and its errors.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Series {
    pub y: String,
    pub y_err: String,
    /// Rows kept for this series alone (e.g. xi where its OZ fit is reliable).
    #[serde(default, rename = "where")]
    pub filter: Where,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointParams {
    /// Stage whose table holds every column (e.g. a join of tau_alpha, chi4 and xi on phi).
    pub data: String,
    pub x: String,
    pub series: Vec<Series>,
    /// Rows kept, for every series.
    #[serde(default, rename = "where")]
    pub filter: Where,
    /// Quantity names for `phi_c` and for `A_Y`, `gamma_Y` (Y a series' column).
    #[serde(default)]
    pub rename: BTreeMap<String, String>,
}

pub struct JointFit;

impl StageKind for JointFit {
    type Params = JointParams;
    fn name(&self) -> &str {
        "joint_fit"
    }
    fn describe(&self) -> &str {
        "power laws y_k = A_k (phi_c - x)^-gamma_k of several columns fitted together with one phi_c"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<JointParams> {
        let p: JointParams = typed("joint_fit", params)?;
        if p.series.len() < 2 {
            bail!("joint_fit: `series` needs at least two columns, each {{y, y_err}}");
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &JointParams, inputs: &[Artifact]) -> Result<Output> {
        let c = Columns::read(&inputs_of("joint_fit", inputs, &p.data)?)?;
        let rows = c.select(&p.filter)?;
        // Per series, the rows where y and its error are usable.
        let mut cols: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = Vec::new();
        for s in &p.series {
            let own = c.select(&s.filter)?;
            let rows: Vec<usize> = rows.iter().copied().filter(|r| own.contains(r)).collect();
            let x = pick(c.col(&p.x)?, &rows);
            let (y, e) = (pick(c.col(&s.y)?, &rows), pick(c.col(&s.y_err)?, &rows));
            let keep: Vec<usize> = (0..x.len())
                .filter(|&i| y[i].is_finite() && y[i] > 0.0 && e[i].is_finite() && e[i] > 0.0)
                .collect();
            cols.push((pick(&x, &keep), pick(&y, &keep), pick(&e, &keep)));
        }
        let series: Vec<Data> = cols.iter().map(|(x, y, e)| Data::new(x, y, e)).collect();
        let name = |n: &str| p.rename.get(n).cloned().unwrap_or_else(|| n.to_string());
        let mut out: Vec<(String, f64, f64)> = Vec::new();
        let note = match joint_power_law_offset(&series) {
            Ok(f) => {
                let (v, e) = f.get("phi_c").expect("a parameter");
                out.push((name("phi_c"), v, e));
                for (k, s) in p.series.iter().enumerate() {
                    for par in ["A", "gamma"] {
                        let (v, e) = f.get(&format!("{par}_{k}")).expect("a parameter");
                        out.push((name(&format!("{par}_{}", s.y)), v, e));
                    }
                }
                out.push((name("reduced_chi2"), f.reduced_chi2, f64::NAN));
                f.warnings.join("; ")
            }
            Err(e) => {
                out.push((name("phi_c"), f64::NAN, f64::NAN));
                format!("fit failed: {e}")
            }
        };
        let points: usize = cols.iter().map(|c| c.0.len()).sum();
        out.push((name("points"), points as f64, 0.0));
        Ok(Output::single(
            "parquet",
            to_parquet_bytes(
                &[quantity_batch(&[], &out, &note, None)?],
                &[(ERROR_METHOD, "fit covariance of the joint fit")],
            )?,
        ))
    }
}
