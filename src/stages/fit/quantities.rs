//! Quantity tables edited after their fit: the groups' tables given one set of
//! columns, and errors replaced.

use std::sync::Arc;

use anyhow::{Context, Result};
use arrow_array::{ArrayRef, Float64Array, RecordBatch};

use crate::table::results::ERROR;

/// The groups' quantity tables with one set of columns: a group whose rows carry
/// no replica samples (other units, a refit impossible) lacks the `value_jkK`
/// columns of the others; they are NaN there.
pub(super) fn same_columns(tables: Vec<RecordBatch>) -> Result<Vec<RecordBatch>> {
    let Some(widest) = tables.iter().max_by_key(|t| t.num_columns()).cloned() else {
        return Ok(tables);
    };
    let schema = widest.schema();
    tables
        .into_iter()
        .map(|t| {
            if t.schema() == schema {
                return Ok(t);
            }
            let cols: Vec<(String, ArrayRef)> = schema
                .fields()
                .iter()
                .map(|f| {
                    let c = t.column_by_name(f.name()).cloned().unwrap_or_else(|| {
                        Arc::new(Float64Array::from(vec![f64::NAN; t.num_rows()])) as ArrayRef
                    });
                    (f.name().clone(), c)
                })
                .collect();
            Ok(RecordBatch::try_from_iter(cols)?)
        })
        .collect()
}

/// `table` with the first `errors.len()` entries of its `error` column replaced.
pub(super) fn with_errors(table: &RecordBatch, errors: &[f64]) -> Result<RecordBatch> {
    let schema = table.schema();
    let (i, _) = schema
        .column_with_name(ERROR)
        .context("a quantity table has an `error` column")?;
    let old = table
        .column(i)
        .as_any()
        .downcast_ref::<Float64Array>()
        .context("`error` is a float column")?;
    let new: Vec<f64> = (0..old.len())
        .map(|k| errors.get(k).copied().unwrap_or(old.value(k)))
        .collect();
    let mut cols = table.columns().to_vec();
    cols[i] = Arc::new(Float64Array::from(new));
    Ok(RecordBatch::try_new(schema, cols)?)
}
