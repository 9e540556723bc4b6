//! Synthetic trajectories with known answers, for tests and benchmarks: random walks
//! (MSD = 4 D t), ballistic motion (MSD = <v^2> t^2), independent slow particles
//! (Q = chi4 = S4 = p) and slow particles modulated by a Gaussian random field with an
//! Ornstein-Zernike spectrum (S4(q) - p = A / (1 + (q xi)^2)).

use std::f64::consts::PI;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::num_complex::Complex;

use super::s4::ComplexFft;
use crate::traj::{Frame, Trajectory};

fn frame(time: f64, x: Vec<f64>, y: Vec<f64>) -> Frame {
    Frame {
        time,
        x,
        y,
        vx: vec![],
        vy: vec![],
    }
}

/// A 50:50 bidisperse system of paper H's particles (r2/r1 = 1.43, m ~ r^2).
fn system(n: usize, box_size: [f64; 2], frames: Vec<Frame>) -> Trajectory {
    Trajectory {
        box_size,
        periodic: [true, true],
        species: (0..n).map(|i| (i % 2) as u8).collect(),
        radii: vec![1.0, 1.43],
        masses: vec![1.0, 1.43 * 1.43],
        frames,
        schedule: None,
    }
}

fn uniform(rng: &mut ChaCha8Rng, n: usize, l: f64) -> Vec<f64> {
    (0..n).map(|_| rng.random::<f64>() * l).collect()
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Brownian particles with diffusion coefficient `d` sampled at `times`
/// (exact Gaussian increments of variance 2 d dt per component).
pub fn random_walk(n: usize, box_size: [f64; 2], times: &[f64], d: f64, seed: u64) -> Trajectory {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = uniform(&mut rng, n, box_size[0]);
    let mut y = uniform(&mut rng, n, box_size[1]);
    let mut frames = Vec::with_capacity(times.len());
    let mut last = times.first().copied().unwrap_or(0.0);
    for &t in times {
        let s = (2.0 * d * (t - last)).sqrt();
        for i in 0..n {
            x[i] += s * normal(&mut rng);
            y[i] += s * normal(&mut rng);
        }
        frames.push(frame(t, x.clone(), y.clone()));
        last = t;
    }
    system(n, box_size, frames)
}

/// Free flight: unit-variance Gaussian velocity components, positions x0 + v t.
/// Velocities are recorded in every frame.
pub fn ballistic(n: usize, box_size: [f64; 2], times: &[f64], seed: u64) -> Trajectory {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x0 = uniform(&mut rng, n, box_size[0]);
    let y0 = uniform(&mut rng, n, box_size[1]);
    let vx: Vec<f64> = (0..n).map(|_| normal(&mut rng)).collect();
    let vy: Vec<f64> = (0..n).map(|_| normal(&mut rng)).collect();
    let frames = times
        .iter()
        .map(|&t| Frame {
            time: t,
            x: x0.iter().zip(&vx).map(|(x, v)| x + v * t).collect(),
            y: y0.iter().zip(&vy).map(|(y, v)| y + v * t).collect(),
            vx: vx.clone(),
            vy: vy.clone(),
        })
        .collect();
    system(n, box_size, frames)
}

/// `origins` independent frame pairs at times (10 k, 10 k + 1): fresh uniform
/// positions at each origin; particle i stays put with probability `p_slow(x, y)`,
/// otherwise jumps a distance `jump` in a random direction.
fn slow_pairs(
    n: usize,
    box_size: [f64; 2],
    origins: usize,
    jump: f64,
    rng: &mut ChaCha8Rng,
    mut p_slow: impl FnMut(&mut ChaCha8Rng, &[f64], &[f64]) -> Vec<f64>,
) -> Trajectory {
    let mut frames = Vec::with_capacity(2 * origins);
    for k in 0..origins {
        let x = uniform(rng, n, box_size[0]);
        let y = uniform(rng, n, box_size[1]);
        let p = p_slow(rng, &x, &y);
        let (mut x1, mut y1) = (x.clone(), y.clone());
        for i in 0..n {
            if rng.random::<f64>() >= p[i] {
                let phi = 2.0 * PI * rng.random::<f64>();
                x1[i] += jump * phi.cos();
                y1[i] += jump * phi.sin();
            }
        }
        let t0 = 10.0 * k as f64;
        frames.push(frame(t0, x, y));
        frames.push(frame(t0 + 1.0, x1, y1));
    }
    system(n, box_size, frames)
}

/// Independent particles, each slow (displacement 0 over lag 1) with probability `p`,
/// else displaced by `jump`: <Q> = chi4 = S4(q) = p for grand-canonical sub-boxes.
pub fn independent_slow(
    n: usize,
    box_size: [f64; 2],
    origins: usize,
    p: f64,
    jump: f64,
    seed: u64,
) -> Trajectory {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    slow_pairs(n, box_size, origins, jump, &mut rng, |_, x, _| {
        vec![p; x.len()]
    })
}

/// A zero-mean, unit-variance Gaussian random field on a k x k grid over a square
/// box of side `l`, with Ornstein-Zernike spectrum P(q) ~ 1 / (1 + (q xi)^2).
pub fn oz_field(k: usize, l: f64, xi: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    // phi = Re FFT2(Z), Z_q independent complex Gaussians of variance P(q): the real
    // part has covariance (P(q) + P(-q)) / 2 = P(q).
    let mut z: Vec<Complex<f64>> = Vec::with_capacity(k * k);
    for iy in 0..k {
        for ix in 0..k {
            let f = |i: usize| {
                (if i <= k / 2 {
                    i as f64
                } else {
                    i as f64 - k as f64
                }) * 2.0
                    * PI
                    / l
            };
            let q2 = f(ix).powi(2) + f(iy).powi(2);
            let amp = (1.0 / (1.0 + q2 * xi * xi)).sqrt();
            z.push(Complex::new(amp * normal(rng), amp * normal(rng)));
        }
    }
    let fft = ComplexFft::new(k);
    for row in z.chunks_mut(k) {
        fft.process(row);
    }
    let mut col = vec![Complex::new(0.0, 0.0); k];
    for ix in 0..k {
        for iy in 0..k {
            col[iy] = z[iy * k + ix];
        }
        fft.process(&mut col);
        for iy in 0..k {
            z[iy * k + ix] = col[iy];
        }
    }
    let phi: Vec<f64> = z.iter().map(|c| c.re).collect();
    let m = phi.iter().sum::<f64>() / phi.len() as f64;
    let sd = (phi.iter().map(|v| (v - m).powi(2)).sum::<f64>() / phi.len() as f64).sqrt();
    phi.iter().map(|v| (v - m) / sd).collect()
}

/// Slow particles modulated by an OZ Gaussian field (fresh field per origin):
/// P(slow at r) = clamp(p0 + eps phi(r), 0, 1) with phi on a `grid` x `grid` mesh
/// (nearest grid point). For small eps, S4(q) = p0 + rho eps^2 C(q) with C(q) the
/// field's spectrum, an OZ form of correlation length xi. Square box of side `l`.
#[allow(clippy::too_many_arguments)]
pub fn oz_slow(
    n: usize,
    l: f64,
    grid: usize,
    xi: f64,
    p0: f64,
    eps: f64,
    origins: usize,
    seed: u64,
) -> Trajectory {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let h = l / grid as f64;
    slow_pairs(n, [l, l], origins, 2.0, &mut rng, |rng, x, y| {
        let phi = oz_field(grid, l, xi, rng);
        x.iter()
            .zip(y)
            .map(|(x, y)| {
                let ix = ((x / h) as usize).min(grid - 1);
                let iy = ((y / h) as usize).min(grid - 1);
                (p0 + eps * phi[iy * grid + ix]).clamp(0.0, 1.0)
            })
            .collect()
    })
}
