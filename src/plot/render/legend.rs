//! The legend: its entries and size, where it goes (a free corner inside the
//! axes, or outside them), and drawing it.

use anyhow::Result;
use plotters::prelude::*;
use plotters::style::Color as _;
use plotters::style::text_anchor::{HPos, VPos};

use super::ink::*;
use super::labels::labelled_lines;
use super::paint::line_width;
use crate::plot::geometry::{P, Rect};
use crate::plot::spec::{Color, Legend, Marker, Panel, Style};

/// A legend entry: its text and the series it stands for (series sharing a
/// label share an entry, e.g. the points and the fitted curve of one phi).
#[derive(Clone, Debug)]
pub(super) struct Entry {
    pub(super) label: String,
    pub(super) series: Vec<usize>,
    /// A reference line's label, its line in the legend (no free place on
    /// the axes): colour and dashes.
    pub(super) line: Option<(Option<Color>, bool)>,
}

/// The legend's entries and measured size.
#[derive(Clone, Debug)]
pub(super) struct LegendBox {
    pub(super) entries: Vec<Entry>,
    pub(super) row: f64,
    pub(super) sample: f64,
    pub(super) width: f64,
    pub(super) height: f64,
}

/// The legend's entries, with the labels of the reference lines `lines`
/// (indices into [`labelled_lines`]), and its size.
pub(super) fn measure_legend<DB: DrawingBackend>(
    area: &Area<DB>,
    p: &Panel,
    sz: Sizes,
    lines: &[usize],
) -> Result<LegendBox> {
    let mut entries: Vec<Entry> = vec![];
    for (i, s) in p
        .series
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.label.is_empty() && p.legend != Legend::None)
    {
        match entries.iter_mut().find(|e| e.label == s.label) {
            Some(e) => e.series.push(i),
            None => entries.push(Entry {
                label: s.label.clone(),
                series: vec![i],
                line: None,
            }),
        }
    }
    // Group values in order of value, even when they come from several layers
    // (one ensemble per eps); the other entries after them, as given.
    let key = |e: &Entry| {
        // A shared style's entry (legend_ink) names no one value.
        let group = e
            .series
            .first()
            .filter(|&&i| !p.series[i].legend_ink)
            .and_then(|&i| p.series[i].group.as_ref());
        group
            .map(|g| g.value)
            .or_else(|| e.label.trim().parse::<f64>().ok())
    };
    entries.sort_by(|a, b| match (key(a), key(b)) {
        (Some(x), Some(y)) => x.total_cmp(&y),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => std::cmp::Ordering::Equal,
    });
    for (l, _) in labelled_lines(p)
        .into_iter()
        .enumerate()
        .filter(|(k, _)| lines.contains(k))
        .map(|(_, l)| l)
    {
        entries.push(Entry {
            label: l.label.clone(),
            series: vec![],
            line: Some((l.color, l.dashed)),
        });
    }
    let row = 1.35 * sz.legend;
    // A dashed sample shows its dash at the middle (under a marker) with a
    // gap and half a dash on either side; a solid one is shorter.
    let dashed = entries.iter().flat_map(|e| &e.series).any(|&i| {
        (p.series[i].dashed || p.series[i].dotted) && !matches!(p.series[i].style, Style::Points)
    }) || entries.iter().any(|e| e.line.is_some_and(|l| l.1));
    let (on, off) = dash_pattern(sz.line, sz);
    let sample = if dashed {
        (2.0 * on + 2.0 * off).max(2.2 * sz.legend)
    } else {
        2.2 * sz.legend
    };
    let mut text_w: f64 = text_size(area, &p.legend_title, sz.legend)?.0 - sample - 0.4 * sz.legend;
    for e in &entries {
        text_w = text_w.max(text_size(area, &e.label, sz.legend)?.0);
    }
    let rows = entries.len() + usize::from(!p.legend_title.is_empty());
    Ok(LegendBox {
        width: 0.5 * sz.legend + sample + 0.4 * sz.legend + text_w + 0.6 * sz.legend,
        height: rows as f64 * row + 0.5 * sz.legend,
        entries,
        row,
        sample,
    })
}

/// Shrink the axes to make room for the legend beside them (on the right) or,
/// `above`, over them at their left edge.
pub(super) fn outside_legend(
    frame: impl Fn(Rect) -> Frame,
    inside: Rect,
    legend: &LegendBox,
    sz: Sizes,
    above: bool,
) -> (Frame, Option<P>) {
    let gap = 0.6 * sz.label;
    let mut rect = inside;
    let at = if above {
        rect.y0 += legend.height + gap;
        (inside.x0, inside.y0)
    } else {
        rect.x1 -= legend.width + gap;
        (rect.x1 + gap, rect.y0)
    };
    (frame(rect), Some(at))
}

pub(super) fn corner_position(r: &Rect, corner: Legend, legend: &LegendBox, sz: Sizes) -> P {
    let m = 0.5 * sz.label;
    let left = r.x0 + m;
    let right = r.x1 - m - legend.width;
    let top = r.y0 + m;
    let bottom = r.y1 - m - legend.height;
    match corner {
        Legend::TopLeft => (left, top),
        Legend::BottomLeft => (left, bottom),
        Legend::BottomRight => (right, bottom),
        _ => (right, top),
    }
}

/// The first of `order`'s inside corners whose legend box covers none of
/// `taken`, if the legend fits at all.
pub(super) fn free_corner(
    f: &Frame,
    order: &[Legend],
    taken: &[P],
    legend: &LegendBox,
    sz: Sizes,
) -> Option<P> {
    let r = f.rect;
    if legend.width > 0.8 * r.width() || legend.height > 0.9 * r.height() {
        return None;
    }
    let pad = sz.marker + 1.0;
    order
        .iter()
        .map(|&c| corner_position(&r, c, legend, sz))
        .find(|&(x, y)| {
            let b = Rect {
                x0: x - pad,
                y0: y - pad,
                x1: x + legend.width + pad,
                y1: y + legend.height + pad,
            };
            !taken.iter().any(|&q| b.contains(q))
        })
}

/// The distinct colours of an entry's series, in order.
fn entry_colors(e: &Entry, colors: &[Color]) -> Vec<Color> {
    let mut out: Vec<Color> = vec![];
    for &i in &e.series {
        if !out.contains(&colors[i]) {
            out.push(colors[i]);
        }
    }
    out
}

/// Each entry's sample is drawn as its series are: the line of the first
/// drawn as a line (its dashes), the marker of the first drawn with markers,
/// in the series' colour; an entry standing for series of several colours
/// (one style, e.g. the power law of every eps) shows the style in each of
/// them in turn.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &Area<DB>,
    p: &Panel,
    colors: &[Color],
    markers: &[Option<Marker>],
    lb: &LegendBox,
    (x, y): P,
    sz: Sizes,
) -> Result<()> {
    let box_style = RGBColor(0xb0, 0xb0, 0xb0).stroke_width(1);
    let corners = [px((x, y)), px((x + lb.width, y + lb.height))];
    area.draw(&Rectangle::new(corners, WHITE.filled()))
        .map_err(err)?;
    area.draw(&Rectangle::new(corners, box_style))
        .map_err(err)?;
    let style = text_style(sz.legend, INK, HPos::Left, VPos::Center);
    let x_sample = x + 0.5 * sz.legend;
    let x_text = x_sample + lb.sample + 0.4 * sz.legend;
    let mut row_y = y + 0.25 * sz.legend + lb.row / 2.0;
    if !p.legend_title.is_empty() {
        draw_text(area, &p.legend_title, &style, (x_sample, row_y))?;
        row_y += lb.row;
    }
    for e in &lb.entries {
        if let Some((c, dashed)) = e.line {
            let color = c.map_or(GREY, rgb);
            let ends = [(x_sample, row_y), (x_sample + lb.sample, row_y)];
            stroke(area, &ends, color, 1, dashed, sz)?;
            draw_text(area, &e.label, &style, (x_text, row_y))?;
            row_y += lb.row;
            continue;
        }
        let shades: Vec<RGBColor> = entry_colors(e, colors).into_iter().map(rgb).collect();
        let line = e.series.iter().find(|&&i| {
            !matches!(
                p.series[i].style,
                Style::Points | Style::Disks | Style::Arrows
            )
        });
        if let Some(&i) = line {
            let s = &p.series[i];
            let width = line_width(s, sz);
            let ends = [(x_sample, row_y), (x_sample + lb.sample, row_y)];
            let pieces = if Dash::of(s) == Dash::Dashed {
                // Half a dash, a gap, a dash (under the marker), a gap, half
                // a dash: both gaps show beside the marker.
                let (on, off) = dash_pattern(width, sz);
                let at = |d: f64| (x_sample + d.min(lb.sample), row_y);
                let (a, b) = (0.5 * on, 0.5 * on + off);
                vec![
                    vec![at(0.0), at(a)],
                    vec![at(b), at(b + on)],
                    vec![at(b + on + off), at(lb.sample)],
                ]
            } else if Dash::of(s) == Dash::Dotted {
                pieces(&ends, Dash::Dotted, width, sz)
            } else if shades.len() > 1 {
                let n = shades.len() as f64;
                (0..shades.len())
                    .map(|k| {
                        let at = |f: f64| (x_sample + f * lb.sample, row_y);
                        vec![at(k as f64 / n), at((k as f64 + 1.0) / n)]
                    })
                    .collect()
            } else {
                vec![ends.to_vec()]
            };
            for (k, d) in pieces.iter().enumerate() {
                let c = if shades.len() > 1 {
                    shades[k % shades.len()]
                } else {
                    rgb(colors[i])
                };
                stroke_dashed(area, d, c, width, Dash::Solid, sz)?;
            }
        }
        let arrows = e
            .series
            .iter()
            .find(|&&i| p.series[i].style == Style::Arrows);
        let dots = e
            .series
            .iter()
            .find(|&&i| markers[i].is_some() && p.series[i].style != Style::Arrows);
        if let Some(&i) = arrows {
            let to = (x_sample + lb.sample, row_y);
            arrow(area, (x_sample, row_y), to, rgb(colors[i]), sz)?;
        } else if let Some(&i) = dots {
            let m = markers[i].expect("found with a marker");
            let dotted: Vec<RGBColor> = e
                .series
                .iter()
                .filter(|&&j| markers[j] == Some(m))
                .map(|&j| rgb(colors[j]))
                .fold(vec![], |mut v, c| {
                    if !v.contains(&c) {
                        v.push(c);
                    }
                    v
                });
            let n = dotted.len();
            for (k, c) in dotted.into_iter().enumerate() {
                let f = (k as f64 + 0.5) / n as f64;
                let at = (x_sample + f * lb.sample, row_y);
                marker(area, m, at, sz.marker, c)?;
            }
        }
        draw_text(area, &e.label, &style, (x_text, row_y))?;
        row_y += lb.row;
    }
    Ok(())
}
