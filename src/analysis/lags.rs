//! Which lags to analyse and which frame pairs (time origins) serve each lag.

use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch, UInt32Array};

use crate::table::columns::is_count;
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
/// two recorded lags around it that answer it by interpolation in ln t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InUnits {
    /// The request, in units of the measured time (8.5 for "8.5 tau_alpha").
    pub multiple: f64,
    /// The request as a time: multiple x unit.
    pub requested: f64,
    /// The recorded lags at or below and at or above the request (equal when it
    /// falls on a lag or at an end of the recorded range).
    pub below: f64,
    pub above: f64,
    /// Weight of `above`: ln(requested / below) / ln(above / below), in [0, 1].
    pub weight: f64,
}

/// How an observable is read at a time between recorded lags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtLag {
    /// A curve of t (Q, chi4, S4, the MSD, van Hove, and the cluster size
    /// distribution P(Nc) on bins its lags share): interpolated in ln t between
    /// the two recorded lags around the request.
    Interpolate,
    /// A configuration of a frame pair (clusters, a mobility snapshot): it
    /// exists at recorded lags only, so the nearest in ln t is taken.
    Nearest,
}

impl InUnits {
    /// The request answered by the recorded lag nearest in ln t alone.
    pub fn nearest(self) -> InUnits {
        let lag = if self.weight > 0.5 {
            self.above
        } else {
            self.below
        };
        InUnits {
            below: lag,
            above: lag,
            weight: 0.0,
            ..self
        }
    }
}

/// The recorded lags around each `multiple x unit`, for a value read off the
/// sampled curve by linear interpolation in ln t (the nearest lag alone would
/// put a step of up to half the lag spacing into it). A request past the last
/// recorded lag or before the first (beyond `rel_tol`) is refused, never
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
        // The first lag at or above t (the last one past the end, within rel_tol).
        let k = lags.partition_point(|&l| l < t).min(lags.len() - 1);
        // On a lag, or before the first / past the last within rel_tol: that lag.
        let (below, above) = if k == 0 || lags[k] <= t {
            (lags[k], lags[k])
        } else {
            (lags[k - 1], lags[k])
        };
        let weight = if above > below {
            (t / below).ln() / (above / below).ln()
        } else {
            0.0
        };
        out.push(InUnits {
            multiple: m,
            requested: t,
            below,
            above,
            weight,
        });
    }
    Ok(out)
}

/// Every lag the requests read, sorted, once each.
pub fn bracketing_lags(requests: &[InUnits]) -> Vec<f64> {
    let mut lags: Vec<f64> = requests.iter().flat_map(|r| [r.below, r.above]).collect();
    lags.sort_by(f64::total_cmp);
    lags.dedup();
    lags
}

/// The rows of a table computed at [`bracketing_lags`] (float column `t` the
/// lag) turned into one block of rows per request at its requested time (at
/// the lag itself when the request is answered by one lag): the
/// rows at `below` and at `above` are paired in order (the same keys, e.g. the
/// same q, must follow in the same order) and every float column is
/// interpolated with the request's weight (a column equal in both rows, a key,
/// is kept bit for bit), but an error `X_err` is the larger of the two, and a
/// count and the largest of what it counts come from the nearer lag, like
/// every column that is not a float. A table
/// without a float column `t` is returned as it is.
pub fn at_requests(b: &RecordBatch, requests: &[InUnits]) -> Result<RecordBatch> {
    let Some(t) = b
        .column_by_name("t")
        .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
    else {
        return Ok(b.clone());
    };
    let rows_at = |lag: f64| -> Vec<u32> {
        (0..t.len())
            .filter(|&i| t.value(i).to_bits() == lag.to_bits())
            .map(|i| i as u32)
            .collect()
    };
    let mut lo_rows = Vec::new();
    let mut hi_rows = Vec::new();
    let mut weights = Vec::new();
    let mut times = Vec::new();
    for r in requests {
        let (lo, hi) = (rows_at(r.below), rows_at(r.above));
        if lo.len() != hi.len() || lo.is_empty() {
            bail!(
                "{} x the measured time: the table has {} row(s) at lag {} and {} at lag {}; \
                 cannot interpolate between them",
                r.multiple,
                lo.len(),
                r.below,
                hi.len(),
                r.above
            );
        }
        let time = if r.below == r.above {
            r.below
        } else {
            r.requested
        };
        weights.extend(std::iter::repeat_n(r.weight, lo.len()));
        times.extend(std::iter::repeat_n(time, lo.len()));
        lo_rows.extend(lo);
        hi_rows.extend(hi);
    }
    let nearer: Vec<u32> = lo_rows
        .iter()
        .zip(&hi_rows)
        .zip(&weights)
        .map(|((&l, &h), &w)| if w > 0.5 { h } else { l })
        .collect();
    let take = |c: &ArrayRef, idx: &[u32]| -> Result<ArrayRef> {
        Ok(arrow_select::take::take(
            c.as_ref(),
            &UInt32Array::from(idx.to_vec()),
            None,
        )?)
    };
    let mut cols: Vec<(String, ArrayRef)> = Vec::new();
    for (f, c) in b.schema().fields().iter().zip(b.columns()) {
        let name = f.name();
        let float = c.as_any().downcast_ref::<Float64Array>();
        let col: ArrayRef = match float {
            _ if name == "t" => Arc::new(Float64Array::from(times.clone())),
            // An error: the larger of the two lags' (their estimates share most
            // of their data, so interpolation cannot shrink it; an empty bin's
            // zero error at one lag must not make the point exact).
            Some(x) if name.ends_with("_err") => {
                Arc::new(Float64Array::from_iter(lo_rows.iter().zip(&hi_rows).map(
                    |(&l, &h)| Some(x.value(l as usize).max(x.value(h as usize))),
                )))
            }
            Some(x) if !of_nearer_lag(name) => Arc::new(Float64Array::from_iter(
                lo_rows
                    .iter()
                    .zip(&hi_rows)
                    .zip(&weights)
                    .map(|((&l, &h), &w)| {
                        let (a, z) = (x.value(l as usize), x.value(h as usize));
                        Some(if a.to_bits() == z.to_bits() {
                            a
                        } else {
                            a + w * (z - a)
                        })
                    }),
            )),
            _ => take(c, &nearer)?,
        };
        cols.push((f.name().clone(), col));
    }
    Ok(RecordBatch::try_from_iter(cols)?)
}

/// Whether column `name` comes from the nearer lag in [`at_requests`]: a count,
/// and the largest of the objects counted (`largest_spanning`), which must
/// describe the same clusters as their count (interpolated, it gave a spanning
/// cluster's size beside a count of none).
fn of_nearer_lag(name: &str) -> bool {
    is_count(name) || name.starts_with("largest_")
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
    fn times_in_units_of_tau_alpha_interpolate_between_lags_and_never_extrapolate() {
        let lags = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0];
        let tau = 1.1;
        let r = in_units(&lags, tau, "tau_alpha", &[1.0, 0.1, 8.5, 1.0 / 1.1], 1e-6).unwrap();
        // 1.1 lies between 1 and 2, a fraction ln 1.1 / ln 2 of the way in ln t.
        assert_eq!((r[0].below, r[0].above), (1.0, 2.0));
        assert!((r[0].weight - 1.1f64.ln() / 2f64.ln()).abs() < 1e-12);
        assert_eq!((r[1].below, r[1].above), (0.1, 0.2));
        assert!((r[1].requested - 0.11).abs() < 1e-12);
        assert_eq!((r[2].below, r[2].above), (5.0, 10.0));
        // A request on a lag reads that lag alone.
        assert_eq!((r[3].below, r[3].above, r[3].weight), (1.0, 1.0, 0.0));
        assert_eq!(bracketing_lags(&r), [0.1, 0.2, 1.0, 2.0, 5.0, 10.0]);
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

    /// A curve linear in ln t is read exactly between its lags; keys (q) are
    /// kept bit for bit, errors are the larger of the two, counts and the
    /// largest of what they count come from the nearer lag, and a table whose
    /// lags hold different rows is refused.
    #[test]
    fn rows_at_a_request_interpolate_in_ln_t() {
        use arrow_array::UInt64Array;
        let t = [1.0, 1.0, 2.0, 2.0];
        let q = [0.3, 0.7, 0.3, 0.7];
        let s4: Vec<f64> = t
            .iter()
            .zip(&q)
            .map(|(t, q)| q + 3.0 * f64::ln(*t))
            .collect();
        let b = RecordBatch::try_from_iter([
            ("t", Arc::new(Float64Array::from(t.to_vec())) as ArrayRef),
            ("q", Arc::new(Float64Array::from(q.to_vec())) as ArrayRef),
            ("s4", Arc::new(Float64Array::from(s4)) as ArrayRef),
            (
                "n",
                Arc::new(UInt64Array::from(vec![10u64, 10, 20, 20])) as ArrayRef,
            ),
            (
                "n_spanning",
                Arc::new(Float64Array::from(vec![0.0, 0.0, 1.0, 1.0])) as ArrayRef,
            ),
            (
                "largest_spanning",
                Arc::new(Float64Array::from(vec![0.0, 0.0, 700.0, 700.0])) as ArrayRef,
            ),
        ])
        .unwrap();
        let r = in_units(&[1.0, 2.0], 1.3, "tau_alpha", &[1.0], 1e-6).unwrap();
        let out = at_requests(&b, &r).unwrap();
        let col = |name: &str| {
            out.column_by_name(name)
                .unwrap()
                .as_any()
                .downcast_ref::<Float64Array>()
                .unwrap()
                .values()
                .to_vec()
        };
        assert_eq!(col("t"), [1.3, 1.3]);
        assert_eq!(col("q"), [0.3, 0.7]);
        for (v, q) in col("s4").iter().zip([0.3, 0.7]) {
            assert!((v - (q + 3.0 * 1.3f64.ln())).abs() < 1e-12);
        }
        let n = out
            .column_by_name("n")
            .unwrap()
            .as_any()
            .downcast_ref::<UInt64Array>()
            .unwrap();
        // 1.3 is nearer 1 than 2 in ln t (weight 0.38).
        assert_eq!(n.values().to_vec(), [10, 10]);
        // The largest spanning cluster belongs with the count of them: none
        // at the nearer lag, so no size either.
        assert_eq!(col("n_spanning"), [0.0, 0.0]);
        assert_eq!(col("largest_spanning"), [0.0, 0.0]);
        let ragged = b.slice(0, 3);
        assert!(err_text(at_requests(&ragged, &r)).contains("cannot interpolate"));
    }
}
