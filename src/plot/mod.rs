//! Figure drawing with plotters (SVG and PNG, embedded font).
//!
//! A [`Figure`] is plain data (serde), so a pipeline YAML holds it; [`draw`] turns it
//! into an SVG and a PNG written atomically. Log axes get decade ticks, points an
//! axis cannot show (NaN, inf, non-positive on a log axis) are skipped, the legend
//! goes where it covers no data.

mod check;
mod colour;
mod font;
mod geometry;
mod palette;
mod render;
mod scale;
mod spec;

use std::path::Path;

use anyhow::{Context, Result, anyhow};
use plotters::prelude::*;

pub use check::{MAX_COVERED, covered, profile_words, typeset};
pub use colour::{ciede2000, delta_e, lab};
pub use geometry::{P, Rect};
pub use palette::viridis;
pub use render::{Dot, PanelLayout, Stroke};
pub use scale::{Scale, Tick};
pub use spec::{
    Axis, Color, Figure, Group, Legend, Marker, Palette, Panel, RefLine, Series, Style,
};

/// Where every part of every panel goes, as [`draw`] puts it (no pixels drawn):
/// frames, scales, legend boxes, samples of the drawn marks, colours, notes.
pub fn layout(fig: &Figure) -> Result<Vec<PanelLayout>> {
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (fig.width, fig.height)).into_drawing_area();
    render::lay_out(&root, fig)
}

/// The height in pixels the caption of `fig` takes under its panels (its
/// lines wrapped to the figure's width): what to add to a figure's height
/// to give it a caption without shrinking the panels.
pub fn caption_height(fig: &Figure) -> Result<f64> {
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (fig.width, fig.height)).into_drawing_area();
    Ok(render::caption(&root, fig)?.height)
}

/// The figure as SVG text. Deterministic: the same figure gives the same bytes.
pub fn draw_svg_string(fig: &Figure) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (fig.width, fig.height)).into_drawing_area();
        render::render(&root, fig)?;
    }
    Ok(svg)
}

/// The figure as PNG bytes, `width` x `height` pixels.
pub fn draw_png_bytes(fig: &Figure) -> Result<Vec<u8>> {
    // plotters encodes PNG only to a path: draw into a private temporary directory.
    let dir = tempfile::tempdir().context("creating a temporary directory for the PNG")?;
    let path = dir.path().join("figure.png");
    {
        let root = BitMapBackend::new(&path, (fig.width, fig.height)).into_drawing_area();
        render::render(&root, fig)?;
    }
    std::fs::read(&path).map_err(|e| anyhow!("reading back the drawn PNG: {e}"))
}

/// Draw `fig` to `svg_path` and `png_path`, each written atomically.
pub fn draw(fig: &Figure, svg_path: &Path, png_path: &Path) -> Result<()> {
    let svg = draw_svg_string(fig).with_context(|| format!("drawing {}", svg_path.display()))?;
    crate::table::write_atomic(svg_path, svg.as_bytes())
        .with_context(|| format!("writing {}", svg_path.display()))?;
    let png = draw_png_bytes(fig).with_context(|| format!("drawing {}", png_path.display()))?;
    crate::table::write_atomic(png_path, &png)
        .with_context(|| format!("writing {}", png_path.display()))
}

/// What a referee would flag in `fig` as laid out (a legend over data, one
/// group value in two colours, unrendered markup, an axis stretched by one
/// error bar), one sentence each; empty when none.
pub fn defects(fig: &Figure) -> Result<Vec<String>> {
    check::defects(fig, &layout(fig)?)
}
