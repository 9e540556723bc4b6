//! Colour difference as a reader sees it: CIE L*a*b* (D65) from sRGB, and the
//! CIEDE2000 difference of two colours (Sharma, Wu and Dalal, "The CIEDE2000
//! color-difference formula: implementation notes, supplementary test data,
//! and mathematical observations", Color Res. Appl. 30, 21 (2005)).

use super::spec::Color;

/// CIE L*a*b* of an sRGB colour, D65 white (the sRGB white point).
pub fn lab(Color([r, g, b]): Color) -> [f64; 3] {
    // sRGB companding undone (IEC 61966-2-1).
    let lin = |c: u8| {
        let c = c as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let (r, g, b) = (lin(r), lin(g), lin(b));
    let x = 0.4124564 * r + 0.3575761 * g + 0.1804375 * b;
    let y = 0.2126729 * r + 0.7151522 * g + 0.0721750 * b;
    let z = 0.0193339 * r + 0.1191920 * g + 0.9503041 * b;
    // D65 reference white, Y = 1.
    let (xn, yn, zn) = (0.95047, 1.0, 1.08883);
    let f = |t: f64| {
        let d: f64 = 6.0 / 29.0;
        if t > d * d * d {
            t.cbrt()
        } else {
            t / (3.0 * d * d) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (f(x / xn), f(y / yn), f(z / zn));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The CIEDE2000 difference of two L*a*b* colours (kL = kC = kH = 1).
pub fn ciede2000([l1, a1, b1]: [f64; 3], [l2, a2, b2]: [f64; 3]) -> f64 {
    let deg = |r: f64| r.to_degrees();
    let rad = |d: f64| d.to_radians();
    let c1 = a1.hypot(b1);
    let c2 = a2.hypot(b2);
    let c_bar = 0.5 * (c1 + c2);
    let c7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c7 / (c7 + 25f64.powi(7))).sqrt());
    let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
    let (c1p, c2p) = (a1p.hypot(b1), a2p.hypot(b2));
    let hue = |b: f64, a: f64| {
        if b == 0.0 && a == 0.0 {
            0.0
        } else {
            let h = deg(b.atan2(a));
            if h < 0.0 { h + 360.0 } else { h }
        }
    };
    let (h1p, h2p) = (hue(b1, a1p), hue(b2, a2p));
    let dl = l2 - l1;
    let dc = c2p - c1p;
    let dh = if c1p * c2p == 0.0 {
        0.0
    } else if (h2p - h1p).abs() <= 180.0 {
        h2p - h1p
    } else if h2p - h1p > 180.0 {
        h2p - h1p - 360.0
    } else {
        h2p - h1p + 360.0
    };
    let d_big_h = 2.0 * (c1p * c2p).sqrt() * rad(dh / 2.0).sin();
    let l_bar = 0.5 * (l1 + l2);
    let cp_bar = 0.5 * (c1p + c2p);
    let hp_bar = if c1p * c2p == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 360.0 {
        0.5 * (h1p + h2p + 360.0)
    } else {
        0.5 * (h1p + h2p - 360.0)
    };
    let t = 1.0 - 0.17 * rad(hp_bar - 30.0).cos()
        + 0.24 * rad(2.0 * hp_bar).cos()
        + 0.32 * rad(3.0 * hp_bar + 6.0).cos()
        - 0.20 * rad(4.0 * hp_bar - 63.0).cos();
    let d_theta = 30.0 * (-((hp_bar - 275.0) / 25.0).powi(2)).exp();
    let cp7 = cp_bar.powi(7);
    let r_c = 2.0 * (cp7 / (cp7 + 25f64.powi(7))).sqrt();
    let l50 = (l_bar - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * cp_bar;
    let s_h = 1.0 + 0.015 * cp_bar * t;
    let r_t = -(2.0 * rad(d_theta)).sin() * r_c;
    let (x, y, z) = (dl / s_l, dc / s_c, d_big_h / s_h);
    (x * x + y * y + z * z + r_t * y * z).sqrt()
}

/// The CIEDE2000 difference of two sRGB colours.
pub fn delta_e(a: Color, b: Color) -> f64 {
    ciede2000(lab(a), lab(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairs of Sharma, Wu and Dalal's (2005) Table 1 (pair number, Lab 1,
    /// Lab 2, Delta E00 to four decimals): the blue region where R_T matters
    /// (1-3), an achromatic colour (7, 8: C = 0), hue differences across
    /// 180 degrees (9, 10, 13, 16), large differences (17-19), unit ones
    /// (21, 25) and a dark pair (33).
    #[test]
    fn ciede2000_matches_the_published_test_pairs() {
        let pairs: [(u32, [f64; 3], [f64; 3], f64); 15] = [
            (1, [50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485], 2.0425),
            (2, [50.0, 3.1571, -77.2803], [50.0, 0.0, -82.7485], 2.8615),
            (3, [50.0, 2.8361, -74.0200], [50.0, 0.0, -82.7485], 3.4412),
            (7, [50.0, 0.0, 0.0], [50.0, -1.0, 2.0], 2.3669),
            (8, [50.0, -1.0, 2.0], [50.0, 0.0, 0.0], 2.3669),
            (9, [50.0, 2.49, -0.001], [50.0, -2.49, 0.0009], 7.1792),
            (10, [50.0, 2.49, -0.001], [50.0, -2.49, 0.0010], 7.1792),
            (13, [50.0, -0.001, 2.49], [50.0, 0.0009, -2.49], 4.8045),
            (16, [50.0, 2.5, 0.0], [50.0, 0.0, -2.5], 4.3065),
            (17, [50.0, 2.5, 0.0], [73.0, 25.0, -18.0], 27.1492),
            (18, [50.0, 2.5, 0.0], [61.0, -5.0, 29.0], 22.8977),
            (19, [50.0, 2.5, 0.0], [56.0, -27.0, -3.0], 31.9030),
            (21, [50.0, 2.5, 0.0], [50.0, 3.1736, 0.5854], 1.0000),
            (
                25,
                [60.2574, -34.0099, 36.2677],
                [60.4626, -34.1751, 39.4387],
                1.2644,
            ),
            (
                33,
                [2.0776, 0.0795, -1.1350],
                [0.9033, -0.0636, -0.5514],
                0.9082,
            ),
        ];
        for (n, a, b, want) in pairs {
            let got = ciede2000(a, b);
            assert!((got - want).abs() < 1e-4, "pair {n}: {got} against {want}");
            // Symmetric.
            assert!((ciede2000(b, a) - want).abs() < 1e-4, "pair {n} reversed");
        }
    }

    /// sRGB white and black, and the published Lab of two sRGB primaries.
    #[test]
    fn srgb_to_lab_d65() {
        let close = |x: [f64; 3], y: [f64; 3]| x.iter().zip(y).all(|(a, b)| (a - b).abs() < 0.05);
        assert!(close(lab(Color([255, 255, 255])), [100.0, 0.0, 0.0]));
        assert!(close(lab(Color([0, 0, 0])), [0.0, 0.0, 0.0]));
        assert!(
            close(lab(Color([255, 0, 0])), [53.24, 80.09, 67.20]),
            "{:?}",
            lab(Color([255, 0, 0]))
        );
        assert!(
            close(lab(Color([0, 0, 255])), [32.30, 79.19, -107.86]),
            "{:?}",
            lab(Color([0, 0, 255]))
        );
        assert_eq!(delta_e(Color([10, 200, 30]), Color([10, 200, 30])), 0.0);
    }
}
