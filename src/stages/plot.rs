//! `plot`: a [`crate::plot::Figure`] whose series come from the gathered tables.
//!
//! Each panel lists `layers`; a layer reads one stage's table (or another of its
//! Parquet files, e.g. a fit's `curve.parquet`), keeps the rows passing `where`,
//! and draws column `y` against `x`, one series per distinct value of `group`
//! (e.g. one curve per phi) or a single series.

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use serde_json::Value;

use super::tables::{Columns, Where, inputs_of};
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::plot::{
    Axis, Color, Figure, Group, Legend, Marker, Palette, Panel, RefLine, Series, Style,
};
use crate::table::references::{Lookup, Reference, Resolved, Target, legend_number, render};

pub use super::verdict_line::{Against, SHORT_CHARS};
use super::verdict_line::{provenance, verdict_line};

/// The values a plot's texts name: its gathered tables and its build (the
/// profile and the experiments upstream). Only this build: a figure is a
/// function of its cache key, which no other figure or profile enters.
struct PlotLookup<'a> {
    inputs: &'a [Artifact],
    build: &'a BuildInfo,
}

impl Lookup for PlotLookup<'_> {
    fn resolve(&self, r: &Reference) -> Result<Resolved> {
        // `{=ci:...}` in a ci build is this build.
        let own_profile = r.profile.as_deref().is_none_or(|p| p == self.build.profile);
        if !(own_profile && r.figure.is_none()) {
            anyhow::bail!(
                "a plot's text references only its own build (a stage it gathers, `profile`, an experiment upstream): state a number of another figure or profile in a compare reason or `error_coverage`"
            );
        }
        let Target::Field { name, field, row } = &r.target else {
            return Ok(Resolved::Text(self.build.profile.clone()));
        };
        if row.is_empty()
            && let Some(v) = (self.build.experiments.get(name))
                .or_else(|| {
                    field
                        .starts_with("where_")
                        .then(|| self.build.windows.get(name))
                        .flatten()
                })
                .and_then(|e| e.get(field))
        {
            return Ok(Resolved::Param(v.clone()));
        }
        let c = Columns::read(&inputs_of("plot", self.inputs, name)?)?;
        let (value, error) = c.value_of(field, row)?;
        Ok(Resolved::Number { value, error })
    }
}

/// A title, legend entry or note with its references resolved
/// ([`crate::table::references`]).
fn fill(text: &str, inputs: &[Artifact], build: &BuildInfo) -> Result<String> {
    render(text, &PlotLookup { inputs, build }).context("plot")
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layer {
    /// Stage whose table is drawn.
    pub from: String,
    /// Which of its files (default `parquet`; e.g. `curve.parquet`).
    #[serde(default = "default_file")]
    pub file: String,
    pub x: String,
    pub y: String,
    #[serde(default)]
    pub y_err: Option<String>,
    /// One series per distinct value of this column, labelled by the value.
    #[serde(default)]
    pub group: Option<String>,
    /// The group value of every row, for a table without the group column
    /// (one ensemble's own table, e.g. eps = 0.9): drawn in that value's colour.
    #[serde(default)]
    pub at: Option<f64>,
    #[serde(default, rename = "where")]
    pub filter: Where,
    /// Legend entry of an ungrouped series; prefix of grouped labels.
    #[serde(default)]
    pub label: String,
    #[serde(default)]
    pub style: Style,
    #[serde(default)]
    pub dashed: bool,
    #[serde(default)]
    pub dotted: bool,
    #[serde(default)]
    pub color: Option<Color>,
    /// Marker shape; `auto` (default): one shape per group value.
    #[serde(default)]
    pub marker: Marker,
    /// A fitted line, painted under the data, thinner; default: a
    /// layer of a fit's `curve.parquet` or `lines.parquet`.
    #[serde(default)]
    pub fit: Option<bool>,
    /// Column of disk radii (style `disks`).
    #[serde(default)]
    pub radius: Option<String>,
    /// Vector columns of style `arrows` and the data units per unit of them.
    #[serde(default)]
    pub arrows: Option<ArrowColumns>,
    /// The legend entries of a grouped layer.
    #[serde(default)]
    pub legend: LayerLegend,
    /// Group values the paper shows: each one absent from the data (the
    /// profile has no such state point) is said in a note on the panel.
    #[serde(default)]
    pub expect: Vec<f64>,
    /// Why an expected value may be absent, when the profile has the state
    /// point but the layer leaves it out (e.g. its fit is unreliable).
    #[serde(default)]
    pub absent: Option<String>,
    /// A grouped layer's curves stacked apart: see [`Offset`].
    #[serde(default)]
    pub offset: Option<Offset>,
    /// A name for this layer, for a fit layer's `points`.
    #[serde(default)]
    pub name: Option<String>,
    /// On a fit layer: the `name` of the layer whose points its line is
    /// judged against (runs of residual signs). Default: every point series
    /// of its group value, which mixes curves when ungrouped layers of one
    /// panel draw several (two drives at one eta).
    #[serde(default)]
    pub points: Option<String>,
}

/// Curves of one quantity that overlap (P(t)/P̄ of every phi about 1) drawn
/// apart: the series of the k-th group value (ascending, from 0) shifted by
/// k `step` in y (a negative step puts the first value on top, in the
/// legend's order); with `line`, a dotted line of each group's colour at its
/// shifted `line` marks the level each curve is read against.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Offset {
    pub step: f64,
    #[serde(default)]
    pub line: Option<f64>,
}

/// The legend entries of a layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LayerLegend {
    /// One entry per group value: the label followed by the value.
    #[default]
    Each,
    /// One entry for the whole layer, its label beside a sample of its style
    /// in each of its colours (e.g. dashed: the power law of every phi).
    Once,
    /// No entry.
    None,
}

/// The arrows of a quiver layer: from (x, y) to (x + scale dx, y + scale dy).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrowColumns {
    pub dx: String,
    pub dy: String,
    pub scale: ArrowScale,
}

/// Data units per unit of the vector columns: a number, or `auto`, which makes
/// the layer's longest arrow 0.9 of its grid spacing (the smallest step between
/// distinct x or y of its points), so that a field on a grid reads the same in
/// a small box and a large one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ArrowScale {
    Fixed(f64),
    Named(AutoScale),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AutoScale {
    Auto,
}

/// A number or `auto`; anything else is refused saying so (an untagged enum
/// would only say that no variant matched).
impl<'de> Deserialize<'de> for ArrowScale {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        match Value::deserialize(d)? {
            Value::Number(n) => Ok(ArrowScale::Fixed(n.as_f64().unwrap_or(f64::NAN))),
            Value::String(s) if s == "auto" => Ok(ArrowScale::Named(AutoScale::Auto)),
            other => Err(serde::de::Error::custom(format!(
                "arrows.scale must be a number > 0 or `auto`, not {other}"
            ))),
        }
    }
}

/// The smallest positive step between distinct values of `v` at `rows`.
fn grid_step(v: &[f64], rows: &[usize]) -> Option<f64> {
    let mut u: Vec<f64> = rows
        .iter()
        .map(|&i| v[i])
        .filter(|x| x.is_finite())
        .collect();
    u.sort_by(f64::total_cmp);
    u.dedup();
    u.windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .min_by(f64::total_cmp)
}

/// The scale of `auto`: the longest arrow at `rows` spans 0.9 grid steps.
fn auto_arrow_scale(x: &[f64], y: &[f64], dx: &[f64], dy: &[f64], rows: &[usize]) -> Option<f64> {
    let step = match (grid_step(x, rows), grid_step(y, rows)) {
        (Some(a), Some(b)) => a.min(b),
        (a, b) => a.or(b)?,
    };
    let longest = rows
        .iter()
        .map(|&i| dx[i].hypot(dy[i]))
        .filter(|l| l.is_finite())
        .fold(0.0, f64::max);
    (longest > 0.0).then(|| 0.9 * step / longest)
}

fn default_file() -> String {
    "parquet".into()
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PanelSpec {
    #[serde(default)]
    pub title: String,
    pub x: Axis,
    pub y: Axis,
    pub layers: Vec<Layer>,
    #[serde(default)]
    pub hlines: Vec<RefLine>,
    #[serde(default)]
    pub vlines: Vec<RefLine>,
    #[serde(default)]
    pub legend: Legend,
    #[serde(default)]
    pub legend_title: String,
    #[serde(default)]
    pub palette: Palette,
    /// Sentences printed above the axes (what differs from the paper, and why).
    #[serde(default)]
    pub notes: Vec<String>,
    /// Curves of a fit form at given parameters: what the paper draws as a
    /// guide, not fitted here (e.g. the algebraic decay of Eq. 8).
    #[serde(default)]
    pub curves: Vec<GuideCurve>,
}

/// A form of the fit catalogue at fixed parameters over [x_min, x_max].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuideCurve {
    pub form: String,
    /// Numbers, or a fitted value `"{=STAGE.QUANTITY}"` (e.g. a prefactor
    /// that puts the guide through the data).
    pub params: std::collections::BTreeMap<String, Value>,
    pub x: (f64, f64),
    #[serde(default)]
    pub label: String,
    #[serde(default)]
    pub dashed: bool,
    #[serde(default)]
    pub dotted: bool,
    #[serde(default)]
    pub color: Option<Color>,
}

impl GuideCurve {
    /// The curve as a series, sampled evenly (in log x on a log axis);
    /// `value` reads a fitted value `{=STAGE.QUANTITY}`.
    fn series(&self, log_x: bool, value: impl Fn(&str) -> Result<f64>) -> Result<Series> {
        // Guides only a plot draws: the logistic master curve of Eq. 8 in
        // x = beta ln(t/tau0), Q = A / (1 + e^((x - x0)/w)).
        let logistic = crate::fit::catalogue::Form {
            name: "logistic",
            describe: "y = A / (1 + exp((x - x0) / w)) (paper H, Eq. 8 in x = beta ln(t/tau0))",
            params: &["A", "x0", "w"],
            log_x: false,
            fit: |_, _| {
                Err(crate::fit::FitError::InvalidInput {
                    form: "logistic".into(),
                    what: "is a guide of the plot stage, not a fit form".into(),
                })
            },
            model: |p, _, x| p[0] / (1.0 + ((x - p[1]) / p[2]).exp()),
        };
        let form = if self.form == "logistic" {
            &logistic
        } else {
            crate::fit::catalogue::find(&self.form).map_err(anyhow::Error::msg)?
        };
        let p = form
            .params
            .iter()
            .map(|n| {
                let what = || format!("plot: curve of form {}: parameter {n}", form.name);
                match self.params.get(*n) {
                    Some(Value::Number(x)) => x.as_f64().with_context(what),
                    Some(Value::String(t)) => value(t).with_context(what),
                    _ => {
                        Err(anyhow::anyhow!("a number or \"{{=STAGE.QUANTITY}}\"").context(what()))
                    }
                }
            })
            .collect::<Result<Vec<f64>>>()?;
        let (a, b) = self.x;
        let at = |k: usize| {
            let f = k as f64 / 199.0;
            if log_x {
                a * (b / a).powf(f)
            } else {
                a + f * (b - a)
            }
        };
        let x: Vec<f64> = (0..200).map(at).collect();
        Ok(Series {
            label: self.label.clone(),
            y: x.iter().map(|&x| (form.model)(&p, &[], x)).collect(),
            x,
            dashed: self.dashed,
            dotted: self.dotted,
            color: self.color,
            fit: true,
            ..Default::default()
        })
    }
}

/// What the planner tells a plot about the build it draws (its parameter
/// `build`, not written in YAML): the profile, the number-valued
/// parameters and replicas of every experiment upstream at that profile, and
/// the row windows (`where`) of the figure's stages upstream, as
/// `where_COL`, `where_COL_min`, `where_COL_max` (a fit's range on the image).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BuildInfo {
    #[serde(default)]
    pub profile: String,
    #[serde(default)]
    pub experiments: std::collections::BTreeMap<String, std::collections::BTreeMap<String, Value>>,
    #[serde(default)]
    pub windows: std::collections::BTreeMap<String, std::collections::BTreeMap<String, Value>>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotParams {
    /// Set by the planner: see [`BuildInfo`].
    #[serde(default)]
    pub build: BuildInfo,
    #[serde(default)]
    pub title: String,
    pub panels: Vec<PanelSpec>,
    #[serde(default)]
    pub columns: Option<usize>,
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
    /// Colours keyed by value, per group column: see [`Figure::colour_ranges`].
    #[serde(default)]
    pub colour_ranges: std::collections::BTreeMap<String, (f64, f64)>,
    /// What the verdict lines compare with: the paper's values, or the
    /// project's own targets (a stability check: T held at 1, a rate ratio).
    #[serde(default)]
    pub against: Against,
}

/// Data units per unit of the vector columns of an arrows layer.
fn arrow_scale(
    layer: &Layer,
    a: &ArrowColumns,
    x: &[f64],
    y: &[f64],
    dx: &[f64],
    dy: &[f64],
    rows: &[usize],
) -> Result<f64> {
    Ok(match a.scale {
        ArrowScale::Fixed(k) if k.is_finite() && k > 0.0 => k,
        ArrowScale::Fixed(k) => anyhow::bail!(
            "plot: layer from '{}': arrows.scale = {k} must be a finite number > 0 or `auto`",
            layer.from
        ),
        // No grid or no motion: the arrows are drawn at length zero.
        ArrowScale::Named(AutoScale::Auto) => auto_arrow_scale(x, y, dx, dy, rows).unwrap_or(1.0),
    })
}

/// The key of an arrows layer, printed on its panel: how long an arrow is per
/// unit of its vector, and the longest vector drawn (a velocity field's scale).
fn arrow_key(layer: &Layer, c: &Columns) -> Result<Option<String>> {
    let Some(a) = &layer.arrows else {
        return Ok(None);
    };
    if c.rows == 0 {
        return Ok(None);
    }
    let rows = c.select(&layer.filter)?;
    let (x, y) = (c.col(&layer.x)?, c.col(&layer.y)?);
    let (dx, dy) = (c.col(&a.dx)?, c.col(&a.dy)?);
    let k = arrow_scale(layer, a, x, y, dx, dy, &rows)?;
    let longest = rows
        .iter()
        .map(|&i| dx[i].hypot(dy[i]))
        .filter(|l| l.is_finite())
        .fold(0.0, f64::max);
    Ok(Some(format!(
        "Arrows: ({}, {}) × {} in units of {}; the longest |({}, {})| = {}.",
        a.dx,
        a.dy,
        super::compare::digits(k, 3),
        layer.x,
        a.dx,
        a.dy,
        super::compare::digits(longest, 3)
    )))
}

/// The series of one layer.
fn series(layer: &Layer, c: &Columns) -> Result<Vec<Series>> {
    // An empty table (e.g. the curve of a fit that failed, see its note) draws nothing.
    if c.rows == 0 {
        return Ok(Vec::new());
    }
    let rows = c.select(&layer.filter)?;
    let (x, y) = (c.col(&layer.x)?, c.col(&layer.y)?);
    let e = layer.y_err.as_ref().map(|n| c.col(n)).transpose()?;
    let g = match (&layer.group, layer.at) {
        (Some(_), Some(_)) => None,
        (n, None) => n.as_ref().map(|n| c.col(n)).transpose()?,
        (None, Some(_)) => anyhow::bail!(
            "plot: layer from '{}': `at` is the value of its `group` column; give both",
            layer.from
        ),
    };
    let rad = layer.radius.as_ref().map(|n| c.col(n)).transpose()?;
    if (layer.style == Style::Disks) != rad.is_some() {
        anyhow::bail!(
            "plot: layer from '{}': style `disks` and `radius: COLUMN` go together",
            layer.from
        );
    }
    if (layer.style == Style::Arrows) != layer.arrows.is_some() {
        anyhow::bail!(
            "plot: layer from '{}': style `arrows` and `arrows: {{dx: COLUMN, dy: COLUMN, scale: S}}` go together",
            layer.from
        );
    }
    let arrows = match &layer.arrows {
        Some(a) => {
            let (dx, dy) = (c.col(&a.dx)?, c.col(&a.dy)?);
            Some((dx, dy, arrow_scale(layer, a, x, y, dx, dy, &rows)?))
        }
        None => None,
    };
    let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
    for &i in &rows {
        let key = g.map(|g| g[i]).or(layer.at).unwrap_or(0.0);
        match groups.iter_mut().find(|(k, _)| k.total_cmp(&key).is_eq()) {
            Some((_, v)) => v.push(i),
            None => groups.push((key, vec![i])),
        }
    }
    groups.sort_by(|a, b| a.0.total_cmp(&b.0));
    if layer.offset.is_some() && g.is_none() {
        anyhow::bail!(
            "plot: layer from '{}': `offset` stacks the curves of a `group` column apart; the layer has none",
            layer.from
        );
    }
    let mut out = Vec::new();
    let mut rank = 0.0;
    for (key, mut idx) in groups {
        // A group without one finite point (a phi whose fit failed) draws
        // nothing, so it gets no series and no legend entry.
        if !idx.iter().any(|&i| x[i].is_finite() && y[i].is_finite()) {
            continue;
        }
        let shift = layer.offset.as_ref().map_or(0.0, |o| rank * o.step);
        rank += 1.0;
        idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
        let label = match (&layer.group, layer.legend) {
            (_, LayerLegend::None) => String::new(),
            (Some(_), LayerLegend::Each) => format!("{}{}", layer.label, legend_number(key)),
            _ => layer.label.clone(),
        };
        let group = layer.group.as_ref().map(|column| Group {
            column: column.clone(),
            value: key,
        });
        if let Some(level) = layer.offset.as_ref().and_then(|o| o.line) {
            let xs = idx.iter().map(|&i| x[i]).filter(|v| v.is_finite());
            let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
            out.push(Series {
                x: vec![lo, hi],
                y: vec![level + shift; 2],
                style: Style::Line,
                dotted: true,
                color: layer.color,
                fit: true,
                group: group.clone(),
                ..Default::default()
            });
        }
        out.push(Series {
            label,
            x: idx.iter().map(|&i| x[i]).collect(),
            y: idx.iter().map(|&i| y[i] + shift).collect(),
            y_err: e.map(|e| idx.iter().map(|&i| e[i]).collect()),
            style: layer.style,
            dashed: layer.dashed,
            dotted: layer.dotted,
            color: layer.color,
            marker: layer.marker,
            fit: layer.fit.unwrap_or(matches!(
                layer.file.as_str(),
                "curve.parquet" | "lines.parquet"
            )),
            radius: rad.map(|r| idx.iter().map(|&i| r[i]).collect()),
            arrows: arrows.map(|(dx, dy, k)| idx.iter().map(|&i| [k * dx[i], k * dy[i]]).collect()),
            group,
            legend_ink: layer.group.is_some() && layer.legend == LayerLegend::Once,
        });
    }
    Ok(out)
}

/// A note for each group value the layer expects but did not draw: the
/// profile lacks a state point the paper shows. The value is named by the
/// panel's legend heading (e.g. φ), else by the group column.
fn missing(layer: &Layer, heading: &str, drawn: &[Series]) -> Option<String> {
    let column = layer.group.as_deref()?;
    let absent: Vec<String> = layer
        .expect
        .iter()
        .filter(|&&v| {
            !drawn
                .iter()
                .any(|s| s.group.as_ref().is_some_and(|g| (g.value - v).abs() < 1e-9))
        })
        .map(|&v| legend_number(v))
        .collect();
    if absent.is_empty() {
        return None;
    }
    let name = if heading.is_empty() { column } else { heading };
    let why = layer
        .absent
        .as_deref()
        .unwrap_or("this profile has no such state point.");
    Some(format!(
        "The paper shows {name} = {}; {why}",
        absent.join(", ")
    ))
}

/// A fit whose residual signs form fewer runs than this level allows
/// (Wald-Wolfowitz, one-sided) misses its points systematically.
const RUNS_LEVEL: f64 = 0.01;

/// The signs (true: above) of the points of `data` inside the x range of
/// the curve `fit`, against the curve interpolated in the panel's axes
/// (log where they are), with their x, in order of x.
fn residual_signs(fit: &Series, data: &[&Series], ps: &PanelSpec) -> Vec<(f64, bool)> {
    let tx = |v: f64| if ps.x.log { v.ln() } else { v };
    let ty = |v: f64| if ps.y.log { v.ln() } else { v };
    let curve: Vec<(f64, f64)> = fit
        .x
        .iter()
        .zip(&fit.y)
        .map(|(&x, &y)| (tx(x), ty(y)))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let at = |x: f64| -> Option<f64> {
        let w = curve
            .windows(2)
            .find(|w| (w[0].0.min(w[1].0)..=w[0].0.max(w[1].0)).contains(&x))?;
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        Some(if x1 == x0 {
            y0
        } else {
            y0 + (y1 - y0) * (x - x0) / (x1 - x0)
        })
    };
    let mut out: Vec<(f64, bool)> = data
        .iter()
        .flat_map(|s| s.x.iter().zip(&s.y))
        .filter_map(|(&x, &y)| {
            let (u, v) = (tx(x), ty(y));
            let r = v - at(u)?;
            // A point on the curve is on neither side.
            (r.is_finite() && r.abs() > 1e-12 * v.abs().max(1e-300)).then_some((x, r > 0.0))
        })
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// A note for each fitted curve of a panel whose points lie on one side of
/// it in runs too long for chance ([`RUNS_LEVEL`]): its form misses their
/// shape (a straight line through a curve that turns). A curve is judged
/// against the marked points of its own group value (or the ungrouped ones).
fn systematic(
    all: &[Series],
    names: &[(Option<String>, Option<String>)],
    ps: &PanelSpec,
) -> Vec<String> {
    let axis = if ps.x.label.is_empty() {
        "x"
    } else {
        &ps.x.label
    };
    let mut out = vec![];
    for (i, fit) in all.iter().enumerate().filter(|(_, s)| s.fit) {
        let against = names.get(i).and_then(|n| n.1.as_ref());
        let data: Vec<&Series> = all
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.fit && matches!(s.style, Style::Points | Style::LinePoints))
            .filter(|(j, s)| match against {
                Some(w) => names.get(*j).and_then(|n| n.0.as_ref()) == Some(w),
                None => s.group == fit.group,
            })
            .map(|(_, s)| s)
            .collect();
        let signs = residual_signs(fit, &data, ps);
        // Runs are counted in order of x: with several points at one x (a
        // scatter of clusters at each N_c) that order, and so the runs, are
        // arbitrary.
        if signs.windows(2).any(|w| w[0].0 == w[1].0) {
            continue;
        }
        let above: Vec<bool> = signs.iter().map(|s| s.1).collect();
        let Some(r) = crate::fit::runs::runs(&above).filter(|r| r.p < RUNS_LEVEL) else {
            continue;
        };
        let name = fit.label.split(':').next().unwrap_or_default().trim();
        let name = if name.is_empty() { "A fit" } else { name };
        let at = fit.group.as_ref().map_or(String::new(), |g| {
            let head = if ps.legend_title.is_empty() {
                &g.column
            } else {
                &ps.legend_title
            };
            format!(" at {head} = {}", legend_number(g.value))
        });
        let (a, b) = (signs[r.longest.0].0, signs[r.longest.1].0);
        out.push(format!(
            "{name}{at} misses its points systematically over {axis} in [{}, {}]: {} runs of residual signs in {} points (p = {} < {RUNS_LEVEL}).",
            super::compare::digits(a, 3),
            super::compare::digits(b, 3),
            r.runs,
            signs.len(),
            super::compare::digits(r.p, 2),
        ));
    }
    out
}

/// The figure from the parameters and the inputs, with the verdict of each
/// number of a gathered `compare` stage under its panels.
pub fn figure(p: &PlotParams, inputs: &[Artifact]) -> Result<Figure> {
    let table =
        |layer: &Layer| Columns::read_file(&inputs_of("plot", inputs, &layer.from)?, &layer.file);
    let fig = build(p, table, |text| fill(text, inputs, &p.build))?;
    with_caption(fig, verdicts(inputs, &p.build, p.against)?)
}

/// `fig` with `lines` under its panels, its height grown by theirs so that
/// the panels keep their size.
fn with_caption(mut fig: Figure, lines: Vec<String>) -> Result<Figure> {
    fig.caption = lines;
    fig.height += crate::plot::caption_height(&fig)?.ceil() as u32;
    Ok(fig)
}

/// One verdict line per row of every gathered `compare` stage (docs/plot.md).
fn verdicts(inputs: &[Artifact], build: &BuildInfo, against: Against) -> Result<Vec<String>> {
    let mut out = vec![];
    for a in inputs.iter().filter(|a| a.kind.name == "compare") {
        let (batches, _) = crate::table::read_parquet_bytes(a.read("parquet")?)?;
        for b in &batches {
            let text = |name: &str, i: usize| -> String {
                b.column_by_name(name)
                    .and_then(|c| c.as_any().downcast_ref::<arrow_array::StringArray>())
                    .filter(|c| arrow_array::Array::is_valid(c, i))
                    .map_or(String::new(), |c| c.value(i).to_string())
            };
            let rows = crate::table::results::read_compare(b)
                .with_context(|| format!("plot: the compare table of {}", a.label))?;
            for (i, c) in rows.iter().enumerate() {
                // The reason's references this build holds (its experiments,
                // the stages the plot gathers) printed as numbers; the others
                // are cut (`before_reference`).
                let mut c = c.clone();
                if let Ok(r) = fill(&c.reason, inputs, build) {
                    c.reason = r;
                }
                out.push(verdict_line(
                    &c,
                    &text(super::compare::SHORT, i),
                    provenance(c.source),
                    against,
                ));
            }
        }
    }
    Ok(out)
}

/// The figure from the parameters, each layer's table and the filling of
/// `{=STAGE.QUANTITY}` in labels.
fn build(
    p: &PlotParams,
    table: impl Fn(&Layer) -> Result<Columns>,
    fill: impl Fn(&str) -> Result<String>,
) -> Result<Figure> {
    // One arrow scale for the whole figure: `auto` fits the longest arrow of
    // all its `auto` layers into a grid step, so panels compare by length.
    let mut auto_scales: Vec<f64> = vec![];
    for layer in p.panels.iter().flat_map(|ps| &ps.layers) {
        let Some(a) = layer
            .arrows
            .as_ref()
            .filter(|a| a.scale == ArrowScale::Named(AutoScale::Auto))
        else {
            continue;
        };
        let c = table(layer).with_context(|| format!("plot: layer from '{}'", layer.from))?;
        if c.rows == 0 {
            continue;
        }
        let rows = c.select(&layer.filter)?;
        let (x, y) = (c.col(&layer.x)?, c.col(&layer.y)?);
        let (dx, dy) = (c.col(&a.dx)?, c.col(&a.dy)?);
        auto_scales.extend(auto_arrow_scale(x, y, dx, dy, &rows));
    }
    let shared_scale = auto_scales.into_iter().min_by(f64::total_cmp);
    let mut panels = Vec::new();
    for (k, ps) in p.panels.iter().enumerate() {
        if let Some(want) = ps
            .layers
            .iter()
            .filter_map(|l| l.points.as_ref())
            .find(|w| !ps.layers.iter().any(|l| l.name.as_ref() == Some(*w)))
        {
            bail!(
                "plot: panel {}: `points: {want}` names no layer of the panel (give that layer `name: {want}`)",
                k + 1
            );
        }
        let mut all = Vec::new();
        // Per series: its layer's `name` and, for a fit, the `points` it is judged against.
        let mut names: Vec<(Option<String>, Option<String>)> = Vec::new();
        let mut notes = ps
            .notes
            .iter()
            .map(|n| fill(n))
            .collect::<Result<Vec<_>>>()?;
        for layer in &ps.layers {
            let c = table(layer)
                .with_context(|| format!("plot: panel {} layer from '{}'", k + 1, layer.from))?;
            let mut layer = layer.clone();
            layer.label = fill(&layer.label)?;
            layer.absent = layer.absent.as_deref().map(&fill).transpose()?;
            if let (Some(a), Some(k)) = (layer.arrows.as_mut(), shared_scale)
                && a.scale == ArrowScale::Named(AutoScale::Auto)
            {
                a.scale = ArrowScale::Fixed(k);
            }
            let drawn: Vec<Series> = series(&layer, &c)?
                .into_iter()
                .filter(|s| !s.x.is_empty())
                .collect();
            notes.extend(missing(&layer, &ps.legend_title, &drawn));
            notes.extend(arrow_key(&layer, &c)?);
            names.extend(
                drawn
                    .iter()
                    .map(|_| (layer.name.clone(), layer.points.clone())),
            );
            all.extend(drawn);
        }
        // Fitted layers only: a guide of the paper (`curves`) is not ours to judge.
        notes.extend(systematic(&all, &names, ps));
        for c in &ps.curves {
            // A fitted value at full precision: `fill` with a `:value` key.
            let value = |t: &str| -> Result<f64> {
                let key = t.strip_suffix('}').map(|k| format!("{k}:value}}"));
                let text = fill(key.as_deref().unwrap_or(t))?;
                text.parse()
                    .with_context(|| format!("{t:?} is not a number nor a fitted value"))
            };
            let mut s = c.series(ps.x.log, value)?;
            s.label = fill(&s.label)?;
            all.push(s);
        }
        // Every text of the panel takes references and quotations alike.
        let (mut x, mut y) = (ps.x.clone(), ps.y.clone());
        x.label = fill(&x.label)?;
        y.label = fill(&y.label)?;
        let lines = |ls: &[RefLine]| -> Result<Vec<RefLine>> {
            ls.iter()
                .map(|l| {
                    Ok(RefLine {
                        label: fill(&l.label)?,
                        ..l.clone()
                    })
                })
                .collect()
        };
        panels.push(Panel {
            title: fill(&ps.title)?,
            x,
            y,
            series: all,
            hlines: lines(&ps.hlines)?,
            vlines: lines(&ps.vlines)?,
            legend: ps.legend,
            legend_title: ps.legend_title.clone(),
            palette: ps.palette,
            notes,
        });
    }
    let n = panels.len().max(1) as u32;
    let cols = p.columns.unwrap_or(n as usize).max(1) as u32;
    let rows = n.div_ceil(cols);
    let fig = Figure {
        title: fill(&p.title)?,
        panels,
        columns: p.columns,
        width: p.width.unwrap_or(560 * cols),
        height: p.height.unwrap_or(440 * rows),
        colour_ranges: p.colour_ranges.clone(),
        profile: (!p.build.profile.is_empty()).then(|| p.build.profile.clone()),
        caption: vec![],
    };
    fig.validate()?;
    Ok(fig)
}

pub struct Plot;

impl StageKind for Plot {
    type Params = PlotParams;
    fn name(&self) -> &str {
        "plot"
    }
    fn describe(&self) -> &str {
        "draw a figure (SVG and PNG) from the gathered tables, one series per group"
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<PlotParams> {
        typed("plot", params)
    }
    fn run(&self, ctx: &StageCtx, p: &PlotParams, inputs: &[Artifact]) -> Result<Output> {
        let fig = figure(&p, inputs)?;
        // What the layout check sees in the real data (the spec test sees
        // synthetic data only), shown with the build's output.
        for d in crate::plot::defects(&fig)? {
            ctx.note(format!("figure defect: {d}"));
        }
        let svg = crate::plot::draw_svg_string(&fig)?;
        let png = crate::plot::draw_png_bytes(&fig)?;
        Ok(Output::single("svg", svg.into_bytes()).with("png", png))
    }
}

#[cfg(test)]
#[path = "plot_tests.rs"]
mod tests;
