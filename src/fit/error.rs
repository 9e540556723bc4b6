//! Why a fit failed, with the form's name and what to try.

use thiserror::Error;

/// A fit that could not produce trustworthy parameters.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    /// The data or options are malformed (NaN, sigma <= 0, length mismatch, ...).
    #[error("{form} fit: invalid input: {what}")]
    InvalidInput { form: String, what: String },

    /// Fewer data points than free parameters + 1.
    #[error(
        "{form} fit: {points} data points for {free} free parameters; need at least {needed} \
         (widen the fit range or fix a parameter)"
    )]
    TooFewPoints {
        form: String,
        points: usize,
        free: usize,
        needed: usize,
    },

    /// The minimiser stopped before meeting its tolerances.
    #[error("{form} fit did not converge after {iterations} iterations: {hint}")]
    NotConverged {
        form: String,
        iterations: usize,
        hint: String,
    },

    /// J^T J is singular: some parameter (combination) is not determined by the data.
    #[error(
        "{form} fit is ill-conditioned: parameter `{parameter}` is not determined by the data ({hint})"
    )]
    IllConditioned {
        form: String,
        parameter: String,
        hint: String,
    },

    /// A parameter ended on one of its bounds, so its error bar is meaningless.
    #[error("{form} fit: parameter `{parameter}` = {value} ended on its bound {bound}: {hint}")]
    AtBound {
        form: String,
        parameter: String,
        value: f64,
        bound: f64,
        hint: String,
    },

    /// The fit ran but its result cannot be trusted for a stated physical reason.
    #[error("{form} fit is unreliable: {reason}")]
    Unreliable { form: String, reason: String },
}

impl FitError {
    pub(crate) fn invalid(form: &str, what: impl Into<String>) -> Self {
        FitError::InvalidInput {
            form: form.to_string(),
            what: what.into(),
        }
    }

    pub(crate) fn unreliable(form: &str, reason: impl Into<String>) -> Self {
        FitError::Unreliable {
            form: form.to_string(),
            reason: reason.into(),
        }
    }
}
