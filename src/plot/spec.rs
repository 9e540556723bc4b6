//! The declarative figure description a pipeline YAML holds.

use std::collections::BTreeMap;

use anyhow::{Result, bail, ensure};
use serde::{Deserialize, Serialize};

/// A whole figure: panels in a grid (an inset of the paper becomes a second panel).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Figure {
    /// Drawn above all panels; empty for none.
    #[serde(default)]
    pub title: String,
    pub panels: Vec<Panel>,
    /// Panels per row; default: all panels in one row.
    #[serde(default)]
    pub columns: Option<usize>,
    /// Size in pixels (PNG) and SVG user units.
    #[serde(default = "default_width")]
    pub width: u32,
    #[serde(default = "default_height")]
    pub height: u32,
    /// Colours keyed by value: a group column (e.g. `phi`) with the (min, max)
    /// the sequential palette spans, the same in every figure of a paper, so a
    /// phi has one colour everywhere. A group column not listed takes its
    /// colours from the rank of its value among the figure's values.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub colour_ranges: BTreeMap<String, (f64, f64)>,
    /// The profile the figure is drawn at (`ci`, `small`, `paper`), if any:
    /// a text naming another profile is a defect ([`crate::plot::defects`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
    /// Lines printed under the panels, across the figure (each compared
    /// number's verdict, put there by the plot stage), wrapped to its
    /// width and printed as written (no markup: quantity names keep their
    /// `_`). They take [`crate::plot::caption_height`] of the height.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub caption: Vec<String>,
}

impl Default for Figure {
    /// No panels (add some), default size, no title.
    fn default() -> Figure {
        Figure {
            title: String::new(),
            panels: vec![],
            columns: None,
            width: default_width(),
            height: default_height(),
            colour_ranges: BTreeMap::new(),
            profile: None,
            caption: vec![],
        }
    }
}

fn default_width() -> u32 {
    720
}
fn default_height() -> u32 {
    540
}

/// One set of axes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Panel {
    /// Drawn at the top left, e.g. "(a)"; empty for none.
    #[serde(default)]
    pub title: String,
    pub x: Axis,
    pub y: Axis,
    #[serde(default)]
    pub series: Vec<Series>,
    /// Horizontal reference lines, e.g. Q = 1/e.
    #[serde(default)]
    pub hlines: Vec<RefLine>,
    /// Vertical reference lines, e.g. t = tau_alpha.
    #[serde(default)]
    pub vlines: Vec<RefLine>,
    #[serde(default)]
    pub legend: Legend,
    /// Heading of the legend, e.g. "φ"; empty for none.
    #[serde(default)]
    pub legend_title: String,
    /// Default colours of series without one.
    #[serde(default)]
    pub palette: Palette,
    /// Sentences printed above the axes, e.g. that the profile lacks a state
    /// point the paper shows. The plotter adds its own (error bars larger than
    /// their value).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// One axis. Labels may use any symbol of DejaVu Sans (χ₄, φ, ξ) and the markup
/// `_{...}` (subscript), `^{...}` (superscript): "τ_{α}", "(φ_{c} − φ)^{−γ}".
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    #[serde(default)]
    pub label: String,
    #[serde(default)]
    pub log: bool,
    /// Fixed (min, max); default: fitted to the data (whole decades on log axes).
    #[serde(default)]
    pub range: Option<(f64, f64)>,
    /// A linear axis fitted to the data and zero (so a drift reads against the
    /// whole value, not against the seed noise).
    #[serde(default)]
    pub from_zero: bool,
}

/// One curve or point set.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Series {
    /// Legend entry; empty to leave the series out of the legend.
    #[serde(default)]
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Symmetric error bars on y.
    #[serde(default)]
    pub y_err: Option<Vec<f64>>,
    #[serde(default)]
    pub style: Style,
    #[serde(default)]
    pub dashed: bool,
    /// Dotted instead (e.g. the paper's Stokes-Einstein line).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub dotted: bool,
    /// "#rrggbb"; default: the panel palette at this series' index.
    #[serde(default)]
    pub color: Option<Color>,
    /// Marker shape; `auto` (the default): a group value's shape by its rank
    /// among the figure's values (one shape per value, as its colour), a
    /// circle for a series without a group.
    #[serde(default)]
    pub marker: Marker,
    /// A fit or guide line: painted before the data, a pixel thinner, so
    /// that it hides none of their markers.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fit: bool,
    /// Per-point radius in data units (style `disks`: disks drawn to scale).
    #[serde(default)]
    pub radius: Option<Vec<f64>>,
    /// Per-point vector [dx, dy] in data units (style `arrows`: an arrow from
    /// each point to point + vector, e.g. a velocity field).
    #[serde(default)]
    pub arrows: Option<Vec<[f64; 2]>>,
    /// The group value this series draws (e.g. phi = 0.78): every series of one
    /// value takes one colour, in every panel, markers and lines alike.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<Group>,
    /// One legend entry names a style (dashed = power law) that series of
    /// several colours share: its sample shows the style in each of their
    /// colours side by side.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub legend_ink: bool,
}

/// A value of a group column.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Group {
    pub column: String,
    pub value: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Style {
    #[default]
    #[serde(rename = "line")]
    Line,
    #[serde(rename = "points")]
    Points,
    #[serde(rename = "line+points")]
    LinePoints,
    /// Filled disks of the series' `radius` (x-axis units), e.g. a configuration.
    #[serde(rename = "disks")]
    Disks,
    /// Arrows of the series' `arrows` vectors (a quiver plot).
    #[serde(rename = "arrows")]
    Arrows,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Marker {
    /// By group value (see [`Series::marker`]).
    #[default]
    Auto,
    /// The shape `auto` gives, open: the same points where a fit drawn beneath
    /// them must show through (a tail of a distribution).
    AutoOpen,
    Circle,
    Square,
    Triangle,
    Diamond,
    TriangleDown,
    Pentagon,
    Star,
    Cross,
    Plus,
    OpenCircle,
    OpenSquare,
    OpenTriangle,
    OpenDiamond,
    OpenTriangleDown,
    OpenPentagon,
    OpenStar,
}

impl Marker {
    /// The filled shapes given to group values in turn: neighbours in rank
    /// (neighbours in colour) never share one.
    pub const CYCLE: [Marker; 7] = [
        Marker::Circle,
        Marker::Square,
        Marker::Triangle,
        Marker::Diamond,
        Marker::TriangleDown,
        Marker::Pentagon,
        Marker::Star,
    ];

    /// Drawn as an outline on white.
    pub fn open(self) -> bool {
        matches!(
            self,
            Marker::AutoOpen
                | Marker::OpenCircle
                | Marker::OpenSquare
                | Marker::OpenTriangle
                | Marker::OpenDiamond
                | Marker::OpenTriangleDown
                | Marker::OpenPentagon
                | Marker::OpenStar
        )
    }

    /// The same shape, filled.
    pub fn filled(self) -> Marker {
        match self {
            Marker::AutoOpen => Marker::Auto,
            Marker::OpenCircle => Marker::Circle,
            Marker::OpenSquare => Marker::Square,
            Marker::OpenTriangle => Marker::Triangle,
            Marker::OpenDiamond => Marker::Diamond,
            Marker::OpenTriangleDown => Marker::TriangleDown,
            Marker::OpenPentagon => Marker::Pentagon,
            Marker::OpenStar => Marker::Star,
            m => m,
        }
    }

    /// The same shape, open (crosses and pluses are lines already).
    pub fn hollow(self) -> Marker {
        match self {
            Marker::Circle | Marker::Auto => Marker::OpenCircle,
            Marker::Square => Marker::OpenSquare,
            Marker::Triangle => Marker::OpenTriangle,
            Marker::Diamond => Marker::OpenDiamond,
            Marker::TriangleDown => Marker::OpenTriangleDown,
            Marker::Pentagon => Marker::OpenPentagon,
            Marker::Star => Marker::OpenStar,
            m => m,
        }
    }
}

/// Where the legend goes: a corner inside the axes, outside on the right, or nowhere.
/// `auto` takes the inside corner covering the fewest data points, else the right.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Legend {
    #[default]
    Auto,
    TopRight,
    TopLeft,
    BottomLeft,
    BottomRight,
    Right,
    None,
}

/// Default series colours: `sequential` (viridis, one curve per phi reads as an
/// ordered family) or `categorical` (distinct hues for unordered sets).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Palette {
    #[default]
    Sequential,
    Categorical,
}

/// A horizontal or vertical reference line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefLine {
    pub at: f64,
    /// Written next to the line, e.g. "1/e"; empty for none.
    #[serde(default)]
    pub label: String,
    #[serde(default = "yes")]
    pub dashed: bool,
    /// Default: grey.
    #[serde(default)]
    pub color: Option<Color>,
    /// Half-width of a pale band about the line (a paper's value and its
    /// tolerance), in the axis' units; none by default.
    #[serde(default)]
    pub band: Option<f64>,
}

fn yes() -> bool {
    true
}

/// An sRGB colour, written "#rrggbb" in YAML.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Color(pub [u8; 3]);

impl Color {
    pub fn parse(s: &str) -> Result<Color> {
        let hex = s.strip_prefix('#').unwrap_or("");
        ensure!(
            hex.len() == 6 && hex.chars().all(|c| c.is_ascii_hexdigit()),
            "colour {s:?} is not of the form \"#rrggbb\" (e.g. \"#1f77b4\")"
        );
        let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).expect("checked hex");
        Ok(Color([byte(0), byte(2), byte(4)]))
    }
}

impl std::fmt::Display for Color {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [r, g, b] = self.0;
        write!(f, "#{r:02x}{g:02x}{b:02x}")
    }
}

impl Serialize for Color {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> Deserialize<'de> for Color {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        Color::parse(&s).map_err(|e| serde::de::Error::custom(format!("{e:#}")))
    }
}

impl Figure {
    /// Check what drawing relies on; errors name the panel, series and what is valid.
    pub fn validate(&self) -> Result<()> {
        ensure!(!self.panels.is_empty(), "figure has no panels");
        ensure!(
            (64..=10_000).contains(&self.width) && (64..=10_000).contains(&self.height),
            "figure size {}x{} is outside 64..=10000 pixels per side",
            self.width,
            self.height
        );
        for (column, &(lo, hi)) in &self.colour_ranges {
            ensure!(
                lo.is_finite() && hi.is_finite() && lo < hi,
                "colour range of {column} ({lo}, {hi}) must be finite with min < max"
            );
        }
        if let Some(c) = self.columns {
            ensure!(c >= 1, "columns must be at least 1");
        }
        for (i, p) in self.panels.iter().enumerate() {
            let name = format!("panel {} {:?}", i + 1, p.title);
            for (axis, a) in [("x", &p.x), ("y", &p.y)] {
                if let Some((lo, hi)) = a.range {
                    ensure!(
                        lo.is_finite() && hi.is_finite() && lo < hi,
                        "{name}: {axis} range ({lo}, {hi}) must be finite with min < max"
                    );
                    ensure!(
                        !a.log || lo > 0.0,
                        "{name}: {axis} axis is logarithmic, its range ({lo}, {hi}) must be positive"
                    );
                }
            }
            for (kind, lines, axis) in [("hline", &p.hlines, &p.y), ("vline", &p.vlines, &p.x)] {
                for l in lines {
                    if let Some(b) = l.band {
                        ensure!(
                            b.is_finite() && b > 0.0,
                            "{name}: the band of the {kind} at {} must be a positive half-width, not {b}",
                            l.at
                        );
                    }
                    if !l.at.is_finite() || (axis.log && l.at <= 0.0) {
                        bail!(
                            "{name}: {kind} at {} cannot be drawn on a {} axis",
                            l.at,
                            if axis.log { "logarithmic" } else { "linear" }
                        );
                    }
                }
            }
            for (j, s) in p.series.iter().enumerate() {
                ensure!(
                    s.x.len() == s.y.len(),
                    "{name}, series {} {:?}: {} x values but {} y values",
                    j + 1,
                    s.label,
                    s.x.len(),
                    s.y.len()
                );
                if let Some(e) = &s.y_err {
                    ensure!(
                        e.len() == s.y.len(),
                        "{name}, series {} {:?}: {} y_err values but {} y values",
                        j + 1,
                        s.label,
                        e.len(),
                        s.y.len()
                    );
                }
            }
        }
        Ok(())
    }
}
