//! Pixel-space geometry: clipping polylines to the axes box and cutting dashes.
//! plotters does not clip, so data beyond a fixed axis range would spill over labels.

/// A point in pixels (y grows downwards).
pub type P = (f64, f64);

/// An axis-aligned rectangle in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    pub fn contains(&self, (x, y): P) -> bool {
        x >= self.x0 - 0.5 && x <= self.x1 + 0.5 && y >= self.y0 - 0.5 && y <= self.y1 + 0.5
    }
    /// Whether the two boxes share some area.
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }
    pub fn height(&self) -> f64 {
        self.y1 - self.y0
    }
}

/// The part of segment a-b inside `r` (Liang-Barsky), if any.
pub fn clip_segment(a: P, b: P, r: &Rect) -> Option<(P, P)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - r.x0),
        (dx, r.x1 - a.0),
        (-dy, a.1 - r.y0),
        (dy, r.y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some((
        (a.0 + t0 * dx, a.1 + t0 * dy),
        (a.0 + t1 * dx, a.1 + t1 * dy),
    ))
}

/// Clip a polyline (None entries break it) to `r`: the visible pieces.
pub fn clip_polyline(points: &[Option<P>], r: &Rect) -> Vec<Vec<P>> {
    let mut out: Vec<Vec<P>> = Vec::new();
    let mut open = false;
    for w in points.windows(2) {
        let (Some(a), Some(b)) = (w[0], w[1]) else {
            open = false;
            continue;
        };
        match clip_segment(a, b, r) {
            Some((c, d)) => {
                // Continue the current piece when this segment starts where it ended.
                if !(open && c == a) {
                    out.push(vec![c]);
                }
                out.last_mut().expect("a piece was pushed").push(d);
                open = d == b;
            }
            None => open = false,
        }
    }
    out
}

/// Cut a polyline into dashes of length `on` separated by gaps `off` (pixels).
pub fn dashes(line: &[P], on: f64, off: f64) -> Vec<Vec<P>> {
    let mut out = Vec::new();
    let mut current: Vec<P> = Vec::new();
    let (mut drawing, mut left) = (true, on);
    if let Some(&p) = line.first() {
        current.push(p);
    }
    for w in line.windows(2) {
        let (mut a, b) = (w[0], w[1]);
        let mut len = (b.0 - a.0).hypot(b.1 - a.1);
        if !len.is_finite() {
            continue; // cannot be cut into dashes; callers pass clipped, finite lines
        }
        while len > left {
            let f = left / len;
            let m = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
            if drawing {
                current.push(m);
                out.push(std::mem::take(&mut current));
            } else {
                current = vec![m];
            }
            len -= left;
            a = m;
            drawing = !drawing;
            left = if drawing { on } else { off };
        }
        left -= len;
        if drawing {
            current.push(b);
        }
    }
    if drawing && current.len() > 1 {
        out.push(current);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: Rect = Rect {
        x0: 0.0,
        y0: 0.0,
        x1: 10.0,
        y1: 10.0,
    };

    #[test]
    fn segments_are_cut_at_the_box() {
        assert_eq!(
            clip_segment((-5.0, 5.0), (5.0, 5.0), &R),
            Some(((0.0, 5.0), (5.0, 5.0)))
        );
        assert_eq!(clip_segment((-5.0, -5.0), (-1.0, 20.0), &R), None);
        assert_eq!(
            clip_segment((5.0, -10.0), (5.0, 20.0), &R),
            Some(((5.0, 0.0), (5.0, 10.0)))
        );
    }

    #[test]
    fn polylines_split_at_gaps_and_exits() {
        let pts = [
            Some((1.0, 1.0)),
            Some((2.0, 2.0)),
            Some((20.0, 2.0)), // leaves the box
            Some((3.0, 3.0)),  // comes back
            None,              // NaN point
            Some((4.0, 4.0)),
            Some((5.0, 5.0)),
        ];
        let pieces = clip_polyline(&pts, &R);
        assert_eq!(pieces.len(), 3);
        assert_eq!(pieces[0], vec![(1.0, 1.0), (2.0, 2.0), (10.0, 2.0)]);
        assert_eq!(pieces[2], vec![(4.0, 4.0), (5.0, 5.0)]);
    }

    #[test]
    fn dashes_cover_the_expected_length() {
        let d = dashes(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], 3.0, 2.0);
        // 20 px at period 5: four dashes of 3 px, one turning the corner.
        assert_eq!(d.len(), 4);
        let len: f64 = d
            .iter()
            .flat_map(|p| {
                p.windows(2)
                    .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
            })
            .sum();
        assert!((len - 12.0).abs() < 1e-9, "{len}");
        assert_eq!(d[2], vec![(10.0, 0.0), (10.0, 3.0)]);
    }
}
