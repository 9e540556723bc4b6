//! Cell list: every pair of particles closer than a cut-off, with the minimum-image
//! separation vector, in O(N) for bounded density. Shared by g_ab(r), clusters,
//! cage-relative displacements and the bond order psi6.

use anyhow::{Result, bail};

use super::fold;
use crate::traj::Trajectory;

/// Neighbours: pairs of disks of `traj` at positions (x, y) closer than
/// `cutoff` times the sum of their radii (a first shell in contact distances);
/// `f(i, j, dx, dy)` once per unordered pair, as [`for_each_pair`].
pub fn for_each_neighbour(
    traj: &Trajectory,
    x: &[f64],
    y: &[f64],
    cutoff: f64,
    mut f: impl FnMut(usize, usize, f64, f64),
) -> Result<()> {
    let radius: Vec<f64> = traj
        .species
        .iter()
        .map(|&s| traj.radii[s as usize])
        .collect();
    let r_max = radius.iter().copied().fold(0.0, f64::max);
    for_each_pair(
        x,
        y,
        traj.box_size,
        traj.periodic,
        cutoff * 2.0 * r_max,
        |i, j, dx, dy| {
            let c = cutoff * (radius[i] + radius[j]);
            if dx * dx + dy * dy < c * c {
                f(i, j, dx, dy);
            }
        },
    )
}

/// Pairs within `rcut` of points (x, y) in a box of side `box_size` (periodic per
/// axis): calls `f(i, j, dx, dy)` once per unordered pair, (dx, dy) = r_j - r_i
/// (minimum image). Positions may be unwrapped; they are folded here.
pub fn for_each_pair(
    x: &[f64],
    y: &[f64],
    box_size: [f64; 2],
    periodic: [bool; 2],
    rcut: f64,
    mut f: impl FnMut(usize, usize, f64, f64),
) -> Result<()> {
    for d in 0..2 {
        if periodic[d] && rcut > 0.5 * box_size[d] {
            bail!(
                "neighbour cut-off {rcut} exceeds half the periodic box side {} \
                 (minimum image would be ambiguous)",
                box_size[d]
            );
        }
    }
    let n = x.len();
    let pos: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            [
                fold(x[i], box_size[0], periodic[0]),
                fold(y[i], box_size[1], periodic[1]),
            ]
        })
        .collect();
    // Fewer than 3 cells on a periodic axis would visit a neighbour cell twice.
    let nc = [0, 1].map(|d| {
        let c = (box_size[d] / rcut).floor().max(1.0) as usize;
        if periodic[d] && c < 3 {
            1
        } else {
            c.min(1 << 14)
        }
    });
    let cell_of = |p: &[f64; 2]| -> [usize; 2] {
        [0, 1]
            .map(|d| ((p[d] / box_size[d] * nc[d] as f64).floor().max(0.0) as usize).min(nc[d] - 1))
    };
    // Counting sort of particles by cell.
    let mut start = vec![0usize; nc[0] * nc[1] + 1];
    let cells: Vec<usize> = pos
        .iter()
        .map(|p| {
            let c = cell_of(p);
            c[1] * nc[0] + c[0]
        })
        .collect();
    for &c in &cells {
        start[c + 1] += 1;
    }
    for k in 0..nc[0] * nc[1] {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut order = vec![0usize; n];
    for (i, &c) in cells.iter().enumerate() {
        order[fill[c]] = i;
        fill[c] += 1;
    }
    let r2 = rcut * rcut;
    let image = |d: usize, v: f64| {
        if periodic[d] {
            v - box_size[d] * (v / box_size[d]).round()
        } else {
            v
        }
    };
    let visit = |ci: usize, cj: usize, same: bool, f: &mut dyn FnMut(usize, usize, f64, f64)| {
        for a in start[ci]..start[ci + 1] {
            let i = order[a];
            let b0 = if same { a + 1 } else { start[cj] };
            for &j in &order[b0..start[cj + 1]] {
                let dx = image(0, pos[j][0] - pos[i][0]);
                let dy = image(1, pos[j][1] - pos[i][1]);
                if dx * dx + dy * dy < r2 {
                    f(i, j, dx, dy);
                }
            }
        }
    };
    // Half stencil: each neighbouring cell pair once.
    const HALF: [(i64, i64); 4] = [(1, 0), (-1, 1), (0, 1), (1, 1)];
    for cy in 0..nc[1] {
        for cx in 0..nc[0] {
            let ci = cy * nc[0] + cx;
            visit(ci, ci, true, &mut f);
            for (ox, oy) in HALF {
                let mut c = [cx as i64 + ox, cy as i64 + oy];
                let mut ok = true;
                for d in 0..2 {
                    let m = nc[d] as i64;
                    if c[d] < 0 || c[d] >= m {
                        if periodic[d] && m > 1 {
                            c[d] = c[d].rem_euclid(m);
                        } else {
                            ok = false;
                        }
                    }
                }
                if ok {
                    visit(ci, c[1] as usize * nc[0] + c[0] as usize, false, &mut f);
                }
            }
        }
    }
    Ok(())
}
