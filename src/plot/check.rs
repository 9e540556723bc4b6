//! What a referee would flag in a laid-out figure, found without looking at
//! pixels: a legend over data, one group value in two colours (or a value
//! outside its colour range), markup left unrendered in a label, a
//! reference-line label over data or under the legend, an axis stretched by
//! a single error bar or with fewer than two tick labels, axes squeezed by a
//! legend beside them.

use anyhow::Result;

use super::render::{PanelLayout, spans};
use super::spec::{Figure, Group};

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
        for (i, s) in p
            .series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.label.is_empty())
        {
            let other = p.series[..i]
                .iter()
                .zip(&lay.colors)
                .find(|(o, oc)| o.label == s.label && **oc != lay.colors[i] && !s.legend_ink);
            if other.is_some() {
                out.push(format!(
                    "{name}: legend entry {:?} stands for series of two colours",
                    s.label
                ));
            }
        }
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
    Ok(out)
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
                }],
                ..Default::default()
            }],
            columns: None,
            width: 600,
            height: 400,
            colour_ranges: Default::default(),
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
    fn markup_outside_braces_is_a_defect() {
        assert!(typeset("τ_{α}"));
        assert!(typeset("(φ_{c} − φ)^{−γ}"));
        assert!(!typeset("phi_0"));
        assert!(!typeset("χ₄ ∝ ξ^d′f"));
        assert!(!typeset("gamma_chi_over_gamma_xi"));
        assert!(!typeset("(φ_{c} − φ)^{−γ_{ξ}}"), "nested markup");
    }
}
