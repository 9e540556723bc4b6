//! Hard walls (paper I: "the walls reflect the particles elastically"), per axis.
//!
//! A walled axis of length `l` holds the disk centres in [r, l - r]. The
//! engine's box is padded beyond `l` on that axis by [`padding`], so that the
//! periodic machinery (cells, nearest images, neighbour lists) never pairs two
//! disks across a wall: the shortest image distance across the padding
//! exceeds every interaction and list range.

/// Padding of a walled axis: more than the largest contact distance plus
/// the list range (two shells on each side).
pub fn padding(rmax: f64, shell: f64) -> f64 {
    2.0 * rmax + 4.0 * shell + rmax
}

/// Time until a disk at `x` with velocity `v` and radius `r (scale + growth tau)`
/// touches the wall at 0 or the one at `l`, and whether it is the upper one.
/// Infinity if it moves away from both (a disk touching within round-off and
/// approaching gets 0).
#[inline]
pub fn wall_time(x: f64, v: f64, r: f64, scale: f64, growth: f64, l: f64) -> (f64, bool) {
    let g = r * growth;
    let lower = if g - v > 0.0 {
        ((x - r * scale) / (g - v)).max(0.0)
    } else {
        f64::INFINITY
    };
    let upper = if v + g > 0.0 {
        ((l - r * scale - x) / (v + g)).max(0.0)
    } else {
        f64::INFINITY
    };
    if upper < lower {
        (upper, true)
    } else {
        (lower, false)
    }
}

/// The velocity component normal to a wall after an elastic reflection, in the
/// frame of the disk's surface (which moves at `r growth` while radii grow).
#[inline]
pub fn reflect(v: f64, r: f64, growth: f64, upper: bool) -> f64 {
    if upper {
        -v - 2.0 * r * growth
    } else {
        2.0 * r * growth - v
    }
}

#[cfg(test)]
mod unit {
    use super::{reflect, wall_time};

    #[test]
    fn wall_times_and_reflections() {
        // Moving up at 2 from x = 3 in [0, 10], radius 1: touches at x = 9.
        assert_eq!(wall_time(3.0, 2.0, 1.0, 1.0, 0.0, 10.0), (3.0, true));
        assert_eq!(wall_time(3.0, -2.0, 1.0, 1.0, 0.0, 10.0), (1.0, false));
        assert_eq!(wall_time(3.0, 0.0, 1.0, 1.0, 0.0, 10.0).0, f64::INFINITY);
        // Growing radius (rate 0.5 of r = 1) at rest in the middle: both walls
        // approach at 0.5; x = 5, l = 10, scale 1: 4 / 0.5 = 8.
        assert_eq!(wall_time(5.0, 0.0, 1.0, 1.0, 0.5, 10.0).0, 8.0);
        assert_eq!(reflect(2.0, 1.0, 0.0, true), -2.0);
        assert_eq!(reflect(-2.0, 1.0, 0.0, false), 2.0);
        // With growth the disk leaves faster than its surface grows.
        assert_eq!(reflect(0.0, 1.0, 0.5, false), 1.0);
    }
}
