//! Every named fit form reachable from a pipeline, one line each: its parameter
//! names, the fit and the model (to draw the fitted curve). The `fit` stage looks
//! forms up here; a new form is one function in `forms` and one line here.

use super::forms::{self, Fixed};
use super::{Data, FitError, FitResult, linear};

/// One named form.
pub struct Form {
    /// Its name in specs (`form: oz`).
    pub name: &'static str,
    /// The model, as in the paper.
    pub describe: &'static str,
    /// Parameter names, in the order of the fit result.
    pub params: &'static [&'static str],
    /// Whether the curve is drawn on log-spaced x.
    pub log_x: bool,
    /// Fit to data with some parameters fixed.
    pub fit: fn(Data<'_>, Fixed<'_>) -> Result<FitResult, FitError>,
    /// y at x for the fitted parameters (in `params` order) and the values held
    /// fixed in the fit (the Gaussian's lag `t`): the fitted curve.
    pub model: fn(&[f64], Fixed<'_>, f64) -> f64,
}

/// Forms solved linearly for every parameter at once: they cannot hold one
/// (`fixed`, `fixed_from`), so a fit that asks it is refused, never run free.
pub const HOLD_NONE: &[&str] = &["power_law", "line", "log_trend", "proportional"];

/// The value of `name` among `fixed`.
fn fixed_value(fixed: Fixed<'_>, name: &str) -> Option<f64> {
    fixed.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

pub static FORMS: &[Form] = &[
    Form {
        name: "power_law_offset",
        describe: "y = A (phi_c - x)^-gamma (paper H, Fig. 4 dashed line)",
        params: &["A", "phi_c", "gamma"],
        log_x: false,
        fit: forms::power_law_offset,
        model: |p, _, x| {
            if x < p[1] {
                p[0] * (p[1] - x).powf(-p[2])
            } else {
                f64::NAN
            }
        },
    },
    Form {
        name: "vft",
        describe: "y = A exp[B / (phi_0 - x)] (Vogel-Fulcher-Tammann; paper H, Fig. 4 solid line)",
        params: &["A", "phi_0", "B"],
        log_x: false,
        fit: forms::vft,
        // Defined below its divergence only, as the power law: beyond phi_0
        // the formula falls back to ~0, a drawn curve to a vertical line.
        model: |p, _, x| {
            if x < p[1] {
                p[0] * (p[2] / (p[1] - x)).exp()
            } else {
                f64::NAN
            }
        },
    },
    Form {
        name: "power_law",
        describe: "y = A x^exponent (a straight line in log-log)",
        params: &["A", "exponent"],
        log_x: true,
        fit: |d, _| forms::power_law(d),
        model: |p, _, x| p[0] * x.powf(p[1]),
    },
    Form {
        name: "line",
        describe: "y = intercept + slope x",
        params: &["intercept", "slope"],
        log_x: false,
        fit: |d, _| linear::line(d),
        model: |p, _, x| p[0] + p[1] * x,
    },
    Form {
        name: "log_trend",
        describe: "y = slope ln(x / x_0): a trend in ln x and the x where it reaches 0 (a number against N)",
        params: &["slope", "x_0"],
        log_x: true,
        fit: |d, _| linear::log_trend(d),
        model: |p, _, x| p[0] * (x / p[1]).ln(),
    },
    Form {
        name: "proportional",
        describe: "y = slope x (a line through the origin)",
        params: &["slope"],
        log_x: false,
        fit: |d, _| linear::proportional(d),
        model: |p, _, x| p[0] * x,
    },
    Form {
        name: "q_relaxation",
        describe: "Q(t) = 1 / ((t/tau0)^beta + 1) (Eq. 8 of paper H)",
        params: &["tau0", "beta"],
        log_x: true,
        fit: forms::q_relaxation,
        model: |p, _, t| 1.0 / ((t / p[0]).powf(p[1]) + 1.0),
    },
    Form {
        name: "oz",
        describe: "S4(q) = chi0 / (1 + (q xi)^2) (Ornstein-Zernike, Eq. 18 of paper H)",
        params: &["chi0", "xi"],
        log_x: true,
        fit: forms::oz,
        model: |p, _, q| p[0] / (1.0 + (q * p[1]).powi(2)),
    },
    Form {
        name: "oz_quartic",
        describe: "S4(q) = chi0 / (1 + (q xi)^2 + A^2 (q xi)^4) (Eq. 20 of paper H)",
        params: &["chi0", "xi", "A"],
        log_x: true,
        fit: forms::oz_quartic,
        model: |p, _, q| {
            let u = (q * p[1]).powi(2);
            p[0] / (1.0 + u + p[2] * p[2] * u * u)
        },
    },
    Form {
        name: "gaussian",
        describe: "P(dx) = exp(-dx^2 / (4 D t)) / sqrt(4 pi D t): the Gaussian van Hove function at lag t (give t in `fixed` or group by t)",
        params: &["D"],
        log_x: false,
        fit: |d, fixed| match fixed_value(fixed, "t") {
            Some(t) => forms::gaussian_van_hove(d, t),
            None => Err(FitError::InvalidInput {
                form: "gaussian".into(),
                what: "needs the lag t: give `fixed: {t: ...}` or group by a column `t`".into(),
            }),
        },
        model: |p, fixed, x| {
            let w = 4.0 * p[0] * fixed_value(fixed, "t").unwrap_or(f64::NAN);
            (-x * x / w).exp() / (std::f64::consts::PI * w).sqrt()
        },
    },
    Form {
        name: "exponential_tail",
        describe: "P(dx) = A exp(-|dx| / x0) (pass the tail points only)",
        params: &["A", "x0"],
        log_x: false,
        fit: forms::exponential_tail,
        model: |p, _, x| p[0] * (-x.abs() / p[1]).exp(),
    },
    Form {
        name: "log_normal",
        describe: "P(Nc) = P0 exp(-[ln(Nc / N_sigma)]^2 / (2 sigma^2)) (Eq. 12-13 of paper H)",
        params: &["P0", "N_sigma", "sigma"],
        log_x: true,
        fit: forms::log_normal,
        model: |p, _, n| p[0] * (-(n / p[1]).ln().powi(2) / (2.0 * p[2] * p[2])).exp(),
    },
    Form {
        name: "crossover",
        describe: "y = mu x (1 + x/x_c)^(beta - 1): linear response below x_c, y ~ x^beta above (paper I, v(F))",
        params: &["mu", "x_c", "beta"],
        log_x: true,
        fit: forms::crossover,
        model: |p, _, x| p[0] * x * (1.0 + x / p[1]).powf(p[2] - 1.0),
    },
];

/// The form called `name`, or an error listing every form.
pub fn find(name: &str) -> Result<&'static Form, String> {
    FORMS.iter().find(|f| f.name == name).ok_or_else(|| {
        format!(
            "unknown form '{name}'; valid forms: {}, drift, value",
            FORMS.iter().map(|f| f.name).collect::<Vec<_>>().join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each form recovers the parameters of data drawn from its own model (the
    /// synthetic examples of the stability map, noise-free).
    #[test]
    fn every_form_fits_its_own_model() {
        for ex in crate::fit::stability::EXAMPLES {
            let (name, truth, f) = (ex.form, ex.truth, ex.form());
            assert_eq!(f.params.len(), truth.len(), "{name}");
            let x = ex.x(20);
            let y = ex.y(&x);
            let s: Vec<f64> = y.iter().map(|v| 1e-3 * v.abs().max(1e-6)).collect();
            let r =
                (f.fit)(Data::new(&x, &y, &s), ex.fixed).unwrap_or_else(|e| panic!("{name}: {e}"));
            for (k, (p, t)) in r.params.iter().zip(truth.iter()).enumerate() {
                assert!(
                    (p - t).abs() <= 1e-3 * t.abs().max(1.0),
                    "{name} parameter {} = {p}, truth {t}",
                    f.params[k]
                );
            }
            assert_eq!(
                r.names,
                f.params.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
                "{name}"
            );
        }
        // The Gaussian needs its lag t, in the fit and in the curve it draws.
        let g = find("gaussian").unwrap();
        let fixed: &[(&str, f64)] = &[("t", 2.5)];
        let x: Vec<f64> = (0..41).map(|i| -4.0 + 0.2 * i as f64).collect();
        let y: Vec<f64> = x.iter().map(|&v| (g.model)(&[0.3], fixed, v)).collect();
        let s: Vec<f64> = y.iter().map(|v| 1e-3 * v.max(1e-6)).collect();
        let r = (g.fit)(Data::new(&x, &y, &s), fixed).unwrap();
        assert!((r.params[0] - 0.3).abs() < 1e-4, "D = {}", r.params[0]);
        // Normalised: the curve integrates to one over dx.
        let area: f64 = (0..4001)
            .map(|i| 0.01 * (g.model)(&[0.3], fixed, -20.0 + 0.01 * i as f64))
            .sum();
        assert!((area - 1.0).abs() < 1e-6, "area {area}");
        let e = (g.fit)(Data::new(&[1.0], &[1.0], &[1.0]), &[]).unwrap_err();
        assert!(e.to_string().contains("lag t"), "{e}");
        assert!(find("gausian").err().unwrap().contains("log_normal"));
    }

    /// The divergent forms are defined below their divergence only: a curve
    /// drawn past it ends there instead of falling to a vertical line.
    #[test]
    fn divergent_forms_end_at_their_divergence() {
        let vft = find("vft").unwrap();
        let (a, phi_0, b) = (0.76, 0.83, 0.148);
        let below = (vft.model)(&[a, phi_0, b], &[], 0.80);
        assert!((below - a * (b / 0.03f64).exp()).abs() < 1e-9 * below);
        assert!((vft.model)(&[a, phi_0, b], &[], 0.84).is_nan());
        let pl = find("power_law_offset").unwrap();
        assert!((pl.model)(&[1.0, 0.82, 2.0], &[], 0.83).is_nan());
    }
}
