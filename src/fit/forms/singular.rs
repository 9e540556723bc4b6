//! Divergences at a packing fraction above the data (Fig. 4, 15, 23):
//! power law tau = A (phi_c - phi)^-gamma and VFT tau = A exp[B/(phi_0 - phi)].
//!
//! Both are hard fits: the singular point sits just beyond the last data point.
//! Starting values come from a scan of the singular point on a log grid above
//! max(phi), solving the (linear) log-space fit of the rest at each grid value;
//! Levenberg-Marquardt then refines all three with the singular point bounded
//! above max(phi). If it runs onto that bound the fit fails with `AtBound`.

use super::{Data, FitError, FitResult, Fixed, fit_form, fixed_value, log_y};
use crate::fit::linear::line;
/// How a warning that makes the fitted numbers untrustworthy starts.
pub use crate::fit::result::UNRELIABLE;
use crate::fit::result::positive;

/// One divergent form, ln y = ln A + k u(phi, c), parameters [A, c, k].
struct Singular {
    form: &'static str,
    names: [&'static str; 3],
    /// Regressor u(phi, c) that makes ln y linear in (ln A, k).
    regressor: fn(f64, f64) -> f64,
}

impl Singular {
    fn model(&self, phi: f64, p: &[f64]) -> f64 {
        p[0] * ((p[2] * (self.regressor)(phi, p[1])).exp())
    }
}

const POWER_LAW: Singular = Singular {
    form: "power_law_offset",
    names: ["A", "phi_c", "gamma"],
    regressor: |phi, c| -(c - phi).ln(),
};

const VFT: Singular = Singular {
    form: "vft",
    names: ["A", "phi_0", "B"],
    regressor: |phi, c| 1.0 / (c - phi),
};

/// tau = A (phi_c - phi)^(-gamma). Parameters: `A`, `phi_c`, `gamma`.
///
/// `data.x` is phi, `data.y` is tau (> 0) with errors `data.sigma`.
/// `fixed` may hold any of them, e.g. `&[("phi_c", 0.82)]`.
pub fn power_law_offset(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    fit_singular(&POWER_LAW, data, fixed)
}

/// tau = A exp[B / (phi_0 - phi)] (Vogel-Fulcher-Tammann form in phi).
/// Parameters: `A`, `phi_0`, `B`.
pub fn vft(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    fit_singular(&VFT, data, fixed)
}

/// Why a singular point `c` fitted above the data `x` is not resolved by them, if
/// it is not: it lies closer to the last data point than the last step of the
/// data, where VFT-shaped data put a free power law's divergence too (on exact
/// power-law data the fit is unbiased there: src/fit/stability.rs), so the
/// place alone does not say which the data are (Fig. 4 at the ci
/// profile: phi_c = 0.788 beyond phi = 0.78 with steps of 0.01; the paper's
/// 0.82 lies 0.015 beyond its last point, three of its steps).
pub fn on_last_point(x: &[f64], c: f64) -> Option<String> {
    let mut v: Vec<f64> = x.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    let [.., before, last] = v[..] else {
        return None;
    };
    let (gap, step) = (c - last, last - before);
    (gap < step).then(|| {
        format!(
            "the divergence lies {gap:.4} beyond the last data point {last}, less than the \
             last step of the data ({step:.4}): it falls on the last point, where a free \
             power law lands on VFT-shaped data too, so it does not by itself locate a \
             divergence (add points between {last} and the divergence)"
        )
    })
}

/// Which divergence data resemble whose free power law puts phi_c on the last
/// point. Fitted to exact VFT data ending at phi_max, a free power law puts
/// phi_c between phi_max and phi_0, so a phi_c on the last point does not by
/// itself say that the data cannot locate a divergence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// The VFT describes the data better and its phi_0 lies beyond the power
    /// law's phi_c: the power law's phi_c is what VFT-shaped data give.
    VftShaped,
    /// Neither form is preferred (or the VFT fails): the data cannot locate phi_c.
    Unlocated,
}

/// The classification and the measurement behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct DivergenceShape {
    pub shape: Shape,
    /// chi^2 of the free power law and of the free VFT on the same points (both
    /// have three parameters, so their difference is the AIC difference).
    pub chi2_power: f64,
    pub chi2_vft: f64,
    pub phi_c: f64,
    /// NaN when the VFT fit failed.
    pub phi_0: f64,
}

/// Smallest AIC difference read as support for one form over the other
/// (Burnham and Anderson's "substantially less support" below it).
pub const AIC_MARGIN: f64 = 2.0;

impl DivergenceShape {
    /// Classifies `data` given its free power-law fit `power`.
    pub fn of(data: Data<'_>, power: &FitResult) -> DivergenceShape {
        let phi_c = power.get("phi_c").map_or(f64::NAN, |p| p.0);
        let (chi2_vft, phi_0) = match vft(data, &[]) {
            Ok(v) => (v.chi2, v.value("phi_0")),
            Err(_) => (f64::NAN, f64::NAN),
        };
        let vft_shaped = power.chi2 - chi2_vft >= AIC_MARGIN && phi_0 > phi_c;
        DivergenceShape {
            shape: if vft_shaped {
                Shape::VftShaped
            } else {
                Shape::Unlocated
            },
            chi2_power: power.chi2,
            chi2_vft,
            phi_c,
            phi_0,
        }
    }
}

impl std::fmt::Display for DivergenceShape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match self.shape {
            Shape::VftShaped => {
                "VFT-shaped: phi_c of a free power law lands between the last point and phi_0"
            }
            Shape::Unlocated => "cannot locate phi_c",
        };
        write!(
            f,
            "{what} (chi^2 {:.3} for the power law against {:.3} for the VFT, phi_0 = {:.4})",
            self.chi2_power, self.chi2_vft, self.phi_0
        )
    }
}

fn fit_singular(s: &Singular, data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    data.validate(s.form, 3usize.saturating_sub(fixed.len()))?;
    let (ly, ls) = log_y(s.form, data)?;
    let max = data.x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = data.x.iter().copied().fold(f64::INFINITY, f64::min);
    let span = max - min;
    if !positive(span) {
        return Err(FitError::invalid(
            s.form,
            "all phi are equal; need a range of phi",
        ));
    }
    let candidates: Vec<f64> = match fixed_value(fixed, s.names[1]) {
        Some(c) if c <= max => {
            return Err(FitError::invalid(
                s.form,
                format!("fixed {} = {c} must exceed max(phi) = {max}", s.names[1]),
            ));
        }
        Some(c) => vec![c],
        None => (0..=160)
            .map(|i| max + span * 10f64.powf(-5.0 + 5.5 * i as f64 / 160.0))
            .collect(),
    };
    let mut best: Option<(f64, Vec<f64>)> = None;
    for c in candidates {
        let u: Vec<f64> = data.x.iter().map(|&phi| (s.regressor)(phi, c)).collect();
        let Ok(l) = line(Data::new(&u, &ly, &ls)) else {
            continue;
        };
        let p = vec![l.value("intercept").exp(), c, l.value("slope")];
        let chi2: f64 = (0..data.len())
            .map(|i| ((data.y[i] - s.model(data.x[i], &p)) / data.sigma[i]).powi(2))
            .sum();
        if chi2.is_finite() && best.as_ref().is_none_or(|(b, _)| chi2 < *b) {
            best = Some((chi2, p));
        }
    }
    let Some((_, p0)) = best else {
        return Err(FitError::unreliable(
            s.form,
            format!(
                "no {} above max(phi) = {max} gives a finite start",
                s.names[1]
            ),
        ));
    };
    let bounds = vec![
        (0.0, f64::INFINITY),
        (max + 1e-6 * span, f64::INFINITY),
        (f64::NEG_INFINITY, f64::INFINITY),
    ];
    let model = |phi: f64, p: &[f64]| s.model(phi, p);
    let mut fit = fit_form(s.form, &s.names, &model, data, p0, bounds, fixed).map_err(|e| match e {
        FitError::NotConverged { form, iterations, .. } => FitError::NotConverged {
            form,
            iterations,
            hint: format!(
                "{} runs away from the data: they may show no divergence above max(phi) = {max} \
                 (try the other divergent form, or fix {})",
                s.names[1], s.names[1]
            ),
        },
        e => e,
    })?;
    let (c, dc) = fit.get(s.names[1]).expect("singular point is a parameter");
    let held = fixed_value(fixed, s.names[1]).is_some();
    if let Some(why) = on_last_point(data.x, c) {
        // A free power law on the last point is also what VFT-shaped data give:
        // say which of the two the data resemble (a VFT fit never recurses here).
        // A held divergence was not fitted here: the comparison belongs to the
        // free fit it came from, so a held one only says where it lies.
        let shape = match s.form {
            "power_law_offset" if !held => format!("; {}", DivergenceShape::of(data, &fit)),
            _ => String::new(),
        };
        let held = if held { " (held)" } else { "" };
        fit.warnings.push(format!(
            "{UNRELIABLE}{} = {c:.4}{held}: {why}{shape}",
            s.names[1]
        ));
    } else if c - max < 3.0 * dc {
        fit.warnings.push(format!(
            "{} = {c} is within 3 sigma ({dc:.2e}) of max(phi) = {max}: the divergence is not \
             resolved by the data (add points further from it, or fix {})",
            s.names[1], s.names[1]
        ));
    }
    Ok(fit)
}

/// Power laws y_k = A_k (phi_c - phi)^(-gamma_k) fitted jointly to several
/// series that share one divergence phi_c (paper H: phi_c "from the
/// simultaneous fit of tau_alpha, chi4 and xi"). Parameters: `phi_c`, then
/// `A_k`, `gamma_k` for each series k from 0. The start scans phi_c as
/// [`power_law_offset`] does, with the log-space line of every series at each
/// value; Levenberg-Marquardt then refines all, phi_c bounded above every phi.
pub fn joint_power_law_offset(series: &[Data<'_>]) -> Result<FitResult, FitError> {
    const FORM: &str = "joint_power_law_offset";
    if series.len() < 2 {
        return Err(FitError::invalid(
            FORM,
            "a joint fit needs at least two series",
        ));
    }
    let mut logs = Vec::new();
    for d in series {
        d.validate(FORM, 2)?;
        logs.push(log_y(FORM, *d)?);
    }
    let all: Vec<f64> = series.iter().flat_map(|d| d.x.iter().copied()).collect();
    let max = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = all.iter().copied().fold(f64::INFINITY, f64::min);
    let span = max - min;
    if !positive(span) {
        return Err(FitError::invalid(
            FORM,
            "all phi are equal; need a range of phi",
        ));
    }
    let mut best: Option<(f64, Vec<f64>)> = None;
    for i in 0..=160 {
        let c = max + span * 10f64.powf(-5.0 + 5.5 * i as f64 / 160.0);
        let mut p = vec![c];
        let mut chi2 = 0.0;
        for (d, (ly, ls)) in series.iter().zip(&logs) {
            let u: Vec<f64> =
                d.x.iter()
                    .map(|&phi| (POWER_LAW.regressor)(phi, c))
                    .collect();
            let Ok(l) = line(Data::new(&u, ly, ls)) else {
                chi2 = f64::NAN;
                break;
            };
            let q = [l.value("intercept").exp(), c, l.value("slope")];
            chi2 += (0..d.len())
                .map(|j| ((d.y[j] - POWER_LAW.model(d.x[j], &q)) / d.sigma[j]).powi(2))
                .sum::<f64>();
            p.extend([q[0], q[2]]);
        }
        if chi2.is_finite() && best.as_ref().is_none_or(|(b, _)| chi2 < *b) {
            best = Some((chi2, p));
        }
    }
    let Some((_, p0)) = best else {
        return Err(FitError::unreliable(
            FORM,
            format!("no phi_c above max(phi) = {max} gives a finite start"),
        ));
    };
    // Every point of every series, stacked; the model reads its series and phi
    // from the point's index, which is the x handed to the least squares.
    let points: Vec<(usize, f64)> = series
        .iter()
        .enumerate()
        .flat_map(|(k, d)| d.x.iter().map(move |&phi| (k, phi)))
        .collect();
    let index: Vec<f64> = (0..points.len()).map(|i| i as f64).collect();
    let y: Vec<f64> = series.iter().flat_map(|d| d.y.iter().copied()).collect();
    let sigma: Vec<f64> = series
        .iter()
        .flat_map(|d| d.sigma.iter().copied())
        .collect();
    let model = |x: f64, p: &[f64]| {
        let (k, phi) = points[x as usize];
        POWER_LAW.model(phi, &[p[1 + 2 * k], p[0], p[2 + 2 * k]])
    };
    let owned: Vec<String> = std::iter::once("phi_c".to_string())
        .chain((0..series.len()).flat_map(|k| [format!("A_{k}"), format!("gamma_{k}")]))
        .collect();
    let names: Vec<&str> = owned.iter().map(String::as_str).collect();
    let mut bounds = vec![(max + 1e-6 * span, f64::INFINITY)];
    for _ in series {
        bounds.extend([(0.0, f64::INFINITY), (f64::NEG_INFINITY, f64::INFINITY)]);
    }
    let mut fit = fit_form(
        FORM,
        &names,
        &model,
        Data::new(&index, &y, &sigma),
        p0,
        bounds,
        &[],
    )?;
    let (c, dc) = fit.get("phi_c").expect("a parameter");
    if let Some(why) = on_last_point(&all, c) {
        fit.warnings
            .push(format!("{UNRELIABLE}phi_c = {c:.4}: {why}"));
    } else if c - max < 3.0 * dc {
        fit.warnings.push(format!(
            "phi_c = {c} is within 3 sigma ({dc:.2e}) of max(phi) = {max}: the divergence is not resolved by the data"
        ));
    }
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// tau = A (phi_c - phi)^-gamma sampled every 0.01 up to 0.78, with 2% errors.
    fn fit_at(phi_c: f64) -> FitResult {
        let phi: Vec<f64> = (0..9).map(|i| 0.70 + 0.01 * i as f64).collect();
        let tau: Vec<f64> = phi.iter().map(|p| 0.4 * (phi_c - p).powf(-1.5)).collect();
        let sig: Vec<f64> = tau.iter().map(|t| 0.02 * t).collect();
        power_law_offset(Data::new(&phi, &tau, &sig), &[]).unwrap()
    }

    /// Fig. 4 at ci/small: a divergence closer to the last point than the data's
    /// step is flagged unreliable (with why), one three steps beyond it is not.
    #[test]
    fn a_divergence_on_the_last_data_point_is_unreliable() {
        let near = fit_at(0.785);
        let w = near.warnings.join("; ");
        assert!(
            w.starts_with(UNRELIABLE) && w.contains("phi_c") && w.contains("last step"),
            "{w}"
        );
        let far = fit_at(0.81);
        assert!(
            far.warnings.iter().all(|w| !w.contains("unreliable")),
            "{:?}",
            far.warnings
        );
        assert!((far.value("phi_c") - 0.81).abs() < 1e-3);
        assert!(
            on_last_point(&[0.78], 0.785).is_none(),
            "one point has no step"
        );
    }

    /// Three series sharing phi_c = 0.82 with their own amplitudes and
    /// exponents (tau, chi4, xi of paper H: 1.5, 2.5, 1.6), 2% errors, points to
    /// 0.79: the joint fit finds phi_c and every exponent, and a series alone
    /// ending further from phi_c locates it no better.
    #[test]
    fn a_joint_fit_recovers_the_shared_divergence() {
        let phi: Vec<f64> = (0..10).map(|i| 0.70 + 0.01 * i as f64).collect();
        let law =
            |a: f64, g: f64| -> Vec<f64> { phi.iter().map(|p| a * (0.82 - p).powf(-g)).collect() };
        let ys = [law(0.4, 1.5), law(0.01, 2.5), law(0.3, 1.6)];
        let errs: Vec<Vec<f64>> = ys
            .iter()
            .map(|y| y.iter().map(|v| 0.02 * v).collect())
            .collect();
        let series: Vec<Data> = ys
            .iter()
            .zip(&errs)
            .map(|(y, e)| Data::new(&phi, y, e))
            .collect();
        let f = joint_power_law_offset(&series).unwrap();
        assert!(
            (f.value("phi_c") - 0.82).abs() < 1e-6,
            "{}",
            f.value("phi_c")
        );
        for (k, g) in [1.5, 2.5, 1.6].iter().enumerate() {
            assert!(
                (f.value(&format!("gamma_{k}")) - g).abs() < 1e-5,
                "series {k}"
            );
        }
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        assert!(joint_power_law_offset(&series[..1]).is_err());
    }

    /// Paper H's packing fractions (Fig. 3) from 0.60 up to `phi_max`.
    fn paper_grid(phi_max: f64) -> Vec<f64> {
        [
            0.60, 0.65, 0.70, 0.72, 0.74, 0.76, 0.77, 0.78, 0.785, 0.79, 0.795, 0.80, 0.805,
        ]
        .into_iter()
        .filter(|&p| p <= phi_max + 1e-12)
        .collect()
    }

    /// Exact tau(phi) on the paper's grid up to `phi_max`, with 2% errors.
    fn exact(law: impl Fn(f64) -> f64, phi_max: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let phi = paper_grid(phi_max);
        let tau: Vec<f64> = phi.iter().map(|&p| law(p)).collect();
        let sig = tau.iter().map(|t| 0.02 * t).collect();
        (phi, tau, sig)
    }

    /// The last step of the paper's grid near its end (0.805 - 0.80).
    const STEP: f64 = 0.005;
    /// Paper H's phi_0 (Fig. 4) as our VFT gives it at small, and a VFT tau of its size.
    const PHI_0: f64 = 0.8288;
    fn vft_tau(p: f64) -> f64 {
        0.82 * (0.133 / (PHI_0 - p)).exp()
    }

    /// Exact VFT data ending at phi_max: a free power law puts phi_c between
    /// phi_max and phi_0, on the last point (within one step of the data), at
    /// the landing points measured here (0.8078 over 0.60-0.805, 0.8040 over
    /// 0.60-0.80; to a tenth of the step); the flag says VFT-shaped, with the
    /// chi^2 of both forms.
    #[test]
    fn a_free_power_law_on_vft_data_lands_between_the_last_point_and_phi_0() {
        for (hi, landing) in [(0.805, 0.8078), (0.80, 0.8040)] {
            let (x, y, s) = exact(vft_tau, hi);
            let d = Data::new(&x, &y, &s);
            let f = power_law_offset(d, &[]).unwrap();
            let c = f.value("phi_c");
            assert!(hi < c && c < PHI_0, "phi_c {c} over 0.60-{hi}");
            assert!(c - hi < STEP, "on the last point: {c}");
            assert!(
                (c - landing).abs() < STEP / 10.0,
                "phi_c {c} over 0.60-{hi}"
            );
            let shape = DivergenceShape::of(d, &f);
            assert_eq!(shape.shape, Shape::VftShaped, "{shape}");
            // Exact VFT data: the VFT fits them to rounding, the power law does not.
            assert!(shape.chi2_vft < 1e-6 && shape.chi2_power > 100.0, "{shape}");
            assert!((shape.phi_0 - PHI_0).abs() < 1e-6, "{shape}");
            let w = f.warnings.join("; ");
            assert!(w.starts_with(UNRELIABLE) && w.contains("VFT-shaped"), "{w}");
        }
    }

    /// A phi_c held from another fit (fig17's gamma_xi takes fig4's) on the
    /// last point is flagged as held, without the free fit's comparison with
    /// the VFT: the held fit's chi^2 is not a free power law's.
    #[test]
    fn a_held_phi_c_on_the_last_point_says_held_and_compares_nothing() {
        let (x, y, s) = exact(vft_tau, 0.805);
        let d = Data::new(&x, &y, &s);
        let free = power_law_offset(d, &[]).unwrap();
        let c = free.value("phi_c");
        let held = power_law_offset(d, &[("phi_c", c)]).unwrap();
        let w = held.warnings.join("; ");
        assert!(
            w.starts_with(UNRELIABLE) && w.contains("(held)") && !w.contains("chi^2"),
            "{w}"
        );
        let w = free.warnings.join("; ");
        assert!(!w.contains("(held)") && w.contains("VFT-shaped: "), "{w}");
    }

    /// The converse: power-law data with phi_c = 0.82 (three steps beyond
    /// 0.805, so the power law locates it and raises no flag) give a VFT
    /// phi_0 far beyond 0.82 (0.8777 at gamma = 1.5 over 0.60-0.805, measured
    /// here), and more so the earlier the window ends: one tau(phi) cannot
    /// give a free phi_c of 0.82 and a free phi_0 of 0.83 at once.
    #[test]
    fn a_free_vft_on_power_law_data_puts_phi_0_far_beyond_phi_c() {
        let law = |p: f64| 0.4 * (0.82 - p).powf(-1.5);
        let phi_0 = |hi: f64| {
            let (x, y, s) = exact(law, hi);
            let d = Data::new(&x, &y, &s);
            let pl = power_law_offset(d, &[]).unwrap();
            assert!((pl.value("phi_c") - 0.82).abs() < 1e-6 && pl.warnings.is_empty());
            vft(d, &[]).unwrap().value("phi_0")
        };
        let (late, early) = (phi_0(0.805), phi_0(0.80));
        assert!((late - 0.8777).abs() < STEP / 10.0, "{late}");
        assert!(early > late, "{early} {late}");
    }

    /// A divergence truly on the last point (power-law data with phi_c one
    /// tenth of a step beyond 0.805): the power law fits exactly, the VFT does
    /// not (it fails, or its chi^2 exceeds the margin), and the flag says the
    /// data cannot locate phi_c.
    #[test]
    fn a_power_law_on_its_last_point_cannot_be_located() {
        let (x, y, s) = exact(|p| 0.4 * (0.8055 - p).powf(-1.5), 0.805);
        let d = Data::new(&x, &y, &s);
        let f = power_law_offset(d, &[]).unwrap();
        let shape = DivergenceShape::of(d, &f);
        assert_eq!(shape.shape, Shape::Unlocated, "{shape}");
        assert!(
            shape.chi2_power < 1e-3 && !(shape.chi2_vft <= AIC_MARGIN),
            "{shape}"
        );
        let w = f.warnings.join("; ");
        assert!(w.contains("cannot locate phi_c (chi^2"), "{w}");
    }
}
