//! What a referee would flag in a laid-out figure, found without looking at
//! pixels: a legend over data, one group value in two colours (or a value
//! outside its colour range), markup left unrendered in a label, a
//! reference-line label over data or under the legend, an axis stretched by
//! a single error bar or with fewer than two tick labels, axes squeezed by a
//! legend beside them, two series a reader cannot tell apart (colours closer
//! than CIEDE2000 10 and one marker and dash), a legend sample unlike its
//! series, a text naming a profile other than the one drawn, markers hidden
//! under lines painted over them.

use anyhow::Result;

use super::geometry::P;
use super::render::{Dot, PanelLayout, Stroke, spans};
use super::spec::{Figure, Group, Series, Style};
// The profile names a note may mention: the specs' own list.
use crate::pipeline::spec::PROFILES;

/// Two series of one panel closer in colour than this (CIEDE2000) must
/// differ in marker or dash.
pub const MIN_DELTA_E: f64 = 10.0;

/// A marker more than this fraction of whose disk lies under lines painted
/// after it is hidden (a fit over a white halo erased most of fig4's points).
pub const MAX_COVERED: f64 = 0.25;

/// Every defect of `fig` as laid out, one sentence each; empty when none.
pub fn defects(fig: &Figure, layout: &[PanelLayout]) -> Result<Vec<String>> {
    let mut out = vec![];
    for bad in labels(fig).into_iter().filter(|l| !typeset(l)) {
        out.push(format!(
            "label {bad:?} has `^` or `_` outside `^{{...}}`/`_{{...}}`"
        ));
    }
    for (column, v, (lo, hi)) in fig.panels.iter().flat_map(|p| &p.series).filter_map(|s| {
        let g = s.group.as_ref()?;
        let &r = fig.colour_ranges.get(&g.column)?;
        Some((&g.column, g.value, r))
    }) {
        // The palette is clamped at the range's ends: values past them would
        // share the end's colour with another value.
        if !(lo - 1e-9..=hi + 1e-9).contains(&v) {
            out.push(format!(
                "{column} = {v} lies outside its colour range [{lo}, {hi}]: it takes the colour of another value"
            ));
        }
    }
    let mut seen: Vec<(&Group, super::Color)> = vec![];
    for (k, (p, lay)) in fig.panels.iter().zip(layout).enumerate() {
        let name = format!("panel {} {:?}", k + 1, p.title);
        if let Some(b) = lay.legend
            && let Some(q) = lay.marks.iter().find(|&&q| b.contains(q))
        {
            out.push(format!("{name}: the legend covers data at pixel {q:?}"));
        }
        for (text, b) in &lay.labels {
            if lay.marks.iter().any(|&q| b.contains(q)) {
                out.push(format!("{name}: the label {text:?} covers data"));
            }
            if lay.legend.is_some_and(|l| l.overlaps(b)) {
                out.push(format!("{name}: the legend hides the label {text:?}"));
            }
        }
        for (axis, s) in [("x", lay.x), ("y", lay.y)] {
            let n = s.ticks().iter().filter(|t| t.label.is_some()).count();
            if n < 2 {
                out.push(format!(
                    "{name}: the {axis} axis has {n} labelled tick(s); two give its scale"
                ));
            }
        }
        for (s, &c) in p.series.iter().zip(&lay.colors) {
            let Some(g) = &s.group else { continue };
            match seen
                .iter()
                .find(|(h, _)| h.column == g.column && h.value == g.value)
            {
                Some((_, other)) if *other != c => out.push(format!(
                    "{name}: {} = {} drawn in {c} and elsewhere in {other}",
                    g.column, g.value
                )),
                Some(_) => {}
                None => seen.push((g, c)),
            }
        }
        out.extend(hidden(p, lay).map(|d| format!("{name}: {d}")));
        out.extend(alike(p, lay).into_iter().map(|d| format!("{name}: {d}")));
        out.extend(
            legend_unlike(p, lay)
                .into_iter()
                .map(|d| format!("{name}: {d}")),
        );
        if lay.frame.width() < 0.5 * lay.cell.width() {
            out.push(format!(
                "{name}: the axes take {:.0}% of the panel's width (a legend beside them?)",
                100.0 * lay.frame.width() / lay.cell.width()
            ));
        }
        if lay.frame.height() < 0.2 * lay.cell.height() {
            out.push(format!(
                "{name}: the axes take {:.0}% of the panel's height (a legend or notes above them?)",
                100.0 * lay.frame.height() / lay.cell.height()
            ));
        }
        if p.y.range.is_none()
            && let Some(why) = stretched(p, lay)
        {
            out.push(format!("{name}: {why}"));
        }
    }
    if let Some(drawn) = &fig.profile {
        let caption = fig.caption.iter().map(String::as_str);
        for text in labels(fig).into_iter().chain(caption) {
            for w in profile_words(text) {
                if w != drawn.as_str() {
                    out.push(format!(
                        "the text {text:?} speaks of the {w} profile, drawn at {drawn}"
                    ));
                }
            }
        }
    }
    Ok(out)
}

/// The markers of `lay` hidden under lines painted over them, if any: how
/// many of how many, and of which series.
fn hidden(p: &super::Panel, lay: &PanelLayout) -> Option<String> {
    let under: Vec<&Dot> = lay
        .dots
        .iter()
        .filter(|d| covered(d, &lay.strokes) > MAX_COVERED)
        .collect();
    let first = under.first()?;
    Some(format!(
        "{} of {} markers lie more than {:.0}% under lines painted over them (first of series {} {:?})",
        under.len(),
        lay.dots.len(),
        100.0 * MAX_COVERED,
        first.series + 1,
        p.series[first.series].label
    ))
}

/// The fraction of the disk of `dot` under the strokes painted after it,
/// counted on a grid of a quarter pixel.
pub fn covered(dot: &Dot, strokes: &[Stroke]) -> f64 {
    let r = dot.radius;
    let (cx, cy) = dot.at;
    // Segments painted later that come within reach of the disk.
    let near: Vec<(P, P, f64)> = strokes
        .iter()
        .filter(|s| s.pass > dot.pass)
        .flat_map(|s| s.line.windows(2).map(move |w| (w[0], w[1], 0.5 * s.width)))
        .filter(|&(a, b, h)| {
            let reach = r + h;
            a.0.min(b.0) <= cx + reach
                && a.0.max(b.0) >= cx - reach
                && a.1.min(b.1) <= cy + reach
                && a.1.max(b.1) >= cy - reach
        })
        .collect();
    if near.is_empty() {
        return 0.0;
    }
    let step = 0.25;
    let k = (r / step).ceil() as i32;
    let (mut inside, mut under) = (0usize, 0usize);
    for i in -k..=k {
        for j in -k..=k {
            let (dx, dy) = (i as f64 * step, j as f64 * step);
            if dx.hypot(dy) > r {
                continue;
            }
            inside += 1;
            let q = (cx + dx, cy + dy);
            if near.iter().any(|&(a, b, h)| distance(q, a, b) <= h) {
                under += 1;
            }
        }
    }
    under as f64 / inside.max(1) as f64
}

/// The distance from `q` to the segment a-b.
fn distance(q: P, a: P, b: P) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((q.0 - a.0) * dx + (q.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (q.0 - a.0 - t * dx).hypot(q.1 - a.1 - t * dy)
}

/// What a series is told apart by besides colour: its marker (none for a
/// plain line) and whether its line is dashed (none for points).
fn look(s: &Series, lay: &PanelLayout, i: usize) -> (Option<super::Marker>, Option<(bool, bool)>) {
    let line = !matches!(s.style, Style::Points | Style::Disks | Style::Arrows);
    (lay.markers[i], line.then_some((s.dashed, s.dotted)))
}

/// Pairs of series of one panel that a reader cannot tell apart: colours
/// closer than [`MIN_DELTA_E`] (CIEDE2000) with the same marker and dash.
/// Series of one group value, or of one legend entry, are meant alike.
fn alike(p: &super::Panel, lay: &PanelLayout) -> Vec<String> {
    let named = |s: &Series| s.group.is_some() || !s.label.is_empty();
    let mut out = vec![];
    for (i, a) in p.series.iter().enumerate().filter(|(_, s)| named(s)) {
        if matches!(a.style, Style::Disks | Style::Arrows) || a.x.is_empty() {
            continue;
        }
        for (j, b) in p
            .series
            .iter()
            .enumerate()
            .skip(i + 1)
            .filter(|(_, s)| named(s))
        {
            if matches!(b.style, Style::Disks | Style::Arrows) || b.x.is_empty() {
                continue;
            }
            let same_group = match (&a.group, &b.group) {
                (Some(g), Some(h)) => g.column == h.column && g.value == h.value,
                (None, None) => false,
                _ => false,
            };
            let same_entry = !a.label.is_empty() && a.label == b.label;
            // Two unlabelled guide lines (an offset curve's level, a fit per
            // group) have no legend entry to be told apart by: each is read
            // against the data it lies beside.
            let guides = a.fit && b.fit && a.label.is_empty() && b.label.is_empty();
            if same_group || same_entry || guides {
                continue;
            }
            // A fit's line beside points: told apart by being a line.
            if look(a, lay, i) != look(b, lay, j) {
                continue;
            }
            let d = super::colour::delta_e(lay.colors[i], lay.colors[j]);
            if d < MIN_DELTA_E {
                let name = |s: &Series| match (&s.group, s.label.is_empty()) {
                    (_, false) => format!("{:?}", s.label),
                    (Some(g), true) => format!("{} = {}", g.column, g.value),
                    _ => "?".into(),
                };
                out.push(format!(
                    "{} and {} differ by CIEDE2000 {d:.1} in colour (< {MIN_DELTA_E}) and share marker and dash",
                    name(a),
                    name(b)
                ));
            }
        }
    }
    out
}

/// Legend entries whose series are drawn unlike one another (the sample
/// shows one dash and one marker shape for all of them).
fn legend_unlike(p: &super::Panel, lay: &PanelLayout) -> Vec<String> {
    if lay.legend.is_none() {
        return vec![];
    }
    let mut out = vec![];
    let mut done: Vec<&str> = vec![];
    for (i, s) in p.series.iter().enumerate() {
        if s.label.is_empty() || done.contains(&s.label.as_str()) {
            continue;
        }
        done.push(&s.label);
        let members: Vec<usize> = (i..p.series.len())
            .filter(|&j| p.series[j].label == s.label)
            .collect();
        let lines: Vec<(bool, bool)> = members
            .iter()
            .filter(|&&j| {
                !matches!(
                    p.series[j].style,
                    Style::Points | Style::Disks | Style::Arrows
                )
            })
            .map(|&j| (p.series[j].dashed, p.series[j].dotted))
            .collect();
        let marks: Vec<super::Marker> = members.iter().filter_map(|&j| lay.markers[j]).collect();
        if lines.windows(2).any(|w| w[0] != w[1]) {
            out.push(format!(
                "legend entry {:?} stands for lines of several dash patterns",
                s.label
            ));
        }
        if marks.windows(2).any(|w| w[0] != w[1]) {
            out.push(format!(
                "legend entry {:?} stands for series of several marker shapes",
                s.label
            ));
        }
    }
    out
}

/// The profile names `text` speaks of: `ci` as a word; `small` followed by
/// a colon (`small: N = 2000`) or `profile`; `paper` followed by `profile`;
/// and `small` or `paper` joined by `and`/`or` to a profile word (`small and
/// paper: 0.78-0.805`). "The paper's φ" and "a small box" are no profile.
pub fn profile_words(text: &str) -> Vec<&'static str> {
    let words: Vec<&str> = text
        .split(|c: char| !(c.is_alphanumeric() || c == ':' || c == '\''))
        .filter(|w| !w.is_empty())
        .collect();
    let bare = |w: &str| -> Option<&'static str> {
        let w = w.trim_end_matches(':');
        PROFILES.iter().copied().find(|p| *p == w)
    };
    let alone = |k: usize| -> bool {
        let w = words[k];
        let next = words.get(k + 1).copied().unwrap_or("");
        match bare(w) {
            Some("ci") => true,
            Some("small") => w.ends_with(':') || next.starts_with("profile"),
            Some(_) => next.starts_with("profile"),
            None => false,
        }
    };
    let mut named = vec![false; words.len()];
    for k in 0..words.len() {
        named[k] = alone(k);
    }
    // Lists: a profile word beside `and`/`or` and a named profile word.
    for _ in 0..2 {
        for k in 0..words.len() {
            if named[k] || bare(words[k]).is_none() {
                continue;
            }
            let joined = |j: Option<usize>, via: Option<usize>| {
                matches!((j, via), (Some(j), Some(v)) if j < words.len()
                    && matches!(words[v], "and" | "or")
                    && bare(words[j]).is_some()
                    && (named[j] || words[j].ends_with(':')))
            };
            if joined(Some(k + 2), Some(k + 1)) || joined(k.checked_sub(2), k.checked_sub(1)) {
                named[k] = true;
            }
        }
    }
    let mut out = vec![];
    for (k, w) in words.iter().enumerate() {
        if let (true, Some(p)) = (named[k], bare(w))
            && !out.contains(&p)
        {
            out.push(p);
        }
    }
    out
}

/// Every text a figure prints.
fn labels(fig: &Figure) -> Vec<&str> {
    let mut out = vec![fig.title.as_str()];
    for p in &fig.panels {
        out.extend([&p.title, &p.x.label, &p.y.label, &p.legend_title].map(String::as_str));
        out.extend(p.series.iter().map(|s| s.label.as_str()));
        out.extend(p.hlines.iter().chain(&p.vlines).map(|l| l.label.as_str()));
        out.extend(p.notes.iter().map(String::as_str));
    }
    out
}

/// Whether `label` prints as meant: no `^`, `_` or brace left once the markup
/// `^{...}` and `_{...}` is set as super- and subscripts (markup does not nest:
/// `^{−γ_{ξ}}` would print `_{ξ` and a brace).
pub fn typeset(label: &str) -> bool {
    spans(label)
        .iter()
        .all(|(piece, _)| !piece.contains(['^', '_', '{', '}']))
}

/// Why the fitted y range reaches well past the values (by more than the
/// quarter span error bars may add, plus the margin), if it does.
fn stretched(p: &super::Panel, lay: &PanelLayout) -> Option<String> {
    let s = lay.y;
    let t = |v: f64| if s.log { v.log10() } else { v };
    let vals: Vec<f64> = p
        .series
        .iter()
        .flat_map(|s| &s.y)
        .copied()
        .filter(|&v| s.accepts(v))
        .map(t)
        .collect();
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let from_zero = p.y.from_zero && !s.log;
    if !(hi > lo) || from_zero {
        return None;
    }
    let allowed = 0.25 * (hi - lo);
    let (a, b) = (t(s.lo), t(s.hi));
    // The 4% margin of the fitted range on top of what bars may add.
    let margin = 0.04 * (b - a) + 1e-9 * (b - a).abs();
    (lo - a > allowed + margin || b - hi > allowed + margin).then(|| {
        format!(
            "the y axis [{}, {}] reaches past the values [{}, {}] by more than error bars may add",
            s.lo, s.hi, lo, hi
        )
    })
}

#[cfg(test)]
mod tests {
    use super::typeset;
    use crate::plot::{Axis, Figure, Panel, Rect, RefLine, Series};

    /// A reference-line label laid over data, or under the legend, is a defect.
    #[test]
    fn a_label_over_data_or_under_the_legend_is_a_defect() {
        let x: Vec<f64> = (0..20).map(f64::from).collect();
        let fig = Figure {
            title: String::new(),
            panels: vec![Panel {
                x: Axis::default(),
                y: Axis::default(),
                series: vec![Series {
                    label: "data".into(),
                    x: x.clone(),
                    y: x,
                    ..Default::default()
                }],
                hlines: vec![RefLine {
                    at: 15.0,
                    label: "paper".into(),
                    dashed: true,
                    color: None,
                    band: None,
                }],
                ..Default::default()
            }],
            columns: None,
            width: 600,
            height: 400,
            colour_ranges: Default::default(),
            profile: None,
            caption: vec![],
        };
        let mut lay = crate::plot::layout(&fig).unwrap();
        assert!(super::defects(&fig, &lay).unwrap().is_empty());
        let (qx, qy) = lay[0].marks[10];
        lay[0].labels[0].1 = Rect {
            x0: qx - 5.0,
            y0: qy - 5.0,
            x1: qx + 5.0,
            y1: qy + 5.0,
        };
        let d = super::defects(&fig, &lay).unwrap();
        assert!(d.iter().any(|d| d.contains("covers data")), "{d:?}");
        lay[0].labels[0].1 = lay[0].legend.unwrap();
        let d = super::defects(&fig, &lay).unwrap();
        assert!(d.iter().any(|d| d.contains("the legend hides")), "{d:?}");
    }

    #[test]
    fn profile_words_are_told_from_the_paper_and_small_things() {
        use super::profile_words as w;
        assert_eq!(w("ci: N = 1000, 2 replicas"), ["ci"]);
        assert_eq!(w("the ci box"), ["ci"]);
        assert_eq!(
            w("(small and paper: 0.78-0.805; ci stops at 0.78)"),
            ["small", "paper", "ci"]
        );
        assert_eq!(w("the small profile draws it"), ["small"]);
        assert_eq!(w("the paper profile's N"), ["paper"]);
        assert!(w("the paper's φ = 0.805 panel; a small box (the paper: φ to 0.805)").is_empty());
        assert!(w("small clusters and paper values; circles").is_empty());
    }

    #[test]
    fn markup_outside_braces_is_a_defect() {
        assert!(typeset("τ_{α}"));
        assert!(typeset("(φ_{c} − φ)^{−γ}"));
        assert!(!typeset("phi_0"));
        assert!(!typeset("χ₄ ∝ ξ^d′f"));
        assert!(!typeset("gamma_chi_over_gamma_xi"));
        assert!(!typeset("(φ_{c} − φ)^{−γ_{ξ}}"), "nested markup");
    }
}
