//! The outcome of a fit, and the data it is fitted to.

use serde::Serialize;

use super::FitError;

/// How a warning that makes the fitted numbers untrustworthy starts (the
/// `compare` stage turns it into the verdict `unreliable`).
pub const UNRELIABLE: &str = "unreliable: ";

/// Data to fit: abscissae, ordinates and the 1-sigma errors of the ordinates.
#[derive(Debug, Clone, Copy)]
pub struct Data<'a> {
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub sigma: &'a [f64],
}

impl<'a> Data<'a> {
    pub fn new(x: &'a [f64], y: &'a [f64], sigma: &'a [f64]) -> Self {
        Data { x, y, sigma }
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Checks lengths, finiteness and positive errors, and that there are at
    /// least `free + 1` points (one degree of freedom for chi-square).
    pub fn validate(&self, form: &str, free: usize) -> Result<(), FitError> {
        let n = self.x.len();
        if self.y.len() != n || self.sigma.len() != n {
            return Err(FitError::invalid(
                form,
                format!(
                    "x, y and sigma must have equal lengths, got {}, {} and {}",
                    n,
                    self.y.len(),
                    self.sigma.len()
                ),
            ));
        }
        for i in 0..n {
            let (x, y, s) = (self.x[i], self.y[i], self.sigma[i]);
            if !x.is_finite() || !y.is_finite() {
                return Err(FitError::invalid(
                    form,
                    format!("point {i} is not finite (x = {x}, y = {y})"),
                ));
            }
            if !(positive(s) && s.is_finite()) {
                return Err(FitError::invalid(
                    form,
                    format!("sigma[{i}] = {s}; errors must be finite and > 0"),
                ));
            }
        }
        if n < free + 1 {
            return Err(FitError::TooFewPoints {
                form: form.to_string(),
                points: n,
                free,
                needed: free + 1,
            });
        }
        Ok(())
    }

    /// The points with `lo <= x <= hi`.
    pub fn window(&self, lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut out = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..self.x.len() {
            if self.x[i] >= lo && self.x[i] <= hi {
                out.0.push(self.x[i]);
                out.1.push(self.y[i]);
                out.2.push(self.sigma[i]);
            }
        }
        out
    }
}

/// True for finite-or-infinite v > 0; false for NaN (unlike `!(v <= 0.0)`).
pub(crate) fn positive(v: f64) -> bool {
    v > 0.0
}

/// Fails naming the first entry of `values` that is not > 0 (NaN included).
pub(crate) fn require_positive(form: &str, what: &str, values: &[f64]) -> Result<(), FitError> {
    match values.iter().position(|&v| !positive(v)) {
        Some(i) => Err(FitError::invalid(
            form,
            format!("{what}[{i}] = {} must be > 0 for this form", values[i]),
        )),
        None => Ok(()),
    }
}

/// Fitted parameters with 1-sigma standard errors and covariance.
///
/// Fixed parameters keep their value, with zero error and zero covariance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitResult {
    /// Which form was fitted (e.g. "power_law_offset").
    pub form: String,
    pub names: Vec<String>,
    pub params: Vec<f64>,
    pub stderr: Vec<f64>,
    pub covariance: Vec<Vec<f64>>,
    pub fixed: Vec<bool>,
    pub chi2: f64,
    pub dof: usize,
    pub reduced_chi2: f64,
    pub converged: bool,
    pub iterations: usize,
    /// True when the errors were multiplied by sqrt(reduced chi2) (data errors unknown).
    pub errors_scaled: bool,
    /// Reasons to distrust an otherwise successful fit (empty when none), e.g.
    /// a singular point within 3 sigma of the last data point.
    pub warnings: Vec<String>,
}

impl FitResult {
    /// Index of a parameter by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// (value, standard error) of a parameter by name.
    pub fn get(&self, name: &str) -> Option<(f64, f64)> {
        self.index(name).map(|i| (self.params[i], self.stderr[i]))
    }

    /// (value, standard error) by name; panics on an unknown name (a programming error).
    pub fn expect(&self, name: &str) -> (f64, f64) {
        self.get(name).unwrap_or_else(|| {
            panic!(
                "fit {} has no parameter `{name}` (has {:?})",
                self.form, self.names
            )
        })
    }

    /// Value of a parameter by name; panics on an unknown name.
    pub fn value(&self, name: &str) -> f64 {
        self.expect(name).0
    }

    /// Standard error of a parameter by name; panics on an unknown name.
    pub fn error(&self, name: &str) -> f64 {
        self.expect(name).1
    }
}
