//! Dense linear algebra for the few (<= ~6) parameters of a fit.

/// Smallest accepted squared Cholesky pivot of the unit-diagonal (correlation)
/// matrix: below it, one parameter is a linear combination of the others to
/// better than 1 part in 1e6 and its error bar means nothing.
pub const MIN_PIVOT: f64 = 1e-12;

/// Inverse of a symmetric positive-definite matrix.
///
/// The matrix is first scaled to unit diagonal so the pivot test measures
/// correlations, not units. `Err(i)` names the row whose pivot vanished (the
/// parameter not determined by the others).
#[allow(clippy::needless_range_loop)] // index notation mirrors the maths
pub fn spd_inverse(a: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, usize> {
    let n = a.len();
    let mut d = vec![0.0; n];
    for i in 0..n {
        if !(a[i][i] > 0.0 && a[i][i].is_finite()) {
            return Err(i);
        }
        d[i] = a[i][i].sqrt();
    }
    // Cholesky of the correlation matrix c = D^-1 a D^-1.
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i][j] / (d[i] * d[j]);
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s.is_nan() || s <= MIN_PIVOT {
                    return Err(i);
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // Inverse of L, then c^-1 = L^-T L^-1.
    let mut linv = vec![vec![0.0; n]; n];
    for i in 0..n {
        linv[i][i] = 1.0 / l[i][i];
        for j in 0..i {
            let s: f64 = (j..i).map(|k| l[i][k] * linv[k][j]).sum();
            linv[i][j] = -s / l[i][i];
        }
    }
    let mut inv = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            let s: f64 = (i.max(j)..n).map(|k| linv[k][i] * linv[k][j]).sum();
            inv[i][j] = s / (d[i] * d[j]);
        }
    }
    Ok(inv)
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    #[test]
    fn inverse_times_matrix_is_identity() {
        let a = vec![
            // Very different scales (units) but well-conditioned correlations.
            vec![4.0, 1.0, 0.005],
            vec![1.0, 3.0, 0.002],
            vec![0.005, 0.002, 1e-4],
        ];
        let inv = spd_inverse(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
                assert!(
                    (p - if i == j { 1.0 } else { 0.0 }).abs() < 1e-10,
                    "{i}{j}: {p}"
                );
            }
        }
    }

    #[test]
    fn singular_matrix_names_the_dependent_row() {
        let a = vec![
            vec![1.0, 2.0, 0.0],
            vec![2.0, 4.0, 0.0],
            vec![0.0, 0.0, 1.0],
        ];
        assert_eq!(spd_inverse(&a), Err(1));
        assert_eq!(spd_inverse(&[vec![0.0]]), Err(0));
    }
}
