//! Cost of the fits the figure pipelines run many times: the hard power-law
//! fit with its phi_c scan, the OZ fit, Q(t) per run, and a data collapse.
//! Run: `cargo bench --bench fit`.

use repro::fit::Data;
use repro::fit::collapse::{Curve, collapse};
use repro::fit::forms;

fn main() {
    divan::main();
}

fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
        .collect()
}

/// Deterministic +-3% wiggle so the data are not exactly on the model.
fn wiggle(i: usize) -> f64 {
    1.0 + 0.03 * ((i as f64 * 2.39996).sin())
}

#[divan::bench]
fn power_law_offset_20_points(b: divan::Bencher) {
    let phi = linspace(0.60, 0.79, 20);
    let tau: Vec<f64> = phi
        .iter()
        .enumerate()
        .map(|(i, p)| 0.5 * (0.82 - p).powf(-2.2) * wiggle(i))
        .collect();
    let sigma: Vec<f64> = tau.iter().map(|t| 0.05 * t).collect();
    b.bench(|| forms::power_law_offset(Data::new(&phi, &tau, &sigma), &[]).unwrap());
}

#[divan::bench]
fn oz_30_points(b: divan::Bencher) {
    let q = linspace(0.05, 1.5, 30);
    let s4: Vec<f64> = q
        .iter()
        .enumerate()
        .map(|(i, q)| 20.0 / (1.0 + (5.0 * q).powi(2)) * wiggle(i))
        .collect();
    let sigma: Vec<f64> = s4.iter().map(|s| 0.05 * s).collect();
    b.bench(|| forms::oz(Data::new(&q, &s4, &sigma), &[]).unwrap());
}

#[divan::bench]
fn q_relaxation_40_points(b: divan::Bencher) {
    let t: Vec<f64> = (0..40)
        .map(|i| 0.01 * 10f64.powf(5.0 * i as f64 / 39.0))
        .collect();
    let q: Vec<f64> = t
        .iter()
        .enumerate()
        .map(|(i, t)| 1.0 / ((t / 10.0).powf(0.8) + 1.0) * wiggle(i))
        .collect();
    let sigma = vec![0.01; t.len()];
    b.bench(|| forms::q_relaxation(Data::new(&t, &q, &sigma), &[]).unwrap());
}

#[divan::bench]
fn collapse_5_curves_15_points(b: divan::Bencher) {
    let curves: Vec<Curve> = [2.0f64, 4.0, 8.0, 16.0, 32.0]
        .iter()
        .map(|&xi| {
            let x: Vec<f64> = (0..15)
                .map(|i| xi * xi * 10f64.powf(-2.0 + 4.0 * i as f64 / 14.0))
                .collect();
            let y: Vec<f64> = x
                .iter()
                .enumerate()
                .map(|(i, n)| {
                    let s = n.sqrt() / xi;
                    xi.powf(1.125) * s * s / (1.0 + s * s) * wiggle(i)
                })
                .collect();
            let sigma = y.iter().map(|y| 0.03 * y).collect();
            Curve {
                label: format!("xi={xi}"),
                param: xi,
                x,
                y,
                sigma,
            }
        })
        .collect();
    let rescale = |p: &[f64], c: &Curve, n: f64, y: f64, s: f64| {
        let f = c.param.powf(-p[0]);
        (n.sqrt() / c.param, y * f, s * f)
    };
    b.bench(|| collapse(&curves, &["g"], &[(0.0, 3.0)], &rescale).unwrap());
}
