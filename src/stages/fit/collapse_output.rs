//! What a collapse writes: its quantity table and the curves rescaled at the
//! best parameters, one block of rows per group of `group_by`.

use anyhow::Result;
use arrow_array::RecordBatch;

use super::ERROR_METHOD;
use super::params::CollapseParams;
use crate::fit::collapse::{self, Curve};
use crate::pipeline::Output;
use crate::table::results::{led_by_group, quantity_batch};
use crate::table::{f64_batch, to_parquet_bytes};

/// One group's collapse: its quantity rows, its rescaled curves and how its
/// errors were taken.
pub(super) struct CollapseParts {
    quantities: RecordBatch,
    rescaled: RecordBatch,
    method: String,
}

/// What one collapse found: its quantity rows, its note (why it failed, or
/// empty), the parameters its curves are rescaled with (none when it failed)
/// and how its errors were taken.
pub(super) struct Collapsed {
    pub(super) rows: Vec<(String, f64, f64)>,
    pub(super) note: String,
    pub(super) best: Option<Vec<f64>>,
    pub(super) method: String,
}

/// A group's outputs: the quantity table and the curves rescaled at the best
/// parameters (none when the collapse failed), each led by the group's
/// `group_by` columns.
pub(super) fn collapse_output(
    p: &CollapseParams,
    curves: &[Curve],
    rescale: collapse::Rescale<'_>,
    found: &Collapsed,
    group: &[(String, f64)],
) -> Result<CollapseParts> {
    let mut cols: [Vec<f64>; 5] = Default::default();
    if let Some(q) = found.best.as_deref() {
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
    for from in p.rename.keys() {
        if !found.rows.iter().any(|r| &r.0 == from) {
            anyhow::bail!(
                "collapse: `rename` names '{from}', which this collapse does not report (it reports {})",
                found
                    .rows
                    .iter()
                    .map(|r| r.0.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let rows: Vec<(String, f64, f64)> = found
        .rows
        .iter()
        .map(|(n, v, e)| (p.rename.get(n).unwrap_or(n).clone(), *v, *e))
        .collect();
    Ok(CollapseParts {
        quantities: quantity_batch(group, &rows, &found.note, None)?,
        rescaled: led_by_group(group, &resc)?,
        method: found.method.clone(),
    })
}

/// The stage's files from its groups, in the groups' order; the error method
/// is each distinct one once.
pub(super) fn collapse_files(parts: Vec<CollapseParts>) -> Result<Output> {
    let mut methods: Vec<&str> = Vec::new();
    for p in &parts {
        if !methods.contains(&p.method.as_str()) {
            methods.push(&p.method);
        }
    }
    let method = methods.join("; ");
    let q: Vec<RecordBatch> = parts.iter().map(|p| p.quantities.clone()).collect();
    let r: Vec<RecordBatch> = parts.iter().map(|p| p.rescaled.clone()).collect();
    Ok(
        Output::single("parquet", to_parquet_bytes(&q, &[(ERROR_METHOD, &method)])?)
            .with("rescaled.parquet", to_parquet_bytes(&r, &[])?),
    )
}
