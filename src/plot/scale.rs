//! Axis scales: data to [0, 1], automatic ranges and tick positions with labels.

/// A linear or logarithmic axis over [lo, hi] in data units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

/// A tick mark; major ticks carry a label.
#[derive(Clone, Debug, PartialEq)]
pub struct Tick {
    pub at: f64,
    pub label: Option<String>,
}

impl Scale {
    /// Whether `v` can be placed on this axis (finite; positive on a log axis).
    pub fn accepts(&self, v: f64) -> bool {
        v.is_finite() && (!self.log || v > 0.0)
    }

    /// Position of `v` along the axis: 0 at lo, 1 at hi.
    pub fn fraction(&self, v: f64) -> f64 {
        let t = |v: f64| if self.log { v.log10() } else { v };
        (t(v) - t(self.lo)) / (t(self.hi) - t(self.lo))
    }

    /// The range fitted to `values`, ignoring what the axis cannot show (NaN, inf,
    /// non-positive on log axes), with 4% margins (of the decades spanned on log axes).
    /// No usable value gives [0, 1] or [1, 10].
    pub fn fit(values: impl IntoIterator<Item = f64>, log: bool) -> Scale {
        let probe = Scale {
            lo: 1.0,
            hi: 10.0,
            log,
        };
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.into_iter().filter(|&v| probe.accepts(v)) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let (lo, hi) = match (lo <= hi, log) {
            (false, false) => (0.0, 1.0),
            (false, true) => (1.0, 10.0),
            (true, true) => {
                let (a, b) = (lo.log10(), hi.log10());
                let pad = if a == b { 0.5 } else { 0.04 * (b - a) };
                // Stay within normal f64 (a pad past 1e308 would give infinity).
                (
                    10f64.powf((a - pad).max(-307.0)),
                    10f64.powf((b + pad).min(308.0)),
                )
            }
            (true, false) if lo == hi => {
                let d = 0.5 * lo.abs().max(1.0);
                (lo - d, hi + d)
            }
            (true, false) => {
                // No margin where it would overflow (data near f64::MAX).
                let pad = 0.04 * (hi - lo);
                let (a, b) = (lo - pad, hi + pad);
                if a.is_finite() && b.is_finite() {
                    (a, b)
                } else {
                    (lo, hi)
                }
            }
        };
        Scale { lo, hi, log }
    }

    /// Ticks inside [lo, hi]: decades (10⁻², 10⁻¹, ...) on log axes, 1-2-5 steps on
    /// linear ones, with unlabelled minor ticks between.
    pub fn ticks(&self) -> Vec<Tick> {
        if self.log {
            self.log_ticks()
        } else {
            self.linear_ticks()
        }
    }

    fn inside(&self, v: f64) -> bool {
        let f = self.fraction(v);
        (-1e-9..=1.0 + 1e-9).contains(&f)
    }

    fn log_ticks(&self) -> Vec<Tick> {
        // Clamped to the f64 range, so a degenerate scale cannot loop for long.
        let first = ((self.lo.log10() - 1e-9).floor() as i32).max(-330);
        let last = ((self.hi.log10() + 1e-9).ceil() as i32).min(310);
        let decades: Vec<i32> = (first..=last)
            .filter(|&k| self.inside(10f64.powi(k)))
            .collect();
        let span = self.hi.log10() - self.lo.log10();
        let mut out = Vec::new();
        if decades.len() >= 2 {
            // At most ~8 labels: every decade, or every 2nd, 3rd, ... on wide axes.
            let every = decades.len().div_ceil(8) as i32;
            for k in first..=last {
                for m in 1..10 {
                    let at = m as f64 * 10f64.powi(k);
                    if !self.inside(at) || (m > 1 && span > 8.0) {
                        continue;
                    }
                    let label = (m == 1 && k.rem_euclid(every) == 0).then(|| decade(k));
                    out.push(Tick { at, label });
                }
            }
        } else {
            // Less than two decades visible: label 1, 2, 5 (all mantissas if too few).
            let candidates: Vec<(f64, i32)> = (first..=last)
                .flat_map(|k| (1..10).map(move |m| (m as f64 * 10f64.powi(k), m)))
                .filter(|&(at, _)| self.inside(at))
                .collect();
            let few = candidates
                .iter()
                .filter(|(_, m)| [1, 2, 5].contains(m))
                .count()
                < 2;
            for (at, m) in candidates {
                let label = (few || [1, 2, 5].contains(&m)).then(|| plain(at, at));
                out.push(Tick { at, label });
            }
        }
        // Under a decade with at most one mantissa inside (9.5 to 19): one
        // label cannot give the scale; round linear steps can.
        if out.iter().filter(|t| t.label.is_some()).count() < 2 {
            return self.linear_ticks();
        }
        out
    }

    fn linear_ticks(&self) -> Vec<Tick> {
        let span = self.hi - self.lo;
        if !(span.is_finite() && span > 0.0) {
            return Vec::new();
        }
        let mag = 10f64.powf((span / 6.0).log10().floor());
        let mult = [1.0, 2.0, 5.0, 10.0]
            .into_iter()
            .find(|m| span / (m * mag) <= 7.0)
            .unwrap_or(10.0);
        let step = mult * mag;
        let minor = step / if mult == 2.0 { 4.0 } else { 5.0 };
        let first = (self.lo / minor - 1e-9).ceil() as i64;
        let last = (self.hi / minor + 1e-9).floor() as i64;
        let per_major = ((step / minor).round() as i64).max(1);
        if last.saturating_sub(first) > 1000 {
            return Vec::new(); // rounding broke down (|values| >> their spread)
        }
        (first..=last)
            .map(|i| {
                let at = i as f64 * minor;
                let label = (i.rem_euclid(per_major) == 0).then(|| plain(at, step));
                Tick { at, label }
            })
            .collect()
    }
}

/// "10" with the exponent as superscript: 10⁻², 10⁰, 10³.
fn decade(k: i32) -> String {
    let sup: String = k
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
        })
        .collect();
    format!("10{sup}")
}

/// `v` with as many decimals as the tick spacing `step` needs, a true minus sign,
/// and powers of ten for very large or small numbers.
fn plain(v: f64, step: f64) -> String {
    // No "-0.0" from rounding noise around zero.
    let v = if v.abs() < 1e-9 * step.abs() { 0.0 } else { v };
    let text = if v.abs() >= 1e5 || step.abs() < 1e-4 {
        let k = v.abs().log10().floor() as i32;
        let m = v / 10f64.powi(k);
        let digits = ((m.abs() * 1e3).round() / 1e3).to_string();
        if digits == "1" {
            decade(k).replacen("10", if v < 0.0 { "-10" } else { "10" }, 1)
        } else {
            format!("{}×{}", (m * 1e3).round() / 1e3, decade(k))
        }
    } else {
        let decimals = (-(step.abs().log10() + 1e-9).floor()).max(0.0) as usize;
        format!("{v:.decimals$}")
    };
    text.replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(s: Scale) -> Vec<String> {
        s.ticks().into_iter().filter_map(|t| t.label).collect()
    }

    #[test]
    fn log_axes_are_labelled_at_decades() {
        let s = Scale::fit([0.013, 5.0, 870.0], true);
        assert_eq!(labels(s), ["10⁻²", "10⁻¹", "10⁰", "10¹", "10²", "10³"]);
        let s = Scale {
            lo: 0.01,
            hi: 1000.0,
            log: true,
        };
        // Minor ticks at 2..9 x 10^k: 9 per decade plus the closing decade.
        assert_eq!(s.ticks().len(), 5 * 9 + 1);
        // Twenty decades: every third decade labelled, no minor ticks.
        let wide = Scale {
            lo: 1e-10,
            hi: 1e10,
            log: true,
        };
        assert_eq!(labels(wide).len(), 7);
        assert_eq!(wide.ticks().len(), 21);
    }

    #[test]
    fn log_fit_skips_what_a_log_axis_cannot_show() {
        let s = Scale::fit([-3.0, 0.0, f64::NAN, f64::INFINITY, 0.2, 30.0], true);
        // 0.2 to 30 spans 2.18 decades; 4% of that pads each end.
        let pad = 0.04 * (30f64 / 0.2).log10();
        assert!(
            (s.lo.log10() - (0.2f64.log10() - pad)).abs() < 1e-12,
            "{s:?}"
        );
        assert!(
            (s.hi.log10() - (30f64.log10() + pad)).abs() < 1e-12,
            "{s:?}"
        );
        assert_eq!(
            Scale::fit([-1.0, f64::NAN], true),
            Scale {
                lo: 1.0,
                hi: 10.0,
                log: true
            }
        );
        // A single value gets half a decade each side.
        let one = Scale::fit([10.0], true);
        assert!((one.lo - 10f64.sqrt()).abs() < 1e-12 && (one.hi - 1000f64.sqrt()).abs() < 1e-9);
        assert_eq!(labels(one), ["5", "10", "20"]);
    }

    #[test]
    fn narrow_log_axes_label_1_2_5() {
        let s = Scale {
            lo: 0.15,
            hi: 0.8,
            log: true,
        };
        assert_eq!(labels(s), ["0.2", "0.5"]);
        // Every log axis has at least two labels, however narrow.
        for (lo, hi) in [(9.5, 19.0), (7.2, 9.9), (0.31, 0.45), (101.0, 180.0)] {
            let s = Scale { lo, hi, log: true };
            assert!(labels(s).len() >= 2, "{lo}..{hi}: {:?}", labels(s));
        }
    }

    #[test]
    fn linear_ticks_are_round_numbers() {
        let s = Scale {
            lo: -0.04,
            hi: 1.04,
            log: false,
        };
        assert_eq!(labels(s), ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        let s = Scale {
            lo: -0.3,
            hi: 0.3,
            log: false,
        };
        assert_eq!(
            labels(s),
            ["−0.3", "−0.2", "−0.1", "0.0", "0.1", "0.2", "0.3"]
        );
        let s = Scale {
            lo: -12.0,
            hi: 31.0,
            log: false,
        };
        assert_eq!(labels(s), ["−10", "0", "10", "20", "30"]);
        let s = Scale {
            lo: 0.0,
            hi: 3e6,
            log: false,
        };
        assert_eq!(labels(s)[1..3], ["5×10⁵".to_string(), "10⁶".to_string()]);
    }

    #[test]
    fn fraction_maps_ends_and_decades() {
        let s = Scale {
            lo: 0.01,
            hi: 100.0,
            log: true,
        };
        assert_eq!(s.fraction(0.01), 0.0);
        assert!((s.fraction(1.0) - 0.5).abs() < 1e-12);
        let l = Scale::fit([2.0, 2.0], false);
        assert_eq!((l.lo, l.hi), (1.0, 3.0));
    }
}
