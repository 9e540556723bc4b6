//! Structural order of every recorded frame: the bond-orientational order
//! parameter psi6 (local and global) and the local composition of the binary
//! mixture (demixing). Not measured by paper H; asked of its densest phi, where
//! a crystal, a hexatic or demixed domains would grow with time instead of a
//! glass.
//!
//! psi6_j = (1/n_j) sum_k exp(6 i theta_jk) over the n_j neighbours k of disk j
//! (pairs closer than `cutoff` times the sum of their radii; a disk without
//! neighbour has psi6_j = 0); `psi6` is the mean of |psi6_j| over disks (1 in a
//! perfect triangular lattice, 0 in a square one), `psi6_global` is |mean of
//! psi6_j| (1 for one crystal orientation, about 1/sqrt(N) without order).
//!
//! Composition: the box is tiled with the square sub-boxes of chi4 (paper H,
//! Eq. 5) holding `n` disks on average; in each cell with n_c disks the
//! fraction f_c of small disks (species 0) is compared
//! to the global fraction x. `small_fraction_var` is the mean over cells of
//! (f_c - x)^2 / [x (1 - x) / n_c], the variance of the fraction in units of
//! its binomial value: 1 for a random mixture, above 1 when the species demix,
//! below 1 when they alternate.

use anyhow::Result;
use arrow_array::RecordBatch;
use serde::Deserialize;

use super::subbox::SubBoxes;
use super::{check_trajectory, ensure_positive, neighbours};
use crate::table::f64_batch;
use crate::traj::{Frame, Trajectory};

/// Neighbours: closer than 1.4 times the sum of the radii, a first-shell
/// distance between contact (1) and the first minimum of g_ab(r) of the dense
/// mixture (about 1.5 contact distances, paper H, Sec. 3.3).
fn default_cutoff() -> f64 {
    1.4
}

/// Sub-boxes of 16 disks on average: about 10 r1 wide at the dense phi
/// (7 x 7 of them at N = 1000).
fn default_n() -> f64 {
    16.0
}

/// Parameters of the order observable.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Neighbours of psi6: pairs closer than `cutoff` x (R_i + R_j).
    #[serde(default = "default_cutoff")]
    pub cutoff: f64,
    /// Mean number of disks of the square cells of the composition: the
    /// sub-boxes of chi4 (paper H, Eq. 5; `subbox::SubBoxes`).
    #[serde(default = "default_n")]
    pub n: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            cutoff: default_cutoff(),
            n: default_n(),
        }
    }
}

/// psi6 of one frame: (mean of |psi6_j|, |mean of psi6_j|).
pub fn psi6(traj: &Trajectory, f: &Frame, cutoff: f64) -> Result<(f64, f64)> {
    let n = traj.n();
    let mut sum = vec![[0.0f64; 2]; n];
    let mut count = vec![0usize; n];
    neighbours::for_each_neighbour(traj, &f.x, &f.y, cutoff, |i, j, dx, dy| {
        // The bond j -> i is the bond i -> j turned by pi: 6 pi, the same phase.
        let (s, c) = (6.0 * dy.atan2(dx)).sin_cos();
        for k in [i, j] {
            sum[k][0] += c;
            sum[k][1] += s;
            count[k] += 1;
        }
    })?;
    let (mut local, mut global) = (0.0, [0.0f64; 2]);
    for (s, &c) in sum.iter().zip(&count) {
        if c > 0 {
            let p = [s[0] / c as f64, s[1] / c as f64];
            local += p[0].hypot(p[1]);
            global = [global[0] + p[0], global[1] + p[1]];
        }
    }
    let n = n as f64;
    Ok((local / n, global[0].hypot(global[1]) / n))
}

/// Variance of the small-disk fraction over the sub-boxes `cells` in units of
/// its binomial value x(1 - x)/n_c; NaN when the trajectory holds one species
/// only. Disks between sub-boxes are left out, as in chi4 (Eq. 5).
pub fn small_fraction_var(traj: &Trajectory, f: &Frame, cells: &SubBoxes) -> f64 {
    let n = traj.n();
    let x = traj.species.iter().filter(|&&s| s == 0).count() as f64 / n as f64;
    if x <= 0.0 || x >= 1.0 {
        return f64::NAN;
    }
    let mut small = vec![0usize; cells.len()];
    let mut all = vec![0usize; cells.len()];
    for i in 0..n {
        if let Some(k) = cells.locate(f.x[i], f.y[i]) {
            all[k] += 1;
            small[k] += usize::from(traj.species[i] == 0);
        }
    }
    let (mut sum, mut used) = (0.0, 0usize);
    for (&s, &a) in small.iter().zip(&all) {
        if a > 0 {
            let dev = s as f64 / a as f64 - x;
            sum += dev * dev * a as f64 / (x * (1.0 - x));
            used += 1;
        }
    }
    sum / used as f64
}

/// Table `t, psi6, psi6_global, small_fraction_var`: one row per recorded
/// frame, t the frame's simulation time.
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    check_trajectory(traj)?;
    ensure_positive("cutoff", p.cutoff)?;
    let cells = SubBoxes::new(traj, p.n)?;
    let mut cols: [Vec<f64>; 4] = Default::default();
    for f in &traj.frames {
        let (local, global) = psi6(traj, f, p.cutoff)?;
        cols[0].push(f.time);
        cols[1].push(local);
        cols[2].push(global);
        cols[3].push(small_fraction_var(traj, f, &cells));
    }
    let [t, local, global, var] = cols;
    f64_batch(&[
        ("t", t),
        ("psi6", local),
        ("psi6_global", global),
        ("small_fraction_var", var),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::test_support::col;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// One frame of `rows` rows of `cols` disks a unit apart, row r shifted and
    /// placed at `row(r)`, species by (column, row).
    fn lattice(
        cols: usize,
        rows: usize,
        row: impl Fn(usize) -> (f64, f64),
        box_size: [f64; 2],
        species: impl Fn(usize, usize) -> u8,
    ) -> Trajectory {
        let (mut x, mut y, mut s) = (Vec::new(), Vec::new(), Vec::new());
        for r in 0..rows {
            let (shift, height) = row(r);
            for c in 0..cols {
                x.push(c as f64 + shift);
                y.push(height);
                s.push(species(c, r));
            }
        }
        trajectory(box_size, s, vec![(0.0, x, y)])
    }

    fn trajectory(
        box_size: [f64; 2],
        species: Vec<u8>,
        frames: Vec<(f64, Vec<f64>, Vec<f64>)>,
    ) -> Trajectory {
        Trajectory {
            box_size,
            periodic: [true, true],
            species,
            // Unit spacing is contact for radius 0.5; the large species barely larger,
            // so that both lattices keep their shells within the cut-off.
            radii: vec![0.5, 0.5],
            masses: vec![1.0, 1.0],
            frames: frames
                .into_iter()
                .map(|(time, x, y)| Frame {
                    time,
                    x,
                    y,
                    vx: Vec::new(),
                    vy: Vec::new(),
                })
                .collect(),
            schedule: None,
        }
    }

    fn order(traj: &Trajectory, p: &Params) -> RecordBatch {
        compute(traj, p).unwrap()
    }

    /// Rows offset by half a spacing, sqrt(3)/2 apart: six neighbours at
    /// multiples of 60 degrees, every exp(6 i theta) = 1.
    #[test]
    fn a_triangular_lattice_has_psi6_one() {
        let (cols, rows) = (24, 28); // rows even: periodic in y
        let h = 3f64.sqrt() / 2.0;
        let t = lattice(
            cols,
            rows,
            |r| (0.5 * (r % 2) as f64 + 0.25, (r as f64 + 0.5) * h),
            [cols as f64, rows as f64 * h],
            |c, r| ((c + r) % 2) as u8,
        );
        let b = order(&t, &Params::default());
        assert!(
            (col(&b, "psi6")[0] - 1.0).abs() < 1e-12,
            "{:?}",
            col(&b, "psi6")
        );
        assert!((col(&b, "psi6_global")[0] - 1.0).abs() < 1e-12);
    }

    /// Four neighbours at 90 degrees: exp(6 i 90 deg) = -1 cancels each pair;
    /// the diagonal ones (sqrt 2 > 1.4) are outside the cut-off.
    #[test]
    fn a_square_lattice_has_psi6_zero() {
        let n = 30;
        let t = lattice(n, n, |r| (0.5, r as f64 + 0.5), [n as f64; 2], |_, _| 0);
        let b = order(&t, &Params::default());
        assert!(col(&b, "psi6")[0].abs() < 1e-12, "{:?}", col(&b, "psi6"));
        assert!(col(&b, "psi6_global")[0].abs() < 1e-12);
        // One species: the composition is undefined, not a number.
        assert!(col(&b, "small_fraction_var")[0].is_nan());
    }

    /// Random points, random species: no orientational order beyond
    /// 1/sqrt(N), and a composition variance at its binomial value.
    #[test]
    fn a_random_mixture_has_no_global_order_and_binomial_composition() {
        let (n, l, frames) = (4000, 64.0, 20);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let species: Vec<u8> = (0..n)
            .map(|_| u8::from(rng.random::<f64>() < 0.5))
            .collect();
        let data = (0..frames)
            .map(|k| {
                let x = (0..n).map(|_| l * rng.random::<f64>()).collect();
                let y = (0..n).map(|_| l * rng.random::<f64>()).collect();
                (k as f64, x, y)
            })
            .collect();
        let t = trajectory([l, l], species, data);
        // Sub-boxes of side 8: 64 of about 62 disks.
        let b = order(
            &t,
            &Params {
                n: 62.5,
                ..Default::default()
            },
        );
        let bound = 4.0 / (n as f64).sqrt();
        for g in col(&b, "psi6_global") {
            assert!(g < bound, "psi6_global {g} above 4/sqrt(N) = {bound}");
        }
        // Each cell's ratio is a chi^2 of one degree of freedom (variance 2):
        // the mean over 64 cells and 20 frames has a standard error of
        // sqrt(2 / 1280) = 0.04; the bound is 4 of them. Drawing without
        // replacement lowers it by 1 - 62/4000 only.
        let v = col(&b, "small_fraction_var");
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        assert!((mean - 1.0).abs() < 0.16, "random mixture: ratio {mean}");
        // The local order of random points is far from both lattices.
        let local = col(&b, "psi6")[0];
        assert!(local > 0.1 && local < 0.9, "psi6 {local}");
    }

    /// Small disks in the left half, large in the right: a cell within one half
    /// is pure, (f - x)^2 = x (1 - x), and the ratio is its disk count.
    #[test]
    fn demixed_halves_give_a_ratio_of_the_cell_count() {
        let n = 32;
        let t = lattice(
            n,
            n,
            |r| (0.5, r as f64 + 0.5),
            [n as f64; 2],
            |c, _| u8::from(c >= n / 2),
        );
        // 4 x 4 cells of 64 disks each, none straddling the halves.
        let b = order(
            &t,
            &Params {
                n: 64.0,
                ..Default::default()
            },
        );
        let v = col(&b, "small_fraction_var")[0];
        assert!((v - 64.0).abs() < 1e-9, "demixed: ratio {v}");
        // A checkerboard: every cell holds exactly half of each, ratio 0.
        let t = lattice(
            n,
            n,
            |r| (0.5, r as f64 + 0.5),
            [n as f64; 2],
            |c, r| ((c + r) % 2) as u8,
        );
        let v = col(
            &order(
                &t,
                &Params {
                    n: 64.0,
                    ..Default::default()
                },
            ),
            "small_fraction_var",
        )[0];
        assert!(v.abs() < 1e-12, "alternating: ratio {v}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let t = lattice(8, 8, |r| (0.5, r as f64 + 0.5), [8.0; 2], |_, _| 0);
        let e = compute(
            &t,
            &Params {
                cutoff: 0.0,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(format!("{e:#}").contains("`cutoff`"), "{e:#}");
    }
}
