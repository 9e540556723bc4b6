//! Named rescalings of a data collapse, one entry each: which scaling
//! parameters the collapse searches, which per-curve numbers it reads (e.g. a
//! per-phi fit joined in) and the map (x, y, sigma) -> (X, Y, sigma_Y).
//! The `collapse` stage looks them up by `rescaling: NAME`; a new collapse is
//! one entry here and a pipeline.
//!
//! The collapse quality compares curves on log-log axes (see [`super::collapse`]),
//! so X and Y must be > 0. A collapse against a variable that is linear in a
//! logarithm, such as Q against beta ln(t/tau0) (paper H, Fig. 6), maps to
//! X = (t/tau0)^beta: ln X is that variable, and the comparison is the same.

/// What one curve of a collapse brings to its rescaling.
pub struct At<'a> {
    /// The control parameter labelling the curve (phi).
    pub param: f64,
    /// The critical phi_c (NaN when the rescaling does not use it).
    pub phi_c: f64,
    /// The curve's values of the rescaling's `per_curve` columns, in that order.
    pub columns: &'a [f64],
}

/// One named rescaling.
pub struct Rescaling {
    /// Its name in specs (`rescaling: cluster_cutoff`).
    pub name: &'static str,
    /// What is plotted against what, as in the paper.
    pub describe: &'static str,
    /// Scaling parameters the collapse searches (in `bounds`), in order.
    pub fitted: &'static [&'static str],
    /// Columns read per curve (from its first row).
    pub per_curve: &'static [&'static str],
    /// Whether phi_c must be given (`phi_c` or `phi_c_from`).
    pub needs_phi_c: bool,
    /// (fitted parameters, curve, x, y, sigma) -> (X, Y, sigma_Y).
    pub map: Map,
}

/// (fitted parameters, curve, x, y, sigma) -> (X, Y, sigma_Y).
pub type Map = fn(&[f64], &At<'_>, f64, f64, f64) -> (f64, f64, f64);

pub static RESCALINGS: &[Rescaling] = &[
    Rescaling {
        name: "cluster_cutoff",
        describe: "P Nc^kappa against Nc/N*, N* = (phi_c - phi)^(-1/rho) (paper H, Eq. 11 and Fig. 13)",
        fitted: &["kappa", "rho"],
        per_curve: &[],
        needs_phi_c: true,
        map: |q, c, x, y, s| {
            let f = x.powf(q[0]);
            (x * (c.phi_c - c.param).powf(1.0 / q[1]), y * f, s * f)
        },
    },
    Rescaling {
        name: "log_normal",
        describe: "[P/P0]^(2 sigma^2) against Nc/N_sigma with each phi's log-normal fit (paper H, Eq. 13 and Fig. 14)",
        fitted: &[],
        per_curve: &["P0", "N_sigma", "sigma"],
        needs_phi_c: false,
        map: |_, c, x, y, s| {
            let (p0, n_sigma, sigma) = (c.columns[0], c.columns[1], c.columns[2]);
            let e = 2.0 * sigma * sigma;
            let big_y = (y / p0).powf(e);
            (x / n_sigma, big_y, big_y * e * s / y)
        },
    },
];

/// The rescaling named `name`, or an error listing the known ones.
pub fn find(name: &str) -> Result<&'static Rescaling, String> {
    RESCALINGS.iter().find(|r| r.name == name).ok_or_else(|| {
        let known: Vec<&str> = RESCALINGS.iter().map(|r| r.name).collect();
        format!("unknown rescaling `{name}`; known: {}", known.join(", "))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::collapse::{self, Curve};

    fn curves_from(xs: &[f64], make: impl Fn(f64, f64) -> f64, params: &[f64]) -> Vec<Curve> {
        params
            .iter()
            .map(|&phi| {
                let y: Vec<f64> = xs.iter().map(|&x| make(phi, x)).collect();
                Curve {
                    label: format!("phi={phi}"),
                    param: phi,
                    x: xs.to_vec(),
                    sigma: y.iter().map(|v| 0.01 * v).collect(),
                    y,
                }
            })
            .collect()
    }

    /// P = Nc^-kappa f(Nc/N*) with N* = (phi_c - phi)^(-1/rho) collapses at the
    /// kappa and rho it was made with.
    #[test]
    fn cluster_cutoff_recovers_kappa_and_rho() {
        let (kappa, rho, phi_c) = (1.8, 1.63, 0.82);
        let xs: Vec<f64> = (0..25).map(|i| 10f64.powf(i as f64 / 8.0)).collect();
        let make = |phi: f64, n: f64| {
            let n_star = (phi_c - phi).powf(-1.0 / rho);
            n.powf(-kappa) * (-n / n_star).exp()
        };
        let curves = curves_from(&xs, make, &[0.70, 0.74, 0.77, 0.79]);
        let r = find("cluster_cutoff").unwrap();
        let map = |q: &[f64], c: &Curve, x: f64, y: f64, s: f64| {
            (r.map)(
                q,
                &At {
                    param: c.param,
                    phi_c,
                    columns: &[],
                },
                x,
                y,
                s,
            )
        };
        let res = collapse::collapse(&curves, r.fitted, &[(1.0, 2.5), (0.8, 3.0)], &map).unwrap();
        let (k, dk) = res.get("kappa").unwrap();
        let (p, dp) = res.get("rho").unwrap();
        assert!((k - kappa).abs() < 0.02 + 3.0 * dk, "kappa {k} ± {dk}");
        assert!((p - rho).abs() < 0.05 + 3.0 * dp, "rho {p} ± {dp}");
        // The minimum is the best collapse, and a wrong kappa spreads the curves
        // (linear interpolation between the points
        // of a curved master curve keeps S above its ideal 1 at 1% errors).
        let s_at = |q: &[f64]| collapse::quality(&curves, &map, q).unwrap().s;
        assert!(
            res.quality.s <= 1.0001 * s_at(&[kappa, rho]),
            "S = {}",
            res.quality.s
        );
        assert!(s_at(&[kappa - 0.3, rho]) > s_at(&[kappa, rho]));
    }

    /// Log-normal curves of different P0, N_sigma and sigma fall on exp(-ln^2 X).
    #[test]
    fn log_normal_maps_onto_the_master_curve() {
        let r = find("log_normal").unwrap();
        for (p0, ns, sg) in [(0.3, 2.0, 1.1), (0.1, 7.0, 1.7)] {
            let cols = [p0, ns, sg];
            let at = At {
                param: 0.7,
                phi_c: f64::NAN,
                columns: &cols,
            };
            for n in [1.0, 3.0, 20.0, 150.0] {
                let p = p0 * (-(n / ns).ln().powi(2) / (2.0 * sg * sg)).exp();
                let (x, y, s) = (r.map)(&[], &at, n, p, 0.1 * p);
                assert!((y - (-x.ln().powi(2)).exp()).abs() < 1e-12 * y.max(1e-300));
                // sigma_Y / Y = 2 sigma^2 sigma_P / P
                assert!((s / y - 2.0 * sg * sg * 0.1).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn unknown_names_list_the_known_ones() {
        let e = find("lognormal").err().unwrap();
        assert!(
            e.contains("log_normal") && e.contains("cluster_cutoff"),
            "{e}"
        );
    }
}
