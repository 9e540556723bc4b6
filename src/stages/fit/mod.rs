//! `fit` and `collapse`: fitted numbers as tables `quantity, value, error, note`
//! (what `compare` reads, schema in [`crate::table::results`]), plus the drawn
//! fit line or the rescaled data.
//!
//! A fit that fails (no divergence found, too few points, curves that do not
//! overlap) does not fail the stage: its quantities are NaN and `note` says why,
//! so the figure is still drawn and `compare` reports the number as missing.

mod collapse;
mod fitting;
mod group;
mod jackknife;
mod kind;
mod leverage;
mod params;
mod pooling;
mod quantities;
mod ranges;
mod rescaled;
#[cfg(test)]
mod tests;

pub use collapse::{Collapse, CollapseParams};
pub use kind::Fit;
pub use params::{CurveSpec, FitForm, FitParams, FromQuantity, JACKKNIFE_FILE};

const MODULES: &[&str] = &[
    "fit",
    "table",
    "stages/fit",
    "stages/tables",
    "analysis/pool",
];

/// Parquet metadata key of a fit table: how its errors were estimated.
pub const ERROR_METHOD: &str = "error_method";
