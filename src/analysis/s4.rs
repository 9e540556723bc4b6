//! Four-point structure factor S4(q, t) (paper H, Eq. 15-16), averaged over shells
//! |q| = q of the reciprocal lattice q = 2 pi (m / l, n / l) of the region the sums
//! run over: the sub-boxes B_r of mean particle number N (`n`, Eq. 16 as the paper
//! writes it, with positions relative to each sub-box), or the whole periodic box
//! (`n` absent, N the particle number).
//!
//! S4(q, t) = N [<|W_r(q)|^2> - |<W_r(q)>|^2], W_r(q) = (1/N) sum_{i in B_r} theta_i
//! exp(-i q.r_i(t0)), theta_i = 1 for slow particles, <.> over sub-boxes and time
//! origins. At q = 0 the mean is taken per replica as chi4's (paper H has one
//! simulation per phi), so W_r = Q_r gives chi4 of the same sub-boxes (Eq. 14);
//! at q != 0 it is pooled ([`Accumulator`]). With sub-boxes the q -> 0
//! limit of Eq. 17 then holds by definition, and the OZ fit can hold its amplitude
//! there. With the whole box the q = 0 point is chi4 of the whole system (Fig. 16
//! caption), but S4(q -> 0) is not that box's chi4 (the paper's remark on fixed N).
//!
//! W(q) for all |q| <= q_max comes from a type-1 non-uniform FFT with Gaussian
//! gridding (Greengard and Lee, SIAM Rev. 46, 443 (2004)): each slow particle is spread
//! with a truncated Gaussian onto a 2x oversampled grid, the grid is Fourier
//! transformed, and the Gaussian is divided out. The truncation half-width sets the
//! accuracy (relative to sum |theta_i|) and is chosen from `tolerance`; the cost is
//! O(N_slow w^2 + G log G) with w = 2 x half-width and G grid points, so 4,000,000
//! particles are cheap. On a sub-box the lattice q is periodic in l, so the same
//! transform of the sub-box's own particles is its Eq. 16. The direct sum over
//! wavevectors is the test reference.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::RecordBatch;
use realfft::num_complex::Complex;
use realfft::{RealFftPlanner, RealToComplex};
use serde::Deserialize;

use super::subbox::SubBoxes;
use super::{check_trajectory, default_a, default_rel_tol, ensure_positive, squared_displacements};
use crate::table::f64_batch;
use crate::traj::Trajectory;

fn default_q_max() -> f64 {
    2.0
}

fn default_tolerance() -> f64 {
    1e-6
}

/// Parameters of S4(q, t).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Mobility cut-off a (units r1).
    #[serde(default = "default_a")]
    pub a: f64,
    /// Lags t at which to evaluate S4 (e.g. [tau_alpha]); required, here or
    /// by the analysis stage's `at:` (the parse checks it).
    #[serde(default)]
    pub lags: Vec<f64>,
    /// Mean particle number N of the sub-boxes B_r (Eqs. 15-16); the whole periodic
    /// box if absent.
    #[serde(default)]
    pub n: Option<f64>,
    /// Largest |q| (units 1/r1).
    #[serde(default = "default_q_max")]
    pub q_max: f64,
    /// Shell width in q; 2 pi / l if absent (l the short side of the region).
    #[serde(default)]
    pub dq: Option<f64>,
    /// Accuracy of W(q) relative to the number of slow particles (1e-15 .. 1e-2).
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Relative tolerance matching a lag to frame time differences.
    #[serde(default = "default_rel_tol")]
    pub rel_tol: f64,
}

/// Reciprocal-lattice vectors q = 2 pi (m / Lx, n / Ly) with 0 < |q| <= q_max, one of
/// each +-q pair (|W(q)| = |W(-q)| for real weights): m > 0, or m = 0 and n > 0.
#[derive(Clone, Debug)]
pub struct Lattice {
    pub modes: [usize; 2],
    /// (m, n) of each vector.
    pub mn: Vec<(i64, i64)>,
    /// |q| of each vector.
    pub q: Vec<f64>,
}

impl Lattice {
    pub fn new(box_size: [f64; 2], q_max: f64) -> Self {
        let modes = [0, 1].map(|d| (q_max * box_size[d] / (2.0 * PI)).floor() as usize);
        let (mut mn, mut q) = (Vec::new(), Vec::new());
        for m in 0..=modes[0] as i64 {
            for n in -(modes[1] as i64)..=modes[1] as i64 {
                if m == 0 && n <= 0 {
                    continue;
                }
                let qq = 2.0 * PI * (m as f64 / box_size[0]).hypot(n as f64 / box_size[1]);
                if qq <= q_max {
                    mn.push((m, n));
                    q.push(qq);
                }
            }
        }
        Self { modes, mn, q }
    }
}

/// Type-1 NUFFT W(m, n) = sum_j c_j exp(-2 pi i (m x_j / Lx + n y_j / Ly)) on a lattice.
pub struct Nufft {
    box_size: [f64; 2],
    modes: [usize; 2],
    /// Oversampled grid size per axis.
    grid: [usize; 2],
    /// Spreading half-width (grid points).
    half_width: usize,
    /// Gaussian width parameter tau per axis (in the 2 pi-periodic variable).
    tau: [f64; 2],
    row_fft: Arc<dyn RealToComplex<f64>>,
    col_fft: ComplexFft,
}

/// Forward complex FFT (sum_l z_l e^{-2 pi i k l / n}) built from two real FFTs, so
/// the crate needs no complex-FFT dependency beyond realfft.
pub struct ComplexFft {
    r2c: Arc<dyn RealToComplex<f64>>,
    n: usize,
}

impl ComplexFft {
    pub fn new(n: usize) -> Self {
        Self {
            r2c: RealFftPlanner::<f64>::new().plan_fft_forward(n),
            n,
        }
    }

    /// Transform `data` (length n) in place.
    pub fn process(&self, data: &mut [Complex<f64>]) {
        let n = self.n;
        let mut re: Vec<f64> = data.iter().map(|z| z.re).collect();
        let mut im: Vec<f64> = data.iter().map(|z| z.im).collect();
        let mut fre = self.r2c.make_output_vec();
        let mut fim = self.r2c.make_output_vec();
        self.r2c
            .process(&mut re, &mut fre)
            .expect("buffer sizes come from the plan");
        self.r2c
            .process(&mut im, &mut fim)
            .expect("buffer sizes come from the plan");
        // Real input: F[n - k] = conj F[k] completes the half spectrum.
        let full = |half: &[Complex<f64>], k: usize| {
            if k <= n / 2 {
                half[k]
            } else {
                half[n - k].conj()
            }
        };
        for (k, z) in data.iter_mut().enumerate() {
            *z = full(&fre, k) + Complex::new(0.0, 1.0) * full(&fim, k);
        }
    }
}

/// Smallest even integer >= n whose only prime factors are 2, 3 and 5 (fast FFT sizes).
fn fft_size(n: usize) -> usize {
    let mut k = n.max(2);
    loop {
        if k.is_multiple_of(2) {
            let mut r = k;
            for p in [2, 3, 5] {
                while r.is_multiple_of(p) {
                    r /= p;
                }
            }
            if r == 1 {
                return k;
            }
        }
        k += 1;
    }
}

impl Nufft {
    /// Transform for modes |m| <= modes[0], |n| <= modes[1] at relative accuracy `tolerance`.
    pub fn new(box_size: [f64; 2], modes: [usize; 2], tolerance: f64) -> Result<Self> {
        if !(tolerance.is_finite() && (1e-15..=1e-2).contains(&tolerance)) {
            bail!("parameter `tolerance` must be in [1e-15, 1e-2], got {tolerance}");
        }
        // Error ~ exp(-pi M_sp (R - 1) / (R - 1/2)) for oversampling R = 2.
        let half_width = ((-tolerance.ln()) / (PI * 2.0 / 3.0)).ceil().max(2.0) as usize;
        let grid = modes.map(|m| fft_size((2 * (2 * m + 1)).max(4 * half_width)));
        // tau = pi M_sp / (M^2 R (R - 1/2)) with M = grid / R modes.
        let tau = grid.map(|g| {
            let m = g as f64 / 2.0;
            PI * half_width as f64 / (m * m * 3.0)
        });
        let mut planner = RealFftPlanner::<f64>::new();
        Ok(Self {
            box_size,
            modes,
            grid,
            half_width,
            tau,
            row_fft: planner.plan_fft_forward(grid[0]),
            col_fft: ComplexFft::new(grid[1]),
        })
    }

    /// Spreading half-width in grid points (cost per particle is (2 w)^2).
    pub fn half_width(&self) -> usize {
        self.half_width
    }

    /// Oversampled grid size.
    pub fn grid(&self) -> [usize; 2] {
        self.grid
    }

    /// Indices and Gaussian weights of the 2 w grid points around coordinate `x` on axis d.
    fn kernel(&self, d: usize, x: f64, idx: &mut [usize], w: &mut [f64]) {
        let g = self.grid[d];
        let h = 2.0 * PI / g as f64;
        let xi = (2.0 * PI * x / self.box_size[d]).rem_euclid(2.0 * PI);
        let l0 = (xi / h).floor() as i64;
        let four_tau = 4.0 * self.tau[d];
        for (k, (i, wk)) in idx.iter_mut().zip(w.iter_mut()).enumerate() {
            let l = l0 - self.half_width as i64 + 1 + k as i64;
            let dx = l as f64 * h - xi;
            *wk = (-dx * dx / four_tau).exp();
            *i = l.rem_euclid(g as i64) as usize;
        }
    }

    /// W on the full block m in 0..=modes[0], n in -modes[1]..=modes[1], stored
    /// m-major: index m * (2 modes[1] + 1) + (n + modes[1]). Sign e^{-i q.r}.
    pub fn transform(&self, x: &[f64], y: &[f64], c: &[f64]) -> Vec<Complex<f64>> {
        let [gx, gy] = self.grid;
        let w2 = 2 * self.half_width;
        let mut field = vec![0.0f64; gx * gy];
        let (mut ix, mut wx) = (vec![0usize; w2], vec![0.0f64; w2]);
        let (mut iy, mut wy) = (vec![0usize; w2], vec![0.0f64; w2]);
        for ((&xj, &yj), &cj) in x.iter().zip(y).zip(c) {
            if cj == 0.0 {
                continue;
            }
            self.kernel(0, xj, &mut ix, &mut wx);
            self.kernel(1, yj, &mut iy, &mut wy);
            for (&r, &wyk) in iy.iter().zip(&wy) {
                let row = &mut field[r * gx..(r + 1) * gx];
                let s = cj * wyk;
                for (&i, &wxk) in ix.iter().zip(&wx) {
                    row[i] += s * wxk;
                }
            }
        }
        // Rows: real FFT along x, keeping m = 0..=modes[0].
        let [mx, my] = self.modes;
        let mut spec = vec![Complex::new(0.0, 0.0); (mx + 1) * gy];
        let mut out = self.row_fft.make_output_vec();
        let mut scratch = self.row_fft.make_scratch_vec();
        for r in 0..gy {
            let row = &mut field[r * gx..(r + 1) * gx];
            self.row_fft
                .process_with_scratch(row, &mut out, &mut scratch)
                .expect("buffer sizes come from the plan");
            for m in 0..=mx {
                spec[m * gy + r] = out[m];
            }
        }
        // Columns: complex FFT along y.
        let ny = 2 * my + 1;
        let mut w = vec![Complex::new(0.0, 0.0); (mx + 1) * ny];
        let deconv = |d: usize, k: f64| (PI / self.tau[d]).sqrt() * (k * k * self.tau[d]).exp();
        let norm = 1.0 / (gx * gy) as f64;
        for m in 0..=mx {
            let col = &mut spec[m * gy..(m + 1) * gy];
            self.col_fft.process(col);
            let dm = deconv(0, m as f64) * norm;
            for n in -(my as i64)..=my as i64 {
                let k = n.rem_euclid(gy as i64) as usize;
                let v = col[k];
                w[m * ny + (n + my as i64) as usize] = v * (dm * deconv(1, n as f64));
            }
        }
        w
    }
}

/// S4 for one lag, shell by shell.
#[derive(Clone, Debug, PartialEq)]
pub struct Shells {
    /// Mean |q| of the vectors in each shell.
    pub q: Vec<f64>,
    /// Mean q^2 of the vectors in each shell (the abscissa of OZ fits in q^2).
    pub q2: Vec<f64>,
    pub s4: Vec<f64>,
    /// Standard error over time origins of the shell average of |W|^2 / N.
    pub s4_err: Vec<f64>,
    /// Number of lattice vectors (one per +-q pair) in each shell.
    pub n_vectors: Vec<usize>,
}

/// Shell average of per-vector values; shell k holds |q| in [(k - 1/2) dq, (k + 1/2) dq).
fn shell_index(q: f64, dq: f64) -> usize {
    (q / dq).round() as usize
}

/// Running sums over time origins, so memory stays O(vectors) whatever the number
/// of origins: sum |W|^2 and sum W per vector over every sample (a sub-box, or
/// the whole box, at an origin), and per-origin shell means of |W|^2.
///
/// For q != 0 the ensemble mean of W is zero (translation invariance), so the
/// mean subtracted is the pooled one, which only removes the estimator's own
/// offset. A mean per replica would also remove slow regions that outlive the
/// run (one sample per origin on the whole box): measured at ci, it moved
/// fig18's amplitude by eight seed-to-seed spreads.
pub struct Accumulator<'a> {
    lat: &'a Lattice,
    shell: Vec<usize>,
    n_shells: usize,
    sum2: Vec<f64>,
    sum1: Vec<Complex<f64>>,
    samples: f64,
    per_origin: Vec<Vec<f64>>,
}

impl<'a> Accumulator<'a> {
    pub fn new(lat: &'a Lattice, dq: f64) -> Self {
        let shell: Vec<usize> = lat.q.iter().map(|&q| shell_index(q, dq)).collect();
        let n_shells = shell.iter().copied().max().unwrap_or(0) + 1;
        Self {
            lat,
            shell,
            n_shells,
            sum2: vec![0.0; lat.q.len()],
            sum1: vec![Complex::new(0.0, 0.0); lat.q.len()],
            samples: 0.0,
            per_origin: Vec::new(),
        }
    }

    /// Add the W of one time origin: one vector (a value per lattice vector) per
    /// sub-box, or one for the whole box.
    pub fn add(&mut self, samples: &[Vec<Complex<f64>>]) {
        let mut shells = vec![0.0; self.n_shells];
        for w in samples {
            for (v, wv) in w.iter().enumerate() {
                self.sum2[v] += wv.norm_sqr();
                self.sum1[v] += wv;
                shells[self.shell[v]] += wv.norm_sqr();
            }
        }
        self.samples += samples.len() as f64;
        let k = samples.len().max(1) as f64;
        self.per_origin
            .push(shells.into_iter().map(|x| x / k).collect());
    }

    /// S4 = (<|W|^2> - |<W>|^2) / N per vector (W unnormalised, the mean pooled),
    /// averaged in shells.
    pub fn shells(&self, n_particles: f64) -> Shells {
        let no = self.per_origin.len() as f64;
        let mut sum_q = vec![0.0; self.n_shells];
        let mut sum_q2 = vec![0.0; self.n_shells];
        let mut sum_s = vec![0.0; self.n_shells];
        let mut count = vec![0usize; self.n_shells];
        for v in 0..self.lat.q.len() {
            let k = self.shell[v];
            let between = self.sum1[v].norm_sqr() / self.samples;
            sum_q[k] += self.lat.q[v];
            sum_q2[k] += self.lat.q[v] * self.lat.q[v];
            sum_s[k] += (self.sum2[v] - between) / self.samples / n_particles;
            count[k] += 1;
        }
        let mut out = Shells {
            q: vec![],
            q2: vec![],
            s4: vec![],
            s4_err: vec![],
            n_vectors: vec![],
        };
        for k in 0..self.n_shells {
            if count[k] == 0 {
                continue;
            }
            let c = count[k] as f64;
            // Standard error over origins of the shell mean of |W|^2 / N.
            let means: Vec<f64> = self
                .per_origin
                .iter()
                .map(|p| p[k] / (c * n_particles))
                .collect();
            let m = means.iter().sum::<f64>() / no;
            let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (no - 1.0).max(1.0);
            out.q.push(sum_q[k] / c);
            out.q2.push(sum_q2[k] / c);
            out.s4.push(sum_s[k] / c);
            out.s4_err.push(if no > 1.0 {
                (var / no).sqrt()
            } else {
                f64::NAN
            });
            out.n_vectors.push(count[k]);
        }
        out
    }
}

/// S4(q) at each requested lag: `(lag, shells)`, shells of q > 0 only (see [`s4_zero`]).
pub fn s4(traj: &Trajectory, p: &Params) -> Result<Vec<(f64, Shells)>> {
    Ok(s4_with_zero(&[traj], p)?
        .into_iter()
        .map(|(t, _, s)| (t, s))
        .collect())
}

/// S4(q = 0) at each requested lag, one shell with q = 0: (1/N) var(N_slow) over
/// time origins, which is chi4 of the whole system (Eq. 14 with a single box).
pub fn s4_zero(traj: &Trajectory, p: &Params) -> Result<Vec<(f64, Shells)>> {
    Ok(s4_with_zero(&[traj], p)?
        .into_iter()
        .map(|(t, z, _)| (t, z))
        .collect())
}

/// Per lag: (lag, the q = 0 shell, the shells of q > 0), averages over every
/// sub-box (or the whole box) at every time origin of every trajectory (replicas
/// of one state point: one box, one N).
fn s4_with_zero(trajs: &[&Trajectory], p: &Params) -> Result<Vec<(f64, Shells, Shells)>> {
    let Some(&traj) = trajs.first() else {
        bail!("S4 needs at least one trajectory");
    };
    for (k, t) in trajs.iter().enumerate() {
        check_trajectory(t)?;
        if t.box_size != traj.box_size || t.n() != traj.n() {
            bail!(
                "S4 pools replicas of one state point: replica {k} has box {:?} and N = {}, replica 0 has box {:?} and N = {}",
                t.box_size,
                t.n(),
                traj.box_size,
                traj.n()
            );
        }
    }
    ensure_positive("a", p.a)?;
    ensure_positive("q_max", p.q_max)?;
    // The region the sums of Eq. 16 run over, and the N of Eq. 15.
    let boxes = p.n.map(|n| SubBoxes::new(traj, n)).transpose()?;
    let (region, n_norm, what) = match &boxes {
        Some(b) => ([b.side, b.side], b.n_mean, "sub-box"),
        None => (traj.box_size, traj.n() as f64, "box"),
    };
    if boxes.is_none() && traj.periodic != [true, true] {
        bail!(
            "S4 of the whole box needs a box periodic in x and y (the trajectory has periodic = {:?}); give sub-boxes with `n`",
            traj.periodic
        );
    }
    if p.lags.is_empty() {
        bail!("parameter `lags` is empty: give at least one lag (e.g. tau_alpha)");
    }
    let dq = p.dq.unwrap_or(2.0 * PI / region[0].min(region[1]));
    ensure_positive("dq", dq)?;
    let lat = Lattice::new(region, p.q_max);
    if lat.q.is_empty() {
        bail!(
            "q_max = {} is below the smallest wavevector 2 pi / l = {:.4} of this {what}",
            p.q_max,
            2.0 * PI / region[0].max(region[1])
        );
    }
    let nufft = Nufft::new(region, lat.modes, p.tolerance)?;
    let lags = super::lags::select(trajs, Some(&p.lags), p.rel_tol)?;
    let ny = 2 * lat.modes[1] + 1;
    let pick = |full: Vec<Complex<f64>>| -> Vec<Complex<f64>> {
        lat.mn
            .iter()
            .map(|&(m, n)| full[m as usize * ny + (n + lat.modes[1] as i64) as usize])
            .collect()
    };
    let a2 = p.a * p.a;
    let mut out = Vec::new();
    for lag in lags {
        let mut acc = Accumulator::new(&lat, dq);
        let mut slow = Vec::with_capacity(lag.pairs.len());
        for &(r, i, j) in &lag.pairs {
            let (f0, f1) = (&trajs[r].frames[i], &trajs[r].frames[j]);
            let theta: Vec<f64> = squared_displacements(f0, f1)
                .into_iter()
                .map(|d2| if d2 < a2 { 1.0 } else { 0.0 })
                .collect();
            let (counts, ws) = match &boxes {
                None => (
                    vec![theta.iter().sum::<f64>()],
                    vec![pick(nufft.transform(&f0.x, &f0.y, &theta))],
                ),
                Some(b) => {
                    // The slow particles of each sub-box, at their positions in it.
                    let mut xy = vec![(Vec::new(), Vec::new()); b.len()];
                    for (k, &th) in theta.iter().enumerate() {
                        if th > 0.0
                            && let Some((bi, rel)) = b.locate_within(f0.x[k], f0.y[k])
                        {
                            xy[bi].0.push(rel[0]);
                            xy[bi].1.push(rel[1]);
                        }
                    }
                    let counts = xy.iter().map(|(x, _)| x.len() as f64).collect();
                    let ws = xy
                        .iter()
                        .map(|(x, y)| pick(nufft.transform(x, y, &vec![1.0; x.len()])))
                        .collect();
                    (counts, ws)
                }
            };
            acc.add(&ws);
            slow.push((r, counts));
        }
        out.push((lag.t, zero_shell(&slow, n_norm), acc.shells(n_norm)));
    }
    Ok(out)
}

/// S4(q = 0) = var(N_slow) / N over the samples (W(0) = N_slow of a sub-box, or
/// of the whole box), the variance taken within each replica about its own mean
/// and averaged over replicas as chi4's ([`super::chi4::Variance`]): chi4 of the
/// same sub-boxes. Error: delete-one-origin jackknife (the variance is not a
/// mean over origins). `origins`: (replica, N_slow per sample) per time origin.
fn zero_shell(origins: &[(usize, Vec<f64>)], n: f64) -> Shells {
    // sum N_slow^2 over samples, and per replica (sum N_slow, samples).
    let mut sq = 0.0;
    let mut per: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for (r, xs) in origins {
        let e = per.entry(*r).or_default();
        for x in xs {
            sq += x * x;
            e.0 += x;
            e.1 += 1.0;
        }
    }
    let s4 = |sq: f64, per: &BTreeMap<usize, (f64, f64)>| {
        let (between, samples) = per
            .values()
            .filter(|(_, k)| *k > 0.0)
            .fold((0.0, 0.0), |(b, c), (s, k)| (b + s * s / k, c + k));
        (sq - between) / samples / n
    };
    let loo: Vec<f64> = origins
        .iter()
        .map(|(r, xs)| {
            let mut rest = per.clone();
            let e = rest.get_mut(r).expect("replica of this origin");
            e.0 -= xs.iter().sum::<f64>();
            e.1 -= xs.len() as f64;
            s4(sq - xs.iter().map(|x| x * x).sum::<f64>(), &rest)
        })
        .collect();
    Shells {
        q: vec![0.0],
        q2: vec![0.0],
        s4: vec![s4(sq, &per)],
        s4_err: vec![super::stats::jackknife_err(loo)],
        n_vectors: vec![1],
    }
}

/// Table `L, t, q, q2, S4, S4_err, n_vectors` (L the short side of the region:
/// the sub-box or the box; q2 the shell mean of q^2); per lag the first row is
/// q = 0 (chi4 of the same sub-boxes, or of the whole system), then the shells of
/// q > 0.
pub fn compute(traj: &Trajectory, p: &Params) -> Result<RecordBatch> {
    compute_pooled(&[traj], p)
}

/// As [`compute`], averaging over every time origin of several replicas (errors:
/// standard error over all those origins).
pub fn compute_pooled(trajs: &[&Trajectory], p: &Params) -> Result<RecordBatch> {
    let mut cols: [Vec<f64>; 6] = Default::default();
    for (t, z, s) in s4_with_zero(trajs, p)? {
        for s in [z, s] {
            cols[0].extend(std::iter::repeat_n(t, s.q.len()));
            cols[1].extend(&s.q);
            cols[5].extend(&s.q2);
            cols[2].extend(&s.s4);
            cols[3].extend(&s.s4_err);
            cols[4].extend(s.n_vectors.iter().map(|&c| c as f64));
        }
    }
    let [t, q, s, e, n, q2] = cols;
    // The region's side: xi / L says how close the correlation length is to it.
    let side = match p.n {
        Some(n) => SubBoxes::new(trajs[0], n)?.side,
        None => trajs[0].box_size[0].min(trajs[0].box_size[1]),
    };
    f64_batch(&[
        ("L", vec![side; t.len()]),
        ("t", t),
        ("q", q),
        ("q2", q2),
        ("S4", s),
        ("S4_err", e),
        ("n_vectors", n),
    ])
}

/// Direct sum W(q) = sum_j c_j exp(-i q.r_j) over the lattice vectors (O(N x vectors);
/// the reference the NUFFT is checked against).
pub fn direct_w(
    lat: &Lattice,
    box_size: [f64; 2],
    x: &[f64],
    y: &[f64],
    c: &[f64],
) -> Vec<Complex<f64>> {
    lat.mn
        .iter()
        .map(|&(m, n)| {
            let (kx, ky) = (
                2.0 * PI * m as f64 / box_size[0],
                2.0 * PI * n as f64 / box_size[1],
            );
            x.iter()
                .zip(y)
                .zip(c)
                .map(|((xj, yj), cj)| Complex::from_polar(*cj, -(kx * xj + ky * yj)))
                .sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::{independent_slow, oz_slow};
    use crate::analysis::test_support::col;
    use crate::analysis::{chi4, overlap, squared_displacements};

    /// S4 at the single lag t = 1 for wave numbers up to `q_max`.
    fn unit_lag(q_max: f64, tolerance: f64) -> Params {
        Params {
            a: 0.6,
            lags: vec![1.0],
            n: None,
            q_max,
            dq: None,
            tolerance,
            rel_tol: 1e-6,
        }
    }

    /// The overlap table at the single lag t = 1, the other parameters default.
    fn overlap_at_unit_lag(traj: &Trajectory) -> RecordBatch {
        overlap::compute(
            traj,
            &overlap::Params {
                lags: Some(vec![1.0]),
                ..Default::default()
            },
        )
        .unwrap()
    }

    /// Fig. 16: the q = 0 point of S4 is Eq. 15 with W(0) = N_slow, i.e. chi4 of the
    /// whole system (Eq. 14 with one box), on correlated (OZ) slow particles.
    #[test]
    fn q_zero_point_is_chi4_of_the_whole_system() {
        let traj = oz_slow(4000, 60.0, 60, 3.0, 0.5, 0.2, 30, 5);
        let p = unit_lag(1.0, 1e-6);
        let s = compute(&traj, &p).unwrap();
        let (q, s4) = (col(&s, "q"), col(&s, "S4"));
        assert_eq!(q[0], 0.0, "first row is q = 0");
        assert!(q[1..].iter().all(|&v| v > 0.0));
        let c = chi4::compute(
            &traj,
            &chi4::Params {
                a: 0.6,
                n: vec![traj.n() as f64],
                fractions: Vec::new(),
                lags: Some(vec![1.0]),
                rel_tol: 1e-6,
                variance: chi4::Variance::default(),
            },
        )
        .unwrap();
        let whole = col(&c, "chi4")[0];
        assert!(
            (s4[0] - whole).abs() <= 1e-9 * whole,
            "S4(0) = {} vs chi4 = {whole}",
            s4[0]
        );
        assert!(
            whole.is_finite() && whole > 0.0,
            "chi4 of the whole system = {whole}"
        );
        let zero = s4_zero(&traj, &p).unwrap();
        assert_eq!(zero[0].1.s4[0], s4[0]);
    }

    #[test]
    fn independent_particles_give_q_chi4_s4_equal_p() {
        let p = 0.3;
        let traj = independent_slow(20_000, [141.0, 141.0], 40, p, 1.0, 7);
        let q = overlap_at_unit_lag(&traj);
        let (qv, qe) = (col(&q, "Q")[0], col(&q, "Q_err")[0]);
        assert!((qv - p).abs() < 4.0 * qe && qe < 0.01, "Q = {qv} +- {qe}");

        // Grand-canonical sub-boxes: slow counts are Poisson, so chi4 = p.
        let c = chi4::compute(
            &traj,
            &chi4::Params {
                a: 0.6,
                n: vec![50.0, 200.0],
                fractions: Vec::new(),
                lags: Some(vec![1.0]),
                rel_tol: 1e-6,
                variance: chi4::Variance::default(),
            },
        )
        .unwrap();
        for (chi, e) in col(&c, "chi4").iter().zip(col(&c, "chi4_err")) {
            assert!(
                (chi - p).abs() < 4.0 * e && e < 0.03 * p,
                "chi4 = {chi} +- {e}"
            );
        }

        let s = s4(&traj, &unit_lag(1.0, 1e-6)).unwrap();
        // ~ 40 origins x 1000 vectors: the overall mean is known to ~0.5 %.
        assert_shells_equal(&s[0].1, p);
    }

    /// Every shell within 5 errors of `p`, and their vector-weighted mean within 2%.
    fn assert_shells_equal(sh: &Shells, p: f64) {
        let (mut weighted, mut total) = (0.0, 0.0);
        for k in 0..sh.q.len() {
            assert!(
                (sh.s4[k] - p).abs() < 5.0 * sh.s4_err[k],
                "shell q = {}: S4 = {} +- {}",
                sh.q[k],
                sh.s4[k],
                sh.s4_err[k]
            );
            weighted += sh.s4[k] * sh.n_vectors[k] as f64;
            total += sh.n_vectors[k] as f64;
        }
        assert!(
            (weighted / total - p).abs() < 0.02 * p,
            "mean S4 = {}",
            weighted / total
        );
    }

    /// Eqs. 15-16 per sub-box: at q = 0, W_r = Q_r, so S4 is chi4 (Eq. 14) of the
    /// same sub-boxes with the same per-replica variance, to rounding; on two
    /// replicas of correlated (OZ) slow particles, several sub-boxes per box.
    #[test]
    fn sub_box_q_zero_point_is_chi4_of_the_same_sub_boxes() {
        let reps = [
            oz_slow(4000, 60.0, 60, 3.0, 0.5, 0.2, 30, 5),
            oz_slow(4000, 60.0, 60, 3.0, 0.5, 0.2, 30, 6),
        ];
        let trajs: Vec<&Trajectory> = reps.iter().collect();
        for n_sub in [250.0, 1000.0] {
            let p = Params {
                n: Some(n_sub),
                ..unit_lag(2.0, 1e-6)
            };
            let s = compute_pooled(&trajs, &p).unwrap();
            let (q, s4, side) = (col(&s, "q"), col(&s, "S4"), col(&s, "L"));
            assert_eq!(q[0], 0.0, "first row is q = 0");
            // The lattice is the sub-box's: the first shell holds 2 pi / l and
            // 2 pi sqrt(2) / l.
            let l = (n_sub / (4000.0 / 3600.0)).sqrt();
            assert!((side[0] - l).abs() < 1e-9 * l, "L = {} vs l = {l}", side[0]);
            let q1 = 2.0 * PI / l;
            assert!(
                q[1] > q1 && q[1] < q1 * 2f64.sqrt(),
                "first shell q = {}",
                q[1]
            );
            let c = chi4::compute_pooled(
                &trajs,
                &chi4::Params {
                    a: 0.6,
                    n: vec![n_sub],
                    fractions: Vec::new(),
                    lags: Some(vec![1.0]),
                    rel_tol: 1e-6,
                    variance: chi4::Variance::PerReplica,
                },
            )
            .unwrap();
            let chi = col(&c, "chi4")[0];
            assert!(
                (s4[0] - chi).abs() <= 1e-9 * chi && chi > 0.0,
                "N = {n_sub}: S4(0) = {} vs chi4 = {chi}",
                s4[0]
            );
        }
    }

    /// Independent slow particles in grand-canonical sub-boxes: S4(q) = p at every
    /// q of the sub-box lattice, q = 0 included (Poisson counts).
    #[test]
    fn independent_particles_give_s4_equal_p_per_sub_box() {
        let p = 0.3;
        let traj = independent_slow(20_000, [141.0, 141.0], 40, p, 1.0, 7);
        let par = Params {
            n: Some(500.0),
            ..unit_lag(1.5, 1e-6)
        };
        let (_, zero, sh) = s4_with_zero(&[&traj], &par).unwrap().remove(0);
        assert!(
            (zero.s4[0] - p).abs() < 4.0 * zero.s4_err[0] && zero.s4_err[0] < 0.05 * p,
            "S4(0) = {} +- {}",
            zero.s4[0],
            zero.s4_err[0]
        );
        assert_shells_equal(&sh, p);
    }

    #[test]
    fn nufft_equals_the_direct_sum() {
        let traj = independent_slow(400, [23.0, 17.0], 1, 0.5, 1.0, 3);
        let (f0, f1) = (&traj.frames[0], &traj.frames[1]);
        let c: Vec<f64> = squared_displacements(f0, f1)
            .iter()
            .map(|&d| if d < 0.36 { 1.0 } else { 0.0 })
            .collect();
        let lat = Lattice::new(traj.box_size, 4.0);
        let direct = direct_w(&lat, traj.box_size, &f0.x, &f0.y, &c);
        let nufft = Nufft::new(traj.box_size, lat.modes, 1e-14).unwrap();
        let full = nufft.transform(&f0.x, &f0.y, &c);
        let ny = 2 * lat.modes[1] + 1;
        let norm: f64 = c.iter().sum();
        let mut worst: f64 = 0.0;
        for (v, &(m, n)) in lat.mn.iter().enumerate() {
            let w = full[m as usize * ny + (n + lat.modes[1] as i64) as usize];
            worst = worst.max((w - direct[v]).norm() / norm);
            // S4 per vector |W|^2 / N, relative.
            let (a, b) = (w.norm_sqr(), direct[v].norm_sqr());
            assert!(
                (a - b).abs() <= 1e-10 * b.max(1e-3 * norm),
                "q = {}: {a} vs {b}",
                lat.q[v]
            );
        }
        assert!(worst < 1e-12, "worst relative error {worst}");
        // The default tolerance 1e-6 holds too.
        let coarse = Nufft::new(traj.box_size, lat.modes, 1e-6).unwrap();
        let fc = coarse.transform(&f0.x, &f0.y, &c);
        for (v, &(m, n)) in lat.mn.iter().enumerate() {
            let w = fc[m as usize * ny + (n + lat.modes[1] as i64) as usize];
            assert!((w - direct[v]).norm() < 1e-6 * norm);
        }
    }

    #[test]
    fn oz_field_recovers_xi_and_s4_tends_to_chi4() {
        // h = L / grid = 0.5 keeps the nearest-grid-point window (xi^2 -> xi^2 + h^2 / 12)
        // negligible; 240 origins keep the statistical error of xi near 2 %.
        let (l, xi, p0) = (200.0, 4.0, 0.5);
        let traj = oz_slow(40_000, l, 400, xi, p0, 0.18, 240, 11);
        let s = s4(&traj, &unit_lag(0.5, 1e-8)).unwrap();
        let sh = &s[0].1;
        let q = overlap_at_unit_lag(&traj);
        let background = col(&q, "Q")[0];
        // Test helper, not library code (the OZ fit lives in src/fit): weighted linear
        // regression of 1 / (S4 - p) against q^2 for q xi <= 2. Weights from a model, not
        // from the noisy data (that would bias the fit): first unweighted per vector, then
        // var(1/excess) ~ S4^2 / (n excess^4) of the first model.
        let regress = |model: Option<(f64, f64)>| {
            let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for k in 0..sh.q.len() {
                if sh.q[k] * xi > 2.0 {
                    continue;
                }
                let (x, y) = (sh.q2[k], 1.0 / (sh.s4[k] - background));
                let n = sh.n_vectors[k] as f64;
                let w = match model {
                    None => n,
                    Some((slope, icpt)) => {
                        let excess = 1.0 / (icpt + slope * x);
                        n * excess.powi(4) / (background + excess).powi(2)
                    }
                };
                sw += w;
                sx += w * x;
                sy += w * y;
                sxx += w * x * x;
                sxy += w * x * y;
            }
            let slope = (sw * sxy - sx * sy) / (sw * sxx - sx * sx);
            (slope, (sy - slope * sx) / sw)
        };
        let (slope, intercept) = regress(Some(regress(None)));
        let xi_fit = (slope / intercept).sqrt();
        let chi0 = 1.0 / intercept;
        eprintln!("xi = {xi_fit}, chi0 = {chi0}, background = {background}");
        assert!(
            (xi_fit - xi).abs() < 0.05 * xi,
            "xi = {xi_fit}, expected {xi}"
        );

        // S4(q -> 0) = background + chi0 is approached by chi4 of sub-boxes large
        // against xi (l = 5 xi, 10 xi). Larger boxes are suppressed by the fixed total
        // (the field has zero mean in each realisation), so the approach stays ~15 % short.
        let c = chi4::compute(
            &traj,
            &chi4::Params {
                a: 0.6,
                n: vec![400.0, 1600.0],
                fractions: Vec::new(),
                lags: Some(vec![1.0]),
                rel_tol: 1e-6,
                variance: chi4::Variance::default(),
            },
        )
        .unwrap();
        let chi = col(&c, "chi4");
        let s0 = background + chi0;
        eprintln!("chi4 = {chi:?}, S4(0) = {s0}");
        assert!(
            chi[0] > background + 0.5 * chi0,
            "chi4 misses the correlations: {chi:?}"
        );
        assert!(chi[0] < chi[1] && chi[1] < s0, "{chi:?} vs S4(0) = {s0}");
        assert!(
            (chi[1] - s0).abs() < 0.2 * s0,
            "chi4 = {} vs S4(0) = {s0}",
            chi[1]
        );
    }
}
