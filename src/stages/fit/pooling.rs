//! Errors of fits on one state point each, pooled over a stage's fits
//! ([`crate::fit::uncertainty::pooling`]) and written into their tables.

use anyhow::Result;

use super::group::Group;
use super::quantities::with_errors;
use crate::fit::uncertainty::pooling::{pooled_errors, pooled_method};

/// The groups whose fit was on one state point with a replica jackknife quote
/// the pooled errors. Returns the method line, if any fit took part.
pub(super) fn pool_one_unit_errors(groups: &mut [Group]) -> Result<Option<String>> {
    let with: Vec<usize> = (0..groups.len())
        .filter(|&g| groups[g].pooled.is_some())
        .collect();
    if with.is_empty() {
        return Ok(None);
    }
    let pairs: Vec<Vec<(f64, f64)>> = with
        .iter()
        .map(|&g| groups[g].pooled.take().unwrap_or_default())
        .collect();
    for (&g, errors) in with.iter().zip(pooled_errors(&pairs)) {
        groups[g].table = with_errors(&groups[g].table, &errors)?;
    }
    Ok(Some(pooled_method(with.len())))
}
