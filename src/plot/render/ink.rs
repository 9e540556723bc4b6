//! What every part of a drawing is made of: fonts and inks, sizes from a
//! panel's cell, text with sub- and superscripts, lines, arrows and markers,
//! and the frame that maps data to pixels.

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::Color as _;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::plot::geometry::{P, Rect, clip_segment, dashes};
use crate::plot::scale::Scale;
use crate::plot::spec::{Color, Marker, Series};

pub(super) const FONT: &str = "sans-serif";
pub(super) const INK: RGBColor = RGBColor(0, 0, 0);
pub(super) const GREY: RGBColor = RGBColor(0x80, 0x80, 0x80);
/// Notes above the axes: dark enough to read, apart from the data's ink.
pub(super) const NOTE: RGBColor = RGBColor(0x40, 0x40, 0x40);

pub(super) type Area<DB> = DrawingArea<DB, Shift>;

pub(super) fn err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> anyhow::Error {
    anyhow!("drawing failed: {e}")
}

pub(super) fn rgb(c: Color) -> RGBColor {
    RGBColor(c.0[0], c.0[1], c.0[2])
}

pub(super) fn px(p: P) -> (i32, i32) {
    (p.0.round() as i32, p.1.round() as i32)
}

/// Sizes derived from the font size of one panel.
#[derive(Clone, Copy, Debug)]
pub(super) struct Sizes {
    pub(super) label: f64,
    pub(super) tick: f64,
    pub(super) legend: f64,
    pub(super) line: u32,
    pub(super) marker: f64,
}

impl Sizes {
    pub(super) fn for_cell(w: f64, h: f64) -> Sizes {
        // From the cell's area: a wide, low panel (a field over a long box)
        // keeps labels as large as a square one of the same area.
        let label = ((w * h).sqrt() / 30.0).clamp(11.0, 22.0);
        Sizes {
            label,
            tick: 0.85 * label,
            legend: 0.78 * label,
            line: if label >= 14.0 { 2 } else { 1 },
            marker: 0.24 * label,
        }
    }
}

pub(super) fn text_style(size: f64, color: RGBColor, h: HPos, v: VPos) -> TextStyle<'static> {
    (FONT, size).into_font().color(&color).pos(Pos::new(h, v))
}

/// Label markup: `_{...}` is a subscript, `^{...}` a superscript (braces
/// required, so names with underscores print as written). Returns the pieces
/// with their level: 0 on the line, -1 below, 1 above.
pub(in crate::plot) fn spans(text: &str) -> Vec<(&str, i8)> {
    let mut out = vec![];
    let mut rest = text;
    while !rest.is_empty() {
        let next = [("_{", -1), ("^{", 1)]
            .into_iter()
            .filter_map(|(m, l)| rest.find(m).map(|i| (i, l)))
            .min();
        let Some((i, level)) = next else {
            out.push((rest, 0));
            break;
        };
        let Some(len) = rest[i + 2..].find('}') else {
            out.push((rest, 0));
            break;
        };
        if i > 0 {
            out.push((&rest[..i], 0));
        }
        out.push((&rest[i + 2..i + 2 + len], level));
        rest = &rest[i + 3 + len..];
    }
    out
}

/// Sub- and superscripts are set at this fraction of the text size.
pub(super) const SCRIPT: f64 = 0.7;

pub(super) fn text_size<DB: DrawingBackend>(
    area: &Area<DB>,
    text: &str,
    size: f64,
) -> Result<(f64, f64)> {
    let (mut w, mut h) = (0.0, 0.0);
    for (piece, level) in spans(text) {
        if piece.is_empty() {
            continue;
        }
        let k = if level == 0 { size } else { SCRIPT * size };
        let (pw, ph) = area
            .estimate_text_size(piece, &TextStyle::from((FONT, k).into_font()))
            .map_err(err)?;
        w += pw as f64;
        let lift = if level == 0 { 0.0 } else { 0.35 * size };
        h = f64::max(h, ph as f64 + lift);
    }
    Ok((w, h))
}

/// Draw `text` (with its sub- and superscripts) anchored at `at` as `style` says;
/// y labels turned by 270 degrees run up the page.
pub(super) fn draw_text<DB: DrawingBackend>(
    area: &Area<DB>,
    text: &str,
    style: &TextStyle,
    at: P,
) -> Result<()> {
    let pieces = spans(text);
    if pieces.iter().all(|p| p.1 == 0) {
        if text.is_empty() {
            return Ok(());
        }
        return area.draw_text(text, style, px(at)).map_err(err);
    }
    let size = style.font.get_size();
    let turned = matches!(style.font.get_transform(), FontTransform::Rotate270);
    let total = text_size(area, text, size)?.0;
    let mut along = match style.pos.h_pos {
        HPos::Left => 0.0,
        HPos::Center => -total / 2.0,
        HPos::Right => -total,
    };
    for (piece, level) in pieces {
        if piece.is_empty() {
            continue;
        }
        let k = if level == 0 { size } else { SCRIPT * size };
        let up = match level {
            1 => 0.4 * size,
            -1 => -0.2 * size,
            _ => 0.0,
        };
        let piece_style = TextStyle {
            font: style.font.resize(k),
            color: style.color,
            pos: Pos::new(HPos::Left, style.pos.v_pos),
        };
        let p = if turned {
            (at.0 - up, at.1 - along)
        } else {
            (at.0 + along, at.1 - up)
        };
        area.draw_text(piece, &piece_style, px(p)).map_err(err)?;
        along += text_size(area, piece, k)?.0;
    }
    Ok(())
}

pub(super) fn polyline<DB: DrawingBackend>(
    area: &Area<DB>,
    pts: &[P],
    color: RGBColor,
    width: u32,
) -> Result<()> {
    if width <= 1 {
        let style = ShapeStyle::from(&color).stroke_width(width);
        return area
            .draw(&PathElement::new(
                pts.iter().map(|&p| px(p)).collect::<Vec<_>>(),
                style,
            ))
            .map_err(err);
    }
    // A wide line as one filled quadrilateral per segment and a disk at each
    // joint: plotters' bitmap backend widens a path vertically only, so steep
    // segments came out one pixel thin (chi4(t) rising to its peak).
    let h = width as f64 / 2.0;
    let fill = color.filled();
    for w in pts.windows(2) {
        let ((ax, ay), (bx, by)) = (w[0], w[1]);
        let len = (bx - ax).hypot(by - ay);
        if !(len > 0.0) {
            continue;
        }
        let (nx, ny) = (-(by - ay) / len * h, (bx - ax) / len * h);
        let quad = vec![
            px((ax + nx, ay + ny)),
            px((bx + nx, by + ny)),
            px((bx - nx, by - ny)),
            px((ax - nx, ay - ny)),
        ];
        area.draw(&Polygon::new(quad, fill)).map_err(err)?;
    }
    if pts.len() > 2 {
        for &p in &pts[1..pts.len() - 1] {
            area.draw(&Circle::new(px(p), h.round() as i32, fill))
                .map_err(err)?;
        }
    }
    Ok(())
}

/// Where data goes on screen.
pub(super) struct Frame {
    pub(super) rect: Rect,
    pub(super) x: Scale,
    pub(super) y: Scale,
}

impl Frame {
    pub(super) fn at(&self, x: f64, y: f64) -> Option<P> {
        if !(self.x.accepts(x) && self.y.accepts(y)) {
            return None;
        }
        let p = (
            self.rect.x0 + self.x.fraction(x) * self.rect.width(),
            self.rect.y1 - self.y.fraction(y) * self.rect.height(),
        );
        // An axis spanning more than f64 can hold (data near f64::MAX) maps to NaN.
        (p.0.is_finite() && p.1.is_finite()).then_some(p)
    }

    pub(super) fn points(&self, s: &Series) -> Vec<Option<P>> {
        s.x.iter().zip(&s.y).map(|(&x, &y)| self.at(x, y)).collect()
    }

    /// The drawn part of each error bar of `s`, in pixels, and whether its far
    /// end is drawn (false where the frame or a log axis cuts it).
    pub(super) fn bars(&self, s: &Series) -> Vec<(P, P, bool, bool)> {
        let r = self.rect;
        let Some(errs) = &s.y_err else {
            return vec![];
        };
        let mut out = vec![];
        for ((&x, &y), &e) in s.x.iter().zip(&s.y).zip(errs) {
            let (Some(mid), true) = (self.at(x, y), e.is_finite() && e > 0.0) else {
                continue;
            };
            // A bar reaching to or below zero on a log axis has no lower end.
            let lo = self.at(x, y - e).map_or(r.y1 + 1.0, |p| p.1);
            let hi = self.at(x, y + e).map_or(r.y0 - 1.0, |p| p.1);
            if let Some((a, b)) = clip_segment((mid.0, lo), (mid.0, hi), &r) {
                out.push((a, b, a.1 == lo, b.1 == hi));
            }
        }
        out
    }
}

/// A solid or dashed polyline.
pub(super) fn stroke<DB: DrawingBackend>(
    area: &Area<DB>,
    line: &[P],
    color: RGBColor,
    width: u32,
    dashed: bool,
    sz: Sizes,
) -> Result<()> {
    let dash = if dashed { Dash::Dashed } else { Dash::Solid };
    stroke_dashed(area, line, color, width, dash, sz)
}

/// The dash and gap lengths of a dashed line `width` pixels wide.
pub(super) fn dash_pattern(width: u32, sz: Sizes) -> (f64, f64) {
    let w = width as f64;
    (0.45 * sz.label + 2.0 * w, 0.25 * sz.label + w)
}

/// The dot and gap lengths of a dotted line `width` pixels wide.
pub(super) fn dot_pattern(width: u32) -> (f64, f64) {
    let w = width as f64;
    (w.max(1.5), 2.0 * w + 2.0)
}

/// How a series' line is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Dash {
    Solid,
    Dashed,
    Dotted,
}

impl Dash {
    pub(super) fn of(s: &Series) -> Dash {
        match (s.dotted, s.dashed) {
            (true, _) => Dash::Dotted,
            (false, true) => Dash::Dashed,
            _ => Dash::Solid,
        }
    }
}

/// `line` cut into its dashes (or dots), or whole when solid.
pub(super) fn pieces(line: &[P], dash: Dash, width: u32, sz: Sizes) -> Vec<Vec<P>> {
    match dash {
        Dash::Solid => vec![line.to_vec()],
        Dash::Dashed => {
            let (on, off) = dash_pattern(width, sz);
            dashes(line, on, off)
        }
        Dash::Dotted => {
            let (on, off) = dot_pattern(width);
            dashes(line, on, off)
        }
    }
}

/// A solid, dashed or dotted polyline.
pub(super) fn stroke_dashed<DB: DrawingBackend>(
    area: &Area<DB>,
    line: &[P],
    color: RGBColor,
    width: u32,
    dash: Dash,
    sz: Sizes,
) -> Result<()> {
    let pieces = pieces(line, dash, width, sz);
    for d in &pieces {
        polyline(area, d, color, width)?;
    }
    Ok(())
}

/// A line from `a` to `b` (pixels) with a filled head at `b` scaled to its
/// length (at most a marker's size), so short vectors stay arrows.
pub(super) fn arrow<DB: DrawingBackend>(
    area: &Area<DB>,
    a: P,
    b: P,
    color: RGBColor,
    sz: Sizes,
) -> Result<()> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = dx.hypot(dy);
    if len < 0.5 {
        return Ok(());
    }
    polyline(area, &[a, b], color, 1)?;
    let head = (0.35 * len).min(sz.marker);
    let (ux, uy) = (dx / len, dy / len);
    let base = (b.0 - head * ux, b.1 - head * uy);
    let half = 0.5 * head;
    let tri = vec![
        px(b),
        px((base.0 - half * uy, base.1 + half * ux)),
        px((base.0 + half * uy, base.1 - half * ux)),
    ];
    area.draw(&Polygon::new(tri, color.filled())).map_err(err)?;
    Ok(())
}

pub(super) fn marker<DB: DrawingBackend>(
    area: &Area<DB>,
    m: Marker,
    (x, y): P,
    size: f64,
    color: RGBColor,
) -> Result<()> {
    // An open marker is its outline alone: a fit drawn beneath it (fig8's
    // tails through their points) shows through.
    let fill = (!m.open()).then(|| ShapeStyle::from(&color).filled());
    let line = ShapeStyle::from(&color).stroke_width(1);
    let s = size.max(2.0);
    let poly = |pts: &[P]| {
        pts.iter()
            .map(|&(dx, dy)| px((x + dx * s, y + dy * s)))
            .collect::<Vec<_>>()
    };
    // A filled polygon with its outline (the outline alone when open).
    let shape = |pts: Vec<P>| -> Result<()> {
        let v = poly(&pts);
        if let Some(fill) = fill {
            area.draw(&Polygon::new(v.clone(), fill)).map_err(err)?;
        }
        let mut closed = v;
        closed.push(closed[0]);
        area.draw(&PathElement::new(closed, line)).map_err(err)
    };
    let regular = |k: usize, r: f64, turn: f64| -> Vec<P> {
        (0..k)
            .map(|i| {
                let a = turn + std::f64::consts::TAU * i as f64 / k as f64;
                (r * a.sin(), -r * a.cos())
            })
            .collect()
    };
    match m.filled() {
        Marker::Circle | Marker::Auto => {
            let c = px((x, y));
            let r = s.round() as i32;
            if let Some(fill) = fill {
                area.draw(&Circle::new(c, r, fill)).map_err(err)?;
            }
            area.draw(&Circle::new(c, r, line)).map_err(err)
        }
        Marker::Square => shape(vec![(-0.9, -0.9), (0.9, -0.9), (0.9, 0.9), (-0.9, 0.9)]),
        Marker::Triangle => shape(vec![(0.0, -1.3), (1.15, 0.7), (-1.15, 0.7)]),
        Marker::TriangleDown => shape(vec![(0.0, 1.3), (1.15, -0.7), (-1.15, -0.7)]),
        Marker::Diamond => shape(vec![(0.0, -1.3), (1.0, 0.0), (0.0, 1.3), (-1.0, 0.0)]),
        Marker::Pentagon => shape(regular(5, 1.15, 0.0)),
        Marker::Star => {
            let outer = regular(5, 1.5, 0.0);
            let inner = regular(5, 0.62, std::f64::consts::PI / 5.0);
            shape(
                outer
                    .into_iter()
                    .zip(inner)
                    .flat_map(|(a, b)| [a, b])
                    .collect(),
            )
        }
        Marker::Cross => area
            .draw(&PathElement::new(
                poly(&[(-1.0, -1.0), (1.0, 1.0)]),
                line.stroke_width(2),
            ))
            .and_then(|_| {
                area.draw(&PathElement::new(
                    poly(&[(-1.0, 1.0), (1.0, -1.0)]),
                    line.stroke_width(2),
                ))
            })
            .map_err(err),
        Marker::Plus => area
            .draw(&PathElement::new(
                poly(&[(-1.2, 0.0), (1.2, 0.0)]),
                line.stroke_width(2),
            ))
            .and_then(|_| {
                area.draw(&PathElement::new(
                    poly(&[(0.0, -1.2), (0.0, 1.2)]),
                    line.stroke_width(2),
                ))
            })
            .map_err(err),
        _ => unreachable!("filled() gives a filled shape"),
    }
}
