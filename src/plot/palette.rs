//! Default series colours.

use super::spec::{Color, Palette};

/// viridis (matplotlib) at 0, 1/8, ..., 1: perceptually uniform, readable in grey.
const VIRIDIS: [[u8; 3]; 9] = [
    [0x44, 0x01, 0x54],
    [0x47, 0x2c, 0x7a],
    [0x3b, 0x51, 0x8b],
    [0x2c, 0x71, 0x8e],
    [0x21, 0x90, 0x8d],
    [0x27, 0xad, 0x81],
    [0x5c, 0xc8, 0x63],
    [0xaa, 0xdc, 0x32],
    [0xfd, 0xe7, 0x25],
];

/// Tableau 10 (matplotlib's default cycle): distinct hues for unordered sets.
const CATEGORICAL: [[u8; 3]; 10] = [
    [0x1f, 0x77, 0xb4],
    [0xff, 0x7f, 0x0e],
    [0x2c, 0xa0, 0x2c],
    [0xd6, 0x27, 0x28],
    [0x94, 0x67, 0xbd],
    [0x8c, 0x56, 0x4b],
    [0xe3, 0x77, 0xc2],
    [0x7f, 0x7f, 0x7f],
    [0xbc, 0xbd, 0x22],
    [0x17, 0xbe, 0xcf],
];

/// Viridis stops short of its pale yellow end, which vanishes on white paper.
const VIRIDIS_END: f64 = 0.88;

/// Colour of series `i` of `n`.
pub fn color(palette: Palette, i: usize, n: usize) -> Color {
    match palette {
        Palette::Categorical => Color(CATEGORICAL[i % CATEGORICAL.len()]),
        Palette::Sequential => {
            let t = if n <= 1 {
                0.0
            } else {
                i as f64 / (n - 1) as f64
            } * VIRIDIS_END;
            viridis(t)
        }
    }
}

/// Colour of a group value at `t` in [0, 1] along its column's values (its
/// rank, or its place in the column's colour range); `k` of `n` values, for
/// the categorical palette.
pub fn group_color(palette: Palette, t: f64, k: usize) -> Color {
    match palette {
        Palette::Categorical => Color(CATEGORICAL[k % CATEGORICAL.len()]),
        Palette::Sequential => viridis(t.clamp(0.0, 1.0) * VIRIDIS_END),
    }
}

/// Viridis at `t` in [0, 1], linear between the stops.
pub fn viridis(t: f64) -> Color {
    let x = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let k = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - k as f64;
    let mix =
        |c: usize| (VIRIDIS[k][c] as f64 * (1.0 - f) + VIRIDIS[k + 1][c] as f64 * f).round() as u8;
    Color([mix(0), mix(1), mix(2)])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative luminance must rise monotonically along the sequential palette,
    /// so curves ordered by phi stay ordered in print.
    #[test]
    fn sequential_palette_brightens_monotonically() {
        let lum =
            |Color([r, g, b]): Color| 0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64;
        let l: Vec<f64> = (0..13)
            .map(|i| lum(color(Palette::Sequential, i, 13)))
            .collect();
        assert!(l.windows(2).all(|w| w[1] > w[0]), "{l:?}");
        assert_eq!(viridis(0.0), Color([0x44, 0x01, 0x54]));
        assert_eq!(viridis(1.0), Color([0xfd, 0xe7, 0x25]));
        assert_eq!(color(Palette::Categorical, 11, 12), Color(CATEGORICAL[1]));
    }
}
