//! What a collapse writes: its quantity table and the curves rescaled at the
//! best parameters.

use anyhow::Result;

use super::ERROR_METHOD;
use super::params::CollapseParams;
use crate::fit::collapse::{self, Curve};
use crate::pipeline::Output;
use crate::table::results::quantity_batch;
use crate::table::{f64_batch, to_parquet_bytes};

/// A collapse's outputs: the quantity table and the curves rescaled at the best
/// parameters (none when the collapse failed).
pub(super) fn collapse_output(
    p: &CollapseParams,
    curves: &[Curve],
    best: Option<&[f64]>,
    rescale: collapse::Rescale<'_>,
    rows: &[(String, f64, f64)],
    note: &str,
    method: &str,
) -> Result<Output> {
    let mut cols: [Vec<f64>; 5] = Default::default();
    if let Some(q) = best {
        for cv in curves {
            for k in 0..cv.x.len() {
                let (x, y, s) = rescale(q, cv, cv.x[k], cv.y[k], cv.sigma[k]);
                for (col, v) in cols.iter_mut().zip([cv.param, cv.x[k], x, y, s]) {
                    col.push(v);
                }
            }
        }
    }
    let [phi, n, x, y, s] = cols;
    let resc = f64_batch(&[
        (p.curve_by.as_str(), phi),
        (p.x.as_str(), n),
        ("X", x),
        ("Y", y),
        ("Y_err", s),
    ])?;
    Ok(Output::single(
        "parquet",
        to_parquet_bytes(
            &[quantity_batch(&[], rows, note, None)?],
            &[(ERROR_METHOD, method)],
        )?,
    )
    .with("rescaled.parquet", to_parquet_bytes(&[resc], &[])?))
}
