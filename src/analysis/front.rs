//! The momentum front of paper I, figs 1-2 (gamma = 0, walls on four sides, the
//! intruder pulled from the left end): the coarse-grained velocity field, the
//! front's position and width from the momentum profile Px(x), their speeds, and
//! the packing fraction the front leaves at the far wall.
//!
//! The front is read from the bath's momentum profile Px(x) (the intruder left
//! out; [`super::intruder::compute_profile`]) averaged over replicas, taken as a
//! distribution of momentum along x: its centre is the first moment and its
//! width its standard deviation (the positive part of Px, so the wall's
//! backflow does not enter). V_cm is the least-squares slope of the centre over
//! a time window before the front reaches the far wall, V_br that of the width
//! through the origin, Delta = V_br t as paper I writes it (`width_growth`);
//! every error is a delete-one jackknife over replicas of the whole chain
//! (profile, moments, slopes).

use anyhow::{Result, bail};
use arrow_array::{Float64Array, RecordBatch};
use serde::Deserialize;

use super::intruder::{ProfileParams, compute_profile};
use super::stats::jackknife_err;
use super::{check_trajectory, frame_with_velocities};
use crate::table::f64_batch;
use crate::traj::{Frame, Trajectory};

/// The intruder's species.
const INTRUDER: u8 = 2;

fn default_cells_x() -> usize {
    25
}

/// Parameters of the velocity field.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FieldParams {
    /// Times of the snapshots (the nearest frame of each replica).
    pub times: Vec<f64>,
    /// Grid cells along x; cells are square, so Ly / (Lx / cells_x) rows (at least 1).
    #[serde(default = "default_cells_x")]
    pub cells_x: usize,
}

fn check_all(trajs: &[&Trajectory]) -> Result<()> {
    if trajs.is_empty() {
        bail!("no trajectory");
    }
    for t in trajs {
        check_trajectory(t)?;
        if t.box_size != trajs[0].box_size {
            bail!(
                "replicas have different boxes ({:?} and {:?}): gather one state point",
                trajs[0].box_size,
                t.box_size
            );
        }
    }
    Ok(())
}

/// Velocity field on a grid of square cells at each time, pooled over replicas:
/// in every cell the bath's mass-weighted mean velocity (sum m v / sum m over the
/// disks whose centre lies in it, in every replica). Main table `t, x, y, vx, vy`
/// (cell centres; empty cells are left out); second table `t, x, y` the
/// intruder's position averaged over replicas.
pub fn velocity_field(
    trajs: &[&Trajectory],
    p: &FieldParams,
) -> Result<(RecordBatch, RecordBatch)> {
    check_all(trajs)?;
    if p.cells_x == 0 {
        bail!("parameter `cells_x` must be at least 1");
    }
    if p.times.is_empty() {
        bail!("parameter `times` is empty: give at least one time");
    }
    let [lx, ly] = trajs[0].box_size;
    let h = lx / p.cells_x as f64;
    let (nx, ny) = (p.cells_x, ((ly / h).round() as usize).max(1));
    let hy = ly / ny as f64;
    let mut cols: [Vec<f64>; 5] = Default::default();
    let mut icols: [Vec<f64>; 3] = Default::default();
    for &t in &p.times {
        // [sum m vx, sum m vy, sum m] per cell.
        let mut acc = vec![[0.0; 3]; nx * ny];
        let (mut xi, mut yi, mut time) = (0.0, 0.0, 0.0);
        for traj in trajs {
            let f = frame_with_velocities(traj, t)?;
            time += f.time;
            for i in 0..traj.n() {
                let s = traj.species[i];
                let (x, y) = (
                    super::fold(f.x[i], lx, traj.periodic[0]),
                    super::fold(f.y[i], ly, traj.periodic[1]),
                );
                if s == INTRUDER {
                    xi += x;
                    yi += y;
                    continue;
                }
                let cx = ((x / h).floor().max(0.0) as usize).min(nx - 1);
                let cy = ((y / hy).floor().max(0.0) as usize).min(ny - 1);
                let m = traj.masses[s as usize];
                let a = &mut acc[cy * nx + cx];
                a[0] += m * f.vx[i];
                a[1] += m * f.vy[i];
                a[2] += m;
            }
        }
        let r = trajs.len() as f64;
        let time = time / r;
        for cy in 0..ny {
            for cx in 0..nx {
                let a = acc[cy * nx + cx];
                if a[2] > 0.0 {
                    for (c, v) in cols.iter_mut().zip([
                        time,
                        (cx as f64 + 0.5) * h,
                        (cy as f64 + 0.5) * hy,
                        a[0] / a[2],
                        a[1] / a[2],
                    ]) {
                        c.push(v);
                    }
                }
            }
        }
        // Without an intruder its position is NaN (nothing to mark).
        let k = trajs
            .iter()
            .map(|t| t.species.iter().filter(|&&s| s == INTRUDER).count())
            .sum::<usize>() as f64;
        for (c, v) in icols.iter_mut().zip([time, xi / k, yi / k]) {
            c.push(v);
        }
    }
    let [t, x, y, vx, vy] = cols;
    let main = f64_batch(&[("t", t), ("x", x), ("y", y), ("vx", vx), ("vy", vy)])?;
    let [t, x, y] = icols;
    let intruder = f64_batch(&[("t", t), ("x", x), ("y", y)])?;
    Ok((main, intruder))
}

fn default_bin() -> f64 {
    4.0
}

/// The region where the compacted packing fraction is measured: a rectangle
/// `width` wide along x ending `offset` before the far wall (x = Lx), leaving
/// `margin` to the walls in y (defaults 0: the box's full height at the wall).
/// Each disk counts with its area inside the rectangle, so the number is the
/// paper's area fraction of that part of the box (its wall layers included).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WallRegion {
    pub width: f64,
    #[serde(default)]
    pub offset: f64,
    #[serde(default)]
    pub margin: f64,
}

/// Parameters of the front analysis.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FrontParams {
    /// Bin width of the momentum profile along x (units r1).
    #[serde(default = "default_bin")]
    pub bin: f64,
    /// Time window [t_min, t_max] of the speed fits (before the front meets the wall).
    pub fit: [f64; 2],
    /// Time window averaged for the packing fraction at the far wall.
    pub compact: [f64; 2],
    /// Where that packing fraction is measured.
    pub wall: WallRegion,
    /// Time step of the positions table (frames nearest to multiples of it
    /// from 0 to the last frame; default: every frame).
    #[serde(default)]
    pub every: Option<f64>,
    /// Count the intruder's own momentum in Px(x) (paper I does not say whether
    /// its front profile leaves it out; default: left out, the bath's front).
    #[serde(default)]
    pub include_intruder: bool,
    /// How V_br is read from the width over the fit window.
    #[serde(default)]
    pub width_growth: WidthGrowth,
}

/// How the width's growth V_br is read from width(t).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum WidthGrowth {
    /// Delta = V_br t, paper I's text: least squares through the origin.
    #[default]
    ThroughOrigin,
    /// The slope of a line with its intercept free (the width the front has
    /// when the fit window opens left out).
    Slope,
}

/// One replica's front data at the analysed times: the momentum profile per time
/// (bins) and the packing fraction of the wall region.
struct Replica {
    profiles: Vec<Vec<f64>>,
    eta_wall: Vec<f64>,
}

/// Centre (first moment) and width (standard deviation) of the positive part
/// of a profile `px` on bin centres `x`.
pub fn moments(x: &[f64], px: &[f64]) -> (f64, f64) {
    let (mut s0, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for (&x, &p) in x.iter().zip(px) {
        let w = p.max(0.0);
        s0 += w;
        s1 += w * x;
        s2 += w * x * x;
    }
    let c = s1 / s0;
    (c, (s2 / s0 - c * c).max(0.0).sqrt())
}

/// y at `x0`, linear between the points (xs ascending), clamped at the ends.
fn interpolate(xs: &[f64], y: &[f64], x0: f64) -> f64 {
    if !x0.is_finite() {
        return f64::NAN;
    }
    let j = xs.partition_point(|&x| x < x0);
    if j == 0 {
        return y[0];
    }
    if j == xs.len() {
        return y[xs.len() - 1];
    }
    let a = (x0 - xs[j - 1]) / (xs[j] - xs[j - 1]);
    y[j - 1] + a * (y[j] - y[j - 1])
}

/// Least-squares slope of y = v x (a line through the origin).
pub fn proportional(x: &[f64], y: &[f64]) -> f64 {
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
    sxy / x.iter().map(|a| a * a).sum::<f64>()
}

/// Least-squares slope of y against x.
pub fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

/// Area of the disk (centre `c`, radius `r`) inside the rectangle
/// [x0, x1] x [y0, y1]: exact when the disk lies wholly inside or outside, else
/// the clipped chord integrated over x (midpoint rule in the angle, where the
/// integrand is smooth).
pub fn disk_area_in(c: [f64; 2], r: f64, [x0, x1]: [f64; 2], [y0, y1]: [f64; 2]) -> f64 {
    let [xc, yc] = c;
    if xc + r <= x0 || xc - r >= x1 || yc + r <= y0 || yc - r >= y1 {
        return 0.0;
    }
    if xc - r >= x0 && xc + r <= x1 && yc - r >= y0 && yc + r <= y1 {
        return std::f64::consts::PI * r * r;
    }
    // x = xc - r cos(theta): dx = r sin(theta) dtheta and the chord's half
    // length is r sin(theta); theta runs over the part of [0, pi] inside
    // [x0, x1], so the integrand has no jump (only kinks where y clips).
    const STEPS: usize = 400;
    let angle = |x: f64| ((xc - x) / r).clamp(-1.0, 1.0).acos();
    let (th0, th1) = (angle(x0), angle(x1));
    let dtheta = (th1 - th0) / STEPS as f64;
    let mut area = 0.0;
    for k in 0..STEPS {
        let th = th0 + (k as f64 + 0.5) * dtheta;
        let half = r * th.sin();
        let len = ((yc + half).min(y1) - (yc - half).max(y0)).max(0.0);
        area += len * r * th.sin() * dtheta;
    }
    area
}

/// Packing fraction of the wall region in frame `f`: the disks' area inside it
/// over its area.
fn wall_packing(traj: &Trajectory, f: &Frame, w: &WallRegion) -> f64 {
    let [lx, ly] = traj.box_size;
    let xr = [lx - w.offset - w.width, lx - w.offset];
    let yr = [w.margin, ly - w.margin];
    let area: f64 = (0..traj.n())
        .map(|i| {
            let r = traj.radii[traj.species[i] as usize];
            let x = super::fold(f.x[i], lx, traj.periodic[0]);
            let y = super::fold(f.y[i], ly, traj.periodic[1]);
            disk_area_in([x, y], r, xr, yr)
        })
        .sum();
    area / ((xr[1] - xr[0]) * (yr[1] - yr[0]))
}

/// The front's numbers from replicas `use_`: per time the centre, width and
/// wall packing fraction, then [V_cm, V_br, V_br / V_cm, eta_wall].
struct Numbers {
    centre: Vec<f64>,
    /// The mean profile at the centre (linear between bin centres), to mark it.
    px_centre: Vec<f64>,
    width: Vec<f64>,
    eta: Vec<f64>,
    keys: [f64; 4],
    /// Intercepts of the fitted lines of centre and width.
    intercepts: [f64; 2],
}

fn numbers(reps: &[&Replica], xs: &[f64], times: &[f64], p: &FrontParams) -> Numbers {
    let r = reps.len() as f64;
    let (mut centre, mut px_centre, mut width, mut eta) = (vec![], vec![], vec![], vec![]);
    for k in 0..times.len() {
        let mean: Vec<f64> = (0..xs.len())
            .map(|b| reps.iter().map(|q| q.profiles[k][b]).sum::<f64>() / r)
            .collect();
        let (c, w) = moments(xs, &mean);
        centre.push(c);
        px_centre.push(interpolate(xs, &mean, c));
        width.push(w);
        eta.push(reps.iter().map(|q| q.eta_wall[k]).sum::<f64>() / r);
    }
    let in_window = |lo: f64, hi: f64| -> Vec<usize> {
        (0..times.len())
            .filter(|&k| times[k] >= lo - 1e-9 && times[k] <= hi + 1e-9)
            .collect()
    };
    let fit = in_window(p.fit[0], p.fit[1]);
    let pick = |v: &[f64]| fit.iter().map(|&k| v[k]).collect::<Vec<f64>>();
    let tf = pick(times);
    let (cf, wf) = (pick(&centre), pick(&width));
    let v_cm = slope(&tf, &cf);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let t_mean = mean(&tf);
    let (v_br, width_at_0) = match p.width_growth {
        WidthGrowth::ThroughOrigin => (proportional(&tf, &wf), 0.0),
        WidthGrowth::Slope => {
            let v = slope(&tf, &wf);
            (v, mean(&wf) - v * t_mean)
        }
    };
    let intercepts = [mean(&cf) - v_cm * t_mean, width_at_0];
    let comp = in_window(p.compact[0], p.compact[1]);
    let eta_wall = comp.iter().map(|&k| eta[k]).sum::<f64>() / comp.len() as f64;
    Numbers {
        centre,
        px_centre,
        width,
        eta,
        keys: [v_cm, v_br, v_br / v_cm, eta_wall],
        intercepts,
    }
}

/// Front analysis of the gathered replicas. Main table: `quantity, value, error,
/// note` with V_cm, V_br, V_ratio (= V_br / V_cm) and eta_wall; second table
/// `t, x_cm, x_cm_err, Px_cm, width, width_err, eta_wall, eta_wall_err` per analysed time;
/// third table `t, x_cm, width`: the fitted lines over the fit window.
pub fn front(trajs: &[&Trajectory], p: &FrontParams) -> Result<[RecordBatch; 3]> {
    check_all(trajs)?;
    let [lx, _] = trajs[0].box_size;
    if !(p.bin.is_finite() && p.bin > 0.0 && p.bin < lx) {
        bail!("parameter `bin` = {} must lie in (0, Lx = {lx})", p.bin);
    }
    let w = &p.wall;
    if !(w.width > 0.0 && w.offset >= 0.0 && w.margin >= 0.0) {
        bail!("parameter `wall` needs width > 0, offset >= 0 and margin >= 0");
    }
    let ly = trajs[0].box_size[1];
    if w.width + w.offset > lx || 2.0 * w.margin >= ly {
        bail!(
            "parameter `wall` (width {}, offset {}, margin {}) does not fit the box {lx} x {ly}",
            w.width,
            w.offset,
            w.margin
        );
    }
    for (name, [lo, hi]) in [("fit", p.fit), ("compact", p.compact)] {
        // NaN-safe: a NaN bound is refused too.
        if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
            bail!("parameter `{name}` = [{lo}, {hi}] must be an interval t_min < t_max");
        }
    }
    // Analysed times: every frame of the first replica (or a coarser grid).
    let frame_times = trajs[0].times();
    let times: Vec<f64> = match p.every {
        None => frame_times.clone(),
        Some(dt) if dt > 0.0 => {
            let last = *frame_times.last().expect("checked non-empty");
            let mut t: Vec<f64> = (0..=((last / dt + 1e-9).floor() as usize))
                .map(|k| k as f64 * dt)
                .collect();
            t.dedup();
            t
        }
        Some(dt) => bail!("parameter `every` = {dt} must be > 0"),
    };
    for (name, [lo, hi]) in [("fit", p.fit), ("compact", p.compact)] {
        let n = times
            .iter()
            .filter(|&&t| t >= lo - 1e-9 && t <= hi + 1e-9)
            .count();
        let need = if name == "fit" { 3 } else { 1 };
        if n < need {
            bail!(
                "parameter `{name}` = [{lo}, {hi}] holds {n} analysed time(s) (frames from {} to {}): give a window with at least {need}",
                times[0],
                times[times.len() - 1]
            );
        }
    }
    let bins = ((lx / p.bin).round() as usize).max(1);
    let pp = ProfileParams {
        times: times.clone(),
        bins,
        exclude_species: (!p.include_intruder).then_some(INTRUDER),
    };
    let mut reps = Vec::with_capacity(trajs.len());
    let mut xs = Vec::new();
    for traj in trajs {
        let b = compute_profile(traj, &pp)?;
        let col = |name: &str| -> Vec<f64> {
            b.column_by_name(name)
                .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
                .expect("compute_profile writes t, x, Px")
                .values()
                .to_vec()
        };
        let (x, px) = (col("x"), col("Px"));
        xs = x[..bins].to_vec();
        let profiles = px.chunks(bins).map(<[f64]>::to_vec).collect();
        let eta_wall = times
            .iter()
            .map(|&t| frame_with_velocities(traj, t).map(|f| wall_packing(traj, f, w)))
            .collect::<Result<Vec<_>>>()?;
        reps.push(Replica { profiles, eta_wall });
    }
    let all: Vec<&Replica> = reps.iter().collect();
    let full = numbers(&all, &xs, &times, p);
    // Delete-one jackknife over replicas.
    let loo: Vec<Numbers> = if reps.len() >= 2 {
        (0..reps.len())
            .map(|k| {
                let some: Vec<&Replica> = (0..reps.len())
                    .filter(|&j| j != k)
                    .map(|j| &reps[j])
                    .collect();
                numbers(&some, &xs, &times, p)
            })
            .collect()
    } else {
        Vec::new()
    };
    let err = |f: &dyn Fn(&Numbers) -> f64| jackknife_err(loo.iter().map(f).collect());
    let names = ["V_cm", "V_br", "V_ratio", "eta_wall"];
    let note = if reps.len() < 2 {
        "one replica: no error".to_string()
    } else {
        String::new()
    };
    let value: Vec<f64> = full.keys.to_vec();
    let error: Vec<f64> = (0..4).map(|q| err(&|n: &Numbers| n.keys[q])).collect();
    let rows: Vec<(String, f64, f64)> = names
        .iter()
        .zip(value.iter().zip(&error))
        .map(|(n, (v, e))| (n.to_string(), *v, *e))
        .collect();
    let main = crate::table::results::quantity_batch(&[], &rows, &note, None)?;
    let per_time = |f: &dyn Fn(&Numbers) -> &Vec<f64>| -> Vec<f64> {
        (0..times.len())
            .map(|k| jackknife_err(loo.iter().map(|n| f(n)[k]).collect()))
            .collect()
    };
    let positions = f64_batch(&[
        ("t", times.clone()),
        ("x_cm", full.centre.clone()),
        ("x_cm_err", per_time(&|n| &n.centre)),
        ("Px_cm", full.px_centre.clone()),
        ("width", full.width.clone()),
        ("width_err", per_time(&|n| &n.width)),
        ("eta_wall", full.eta.clone()),
        ("eta_wall_err", per_time(&|n| &n.eta)),
    ])?;
    // The fitted lines over the fit window, to draw them.
    let tf: Vec<f64> = times
        .iter()
        .copied()
        .filter(|&t| t >= p.fit[0] - 1e-9 && t <= p.fit[1] + 1e-9)
        .collect();
    let line = |a: f64, b: f64| tf.iter().map(|t| a + b * t).collect::<Vec<f64>>();
    let lines = f64_batch(&[
        ("t", tf.clone()),
        ("x_cm", line(full.intercepts[0], full.keys[0])),
        ("width", line(full.intercepts[1], full.keys[1])),
    ])?;
    Ok([main, positions, lines])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::test_support::col;
    use arrow_array::{Array, StringArray};
    use std::f64::consts::PI;

    #[test]
    fn disk_area_in_rectangle_matches_geometry() {
        let (r, big) = (1.3, [-10.0, 10.0]);
        assert_eq!(disk_area_in([0.0, 0.0], r, big, big), PI * r * r);
        assert_eq!(disk_area_in([20.0, 0.0], r, big, big), 0.0);
        // Cut through the centre: half; a corner at the centre: a quarter.
        let half = disk_area_in([0.0, 0.0], r, [0.0, 10.0], big);
        assert!((half / (PI * r * r) - 0.5).abs() < 1e-5, "{half}");
        let quarter = disk_area_in([0.0, 0.0], r, [0.0, 10.0], [0.0, 10.0]);
        assert!((quarter / (PI * r * r) - 0.25).abs() < 1e-5, "{quarter}");
        // A chord at distance d: the segment r^2 acos(d/r) - d sqrt(r^2 - d^2).
        for d in [0.1, 0.7, 1.2] {
            let seg = r * r * (d / r).acos() - d * (r * r - d * d).sqrt();
            let got = disk_area_in([0.0, 0.0], r, [d, 10.0], big);
            assert!((got - seg).abs() < 1e-4 * r * r, "d = {d}: {got} vs {seg}");
        }
    }

    #[test]
    fn moments_of_a_plateau_ignore_the_backflow() {
        // Px = 1 on [10, 50), bins 1 wide, and a negative wake before it.
        let x: Vec<f64> = (0..100).map(|k| k as f64 + 0.5).collect();
        let px: Vec<f64> = x
            .iter()
            .map(|&x| match x {
                x if x < 5.0 => -3.0,
                x if (10.0..50.0).contains(&x) => 1.0,
                _ => 0.0,
            })
            .collect();
        let (c, w) = moments(&x, &px);
        assert!((c - 30.0).abs() < 1e-12, "{c}");
        // Uniform over 40 bins: sqrt((40^2 - 1)/12).
        assert!((w - ((1600.0f64 - 1.0) / 12.0).sqrt()).abs() < 1e-9, "{w}");
        assert!((slope(&[0.0, 1.0, 2.0, 3.0], &[1.0, 3.5, 6.0, 8.5]) - 2.5).abs() < 1e-12);
    }

    /// Disks of radius 0.3 on the unit lattice (centres at half-integers) of an
    /// 80 x 10 walled box; the bath moves at vx = 1 behind x_f(t) = 10 + 20 t
    /// and rests ahead; the intruder (species 2) sits at (2 + t, 5).
    fn plateau(times: &[f64], vy: f64) -> Trajectory {
        let (lx, ly) = (80.0, 10.0);
        let mut species = vec![2u8];
        let mut pos = vec![[2.0, 5.0]];
        for i in 0..80 {
            for j in 0..10 {
                species.push(0);
                pos.push([i as f64 + 0.5, j as f64 + 0.5]);
            }
        }
        let frames = times
            .iter()
            .map(|&t| {
                let xf = 10.0 + 20.0 * t;
                let mut x: Vec<f64> = pos.iter().map(|p| p[0]).collect();
                x[0] += t;
                let vx = pos
                    .iter()
                    .map(|p| if p[0] < xf { 1.0 } else { 0.0 })
                    .collect();
                Frame {
                    time: t,
                    x,
                    y: pos.iter().map(|p| p[1]).collect(),
                    vx,
                    vy: vec![vy; pos.len()],
                }
            })
            .collect();
        Trajectory {
            box_size: [lx, ly],
            periodic: [false, false],
            species,
            radii: vec![0.3, 0.3, 1.0],
            masses: vec![1.0, 1.0, 4.0],
            frames,
            schedule: None,
        }
    }

    fn params() -> FrontParams {
        serde_json::from_value(serde_json::json!({
            "bin": 1.0, "fit": [0.5, 2.5], "compact": [0.0, 3.0], "wall": {"width": 8.0}
        }))
        .unwrap()
    }

    #[test]
    fn front_of_a_moving_plateau_has_the_analytic_speeds() {
        let times: Vec<f64> = (0..31).map(|k| k as f64 * 0.1).collect();
        let t = plateau(&times, 0.0);
        let [main, positions, lines] = front(&[&t, &t, &t], &params()).unwrap();
        let q = main
            .column_by_name(crate::table::results::QUANTITY)
            .unwrap()
            .as_any()
            .downcast_ref::<StringArray>()
            .unwrap();
        let (value, error) = (
            col(&main, crate::table::results::VALUE),
            col(&main, crate::table::results::ERROR),
        );
        let get = |name: &str| {
            let i = (0..q.len()).find(|&i| q.value(i) == name).unwrap();
            (value[i], error[i])
        };
        // Plateau [0, x_f): centre x_f / 2, width x_f / sqrt(12), up to the bins.
        let (v_cm, e) = get("V_cm");
        assert!((v_cm - 10.0).abs() < 0.2, "V_cm = {v_cm}");
        assert_eq!(e, 0.0, "identical replicas: no spread");
        // Width (10 + 20 t)/sqrt(12): Delta = V_br t through the origin over the
        // window's times, or the slope 20/sqrt(12) with `width_growth: slope`.
        let (v_br, _) = get("V_br");
        let tw: Vec<f64> = times
            .iter()
            .copied()
            .filter(|t| (0.5 - 1e-9..=2.5 + 1e-9).contains(t))
            .collect();
        let w: Vec<f64> = tw
            .iter()
            .map(|t| (10.0 + 20.0 * t) / 12f64.sqrt())
            .collect();
        let expect = proportional(&tw, &w);
        assert!(
            (v_br - expect).abs() < 0.2,
            "V_br = {v_br}, expected {expect}"
        );
        let slope_params = FrontParams {
            width_growth: WidthGrowth::Slope,
            ..params()
        };
        let [slope_main, ..] = front(&[&t, &t, &t], &slope_params).unwrap();
        let i = (0..q.len()).find(|&i| q.value(i) == "V_br").unwrap();
        let v_slope = col(&slope_main, crate::table::results::VALUE)[i];
        assert!(
            (v_slope - 20.0 / 12f64.sqrt()).abs() < 0.2,
            "V_br (slope) = {v_slope}"
        );
        assert!((get("V_ratio").0 - v_br / v_cm).abs() < 1e-12);
        // The lattice strip of whole cells: pi r^2 per unit cell.
        let (eta, _) = get("eta_wall");
        assert!((eta - PI * 0.09).abs() < 1e-6, "eta_wall = {eta}");
        assert_eq!(col(&positions, "t").len(), times.len());
        // The fitted line passes through the measured centres.
        let (tl, xl) = (col(&lines, "t"), col(&lines, "x_cm"));
        assert!((tl[0] - 0.5).abs() < 1e-9 && (tl[tl.len() - 1] - 2.5).abs() < 1e-9);
        assert!((xl[0] - 0.5 * (10.0 + 20.0 * 0.5)).abs() < 0.5, "{}", xl[0]);
    }

    /// Every column the front and field tables publish has a unit and a
    /// description (src/table/columns.rs).
    #[test]
    fn every_front_column_is_described() {
        let times: Vec<f64> = (0..31).map(|k| k as f64 * 0.1).collect();
        let t = plateau(&times, 0.0);
        let p = FieldParams {
            times: vec![1.0],
            cells_x: 8,
        };
        let (field, intruder) = velocity_field(&[&t, &t], &p).unwrap();
        let [main, positions, lines] = front(&[&t, &t, &t], &params()).unwrap();
        for b in [&field, &intruder, &main, &positions, &lines] {
            for f in b.schema().fields() {
                assert!(
                    crate::table::columns::describe(f.name()).is_some(),
                    "column `{}` has no row in src/table/columns.rs",
                    f.name()
                );
            }
        }
    }

    #[test]
    fn velocity_field_averages_cells_and_marks_the_intruder() {
        let t = plateau(&[0.0, 1.0], -0.5);
        let p = FieldParams {
            times: vec![1.0],
            cells_x: 8,
        };
        let (field, intruder) = velocity_field(&[&t, &t], &p).unwrap();
        // Cells 10 wide: rows of 1 cell in y; x_f = 30 at t = 1.
        let (x, vx, vy) = (col(&field, "x"), col(&field, "vx"), col(&field, "vy"));
        assert_eq!(x.len(), 8);
        for k in 0..8 {
            let want = if x[k] < 30.0 { 1.0 } else { 0.0 };
            assert_eq!(vx[k], want, "cell at x = {}", x[k]);
            assert_eq!(vy[k], -0.5);
        }
        assert_eq!(col(&intruder, "x"), vec![3.0]);
        assert_eq!(col(&intruder, "y"), vec![5.0]);
    }

    #[test]
    fn bad_inputs_name_the_parameter() {
        let times: Vec<f64> = (0..31).map(|k| k as f64 * 0.1).collect();
        let mut t = plateau(&times, 0.0);
        let mut p = params();
        p.fit = [5.0, 6.0];
        let e = format!("{:#}", front(&[&t], &p).err().unwrap());
        assert!(e.contains("`fit`") && e.contains("0 analysed time"), "{e}");
        let mut p = params();
        p.wall.width = 100.0;
        let e = format!("{:#}", front(&[&t], &p).err().unwrap());
        assert!(e.contains("`wall`"), "{e}");
        for f in &mut t.frames {
            f.vx.clear();
        }
        let e = format!("{:#}", front(&[&t], &params()).err().unwrap());
        assert!(e.contains("no velocities"), "{e}");
    }
}
