//! Relaxation of the overlap, Q(t) = 1 / ((t/tau0)^beta + 1) (paper H, Eq. 8).

use super::{Data, FitError, FitResult, Fixed, fit_form};
use crate::fit::linear::line;
use crate::fit::result::{positive, require_positive};

const FORM: &str = "q_relaxation";

/// Q(t) = 1 / ((t/tau0)^beta + 1). Parameters: `tau0`, `beta`.
///
/// Starting values from the straight line ln(1/Q - 1) = beta (ln t - ln tau0)
/// through the points with 0.05 < Q < 0.95; the decay must be visible there.
pub fn q_relaxation(data: Data<'_>, fixed: Fixed<'_>) -> Result<FitResult, FitError> {
    data.validate(FORM, 2usize.saturating_sub(fixed.len()))?;
    require_positive(FORM, "t", data.x)?;
    let (mut lt, mut lq) = (Vec::new(), Vec::new());
    for (&t, &q) in data.x.iter().zip(data.y) {
        if q > 0.05 && q < 0.95 {
            lt.push(t.ln());
            lq.push((1.0 / q - 1.0).ln());
        }
    }
    let ones = vec![1.0; lt.len()];
    let start = line(Data::new(&lt, &lq, &ones)).map_err(|_| {
        FitError::unreliable(
            FORM,
            format!(
                "only {} points with 0.05 < Q < 0.95: the decay of Q(t) is not resolved \
                 (run longer or sample more lag times around tau_alpha)",
                lt.len()
            ),
        )
    })?;
    let beta = start.value("slope");
    if !positive(beta) {
        return Err(FitError::unreliable(FORM, "Q(t) does not decrease with t"));
    }
    let tau0 = (-start.value("intercept") / beta).exp();
    let model = |t: f64, p: &[f64]| 1.0 / ((t / p[0]).powf(p[1]) + 1.0);
    let bounds = vec![(0.0, f64::INFINITY), (0.0, f64::INFINITY)];
    fit_form(
        FORM,
        &["tau0", "beta"],
        &model,
        data,
        vec![tau0, beta],
        bounds,
        fixed,
    )
}
