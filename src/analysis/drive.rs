//! The drive of a run as the analyses read it (eps, gamma, T): the analysis
//! stage takes it from the runs it analyses and hands it to the observables
//! that need it (paper I, Eq. 7). A module of its own so that the stage's
//! plumbing reaches no observable's code.

use serde::Deserialize;

/// eps, gamma and T of the simulation, for Eq. (7) of paper I.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DriveParams {
    pub eps: f64,
    pub gamma: f64,
    pub temperature: f64,
}
