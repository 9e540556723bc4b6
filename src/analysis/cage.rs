//! Displacements relative to each disk's cage: dr_i minus the mean dr_j of the
//! disks that were its neighbours at t0 (closer than `cutoff` times the contact
//! distance R_i + R_j). In two dimensions displacements from a fixed origin
//! carry long-wavelength collective motion that grows with the box
//! (Mermin-Wagner fluctuations; Flenner and Szamel, Nat. Commun. 6, 7392 (2015);
//! Illing et al., PNAS 114, 1856 (2017)); a cage moving with its disk is then no
//! relaxation. This is a diagnostic beside paper H's absolute overlap, not its
//! method.

use anyhow::{Result, bail};

use super::neighbours::for_each_neighbour;
use crate::traj::{Frame, Trajectory};

/// |dr_i - <dr_j>_{j in cage(i)}|^2 per disk over the frames f0 -> f1 of `traj`;
/// a disk without neighbours keeps its own displacement.
pub fn squared_displacements(
    traj: &Trajectory,
    f0: &Frame,
    f1: &Frame,
    cutoff: f64,
) -> Result<Vec<f64>> {
    if !(cutoff.is_finite() && cutoff > 0.0) {
        bail!("the cage cut-off (in contact distances) must be positive, got {cutoff}");
    }
    let n = traj.n();
    let dx: Vec<f64> = f1.x.iter().zip(&f0.x).map(|(a, b)| a - b).collect();
    let dy: Vec<f64> = f1.y.iter().zip(&f0.y).map(|(a, b)| a - b).collect();
    let (mut sx, mut sy, mut k) = (vec![0.0; n], vec![0.0; n], vec![0u32; n]);
    for_each_neighbour(traj, &f0.x, &f0.y, cutoff, |i, j, _, _| {
        sx[i] += dx[j];
        sy[i] += dy[j];
        k[i] += 1;
        sx[j] += dx[i];
        sy[j] += dy[i];
        k[j] += 1;
    })?;
    Ok((0..n)
        .map(|i| {
            let (mx, my) = if k[i] > 0 {
                (sx[i] / k[i] as f64, sy[i] / k[i] as f64)
            } else {
                (0.0, 0.0)
            };
            (dx[i] - mx).powi(2) + (dy[i] - my).powi(2)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::squared_displacements as absolute;
    use crate::analysis::synthetic::independent_slow;

    /// A rigid shift of every disk moves no disk relative to its cage; added to
    /// individual jumps, it changes no cage-relative displacement, while the
    /// absolute ones all exceed the cut-off.
    #[test]
    fn a_collective_shift_is_no_cage_relative_motion() {
        let traj = independent_slow(3000, [80.0, 80.0], 1, 0.3, 1.0, 5);
        let (f0, f1) = (&traj.frames[0], &traj.frames[1]);
        let mut shifted = f1.clone();
        shifted.x.iter_mut().for_each(|x| *x += 5.0);
        shifted.y.iter_mut().for_each(|y| *y -= 3.0);
        let mut rigid = f0.clone();
        rigid.x.iter_mut().for_each(|x| *x += 5.0);
        rigid.y.iter_mut().for_each(|y| *y -= 3.0);

        let none = squared_displacements(&traj, f0, &rigid, 1.4).unwrap();
        assert!(
            none.iter().all(|&d| d < 1e-20),
            "max {:?}",
            none.iter().copied().fold(0.0, f64::max)
        );
        let own = squared_displacements(&traj, f0, f1, 1.4).unwrap();
        let with_shift = squared_displacements(&traj, f0, &shifted, 1.4).unwrap();
        for (a, b) in own.iter().zip(&with_shift) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        assert!(absolute(f0, &shifted).iter().all(|&d| d > 0.36));
        // Without a shift, slow disks (dr = 0) keep |dr_rel| = |mean of their
        // neighbours' jumps| < 1 (the jump length).
        let slow_abs = absolute(f0, f1).iter().filter(|&&d| d < 1e-20).count();
        assert!(slow_abs > 800, "{slow_abs} slow disks");
        assert!(squared_displacements(&traj, f0, f1, 0.0).is_err());
    }
}
