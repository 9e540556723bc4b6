//! Which lags to analyse and which frame pairs (time origins) serve each lag.

use anyhow::{Result, bail};

use crate::traj::Trajectory;

/// One lag with every frame pair that realises it, over all replicas.
#[derive(Clone, Debug, PartialEq)]
pub struct Lag {
    /// The lag t (time difference between the two frames).
    pub t: f64,
    /// (replica, origin frame, later frame) for every time origin.
    pub pairs: Vec<(usize, usize, usize)>,
}

impl Lag {
    /// Accumulation block of a pair: (replica, origin frame index). Per-origin
    /// analyses (Fig. 2's aging) read these keys; errors regroup them with
    /// [`origin_bins`].
    pub fn block(pair: &(usize, usize, usize)) -> (usize, usize) {
        (pair.0, pair.1)
    }
}

/// The jackknife unit of an error: (replica, origin bin), bins `length` long from
/// each replica's first frame. Origins closer than the structural relaxation time
/// see overlapping stretches of the same motion, so their blocks are correlated and
/// a jackknife over them quotes too small an error; with `length` >= tau_alpha the
/// bins are nearly independent. A `length` that is not a positive number leaves
/// every origin its own bin.
pub fn origin_bins(
    trajs: &[&Trajectory],
    length: f64,
) -> impl Fn(&(usize, usize)) -> (usize, usize) + use<> {
    let starts: Vec<f64> = trajs
        .iter()
        .map(|t| t.frames.first().map_or(0.0, |f| f.time))
        .collect();
    let times: Vec<Vec<f64>> = trajs.iter().map(|t| t.times()).collect();
    move |&(r, i): &(usize, usize)| {
        if !(length.is_finite() && length > 0.0) {
            return (r, i);
        }
        // The slack keeps an origin that lands on a bin edge in the later bin.
        let bin = ((times[r][i] - starts[r]) / length + 1e-9).floor();
        (r, bin as usize)
    }
}

/// The lags to analyse: `requested` (each must exist in at least one replica) or, by
/// default, every distinct `t_j - t_0` of the first replica. Lags that no replica
/// realises are a clear error; lag 0 is skipped.
pub fn select(trajs: &[&Trajectory], requested: Option<&[f64]>, rel_tol: f64) -> Result<Vec<Lag>> {
    let Some(first) = trajs.first() else {
        bail!("no trajectory given");
    };
    if !((0.0..0.5).contains(&rel_tol)) {
        bail!("parameter `rel_tol` must be in [0, 0.5), got {rel_tol}");
    }
    let candidates: Vec<f64> = match requested {
        Some(r) => {
            if r.is_empty() {
                bail!("parameter `lags` is empty: give at least one lag or omit it");
            }
            if let Some(bad) = r.iter().find(|l| !(l.is_finite() && **l > 0.0)) {
                bail!("parameter `lags` must hold finite lags > 0, got {bad}");
            }
            r.to_vec()
        }
        None => {
            let t = first.times();
            let mut l: Vec<f64> = t.iter().skip(1).map(|x| x - t[0]).collect();
            l.dedup_by(|a, b| (*a - *b).abs() <= rel_tol.max(1e-12) * b.abs());
            l
        }
    };
    let mut out = Vec::with_capacity(candidates.len());
    for &t in &candidates {
        let pairs: Vec<(usize, usize, usize)> = trajs
            .iter()
            .enumerate()
            .flat_map(|(r, tr)| {
                tr.pairs_at_lag(t, rel_tol)
                    .into_iter()
                    .map(move |(i, j)| (r, i, j))
            })
            .collect();
        if pairs.is_empty() {
            if requested.is_some() {
                let avail: Vec<String> = first
                    .times()
                    .iter()
                    .skip(1)
                    .take(8)
                    .map(|x| format!("{:.6}", x - first.frames[0].time))
                    .collect();
                bail!(
                    "lag {t} is not realised by any pair of frames (within relative tolerance \
                     {rel_tol}); lags from the first frame are {} ...",
                    avail.join(", ")
                );
            }
            continue;
        }
        out.push(Lag { t, pairs });
    }
    if out.is_empty() {
        bail!("the trajectory has fewer than two frames: no lag to analyse");
    }
    Ok(out)
}

/// The lags every time origin of every replica realises: `requested` if given, else
/// the schedule's own lags. Trajectories that carry their schedule (every
/// simulation's) give its lags directly; for others the shortest lag sets the
/// count of origins, and a lag with fewer pairs comes only from differences
/// between frames of different origins (mixing those in makes curves jagged).
pub fn every_origin(
    trajs: &[&Trajectory],
    requested: Option<Vec<f64>>,
    rel_tol: f64,
) -> Result<Option<Vec<f64>>> {
    if requested.is_some() {
        return Ok(requested);
    }
    let schedules: Option<Vec<&Vec<f64>>> = trajs
        .iter()
        .map(|t| t.schedule.as_ref().map(|s| &s.lags))
        .collect();
    if let Some(all) = schedules
        && let Some(first) = all.first()
        && all.iter().all(|l| l == first)
        && !first.is_empty()
    {
        let mut lags: Vec<f64> = first.iter().copied().filter(|l| *l > 0.0).collect();
        lags.sort_by(f64::total_cmp);
        lags.dedup_by(|a, b| (*a - *b).abs() <= rel_tol.max(1e-12) * b.abs());
        return Ok(Some(lags));
    }
    let lags = select(trajs, None, rel_tol)?;
    // The shortest lag is realised once per origin and replica, and only then.
    let every = lags.first().map(|l| l.pairs.len()).unwrap_or(0);
    Ok(Some(
        lags.iter()
            .filter(|l| l.pairs.len() >= every)
            .map(|l| l.t)
            .collect(),
    ))
}

/// A time asked for in units of a measured time (`multiple` x tau_alpha), and the
/// recorded lag that answers it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InUnits {
    /// The request, in units of the measured time (8.5 for "8.5 tau_alpha").
    pub multiple: f64,
    /// The request as a time: multiple x unit.
    pub requested: f64,
    /// The recorded lag used: the nearest in ln t.
    pub lag: f64,
    /// How far it is from the request: lag / requested - 1.
    pub rel_diff: f64,
}

/// The recorded lag nearest (in ln t) to each `multiple x unit`. A request past the
/// last recorded lag or before the first (beyond `rel_tol`) is refused, never
/// extrapolated: the error names the request, the measured time and the range.
pub fn in_units(
    lags: &[f64],
    unit: f64,
    unit_name: &str,
    multiples: &[f64],
    rel_tol: f64,
) -> Result<Vec<InUnits>> {
    if !(unit.is_finite() && unit > 0.0) {
        bail!("{unit_name} = {unit} is not a positive time: cannot express lags in its units");
    }
    let (Some(&first), Some(&last)) = (lags.first(), lags.last()) else {
        bail!("no recorded lag to answer a time in units of {unit_name}");
    };
    let mut out = Vec::with_capacity(multiples.len());
    for &m in multiples {
        if !(m.is_finite() && m > 0.0) {
            bail!("`at` must hold multiples > 0 of {unit_name}, got {m}");
        }
        let t = m * unit;
        if t > last * (1.0 + rel_tol) || t < first * (1.0 - rel_tol) {
            bail!(
                "{m} {unit_name} = {t:.6} lies outside the recorded lags [{first:.6}, {last:.6}] \
                 ({unit_name} = {unit:.6}); refusing to extrapolate: record longer (or shorter) lags"
            );
        }
        let lag = lags
            .iter()
            .copied()
            .min_by(|a, b| (a / t).ln().abs().total_cmp(&(b / t).ln().abs()))
            .expect("lags not empty");
        out.push(InUnits {
            multiple: m,
            requested: t,
            lag,
            rel_diff: lag / t - 1.0,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::random_walk;
    use crate::analysis::test_support::{err_text, schedule_times};
    use crate::traj::Schedule;

    /// Origins 0.5 apart (from t = 3) fall two to a bin of length 1, per replica;
    /// a length that is not positive keeps one block per origin.
    #[test]
    fn origin_bins_group_close_origins_of_each_replica() {
        let times = Schedule {
            start: 3.0,
            origins: 5,
            origin_spacing: 0.5,
            lags: vec![0.1],
        }
        .times();
        let (a, b) = (
            random_walk(4, [5.0, 5.0], &times, 0.1, 1),
            random_walk(4, [5.0, 5.0], &times, 0.1, 2),
        );
        let bin = origin_bins(&[&a, &b], 1.0);
        // Frames: 3.0, 3.1, 3.5, 3.6, 4.0, 4.1, 4.5, 4.6, 5.0, 5.1; origins at even indices.
        let bins: Vec<(usize, usize)> = [0, 2, 4, 6, 8].iter().map(|&i| bin(&(1, i))).collect();
        assert_eq!(bins, vec![(1, 0), (1, 0), (1, 1), (1, 1), (1, 2)]);
        assert_eq!(origin_bins(&[&a, &b], 0.0)(&(0, 6)), (0, 6));
        assert_eq!(origin_bins(&[&a, &b], f64::NAN)(&(1, 4)), (1, 4));
    }

    #[test]
    fn every_origin_lags_keep_only_lags_each_origin_realises() {
        let times = schedule_times(4, 40.0, 0.1, 30.0);
        let traj = random_walk(50, [30.0, 30.0], &times, 0.05, 3);
        let lags = every_origin(&[&traj], None, 1e-6).unwrap().unwrap();
        let all = select(&[&traj], None, 1e-6).unwrap();
        assert!(!lags.is_empty() && lags.len() < all.len());
        // Kept: lags with at least one pair per origin; dropped: the rest.
        for l in &all {
            let kept = lags.contains(&l.t);
            assert_eq!(
                l.pairs.len() >= 4,
                kept,
                "lag {} with {} pairs",
                l.t,
                l.pairs.len()
            );
        }
        // A request is kept as given.
        assert_eq!(
            every_origin(&[&traj], Some(vec![1.0]), 1e-6).unwrap(),
            Some(vec![1.0])
        );
    }

    #[test]
    fn times_in_units_of_tau_alpha_pick_the_nearest_lag_and_never_extrapolate() {
        let lags = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0];
        let tau = 1.1;
        let r = in_units(&lags, tau, "tau_alpha", &[1.0, 0.1, 8.5], 1e-6).unwrap();
        assert_eq!(r[0].lag, 1.0);
        assert!((r[0].rel_diff - (1.0 / 1.1 - 1.0)).abs() < 1e-12);
        assert_eq!(r[1].lag, 0.1);
        assert!((r[1].requested - 0.11).abs() < 1e-12);
        // 8.5 x 1.1 = 9.35: nearest in ln t is 10.
        assert_eq!(r[2].lag, 10.0);
        // 10 tau_alpha = 11 > 10: refused, with the numbers.
        let e = err_text(in_units(&lags, tau, "tau_alpha", &[10.0], 1e-6));
        assert!(
            e.contains("10 tau_alpha") && e.contains("extrapolate"),
            "{e}"
        );
        let e = err_text(in_units(&lags, tau, "tau_alpha", &[0.05], 1e-6));
        assert!(e.contains("outside the recorded lags"), "{e}");
        let e = err_text(in_units(&lags, f64::NAN, "tau_alpha", &[1.0], 1e-6));
        assert!(e.contains("not a positive time"), "{e}");
    }
}
