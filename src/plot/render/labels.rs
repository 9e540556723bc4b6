//! Labels of reference lines: the points a label must not cover (markers,
//! curves, bars) and where each label goes, beside its line where it covers no
//! data, else into the legend.

use anyhow::Result;
use plotters::prelude::*;

use super::ink::*;
use crate::plot::geometry::{P, Rect, clip_polyline};
use crate::plot::spec::{Panel, Style};

/// Points every two pixels along the polyline.
fn along(piece: &[P], out: &mut Vec<P>) {
    out.extend(piece.first());
    for w in piece.windows(2) {
        let len = (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1);
        let n = (len / 2.0).ceil().clamp(1.0, 1e5) as usize;
        out.extend((1..=n).map(|k| {
            let t = k as f64 / n as f64;
            (
                w[0].0 + t * (w[1].0 - w[0].0),
                w[0].1 + t * (w[1].1 - w[0].1),
            )
        }));
    }
}

/// Pixel samples of the data a panel draws inside its axes: markers, lines
/// and error bars every two pixels.
pub(super) fn marks(f: &Frame, p: &Panel) -> Vec<P> {
    let r = f.rect;
    let mut out: Vec<P> = Vec::new();
    for s in &p.series {
        let pts = f.points(s);
        out.extend(pts.iter().flatten().filter(|&&q| r.contains(q)));
        if !matches!(s.style, Style::Points | Style::Disks | Style::Arrows) {
            for piece in clip_polyline(&pts, &r) {
                along(&piece, &mut out);
            }
        }
        for (a, b, _, _) in f.bars(s) {
            along(&[a, b], &mut out);
        }
    }
    out
}

/// Samples every three pixels over `b`, so that a legend avoids it.
pub(super) fn fill_rect(b: &Rect, out: &mut Vec<P>) {
    let (nx, ny) = (
        (b.width() / 3.0).ceil() as usize,
        (b.height() / 3.0).ceil() as usize,
    );
    for i in 0..=nx {
        for j in 0..=ny {
            out.push((
                b.x0 + b.width() * i as f64 / nx.max(1) as f64,
                b.y0 + b.height() * j as f64 / ny.max(1) as f64,
            ));
        }
    }
}

/// The reference lines with a label, hlines (true) then vlines.
pub(in crate::plot) fn labelled_lines(p: &Panel) -> Vec<(&crate::plot::spec::RefLine, bool)> {
    p.hlines
        .iter()
        .map(|l| (l, true))
        .chain(p.vlines.iter().map(|l| (l, false)))
        .filter(|(l, _)| !l.label.is_empty())
        .collect()
}

/// Where each labelled reference line's label goes (hlines, then vlines; None
/// for a line outside the axes or a label in `skip`, which the legend holds):
/// the first place along the line, at either end or the middle, on either
/// side, whose box covers none of `taken` nor an earlier label, and whether
/// every place covers some (the first place is then taken).
pub(super) fn ref_labels<DB: DrawingBackend>(
    area: &Area<DB>,
    f: &Frame,
    p: &Panel,
    sz: Sizes,
    taken: &[P],
    skip: &[usize],
) -> Result<Vec<Option<(String, Rect, bool)>>> {
    let r = f.rect;
    let (gap, inset) = (0.2 * sz.legend, 0.4 * sz.legend);
    let mut out: Vec<Option<(String, Rect, bool)>> = vec![];
    for (k, (l, horizontal)) in labelled_lines(p).into_iter().enumerate() {
        let at = if horizontal {
            r.y1 - f.y.fraction(l.at) * r.height()
        } else {
            r.x0 + f.x.fraction(l.at) * r.width()
        };
        let inside = if horizontal {
            (r.y0..=r.y1).contains(&at)
        } else {
            (r.x0..=r.x1).contains(&at)
        };
        if !inside || skip.contains(&k) {
            out.push(None);
            continue;
        }
        let (w, h) = text_size(area, &l.label, sz.legend)?;
        let places: Vec<P> = if horizontal {
            let (above, below) = (at - gap - h, at + gap);
            let (right, left, mid) = (r.x1 - inset - w, r.x0 + inset, (r.x0 + r.x1 - w) / 2.0);
            vec![
                (right, above),
                (left, above),
                (right, below),
                (left, below),
                (mid, above),
                (mid, below),
            ]
        } else {
            let (right, left) = (at + 0.3 * sz.legend, at - 0.3 * sz.legend - w);
            let (top, bottom, mid) = (r.y0 + inset, r.y1 - inset - h, (r.y0 + r.y1 - h) / 2.0);
            vec![
                (right, top),
                (left, top),
                (right, bottom),
                (left, bottom),
                (right, mid),
                (left, mid),
            ]
        };
        let boxes: Vec<Rect> = places
            .into_iter()
            .map(|(x0, y0)| Rect {
                x0,
                y0,
                x1: x0 + w,
                y1: y0 + h,
            })
            .filter(|b| b.x0 >= r.x0 && b.x1 <= r.x1 && b.y0 >= r.y0 && b.y1 <= r.y1)
            .collect();
        let earlier: Vec<Rect> = out.iter().flatten().map(|l| l.1).collect();
        let free = |b: &Rect| {
            !taken.iter().any(|&q| b.contains(q)) && !earlier.iter().any(|e| e.overlaps(b))
        };
        out.push(match boxes.iter().find(|b| free(b)) {
            Some(&b) => Some((l.label.clone(), b, false)),
            None => boxes.first().map(|&b| (l.label.clone(), b, true)),
        });
    }
    Ok(out)
}
