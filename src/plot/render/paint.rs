//! In what order and at what width a panel's parts are painted, one rule for
//! the drawing and for the layout check: fits and guides first and thinner,
//! then the data's lines and error bars, then every marker, so that no line
//! hides a point.

use super::ink::{Frame, Sizes};
use crate::plot::geometry::{P, clip_polyline};
use crate::plot::spec::{Marker, Panel, Series, Style};

/// A part of a series as painted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Part {
    /// Its line and error bars (a fit's or guide's line alone).
    Line,
    Marker,
}

/// The passes, in painting order.
pub(super) const PASSES: [u8; 3] = [0, 1, 2];

/// The pass that paints `part` of `s`: fits and guides under the data,
/// the data's lines and bars under every marker.
pub(super) fn pass(s: &Series, part: Part) -> u8 {
    match part {
        Part::Line if s.fit => 0,
        Part::Line => 1,
        Part::Marker => 2,
    }
}

/// The width of the line of `s` in pixels: a fit or guide a pixel thinner
/// than the data (at least one), so it reads as drawn beneath them.
pub(super) fn line_width(s: &Series, sz: Sizes) -> u32 {
    if s.fit {
        sz.line.saturating_sub(1).max(1)
    } else {
        sz.line
    }
}

/// The radius of a marker of `sz` in pixels, as drawn.
pub(super) fn marker_radius(sz: Sizes) -> f64 {
    sz.marker.max(2.0)
}

/// The points of a line that carry its markers: about eight, shifted by
/// `phase` so that curves running together do not stack them.
fn sparse_points(n: usize, phase: usize) -> impl Iterator<Item = usize> {
    let step = (n / 8).max(1);
    let first = (phase * step.div_ceil(3)) % step;
    (first..n).step_by(step)
}

/// The indices and pixel positions of the markers `s` draws inside the
/// frame: every point, or about eight of a line (a family line's shape).
pub(super) fn marker_points(f: &Frame, s: &Series, phase: usize) -> Vec<(usize, P)> {
    if matches!(s.style, Style::Disks | Style::Arrows) {
        return vec![];
    }
    let pts = f.points(s);
    let at: Vec<usize> = if s.style == Style::Line {
        sparse_points(pts.len(), phase).collect()
    } else {
        (0..pts.len()).collect()
    };
    at.into_iter()
        .filter_map(|i| pts[i].filter(|&q| f.rect.contains(q)).map(|q| (i, q)))
        .collect()
}

/// The pieces of the line of `s` inside the frame (none for points, disks
/// and arrows).
pub(super) fn line_pieces(f: &Frame, s: &Series) -> Vec<Vec<P>> {
    if matches!(s.style, Style::Points | Style::Disks | Style::Arrows) {
        return vec![];
    }
    clip_polyline(&f.points(s), &f.rect)
}

/// A line as painted: its pixel polyline, width and pass.
#[derive(Clone, Debug)]
pub struct Stroke {
    /// Index of its series in the panel.
    pub series: usize,
    pub line: Vec<P>,
    pub width: f64,
    pub pass: u8,
}

/// A marker as painted: centre, radius in pixels and pass.
#[derive(Clone, Debug)]
pub struct Dot {
    pub series: usize,
    pub at: P,
    pub radius: f64,
    pub pass: u8,
}

/// Every line and marker of panel `p` as painted in `f`, for the check of
/// markers hidden under lines.
pub(super) fn plan(
    f: &Frame,
    p: &Panel,
    markers: &[Option<Marker>],
    sz: Sizes,
) -> (Vec<Stroke>, Vec<Dot>) {
    let (mut strokes, mut dots) = (vec![], vec![]);
    for (i, (s, m)) in p.series.iter().zip(markers).enumerate() {
        let line = pass(s, Part::Line);
        for piece in line_pieces(f, s) {
            let width = line_width(s, sz) as f64;
            strokes.push(Stroke {
                series: i,
                line: piece,
                width,
                pass: line,
            });
        }
        for (a, b, _, _) in f.bars(s) {
            strokes.push(Stroke {
                series: i,
                line: vec![a, b],
                width: 1.0,
                pass: line,
            });
        }
        if m.is_some() {
            for (_, at) in marker_points(f, s, i) {
                dots.push(Dot {
                    series: i,
                    at,
                    radius: marker_radius(sz),
                    pass: pass(s, Part::Marker),
                });
            }
        }
    }
    (strokes, dots)
}
