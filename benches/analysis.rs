//! Hot paths of the observables at 10^6 particles (one frame pair each):
//! Q and chi4 for one sub-box size, S4 on all shells, clusters with Rg.
//! Run: `cargo bench --bench analysis`. Figures in docs/analysis.md.

use repro::analysis::synthetic::independent_slow;
use repro::analysis::{chi4, clusters, s4, squared_displacements};
use repro::traj::Trajectory;

const N: usize = 1_000_000;

fn system() -> Trajectory {
    // Density 1, 30 % slow particles, one frame pair at lag 1.
    independent_slow(N, [1000.0, 1000.0], 1, 0.3, 1.0, 1)
}

fn main() {
    divan::main();
}

#[divan::bench(sample_count = 10)]
fn chi4_one_pair_1e6(b: divan::Bencher) {
    let traj = system();
    let p = chi4::Params {
        a: 0.6,
        n: vec![100.0],
        fractions: Vec::new(),
        lags: Some(vec![1.0]),
        rel_tol: 1e-6,
        variance: chi4::Variance::default(),
    };
    b.bench(|| chi4::compute(divan::black_box(&traj), &p).unwrap());
}

#[divan::bench(sample_count = 5, args = [1e-6, 1e-10])]
fn s4_one_pair_1e6_qmax2(b: divan::Bencher, tolerance: f64) {
    let traj = system();
    let p = s4::Params {
        a: 0.6,
        lags: vec![1.0],
        n: None,
        q_max: 2.0,
        dq: None,
        tolerance,
        rel_tol: 1e-6,
    };
    b.bench(|| s4::s4(divan::black_box(&traj), &p).unwrap());
}

#[divan::bench(sample_count = 5)]
fn clusters_slow_1e6(b: divan::Bencher) {
    let traj = system();
    let (f0, f1) = (&traj.frames[0], &traj.frames[1]);
    let slow: Vec<bool> = squared_displacements(f0, f1)
        .iter()
        .map(|&d| d < 0.36)
        .collect();
    let cut = vec![vec![1.2, 1.35], vec![1.35, 1.5]];
    b.bench(|| clusters::find_clusters(&traj, &f1.x, &f1.y, &slow, &cut).unwrap());
}
