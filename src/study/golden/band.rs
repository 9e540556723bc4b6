//! One golden band: the values of a key number over the recorded master seeds,
//! their mean, spread and band, and how the band gates the number.

use serde::{Deserialize, Serialize};

/// Golden values of one quantity of one figure.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Golden {
    pub figure: String,
    pub quantity: String,
    pub seeds: Vec<u64>,
    /// Per seed; a seed whose fit gave no number is NaN, written as `null`.
    #[serde(with = "crate::study::results::nan_as_null")]
    pub values: Vec<f64>,
    /// The 1-sigma error each seed's figure quoted for its value (what the
    /// coverage test checks against the seed-to-seed scatter); empty in goldens
    /// recorded without them.
    #[serde(default, with = "crate::study::results::nan_as_null")]
    pub errors: Vec<f64>,
    pub mean: f64,
    pub std: f64,
    pub band: [f64; 2],
    /// How the band gates the number.
    #[serde(default)]
    pub gate: Gate,
    /// The figure's compare verdict was `agree` at every recorded seed: turning
    /// `disagree` is a regression.
    #[serde(default)]
    pub always_agree: bool,
}

/// How a golden band gates its number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Gate {
    /// The value must lie in the band.
    #[default]
    Band,
    /// Smaller is better (a drift, a precision): |value| at most the band's top.
    AtMost,
    /// A gap: at least 0 (disks never overlap) and at most the band's top.
    NonNegative,
    /// Its band would be wider than the value itself, so it could not fail: the
    /// number counts in the joint test only.
    JointOnly,
}

impl std::fmt::Display for Gate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Gate::Band => "band",
            Gate::AtMost => "one-sided (at most)",
            Gate::NonNegative => "one-sided (gap)",
            Gate::JointOnly => "joint only",
        })
    }
}

impl Gate {
    /// Whether `v` passes (NaN never does, except in the joint test only).
    pub fn passes(self, v: f64, band: [f64; 2]) -> bool {
        match self {
            Gate::Band => v >= band[0] && v <= band[1],
            Gate::AtMost => v.abs() <= band[1],
            Gate::NonNegative => v >= 0.0 && v <= band[1],
            Gate::JointOnly => true,
        }
    }

    /// The gate of a quantity, by what it measures: drifts and precision are
    /// better smaller, a closest gap must not be negative.
    pub(super) fn of(quantity: &str) -> Gate {
        if quantity.starts_with("closest_gap") {
            Gate::NonNegative
        } else if quantity.contains("drift") || quantity.contains("precision") {
            Gate::AtMost
        } else {
            Gate::Band
        }
    }
}
