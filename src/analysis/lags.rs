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
    /// Jackknife block of a pair: (replica, origin frame index).
    pub fn block(pair: &(usize, usize, usize)) -> (usize, usize) {
        (pair.0, pair.1)
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
/// the schedule's own lags (the shortest lag sets the count of origins; a lag with
/// fewer pairs comes only from differences between frames of different origins,
/// and mixing those in makes curves jagged).
pub fn every_origin(
    trajs: &[&Trajectory],
    requested: Option<Vec<f64>>,
    rel_tol: f64,
) -> Result<Option<Vec<f64>>> {
    if requested.is_some() {
        return Ok(requested);
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
