//! How a fit's errors are estimated beyond its covariance: the statistics the
//! `fit` and `collapse` stages apply to every fit they make.
//!
//! - [`scatter`]: the points cleaned for a fit, and a relative model scatter
//!   that brings the reduced chi^2 to 1 where the model does not describe the
//!   points within their errors.
//! - [`replicas`]: the delete-one jackknife over replicas (independent runs of
//!   one state point): refits with each replica of each unit left out, numbers
//!   taken from other fits refitted on the same replicas, objects of several
//!   replicas, and the account of the method.
//! - [`pooling`]: fits on one state point each, their jackknife scale pooled.
//! - [`held`]: the share of a number held at another fit's value, from
//!   refits at that value plus and minus its error.
//! - [`leverage`]: a fit one point carries, and an error at least the
//!   delete-one-point jackknife's when it does.
//! - [`x_errors`]: errors in x carried into y's by the model's slope
//!   (effective variance).
//!
//! Everything works on plain numbers and on a `refit` closure; reading and
//! writing tables is the stages' business.

pub mod held;
pub mod leverage;
pub mod pooling;
pub mod replicas;
pub mod scatter;
pub mod x_errors;
