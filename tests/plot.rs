//! Figure drawing: what the SVG and PNG contain, robustness to data a log axis
//! cannot show, determinism, and the YAML form of a figure.
//!
//! `REPRO_PLOT_SAMPLES=dir cargo test --release --test plot` also writes the sample
//! figures (13 Q(t) curves, a two-panel log-log figure) to `dir` for looking at.

use repro::plot::{
    Axis, Figure, Group, Legend, Marker, Palette, Panel, RefLine, Series, Style, defects, draw,
    draw_png_bytes, draw_svg_string, layout,
};

const PHI: [f64; 13] = [
    0.60, 0.65, 0.70, 0.72, 0.74, 0.76, 0.77, 0.78, 0.785, 0.79, 0.795, 0.80, 0.805,
];

fn axis(label: &str, log: bool) -> Axis {
    Axis {
        label: label.into(),
        log,
        range: None,
        from_zero: false,
    }
}

fn series(label: &str, x: Vec<f64>, y: Vec<f64>) -> Series {
    Series {
        label: label.into(),
        x,
        y,
        y_err: None,
        style: Style::Line,
        dashed: false,
        color: None,
        marker: Marker::Auto,
        radius: None,
        arrows: None,
        ..Default::default()
    }
}

fn panel(title: &str, x: Axis, y: Axis, series: Vec<Series>) -> Panel {
    Panel {
        title: title.into(),
        x,
        y,
        series,
        hlines: vec![],
        vlines: vec![],
        legend: Legend::Auto,
        legend_title: String::new(),
        palette: Palette::Sequential,
        ..Default::default()
    }
}

/// Like paper H Fig. 3: Q(t) = 1/((t/tau0)^beta + 1) for 13 packing fractions.
fn overlap_figure() -> Figure {
    let t: Vec<f64> = (0..=70)
        .map(|i| 10f64.powf(-2.0 + 0.1 * i as f64))
        .collect();
    let curves = PHI
        .iter()
        .enumerate()
        .map(|(i, phi)| {
            let tau0 = 10f64.powf(4.0 * (i as f64 / 12.0).powf(1.5));
            let beta = 1.6 - 0.7 * i as f64 / 12.0;
            let q = t
                .iter()
                .map(|t| 1.0 / ((t / tau0).powf(beta) + 1.0))
                .collect();
            // As the paper writes them: 0.60, 0.785.
            let digits = if (phi * 100.0).fract().abs() < 1e-9 {
                2
            } else {
                3
            };
            series(&format!("{phi:.digits$}"), t.clone(), q)
        })
        .collect();
    let mut p = panel("", axis("t", true), axis("Q(t)", false), curves);
    p.hlines.push(RefLine {
        at: (-1.0f64).exp(),
        label: "1/e".into(),
        dashed: true,
        color: None,
        band: None,
    });
    p.legend_title = "φ".into();
    Figure {
        title: String::new(),
        panels: vec![p],
        columns: None,
        width: 720,
        height: 540,
        colour_ranges: Default::default(),
        profile: None,
        caption: vec![],
    }
}

/// Like paper H Fig. 19: (a) chi4 peak vs N with error bars, (b) a scaling collapse.
fn finite_size_figure() -> Figure {
    let n: Vec<f64> = (0..9).map(|i| 10f64.powf(1.0 + 0.5 * i as f64)).collect();
    let phis = [0.76, 0.78, 0.79, 0.80];
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for (k, phi) in phis.iter().enumerate() {
        let xi = 2.0 * 2f64.powi(k as i32);
        let chi_inf = 0.5 * xi.powf(1.6);
        let chi: Vec<f64> = n
            .iter()
            .map(|n| chi_inf * n / (n + xi * xi * 4.0))
            .collect();
        let mut s = series(&format!("φ = {phi}"), n.clone(), chi.clone());
        s.style = Style::LinePoints;
        s.y_err = Some(chi.iter().map(|c| 0.1 * c).collect());
        s.marker = [
            Marker::Circle,
            Marker::Square,
            Marker::Triangle,
            Marker::Diamond,
        ][k];
        a.push(s);
        let x = n.iter().map(|n| n.sqrt() / xi).collect();
        let y = chi.iter().map(|c| c * xi.powf(-1.6)).collect();
        let mut s = series(&format!("φ = {phi}"), x, y);
        s.style = Style::Points;
        s.marker = [
            Marker::OpenCircle,
            Marker::OpenSquare,
            Marker::Triangle,
            Marker::Cross,
        ][k];
        b.push(s);
    }
    Figure {
        title: String::new(),
        panels: vec![
            panel("(a)", axis("N", true), axis("χ₄ᴾ", true), a),
            panel("(b)", axis("√N / ξ", true), axis("χ₄ᴾ ξ^{−γχ/γξ}", true), b),
        ],
        columns: None,
        width: 1000,
        height: 440,
        colour_ranges: Default::default(),
        profile: None,
        caption: vec![],
    }
}

/// Text of every <text> element of an SVG.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .map(|t| {
            let body = &t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()];
            body.trim().to_string()
        })
        .collect()
}

#[test]
fn svg_has_legend_and_axis_labels_and_decade_ticks() {
    let svg = draw_svg_string(&overlap_figure()).unwrap();
    let texts = svg_texts(&svg);
    for want in ["t", "Q(t)", "φ", "0.60", "0.785", "1/e"] {
        assert!(
            texts.iter().any(|t| t == want),
            "no text {want:?} in {texts:?}"
        );
    }
    let decades: Vec<&String> = texts.iter().filter(|t| t.starts_with("10")).collect();
    assert_eq!(
        decades,
        ["10⁻²", "10⁻¹", "10⁰", "10¹", "10²", "10³", "10⁴", "10⁵"]
    );
    assert!(
        texts.iter().any(|t| t == "0.4"),
        "linear Q axis ticks: {texts:?}"
    );
    // Sample samples when asked.
    if let Some(dir) = std::env::var_os("REPRO_PLOT_SAMPLES") {
        let dir = std::path::Path::new(&dir);
        draw(
            &overlap_figure(),
            &dir.join("overlap.svg"),
            &dir.join("overlap.png"),
        )
        .unwrap();
        let fs = finite_size_figure();
        draw(
            &fs,
            &dir.join("finite-size.svg"),
            &dir.join("finite-size.png"),
        )
        .unwrap();
    }
}

#[test]
fn svg_is_byte_identical_for_the_same_figure() {
    let f = finite_size_figure();
    assert_eq!(
        draw_svg_string(&f).unwrap(),
        draw_svg_string(&f.clone()).unwrap()
    );
}

#[test]
fn unshowable_points_are_skipped_and_empty_series_keep_their_legend_entry() {
    let mut f = finite_size_figure();
    let p = &mut f.panels[0];
    p.series[0].y[2] = f64::NAN;
    p.series[1].y[3] = -1.0; // below zero on a log axis
    p.series[2].x[0] = 0.0;
    p.series[3].y[4] = f64::INFINITY;
    p.series[3].y_err.as_mut().unwrap()[5] = 1e9; // lower end negative
    p.series.push(series("empty", vec![], vec![]));
    let mut only_bad = series("all negative", vec![1.0, 2.0], vec![-1.0, -2.0]);
    only_bad.style = Style::LinePoints;
    p.series.push(only_bad);
    let svg = draw_svg_string(&f).unwrap();
    let texts = svg_texts(&svg);
    assert!(texts.iter().any(|t| t == "empty") && texts.iter().any(|t| t == "all negative"));
    // A panel of nothing drawable still gets axes (one default decade).
    let blank = panel(
        "",
        axis("x", true),
        axis("y", true),
        vec![series("none", vec![-1.0], vec![f64::NAN])],
    );
    let f = Figure {
        panels: vec![blank],
        ..overlap_figure()
    };
    let texts = svg_texts(&draw_svg_string(&f).unwrap());
    assert!(
        texts.iter().any(|t| t == "10⁰") && texts.iter().any(|t| t == "10¹"),
        "{texts:?}"
    );
}

#[test]
fn data_outside_a_fixed_range_is_clipped_to_the_axes() {
    let mut f = overlap_figure();
    f.panels[0].y.range = Some((0.2, 0.8));
    f.panels[0].x.range = Some((0.1, 100.0));
    let svg = draw_svg_string(&f).unwrap();
    // The frame is the only rectangle with no fill; every polyline stays inside it.
    let frame: Vec<i32> = svg
        .split("<rect")
        .skip(1)
        .find(|r| r.contains("fill=\"none\""))
        .map(|r| {
            ["x=\"", "y=\"", "width=\"", "height=\""]
                .iter()
                .map(|k| {
                    r.split(k)
                        .nth(1)
                        .unwrap()
                        .split('"')
                        .next()
                        .unwrap()
                        .parse()
                        .unwrap()
                })
                .collect()
        })
        .unwrap();
    let (x0, y0, x1, y1) = (frame[0], frame[1], frame[0] + frame[2], frame[1] + frame[3]);
    let mut n = 0;
    // Wide lines are drawn as filled polygons, one per segment.
    let shapes = svg
        .split("<polyline")
        .skip(1)
        .chain(svg.split("<polygon").skip(1));
    for pl in shapes {
        let pts = pl
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        for xy in pts.split_whitespace() {
            let (x, y) = xy.split_once(',').unwrap();
            let (x, y): (i32, i32) = (x.parse().unwrap(), y.parse().unwrap());
            // Legend samples lie inside too: the legend is inside the axes.
            assert!(
                x >= x0 - 1 && x <= x1 + 1 && y >= y0 - 1 && y <= y1 + 1,
                "({x},{y}) outside {frame:?}"
            );
            n += 1;
        }
    }
    assert!(n > 200, "only {n} polyline points");
}

#[test]
fn png_has_the_signature_and_the_requested_size() {
    let mut f = finite_size_figure();
    f.width = 640;
    f.height = 300;
    let png = draw_png_bytes(&f).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (640, 300));
    let dir = tempfile::tempdir().unwrap();
    let (svg_path, png_path) = (dir.path().join("f.svg"), dir.path().join("sub/f.png"));
    draw(&f, &svg_path, &png_path).unwrap();
    assert_eq!(std::fs::read(&png_path).unwrap(), png);
    assert!(
        std::fs::read_to_string(&svg_path)
            .unwrap()
            .starts_with("<svg")
    );
}

#[test]
fn figures_come_from_yaml_and_bad_ones_are_refused_clearly() {
    let yaml = r##"
title: Fig. 4
panels:
  - x: {label: "φ"}
    y: {label: "τ_α", log: true}
    series:
      - {label: data, x: [0.6, 0.7, 0.8], y: [1.0, 10.0, 1000.0], style: points, marker: open_circle}
      - {label: fit, x: [0.6, 0.8], y: [1.0, 1000.0], dashed: true, color: "#d62728"}
    hlines: [{at: 100.0, label: "τ = 100"}]
    legend: top_left
"##;
    let f: Figure = serde_saphyr::from_str(yaml).unwrap();
    assert_eq!(f.width, 720);
    assert_eq!(f.panels[0].series[0].style, Style::Points);
    assert_eq!(f.panels[0].series[1].color.unwrap().to_string(), "#d62728");
    assert!(
        svg_texts(&draw_svg_string(&f).unwrap())
            .iter()
            .any(|t| t == "τ_α")
    );

    let bad_color = yaml.replace("#d62728", "red");
    let e = serde_saphyr::from_str::<Figure>(&bad_color)
        .unwrap_err()
        .to_string();
    assert!(e.contains("\"red\" is not of the form \"#rrggbb\""), "{e}");

    let typo = yaml.replace("legend: top_left", "legend: top_left\n    lgend_title: x");
    let e = serde_saphyr::from_str::<Figure>(&typo)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lgend_title"), "{e}");

    let mut f2 = f.clone();
    f2.panels[0].series[0].y.pop();
    let e = format!("{:#}", draw_svg_string(&f2).unwrap_err());
    assert!(
        e.contains("series 1 \"data\": 3 x values but 2 y values"),
        "{e}"
    );

    let mut f3 = f.clone();
    f3.panels[0].y.range = Some((-1.0, 10.0));
    let e = format!("{:#}", draw_svg_string(&f3).unwrap_err());
    assert!(
        e.contains("y axis is logarithmic") && e.contains("must be positive"),
        "{e}"
    );

    let mut f4 = f;
    f4.panels[0].hlines[0].at = 0.0;
    let e = format!("{:#}", draw_svg_string(&f4).unwrap_err());
    assert!(
        e.contains("hline at 0 cannot be drawn on a logarithmic axis"),
        "{e}"
    );
}

mod robustness {
    use super::*;
    use proptest::prelude::*;

    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => -1e3..1e3f64,
            2 => (-300.0..300.0f64).prop_map(|e| 10f64.powf(e)),
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(-f64::MAX),
            1 => Just(0.0),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// Whatever the numbers, drawing a valid figure succeeds (never panics) and
        /// every legend label is in the SVG.
        #[test]
        fn any_data_draws(
            data in proptest::collection::vec(proptest::collection::vec((value(), value(), value()), 0..12), 1..5),
            xlog: bool,
            ylog: bool,
            legend in prop_oneof![Just(Legend::Auto), Just(Legend::Right), Just(Legend::BottomLeft), Just(Legend::None)],
        ) {
            let series: Vec<Series> = data
                .iter()
                .enumerate()
                .map(|(i, pts)| {
                    let mut s = series(&format!("s{i}"), pts.iter().map(|p| p.0).collect(), pts.iter().map(|p| p.1).collect());
                    s.y_err = Some(pts.iter().map(|p| p.2).collect());
                    s.style = [Style::Line, Style::Points, Style::LinePoints][i % 3];
                    s.dashed = i % 2 == 1;
                    s
                })
                .collect();
            let mut p = panel("(a)", axis("x", xlog), axis("y", ylog), series);
            p.legend = legend;
            let f = Figure { panels: vec![p.clone(), p], columns: Some(1), width: 300, height: 400, title: "t".into(), colour_ranges: Default::default(), profile: None, caption: vec![] };
            let texts = svg_texts(&draw_svg_string(&f).unwrap());
            if legend != Legend::None {
                for i in 0..data.len() {
                    let label = format!("s{i}");
                    prop_assert!(texts.contains(&label));
                }
            }
        }
    }
}

/// The sample figures lay out without a defect a referee would see.
#[test]
fn sample_figures_have_no_defects() {
    for f in [overlap_figure(), finite_size_figure()] {
        assert_eq!(defects(&f).unwrap(), Vec::<String>::new());
    }
}

/// A legend asked for a corner full of data goes where it covers none, and
/// the check sees a legend that covers data.
#[test]
fn a_legend_never_covers_data() {
    let mut f = overlap_figure();
    // Q(t) starts at 1 on the left: the top left corner is full of curves.
    f.panels[0].legend = Legend::TopLeft;
    let lay = layout(&f).unwrap();
    let b = lay[0].legend.expect("a legend");
    assert!(!lay[0].marks.iter().any(|&q| b.contains(q)), "{b:?}");
    // Not where it was asked: the top left corner holds the curves' start.
    let f0 = lay[0].frame;
    assert!(
        b.y0 > f0.y0 + 0.2 * f0.height() || b.x0 > f0.x0 + 0.3 * f0.width(),
        "{b:?}"
    );
    assert!(defects(&f).unwrap().is_empty());
}

/// A legend too wide for a free corner (fitted values in its labels) goes
/// above the axes, not beside them: the axes keep the panel's width, the
/// legend covers no data, and the check flags axes squeezed to a strip.
#[test]
fn a_wide_legend_leaves_the_axes_their_width() {
    let mut f = overlap_figure();
    for s in &mut f.panels[0].series {
        s.label = format!(
            "{}: τ = 1.234 ± 0.056, β = 0.789 ± 0.012, A = 0.95 ± 0.01",
            s.label
        );
    }
    let lay = layout(&f).unwrap();
    let (b, fr) = (lay[0].legend.expect("a legend"), lay[0].frame);
    assert!(
        fr.width() > 0.7 * lay[0].cell.width(),
        "{fr:?} in {:?}",
        lay[0].cell
    );
    assert!(!lay[0].marks.iter().any(|&q| b.contains(q)), "{b:?}");
    assert_eq!(defects(&f).unwrap(), Vec::<String>::new());
}

/// Series of one group value share a colour in every panel, markers and
/// lines alike; the check flags one drawn in another colour.
#[test]
fn one_group_value_has_one_colour_everywhere() {
    let mut f = finite_size_figure();
    for p in &mut f.panels {
        // Panel (b) lacks the first phi: its series would shift by one colour
        // if colours followed the index.
        if p.title == "(b)" {
            p.series.remove(0);
        }
        for s in &mut p.series {
            let phi: f64 = s.label.trim_start_matches("φ = ").parse().unwrap();
            s.group = Some(Group {
                column: "phi".into(),
                value: phi,
            });
        }
    }
    let lay = layout(&f).unwrap();
    assert_eq!(lay[0].colors[1..], lay[1].colors[..]);
    assert!(defects(&f).unwrap().is_empty());
    // A colour range that stops short of a value gives it the colour of the
    // range's end, which another value has (a = 3 and a = 4 in one colour).
    let mut short = f.clone();
    short.colour_ranges.insert("phi".into(), (0.60, 0.79));
    let d = defects(&short).unwrap();
    assert!(
        d.iter()
            .any(|d| d.contains("phi = 0.8 lies outside its colour range")),
        "{d:?}"
    );
    f.panels[1].series[0].color = Some(repro::plot::Color([0, 0, 0]));
    let d = defects(&f).unwrap();
    assert!(d.iter().any(|d| d.contains("phi = 0.78 drawn in")), "{d:?}");
}

/// `^` and `_` outside the markup print as written: a defect.
#[test]
fn unrendered_markup_is_a_defect() {
    let mut f = overlap_figure();
    f.panels[0].y.label = "gamma_chi_over_gamma_xi".into();
    f.panels[0].series[0].label = "χ₄ ∝ ξ^d′f".into();
    let d = defects(&f).unwrap();
    assert_eq!(d.len(), 2, "{d:?}");
}

/// One error bar twenty times its value neither stretches the y axis nor
/// runs off the frame; a note says the bars end there (and, on a log axis,
/// that its point, noise, is drawn open).
#[test]
fn one_long_error_bar_does_not_set_the_axis() {
    let x: Vec<f64> = (1..=8).map(f64::from).collect();
    let y: Vec<f64> = x.iter().map(|x| 10.0 + x).collect();
    let mut s = series("data", x, y.clone());
    s.style = Style::Points;
    let mut e = vec![0.5; 8];
    e[3] = 20.0 * y[3];
    s.y_err = Some(e);
    for log in [false, true] {
        let f = Figure {
            panels: vec![panel("", axis("x", false), axis("y", log), vec![s.clone()])],
            ..overlap_figure()
        };
        let lay = layout(&f).unwrap();
        let (lo, hi) = (lay[0].y.lo, lay[0].y.hi);
        let t = |v: f64| if log { v.log10() } else { v };
        let span = t(18.0) - t(11.0);
        assert!(
            t(hi) - t(18.0) < 0.35 * span && t(11.0) - t(lo) < 0.35 * span,
            "{lo} {hi}"
        );
        assert!(lay[0].marks.iter().all(|&q| lay[0].frame.contains(q)));
        assert!(
            lay[0].notes.iter().any(|n| n.contains(if log {
                "Open markers of filled series: points whose error exceeds their value"
            } else {
                "some errors exceed their value"
            })),
            "{:?}",
            lay[0].notes
        );
        assert!(defects(&f).unwrap().is_empty());
    }
}

/// A reference line's label goes where it covers no data (here not at the
/// right end, where the curve runs), and into the legend when the data cover
/// its line everywhere (coverage curves all around 68.3%).
#[test]
fn a_reference_label_never_covers_data() {
    let x: Vec<f64> = (0..=50).map(|i| i as f64 / 50.0).collect();
    // Curves just above and below the line over its right half.
    let right: Vec<f64> = x.iter().map(|x| 0.5 + 0.5 * x).collect();
    let mut p = panel(
        "",
        axis("x", false),
        axis("y", false),
        vec![
            series("data", x.clone(), x.clone()),
            series("above", right.clone(), vec![0.93; 51]),
            series("below", right, vec![0.87; 51]),
        ],
    );
    p.hlines.push(RefLine {
        at: 0.9,
        label: "paper".into(),
        dashed: true,
        color: None,
        band: None,
    });
    let mut f = Figure {
        panels: vec![p],
        ..overlap_figure()
    };
    let lay = layout(&f).unwrap();
    let (_, b) = &lay[0].labels[0];
    assert!(!lay[0].marks.iter().any(|&q| b.contains(q)), "{b:?}");
    assert!(b.x1 < lay[0].frame.x0 + 0.5 * lay[0].frame.width(), "{b:?}");
    assert!(defects(&f).unwrap().is_empty());

    f.panels[0].series = (0..6)
        .map(|k| {
            let y = x
                .iter()
                .map(|x| 0.64 + 0.015 * k as f64 + 0.01 * (9.0 * x).sin())
                .collect();
            series(&format!("form {k}"), x.clone(), y)
        })
        .collect();
    f.panels[0].hlines[0].at = 0.683;
    f.panels[0].hlines[0].label = "68.3%".into();
    f.panels[0].y.range = Some((0.0, 1.0));
    let lay = layout(&f).unwrap();
    assert!(lay[0].labels.is_empty(), "{:?}", lay[0].labels);
    let svg = draw_svg_string(&f).unwrap();
    assert!(svg_texts(&svg).contains(&"68.3%".to_string()));
    assert!(defects(&f).unwrap().is_empty(), "{:?}", defects(&f));
}

/// A paper's value just past the data (fig11's slow d_f = 1.91 over d_f of
/// 1.1 to 1.83) is brought into view; one far from them does not squeeze them.
#[test]
fn a_reference_line_near_the_data_is_in_view() {
    let x: Vec<f64> = (0..8).map(|i| 0.60 + 0.025 * i as f64).collect();
    let y: Vec<f64> = (0..8).map(|i| 1.10 + 0.105 * i as f64).collect();
    let mut p = panel(
        "",
        axis("φ", false),
        axis("d_{f}", false),
        vec![series("slow", x, y)],
    );
    for (at, label) in [(1.91, "slow"), (5.0, "far")] {
        p.hlines.push(RefLine {
            at,
            label: label.into(),
            dashed: true,
            color: None,
            band: None,
        });
    }
    let f = Figure {
        panels: vec![p],
        ..overlap_figure()
    };
    let lay = layout(&f).unwrap();
    assert!(lay[0].y.hi > 1.91 && lay[0].y.hi < 2.1, "{:?}", lay[0].y);
    assert!(defects(&f).unwrap().is_empty(), "{:?}", defects(&f));
}

/// Thirteen phi crowded near 0.8 (paper H's grid), drawn as before: colours
/// linear in phi over 0.60-0.805 and one marker for all. The densest phi
/// differ by CIEDE2000 < 10 and share marker and dash: a defect. Drawn as
/// now (colours by rank, a marker shape per value), none.
#[test]
fn crowded_group_values_are_told_apart_by_rank_colour_and_shape() {
    let x: Vec<f64> = (1..=6).map(f64::from).collect();
    let make = |old: bool| {
        let curves = PHI
            .iter()
            .enumerate()
            .map(|(k, &phi)| {
                let y = x.iter().map(|x| x * (1.0 + k as f64)).collect();
                let mut s = series(&format!("{phi}"), x.clone(), y);
                s.style = Style::LinePoints;
                s.group = Some(Group {
                    column: "phi".into(),
                    value: phi,
                });
                if old {
                    s.color = Some(repro::plot::viridis((phi - 0.60) / (0.805 - 0.60) * 0.88));
                    s.marker = Marker::Circle;
                }
                s
            })
            .collect();
        let mut p = panel("", axis("t", false), axis("y", false), curves);
        p.legend = Legend::Right;
        Figure {
            panels: vec![p],
            width: 900,
            ..overlap_figure()
        }
    };
    let d = defects(&make(true)).unwrap();
    assert!(
        d.iter()
            .any(|d| d.contains("\"0.8\" and \"0.805\" differ by CIEDE2000")),
        "{d:?}"
    );
    let new = make(false);
    assert_eq!(defects(&new).unwrap(), Vec::<String>::new());
    // Every pair of the new drawing closer than 10 differs in shape.
    let lay = layout(&new).unwrap();
    for i in 0..13 {
        for j in i + 1..13 {
            let de = repro::plot::delta_e(lay[0].colors[i], lay[0].colors[j]);
            assert!(
                de >= 10.0 || lay[0].markers[i] != lay[0].markers[j],
                "{i} {j} {de}"
            );
        }
    }
    // Neighbours in rank never share a shape.
    assert!(lay[0].markers.windows(2).all(|w| w[0] != w[1]));
}

/// Unlabelled guide lines of neighbouring values (an offset curve's dotted
/// level) have no legend entry to tell apart and are not a defect; the same
/// lines with legend entries are.
#[test]
fn unlabelled_guides_of_close_colours_are_no_defect() {
    let make = |labelled: bool| {
        let guides = [0.8, 0.805]
            .iter()
            .map(|&phi| {
                let mut s = series(
                    if labelled { "guide" } else { "" },
                    vec![1.0, 6.0],
                    vec![phi; 2],
                );
                if labelled {
                    s.label = format!("level {phi}");
                }
                s.dotted = true;
                s.fit = true;
                s.color = Some(repro::plot::viridis((phi - 0.60) / (0.805 - 0.60) * 0.88));
                s.group = Some(Group {
                    column: "phi".into(),
                    value: phi,
                });
                s
            })
            .collect();
        Figure {
            panels: vec![panel("", axis("t", false), axis("y", false), guides)],
            ..overlap_figure()
        }
    };
    let close = |f: &Figure| {
        defects(f)
            .unwrap()
            .into_iter()
            .filter(|d| d.contains("share marker and dash"))
            .count()
    };
    assert_eq!(close(&make(false)), 0);
    assert_eq!(close(&make(true)), 1);
}

/// A note naming a profile other than the one drawn is a defect; naming the
/// drawn one, or the paper as a publication, is not.
#[test]
fn a_note_for_another_profile_is_a_defect() {
    let mut f = overlap_figure();
    f.panels[0].notes =
        vec!["A small box (ci: N = 1000, 2 replicas); the paper's φ = 0.805.".into()];
    f.profile = Some("ci".into());
    assert_eq!(defects(&f).unwrap(), Vec::<String>::new());
    f.profile = Some("small".into());
    let d = defects(&f).unwrap();
    assert!(
        d.iter()
            .any(|d| d.contains("speaks of the ci profile, drawn at small")),
        "{d:?}"
    );
    f.panels[0].notes = vec!["The θ′ branch (small and paper: 0.78-0.805).".into()];
    f.profile = Some("ci".into());
    assert_eq!(defects(&f).unwrap().len(), 2);
}

/// One legend entry stands for a solid and a dashed line (its sample shows
/// one of them): a defect.
#[test]
fn a_legend_entry_unlike_its_series_is_a_defect() {
    let x: Vec<f64> = (1..=6).map(f64::from).collect();
    let a = series("fit", x.clone(), x.clone());
    let mut b = series("fit", x.clone(), x.iter().map(|v| 2.0 * v).collect());
    b.dashed = true;
    b.color = Some(repro::plot::Color([0xd6, 0x27, 0x28]));
    let mut f = overlap_figure();
    f.panels = vec![panel("", axis("x", false), axis("y", false), vec![a, b])];
    let d = defects(&f).unwrap();
    assert!(
        d.iter().any(|d| d.contains("several dash patterns")),
        "{d:?}"
    );
}

/// On a log axis a point whose error exceeds its value is noise: it does not
/// set the y range, is drawn open inside the axes, left out (with a note)
/// outside them.
#[test]
fn noise_on_a_log_axis_is_drawn_open_or_left_out() {
    let x: Vec<f64> = (1..=8).map(f64::from).collect();
    let mut y: Vec<f64> = x.iter().map(|x| 10f64.powf(-x)).collect();
    y[7] = 1e-40;
    let mut e: Vec<f64> = y.iter().map(|v| 0.1 * v).collect();
    e[2] = 2.0 * y[2];
    e[7] = 2.0 * y[7];
    let mut s = series("data", x, y);
    s.style = Style::Points;
    s.y_err = Some(e);
    let f = Figure {
        panels: vec![panel("", axis("x", false), axis("y", true), vec![s])],
        ..overlap_figure()
    };
    let lay = layout(&f).unwrap();
    assert!(lay[0].y.lo > 1e-12, "{:?}", lay[0].y);
    let notes = lay[0].notes.join(" ");
    assert!(
        notes.contains("1 point whose error exceeds its value lies outside the axes"),
        "{notes}"
    );
    assert!(notes.contains("Open markers"), "{notes}");
}

/// A measured value below zero beyond its error cannot be drawn on a log
/// axis: it is counted in a note, never dropped without a word (paper I's
/// fig3: v < 0 at the smallest force). An exact zero (an empty histogram bin,
/// fig8's van Hove tails) is no measurement and is not counted.
#[test]
fn a_value_below_zero_on_a_log_axis_is_counted() {
    let x: Vec<f64> = (1..=6).map(f64::from).collect();
    let mut y: Vec<f64> = x.iter().map(|x| 10f64.powf(-x)).collect();
    y[0] = -0.02;
    y[1] = -0.5;
    y[2] = 0.0;
    let mut e: Vec<f64> = y.iter().map(|v| 0.1 * v.abs()).collect();
    e[0] = 0.007;
    e[1] = 0.0;
    e[2] = 0.0;
    let mut s = series("data", x, y);
    s.style = Style::Points;
    s.y_err = Some(e);
    let f = Figure {
        panels: vec![panel("", axis("x", false), axis("y", true), vec![s])],
        ..overlap_figure()
    };
    let notes = layout(&f).unwrap()[0].notes.join(" ");
    assert!(
        notes.contains("2 points below zero beyond their errors cannot be drawn on the log axis"),
        "{notes}"
    );
    // On a linear axis they are drawn: no such note.
    let mut s = series("data", vec![1.0, 2.0], vec![-0.02, 0.5]);
    s.style = Style::Points;
    let f = Figure {
        panels: vec![panel("", axis("x", false), axis("y", false), vec![s])],
        ..overlap_figure()
    };
    let notes = layout(&f).unwrap()[0].notes.join(" ");
    assert!(!notes.contains("below zero"), "{notes}");
}

/// What the y range leaves out does not widen the x range: a noise point far
/// along x below the axes, and the stretch of a fit that falls out of view
/// (fig14's master curve at small), end where the shown data end.
#[test]
fn the_x_range_ends_where_what_shows_ends() {
    let mut x: Vec<f64> = (1..=8).map(f64::from).collect();
    x[7] = 1000.0;
    let mut y: Vec<f64> = (1..=8).map(|x| 10f64.powi(-x)).collect();
    y[7] = 1e-40;
    let mut e: Vec<f64> = y.iter().map(|v| 0.1 * v).collect();
    e[7] = 2.0 * y[7];
    let mut s = series("data", x, y);
    s.style = Style::Points;
    s.y_err = Some(e);
    let fx: Vec<f64> = (0..100).map(|i| 1.0 + 10.0 * i as f64).collect();
    let fy: Vec<f64> = fx.iter().map(|x| 10f64.powf(-x)).collect();
    let mut fit = series("fit", fx, fy);
    fit.fit = true;
    let f = Figure {
        panels: vec![panel("", axis("x", false), axis("y", true), vec![s, fit])],
        ..overlap_figure()
    };
    let lay = layout(&f).unwrap();
    assert!(lay[0].x.hi > 7.0 && lay[0].x.hi < 20.0, "{:?}", lay[0].x);
}

/// A paper's value with its tolerance: a pale band about the line, as tall as
/// twice the half-width on the axis, under the data; none without `band`.
#[test]
fn a_reference_band_spans_its_tolerance() {
    let x: Vec<f64> = (0..8).map(|i| 1000.0 * 2f64.powi(i)).collect();
    let y: Vec<f64> = (0..8).map(|i| 1.0 + 0.1 * i as f64).collect();
    let mut yaxis = axis("exponent", false);
    yaxis.range = Some((0.0, 4.0));
    let mut p = panel("", axis("N", true), yaxis, vec![series("d_{f}", x, y)]);
    p.hlines.push(RefLine {
        at: 1.6,
        label: "paper".into(),
        dashed: true,
        color: Some(repro::plot::Color([0, 0, 0])),
        band: Some(0.3),
    });
    let f = Figure {
        panels: vec![p],
        ..overlap_figure()
    };
    assert!(defects(&f).unwrap().is_empty(), "{:?}", defects(&f));
    let lay = layout(&f).unwrap();
    let frame_h = lay[0].frame.y1 - lay[0].frame.y0;
    let svg = draw_svg_string(&f).unwrap();
    // The tint of black: 255 - 255 * 3/20 = 217 (#D9D9D9).
    let bands: Vec<f64> = svg
        .split("<rect")
        .skip(1)
        .filter(|r| r.contains("#D9D9D9"))
        .filter_map(|r| {
            let h = r.split("height=\"").nth(1)?.split('"').next()?;
            h.parse::<f64>().ok()
        })
        .collect();
    assert_eq!(bands.len(), 1, "one band: {bands:?}");
    let want = 0.6 / 4.0 * frame_h;
    assert!(
        (bands[0] - want).abs() < 2.0,
        "band {} px, want {want}",
        bands[0]
    );
    let mut plain = f.clone();
    plain.panels[0].hlines[0].band = None;
    assert!(!draw_svg_string(&plain).unwrap().contains("#D9D9D9"));
    // A band needs a positive half-width.
    let mut bad = f.clone();
    bad.panels[0].hlines[0].band = Some(-1.0);
    assert!(draw_svg_string(&bad).is_err() || !defects(&bad).unwrap().is_empty());
}

/// tau_alpha(phi) points of paper H's Fig. 4 with error bars and the two fits
/// through them (power law dashed, VFT solid) as the plot stage draws them:
/// 400-point curves flagged `fit`; `eps` gives one family per value (Fig. 23(a)).
fn tau_panel(eps: &[f64]) -> Panel {
    let mut all = vec![];
    for (k, &e) in eps.iter().enumerate() {
        let shift = 0.01 * k as f64;
        let law = |phi: f64| 0.3 * (0.82 - shift - phi).powf(-1.8);
        let vft = |phi: f64| 0.8 * (0.13 / (0.83 - shift - phi)).exp();
        let phi: Vec<f64> = PHI.iter().copied().filter(|&p| p < 0.80 - shift).collect();
        let tau: Vec<f64> = phi.iter().map(|&p| law(p)).collect();
        let group = (eps.len() > 1).then(|| Group {
            column: "eps".into(),
            value: e,
        });
        all.push(Series {
            style: Style::Points,
            y_err: Some(tau.iter().map(|t| 0.05 * t).collect()),
            group: group.clone(),
            ..series("simulation", phi, tau)
        });
        let x: Vec<f64> = (0..400).map(|i| 0.58 + 0.2 * i as f64 / 399.0).collect();
        for (curve, dashed) in [(&law as &dyn Fn(f64) -> f64, true), (&vft, false)] {
            all.push(Series {
                fit: true,
                dashed,
                group: group.clone(),
                ..series("", x.clone(), x.iter().map(|&p| curve(p)).collect())
            });
        }
    }
    Panel {
        y: Axis {
            range: Some((0.5, 3000.0)),
            ..axis("τ_{α}", true)
        },
        legend: Legend::None,
        ..panel("", axis("φ", false), axis("", true), all)
    }
}

/// The markers of `lay` more than [`MAX_COVERED`] under lines painted after
/// them, with the fits painted as before: after every marker, a pixel wider
/// than now and over a white halo a pixel wider on each side.
fn hidden_markers(lay: &repro::plot::PanelLayout, fits: &[usize], old: bool) -> usize {
    let strokes: Vec<repro::plot::Stroke> = lay
        .strokes
        .iter()
        .cloned()
        .map(|mut s| {
            if old && fits.contains(&s.series) {
                s.pass = 3;
                s.width += 1.0 + 2.0;
            }
            s
        })
        .collect();
    lay.dots
        .iter()
        .filter(|d| repro::plot::covered(d, &strokes) > repro::plot::MAX_COVERED)
        .count()
}

/// Fig. 4 and Fig. 23(a): drawn the old way (fits above the markers over a
/// white halo) most markers vanish under the fits and the check says so;
/// drawn now (fits first and thinner, markers last) none is hidden and the
/// figure has no defect.
#[test]
fn markers_are_painted_above_the_fits_through_them() {
    for (name, eps, most) in [
        ("fig4", vec![0.9], 7),
        ("fig23(a)", vec![0.7, 0.8, 0.9, 1.0], 20),
    ] {
        let fig = Figure {
            width: 560,
            height: 440,
            panels: vec![tau_panel(&eps)],
            ..Default::default()
        };
        let lay = &layout(&fig).unwrap()[0];
        let fits: Vec<usize> = (0..fig.panels[0].series.len())
            .filter(|&i| fig.panels[0].series[i].fit)
            .collect();
        let old = hidden_markers(lay, &fits, true);
        assert!(
            old >= most,
            "{name}: only {old} of {} markers hidden the old way",
            lay.dots.len()
        );
        assert_eq!(hidden_markers(lay, &fits, false), 0, "{name}");
        let d = defects(&fig).unwrap();
        assert!(d.is_empty(), "{name}: {d:?}");
    }
}

/// The coverage of a marker is the share of its disk under later strokes:
/// a line through its centre covers width / (pi r / 2) of it, one painted
/// before it nothing, one beside it nothing.
#[test]
fn marker_coverage_is_the_share_of_its_disk_under_later_lines() {
    use repro::plot::{Dot, Stroke, covered};
    let dot = Dot {
        series: 0,
        at: (50.0, 50.0),
        radius: 4.0,
        pass: 1,
    };
    let line = |y: f64, pass: u8| Stroke {
        series: 1,
        line: vec![(0.0, y), (100.0, y)],
        width: 2.0,
        pass,
    };
    // A band of half-width h through the centre of a disk of radius r covers
    // (2/pi)(asin(h/r) + (h/r) sqrt(1 - h^2/r^2)) of it.
    let (h, r) = (1.0f64, 4.0f64);
    let exact =
        2.0 / std::f64::consts::PI * ((h / r).asin() + (h / r) * (1.0 - (h / r).powi(2)).sqrt());
    // The quarter-pixel grid counts the band's edge rows in full, which adds
    // up to an eighth of the band at this radius.
    let c = covered(&dot, &[line(50.0, 2)]);
    assert!(c >= exact && c < 1.15 * exact, "{c} against {exact}");
    assert_eq!(covered(&dot, &[line(50.0, 0)]), 0.0);
    assert_eq!(covered(&dot, &[line(60.0, 2)]), 0.0);
}
