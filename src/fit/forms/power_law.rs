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
