//! Lay out and draw a [`Figure`] on any plotters backend (SVG or bitmap).
//!
//! Drawn in pixel space by hand (frame, inward ticks on all sides, decade labels,
//! clipping, legend placement) rather than with plotters' chart builder, whose meshes,
//! outward ticks and unclipped series do not read like a physics paper.

use std::collections::BTreeMap;

use anyhow::Result;
use plotters::prelude::*;
use plotters::style::Color as _;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, VPos};

use super::geometry::{P, Rect};
use super::palette;
use super::scale::Scale;
use super::spec::{Color, Figure, Legend, Marker, Palette, Panel, Series, Style};

mod ink;
mod labels;
mod legend;
mod paint;
pub(super) use ink::spans;
use ink::{
    Area, Dash, Frame, GREY, INK, NOTE, Sizes, arrow, draw_text, err, marker, polyline, px, rgb,
    stroke, stroke_dashed, text_size, text_style,
};
pub(super) use labels::labelled_lines;
use labels::{fill_rect, marks, ref_labels};
use legend::{LegendBox, draw_legend, free_corner, measure_legend, outside_legend};
pub use paint::{Dot, Stroke};
use paint::{Part, line_pieces, line_width, marker_points, pass};

/// Draw the whole figure on `root` (already sized to the figure).
pub fn render<DB: DrawingBackend>(root: &Area<DB>, fig: &Figure) -> Result<()> {
    root.fill(&WHITE).map_err(err)?;
    let laid = lay_out(root, fig)?;
    if !fig.title.is_empty() {
        let (w, h) = (fig.width as f64, fig.height as f64);
        let title_size = (w.min(h) / 26.0).clamp(12.0, 24.0);
        let (_, th) = text_size(root, &fig.title, title_size)?;
        let style = text_style(title_size, INK, HPos::Center, VPos::Top);
        draw_text(root, &fig.title, &style, (w / 2.0, 0.4 * th))?;
    }
    for (panel, lay) in fig.panels.iter().zip(&laid) {
        draw_panel(root, panel, lay)?;
    }
    let cap = caption(root, fig)?;
    let style = text_style(cap.size, NOTE, HPos::Left, VPos::Top);
    for (k, line) in cap.lines.iter().enumerate() {
        let y = fig.height as f64 - cap.height + cap.pad + k as f64 * cap.row;
        draw_text(root, line, &style, (cap.pad, y))?;
    }
    root.present().map_err(err)
}

/// The caption under the panels as laid out: text size, lines wrapped to
/// the figure's width, row and margin, and the height it takes.
pub struct Caption {
    pub size: f64,
    pub lines: Vec<String>,
    pub row: f64,
    pub pad: f64,
    pub height: f64,
}

/// The caption of `fig` as laid out. Its text size follows the width of a
/// panel only, so adding its height to the figure's keeps the panels'.
pub fn caption<DB: DrawingBackend>(root: &Area<DB>, fig: &Figure) -> Result<Caption> {
    super::font::register()?;
    let cols = fig
        .columns
        .unwrap_or(fig.panels.len())
        .clamp(1, fig.panels.len().max(1));
    let size = (fig.width as f64 / cols as f64 / 40.0).clamp(11.0, 14.0);
    let (row, pad) = (1.3 * size, 0.6 * size);
    let mut lines = vec![];
    for text in &fig.caption {
        lines.extend(wrap(root, text, size, fig.width as f64 - 2.0 * pad)?);
    }
    let height = if lines.is_empty() {
        0.0
    } else {
        lines.len() as f64 * row + 2.0 * pad
    };
    Ok(Caption {
        size,
        lines,
        row,
        pad,
        height,
    })
}

/// Where every part of every panel goes, as drawing puts it: what a test checks
/// without looking at pixels.
pub fn lay_out<DB: DrawingBackend>(root: &Area<DB>, fig: &Figure) -> Result<Vec<PanelLayout>> {
    fig.validate()?;
    super::font::register()?;
    let (w, h) = (fig.width as f64, fig.height as f64);
    let title_size = (w.min(h) / 26.0).clamp(12.0, 24.0);
    let top = if fig.title.is_empty() {
        0.0
    } else {
        1.8 * text_size(root, &fig.title, title_size)?.1
    };
    let cols = fig
        .columns
        .unwrap_or(fig.panels.len())
        .min(fig.panels.len());
    let rows = fig.panels.len().div_ceil(cols);
    let bottom = caption(root, fig)?.height;
    let (cw, ch) = (w / cols as f64, (h - top - bottom) / rows as f64);
    let colors = series_colors(fig);
    let markers = series_markers(fig);
    let mut out = Vec::new();
    for (i, ((panel, colors), markers)) in fig.panels.iter().zip(colors).zip(markers).enumerate() {
        let cell = Rect {
            x0: (i % cols) as f64 * cw,
            y0: top + (i / cols) as f64 * ch,
            x1: (i % cols + 1) as f64 * cw,
            y1: top + (i / cols + 1) as f64 * ch,
        };
        out.push(lay_out_panel(root, panel, cell, colors, markers)?);
    }
    Ok(out)
}

/// The rank of every group value among the figure's values of its column,
/// and how many values the column has.
fn group_ranks(fig: &Figure) -> BTreeMap<&str, Vec<f64>> {
    let mut values: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for g in fig
        .panels
        .iter()
        .flat_map(|p| &p.series)
        .filter_map(|s| s.group.as_ref())
    {
        values.entry(&g.column).or_default().push(g.value);
    }
    for v in values.values_mut() {
        v.sort_by(f64::total_cmp);
        v.dedup_by(|a, b| a.total_cmp(b).is_eq());
    }
    values
}

/// The rank of `g` among the figure's values of its column, of how many.
fn rank_of(values: &BTreeMap<&str, Vec<f64>>, g: &super::spec::Group) -> (usize, usize) {
    let vals = &values[g.column.as_str()];
    let k = vals
        .iter()
        .position(|v| v.total_cmp(&g.value).is_eq())
        .unwrap_or(0);
    (k, vals.len())
}

/// The colour of every series, panel by panel: its own; else its group
/// value's, one colour per value in all panels, spaced evenly by the value's
/// rank among the figure's values of its column (not by the value itself: a
/// dozen phi crowded near 0.8 would take near-identical colours); else the
/// panel palette at its place among the panel's other such series.
fn series_colors(fig: &Figure) -> Vec<Vec<Color>> {
    let values = group_ranks(fig);
    fig.panels
        .iter()
        .map(|p| {
            let plain = |s: &Series| s.color.is_none() && s.group.is_none();
            let n_plain = p.series.iter().filter(|s| plain(s)).count();
            let grouped = p.series.iter().any(|s| s.group.is_some());
            // Beside group colours, other series take distinct hues.
            let own = if grouped {
                Palette::Categorical
            } else {
                p.palette
            };
            let mut k_plain = 0;
            p.series
                .iter()
                .map(|s| {
                    if let Some(c) = s.color {
                        return c;
                    }
                    if let Some(g) = &s.group {
                        let (k, n) = rank_of(&values, g);
                        let t = if n > 1 {
                            k as f64 / (n - 1) as f64
                        } else {
                            0.0
                        };
                        return palette::group_color(p.palette, t, k);
                    }
                    k_plain += 1;
                    palette::color(own, k_plain - 1, n_plain)
                })
                .collect()
        })
        .collect()
}

/// The marker every series draws, panel by panel (`None`: a line without
/// markers, disks, arrows): its own shape; else, for a group value, the
/// shape of its rank in [`Marker::CYCLE`], and for a series coloured by the
/// panel palette the shape of its place among them, so that series next in
/// colour differ in shape; else a circle. Data lines of such a family carry
/// their shape on a few of their points.
fn series_markers(fig: &Figure) -> Vec<Vec<Option<Marker>>> {
    let values = group_ranks(fig);
    fig.panels
        .iter()
        .map(|p| {
            let family_lines = p.series.iter().filter(|s| family_line(s)).count();
            let mut k_plain = 0;
            p.series
                .iter()
                .map(|s| {
                    let plain = s.color.is_none() && s.group.is_none();
                    let shape = match (s.marker, &s.group) {
                        (Marker::Auto, Some(g)) => {
                            Marker::CYCLE[rank_of(&values, g).0 % Marker::CYCLE.len()]
                        }
                        (Marker::Auto, None) if plain => {
                            k_plain += 1;
                            Marker::CYCLE[(k_plain - 1) % Marker::CYCLE.len()]
                        }
                        (Marker::Auto, None) => Marker::Circle,
                        (Marker::AutoOpen, Some(g)) => {
                            Marker::CYCLE[rank_of(&values, g).0 % Marker::CYCLE.len()].hollow()
                        }
                        (Marker::AutoOpen, None) => Marker::OpenCircle,
                        (m, _) => {
                            k_plain += usize::from(plain);
                            m
                        }
                    };
                    match s.style {
                        Style::Points | Style::LinePoints => Some(shape),
                        Style::Line if family_line(s) && family_lines > 1 => Some(shape),
                        _ => None,
                    }
                })
                .collect()
        })
        .collect()
}

/// A data line of a family (one group value, or one of the panel palette's
/// colours), which carries its marker on a few of its points so that lines
/// of neighbouring colours stay apart; fits and guides do not.
fn family_line(s: &Series) -> bool {
    s.style == Style::Line && (s.group.is_some() || s.color.is_none()) && !s.fit && !s.legend_ink
}

/// Axis scales of a panel: the given ranges, or ranges fitted to its values.
/// Error bars widen a fitted range by at most a quarter of the values' span on
/// each side (in decades on a log axis), so one long bar cannot squeeze the
/// data into a strip; the bars are cut at the frame instead.
fn scales(p: &Panel) -> (Scale, Scale) {
    let fit = |axis: &super::spec::Axis, values: Vec<f64>| match axis.range {
        Some((lo, hi)) => Scale {
            lo,
            hi,
            log: axis.log,
        },
        None if axis.from_zero && !axis.log => Scale::fit(values.into_iter().chain([0.0]), false),
        None => Scale::fit(values, axis.log),
    };
    let y_axis = Scale {
        lo: 1.0,
        hi: 10.0,
        log: p.y.log,
    };
    let t = |v: f64| if p.y.log { v.log10() } else { v };
    let back = |v: f64| if p.y.log { 10f64.powf(v) } else { v };
    // The data set the y range: fits and guides are drawn within it, and on
    // a log axis so are points whose error exceeds their value (noise), when
    // there are other points to set it.
    let data = |keep_noise: bool, keep_fits: bool| -> Vec<f64> {
        p.series
            .iter()
            .filter(|s| keep_fits || !s.fit)
            .flat_map(|s| {
                (0..s.y.len())
                    .filter(move |&i| keep_noise || !noise(s, i, p.y.log))
                    .map(move |i| s.y[i])
            })
            .filter(|&v| y_axis.accepts(v))
            .collect()
    };
    let mut values = data(false, false);
    if values.len() < 2 {
        values = data(true, false);
    }
    if values.len() < 2 {
        values = data(true, true);
    }
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(t(v)), b.max(t(v)))
        });
    let reach = if hi > lo {
        0.25 * (hi - lo)
    } else {
        f64::INFINITY
    };
    let ends = p.series.iter().flat_map(|s| {
        let err = s.y_err.as_deref().unwrap_or(&[]);
        s.y.iter().zip(err).flat_map(|(&y, &e)| {
            [y - e.abs(), y + e.abs()]
                .into_iter()
                .filter(move |&v| y_axis.accepts(v) && y_axis.accepts(y) && e.is_finite())
                .map(move |v| back(t(v).clamp(lo - reach, hi + reach)))
        })
    });
    // A reference line as near the values as a bar may reach is brought into
    // view (a paper's value just past the data), a far one is not.
    let near = p
        .hlines
        .iter()
        .map(|l| l.at)
        .filter(|&v| y_axis.accepts(v) && t(v) >= lo - reach && t(v) <= hi + reach);
    let ys = values.iter().copied().chain(ends).chain(near).collect();
    let y = fit(&p.y, ys);
    // The x range holds what shows: a noise point or a stretch of a fit that
    // the y range leaves out does not widen it (fig14's log-normal tail).
    let shown = |v: f64| y.accepts(v) && (y.fraction(v) >= 0.0 && y.fraction(v) <= 1.0);
    let xs = p
        .series
        .iter()
        .flat_map(|s| {
            (0..s.x.len())
                .filter(move |&i| !((s.fit || noise(s, i, p.y.log)) && !shown(s.y[i])))
                .map(move |i| s.x[i])
        })
        .collect();
    (fit(&p.x, xs), y)
}

/// Where a panel's parts go.
#[derive(Clone, Debug)]
pub struct PanelLayout {
    /// The axes box in pixels.
    pub frame: Rect,
    pub x: Scale,
    pub y: Scale,
    /// The legend box, if any.
    pub legend: Option<Rect>,
    /// Pixel samples of the data drawn inside the axes: markers, lines
    /// (every two pixels), error bars.
    pub marks: Vec<P>,
    /// The box of each reference-line label drawn on the axes, with its text
    /// (a label moved into the legend has none).
    pub labels: Vec<(String, Rect)>,
    label_colors: Vec<Option<Color>>,
    /// The colour of each series.
    pub colors: Vec<Color>,
    /// The marker each series draws (`None`: none, e.g. a fitted line).
    pub markers: Vec<Option<Marker>>,
    /// Every line and error bar as painted (pixels, width, pass).
    pub strokes: Vec<Stroke>,
    /// Every marker as painted: what [`crate::plot::defects`] checks the
    /// strokes painted after it do not hide.
    pub dots: Vec<Dot>,
    /// The notes above the axes, the panel's and the plotter's.
    pub notes: Vec<String>,
    /// The notes wrapped to the frame width, as drawn.
    lines: Vec<String>,
    sz: Sizes,
    ticks_size: (f64, f64, f64),
    /// The panel's whole cell of the figure (axes, labels, title, notes).
    pub cell: Rect,
    legend_box: Option<LegendBox>,
}

/// The plotter's own notes: error bars cut at the frame, and whether any of
/// them is longer than its value.
fn bar_notes(p: &Panel, xs: Scale, ys: Scale) -> Vec<String> {
    let (mut cut, mut larger) = (false, false);
    for s in &p.series {
        let err = s.y_err.as_deref().unwrap_or(&[]);
        for ((&x, &y), &e) in s.x.iter().zip(&s.y).zip(err) {
            let shown = xs.accepts(x)
                && (xs.lo..=xs.hi).contains(&x)
                && ys.accepts(y)
                && (ys.lo..=ys.hi).contains(&y);
            if !(shown && e.is_finite() && e > 0.0) {
                continue;
            }
            let out = |v: f64| !ys.accepts(v) || v < ys.lo || v > ys.hi;
            if out(y - e) || out(y + e) {
                cut = true;
                larger |= e > y.abs();
            }
        }
    }
    let mut out: Vec<String> = match (cut, larger) {
        (false, _) => vec![],
        (true, false) => vec!["Error bars end at the frame.".into()],
        (true, true) => {
            vec!["Error bars end at the frame; some errors exceed their value.".into()]
        }
    };
    // Noise on a log axis: points whose error exceeds their value, drawn
    // open where they fall inside the axes, left out (the y range is set by
    // the other points) where they do not.
    let (mut open, mut left_out, mut below_zero) = (false, 0, 0);
    for s in p
        .series
        .iter()
        .filter(|s| matches!(s.style, Style::Points | Style::LinePoints) && !s.fit)
    {
        // A measured value below zero that is not noise: a log axis cannot
        // draw it, and it must not vanish without a word. (An exact zero is
        // an empty histogram bin, no measurement.)
        below_zero += (0..s.y.len())
            .filter(|&i| !noise(s, i, ys.log))
            .filter(|&i| {
                let below = |log: bool, v: f64| log && v.is_finite() && v < 0.0;
                below(ys.log, s.y[i]) || below(xs.log, s.x[i])
            })
            .count();
        for i in (0..s.y.len()).filter(|&i| noise(s, i, ys.log)) {
            // Below the y range it is left out wherever its x lies: the x
            // range ends with what shows ([`scales`]).
            let in_x = xs.accepts(s.x[i]) && (xs.lo..=xs.hi).contains(&s.x[i]);
            if !(ys.accepts(s.y[i]) && (ys.lo..=ys.hi).contains(&s.y[i])) {
                left_out += 1;
            } else if in_x {
                open |= !s.marker.open();
            }
        }
    }
    if open || left_out > 0 {
        // Said below, with what is drawn of them.
        out.retain(|n| !n.contains("exceed their value"));
        if cut {
            out.push("Error bars end at the frame.".into());
        }
    }
    if open {
        out.push("Open markers of filled series: points whose error exceeds their value.".into());
    }
    // "1 point whose error exceeds its value lies" / "2 points ... their ... lie".
    let count = |n: usize, text: &str| -> String {
        let one = n == 1;
        let text = text
            .replace("{s}", if one { "" } else { "s" })
            .replace("{its}", if one { "its" } else { "their" })
            .replace("{lies}", if one { "lies" } else { "lie" });
        format!("{n} point{} {text}", if one { "" } else { "s" })
    };
    if left_out > 0 {
        out.push(count(
            left_out,
            "whose error exceeds {its} value {lies} outside the axes, left out.",
        ));
    }
    if below_zero > 0 {
        out.push(count(
            below_zero,
            "below zero beyond {its} error{s} cannot be drawn on the log axis, left out.",
        ));
    }
    out
}

/// `text` broken into lines no wider than `width` at `size`.
fn wrap<DB: DrawingBackend>(
    area: &Area<DB>,
    text: &str,
    size: f64,
    width: f64,
) -> Result<Vec<String>> {
    let mut lines: Vec<String> = vec![];
    let mut line = String::new();
    for word in text.split_whitespace() {
        let longer = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if !line.is_empty() && text_size(area, &longer, size)?.0 > width {
            lines.push(std::mem::replace(&mut line, word.to_string()));
        } else {
            line = longer;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    Ok(lines)
}

fn lay_out_panel<DB: DrawingBackend>(
    root: &Area<DB>,
    p: &Panel,
    cell: Rect,
    colors: Vec<Color>,
    markers: Vec<Option<Marker>>,
) -> Result<PanelLayout> {
    let sz = Sizes::for_cell(cell.width(), cell.height());
    let (xs, ys) = scales(p);
    let (xticks, yticks) = (xs.ticks(), ys.ticks());
    let pad = 0.6 * sz.label;
    let mut ytick_w: f64 = 0.0;
    for t in yticks.iter().filter_map(|t| t.label.as_ref()) {
        ytick_w = ytick_w.max(text_size(root, t, sz.tick)?.0);
    }
    let tick_h = text_size(root, "10⁰", sz.tick)?.1;
    let label_h = text_size(root, "Xg", sz.label)?.1;
    let last_xtick = xticks.iter().rev().find_map(|t| t.label.as_ref());
    let xtick_half = text_size(root, last_xtick.map_or("", |s| s), sz.tick)?.0 / 2.0;
    // Room for an axis label: none when it is empty.
    let room = |label: &str, gap: f64| if label.is_empty() { 0.0 } else { label_h + gap };
    let left = pad + room(&p.y.label, 0.5 * sz.label) + ytick_w + 0.5 * sz.tick;
    let bottom = pad + room(&p.x.label, 0.4 * sz.label) + tick_h + 0.5 * sz.tick;
    let right = pad + xtick_half.max(0.3 * sz.label) + 0.2 * sz.label;
    // A note's `code` spans (shared with the report's Markdown) print as
    // plain text on the image.
    let notes: Vec<String> = p
        .notes
        .iter()
        .map(|n| n.replace('`', ""))
        .chain(bar_notes(p, xs, ys))
        .collect();
    let mut lines = vec![];
    for n in &notes {
        lines.extend(wrap(root, n, sz.legend, cell.width() - left - right)?);
    }
    let top =
        pad + room(&p.title, 0.4 * sz.label).max(0.5 * tick_h) + lines.len() as f64 * note_row(sz);

    let inside = Rect {
        x0: cell.x0 + left,
        y0: cell.y0 + top,
        x1: cell.x1 - right,
        y1: cell.y1 - bottom,
    };
    let frame = |rect| Frame { rect, x: xs, y: ys };
    // A reference-line label with no free place along its line goes into the
    // legend instead of over the data.
    let first = frame(inside);
    let first_marks = marks(&first, p);
    let crowded: Vec<usize> = ref_labels(root, &first, p, sz, &first_marks, &[])?
        .iter()
        .enumerate()
        .filter(|(_, l)| l.as_ref().is_some_and(|l| l.2))
        .map(|(k, _)| k)
        .collect();
    let legend = measure_legend(root, p, sz, &crowded)?;
    let corners = [
        Legend::TopRight,
        Legend::TopLeft,
        Legend::BottomLeft,
        Legend::BottomRight,
    ];
    // The asked corner first, then the others; the right side if all cover data.
    let order: Vec<Legend> = match p.legend {
        Legend::Auto | Legend::Right | Legend::None => corners.to_vec(),
        asked => std::iter::once(asked)
            .chain(corners.into_iter().filter(|&c| c != asked))
            .collect(),
    };
    let (frame, legend_at) = match (p.legend, legend.entries.is_empty()) {
        // `none` leaves the series out; a crowded reference label still shows.
        (_, true) => (frame(inside), None),
        (Legend::Right, _) => outside_legend(frame, inside, &legend, sz, false),
        _ => {
            let f = frame(inside);
            let mut taken = marks(&f, p);
            for (_, b, _) in ref_labels(root, &f, p, sz, &taken, &crowded)?
                .into_iter()
                .flatten()
            {
                fill_rect(&b, &mut taken);
            }
            match free_corner(&f, &order, &taken, &legend, sz) {
                Some(at) => (f, Some(at)),
                // Beside the axes or above them, whichever leaves them more
                // room: a wide legend (fitted values in its labels) beside
                // them would squeeze them to a strip, a tall one (a dozen phi)
                // above them too.
                None => {
                    let beside = (inside.width() - legend.width).max(0.0) * inside.height();
                    let over = inside.width() * (inside.height() - legend.height).max(0.0);
                    let above = over > beside;
                    outside_legend(frame, inside, &legend, sz, above)
                }
            }
        }
    };
    let marks = marks(&frame, p);
    let (strokes, dots) = paint::plan(&frame, p, &markers, sz);
    let mut labels = vec![];
    let mut label_colors = vec![];
    let placed = ref_labels(root, &frame, p, sz, &marks, &crowded)?;
    for (l, (line, _)) in placed.into_iter().zip(labelled_lines(p)) {
        if let Some((text, b, _)) = l {
            labels.push((text, b));
            label_colors.push(line.color);
        }
    }
    Ok(PanelLayout {
        frame: frame.rect,
        x: xs,
        y: ys,
        legend: legend_at.map(|(x, y)| Rect {
            x0: x,
            y0: y,
            x1: x + legend.width,
            y1: y + legend.height,
        }),
        marks,
        labels,
        label_colors,
        colors,
        markers,
        strokes,
        dots,
        notes,
        lines,
        sz,
        ticks_size: (ytick_w, tick_h, label_h),
        cell,
        legend_box: legend_at.map(|_| legend),
    })
}

fn note_row(sz: Sizes) -> f64 {
    1.3 * sz.legend
}

fn draw_panel<DB: DrawingBackend>(root: &Area<DB>, p: &Panel, lay: &PanelLayout) -> Result<()> {
    let sz = lay.sz;
    let (xs, ys) = (lay.x, lay.y);
    let frame = Frame {
        rect: lay.frame,
        x: xs,
        y: ys,
    };
    let r = frame.rect;

    // Bands about reference lines (a paper's tolerance) under everything, pale
    // tints of the line's colour; on a log axis the lower edge may leave it.
    let tint = |c: Option<Color>| {
        let RGBColor(r, g, b) = c.map_or(GREY, rgb);
        let pale = |v: u8| 255 - ((255 - v as u16) * 3 / 20) as u8;
        RGBColor(pale(r), pale(g), pale(b))
    };
    for l in &p.hlines {
        if let Some(w) = l.band {
            let at = |v: f64| {
                let f = if ys.log && v <= 0.0 {
                    -1.0
                } else {
                    ys.fraction(v)
                };
                (r.y1 - f.clamp(0.0, 1.0) * r.height()).clamp(r.y0, r.y1)
            };
            let (y0, y1) = (at(l.at + w), at(l.at - w));
            if y1 > y0 {
                let c = [px((r.x0, y0)), px((r.x1, y1))];
                root.draw(&Rectangle::new(c, tint(l.color).filled()))
                    .map_err(err)?;
            }
        }
    }
    for l in &p.vlines {
        if let Some(w) = l.band {
            let at = |v: f64| {
                let f = if xs.log && v <= 0.0 {
                    0.0
                } else {
                    xs.fraction(v)
                };
                (r.x0 + f.clamp(0.0, 1.0) * r.width()).clamp(r.x0, r.x1)
            };
            let (x0, x1) = (at(l.at - w), at(l.at + w));
            if x1 > x0 {
                let c = [px((x0, r.y0)), px((x1, r.y1))];
                root.draw(&Rectangle::new(c, tint(l.color).filled()))
                    .map_err(err)?;
            }
        }
    }
    // Reference lines under the data.
    for l in &p.hlines {
        let y = r.y1 - ys.fraction(l.at) * r.height();
        if y >= r.y0 && y <= r.y1 {
            let color = l.color.map_or(GREY, rgb);
            stroke(root, &[(r.x0, y), (r.x1, y)], color, 1, l.dashed, sz)?;
        }
    }
    for l in &p.vlines {
        let x = r.x0 + xs.fraction(l.at) * r.width();
        if x >= r.x0 && x <= r.x1 {
            let color = l.color.map_or(GREY, rgb);
            stroke(root, &[(x, r.y0), (x, r.y1)], color, 1, l.dashed, sz)?;
        }
    }

    // Fits and guides first, then the data's lines and bars, then every
    // marker: no line hides a point (paint::pass).
    for now in paint::PASSES {
        for (i, ((s, &c), &m)) in p
            .series
            .iter()
            .zip(&lay.colors)
            .zip(&lay.markers)
            .enumerate()
        {
            draw_series(root, &frame, s, rgb(c), m, i, sz, now)?;
        }
    }

    // Their labels where they cover no data, on white, so that no curve hides them.
    for ((text, b), c) in lay.labels.iter().zip(&lay.label_colors) {
        let color = c.map_or(GREY, rgb);
        let back = [px((b.x0 - 1.0, b.y0)), px((b.x1 + 1.0, b.y1))];
        root.draw(&Rectangle::new(back, WHITE.filled()))
            .map_err(err)?;
        let style = text_style(sz.legend, color, HPos::Left, VPos::Bottom);
        draw_text(root, text, &style, (b.x0, b.y1))?;
    }

    // The title sits above the notes, which sit on the frame, or on a legend
    // set above it.
    let top = lay
        .legend
        .filter(|l| l.y1 <= r.y0 + 0.5)
        .map_or(r.y0, |l| l.y0);
    let notes_h = lay.lines.len() as f64 * note_row(sz);
    draw_axes(
        root,
        &frame,
        p,
        sz,
        lay.ticks_size,
        lay.cell,
        notes_h + r.y0 - top,
    )?;
    let note_style = text_style(sz.legend, NOTE, HPos::Left, VPos::Bottom);
    let n = lay.lines.len();
    for (k, line) in lay.lines.iter().enumerate() {
        let y = top - 0.3 * sz.legend - (n - 1 - k) as f64 * note_row(sz);
        draw_text(root, line, &note_style, (r.x0, y))?;
    }
    if let (Some(lb), Some(at)) = (&lay.legend_box, lay.legend) {
        draw_legend(root, p, &lay.colors, &lay.markers, lb, (at.x0, at.y0), sz)?;
    }
    Ok(())
}

/// Whether point `i` of `s` is noise on a log y axis: its error exceeds its
/// value, so the point may as well be zero (drawn open).
fn noise(s: &Series, i: usize, y_log: bool) -> bool {
    let e = s.y_err.as_deref().and_then(|e| e.get(i)).copied();
    y_log && e.is_some_and(|e| e.is_finite() && e > s.y[i].abs())
}

/// The parts of a series painted in pass `now` (see [`paint::pass`]): error
/// bars and line, or markers (open where the point is noise).
#[allow(clippy::too_many_arguments)]
fn draw_series<DB: DrawingBackend>(
    area: &Area<DB>,
    f: &Frame,
    s: &Series,
    color: RGBColor,
    shape: Option<Marker>,
    phase: usize,
    sz: Sizes,
    now: u8,
) -> Result<()> {
    let r = f.rect;
    if pass(s, Part::Line) == now {
        let cap = 0.6 * sz.marker + 1.0;
        for (a, b, a_end, b_end) in f.bars(s) {
            polyline(area, &[a, b], color, 1)?;
            // A cap only where the bar ends, none where the frame cuts it.
            for (end, shown) in [(a, a_end), (b, b_end)] {
                if shown {
                    polyline(
                        area,
                        &[(end.0 - cap, end.1), (end.0 + cap, end.1)],
                        color,
                        1,
                    )?;
                }
            }
        }
        draw_shapes(area, f, s, color, sz)?;
        for piece in line_pieces(f, s) {
            stroke_dashed(area, &piece, color, line_width(s, sz), Dash::of(s), sz)?;
        }
    }
    let Some(shape) = shape.filter(|_| pass(s, Part::Marker) == now) else {
        return Ok(());
    };
    for (i, q) in marker_points(f, s, phase) {
        let m = if noise(s, i, f.y.log) {
            shape.hollow()
        } else {
            shape
        };
        debug_assert!(r.contains(q));
        marker(area, m, q, sz.marker, color)?;
    }
    Ok(())
}

/// The disks of style `disks` and the arrows of style `arrows`.
fn draw_shapes<DB: DrawingBackend>(
    area: &Area<DB>,
    f: &Frame,
    s: &Series,
    color: RGBColor,
    sz: Sizes,
) -> Result<()> {
    let r = f.rect;
    if s.style == Style::Disks {
        // Radius in pixels from the x scale: to scale when the panel's data
        // aspect matches its frame (a square box in a square frame).
        let radii = s.radius.as_deref().unwrap_or(&[]);
        for ((&x, &y), &rad) in s.x.iter().zip(&s.y).zip(radii) {
            let (Some(c), Some(e)) = (f.at(x, y), f.at(x + rad, y)) else {
                continue;
            };
            if r.contains(c) {
                let px_r = (e.0 - c.0).abs().max(1.0);
                area.draw(&Circle::new(px(c), px_r.round() as i32, color.filled()))
                    .map_err(err)?;
            }
        }
    }
    if s.style == Style::Arrows {
        let vectors = s.arrows.as_deref().unwrap_or(&[]);
        for ((&x, &y), &[dx, dy]) in s.x.iter().zip(&s.y).zip(vectors) {
            if let (Some(a), Some(b)) = (f.at(x, y), f.at(x + dx, y + dy))
                && r.contains(a)
            {
                arrow(area, a, b, color, sz)?;
            }
        }
    }
    Ok(())
}

/// Frame, inward ticks on all four sides, tick labels, axis labels, panel title
/// (`notes_h` above the frame, over the panel's notes).
fn draw_axes<DB: DrawingBackend>(
    area: &Area<DB>,
    f: &Frame,
    p: &Panel,
    sz: Sizes,
    (ytick_w, tick_h, label_h): (f64, f64, f64),
    cell: Rect,
    notes_h: f64,
) -> Result<()> {
    let r = f.rect;
    area.draw(&Rectangle::new(
        [px((r.x0, r.y0)), px((r.x1, r.y1))],
        INK.stroke_width(1),
    ))
    .map_err(err)?;
    let major = 0.45 * sz.label;
    let minor = 0.25 * sz.label;
    let tick_style = text_style(sz.tick, INK, HPos::Center, VPos::Top);
    for t in f.x.ticks() {
        let x = r.x0 + f.x.fraction(t.at) * r.width();
        let len = if t.label.is_some() { major } else { minor };
        polyline(area, &[(x, r.y1), (x, r.y1 - len)], INK, 1)?;
        polyline(area, &[(x, r.y0), (x, r.y0 + len)], INK, 1)?;
        if let Some(l) = &t.label {
            draw_text(area, l, &tick_style, (x, r.y1 + 0.4 * sz.tick))?;
        }
    }
    let tick_style = text_style(sz.tick, INK, HPos::Right, VPos::Center);
    for t in f.y.ticks() {
        let y = r.y1 - f.y.fraction(t.at) * r.height();
        let len = if t.label.is_some() { major } else { minor };
        polyline(area, &[(r.x0, y), (r.x0 + len, y)], INK, 1)?;
        polyline(area, &[(r.x1, y), (r.x1 - len, y)], INK, 1)?;
        if let Some(l) = &t.label {
            draw_text(area, l, &tick_style, (r.x0 - 0.4 * sz.tick, y))?;
        }
    }
    let label_style = text_style(sz.label, INK, HPos::Center, VPos::Top);
    let below = r.y1 + 0.4 * sz.tick + tick_h + 0.4 * sz.label;
    draw_text(area, &p.x.label, &label_style, ((r.x0 + r.x1) / 2.0, below))?;
    let ylabel_style =
        text_style(sz.label, INK, HPos::Center, VPos::Center).transform(FontTransform::Rotate270);
    let x = (r.x0 - 0.4 * sz.tick - ytick_w - 0.5 * sz.label - label_h / 2.0)
        .max(cell.x0 + label_h / 2.0);
    draw_text(area, &p.y.label, &ylabel_style, (x, (r.y0 + r.y1) / 2.0))?;
    let title_style = text_style(sz.label, INK, HPos::Left, VPos::Bottom);
    draw_text(
        area,
        &p.title,
        &title_style,
        (r.x0, r.y0 - 0.3 * sz.label - notes_h),
    )
}

#[cfg(test)]
mod tests {
    use super::spans;

    #[test]
    fn labels_split_into_sub_and_superscripts() {
        assert_eq!(
            spans("(φ_{c} − φ)^{−γ}"),
            vec![("(φ", 0), ("c", -1), (" − φ)", 0), ("−γ", 1)]
        );
        assert_eq!(spans("τ_{α}"), vec![("τ", 0), ("α", -1)]);
        // Names with underscores and unclosed braces print as written.
        assert_eq!(spans("tau_alpha"), vec![("tau_alpha", 0)]);
        assert_eq!(spans("x^{2"), vec![("x^{2", 0)]);
        assert!(spans("").is_empty());
    }
}
