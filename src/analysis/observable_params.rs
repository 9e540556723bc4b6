//! An observable's parameters as one typed value ([`ObservableParams`]): parsed
//! once from a stage's `params` ([`super::observables::Observable::parse`]) and
//! handed typed to its computation. What the analysis stage learns elsewhere,
//! the lags that `at:` chooses and the drive of the runs, it sets through the
//! setters here, never by editing the parameters as JSON.

use std::any::Any;

use anyhow::Result;

use super::drive::DriveParams;
use super::intruder;
use super::{chi4, clusters, front, gr, msd, order, overlap, s4, van_hove};
use crate::pipeline::canon::param_error;

/// The parsed parameters of an observable.
pub trait ObservableParams: Any + Send + Sync + std::fmt::Debug + BoxedClone {
    /// Its lags, for an observable computed at lags (which `at:` can choose);
    /// `None` for the others.
    fn lags(&mut self) -> Option<Lags<'_>> {
        None
    }
    /// Compute at these lags (those `at:` chose). The parse refuses `at:` for an
    /// observable not computed at lags ([`LagsFrom::At`]), which ignores them.
    fn set_lags(&mut self, lags: Vec<f64>) {
        match self.lags() {
            Some(Lags::Optional { lags: l, .. }) => *l = Some(lags),
            Some(Lags::Required { lags: l, .. }) => *l = lags,
            None => {}
        }
    }
    /// What the types cannot check, once after the parse (`kind` names the
    /// observable in the error).
    fn check(&self, _kind: &str) -> Result<()> {
        Ok(())
    }
    /// The drive the parameters give (`drive`, `kick_rate_factor`), for an
    /// observable that reads the drive of its runs.
    fn drive(&self) -> (Option<&DriveParams>, Option<f64>) {
        (None, None)
    }
    /// Read this drive (the runs' own: the analysis stage takes it from them);
    /// an observable that reads no drive ignores it.
    fn set_drive(&mut self, _drive: DriveParams, _kick_rate_factor: Option<f64>) {}
}

/// A copy behind the box, for every parameters type that is `Clone`.
pub trait BoxedClone {
    fn boxed(&self) -> Box<dyn ObservableParams>;
}

impl<T: ObservableParams + Clone> BoxedClone for T {
    fn boxed(&self) -> Box<dyn ObservableParams> {
        Box::new(self.clone())
    }
}

impl Clone for Box<dyn ObservableParams> {
    fn clone(&self) -> Self {
        (**self).boxed()
    }
}

/// The lags of an observable computed at lags, as its parameters hold them, with
/// the relative tolerance matching a lag to frame time differences.
pub enum Lags<'a> {
    /// Every lag the trajectories record unless given.
    Optional {
        lags: &'a mut Option<Vec<f64>>,
        rel_tol: f64,
    },
    /// Always given: in the parameters, or chosen by `at:`.
    Required {
        lags: &'a mut Vec<f64>,
        rel_tol: f64,
    },
}

impl Lags<'_> {
    pub fn rel_tol(&self) -> f64 {
        match self {
            Lags::Optional { rel_tol, .. } | Lags::Required { rel_tol, .. } => *rel_tol,
        }
    }

    /// Whether the parameters give lags.
    fn given(&self) -> bool {
        match self {
            Lags::Optional { lags, .. } => lags.is_some(),
            Lags::Required { lags, .. } => !lags.is_empty(),
        }
    }
}

/// Where the lags of an observable computed at lags come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LagsFrom {
    /// Its parameters (`lags`; every recorded lag where they may be left out).
    Params,
    /// The analysis stage's `at:`, after the parse
    /// ([`ObservableParams::set_lags`]): the parameters must not give them.
    At,
}

/// The checks of the parsed parameters `p` of observable `kind` that their type
/// cannot make: its own ([`ObservableParams::check`]) and where its lags come from.
pub(super) fn checked(kind: &str, p: &mut dyn ObservableParams, from: LagsFrom) -> Result<()> {
    p.check(kind)?;
    match (from, p.lags()) {
        (LagsFrom::At, None) => Err(param_error(
            &["at"],
            format!(
                "parameters of analysis `{kind}`: `at` chooses the lags, and `{kind}` is not computed at lags; leave `at` out"
            ),
        )),
        (LagsFrom::At, Some(l)) if l.given() => Err(param_error(
            &["lags"],
            format!(
                "parameters of analysis `{kind}`: give `at` or `lags`, not both (`at` sets the lags)"
            ),
        )),
        // Required lags may be left out of the type only because `at:` can set them.
        (LagsFrom::Params, Some(l @ Lags::Required { .. })) if !l.given() => Err(param_error(
            &[],
            format!(
                "invalid parameters for stage kind '{kind}': missing field `lags` (at least one lag)"
            ),
        )),
        _ => Ok(()),
    }
}

/// Parameters computed at lags, from their fields `lags` and `rel_tol`.
macro_rules! computed_at_lags {
    ($variant:ident: $($t:ty),+) => {$(
        impl ObservableParams for $t {
            fn lags(&mut self) -> Option<Lags<'_>> {
                Some(Lags::$variant { lags: &mut self.lags, rel_tol: self.rel_tol })
            }
        }
    )+};
}

computed_at_lags!(
    Optional: overlap::Params, overlap::LevelParams, msd::Params, msd::DiffusionParams
);
computed_at_lags!(Required: s4::Params, clusters::Params, van_hove::Params);

impl ObservableParams for chi4::Params {
    fn lags(&mut self) -> Option<Lags<'_>> {
        Some(Lags::Optional {
            lags: &mut self.lags,
            rel_tol: self.rel_tol,
        })
    }
    fn check(&self, kind: &str) -> Result<()> {
        if self.n.is_empty() && self.fractions.is_empty() {
            anyhow::bail!(
                "parameters of analysis `{kind}`: no sub-box size; give `n` (particle numbers, e.g. n: [100, 400]) or `fractions` (of the box, e.g. fractions: [0.25, 1])"
            );
        }
        if let Some(f) = self.fractions.iter().find(|f| !(**f > 0.0 && **f <= 1.0)) {
            anyhow::bail!(
                "parameters of analysis `{kind}`: `fractions` holds {f}, not a fraction of the box in (0, 1]"
            );
        }
        Ok(())
    }
}

impl ObservableParams for intruder::VelocityParams {
    fn drive(&self) -> (Option<&DriveParams>, Option<f64>) {
        (self.drive.as_ref(), self.kick_rate_factor)
    }
    fn set_drive(&mut self, drive: DriveParams, kick_rate_factor: Option<f64>) {
        self.drive = Some(drive);
        self.kick_rate_factor = kick_rate_factor;
    }
}

impl ObservableParams for gr::Params {}
impl ObservableParams for order::Params {}
impl ObservableParams for intruder::ProfileParams {}
impl ObservableParams for intruder::DiffusionParams {}
impl ObservableParams for front::FieldParams {}
impl ObservableParams for front::FrontParams {}
