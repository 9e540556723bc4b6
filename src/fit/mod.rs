//! Weighted least-squares fits with uncertainties, and the fit forms the papers use.
//!
//! Everything here works on plain numbers: x, y and the 1-sigma error of y.
//! - [`least_squares`]: general nonlinear weighted fit (Levenberg-Marquardt via
//!   MPFIT/`rmpfit`), with bounds and fixed parameters; covariance from J^T J.
//! - [`linear`]: weighted linear least squares (straight line, any basis).
//! - [`forms`]: the named forms of papers H and I (power law with offset, VFT,
//!   Q(t) of Eq. 8, Ornstein-Zernike Eq. 18/20, Gaussian and exponential tails,
//!   log-normal Eq. 13, plain power laws).
//! - [`collapse`]: scaling exponents by minimising the spread of rescaled curves.
//! - [`rescalings`]: the named rescalings of a collapse (Figs. 13, 14 of paper H).
//! - [`ranges`]: the same fit over several ranges, with the spread of the results.
//! - [`uncertainty`]: errors beyond the covariance: replica jackknife, model
//!   scatter, leverage, pooled scales.
//! - [`stability`]: coverage of every form's errors on synthetic data, and the bias of a
//!   divergence fitted close to the data.
//!
//! Every fit returns a [`FitResult`] or a [`FitError`] that names the form, the
//! problem and what to try; never NaN.

pub mod catalogue;
pub mod collapse;
mod error;
pub mod forms;
mod least_squares;
pub(crate) mod linalg;
pub mod linear;
pub mod ranges;
pub mod rescalings;
mod result;
pub mod runs;
pub mod stability;
pub mod uncertainty;

pub use error::FitError;
pub use least_squares::{FitOptions, least_squares};
pub use result::{Data, FitResult};
