//! Data collapse: find scaling exponents by minimising the spread of rescaled
//! curves (paper H, Fig. 13, 19, 24).
//!
//! Each curve (x_i, y_i, sigma_i) is mapped by a user closure to rescaled
//! points (X, Y, sigma_Y) that depend on the parameters (e.g. X = sqrt(N)/xi,
//! Y = chi4P xi^-g). The quality measure follows Houdayer and Hartmann (PRB 70,
//! 014418, 2004) on log-log axes: every point of every curve is compared with
//! the linear interpolation of each other curve that spans its X, in units of
//! both errors. With K curves overlapping at a point, the K(K-1) ordered
//! comparisons there are weighted 1/K, which makes the sum equal to the
//! chi-square of the points about their common (master) curve; S divides it by
//! its expectation, so S ~ 1 for a collapse within the errors (below).
//!
//! A comparison enters with a weight that rises linearly from 0 at the end of
//! the other curve's range to 1 at its next point, so that S is continuous in
//! the parameters. With full weight from the end on, a point crossing into
//! another curve's range switches a comparison on at once and S steps; the
//! minimum then sits on a step's edge, which the grid of the data fixes (with
//! phi_c held and phi differences in ratios 2 and 3/2, the first cluster sizes
//! 1, 2, 3 line up at rho = 1 and ln 1.5 / ln 2), not the data's values, and
//! the curvature there says nothing of the error.
//!
//! The interpolated value carries the weighted mean of its two points' errors,
//! as for errors fully correlated along a curve: neighbouring points of one
//! measured curve come from the same runs (P(Nc) at adjacent sizes, chi4 of
//! nested sub-boxes). With the independent-error form (1 - t)^2 s0^2 + t^2 s1^2,
//! which halves the variance midway between points, S dips wherever the points
//! of two curves line up, and on curves whose misfit is systematic those dips
//! are its minima: on the default profile's cluster sizes (integer Nc) the best
//! rho of fig13's collapse sat on such alignments, exactly on rho = 1 at N =
//! 1000 in the sweep in N, with errors from the curvature of a cusp. For
//! independent errors this form puts S of a collapse within the errors below
//! 1 where the points of the curves do not line up.
//!
//! The parameters minimise S (grid scan, then Nelder-Mead within the bounds).
//! Their covariance is 2 H^-1 with H the Hessian of that chi-square at the
//! minimum, multiplied by S when S > 1 (scatter beyond the errors).

use serde::Serialize;

use super::FitError;
use super::linalg::spd_inverse;

const FORM: &str = "collapse";

/// One measured curve, with the control parameter that labels it (phi, xi, ...).
#[derive(Debug, Clone, Serialize)]
pub struct Curve {
    pub label: String,
    pub param: f64,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub sigma: Vec<f64>,
}

/// Maps (scaling parameters, curve, x, y, sigma) to a rescaled point (X, Y, sigma_Y).
/// X and Y must come out > 0 (the comparison is on log-log axes).
pub type Rescale<'a> = &'a dyn Fn(&[f64], &Curve, f64, f64, f64) -> (f64, f64, f64);

/// The curves of a collapse from a table's columns, one per value of `by`
/// (named `by_name`) with at least two points of
/// positive x, y and error, in ascending order of that value.
pub fn curves_by(by_name: &str, x: &[f64], y: &[f64], e: &[f64], by: &[f64]) -> Vec<Curve> {
    let mut m: std::collections::BTreeMap<u64, Curve> = Default::default();
    for i in 0..x.len() {
        let ok = x[i] > 0.0 && y[i] > 0.0 && e[i] > 0.0 && y[i].is_finite() && e[i].is_finite();
        if !ok {
            continue;
        }
        let cv = m.entry(by[i].to_bits()).or_insert_with(|| Curve {
            label: format!("{by_name}={}", by[i]),
            param: by[i],
            x: vec![],
            y: vec![],
            sigma: vec![],
        });
        cv.x.push(x[i]);
        cv.y.push(y[i]);
        cv.sigma.push(e[i]);
    }
    let mut curves: Vec<Curve> = m.into_values().filter(|c| c.x.len() >= 2).collect();
    curves.sort_by(|a, b| a.param.total_cmp(&b.param));
    curves
}

/// How well the rescaled curves fall on one another.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Quality {
    /// chi2 / expected chi2: ~1 for a collapse within the errors.
    pub s: f64,
    /// Chi-square of the points about the common curve (see module doc).
    pub chi2: f64,
    /// Its expectation for a perfect collapse.
    pub expected: f64,
    /// Number of point-versus-curve comparisons made.
    pub comparisons: usize,
}

/// Best scaling parameters with 1-sigma errors.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CollapseResult {
    pub names: Vec<String>,
    pub params: Vec<f64>,
    pub stderr: Vec<f64>,
    pub covariance: Vec<Vec<f64>>,
    pub quality: Quality,
}

impl CollapseResult {
    /// (value, standard error) of a parameter by name.
    pub fn get(&self, name: &str) -> Option<(f64, f64)> {
        let j = self.names.iter().position(|n| n == name)?;
        Some((self.params[j], self.stderr[j]))
    }
}

/// One rescaled curve on log-log axes, sorted by ln X.
struct LogCurve {
    lx: Vec<f64>,
    ly: Vec<f64>,
    /// Error of ln Y.
    ls: Vec<f64>,
}

fn rescaled(curves: &[Curve], rescale: Rescale<'_>, p: &[f64]) -> Result<Vec<LogCurve>, FitError> {
    curves
        .iter()
        .map(|c| {
            let mut pts: Vec<(f64, f64, f64)> = Vec::with_capacity(c.x.len());
            for i in 0..c.x.len() {
                let (x, y, s) = rescale(p, c, c.x[i], c.y[i], c.sigma[i]);
                if !(x > 0.0
                    && y > 0.0
                    && s > 0.0
                    && x.is_finite()
                    && y.is_finite()
                    && s.is_finite())
                {
                    return Err(FitError::invalid(
                        FORM,
                        format!(
                            "curve `{}` point {i} rescales to X = {x}, Y = {y}, sigma = {s} at \
                             parameters {p:?}; X, Y and sigma must be finite and > 0",
                            c.label
                        ),
                    ));
                }
                pts.push((x.ln(), y.ln(), s / y));
            }
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            Ok(LogCurve {
                lx: pts.iter().map(|p| p.0).collect(),
                ly: pts.iter().map(|p| p.1).collect(),
                ls: pts.iter().map(|p| p.2).collect(),
            })
        })
        .collect()
}

/// Linear interpolation of `c` at ln X = `x`: (ln Y, variance, weight), if `c`
/// spans `x`. The weight tapers the comparison to 0 at either end of `c`'s range
/// over its end interval (module doc): 1 from the second point to the last but one.
fn interpolate(c: &LogCurve, x: f64) -> Option<(f64, f64, f64)> {
    let n = c.lx.len();
    if n < 2 || x < c.lx[0] || x > c.lx[n - 1] {
        return None;
    }
    let k = c.lx.partition_point(|&v| v <= x).clamp(1, n - 1);
    let (x0, x1) = (c.lx[k - 1], c.lx[k]);
    let t = if x1 > x0 { (x - x0) / (x1 - x0) } else { 0.0 };
    let y = (1.0 - t) * c.ly[k - 1] + t * c.ly[k];
    // The two points' errors taken as fully correlated (module doc): the
    // interpolated error is their weighted mean, not the smaller
    // sqrt((1 - t)^2 s0^2 + t^2 s1^2) of independent errors.
    let var = ((1.0 - t) * c.ls[k - 1] + t * c.ls[k]).powi(2);
    // From 0 at the end `from` to 1 at the next point `to` (either side).
    let ramp = |from: f64, to: f64| {
        if to != from {
            ((x - from) / (to - from)).clamp(0.0, 1.0)
        } else {
            1.0
        }
    };
    let w = ramp(c.lx[0], c.lx[1]).min(ramp(c.lx[n - 1], c.lx[n - 2]));
    Some((y, var, w))
}

/// Collapse quality at parameters `p`. Fails (naming the curves) when the
/// rescaled curves do not all overlap, directly or through each other.
pub fn quality(curves: &[Curve], rescale: Rescale<'_>, p: &[f64]) -> Result<Quality, FitError> {
    if curves.len() < 2 {
        return Err(FitError::invalid(
            FORM,
            "a collapse needs at least two curves",
        ));
    }
    for c in curves {
        if c.y.len() != c.x.len() || c.sigma.len() != c.x.len() {
            return Err(FitError::invalid(
                FORM,
                format!("curve `{}`: x, y, sigma lengths differ", c.label),
            ));
        }
    }
    let logs = rescaled(curves, rescale, p)?;
    let k = logs.len();
    // Union-find over curves: which ones are linked by overlaps.
    let mut root: Vec<usize> = (0..k).collect();
    fn find(root: &mut [usize], mut a: usize) -> usize {
        while root[a] != a {
            root[a] = root[root[a]];
            a = root[a];
        }
        a
    }
    let (mut chi2, mut expected, mut comparisons) = (0.0, 0.0, 0usize);
    for (a, ca) in logs.iter().enumerate() {
        for j in 0..ca.lx.len() {
            // m: the comparisons' summed weight (their number where all are whole).
            let (mut sum, mut m) = (0.0, 0.0);
            for (b, cb) in logs.iter().enumerate() {
                if a == b {
                    continue;
                }
                if let Some((y, var, w)) = interpolate(cb, ca.lx[j]) {
                    sum += w * (ca.ly[j] - y).powi(2) / (ca.ls[j].powi(2) + var);
                    m += w;
                    comparisons += 1;
                    let (ra, rb) = (find(&mut root, a), find(&mut root, b));
                    root[ra] = rb;
                }
            }
            if m > 0.0 {
                chi2 += sum / (m + 1.0);
                expected += m / (m + 1.0);
            }
        }
    }
    let r0 = find(&mut root, 0);
    let apart: Vec<&str> = (0..k)
        .filter(|&c| find(&mut root, c) != r0)
        .map(|c| curves[c].label.as_str())
        .collect();
    if comparisons == 0 || expected <= 0.0 || !apart.is_empty() {
        return Err(FitError::unreliable(
            FORM,
            format!(
                "after rescaling with parameters {p:?} the curves do not overlap enough to judge a \
                 collapse ({comparisons} comparisons; not linked to `{}`: {apart:?}); widen the x \
                 ranges or narrow the parameter bounds",
                curves[0].label
            ),
        ));
    }
    Ok(Quality {
        s: chi2 / expected,
        chi2,
        expected,
        comparisons,
    })
}

/// Finds the parameters (named `names`, searched within finite `bounds`) that
/// minimise the collapse quality S.
pub fn collapse(
    curves: &[Curve],
    names: &[&str],
    bounds: &[(f64, f64)],
    rescale: Rescale<'_>,
) -> Result<CollapseResult, FitError> {
    let (u, q) = minimise(curves, names, bounds, rescale)?;
    let n = names.len();
    let p = unit_to_params(&u, bounds);
    let s_at = |u: &[f64]| -> f64 {
        if u.iter().any(|v| !(0.0..=1.0).contains(v)) {
            return f64::INFINITY;
        }
        quality(curves, rescale, &unit_to_params(u, bounds)).map_or(f64::INFINITY, |q| q.s)
    };
    // chi2 about the master curve, with the overlap count frozen at the minimum.
    let chi2_at = |v: &[f64]| s_at(v) * q.expected;
    let hess = hessian(&u, q.chi2, &chi2_at);
    let inv = spd_inverse(&hess).map_err(|j| FitError::IllConditioned {
        form: FORM.into(),
        parameter: names[j].into(),
        hint: "the collapse quality does not change with this parameter (or a combination); fix it"
            .into(),
    })?;
    let scale = 2.0 * q.s.max(1.0);
    let w: Vec<f64> = bounds.iter().map(|(lo, hi)| hi - lo).collect();
    let covariance: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| scale * inv[i][j] * w[i] * w[j]).collect())
        .collect();
    Ok(CollapseResult {
        names: names.iter().map(|s| s.to_string()).collect(),
        stderr: (0..n).map(|j| covariance[j][j].sqrt()).collect(),
        params: p,
        covariance,
        quality: q,
    })
}

fn unit_to_params(u: &[f64], bounds: &[(f64, f64)]) -> Vec<f64> {
    u.iter()
        .zip(bounds)
        .map(|(u, (lo, hi))| lo + u * (hi - lo))
        .collect()
}

/// The best parameters of a collapse without their covariance (a jackknife
/// refit needs only the minimum, even where the quality is flat around it).
pub fn best(
    curves: &[Curve],
    names: &[&str],
    bounds: &[(f64, f64)],
    rescale: Rescale<'_>,
) -> Result<Vec<f64>, FitError> {
    let (u, _) = minimise(curves, names, bounds, rescale)?;
    Ok(unit_to_params(&u, bounds))
}

/// The minimum of S in unit coordinates (inside the bounds, with enough overlap)
/// and its quality.
fn minimise(
    curves: &[Curve],
    names: &[&str],
    bounds: &[(f64, f64)],
    rescale: Rescale<'_>,
) -> Result<(Vec<f64>, Quality), FitError> {
    let n = names.len();
    if n == 0 || bounds.len() != n {
        return Err(FitError::invalid(
            FORM,
            format!(
                "{} names and {} bounds; give one finite bound pair per parameter",
                n,
                bounds.len()
            ),
        ));
    }
    if let Some((j, b)) = bounds
        .iter()
        .enumerate()
        .find(|(_, b)| !(b.0.is_finite() && b.1.is_finite() && b.0 < b.1))
    {
        return Err(FitError::invalid(
            FORM,
            format!("bounds of `{}` = {b:?}; need finite lo < hi", names[j]),
        ));
    }
    // Work in unit coordinates u in [0, 1]^n.
    let to_p = |u: &[f64]| unit_to_params(u, bounds);
    let s_at = |u: &[f64]| -> f64 {
        if u.iter().any(|v| !(0.0..=1.0).contains(v)) {
            return f64::INFINITY;
        }
        quality(curves, rescale, &to_p(u)).map_or(f64::INFINITY, |q| q.s)
    };
    let start = grid_start(n, &s_at);
    let u = nelder_mead(start, &s_at);
    let p = to_p(&u);
    // Report the real reason if even the best point has no usable overlap.
    let q = quality(curves, rescale, &p)?;
    if q.expected < (n + 1) as f64 {
        return Err(FitError::unreliable(
            FORM,
            format!(
                "only {} comparisons between overlapping curves for {n} parameters; extend the \
                 curves so they overlap",
                q.comparisons
            ),
        ));
    }
    for j in 0..n {
        if u[j] < 1e-6 || u[j] > 1.0 - 1e-6 {
            return Err(FitError::AtBound {
                form: FORM.into(),
                parameter: names[j].into(),
                value: p[j],
                bound: if u[j] < 0.5 { bounds[j].0 } else { bounds[j].1 },
                hint: "the best collapse lies at or beyond the search bounds; widen them".into(),
            });
        }
    }
    Ok((u, q))
}

/// Best point of a regular grid over the unit cube (1-3 parameters), else the centre.
fn grid_start(n: usize, f: &dyn Fn(&[f64]) -> f64) -> Vec<f64> {
    let g: usize = match n {
        1 => 101,
        2 => 31,
        3 => 11,
        _ => return vec![0.5; n],
    };
    let mut best = (f64::INFINITY, vec![0.5; n]);
    for idx in 0..g.pow(n as u32) {
        let u: Vec<f64> = (0..n)
            .map(|d| ((idx / g.pow(d as u32)) % g) as f64 / (g - 1) as f64)
            .collect();
        let v = f(&u);
        if v < best.0 {
            best = (v, u);
        }
    }
    best.1
}

/// Nelder-Mead in the unit cube (points outside evaluate to +inf).
fn nelder_mead(start: Vec<f64>, f: &dyn Fn(&[f64]) -> f64) -> Vec<f64> {
    let n = start.len();
    let mut simplex: Vec<(f64, Vec<f64>)> = vec![(f(&start), start.clone())];
    for d in 0..n {
        let mut v = start.clone();
        v[d] += if v[d] > 0.5 { -0.02 } else { 0.02 };
        simplex.push((f(&v), v));
    }
    for _ in 0..2000 {
        simplex.sort_by(|a, b| a.0.total_cmp(&b.0));
        let size = simplex
            .iter()
            .skip(1)
            .map(|(_, v)| {
                v.iter()
                    .zip(&simplex[0].1)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if size < 1e-9 {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|d| simplex[..n].iter().map(|(_, v)| v[d]).sum::<f64>() / n as f64)
            .collect();
        let worst = simplex[n].1.clone();
        let along = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(&worst)
                .map(|(c, w)| c + t * (c - w))
                .collect()
        };
        let r = along(1.0);
        let fr = f(&r);
        if fr < simplex[0].0 {
            let e = along(2.0);
            let fe = f(&e);
            simplex[n] = if fe < fr { (fe, e) } else { (fr, r) };
        } else if fr < simplex[n - 1].0 {
            simplex[n] = (fr, r);
        } else {
            let c = along(-0.5);
            let fc = f(&c);
            if fc < simplex[n].0 {
                simplex[n] = (fc, c);
            } else {
                let best = simplex[0].1.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.1 =
                        s.1.iter()
                            .zip(&best)
                            .map(|(v, b)| b + 0.5 * (v - b))
                            .collect();
                    s.0 = f(&s.1);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.0.total_cmp(&b.0));
    simplex.swap_remove(0).1
}

/// Finite-difference Hessian of `f` at `u` (f(u) = `f0`), each step sized so
/// that f rises by about 1 (the 1-sigma scale of a chi-square).
fn hessian(u: &[f64], f0: f64, f: &dyn Fn(&[f64]) -> f64) -> Vec<Vec<f64>> {
    let n = u.len();
    let shifted = |steps: &[(usize, f64)]| {
        let mut v = u.to_vec();
        for &(d, h) in steps {
            v[d] += h;
        }
        f(&v)
    };
    let room: Vec<f64> = u.iter().map(|v| v.min(1.0 - v)).collect();
    let h: Vec<f64> = (0..n)
        .map(|d| {
            let mut h = 1e-3f64.min(0.5 * room[d]);
            for _ in 0..3 {
                let rise = 0.5 * (shifted(&[(d, h)]) + shifted(&[(d, -h)])) - f0;
                if !(rise > 0.0 && rise.is_finite()) {
                    break;
                }
                h = (h / rise.sqrt()).min(0.5 * room[d]).max(1e-9);
            }
            h
        })
        .collect();
    let mut hess = vec![vec![0.0; n]; n];
    for i in 0..n {
        hess[i][i] = (shifted(&[(i, h[i])]) - 2.0 * f0 + shifted(&[(i, -h[i])])) / (h[i] * h[i]);
        for j in 0..i {
            let v = (shifted(&[(i, h[i]), (j, h[j])])
                - shifted(&[(i, h[i]), (j, -h[j])])
                - shifted(&[(i, -h[i]), (j, h[j])])
                + shifted(&[(i, -h[i]), (j, -h[j])]))
                / (4.0 * h[i] * h[j]);
            hess[i][j] = v;
            hess[j][i] = v;
        }
    }
    hess
}
