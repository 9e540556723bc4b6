//! Plain power law y = A x^exponent, fitted as a straight line on log-log data
//! (Fig. 15 tau4 ~ tau_alpha^x, Fig. 18 chi4 ~ xi^d_f).

use super::{Data, FitError, FitResult, log_y};
use crate::fit::linear::line;
use crate::fit::result::require_positive;

/// y = A x^exponent via ln y = ln A + exponent ln x, with sigma_ln y = sigma / y.
/// Parameters: `A`, `exponent`. Needs x > 0 and y > 0; errors of A by the delta
/// method (sigma_A = A sigma_ln A).
pub fn power_law(data: Data<'_>) -> Result<FitResult, FitError> {
    const FORM: &str = "power_law";
    data.validate(FORM, 2)?;
    require_positive(FORM, "x", data.x)?;
    let (ly, ls) = log_y(FORM, data)?;
    let lx: Vec<f64> = data.x.iter().map(|x| x.ln()).collect();
    let mut f = line(Data::new(&lx, &ly, &ls)).map_err(|e| match e {
        FitError::IllConditioned { .. } => {
            FitError::invalid(FORM, "all x are equal; a power law needs a range of x")
        }
        e => e,
    })?;
    let a = f.params[0].exp();
    // Jacobian of (A, exponent) w.r.t. (ln A, exponent) is diag(A, 1).
    let jac = [a, 1.0];
    for i in 0..2 {
        for j in 0..2 {
            f.covariance[i][j] *= jac[i] * jac[j];
        }
    }
    f.params[0] = a;
    f.stderr = vec![f.covariance[0][0].sqrt(), f.covariance[1][1].sqrt()];
    f.names = vec!["A".into(), "exponent".into()];
    f.form = FORM.into();
    Ok(f)
}

/// The linear-to-power-law crossover of paper I's v(F): y = mu x (1 + x/x_c)^(beta - 1),
/// linear (slope mu) for x << x_c and mu x_c^(1 - beta) x^beta for x >> x_c.
/// Parameters: `mu`, `x_c` (the crossover, where the two asymptotes meet), `beta`.
///
/// Start values: mu from the smallest x, beta from the straight log-log line
/// through the upper half of the points, x_c where the two asymptotes cross.
/// Needs x > 0, y > 0 and points on both sides of the crossover to be reliable:
/// a crossover outside the range of x is reported as `unreliable`.
pub fn crossover(data: Data<'_>, fixed: super::Fixed<'_>) -> Result<FitResult, FitError> {
    const FORM: &str = "crossover";
    data.validate(FORM, 3usize.saturating_sub(fixed.len()))?;
    require_positive(FORM, "x", data.x)?;
    require_positive(FORM, "y", data.y)?;
    let mut order: Vec<usize> = (0..data.x.len()).collect();
    order.sort_by(|&a, &b| data.x[a].total_cmp(&data.x[b]));
    let (lo, hi) = (order[0], order[order.len() - 1]);
    let mu = data.y[lo] / data.x[lo];
    let upper = &order[order.len() / 2..];
    let lx: Vec<f64> = upper.iter().map(|&i| data.x[i].ln()).collect();
    let ly: Vec<f64> = upper.iter().map(|&i| data.y[i].ln()).collect();
    let ones = vec![1.0; upper.len()];
    let (beta, ln_a) = match line(Data::new(&lx, &ly, &ones)) {
        Ok(f) if f.value("slope") < 0.95 => (f.value("slope"), f.value("intercept")),
        _ => (0.5, (data.y[hi] / data.x[hi].sqrt()).ln()),
    };
    // mu x_c = A x_c^beta  =>  x_c = (A / mu)^(1 / (1 - beta)).
    let x_c = ((ln_a - mu.ln()) / (1.0 - beta)).exp();
    let x_c = x_c.clamp(data.x[lo], data.x[hi]);
    let model = |x: f64, p: &[f64]| p[0] * x * (1.0 + x / p[1]).powf(p[2] - 1.0);
    // x_c within the data: a crossover outside them is not determined (with
    // beta ~ 1 the model is a line for any x_c), and the fit says so by ending
    // on the bound.
    let bounds = vec![(0.0, f64::INFINITY), (data.x[lo], data.x[hi]), (-1.0, 3.0)];
    let f = super::fit_form(
        FORM,
        &["mu", "x_c", "beta"],
        &model,
        data,
        vec![mu, x_c, beta],
        bounds,
        fixed,
    )?;
    let xc = f.value("x_c");
    if !(xc > data.x[lo] && xc < data.x[hi]) {
        return Err(FitError::unreliable(
            FORM,
            format!(
                "the crossover x_c = {xc:.3e} lies outside the data ({:.3e} to {:.3e}): \
                 extend the range of x to both sides of it",
                data.x[lo], data.x[hi]
            ),
        ));
    }
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossover_recovers_the_asymptotes_and_refuses_a_line() {
        // v = 0.25 F (1 + F/30)^(0.55 - 1) over four decades, 2% errors: mu, F_c
        // and beta come back within their errors' reach.
        let x: Vec<f64> = (0..17).map(|i| 0.1 * 2f64.powi(i)).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|&f| 0.25 * f * (1.0 + f / 30.0).powf(-0.45))
            .collect();
        let s: Vec<f64> = y.iter().map(|v| 0.02 * v).collect();
        let f = crossover(Data::new(&x, &y, &s), &[]).unwrap();
        assert!((f.value("mu") - 0.25).abs() < 1e-6, "{f:?}");
        assert!((f.value("x_c") - 30.0).abs() < 1e-4, "{f:?}");
        assert!((f.value("beta") - 0.55).abs() < 1e-6, "{f:?}");
        // Linear response everywhere: no crossover in the data, no number.
        let line: Vec<f64> = x.iter().map(|&f| 0.25 * f).collect();
        let e = crossover(Data::new(&x, &line, &s), &[]).unwrap_err();
        assert!(!e.to_string().is_empty());
        // The crossover beyond the largest x: the fit must not invent one.
        let late: Vec<f64> = x
            .iter()
            .map(|&f| 0.25 * f * (1.0 + f / 1e6).powf(-0.45))
            .collect();
        assert!(crossover(Data::new(&x, &late, &s), &[]).is_err());
    }
}
