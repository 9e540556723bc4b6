//! What `fit` and `collapse` stages are told: the typed parameters, the form
//! among a closed set, and the numbers they take from other fits.

use std::collections::BTreeMap;
use std::fmt;

use anyhow::Result;
use serde::{Deserialize, Deserializer};

use crate::analysis::pool;
use crate::fit::catalogue::{self, Form};
use crate::fit::uncertainty::replicas::{Refits, TakenFrom};
use crate::pipeline::Artifact;
use crate::stages::tables::{Columns, Where, inputs_of};
use crate::table::results::{QUANTITY, REPLICA, VALUE};

/// A number taken from another fit table of the same stage's inputs.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FromQuantity {
    pub stage: String,
    pub quantity: String,
}

impl FromQuantity {
    /// The number's value and quoted error.
    pub(super) fn get(&self, kind: &str, inputs: &[Artifact]) -> Result<(f64, f64)> {
        let c = Columns::read(&inputs_of(kind, inputs, &self.stage)?)?;
        c.quantity(&self.quantity)
    }

    /// Where its own fit marks the number unreliable (a phi_c on its last
    /// point), the note every number fitted with it as `param` inherits.
    pub(super) fn inherited_unreliable(
        &self,
        param: &str,
        kind: &str,
        inputs: &[Artifact],
    ) -> Result<Option<String>> {
        let c = Columns::read(&inputs_of(kind, inputs, &self.stage)?)?;
        let (Some(q), Some(n)) = (c.str.get(QUANTITY), c.str.get(crate::table::results::NOTE))
        else {
            return Ok(None);
        };
        Ok((0..q.len())
            .find(|&i| q[i] == self.quantity && n[i].contains("unreliable"))
            .map(|i| {
                let why = n[i].trim_start_matches("unreliable:").trim();
                format!(
                    "unreliable: {param} is {} of {}, itself unreliable ({why})",
                    self.quantity, self.stage
                )
            }))
    }

    /// The number's replica jackknife refits (`jackknife.parquet` of its fit), if
    /// it has them: its value with each replica of each unit left out.
    pub(super) fn jackknife(&self, kind: &str, inputs: &[Artifact]) -> Result<Option<Refits>> {
        let arts = inputs_of(kind, inputs, &self.stage)?;
        if arts.iter().any(|a| !a.files.contains_key(JACKKNIFE_FILE)) {
            return Ok(None);
        }
        let c = Columns::read_file(&arts, JACKKNIFE_FILE)?;
        let Some(q) = c.str.get(QUANTITY) else {
            return Ok(None);
        };
        let (unit, replica, value) = (c.col(pool::JK_UNIT)?, c.col(REPLICA)?, c.col(VALUE)?);
        let refits: Refits = (0..c.rows)
            .filter(|&i| q[i] == self.quantity)
            .map(|i| ((unit[i].to_bits(), replica[i] as usize), value[i]))
            .collect();
        Ok((!refits.is_empty()).then_some(refits))
    }
}

/// File of a fit's replica jackknife refits: `jk_unit`, `replica` (the one left
/// out), `quantity`, `value` (and the group's columns); a fit that takes one of
/// its numbers (`fixed_from`) refits with the same replica left out.
pub const JACKKNIFE_FILE: &str = "jackknife.parquet";

/// Where the fitted line is drawn.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    #[serde(default)]
    pub x_min: Option<f64>,
    #[serde(default)]
    pub x_max: Option<f64>,
    #[serde(default = "default_points")]
    pub points: usize,
}

fn default_file() -> String {
    "parquet".into()
}

fn default_points() -> usize {
    200
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FitParams {
    /// A form of the catalogue (`power_law_offset`, `vft`, `power_law`, `line`,
    /// ...), `drift` or `value`.
    pub form: FitForm,
    /// Stage whose table holds the data; may be left out when every input comes
    /// from one stage (`gather: [tau_table]`).
    #[serde(default)]
    pub data: Option<String>,
    /// Which of its files (default `parquet`).
    #[serde(default = "default_file")]
    pub file: String,
    pub x: String,
    pub y: String,
    /// Column of 1-sigma errors of y; without it the errors are scaled to the scatter.
    #[serde(default)]
    pub y_err: Option<String>,
    /// Column of 1-sigma errors of x (a named form, with `y_err`): each y error
    /// is widened in quadrature by the model's slope times it, the slope taken
    /// from the fit and the fit repeated (effective variance,
    /// `fit::uncertainty::x_errors`).
    #[serde(default)]
    pub x_err: Option<String>,
    #[serde(default, rename = "where")]
    pub filter: Where,
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    #[serde(default)]
    pub fixed_from: BTreeMap<String, FromQuantity>,
    /// Parameters held, in each group, at the group's own y where x equals the
    /// given value (a row the `where` filter may leave out of the fit): paper H's
    /// OZ fit with chi0 = chi4(tau_alpha), S4 at q = 0 (`{chi0: 0}`).
    #[serde(default)]
    pub fixed_at_x: BTreeMap<String, f64>,
    /// Quantity names for the parameters (default: the form's own names).
    #[serde(default)]
    pub rename: BTreeMap<String, String>,
    #[serde(default)]
    pub curve: Option<CurveSpec>,
    /// One fit per distinct value of these columns (e.g. `[phi]`), each a row
    /// group of the output with these columns; a column `t` among them is also the
    /// lag of a `gaussian` fit.
    #[serde(default)]
    pub group_by: Vec<String>,
    /// Range scan (paper H, Appendix, Fig. 25): the same fit again over each
    /// window `[x_min, x_max]` of x; `ranges.parquet` holds every window's fit and
    /// the main table gains `<parameter>_range_std`, its spread between windows.
    #[serde(default)]
    pub ranges: Vec<(f64, f64)>,
    /// `relative`: where the model does not describe the points within their
    /// errors (reduced chi^2 > 1, e.g. curves of several eta that collapse only
    /// roughly), a relative model scatter s_m |y| is added in quadrature to every
    /// point's error, s_m chosen so that the reduced chi^2 is 1. Without it the
    /// few points with the smallest errors set the fit, and which points those
    /// are changes from seed to seed. The table gains `scatter` (s_m); its
    /// `reduced_chi2` stays that of the errors alone.
    #[serde(default)]
    pub scatter: Option<String>,
}

impl FitParams {
    /// The quantity name of parameter `n` (`rename`, else its own name).
    pub(super) fn quantity_name(&self, n: &str) -> String {
        self.rename.get(n).cloned().unwrap_or_else(|| n.to_string())
    }

    /// The numbers taken from other fits, as the account of the error method
    /// names them.
    pub(super) fn taken(&self) -> Vec<TakenFrom> {
        self.fixed_from
            .iter()
            .map(|(param, f)| TakenFrom {
                param: param.clone(),
                what: format!("{} of {}", f.quantity, f.stage),
            })
            .collect()
    }

    /// The name of the fit's largest leverage: named as its `points` is
    /// (`points_tau4` -> `leverage_tau4`), so two fits of one figure keep theirs
    /// apart.
    pub(super) fn leverage_name(&self) -> String {
        let points = self.quantity_name("points");
        if points.contains("points") {
            points.replacen("points", "leverage", 1)
        } else {
            format!("leverage_{points}")
        }
    }
}

/// What a fit fits, named in YAML as a catalogue form's name, `drift` or `value`.
#[derive(Clone, Copy)]
pub enum FitForm {
    /// A named form of [`crate::fit::catalogue`].
    Named(&'static Form),
    /// A line whose slope is reported as the relative change of y over the x range.
    Drift,
    /// No fit: the mean of y over the selected rows (e.g. tau_alpha at one phi).
    Value,
}

impl FitForm {
    /// The form of a YAML name.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "drift" => Ok(FitForm::Drift),
            "value" => Ok(FitForm::Value),
            f => catalogue::find(f).map(FitForm::Named),
        }
    }

    /// Its YAML name.
    pub fn name(&self) -> &'static str {
        match self {
            FitForm::Named(f) => f.name,
            FitForm::Drift => "drift",
            FitForm::Value => "value",
        }
    }

    /// The catalogue form; None for `drift` (a line) and `value` (no fit).
    pub fn named(&self) -> Option<&'static Form> {
        match self {
            FitForm::Named(f) => Some(f),
            FitForm::Drift | FitForm::Value => None,
        }
    }

    /// The names of the numbers a fit of this form reports, before `rename`.
    pub(super) fn params(&self) -> &'static [&'static str] {
        match self {
            FitForm::Named(f) => f.params,
            FitForm::Drift => &["drift"],
            FitForm::Value => &["intercept", "slope"],
        }
    }
}

impl fmt::Debug for FitForm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl PartialEq for FitForm {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

impl<'de> Deserialize<'de> for FitForm {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        FitForm::parse(&name).map_err(serde::de::Error::custom)
    }
}

/// The relative change of y across the x range from the slope `b` of a line:
/// the range of x and the mean of y, by which `b` is scaled.
pub(super) fn drift_scale(x: &[f64], y: &[f64]) -> (f64, f64) {
    let span = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - x.iter().cloned().fold(f64::INFINITY, f64::min);
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    (span, mean)
}

/// `collapse`: finite-size scaling of Fig. 19. Curves y(x) labelled by `curve_by`
/// (phi) rescale as X = sqrt(x)/xi, Y = y xi^-g with xi = (phi_c - phi)^-gamma_xi;
/// g = gamma_chi/gamma_xi and gamma_xi are fitted, phi_c is given or taken from a fit.
/// With `xi: COLUMN` the measured xi of each curve is used and only g is fitted.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CollapseParams {
    pub data: String,
    pub x: String,
    pub y: String,
    pub y_err: String,
    pub curve_by: String,
    #[serde(default, rename = "where")]
    pub filter: Where,
    #[serde(default)]
    pub phi_c: Option<f64>,
    #[serde(default)]
    pub phi_c_from: Option<FromQuantity>,
    /// Column of the data holding a measured xi per curve (e.g. the OZ xi joined
    /// in): then xi is not a power law of phi, and only `g` is fitted.
    #[serde(default)]
    pub xi: Option<String>,
    /// With `xi`: hold g at a number another fit reports (paper H, Fig. 19 and
    /// 24: the exponents come from the independent fits, and the collapse tests
    /// them) instead of fitting it; `bounds` then stays empty.
    #[serde(default)]
    pub g_from: Option<FromQuantity>,
    /// Search ranges of `g` and `gamma_xi` (only `g` with `xi`), or of the
    /// `rescaling`'s fitted parameters.
    #[serde(default)]
    pub bounds: BTreeMap<String, (f64, f64)>,
    /// One collapse per distinct value of these columns (e.g. `[n]`, the total
    /// N of a convergence sweep), each a row group of both outputs with these
    /// columns; `g_from` then takes the row of its group where the source
    /// table has these columns.
    #[serde(default)]
    pub group_by: Vec<String>,
    /// A named rescaling of [`crate::fit::rescalings`] instead of Fig. 19's
    /// finite-size scaling (e.g. `cluster_cutoff`, `log_normal`).
    #[serde(default)]
    pub rescaling: Option<String>,
    /// Quantity names of the table (`{rho: rho_held}`), so that a figure can
    /// compare two collapses of one rescaling (phi_c fitted and held).
    #[serde(default)]
    pub rename: BTreeMap<String, String>,
}
