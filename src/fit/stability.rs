//! Where the fits fail: every named form of [`catalogue`] fitted to synthetic
//! data with known truth, many noise realisations each, to measure
//! - the coverage of its quoted 1-sigma errors (the fraction of realisations
//!   whose interval holds the truth: 68% when honest) and the ratio of the
//!   quoted error to the true spread, against the noise level, the number of
//!   points and the correlation between neighbouring points (the points of
//!   Q(t) or chi4(t) at nearby lags come from the same frames: correlated);
//! - the bias of phi_c in tau = A (phi_c - phi)^-gamma when the data stop at a
//!   distance d below phi_c (Figs. 4, 23 of paper H), and how often the fit
//!   calls itself unreliable there ([`super::forms::on_last_point`]).
//!
//! Noise is relative: y_i = model(x_i) (1 + level e_i), with e an AR(1) series
//! of unit variance and lag-one correlation `rho`; the fit is told the
//! independent errors level |model(x_i)|, as the analyses quote per point.
//! Its quoted error is either the fit's covariance from those errors
//! ([`Errors::Covariance`]) or, as the pipelines quote a fit to points that
//! share replicas, the delete-one jackknife over replicas of the whole fit
//! ([`Errors::ReplicaJackknife`]): each point is then the mean of R replicas,
//! each replica one AR(1) series over all points (a replica's noise is shared
//! by its points, as one run's is by its lags).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use serde::Deserialize;

use super::catalogue::{FORMS, Form};
use super::forms::UNRELIABLE;
use super::{Data, FitResult};
use crate::analysis::stats::jackknife_err;

/// A form's synthetic case: true parameters (in `params` order), the x range
/// sampled (log-spaced when the form is drawn on log x) and the values held
/// fixed (the Gaussian's lag t).
pub struct Example {
    pub form: &'static str,
    pub truth: &'static [f64],
    pub x_range: (f64, f64),
    pub fixed: &'static [(&'static str, f64)],
}

/// One example per form of the catalogue, with parameters like the papers'.
pub const EXAMPLES: &[Example] = &[
    Example {
        form: "power_law_offset",
        truth: &[0.05, 0.82, 1.5],
        x_range: (0.60, 0.78),
        fixed: &[],
    },
    Example {
        form: "vft",
        truth: &[0.7, 0.85, 0.15],
        x_range: (0.60, 0.78),
        fixed: &[],
    },
    Example {
        form: "power_law",
        truth: &[3.0, -1.5],
        x_range: (1.0, 100.0),
        fixed: &[],
    },
    Example {
        form: "line",
        truth: &[1.0, 2.0],
        x_range: (0.0, 10.0),
        fixed: &[],
    },
    Example {
        form: "proportional",
        truth: &[2.5],
        x_range: (1.0, 10.0),
        fixed: &[],
    },
    Example {
        form: "q_relaxation",
        truth: &[5.0, 0.8],
        x_range: (0.05, 200.0),
        fixed: &[],
    },
    Example {
        form: "oz",
        truth: &[20.0, 4.0],
        x_range: (0.05, 1.5),
        fixed: &[],
    },
    Example {
        form: "oz_quartic",
        truth: &[20.0, 4.0, 0.5],
        x_range: (0.05, 1.5),
        fixed: &[],
    },
    Example {
        form: "gaussian",
        truth: &[0.3],
        x_range: (-4.0, 4.0),
        fixed: &[("t", 2.5)],
    },
    Example {
        form: "exponential_tail",
        truth: &[0.3, 0.7],
        x_range: (1.0, 5.0),
        fixed: &[],
    },
    Example {
        form: "log_normal",
        truth: &[0.2, 5.0, 1.2],
        x_range: (1.0, 1000.0),
        fixed: &[],
    },
    Example {
        form: "crossover",
        truth: &[0.25, 30.0, 0.55],
        x_range: (0.5, 2.6e5),
        fixed: &[],
    },
    // A trend against N that would reach 0 just beyond the largest box, as
    // the cut-off scans' large-a slopes do.
    Example {
        form: "log_trend",
        truth: &[0.5, 20000.0],
        x_range: (1000.0, 16000.0),
        fixed: &[],
    },
];

impl Example {
    /// The catalogue entry of this example's form.
    pub fn form(&self) -> &'static Form {
        super::catalogue::find(self.form).expect("every example names a catalogue form")
    }

    /// `points` abscissae over the range (log-spaced on log-x forms).
    pub fn x(&self, points: usize) -> Vec<f64> {
        let (lo, hi) = self.x_range;
        let log = self.form().log_x && lo > 0.0;
        (0..points)
            .map(|i| {
                let u = i as f64 / (points.max(2) - 1) as f64;
                if log {
                    lo * (hi / lo).powf(u)
                } else {
                    lo + u * (hi - lo)
                }
            })
            .collect()
    }

    /// The model at `x`, true parameters.
    pub fn y(&self, x: &[f64]) -> Vec<f64> {
        let f = self.form();
        x.iter()
            .map(|&v| (f.model)(self.truth, self.fixed, v))
            .collect()
    }
}

/// Relative noise of unit variance with lag-one correlation `rho` (AR(1)).
pub fn correlated_noise(rng: &mut ChaCha8Rng, n: usize, rho: f64) -> Vec<f64> {
    let mut e: f64 = StandardNormal.sample(rng);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        if i > 0 {
            let z: f64 = StandardNormal.sample(rng);
            e = rho * e + (1.0 - rho * rho).sqrt() * z;
        }
        out.push(e);
    }
    out
}

/// How a fit's quoted error is estimated.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Errors {
    /// The fit's covariance from the per-point errors, as if independent.
    #[default]
    Covariance,
    /// The delete-one jackknife over `replicas` replicas of the whole fit.
    ReplicaJackknife { replicas: usize },
}

/// One noise setting of a coverage measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setting {
    /// Relative 1-sigma noise of each point (of the replica mean).
    pub level: f64,
    pub points: usize,
    /// Lag-one correlation of the noise of neighbouring points.
    pub rho: f64,
    pub errors: Errors,
}

/// One realisation's data: the points (replica means) and, with the replica
/// jackknife, the means with each replica left out.
fn realise(rng: &mut ChaCha8Rng, truth_y: &[f64], setting: Setting) -> (Vec<f64>, Vec<Vec<f64>>) {
    let noisy = |e: &[f64], scale: f64| -> Vec<f64> {
        truth_y
            .iter()
            .zip(e)
            .map(|(y, e)| y * (1.0 + scale * e))
            .collect()
    };
    match setting.errors {
        Errors::Covariance => {
            let e = correlated_noise(rng, truth_y.len(), setting.rho);
            (noisy(&e, setting.level), Vec::new())
        }
        Errors::ReplicaJackknife { replicas } => {
            let r = replicas as f64;
            // Each replica's noise sqrt(R) larger, so their mean has `level`.
            let reps: Vec<Vec<f64>> = (0..replicas)
                .map(|_| correlated_noise(rng, truth_y.len(), setting.rho))
                .collect();
            let mean_of = |skip: Option<usize>| -> Vec<f64> {
                let k = r - f64::from(u8::from(skip.is_some()));
                let e: Vec<f64> = (0..truth_y.len())
                    .map(|i| {
                        reps.iter()
                            .enumerate()
                            .filter(|(j, _)| Some(*j) != skip)
                            .map(|(_, e)| e[i])
                            .sum::<f64>()
                            / k
                    })
                    .collect();
                noisy(&e, setting.level * r.sqrt())
            };
            let left_out = (0..replicas).map(|j| mean_of(Some(j))).collect();
            (mean_of(None), left_out)
        }
    }
}

/// Coverage of one parameter of one form at one setting.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamCoverage {
    pub form: &'static str,
    pub parameter: &'static str,
    pub setting: Setting,
    /// Realisations whose fit succeeded.
    pub fits: usize,
    /// Fraction of realisations whose fit failed (an error, not a number).
    pub failed: f64,
    /// Fraction of the successful fits with |value - truth| <= quoted error.
    pub coverage: f64,
    /// Root mean square quoted error over the spread of the values about the truth.
    pub ratio: f64,
    /// Mean of value - truth, in units of that spread.
    pub bias: f64,
}

/// Fits `realisations` noisy copies of `ex` at `setting` (seeded: the same
/// numbers on any machine) and measures each parameter's coverage.
pub fn coverage(
    ex: &Example,
    setting: Setting,
    realisations: usize,
    seed: u64,
) -> Vec<ParamCoverage> {
    let f = ex.form();
    let x = ex.x(setting.points);
    let truth_y = ex.y(&x);
    let sigma: Vec<f64> = truth_y
        .iter()
        .map(|y| setting.level * y.abs().max(1e-300))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut fits: Vec<FitResult> = Vec::new();
    for _ in 0..realisations {
        let (y, left_out) = realise(&mut rng, &truth_y, setting);
        let Ok(mut r) = (f.fit)(Data::new(&x, &y, &sigma), ex.fixed) else {
            continue;
        };
        if !left_out.is_empty() {
            // The fit to R - 1 replicas has errors sqrt(R / (R - 1)) larger.
            let k = left_out.len() as f64;
            let s: Vec<f64> = sigma.iter().map(|s| s * (k / (k - 1.0)).sqrt()).collect();
            let refits: Vec<FitResult> = left_out
                .iter()
                .filter_map(|y| (f.fit)(Data::new(&x, y, &s), ex.fixed).ok())
                .collect();
            if refits.len() < left_out.len() {
                continue;
            }
            for (p, err) in r.stderr.iter_mut().enumerate() {
                *err = jackknife_err(refits.iter().map(|q| q.params[p]).collect());
            }
        }
        fits.push(r);
    }
    let n = fits.len() as f64;
    f.params
        .iter()
        .enumerate()
        .map(|(k, &parameter)| {
            let truth = ex.truth[k];
            let dev: Vec<f64> = fits.iter().map(|r| r.params[k] - truth).collect();
            let spread = (dev.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
            let quoted = (fits.iter().map(|r| r.stderr[k].powi(2)).sum::<f64>() / n).sqrt();
            let covered = fits
                .iter()
                .filter(|r| (r.params[k] - truth).abs() <= r.stderr[k])
                .count();
            ParamCoverage {
                form: f.name,
                parameter,
                setting,
                fits: fits.len(),
                failed: 1.0 - n / realisations as f64,
                coverage: covered as f64 / n,
                ratio: quoted / spread,
                bias: dev.iter().sum::<f64>() / n / spread,
            }
        })
        .collect()
}

/// phi_c of a power-law divergence fitted to data that stop at distance `d`
/// below it.
#[derive(Clone, Debug, PartialEq)]
pub struct DivergenceBias {
    /// Distance of the last data point below the true phi_c.
    pub d: f64,
    /// d over the step of the data.
    pub d_steps: f64,
    pub fits: usize,
    /// Mean fitted phi_c - true phi_c.
    pub bias: f64,
    /// Standard deviation of the fitted phi_c.
    pub spread: f64,
    /// Root mean square of the quoted errors of phi_c.
    pub quoted: f64,
    /// Fraction of fits whose quoted interval holds the true phi_c.
    pub coverage: f64,
    /// Fraction of realisations the fit reports `unreliable` (or fails).
    pub unreliable: f64,
}

/// The divergence tau = A (phi_c - phi)^-gamma (phi_c = 0.82, gamma = 1.5, as
/// in Fig. 4) sampled at `points` packing fractions `step` apart, the last at
/// phi_c - d, with relative noise `level`, for each `d`.
pub fn divergence_bias(
    ds: &[f64],
    step: f64,
    points: usize,
    level: f64,
    realisations: usize,
    seed: u64,
) -> Vec<DivergenceBias> {
    let (a, phi_c, gamma) = (0.05, 0.82, 1.5);
    let f = super::catalogue::find("power_law_offset").expect("in the catalogue");
    ds.iter()
        .enumerate()
        .map(|(j, &d)| {
            let last = phi_c - d;
            let x: Vec<f64> = (0..points)
                .map(|i| last - step * (points - 1 - i) as f64)
                .collect();
            let truth: Vec<f64> = x.iter().map(|p| a * (phi_c - p).powf(-gamma)).collect();
            let sigma: Vec<f64> = truth.iter().map(|t| level * t).collect();
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(j as u64));
            let (mut values, mut errors, mut flagged) = (Vec::new(), Vec::new(), 0usize);
            for _ in 0..realisations {
                let e = correlated_noise(&mut rng, points, 0.0);
                let y: Vec<f64> = truth
                    .iter()
                    .zip(&e)
                    .map(|(t, e)| t * (1.0 + level * e))
                    .collect();
                match (f.fit)(Data::new(&x, &y, &sigma), &[]) {
                    Ok(r) => {
                        if r.warnings.iter().any(|w| w.starts_with(UNRELIABLE)) {
                            flagged += 1;
                        }
                        values.push(r.value("phi_c"));
                        errors.push(r.error("phi_c"));
                    }
                    Err(_) => flagged += 1,
                }
            }
            let n = values.len() as f64;
            let mean = values.iter().sum::<f64>() / n;
            let spread = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
            let quoted = (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
            let covered = values
                .iter()
                .zip(&errors)
                .filter(|(v, e)| (*v - phi_c).abs() <= **e)
                .count();
            DivergenceBias {
                d,
                d_steps: d / step,
                fits: values.len(),
                bias: mean - phi_c,
                spread,
                quoted,
                coverage: covered as f64 / n,
                unreliable: flagged as f64 / realisations as f64,
            }
        })
        .collect()
}

/// Index of a form in the catalogue (a numeric key for tables and plots).
pub fn form_index(name: &str) -> usize {
    FORMS
        .iter()
        .position(|f| f.name == name)
        .expect("a catalogue form")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every form of the catalogue has its synthetic example.
    #[test]
    fn every_form_has_an_example() {
        for f in FORMS {
            let ex = EXAMPLES.iter().find(|e| e.form == f.name);
            let ex = ex.unwrap_or_else(|| panic!("no example for {}", f.name));
            assert_eq!(ex.truth.len(), f.params.len(), "{}", f.name);
        }
    }

    /// The AR(1) noise has unit variance and the lag-one correlation asked for.
    #[test]
    fn correlated_noise_has_its_correlation() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let e = correlated_noise(&mut rng, 200_000, 0.8);
        let n = e.len() as f64;
        let var = e.iter().map(|v| v * v).sum::<f64>() / n;
        let c1 = e.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (n - 1.0);
        assert!((var - 1.0).abs() < 0.03, "variance {var}");
        assert!((c1 / var - 0.8).abs() < 0.01, "correlation {}", c1 / var);
    }

    /// Independent noise: the line's errors are exact (coverage 68%, ratio 1);
    /// strongly correlated noise makes them too small.
    #[test]
    fn line_covers_with_white_noise_and_not_with_correlated_noise() {
        let ex = EXAMPLES.iter().find(|e| e.form == "line").unwrap();
        let white = Setting {
            level: 0.05,
            points: 12,
            rho: 0.0,
            errors: Errors::Covariance,
        };
        for c in coverage(ex, white, 2000, 3) {
            assert!((c.coverage - 0.683).abs() < 0.04, "{c:?}");
            assert!((c.ratio - 1.0).abs() < 0.08, "{c:?}");
        }
        let red = Setting { rho: 0.9, ..white };
        let slope = &coverage(ex, red, 2000, 3)[1];
        assert!(slope.ratio < 0.7 && slope.coverage < 0.55, "{slope:?}");
    }

    /// With the same correlated noise, the replica jackknife of the whole fit
    /// (as the pipelines quote a fit to points sharing replicas) covers: its
    /// error follows the spread of the fit, correlations included. With R = 8
    /// replicas the jackknife error has 7 degrees of freedom, so the 1-sigma
    /// interval covers P(|t_7| < 1) = 0.65 rather than 0.683, and the rms
    /// ratio quoted / spread is 1 (within the 2000 realisations' noise).
    #[test]
    fn the_replica_jackknife_covers_with_correlated_noise() {
        let ex = EXAMPLES.iter().find(|e| e.form == "line").unwrap();
        let red = Setting {
            level: 0.05,
            points: 12,
            rho: 0.9,
            errors: Errors::ReplicaJackknife { replicas: 8 },
        };
        for c in coverage(ex, red, 2000, 3) {
            assert!((c.coverage - 0.65).abs() < 0.04, "{c:?}");
            assert!((c.ratio - 1.0).abs() < 0.1, "{c:?}");
        }
        let pl = EXAMPLES.iter().find(|e| e.form == "power_law").unwrap();
        for c in coverage(pl, red, 2000, 4) {
            assert!((0.6..0.72).contains(&c.coverage), "{c:?}");
        }
    }

    /// Data drawn from a true power law locate phi_c without bias (within half
    /// its spread) both when they stop a fifth of a step below it and four steps
    /// below; the first is the one the fit calls unreliable (it cannot tell a
    /// divergence from a last point that happens to be large).
    #[test]
    fn a_true_divergence_is_found_without_bias_and_flagged_on_the_last_point() {
        let b = divergence_bias(&[0.002, 0.04], 0.01, 8, 0.03, 200, 5);
        let (near, far) = (&b[0], &b[1]);
        assert!(
            far.unreliable < 0.1 && far.bias.abs() < 0.5 * far.spread,
            "{far:?}"
        );
        assert!(
            near.unreliable > 0.9 && near.bias.abs() < 0.5 * near.spread,
            "{near:?}"
        );
        assert!(near.spread < 0.1 * far.spread, "{near:?} {far:?}");
    }
}
