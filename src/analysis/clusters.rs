//! Clusters of slow (|dr| < a) and fast (|dr| > 3a) particles over a lag t (paper H,
//! Sec. 3.3): two such particles are linked if closer than r_ab^min, the first
//! minimum of g_ab(r). Union-find over a cell list; each node keeps its offset to its
//! parent, so clusters that wrap the periodic box are unwrapped for Rg (Eq. 10) and
//! clusters that span the box (a loop of bonds winding around it) are flagged.

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::{check_trajectory, default_a, default_rel_tol, ensure_positive, gr, lags, neighbours};
use crate::table::f64_batch;
use crate::traj::Trajectory;

fn default_fast_factor() -> f64 {
    3.0
}

/// Parameters of the cluster analysis.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Slow: |dr| < a (units r1).
    #[serde(default = "default_a")]
    pub a: f64,
    /// Fast: |dr| > fast_factor * a.
    #[serde(default = "default_fast_factor")]
    pub fast_factor: f64,
    /// Lags t (e.g. [tau_alpha]); required, here or by the analysis stage's
    /// `at:` (the parse checks it).
    #[serde(default)]
    pub lags: Vec<f64>,
    /// Neighbour cut-offs r_ab (species x species); first minima of g_ab(r) if absent.
    #[serde(default)]
    pub cutoffs: Option<Vec<Vec<f64>>>,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
    /// Bins per decade of Nc for the size distribution P(Nc).
    #[serde(default = "default_per_decade")]
    pub per_decade: usize,
}

fn default_per_decade() -> usize {
    5
}

/// One cluster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// Number of particles Nc.
    pub size: usize,
    /// Radius of gyration of the unwrapped cluster.
    pub rg: f64,
    /// The cluster is connected to its own periodic image (spans the box).
    pub spans: bool,
}

/// Union-find with offsets: `off[i]` = unwrapped r_i - unwrapped r_parent(i).
struct Forest {
    parent: Vec<usize>,
    size: Vec<usize>,
    off: Vec<[f64; 2]>,
    spans: Vec<bool>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
            size: vec![1; n],
            off: vec![[0.0; 2]; n],
            spans: vec![false; n],
        }
    }

    /// Root of i and the offset r_i - r_root, compressing the path.
    fn find(&mut self, i: usize) -> (usize, [f64; 2]) {
        let mut path = Vec::new();
        let mut r = i;
        while self.parent[r] != r {
            path.push(r);
            r = self.parent[r];
        }
        // Walk back from the node nearest the root, accumulating offsets.
        let mut acc = [0.0; 2];
        for &k in path.iter().rev() {
            acc = [acc[0] + self.off[k][0], acc[1] + self.off[k][1]];
            self.off[k] = acc;
            self.parent[k] = r;
        }
        (
            r,
            if path.is_empty() {
                [0.0; 2]
            } else {
                self.off[i]
            },
        )
    }

    /// Link i and j with bond d = r_j - r_i (minimum image). A bond closing a loop
    /// with a mismatch of order the box side means the cluster wraps onto itself.
    fn union(&mut self, i: usize, j: usize, d: [f64; 2], half_box: f64) {
        let (ri, oi) = self.find(i);
        let (rj, oj) = self.find(j);
        // r_rj - r_ri implied by this bond.
        let rel = [oi[0] + d[0] - oj[0], oi[1] + d[1] - oj[1]];
        if ri == rj {
            if rel[0].abs().max(rel[1].abs()) > half_box {
                self.spans[ri] = true;
            }
            return;
        }
        let (big, small, off) = if self.size[ri] >= self.size[rj] {
            (ri, rj, rel)
        } else {
            (rj, ri, [-rel[0], -rel[1]])
        };
        self.parent[small] = big;
        self.off[small] = off;
        self.size[big] += self.size[small];
        self.spans[big] |= self.spans[small];
    }
}

/// Clusters among the particles with `member[i]`, linked when closer than
/// `cutoff[s_i][s_j]`, positions (x, y) unwrapped or folded.
pub fn find_clusters(
    traj: &Trajectory,
    x: &[f64],
    y: &[f64],
    member: &[bool],
    cutoff: &[Vec<f64>],
) -> Result<Vec<Cluster>> {
    let idx: Vec<usize> = (0..x.len()).filter(|&i| member[i]).collect();
    let xs: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
    let ys: Vec<f64> = idx.iter().map(|&i| y[i]).collect();
    let rmax = cutoff.iter().flatten().copied().fold(0.0, f64::max);
    let mut forest = Forest::new(idx.len());
    let half_box = 0.5 * traj.box_size[0].min(traj.box_size[1]);
    neighbours::for_each_pair(
        &xs,
        &ys,
        traj.box_size,
        traj.periodic,
        rmax,
        |a, b, dx, dy| {
            let (si, sj) = (traj.species[idx[a]] as usize, traj.species[idx[b]] as usize);
            let rc = cutoff[si][sj];
            if dx * dx + dy * dy < rc * rc {
                forest.union(a, b, [dx, dy], half_box);
            }
        },
    )?;
    // Per root: count, sum of offsets, sum of squared offsets (relative to the root).
    let n = idx.len();
    let mut acc = vec![[0.0f64; 3]; n];
    for k in 0..n {
        let (r, o) = forest.find(k);
        acc[r][0] += o[0];
        acc[r][1] += o[1];
        acc[r][2] += o[0] * o[0] + o[1] * o[1];
    }
    Ok((0..n)
        .filter(|&k| forest.parent[k] == k)
        .map(|r| {
            let c = forest.size[r] as f64;
            let (mx, my) = (acc[r][0] / c, acc[r][1] / c);
            Cluster {
                size: forest.size[r],
                rg: (acc[r][2] / c - mx * mx - my * my).max(0.0).sqrt(),
                spans: forest.spans[r],
            }
        })
        .collect())
}

fn validate_cutoffs(traj: &Trajectory, c: &[Vec<f64>]) -> Result<()> {
    let ns = traj.species.iter().copied().max().unwrap_or(0) as usize + 1;
    if c.len() < ns || c.iter().any(|row| row.len() < ns) {
        bail!("parameter `cutoffs` must be a {ns} x {ns} matrix (one row per species)");
    }
    for (a, row) in c.iter().enumerate() {
        for (b, &v) in row.iter().enumerate() {
            ensure_positive(&format!("cutoffs[{a}][{b}]"), v)?;
            if (v - c[b][a]).abs() > 1e-12 * v {
                bail!(
                    "parameter `cutoffs` must be symmetric: [{a}][{b}] = {v} but [{b}][{a}] = {}",
                    c[b][a]
                );
            }
        }
    }
    Ok(())
}

/// Table `t, t0, kind, Nc, Rg, spans`: one row per cluster; kind 0 = slow, 1 = fast;
/// positions at the end of each interval (Eq. 10: r_i(tau_alpha)); spans = 1 for a
/// cluster connected to its own periodic image (its Rg is not meaningful).
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    ensure_positive("a", p.a)?;
    if !(p.fast_factor.is_finite() && p.fast_factor >= 1.0) {
        bail!(
            "parameter `fast_factor` must be >= 1, got {}",
            p.fast_factor
        );
    }
    if p.lags.is_empty() {
        bail!("parameter `lags` is empty: give at least one lag (e.g. tau_alpha)");
    }
    let cut = match &p.cutoffs {
        Some(c) => c.clone(),
        None => gr::cutoffs(traj, &gr::Params::default())?,
    };
    validate_cutoffs(traj, &cut)?;
    let (slow2, fast2) = (p.a * p.a, (p.fast_factor * p.a).powi(2));
    let mut cols: [Vec<f64>; 6] = Default::default();
    let start = traj.frames[0].time;
    for lag in lags::select(&[traj], Some(&p.lags), p.rel_tol)? {
        for &(_, i, j) in &lag.pairs {
            let (f0, f1) = (&traj.frames[i], &traj.frames[j]);
            let d2 = super::squared_displacements(f0, f1);
            for (kind, member) in [
                d2.iter().map(|&d| d < slow2).collect::<Vec<_>>(),
                d2.iter().map(|&d| d > fast2).collect(),
            ]
            .into_iter()
            .enumerate()
            {
                for c in find_clusters(traj, &f1.x, &f1.y, &member, &cut)? {
                    cols[0].push(lag.t);
                    cols[1].push(f0.time - start);
                    cols[2].push(kind as f64);
                    cols[3].push(c.size as f64);
                    cols[4].push(c.rg);
                    cols[5].push(if c.spans { 1.0 } else { 0.0 });
                }
            }
        }
    }
    let [t, t0, k, nc, rg, sp] = cols;
    f64_batch(&[
        ("t", t),
        ("t0", t0),
        ("kind", k),
        ("Nc", nc),
        ("Rg", rg),
        ("spans", sp),
    ])
}

/// Table `t, t0, x, y, radius, class`: one frame's disks (positions at the end of
/// the first interval of the first lag, folded into the box) with their mobility
/// class over that interval: 0 slow (|dr| < a), 1 fast (|dr| > fast_factor a),
/// 2 neither (paper H, Fig. 10).
pub fn compute_snapshot(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    ensure_positive("a", p.a)?;
    let Some(&lag) = p.lags.first() else {
        bail!("parameter `lags` is empty: give the lag of the snapshot (e.g. tau_alpha)");
    };
    let selected = lags::select(&[traj], Some(&[lag]), p.rel_tol)?;
    let Some(&(_, i, j)) = selected.first().and_then(|l| l.pairs.first()) else {
        bail!(
            "no pair of frames is {lag} apart (within rel_tol = {})",
            p.rel_tol
        );
    };
    let (f0, f1) = (&traj.frames[i], &traj.frames[j]);
    let (slow2, fast2) = (p.a * p.a, (p.fast_factor * p.a).powi(2));
    let d2 = super::squared_displacements(f0, f1);
    let fold = |v: f64, l: f64| v.rem_euclid(l);
    let n = d2.len();
    f64_batch(&[
        ("t", vec![selected[0].t; n]),
        ("t0", vec![f0.time - traj.frames[0].time; n]),
        (
            "x",
            f1.x.iter().map(|&v| fold(v, traj.box_size[0])).collect(),
        ),
        (
            "y",
            f1.y.iter().map(|&v| fold(v, traj.box_size[1])).collect(),
        ),
        (
            "radius",
            traj.species
                .iter()
                .map(|&s| traj.radii[s as usize])
                .collect(),
        ),
        (
            "class",
            d2.iter()
                .map(|&d| {
                    if d < slow2 {
                        0.0
                    } else if d > fast2 {
                        1.0
                    } else {
                        2.0
                    }
                })
                .collect(),
        ),
    ])
}

/// Table `t, kind, Nc, P, P_err, n_clusters, n_spanning, largest_spanning`: the
/// log-binned size distribution of the slow (kind 0) and fast (kind 1) clusters
/// that do not span the box, at each lag, pooled over time origins, with its
/// counting error P / sqrt(clusters in bin); beside it the number of spanning
/// clusters left out and the largest of them (0 if none).
pub fn compute_sizes(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    sizes_table(&compute(traj, p)?, p)
}

/// [`compute_sizes`] from cluster rows of [`compute`] (of one replica, or of several
/// concatenated: the distribution of all their clusters).
pub fn sizes_table(rows: &RecordBatch, p: &Params) -> Result<RecordBatch> {
    sizes_of(rows, p, |_| true)
}

/// [`sizes_table`] of concatenated replicas (`replica` column) again with each
/// replica left out, on the rows of `full` (the table of all of them): the
/// replica jackknife samples of P(Nc), from the cluster rows already found. A
/// bin that the others leave empty at every lag has P = NaN there (a fit
/// refitting the sample then skips it); one they fill at another lag has P = 0
/// where they leave it empty, as in `full`. The lags are those of `full`.
pub fn sizes_left_out(
    rows: &RecordBatch,
    p: &Params,
    full: &RecordBatch,
) -> Result<Vec<RecordBatch>> {
    use arrow_array::Int64Array;
    let replica: Vec<i64> = rows
        .column_by_name("replica")
        .and_then(|c| c.as_any().downcast_ref::<Int64Array>())
        .map(|a| a.values().to_vec())
        .ok_or_else(|| anyhow::anyhow!("cluster rows without a `replica` column"))?;
    let mut distinct = replica.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let key = |b: &RecordBatch| -> Vec<[u64; 3]> {
        let c = |n: &str| float_col(b, n);
        let (t, k, n) = (c("t"), c("kind"), c("Nc"));
        (0..b.num_rows())
            .map(|i| [t[i].to_bits(), k[i].to_bits(), n[i].to_bits()])
            .collect()
    };
    let want = key(full);
    distinct
        .iter()
        .map(|&r| {
            let s = sizes_of(rows, p, |i| replica[i] != r)?;
            let have: std::collections::HashMap<[u64; 3], usize> = key(&s)
                .into_iter()
                .enumerate()
                .map(|(i, k)| (k, i))
                .collect();
            // Per (t, kind): the spanning clusters of the others.
            let span: std::collections::HashMap<[u64; 2], (f64, f64)> = {
                let (t, k) = (float_col(&s, "t"), float_col(&s, "kind"));
                let (n, big) = (
                    float_col(&s, "n_spanning"),
                    float_col(&s, "largest_spanning"),
                );
                (0..s.num_rows())
                    .map(|i| ([t[i].to_bits(), k[i].to_bits()], (n[i], big[i])))
                    .collect()
            };
            // (name, the sample's column, the column on full's rows)
            let mut cols: Vec<(String, Vec<f64>, Vec<f64>)> = full
                .schema()
                .fields()
                .iter()
                .map(|f| {
                    let name = f.name().clone();
                    let own = float_col(&s, &name);
                    (name, own, Vec::with_capacity(full.num_rows()))
                })
                .collect();
            for w in &want {
                let at = have.get(w).copied();
                let spanning = span.get(&[w[0], w[1]]).copied().unwrap_or((0.0, 0.0));
                for (name, own, v) in cols.iter_mut() {
                    v.push(match (name.as_str(), at) {
                        ("t", _) => f64::from_bits(w[0]),
                        ("kind", _) => f64::from_bits(w[1]),
                        ("Nc", _) => f64::from_bits(w[2]),
                        ("n_spanning", _) => spanning.0,
                        ("largest_spanning", _) => spanning.1,
                        ("n_clusters", None) => 0.0,
                        (_, None) => f64::NAN,
                        (_, Some(i)) => own[i],
                    });
                }
            }
            let named: Vec<(&str, Vec<f64>)> = cols
                .iter_mut()
                .map(|(n, _, v)| (n.as_str(), std::mem::take(v)))
                .collect();
            f64_batch(&named)
        })
        .collect()
}

fn float_col(b: &RecordBatch, name: &str) -> Vec<f64> {
    b.column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<arrow_array::Float64Array>())
        .map(|a| a.values().to_vec())
        .expect("column written by compute")
}

/// [`sizes_table`] of the cluster rows `keep` accepts.
fn sizes_of(rows: &RecordBatch, p: &Params, keep: impl Fn(usize) -> bool) -> Result<RecordBatch> {
    let col = |name: &str| float_col(rows, name);
    let (t, kind, nc, spans) = (col("t"), col("kind"), col("Nc"), col("spans"));
    // Per (lag, kind): spanning clusters, the largest of them, and P(Nc).
    let mut per = Vec::new();
    for &lag in &p.lags {
        for k in [0.0, 1.0] {
            let here: Vec<usize> = (0..t.len())
                .filter(|&i| keep(i) && kind[i] == k && (t[i] - lag).abs() <= p.rel_tol * lag)
                .collect();
            // A cluster that wraps around the box has no finite size: the box, not
            // phi, cuts it off. It is left out of P(Nc) and counted beside it.
            let sizes: Vec<usize> = here
                .iter()
                .filter(|&&i| spans[i] == 0.0)
                .map(|&i| nc[i] as usize)
                .collect();
            let spanning = here.iter().filter(|&&i| spans[i] != 0.0).count() as f64;
            let largest = here
                .iter()
                .filter(|&&i| spans[i] != 0.0)
                .map(|&i| nc[i])
                .fold(0.0, f64::max);
            per.push((
                lag,
                k,
                spanning,
                largest,
                size_distribution(&sizes, p.per_decade)?,
            ));
        }
    }
    // Every lag has the bins any lag fills for its kind, P = 0 where it has
    // none: a time between two recorded lags is then read off bin by bin
    // (`lags::at_requests`), the two lags' distributions mixed in ln t.
    let bins = |k: f64| -> Vec<f64> {
        let mut c: Vec<f64> = per
            .iter()
            .filter(|x| x.1 == k)
            .flat_map(|x| x.4.iter().map(|b| b.0))
            .collect();
        c.sort_by(f64::total_cmp);
        c.dedup_by(|a, b| a.to_bits() == b.to_bits());
        c
    };
    let shared = [bins(0.0), bins(1.0)];
    let mut cols: [Vec<f64>; 8] = Default::default();
    for (lag, k, spanning, largest, dist) in &per {
        for &centre in &shared[*k as usize] {
            let (prob, count) = dist
                .iter()
                .find(|b| b.0.to_bits() == centre.to_bits())
                .map_or((0.0, 0), |b| (b.1, b.2));
            cols[0].push(*lag);
            cols[1].push(*k);
            cols[2].push(centre);
            cols[3].push(prob);
            cols[4].push(count as f64);
            cols[5].push(*spanning);
            cols[6].push(*largest);
            cols[7].push(if count > 0 {
                prob / (count as f64).sqrt()
            } else {
                0.0
            });
        }
    }
    let [t, k, n, pr, c, sp, big, pe] = cols;
    f64_batch(&[
        ("t", t),
        ("kind", k),
        ("Nc", n),
        ("P", pr),
        ("P_err", pe),
        ("n_clusters", c),
        ("n_spanning", sp),
        ("largest_spanning", big),
    ])
}

/// P(Nc): the fraction of clusters of size Nc, log-binned with `per_decade` bins per
/// decade: P = (clusters in bin) / (all clusters x integers in bin). Returns
/// (Nc bin centre = geometric mean of its smallest and largest integer, P, clusters in bin).
pub fn size_distribution(sizes: &[usize], per_decade: usize) -> Result<Vec<(f64, f64, usize)>> {
    if per_decade == 0 {
        bail!("parameter `per_decade` must be at least 1");
    }
    let Some(&max) = sizes.iter().max() else {
        return Ok(vec![]);
    };
    let edge = |k: usize| 10f64.powf(k as f64 / per_decade as f64);
    let mut out = Vec::new();
    let mut k = 0;
    while edge(k) <= max as f64 {
        // Integers n with edge(k) <= n < edge(k + 1).
        let lo = edge(k).ceil() as usize;
        let hi = edge(k + 1).ceil() as usize;
        if hi > lo {
            let c = sizes.iter().filter(|&&s| s >= lo && s < hi).count();
            if c > 0 {
                let centre = ((lo * (hi - 1)) as f64).sqrt();
                out.push((
                    centre,
                    c as f64 / (sizes.len() as f64 * (hi - lo) as f64),
                    c,
                ));
            }
        }
        k += 1;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::test_support::col;
    use crate::traj::{Frame, Trajectory};

    /// Mobility classes at a = 0.6 and 3a over the single lag t = 1.
    fn unit_lag_params(per_decade: usize) -> Params {
        Params {
            a: 0.6,
            fast_factor: 3.0,
            lags: vec![1.0],
            cutoffs: None,
            rel_tol: 1e-6,
            per_decade,
        }
    }

    /// Free flight over t = 1: a disk is slow when its speed is below a, fast above
    /// 3a; each carries its species' radius and a position inside the box.
    #[test]
    fn snapshot_classes_follow_the_displacement() {
        let traj = crate::analysis::synthetic::ballistic(400, [20.0, 20.0], &[0.0, 1.0], 3);
        let p = unit_lag_params(5);
        let b = compute_snapshot(&traj, &p).unwrap();
        let col = |n: &str| col(&b, n);
        let (x, y, r, class) = (col("x"), col("y"), col("radius"), col("class"));
        assert_eq!(class.len(), 400);
        let f = &traj.frames[1];
        for i in 0..400 {
            let v = f.vx[i].hypot(f.vy[i]);
            let want = if v < 0.6 {
                0.0
            } else if v > 1.8 {
                1.0
            } else {
                2.0
            };
            assert_eq!(class[i], want, "disk {i}, speed {v}");
            assert_eq!(r[i], traj.radii[traj.species[i] as usize]);
            assert!((0.0..20.0).contains(&x[i]) && (0.0..20.0).contains(&y[i]));
        }
        // All three classes occur for unit-variance velocities.
        for k in [0.0, 1.0, 2.0] {
            assert!(class.contains(&k));
        }
    }

    /// A spanning cluster has no finite size: it is counted beside P(Nc), not in it.
    #[test]
    fn spanning_clusters_are_left_out_of_the_size_distribution() {
        let rows = f64_batch(&[
            ("t", vec![1.0; 5]),
            ("t0", vec![0.0; 5]),
            ("kind", vec![0.0, 0.0, 0.0, 0.0, 1.0]),
            ("Nc", vec![1.0, 1.0, 2.0, 400.0, 3.0]),
            ("Rg", vec![0.0, 0.0, 0.5, 9.0, 0.8]),
            ("spans", vec![0.0, 0.0, 0.0, 1.0, 0.0]),
        ])
        .unwrap();
        let p = unit_lag_params(10);
        let b = sizes_table(&rows, &p).unwrap();
        let col = |n: &str| col(&b, n);
        let (kind, nc, pr, sp, big) = (
            col("kind"),
            col("Nc"),
            col("P"),
            col("n_spanning"),
            col("largest_spanning"),
        );
        let slow: Vec<usize> = (0..kind.len()).filter(|&i| kind[i] == 0.0).collect();
        // Slow: sizes 1, 1, 2 only (the 400 spans); P normalised over those three.
        assert_eq!(
            slow.iter().map(|&i| nc[i]).collect::<Vec<_>>(),
            vec![1.0, 2.0]
        );
        assert!((pr[slow[0]] - 2.0 / 3.0).abs() < 1e-12 && (pr[slow[1]] - 1.0 / 3.0).abs() < 1e-12);
        assert!(slow.iter().all(|&i| sp[i] == 1.0 && big[i] == 400.0));
        // Counting error: two clusters of size 1, one of size 2.
        let pe = col("P_err");
        assert!((pe[slow[0]] - pr[slow[0]] / 2f64.sqrt()).abs() < 1e-12);
        assert!((pe[slow[1]] - pr[slow[1]]).abs() < 1e-12);
        let fast: Vec<usize> = (0..kind.len()).filter(|&i| kind[i] == 1.0).collect();
        assert!(fast.iter().all(|&i| sp[i] == 0.0 && big[i] == 0.0));
    }

    /// Two lags whose clusters fill different bins share their bins (P = 0 where
    /// a lag has none), so a time between them is read off bin by bin: at
    /// weight w on the second lag, P is the mixture (1 - w) P_1 + w P_2 of the
    /// two distributions, and its error the larger of the two.
    #[test]
    fn a_time_between_two_lags_mixes_their_distributions_bin_by_bin() {
        // Lag 1: slow sizes 1, 1, 2. Lag 2: slow sizes 2, 5.
        let rows = f64_batch(&[
            ("t", vec![1.0, 1.0, 1.0, 2.0, 2.0]),
            ("t0", vec![0.0; 5]),
            ("kind", vec![0.0; 5]),
            ("Nc", vec![1.0, 1.0, 2.0, 2.0, 5.0]),
            ("Rg", vec![0.0, 0.0, 0.5, 0.5, 1.0]),
            ("spans", vec![0.0; 5]),
        ])
        .unwrap();
        let mut p = unit_lag_params(10);
        p.lags = vec![1.0, 2.0];
        let b = sizes_table(&rows, &p).unwrap();
        let (t, nc, pr, pe) = (col(&b, "t"), col(&b, "Nc"), col(&b, "P"), col(&b, "P_err"));
        let at = |lag: f64| -> Vec<(f64, f64, f64)> {
            (0..t.len())
                .filter(|&i| t[i] == lag && col(&b, "kind")[i] == 0.0)
                .map(|i| (nc[i], pr[i], pe[i]))
                .collect()
        };
        let (one, two) = (at(1.0), at(2.0));
        // Bins {1}, {2} and {4, 5} (centre sqrt(20), two integers wide).
        let centres = [1.0, 2.0, 20f64.sqrt()];
        assert_eq!(one.iter().map(|r| r.0).collect::<Vec<_>>(), centres);
        assert_eq!(two.iter().map(|r| r.0).collect::<Vec<_>>(), centres);
        assert_eq!((one[2].1, one[2].2), (0.0, 0.0), "sizes 4-5 at lag 1");
        assert_eq!((two[0].1, two[0].2), (0.0, 0.0), "size 1 at lag 2");
        // Read at t = 2^0.25 (weight 0.25 on lag 2), as `at` does.
        let request =
            crate::analysis::lags::in_units(&[1.0, 2.0], 2f64.powf(0.25), "u", &[1.0], 0.0)
                .unwrap();
        assert!((request[0].weight - 0.25).abs() < 1e-12);
        let r = crate::analysis::lags::at_requests(&b, &request).unwrap();
        let (rk, rn, rp, re) = (
            col(&r, "kind"),
            col(&r, "Nc"),
            col(&r, "P"),
            col(&r, "P_err"),
        );
        let slow: Vec<usize> = (0..rk.len()).filter(|&i| rk[i] == 0.0).collect();
        assert_eq!(slow.len(), 3);
        for (j, &i) in slow.iter().enumerate() {
            assert_eq!(rn[i], one[j].0);
            let want = 0.75 * one[j].1 + 0.25 * two[j].1;
            assert!(
                (rp[i] - want).abs() < 1e-12,
                "Nc {}: {} against {want}",
                rn[i],
                rp[i]
            );
            assert_eq!(re[i], one[j].2.max(two[j].2));
            assert!(rp[i] > 0.0);
        }
        // Normalised: the sum of P x integers per bin is 1 at each lag, and so mixed.
        let norm: f64 = slow
            .iter()
            .zip([1.0, 1.0, 2.0])
            .map(|(&i, w)| rp[i] * w)
            .sum();
        assert!((norm - 1.0).abs() < 1e-12, "{norm}");
    }

    /// The leave-one-out tables of P(Nc) are those of the other replicas' clusters
    /// on the full table's bins, NaN where the others have none.
    #[test]
    fn leaving_a_replica_out_recounts_the_others_clusters_on_the_same_bins() {
        use arrow_array::{ArrayRef, Int64Array};
        let floats = f64_batch(&[
            ("t", vec![1.0; 5]),
            ("t0", vec![0.0; 5]),
            ("kind", vec![0.0; 5]),
            ("Nc", vec![1.0, 1.0, 2.0, 1.0, 5.0]),
            ("Rg", vec![0.0; 5]),
            ("spans", vec![0.0; 5]),
        ])
        .unwrap();
        let mut cols: Vec<(String, ArrayRef)> = vec![(
            "replica".into(),
            std::sync::Arc::new(Int64Array::from(vec![0, 0, 0, 1, 1])) as ArrayRef,
        )];
        for (f, c) in floats.schema().fields().iter().zip(floats.columns()) {
            cols.push((f.name().clone(), c.clone()));
        }
        let rows = RecordBatch::try_from_iter(cols).unwrap();
        let p = unit_lag_params(10);
        let full = sizes_table(&rows, &p).unwrap();
        let out = sizes_left_out(&rows, &p, &full).unwrap();
        assert_eq!(out.len(), 2);
        let col = |b: &RecordBatch, n: &str| col(b, n);
        // Bins of sizes 1, 2 and 5.
        assert_eq!(col(&full, "Nc").len(), 3);
        // Without replica 0: sizes 1 and 5, half each; no cluster of size 2.
        let (nc, pr) = (col(&out[0], "Nc"), col(&out[0], "P"));
        assert_eq!(nc, col(&full, "Nc"));
        // (The bin of 5 holds several integers: P is per integer, so its ratio to
        // the full table's P is that of the fractions, 1/2 against 1/5.)
        let full_p = col(&full, "P");
        assert!((pr[0] - 0.5).abs() < 1e-12 && pr[1].is_nan());
        assert!((pr[2] - 2.5 * full_p[2]).abs() < 1e-12);
        assert_eq!(col(&out[0], "n_clusters"), vec![1.0, 0.0, 1.0]);
        // Without replica 1: sizes 1, 1, 2; none of size 5.
        let pr = col(&out[1], "P");
        assert!((pr[0] - 2.0 / 3.0).abs() < 1e-12 && (pr[1] - 1.0 / 3.0).abs() < 1e-12);
        assert!(pr[2].is_nan());
    }

    fn one_frame(x: Vec<f64>, y: Vec<f64>, species: Vec<u8>, l: f64) -> Trajectory {
        Trajectory {
            box_size: [l, l],
            periodic: [true, true],
            species,
            radii: vec![0.5, 0.7],
            masses: vec![1.0, 2.0],
            frames: vec![Frame {
                time: 0.0,
                x,
                y,
                vx: vec![],
                vy: vec![],
            }],
            schedule: None,
        }
    }

    #[test]
    fn hand_built_clusters_have_exact_sizes_and_rg() {
        // A chain across the boundary (x = 19, 20 = 0, 21 = 1), two touching disks, an
        // isolated disk, and a ring of 20 disks around the box (spans it).
        let mut x = vec![19.0, 20.0, 21.0, 10.0, 11.0, 5.0];
        let mut y = vec![5.0, 5.0, 5.0, 10.0, 10.0, 15.0];
        for k in 0..20 {
            x.push(k as f64);
            y.push(18.0);
        }
        let n = x.len();
        let traj = one_frame(x.clone(), y.clone(), vec![0; n], 20.0);
        let cut = vec![vec![1.5, 1.5], vec![1.5, 1.5]];
        let mut c = find_clusters(&traj, &x, &y, &vec![true; n], &cut).unwrap();
        c.sort_by_key(|k| k.size);
        assert_eq!(
            c.iter().map(|k| k.size).collect::<Vec<_>>(),
            vec![1, 2, 3, 20]
        );
        assert_eq!(c[0].rg, 0.0);
        assert!((c[1].rg - 0.5).abs() < 1e-12);
        assert!(
            (c[2].rg - (2.0f64 / 3.0).sqrt()).abs() < 1e-12,
            "{}",
            c[2].rg
        );
        assert_eq!(
            c.iter().map(|k| k.spans).collect::<Vec<_>>(),
            vec![false, false, false, true]
        );
    }

    /// O(N^2) reference: depth-first search with minimum-image bonds, unwrapping as it goes.
    fn brute_clusters(traj: &Trajectory, cut: &[Vec<f64>]) -> Vec<(usize, f64)> {
        let f = &traj.frames[0];
        let l = traj.box_size[0];
        let n = traj.n();
        let img = |v: f64| v - l * (v / l).round();
        let mut seen = vec![false; n];
        let mut out = Vec::new();
        for s in 0..n {
            if seen[s] {
                continue;
            }
            seen[s] = true;
            let mut stack = vec![(s, [0.0, 0.0])];
            let mut pos = Vec::new();
            while let Some((i, p)) = stack.pop() {
                pos.push(p);
                for j in 0..n {
                    let (dx, dy) = (img(f.x[j] - f.x[i]), img(f.y[j] - f.y[i]));
                    let rc = cut[traj.species[i] as usize][traj.species[j] as usize];
                    if !seen[j] && dx * dx + dy * dy < rc * rc {
                        seen[j] = true;
                        stack.push((j, [p[0] + dx, p[1] + dy]));
                    }
                }
            }
            let c = pos.len() as f64;
            let mx = pos.iter().map(|p| p[0]).sum::<f64>() / c;
            let my = pos.iter().map(|p| p[1]).sum::<f64>() / c;
            let rg2 = pos
                .iter()
                .map(|p| (p[0] - mx).powi(2) + (p[1] - my).powi(2))
                .sum::<f64>()
                / c;
            out.push((pos.len(), rg2.sqrt()));
        }
        out.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        out
    }

    #[test]
    fn union_find_equals_brute_force_on_random_configurations() {
        use rand::{RngExt, SeedableRng};
        for seed in 0..4u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let (n, l) = (600, 30.0);
            let x: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * l).collect();
            let y: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * l).collect();
            let sp: Vec<u8> = (0..n).map(|_| rng.random_range(0..2u8)).collect();
            let traj = one_frame(x.clone(), y.clone(), sp, l);
            let cut = vec![vec![1.1, 1.3], vec![1.3, 1.5]];
            let mut fast: Vec<(usize, f64)> = find_clusters(&traj, &x, &y, &vec![true; n], &cut)
                .unwrap()
                .iter()
                .map(|c| {
                    assert!(!c.spans);
                    (c.size, c.rg)
                })
                .collect();
            fast.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            let slow = brute_clusters(&traj, &cut);
            assert_eq!(fast.len(), slow.len(), "seed {seed}");
            assert!(
                fast.iter().any(|c| c.0 >= 5),
                "seed {seed}: no sizeable cluster"
            );
            for (a, b) in fast.iter().zip(&slow) {
                assert_eq!(a.0, b.0, "seed {seed}");
                assert!(
                    (a.1 - b.1).abs() < 1e-9,
                    "seed {seed}: Rg {} vs {}",
                    a.1,
                    b.1
                );
            }
        }
    }

    #[test]
    fn size_distribution_counts_integers_per_log_bin() {
        let d = size_distribution(&[1, 1, 1, 2, 3, 10], 1).unwrap();
        assert_eq!(d.len(), 2);
        assert!((d[0].1 - 5.0 / (6.0 * 9.0)).abs() < 1e-15 && d[0].2 == 5);
        assert!((d[1].1 - 1.0 / (6.0 * 90.0)).abs() < 1e-15 && d[1].2 == 1);
        assert!((d[0].0 - 3.0).abs() < 1e-12);
    }
}
