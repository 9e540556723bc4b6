//! Small statistics shared by the observables: blocked sums with jackknife errors,
//! the crossing time of a decaying curve and the peak of a curve in log t.

use std::collections::BTreeMap;

/// A value with its standard error.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub value: f64,
    pub err: f64,
}

/// Additive sums (e.g. [count, sum Q, sum Q^2]) accumulated per block (time origin
/// of a replica), so that any smooth function of the totals gets a jackknife error.
#[derive(Clone, Debug, Default)]
pub struct Blocks {
    sums: BTreeMap<(usize, usize), Vec<f64>>,
}

impl Blocks {
    /// Add `values` to the sums of `block`.
    pub fn add(&mut self, block: (usize, usize), values: &[f64]) {
        let s = self
            .sums
            .entry(block)
            .or_insert_with(|| vec![0.0; values.len()]);
        for (a, v) in s.iter_mut().zip(values) {
            *a += v;
        }
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.sums.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sums.is_empty()
    }

    /// Totals over all blocks.
    pub fn total(&self) -> Vec<f64> {
        let mut t: Vec<f64> = Vec::new();
        for s in self.sums.values() {
            if t.is_empty() {
                t = vec![0.0; s.len()];
            }
            for (a, v) in t.iter_mut().zip(s) {
                *a += v;
            }
        }
        t
    }

    /// Totals with `block` left out (zeros if the block is absent).
    pub fn total_without(&self, total: &[f64], block: &(usize, usize)) -> Vec<f64> {
        match self.sums.get(block) {
            Some(s) => total.iter().zip(s).map(|(t, v)| t - v).collect(),
            None => total.to_vec(),
        }
    }

    /// Sums of one block.
    pub fn get(&self, block: &(usize, usize)) -> Option<&[f64]> {
        self.sums.get(block).map(Vec::as_slice)
    }

    /// Block keys in a fixed order.
    pub fn keys(&self) -> impl Iterator<Item = &(usize, usize)> {
        self.sums.keys()
    }

    /// `f` of the totals, with its delete-one jackknife standard error
    /// (NaN error with fewer than two blocks).
    pub fn jackknife(&self, f: impl Fn(&[f64]) -> f64) -> Estimate {
        let total = self.total();
        let value = f(&total);
        let keys: Vec<_> = self.keys().copied().collect();
        Estimate {
            value,
            err: jackknife_err(
                keys.iter()
                    .map(|k| f(&self.total_without(&total, k)))
                    .collect(),
            ),
        }
    }
}

/// Jackknife standard error from delete-one estimates: sqrt((n-1)/n sum (x_k - mean)^2).
/// NaN with fewer than two estimates; non-finite estimates are dropped.
pub fn jackknife_err(estimates: Vec<f64>) -> f64 {
    let x: Vec<f64> = estimates.into_iter().filter(|v| v.is_finite()).collect();
    let n = x.len() as f64;
    if x.len() < 2 {
        return f64::NAN;
    }
    let m = x.iter().sum::<f64>() / n;
    ((n - 1.0) / n * x.iter().map(|v| (v - m).powi(2)).sum::<f64>()).sqrt()
}

/// Mean and sample standard deviation (n - 1) of the finite values: the
/// seed-to-seed spread of independent runs. NaN mean without a finite value, NaN
/// deviation with fewer than two.
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    let x: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let std = if x.len() > 1 {
        (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    };
    (mean, std)
}

/// First time at which a decaying curve `y(t)` crosses `level`, by linear
/// interpolation in ln t between the two bracketing samples (t ascending, t > 0).
/// None if it never crosses.
pub fn crossing_time(t: &[f64], y: &[f64], level: f64) -> Option<f64> {
    if let (Some(&t0), Some(&y0)) = (t.first(), y.first())
        && y0 <= level
    {
        return (y0 == level).then_some(t0);
    }
    for k in 1..t.len().min(y.len()) {
        let (ya, yb) = (y[k - 1], y[k]);
        if ya > level && yb <= level {
            let (la, lb) = (t[k - 1].ln(), t[k].ln());
            let s = (ya - level) / (ya - yb);
            return Some((la + s * (lb - la)).exp());
        }
    }
    None
}

/// Linear interpolation of y in ln t at `t0` (t ascending); None outside the samples
/// (never an extrapolation).
pub fn interp_log_t(t: &[f64], y: &[f64], t0: f64) -> Option<f64> {
    if t0.is_nan() || t0 <= 0.0 || t.len() < 2 || t0 < t[0] || t0 > t[t.len() - 1] {
        return None;
    }
    let k = t.partition_point(|&x| x <= t0).clamp(1, t.len() - 1);
    let (la, lb) = (t[k - 1].ln(), t[k].ln());
    let s = if lb > la {
        (t0.ln() - la) / (lb - la)
    } else {
        0.0
    };
    Some(y[k - 1] + s * (y[k] - y[k - 1]))
}

/// The top of a peak that [`peak_log_t`] fits: the samples around the highest
/// one down to this fraction of its height.
pub const PEAK_TOP: f64 = 0.8;

/// Peak (t_peak, y_peak) of a curve sampled at ascending t > 0: the vertex of the
/// least-squares parabola in ln t through the samples around the maximum that
/// reach [`PEAK_TOP`] of it (at least the maximum and its two neighbours), the
/// vertex kept inside them; the maximum sample itself at an end of the curve or
/// where the parabola is not concave. A parabola through the top rather than
/// through the highest sample alone: on a noisy, finely sampled curve the
/// highest sample jumps from lag to lag, the estimate with it, and a
/// leave-one-out jackknife of such a jump under-quotes its spread.
pub fn peak_log_t(t: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    peak_log_t_within(t, y, PEAK_TOP)
}

/// [`peak_log_t`] over the samples reaching `top` x the maximum (`top` = 1: the
/// maximum and its two neighbours, the parabola through three points).
pub fn peak_log_t_within(t: &[f64], y: &[f64], top: f64) -> Option<(f64, f64)> {
    let n = t.len().min(y.len());
    let k = (0..n)
        .filter(|&i| y[i].is_finite())
        .max_by(|&a, &b| y[a].total_cmp(&y[b]))?;
    if k == 0 || k + 1 >= n || !(y[k - 1].is_finite() && y[k + 1].is_finite()) {
        return Some((t[k], y[k]));
    }
    // The top: contiguous finite samples down to `top` x the maximum (a
    // negative maximum keeps the three points).
    let reaches = |i: usize| y[i].is_finite() && y[i] >= top * y[k];
    let (mut lo, mut hi) = (k - 1, k + 1);
    while lo > 0 && reaches(lo - 1) {
        lo -= 1;
    }
    while hi + 1 < n && reaches(hi + 1) {
        hi += 1;
    }
    // y = c0 + c1 u + c2 u^2, u = ln t - ln t_k, by the normal equations.
    let x1 = t[k].ln();
    let mut s = [0.0f64; 5];
    let mut r = [0.0f64; 3];
    for i in lo..=hi {
        let u = t[i].ln() - x1;
        let mut p = 1.0;
        for (j, sj) in s.iter_mut().enumerate() {
            *sj += p;
            if j < 3 {
                r[j] += p * y[i];
            }
            p *= u;
        }
    }
    let m = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]];
    let c = solve3(m, r)?;
    if !(c[2] < 0.0) {
        return Some((t[k], y[k]));
    }
    let (ua, ub) = (t[lo].ln() - x1, t[hi].ln() - x1);
    let du = (-c[1] / (2.0 * c[2])).clamp(ua, ub);
    Some(((x1 + du).exp(), c[0] + c[1] * du + c[2] * du * du))
}

/// A 3 x 3 system by Cramer's rule; None when singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    if !(d.abs() > 0.0) {
        return None;
    }
    let mut out = [0.0; 3];
    for (j, o) in out.iter_mut().enumerate() {
        let mut a = m;
        for i in 0..3 {
            a[i][j] = r[i];
        }
        *o = det(a) / d;
    }
    Some(out)
}

/// How finely a sampled curve fixes its peak (t, y) from [`peak_log_t`]: the time to
/// the standard deviation of a uniform spread over the local grid step in ln t
/// (step / sqrt 12, times t), the height to the parabola's correction over the
/// highest sample. A jackknife over blocks that all pick the same grid point says
/// the error is zero; the grid says it is at least this.
pub fn peak_resolution(t: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let n = t.len().min(y.len());
    let k = (0..n)
        .filter(|&i| y[i].is_finite())
        .max_by(|&a, &b| y[a].total_cmp(&y[b]))?;
    let (tp, yp) = peak_log_t(t, y)?;
    let (lo, hi) = (k.saturating_sub(1), (k + 1).min(n - 1));
    let step = if hi > lo {
        (t[hi].ln() - t[lo].ln()) / (hi - lo) as f64
    } else {
        0.0
    };
    Some((tp * step / 12f64.sqrt(), (yp - y[k]).abs()))
}

/// How finely the samples fix the crossing of [`crossing_time`]: the distance
/// between its linear interpolation in ln t and a quadratic one through the
/// bracketing samples and the nearer third (the interpolation's own error); when
/// the quadratic has no root between the bracketing samples, the bracket's width
/// over sqrt 12. None when the curve never crosses.
pub fn crossing_resolution(t: &[f64], y: &[f64], level: f64) -> Option<f64> {
    let lin = crossing_time(t, y, level)?;
    let n = t.len().min(y.len());
    let Some(k) = (1..n).find(|&k| y[k - 1] > level && y[k] <= level) else {
        return Some(0.0); // The first sample is on the level: exact.
    };
    let x = |i: usize| t[i].ln();
    let third = match (k.checked_sub(2), (k + 1 < n).then_some(k + 1)) {
        (Some(a), Some(b)) => Some(if x(k - 1) - x(a) <= x(b) - x(k) { a } else { b }),
        (a, b) => a.or(b),
    };
    let bracket = (x(k) - x(k - 1)) / 12f64.sqrt();
    let Some(m) = third.filter(|&m| y[m].is_finite()) else {
        return Some(lin * bracket);
    };
    // Newton form through (x_{k-1}, y), (x_k, y), (x_m, y); root of q(x) - level.
    let (x0, x1, x2) = (x(k - 1), x(k), x(m));
    let (y0, y1, y2) = (y[k - 1], y[k], y[m]);
    let d01 = (y1 - y0) / (x1 - x0);
    let d12 = (y2 - y1) / (x2 - x1);
    let c2 = (d12 - d01) / (x2 - x0);
    // q(x) = y0 + d01 (x - x0) + c2 (x - x0)(x - x1) = a u^2 + b u + c, u = x - x0.
    let (a, b, c) = (c2, d01 - c2 * (x1 - x0), y0 - level);
    // The stable pair of roots (q / a and c / q): no cancellation when the
    // curve is nearly straight (a -> 0 leaves c / q, the linear root).
    let disc = b * b - 4.0 * a * c;
    let roots = if disc < 0.0 {
        vec![]
    } else {
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        vec![q / a, c / q]
    };
    let quad = roots
        .into_iter()
        .map(|u| x0 + u)
        .filter(|v| v.is_finite() && *v >= x0 - 1e-12 && *v <= x1 + 1e-12)
        .min_by(|p, q| (p - lin.ln()).abs().total_cmp(&(q - lin.ln()).abs()));
    Some(match quad {
        Some(v) => (v.exp() - lin).abs(),
        None => lin * bracket,
    })
}

/// An error that is never below the resolution `res` of its estimator (NaN, no
/// error estimate at all, stays NaN).
pub fn at_least(err: f64, res: f64) -> f64 {
    if err.is_nan() { err } else { err.max(res) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_is_exact_for_a_log_linear_curve() {
        let t: Vec<f64> = (0..20).map(|k| 0.1 * 1.5f64.powi(k)).collect();
        // y linear in ln t crosses 1/e at ln t = ln 3.
        let y: Vec<f64> = t
            .iter()
            .map(|x| (-1f64).exp() - 0.1 * (x.ln() - 3f64.ln()))
            .collect();
        let c = crossing_time(&t, &y, (-1f64).exp()).unwrap();
        assert!((c - 3.0).abs() < 1e-12, "{c}");
        assert!(crossing_time(&t, &y, -10.0).is_none());
    }

    #[test]
    fn parabola_peak_is_exact_for_a_parabola_in_log_t() {
        let t: Vec<f64> = (0..15).map(|k| 0.5 * 1.7f64.powi(k)).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|x| 7.0 - 2.0 * (x.ln() - 10f64.ln()).powi(2))
            .collect();
        let (tp, yp) = peak_log_t(&t, &y).unwrap();
        assert!(
            (tp - 10.0).abs() < 1e-9 && (yp - 7.0).abs() < 1e-12,
            "{tp} {yp}"
        );
    }

    #[test]
    fn jackknife_of_a_mean_is_the_standard_error() {
        let mut b = Blocks::default();
        let xs = [1.0, 4.0, 2.0, 8.0, 5.0];
        for (k, x) in xs.iter().enumerate() {
            b.add((0, k), &[1.0, *x]);
        }
        let e = b.jackknife(|s| s[1] / s[0]);
        let m = 4.0;
        let var = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 4.0;
        assert!((e.value - m).abs() < 1e-12);
        assert!((e.err - (var / 5.0).sqrt()).abs() < 1e-12, "{}", e.err);
    }

    #[test]
    fn log_interpolation_is_exact_for_log_linear_data_and_never_extrapolates() {
        let t = [1.0, 10.0, 100.0];
        let y = [0.0, 1.0, 2.0];
        assert!((interp_log_t(&t, &y, 10f64.sqrt()).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(interp_log_t(&t, &y, 1000.0), None);
        assert_eq!(interp_log_t(&t, &y, 0.5), None);
    }

    /// On a noisy, finely sampled peak the parabola through the top finds the
    /// peak time closer than the parabola through the highest sample and its
    /// neighbours (`top` = 1), and the top's estimate moves less from one noise
    /// realisation to the next: the jumps of the highest sample are what a
    /// jackknife of the three-point peak under-quotes.
    #[test]
    fn the_top_of_a_noisy_peak_locates_it_better_than_its_highest_sample() {
        // chi4-like: a Gaussian in ln t, 12 lags a decade, 5% noise.
        let t: Vec<f64> = (0..49)
            .map(|k| 0.01 * 10f64.powf(k as f64 / 12.0))
            .collect();
        let (t_peak, width) = (3.3f64, 1.2f64);
        let mut state = 0x2545F4914F6CDD1Du64;
        let mut normal = move || {
            // Box-Muller on xorshift64* uniforms.
            let mut u = || {
                state ^= state >> 12;
                state ^= state << 25;
                state ^= state >> 27;
                ((state.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        };
        let (mut top, mut three) = (Vec::new(), Vec::new());
        for _ in 0..400 {
            let y: Vec<f64> = t
                .iter()
                .map(|x| {
                    let g = (-(x.ln() - t_peak.ln()).powi(2) / (2.0 * width * width)).exp();
                    g * (1.0 + 0.05 * normal())
                })
                .collect();
            top.push((peak_log_t(&t, &y).unwrap().0 / t_peak).ln());
            three.push((peak_log_t_within(&t, &y, 1.0).unwrap().0 / t_peak).ln());
        }
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let (r_top, r_three) = (rms(&top), rms(&three));
        // Measured: 0.10 against 0.19 in ln t.
        assert!(
            r_top < 0.7 * r_three,
            "rms ln error: top {r_top}, three points {r_three}"
        );
        assert!(r_top < 0.13, "{r_top}");
    }

    /// A peak between grid points: the parabola finds it, and its error is at least
    /// the grid's resolution even when every leave-one-out sample agrees.
    #[test]
    fn a_peak_between_grid_points_is_found_with_the_grid_resolution() {
        // 8 points a decade; the peak at t = 3.7 lies between 3.16 and 4.22.
        let t: Vec<f64> = (0..25).map(|k| 0.1 * 10f64.powf(k as f64 / 8.0)).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|x| 0.3 - 0.05 * (x.ln() - 3.7f64.ln()).powi(2))
            .collect();
        let (tp, yp) = peak_log_t(&t, &y).unwrap();
        assert!(
            (tp - 3.7).abs() < 1e-9 && (yp - 0.3).abs() < 1e-12,
            "{tp} {yp}"
        );
        let (t_res, y_res) = peak_resolution(&t, &y).unwrap();
        let step = 10f64.ln() / 8.0;
        assert!((t_res - 3.7 * step / 12f64.sqrt()).abs() < 1e-9, "{t_res}");
        let k = y
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        assert!(
            (y_res - (0.3 - y[k])).abs() < 1e-12 && y_res > 0.0,
            "{y_res}"
        );
        // Identical leave-one-out peaks: jackknife 0, quoted error the resolution.
        let jk = jackknife_err(vec![tp; 10]);
        assert!(jk < 1e-12, "{jk}");
        assert_eq!(at_least(jk, t_res), t_res);
        assert!(at_least(f64::NAN, t_res).is_nan());
    }

    /// The crossing's resolution bounds the interpolation's error: zero for data
    /// linear in ln t, at least the true error for a curved Q(t) and far below
    /// the grid's step.
    #[test]
    fn crossing_resolution_measures_the_interpolation_error() {
        let t: Vec<f64> = (0..20).map(|k| 0.1 * 10f64.powf(k as f64 / 4.0)).collect();
        let line: Vec<f64> = t.iter().map(|x| 1.0 - 0.1 * x.ln()).collect();
        assert!(crossing_resolution(&t, &line, 0.8).unwrap() < 1e-9);
        // Q = exp(-(t/tau)^0.7), tau = 7.3: Q = 1/e at t = tau exactly.
        let q: Vec<f64> = t.iter().map(|x| (-(x / 7.3f64).powf(0.7)).exp()).collect();
        let level = (-1f64).exp();
        let lin = crossing_time(&t, &q, level).unwrap();
        let res = crossing_resolution(&t, &q, level).unwrap();
        let true_err = (lin - 7.3).abs();
        assert!(true_err > 1e-4, "{true_err}");
        // Conservative (near the curve's inflection in ln t the straight line is
        // luckily good, the quadratic less so), and far finer than the grid (the
        // bracketing lags are 5.6 and 10).
        assert!(res >= true_err && res < 0.01 * 7.3, "{res} vs {true_err}");
        assert_eq!(crossing_resolution(&t, &q, -1.0), None);
    }
}
