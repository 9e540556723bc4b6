//! `fit` and `collapse`: fitted numbers as tables `quantity, value, error, note`
//! (what `compare` reads, schema in [`crate::table::results`]), plus the drawn
//! fit line or the rescaled data.
//!
//! Adapters only: the parameters read, the rows picked from the input tables,
//! the library's fits ([`crate::fit`]) and error estimates
//! ([`crate::fit::uncertainty`]) called, their numbers written as tables.
//!
//! A fit that fails (no divergence found, too few points, curves that do not
//! overlap) does not fail the stage: its quantities are NaN and `note` says why,
//! so the figure is still drawn and `compare` reports the number as missing.

mod collapse;
mod collapse_output;
mod curve_rows;
mod fitting;
mod group;
mod kind;
mod params;
mod pooling;
mod quantities;
mod ranges;
mod rescaled;
mod samples;
#[cfg(test)]
mod tests;

pub use collapse::Collapse;
pub use kind::Fit;
pub use params::{CollapseParams, CurveSpec, FitForm, FitParams, FromQuantity, JACKKNIFE_FILE};

/// Parquet metadata key of a fit table: how its errors were estimated.
pub const ERROR_METHOD: &str = "error_method";
