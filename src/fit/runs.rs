//! The Wald-Wolfowitz runs test on the signs of a fit's residuals: too few
//! runs (long stretches of points on one side of the curve) say that the form
//! misses the shape of the data, however small its residuals or its chi^2.

/// The runs of a sequence of residual signs and how unlikely so few are.
#[derive(Clone, Debug, PartialEq)]
pub struct Runs {
    /// Number of runs of one sign.
    pub runs: usize,
    /// Points above and below the curve.
    pub above: usize,
    pub below: usize,
    /// Probability of at most `runs` runs were the signs in random order
    /// (exact); with every sign alike, of n alike fair coin signs, 2^(1-n).
    pub p: f64,
    /// Index range (first, last) of the longest run.
    pub longest: (usize, usize),
}

/// The runs of `above` (true: the point lies above the curve), in order of x;
/// `None` for no points.
pub fn runs(above: &[bool]) -> Option<Runs> {
    let n = above.len();
    if n == 0 {
        return None;
    }
    let (mut count, mut start, mut longest) = (1, 0, (0, 0));
    for i in 1..=n {
        if i == n || above[i] != above[i - 1] {
            if i - 1 - start > longest.1 - longest.0 {
                longest = (start, i - 1);
            }
            if i < n {
                count += 1;
                start = i;
            }
        }
    }
    let up = above.iter().filter(|&&a| a).count();
    let down = n - up;
    let p = if up == 0 || down == 0 {
        2f64.powi(1 - n as i32).min(1.0)
    } else {
        p_at_most(up, down, count)
    };
    Some(Runs {
        runs: count,
        above: up,
        below: down,
        p,
        longest,
    })
}

/// P(R <= r) for R the number of runs of `a` signs of one kind and `b` of the
/// other in random order (Swed and Eisenhart, Ann. Math. Statist. 14, 66
/// (1943)): R = 2k in 2 C(a-1, k-1) C(b-1, k-1) of the C(a+b, a) orders,
/// R = 2k+1 in C(a-1, k) C(b-1, k-1) + C(a-1, k-1) C(b-1, k).
pub fn p_at_most(a: usize, b: usize, r: usize) -> f64 {
    let total = ln_choose(a + b, a);
    let term = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => (x + y - total).exp(),
        _ => 0.0,
    };
    let c = |n: usize, k: usize| (k <= n).then(|| ln_choose(n, k));
    let mut p = 0.0;
    for runs in 2..=r {
        let k = runs / 2;
        p += if runs % 2 == 0 {
            2.0 * term(c(a - 1, k - 1), c(b - 1, k - 1))
        } else {
            term(c(a - 1, k), c(b - 1, k - 1)) + term(c(a - 1, k - 1), c(b - 1, k))
        };
    }
    p.min(1.0)
}

/// ln C(n, k) as a sum of logarithms (exact enough for n in the thousands).
fn ln_choose(n: usize, k: usize) -> f64 {
    let k = k.min(n - k);
    (1..=k)
        .map(|i| ((n - k + i) as f64).ln() - (i as f64).ln())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::{p_at_most, runs};

    /// The exact distribution against counting every order of 6 + 5 signs.
    #[test]
    fn the_exact_distribution_counts_every_order() {
        let (a, b) = (6usize, 5usize);
        let n = a + b;
        let mut counts = vec![0usize; n + 2];
        let mut total = 0usize;
        for mask in 0u32..(1 << n) {
            if mask.count_ones() as usize != a {
                continue;
            }
            let signs: Vec<bool> = (0..n).map(|i| mask >> i & 1 == 1).collect();
            counts[runs(&signs).unwrap().runs] += 1;
            total += 1;
        }
        let mut cumulative = 0;
        for r in 2..=n {
            cumulative += counts[r];
            let p = p_at_most(a, b, r);
            assert!(
                (p - cumulative as f64 / total as f64).abs() < 1e-12,
                "r = {r}: {p} against {cumulative}/{total}"
            );
        }
    }

    #[test]
    fn runs_and_the_longest_are_counted() {
        let s = [true, true, false, false, false, true];
        let r = runs(&s).unwrap();
        assert_eq!((r.runs, r.above, r.below, r.longest), (3, 3, 3, (2, 4)));
        let alike = runs(&[true; 8]).unwrap();
        assert_eq!((alike.runs, alike.p), (1, 2f64.powi(-7)));
        assert!(runs(&[]).is_none());
    }
}
