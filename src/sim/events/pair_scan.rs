//! The pair scan: the earliest collision of one disk with the disks of its
//! neighbour list, the engine's innermost loop (about half its time at N = 10^4).
//!
//! Two versions give the same answer bit for bit, ties included, so a
//! trajectory does not depend on the machine it runs on:
//! - [`earliest_pair_scalar`], the reference (and the scan off x86_64);
//! - an SSE2 one (x86_64 baseline, no run-time dispatch), two listed disks per
//!   step.
//!
//! Both do the same IEEE operations in the same order on every pair (no fused
//! multiply-add), keep per lane the earliest time by strict comparison in list
//! order, and break ties between lanes by list position: the reference's "first
//! earliest in list order".
//!
//! Wider vectors did not pay (docs/sim.md): lists hold 5.4 disks on average at
//! phi = 0.78, and the scan waits on loading the listed disks' lines.

use super::disk::{Disk, SHELL};

/// The earliest collision of disk `a` (at time `now`) with the disks `list` of
/// `d`, if earlier than `best`: (time from now, partner), or (`best`, SHELL).
/// A listed disk `j` whose own pending event (`te`) is earlier is skipped: it
/// will predict anew then (every event ends in a prediction) and find `a`
/// itself (Smallenburg's rule; spares the stale event this one would become).
#[inline(always)]
pub(crate) fn earliest_pair(
    d: &[Disk],
    list: &[u32],
    a: &Disk,
    now: f64,
    lx: f64,
    ly: f64,
    best: f64,
) -> (f64, u32) {
    // SAFETY: SSE2 is part of the x86_64 baseline.
    #[cfg(target_arch = "x86_64")]
    return unsafe { earliest_pair_sse2(d, list, a, now, lx, ly, best) };
    #[cfg(not(target_arch = "x86_64"))]
    return earliest_pair_scalar(d, list, a, now, lx, ly, best);
}

/// The separation `d` along a periodic axis of length `l` brought to its
/// nearest image.
#[inline(always)]
pub(crate) fn nearest_image(d: f64, l: f64) -> f64 {
    d - l * round_nearest(d / l)
}

/// `x` rounded to the nearest integer (ties to even) for |x| < 2^51, without a
/// branch or a libm call: adding 1.5 2^52 leaves no fraction bits.
#[inline(always)]
pub(crate) fn round_nearest(x: f64) -> f64 {
    (x + ROUND_MAGIC) - ROUND_MAGIC
}

const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

/// The reference scan (and the scan off x86_64). Written without branches on the pair geometry (which pair
/// approaches is a coin flip that the branch predictor loses half the time):
/// every pair's root is computed and the earliest kept by selects.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn earliest_pair_scalar(
    d: &[Disk],
    list: &[u32],
    a: &Disk,
    now: f64,
    lx: f64,
    ly: f64,
    mut best: f64,
) -> (f64, u32) {
    let (ilx, ily) = (1.0 / lx, 1.0 / ly);
    let mut partner = SHELL;
    for &j in list {
        let b = &d[j as usize];
        let dtj = now - b.t;
        let dvx = b.vx - a.vx;
        let dvy = b.vy - a.vy;
        let dx = b.x + b.vx * dtj - a.x;
        let dy = b.y + b.vy * dtj - a.y;
        // List members are much closer than half a box: the nearest image.
        let dx = dx - lx * round_nearest(dx * ilx);
        let dy = dy - ly * round_nearest(dy * ily);
        let bb = dx * dvx + dy * dvy;
        let sig = a.radius + b.radius;
        let c = dx * dx + dy * dy - sig * sig;
        let aa = dvx * dvx + dvy * dvy;
        let disc = bb * bb - aa * c;
        // With bb < 0 the denominator is positive; c <= 0 (touching within
        // round-off) while approaching gives a collision now.
        let tt = (c / (disc.max(0.0).sqrt() - bb)).max(0.0);
        let hit = (bb < 0.0) & (disc >= 0.0) & (tt < best) & (now + tt <= b.te);
        best = select_f64(hit, tt, best);
        partner = select_u32(hit, j, partner);
    }
    (best, partner)
}

/// Two listed disks per step. Lane 0 takes the even list positions, lane 1 the
/// odd ones; an odd last disk is paired with itself (the same pair twice).
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "sse2")]
fn earliest_pair_sse2(
    d: &[Disk],
    list: &[u32],
    a: &Disk,
    now: f64,
    lx: f64,
    ly: f64,
    best: f64,
) -> (f64, u32) {
    use std::arch::x86_64::*;
    let n = list.len();
    if n == 0 {
        return (best, SHELL);
    }
    let v = |x: f64| _mm_set1_pd(x);
    let (now2, ax, ay, avx, avy, ar) = (v(now), v(a.x), v(a.y), v(a.vx), v(a.vy), v(a.radius));
    let (lx2, ly2, ilx2, ily2) = (v(lx), v(ly), v(1.0 / lx), v(1.0 / ly));
    let magic = v(ROUND_MAGIC);
    let zero = _mm_setzero_pd();
    let mut best2 = v(best);
    let mut pos2 = _mm_set1_epi64x(-1);
    let mut k = 0;
    while k < n {
        let k1 = (k + 1).min(n - 1);
        let (b0, b1) = (&d[list[k] as usize], &d[list[k1] as usize]);
        // SAFETY: Disk is repr(C, align(64)) and starts with x, y, vx, vy, t,
        // radius (16-byte aligned pairs); the pointers come from whole-Disk
        // references, so each aligned 16-byte load stays inside one Disk.
        let (p0, p1) = (
            (b0 as *const Disk).cast::<f64>(),
            (b1 as *const Disk).cast::<f64>(),
        );
        let (xy0, xy1, v0, v1, tr0, tr1) = unsafe {
            (
                _mm_load_pd(p0),
                _mm_load_pd(p1),
                _mm_load_pd(p0.add(2)),
                _mm_load_pd(p1.add(2)),
                _mm_load_pd(p0.add(4)),
                _mm_load_pd(p1.add(4)),
            )
        };
        let (bx, by) = (_mm_unpacklo_pd(xy0, xy1), _mm_unpackhi_pd(xy0, xy1));
        let (bvx, bvy) = (_mm_unpacklo_pd(v0, v1), _mm_unpackhi_pd(v0, v1));
        let (bt, br) = (_mm_unpacklo_pd(tr0, tr1), _mm_unpackhi_pd(tr0, tr1));
        let bte = _mm_set_pd(b1.te, b0.te);
        let dtj = _mm_sub_pd(now2, bt);
        let dvx = _mm_sub_pd(bvx, avx);
        let dvy = _mm_sub_pd(bvy, avy);
        let dx = _mm_sub_pd(_mm_add_pd(bx, _mm_mul_pd(bvx, dtj)), ax);
        let dy = _mm_sub_pd(_mm_add_pd(by, _mm_mul_pd(bvy, dtj)), ay);
        let kx = _mm_sub_pd(_mm_add_pd(_mm_mul_pd(dx, ilx2), magic), magic);
        let ky = _mm_sub_pd(_mm_add_pd(_mm_mul_pd(dy, ily2), magic), magic);
        let dx = _mm_sub_pd(dx, _mm_mul_pd(lx2, kx));
        let dy = _mm_sub_pd(dy, _mm_mul_pd(ly2, ky));
        let bb = _mm_add_pd(_mm_mul_pd(dx, dvx), _mm_mul_pd(dy, dvy));
        let sig = _mm_add_pd(ar, br);
        let c = _mm_sub_pd(
            _mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)),
            _mm_mul_pd(sig, sig),
        );
        let aa = _mm_add_pd(_mm_mul_pd(dvx, dvx), _mm_mul_pd(dvy, dvy));
        let disc = _mm_sub_pd(_mm_mul_pd(bb, bb), _mm_mul_pd(aa, c));
        // max(x, 0) as in the scalar version (maxpd returns 0 for NaN x).
        let root = _mm_sqrt_pd(_mm_max_pd(disc, zero));
        let tt = _mm_max_pd(_mm_div_pd(c, _mm_sub_pd(root, bb)), zero);
        let hit = _mm_and_pd(
            _mm_and_pd(_mm_cmplt_pd(bb, zero), _mm_cmpge_pd(disc, zero)),
            _mm_and_pd(
                _mm_cmplt_pd(tt, best2),
                _mm_cmple_pd(_mm_add_pd(now2, tt), bte),
            ),
        );
        best2 = _mm_or_pd(_mm_and_pd(hit, tt), _mm_andnot_pd(hit, best2));
        let hm = _mm_castpd_si128(hit);
        let kk = _mm_set_epi64x(k1 as i64, k as i64);
        pos2 = _mm_or_si128(_mm_and_si128(hm, kk), _mm_andnot_si128(hm, pos2));
        k += 2;
    }
    let t = [
        _mm_cvtsd_f64(best2),
        _mm_cvtsd_f64(_mm_unpackhi_pd(best2, best2)),
    ];
    let p = [
        _mm_cvtsi128_si64(pos2),
        _mm_cvtsi128_si64(_mm_unpackhi_epi64(pos2, pos2)),
    ];
    // The earlier lane; on a tie the earlier list position (lane 1's positions
    // are odd, lane 0's even, so a tie between hits has distinct positions).
    let l = usize::from(t[1] < t[0] || (t[1] == t[0] && p[1] >= 0 && (p[0] < 0 || p[1] < p[0])));
    partner_at(list, t[l], p[l])
}

/// (time, partner) from the winning list position (-1: no hit, the shell).
#[inline(always)]
fn partner_at(list: &[u32], t: f64, pos: i64) -> (f64, u32) {
    if pos < 0 {
        (t, SHELL)
    } else {
        (t, list[pos as usize])
    }
}

/// `if c { a } else { b }` without a branch: which disk wins is a coin flip,
/// and LLVM turns a plain `if` on it into a jump mispredicted half the time.
#[inline(always)]
fn select_u32(c: bool, a: u32, b: u32) -> u32 {
    let m = (c as u32).wrapping_neg();
    (a & m) | (b & !m)
}

/// `if c { a } else { b }` without a branch (see [`select_u32`]).
#[inline(always)]
fn select_f64(c: bool, a: f64, b: f64) -> f64 {
    let m = (c as u64).wrapping_neg();
    f64::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

#[cfg(test)]
mod unit {
    use super::{Disk, SHELL, earliest_pair, earliest_pair_scalar, round_nearest};
    use rand::{RngExt, SeedableRng};

    /// The scan gives the scalar reference's answer, bit for bit
    /// and partner for partner, on random neighbourhoods of every list length
    /// (odd lengths pair the last disk with itself in SSE2), near a periodic
    /// boundary, with some neighbours' events earlier, and with exact ties: some
    /// neighbours are copies of another (same time, the first in the list wins).
    #[test]
    fn every_scan_equals_the_scalar_reference() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (lx, ly) = (40.0, 30.0);
        let (mut hits, mut ties) = (0, 0);
        for case in 0..6000 {
            let m = case % 19;
            let mut d = vec![Disk::default(); m + 1];
            for k in 0..=m {
                if k >= 2 && rng.random::<f64>() < 0.15 {
                    d[k] = d[rng.random_range(1..k)];
                    continue;
                }
                let r = if rng.random::<bool>() { 1.0 } else { 1.43 };
                let (ang, dist) = (
                    rng.random::<f64>() * std::f64::consts::TAU,
                    2.9 + 0.8 * rng.random::<f64>(),
                );
                // Disk 0 sits at the box edge: neighbours wrap around.
                let (x, y) = if k == 0 {
                    (0.1, 29.9)
                } else {
                    (0.1 + dist * ang.cos(), 29.9 + dist * ang.sin())
                };
                d[k] = Disk {
                    x: x.rem_euclid(lx),
                    y: y.rem_euclid(ly),
                    vx: rng.random::<f64>() * 4.0 - 2.0,
                    vy: rng.random::<f64>() * 4.0 - 2.0,
                    t: 5.0 - 0.01 * rng.random::<f64>(),
                    radius: r,
                    te: 5.0
                        + if rng.random::<f64>() < 0.2 {
                            0.05
                        } else {
                            10.0
                        },
                    ..Disk::default()
                };
            }
            let a = Disk { t: 5.0, ..d[0] };
            let list: Vec<u32> = (1..=m as u32).collect();
            let shell = 0.5 * rng.random::<f64>();
            let want = earliest_pair_scalar(&d, &list, &a, 5.0, lx, ly, shell);
            let got = earliest_pair(&d, &list, &a, 5.0, lx, ly, shell);
            assert_eq!(got.0.to_bits(), want.0.to_bits(), "case {case}");
            assert_eq!(got.1, want.1, "case {case}");
            if want.1 != SHELL {
                hits += 1;
                let w = &d[want.1 as usize];
                ties += usize::from(d[1..].iter().filter(|b| b.x == w.x).count() > 1);
            }
        }
        // Some cases find a collision, the others only the shell exit: both paths
        // run; and some winners have an identical copy later in the list.
        assert!(
            hits > 600 && hits < 5800,
            "{hits} of 6000 found a collision"
        );
        assert!(ties > 50, "only {ties} winners had a tie");
    }

    #[test]
    fn round_nearest_is_the_nearest_image_count() {
        for (x, r) in [
            (0.2, 0.0),
            (-0.2, 0.0),
            (0.7, 1.0),
            (-0.7, -1.0),
            (1.4, 1.0),
            (-1.6, -2.0),
        ] {
            assert_eq!(round_nearest(x), r, "{x}");
        }
    }
}
