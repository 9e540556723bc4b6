//! Tests against exact small cases, analytic limits and synthetic systems with known
//! answers (see `synthetic`).

use std::f64::consts::PI;

use arrow_array::{Array, Float64Array, RecordBatch};

use super::synthetic::{ballistic, independent_slow, oz_slow, random_walk};
use super::*;
use crate::traj::{Frame, Schedule, Trajectory};

/// A Float64 column of a table, for the analysis modules' tests.
pub(super) fn col(b: &RecordBatch, name: &str) -> Vec<f64> {
    b.column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<Float64Array>()
        .unwrap()
        .values()
        .to_vec()
}

fn err_text<T: std::fmt::Debug>(r: anyhow::Result<T>) -> String {
    format!("{:#}", r.unwrap_err())
}

fn schedule_times(origins: usize, spacing: f64, min: f64, max: f64) -> Vec<f64> {
    Schedule {
        start: 0.0,
        origins,
        origin_spacing: spacing,
        lags: Schedule::log_lags(min, max, 8),
    }
    .times()
}

#[test]
fn independent_particles_give_q_chi4_s4_equal_p() {
    let p = 0.3;
    let traj = independent_slow(20_000, [141.0, 141.0], 40, p, 1.0, 7);
    let q = overlap::compute(
        &traj,
        &overlap::Params {
            lags: Some(vec![1.0]),
            ..Default::default()
        },
    )
    .unwrap();
    let (qv, qe) = (col(&q, "Q")[0], col(&q, "Q_err")[0]);
    assert!((qv - p).abs() < 4.0 * qe && qe < 0.01, "Q = {qv} +- {qe}");

    // Grand-canonical sub-boxes: slow counts are Poisson, so chi4 = p.
    let c = chi4::compute(
        &traj,
        &chi4::Params {
            a: 0.6,
            n: vec![50.0, 200.0],
            lags: Some(vec![1.0]),
            rel_tol: 1e-6,
        },
    )
    .unwrap();
    for (chi, e) in col(&c, "chi4").iter().zip(col(&c, "chi4_err")) {
        assert!(
            (chi - p).abs() < 4.0 * e && e < 0.03 * p,
            "chi4 = {chi} +- {e}"
        );
    }

    let s = s4::s4(
        &traj,
        &s4::Params {
            a: 0.6,
            lags: vec![1.0],
            q_max: 1.0,
            dq: None,
            tolerance: 1e-6,
            rel_tol: 1e-6,
        },
    )
    .unwrap();
    let sh = &s[0].1;
    let mut weighted = 0.0;
    let mut total = 0.0;
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
    // ~ 40 origins x 1000 vectors: the overall mean is known to ~0.5 %.
    assert!(
        (weighted / total - p).abs() < 0.02 * p,
        "mean S4 = {}",
        weighted / total
    );
}

#[test]
fn nufft_equals_the_direct_sum() {
    let traj = independent_slow(400, [23.0, 17.0], 1, 0.5, 1.0, 3);
    let (f0, f1) = (&traj.frames[0], &traj.frames[1]);
    let c: Vec<f64> = squared_displacements(f0, f1)
        .iter()
        .map(|&d| if d < 0.36 { 1.0 } else { 0.0 })
        .collect();
    let lat = s4::Lattice::new(traj.box_size, 4.0);
    let direct = s4::direct_w(&lat, traj.box_size, &f0.x, &f0.y, &c);
    let nufft = s4::Nufft::new(traj.box_size, lat.modes, 1e-14).unwrap();
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
    let coarse = s4::Nufft::new(traj.box_size, lat.modes, 1e-6).unwrap();
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
    let s = s4::s4(
        &traj,
        &s4::Params {
            a: 0.6,
            lags: vec![1.0],
            q_max: 0.5,
            dq: None,
            tolerance: 1e-8,
            rel_tol: 1e-6,
        },
    )
    .unwrap();
    let sh = &s[0].1;
    let q = overlap::compute(
        &traj,
        &overlap::Params {
            lags: Some(vec![1.0]),
            ..Default::default()
        },
    )
    .unwrap();
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
            lags: Some(vec![1.0]),
            rel_tol: 1e-6,
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

#[test]
fn random_walk_msd_is_4dt_and_van_hove_is_gaussian() {
    let d = 0.25;
    let times = schedule_times(10, 20.0, 0.1, 10.0);
    let traj = random_walk(20_000, [140.0, 140.0], &times, d, 5);
    let b = msd::compute(
        &traj,
        &msd::Params {
            lags: Some(vec![0.1, 1.0, 10.0]),
            fractions: vec![0.1],
            rel_tol: 1e-6,
        },
    )
    .unwrap();
    let (t, sp, sel, m) = (
        col(&b, "t"),
        col(&b, "species"),
        col(&b, "select"),
        col(&b, "msd"),
    );
    for k in 0..t.len() {
        let exact = 4.0 * d * t[k];
        // |dr|^2 / 4Dt is Exp(1): fastest 10 % average 1 + ln 10, slowest 10 %
        // 1 - q e^-q / (1 - e^-q) with q = ln(10/9).
        let qs = (10f64 / 9.0).ln();
        let factor = match sel[k] as i8 {
            0 => 1.0,
            1 => 1.0 + 10f64.ln(),
            _ => 1.0 - qs * (-qs).exp() / (1.0 - (-qs).exp()),
        };
        let tol = if sel[k] == 0.0 { 0.02 } else { 0.04 };
        assert!(
            (m[k] / (exact * factor) - 1.0).abs() < tol,
            "t = {} species {} select {}: {} vs {}",
            t[k],
            sp[k],
            sel[k],
            m[k],
            exact * factor
        );
    }

    let h = van_hove::compute(
        &traj,
        &van_hove::Params {
            lags: vec![1.0],
            bin: 0.05,
            range: 5.0,
            species: None,
            rel_tol: 1e-6,
        },
    )
    .unwrap();
    let (dx, pdx) = (col(&h, "dx"), col(&h, "P"));
    let var = 2.0 * d;
    let bin = dx[1] - dx[0];
    let norm: f64 = pdx.iter().sum::<f64>() * bin;
    let second: f64 = dx.iter().zip(&pdx).map(|(x, p)| x * x * p).sum::<f64>() * bin;
    assert!((norm - 1.0).abs() < 1e-3, "normalisation {norm}");
    assert!(
        (second / var - 1.0).abs() < 0.03,
        "<dx^2> = {second}, expected {var}"
    );
    let centre = pdx[dx.len() / 2 - 1..dx.len() / 2 + 1].iter().sum::<f64>() / 2.0;
    let gauss0 = 1.0 / (2.0 * PI * var).sqrt();
    assert!(
        (centre / gauss0 - 1.0).abs() < 0.03,
        "P(0) = {centre}, Gaussian {gauss0}"
    );
}

#[test]
fn ballistic_msd_is_v2_t2() {
    let times = schedule_times(3, 5.0, 0.01, 3.0);
    let traj = ballistic(500, [40.0, 40.0], &times, 9);
    let f = &traj.frames[0];
    let v2: f64 =
        f.vx.iter()
            .zip(&f.vy)
            .map(|(a, b)| a * a + b * b)
            .sum::<f64>()
            / 500.0;
    let b = msd::compute(
        &traj,
        &msd::Params {
            lags: Some(vec![0.01, 3.0]),
            ..Default::default()
        },
    )
    .unwrap();
    for ((t, s), m) in col(&b, "t")
        .iter()
        .zip(col(&b, "species"))
        .zip(col(&b, "msd"))
    {
        if s < 0.0 {
            assert!(
                (m / (v2 * t * t) - 1.0).abs() < 1e-9,
                "t = {t}: {m} vs {}",
                v2 * t * t
            );
        }
    }
}

#[test]
fn tau_alpha_matches_the_random_walk_overlap() {
    // Q(t) = P(|dr| < a) = 1 - exp(-a^2 / 4Dt): Q = 1/e at a^2 / (4 D ln(e / (e - 1))).
    let (d, a) = (0.05, 0.6);
    let exact = a * a / (4.0 * d * (std::f64::consts::E / (std::f64::consts::E - 1.0)).ln());
    let times = schedule_times(20, 40.0, 0.1, 30.0);
    let traj = random_walk(3000, [60.0, 60.0], &times, d, 21);
    let p = overlap::Params {
        a,
        ..Default::default()
    };
    let lags = Schedule::log_lags(0.1, 30.0, 8);
    let p = overlap::Params {
        lags: Some(lags),
        ..p
    };
    let tau = overlap::tau_alpha(&[&traj], &p).unwrap();
    eprintln!("tau_alpha = {} +- {}, exact {exact}", tau.value, tau.err);
    assert!(tau.err > 0.0 && tau.err < 0.02 * exact);
    assert!((tau.value - exact).abs() < 0.03 * exact);

    // Aging check: every origin gives its own curve; the stationary walk shows none.
    let (_, ag) = overlap::aging(&[&traj], &p).unwrap();
    let per_origin = col(&ag, "tau_alpha");
    let finite: Vec<f64> = per_origin
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    assert!(finite.len() >= 20);
    assert!(
        finite.iter().all(|v| (v - exact).abs() < 0.1 * exact),
        "{finite:?}"
    );
}

#[test]
fn bad_parameters_are_clear_errors() {
    let traj = independent_slow(100, [10.0, 10.0], 2, 0.5, 1.0, 1);
    let e = err_text(overlap::compute(
        &traj,
        &overlap::Params {
            a: 0.0,
            ..Default::default()
        },
    ));
    assert!(e.contains("`a`") && e.contains("> 0"), "{e}");
    let e = err_text(chi4::compute(
        &traj,
        &chi4::Params {
            a: 0.6,
            n: vec![1e6],
            lags: None,
            rel_tol: 1e-6,
        },
    ));
    assert!(e.contains("N = 1000000") && e.contains("(0, 100]"), "{e}");
    let e = err_text(overlap::compute(
        &traj,
        &overlap::Params {
            lags: Some(vec![3.7]),
            ..Default::default()
        },
    ));
    assert!(e.contains("lag 3.7") && e.contains("not realised"), "{e}");
    let e = err_text(s4::compute(
        &traj,
        &s4::Params {
            a: 0.6,
            lags: vec![1.0],
            q_max: 0.1,
            dq: None,
            tolerance: 1e-6,
            rel_tol: 1e-6,
        },
    ));
    assert!(e.contains("q_max"), "{e}");
    let e = err_text(run(
        "chi4",
        serde_json::json!({"n": [10], "bogus": 1}),
        &traj,
    ));
    assert!(e.contains("`chi4`") && e.contains("bogus"), "{e}");
    let e = err_text(run("chi5", serde_json::json!({}), &traj));
    assert!(e.contains("chi5") && e.contains("chi4_peaks"), "{e}");
    // Every kind is dispatched (a missing arm would report an unknown kind).
    for kind in observables::OBSERVABLES.iter().map(|o| o.name) {
        let e = format!(
            "{:#}",
            run(kind, serde_json::json!({"bogus": 1}), &traj).unwrap_err()
        );
        assert!(e.contains(&format!("`{kind}`")), "{kind}: {e}");
    }
}

fn one_frame(x: Vec<f64>, y: Vec<f64>, species: Vec<u8>, l: f64) -> Trajectory {
    Trajectory {
        box_size: [l, l],
        periodic: [true, true],
        species,
        radii: vec![0.5, 0.7],
        masses: vec![1.0, 2.0],
        frames: vec![Frame {
            time: 0.0,
            x,
            y,
            vx: vec![],
            vy: vec![],
        }],
    }
}

#[test]
fn hand_built_clusters_have_exact_sizes_and_rg() {
    // A chain across the boundary (x = 19, 20 = 0, 21 = 1), two touching disks, an
    // isolated disk, and a ring of 20 disks around the box (spans it).
    let mut x = vec![19.0, 20.0, 21.0, 10.0, 11.0, 5.0];
    let mut y = vec![5.0, 5.0, 5.0, 10.0, 10.0, 15.0];
    for k in 0..20 {
        x.push(k as f64);
        y.push(18.0);
    }
    let n = x.len();
    let traj = one_frame(x.clone(), y.clone(), vec![0; n], 20.0);
    let cut = vec![vec![1.5, 1.5], vec![1.5, 1.5]];
    let mut c = clusters::find_clusters(&traj, &x, &y, &vec![true; n], &cut).unwrap();
    c.sort_by_key(|k| k.size);
    assert_eq!(
        c.iter().map(|k| k.size).collect::<Vec<_>>(),
        vec![1, 2, 3, 20]
    );
    assert_eq!(c[0].rg, 0.0);
    assert!((c[1].rg - 0.5).abs() < 1e-12);
    assert!(
        (c[2].rg - (2.0f64 / 3.0).sqrt()).abs() < 1e-12,
        "{}",
        c[2].rg
    );
    assert_eq!(
        c.iter().map(|k| k.spans).collect::<Vec<_>>(),
        vec![false, false, false, true]
    );
}

/// O(N^2) reference: depth-first search with minimum-image bonds, unwrapping as it goes.
fn brute_clusters(traj: &Trajectory, cut: &[Vec<f64>]) -> Vec<(usize, f64)> {
    let f = &traj.frames[0];
    let l = traj.box_size[0];
    let n = traj.n();
    let img = |v: f64| v - l * (v / l).round();
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    for s in 0..n {
        if seen[s] {
            continue;
        }
        seen[s] = true;
        let mut stack = vec![(s, [0.0, 0.0])];
        let mut pos = Vec::new();
        while let Some((i, p)) = stack.pop() {
            pos.push(p);
            for j in 0..n {
                let (dx, dy) = (img(f.x[j] - f.x[i]), img(f.y[j] - f.y[i]));
                let rc = cut[traj.species[i] as usize][traj.species[j] as usize];
                if !seen[j] && dx * dx + dy * dy < rc * rc {
                    seen[j] = true;
                    stack.push((j, [p[0] + dx, p[1] + dy]));
                }
            }
        }
        let c = pos.len() as f64;
        let mx = pos.iter().map(|p| p[0]).sum::<f64>() / c;
        let my = pos.iter().map(|p| p[1]).sum::<f64>() / c;
        let rg2 = pos
            .iter()
            .map(|p| (p[0] - mx).powi(2) + (p[1] - my).powi(2))
            .sum::<f64>()
            / c;
        out.push((pos.len(), rg2.sqrt()));
    }
    out.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    out
}

#[test]
fn union_find_equals_brute_force_on_random_configurations() {
    use rand::{RngExt, SeedableRng};
    for seed in 0..4u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (n, l) = (600, 30.0);
        let x: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * l).collect();
        let y: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * l).collect();
        let sp: Vec<u8> = (0..n).map(|_| rng.random_range(0..2u8)).collect();
        let traj = one_frame(x.clone(), y.clone(), sp, l);
        let cut = vec![vec![1.1, 1.3], vec![1.3, 1.5]];
        let mut fast: Vec<(usize, f64)> =
            clusters::find_clusters(&traj, &x, &y, &vec![true; n], &cut)
                .unwrap()
                .iter()
                .map(|c| {
                    assert!(!c.spans);
                    (c.size, c.rg)
                })
                .collect();
        fast.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let slow = brute_clusters(&traj, &cut);
        assert_eq!(fast.len(), slow.len(), "seed {seed}");
        assert!(
            fast.iter().any(|c| c.0 >= 5),
            "seed {seed}: no sizeable cluster"
        );
        for (a, b) in fast.iter().zip(&slow) {
            assert_eq!(a.0, b.0, "seed {seed}");
            assert!(
                (a.1 - b.1).abs() < 1e-9,
                "seed {seed}: Rg {} vs {}",
                a.1,
                b.1
            );
        }
    }
}

#[test]
fn size_distribution_counts_integers_per_log_bin() {
    let d = clusters::size_distribution(&[1, 1, 1, 2, 3, 10], 1).unwrap();
    assert_eq!(d.len(), 2);
    assert!((d[0].1 - 5.0 / (6.0 * 9.0)).abs() < 1e-15 && d[0].2 == 5);
    assert!((d[1].1 - 1.0 / (6.0 * 90.0)).abs() < 1e-15 && d[1].2 == 1);
    assert!((d[0].0 - 3.0).abs() < 1e-12);
}

#[test]
fn ideal_gas_g_is_one_and_minimum_is_found() {
    let traj = independent_slow(3000, [50.0, 50.0], 5, 0.5, 1.0, 2);
    let parts = gr::partials(
        &traj,
        &gr::Params {
            r_max: 5.0,
            bin: 0.1,
            max_frames: 10,
        },
    )
    .unwrap();
    assert_eq!(parts.len(), 3);
    for p in &parts {
        let mean = p.g[10..].iter().sum::<f64>() / (p.g.len() - 10) as f64;
        assert!((mean - 1.0).abs() < 0.02, "g_{}{} mean {mean}", p.a, p.b);
    }
    // A liquid-like g(r): main peak at 1, first minimum at 1.5 exactly.
    let r: Vec<f64> = (0..400).map(|k| 0.5 + k as f64 * 0.01).collect();
    let g: Vec<f64> = r
        .iter()
        .map(|&x| 1.0 + (-(x - 1.0)).exp() * (2.0 * PI * (x - 1.0)).cos())
        .collect();
    let m = gr::first_minimum(&r, &g).unwrap();
    // d/dr [e^-u cos 2 pi u] = 0 at tan(2 pi u) = -1 / (2 pi): u = 0.5 - atan(1/2pi)/2pi.
    let u = 0.5 - (1.0 / (2.0 * PI)).atan() / (2.0 * PI);
    assert!((m - (1.0 + u)).abs() < 0.011, "{m} vs {}", 1.0 + u);
}

#[test]
fn intruder_velocity_and_mobility() {
    // An intruder drifting at v = 0.7 with small Brownian noise among bath particles.
    let times: Vec<f64> = (0..=200).map(|k| k as f64 * 0.5).collect();
    let mut traj = random_walk(50, [30.0, 30.0], &times, 0.01, 4);
    traj.species[0] = 2;
    traj.radii.push(2.0);
    traj.masses.push(4.0);
    for f in &mut traj.frames {
        f.x[0] += 0.7 * f.time;
    }
    let p = intruder::VelocityParams {
        species: 2,
        t_start: 10.0,
        blocks: 10,
        drive: None,
        kick_rate_factor: None,
    };
    let v = intruder::stationary_velocity(&[&traj], &p).unwrap();
    assert!((v.value - 0.7).abs() < 4.0 * v.err && v.err < 0.02, "{v:?}");
    let mu =
        intruder::mobility(&[(1.0, 0.5, 0.1), (2.0, 1.0, 0.1), (1e4, 3.0, 0.1)], 10.0).unwrap();
    assert!((mu.value - 0.5).abs() < 1e-12);
    assert!((mu.err - 0.1 / 5f64.sqrt()).abs() < 1e-12);
    let e = err_text(intruder::compute_profile(
        &traj,
        &intruder::ProfileParams {
            times: vec![1.0],
            bins: 5,
            exclude_species: Some(2),
        },
    ));
    assert!(e.contains("no velocities"), "{e}");
}

#[test]
fn momentum_profile_of_uniform_flow() {
    // Every particle moving at vx = 1: Px = total mass / area in every bin (on average),
    // exactly total mass / area summed over bins times bin width.
    let times = [0.0];
    let mut traj = ballistic(1000, [20.0, 10.0], &times, 3);
    for f in &mut traj.frames {
        f.vx.iter_mut().for_each(|v| *v = 1.0);
    }
    let b = intruder::compute_profile(
        &traj,
        &intruder::ProfileParams {
            times: vec![0.0],
            bins: 4,
            exclude_species: None,
        },
    )
    .unwrap();
    let px = col(&b, "Px");
    let mass: f64 = traj.species.iter().map(|&s| traj.masses[s as usize]).sum();
    let total: f64 = px.iter().sum::<f64>() * 5.0 * 10.0;
    assert!((total - mass).abs() < 1e-9 * mass);
}

#[test]
fn every_kind_runs_from_json_parameters() {
    use serde_json::json;
    let times = schedule_times(4, 20.0, 0.1, 10.0);
    let mut traj = ballistic(400, [30.0, 30.0], &times, 8);
    traj.species[0] = 2;
    traj.radii.push(2.0);
    traj.masses.push(4.0);
    let cut = json!([[1.2, 1.3, 2.0], [1.3, 1.5, 2.0], [2.0, 2.0, 2.5]]);
    let cases = [
        ("overlap", json!({"lags": [0.1, 1.0]}), "Q"),
        ("tau_alpha", json!({"a": 0.6}), "tau_alpha"),
        ("q_levels", json!({"levels": [0.6]}), "t_over_tau_alpha"),
        ("diffusion", json!({"fit_min_tau": 1.0}), "D"),
        ("aging", json!({"lags": [0.1, 1.0]}), "t0"),
        ("chi4", json!({"n": [50, 100], "lags": [1.0]}), "chi4"),
        ("chi4_peaks", json!({"n": [50]}), "tau4"),
        ("s4", json!({"lags": [1.0], "q_max": 1.0}), "S4"),
        ("msd", json!({"fractions": [0.1]}), "msd"),
        ("van_hove", json!({"lags": [1.0]}), "P"),
        ("gr", json!({"r_max": 5.0}), "g"),
        ("clusters", json!({"lags": [1.0], "cutoffs": cut}), "Rg"),
        ("cluster_sizes", json!({"lags": [1.0], "cutoffs": cut}), "P"),
        ("mobility_snapshot", json!({"lags": [1.0]}), "class"),
        ("intruder_velocity", json!({"blocks": 2}), "v"),
        ("intruder_path", json!({}), "x"),
        ("momentum_profile", json!({"times": [1.0], "bins": 6}), "Px"),
        (
            "intruder_diffusion",
            json!({"lag_min": 0.5, "lag_max": 10.0}),
            "D",
        ),
        (
            "velocity_field",
            json!({"times": [1.0], "cells_x": 5}),
            "vx",
        ),
        (
            "front",
            json!({"bin": 2.0, "fit": [0.0, 10.0], "compact": [0.0, 10.0], "wall": {"width": 5.0}}),
            "value",
        ),
    ];
    assert_eq!(cases.len(), observables::OBSERVABLES.len());
    for (kind, params, column) in cases {
        let b = run(kind, params, &traj).unwrap_or_else(|e| panic!("{kind}: {e:#}"));
        assert!(b.num_rows() > 0, "{kind}: empty table");
        assert!(
            col(&b, column).iter().any(|v| v.is_finite()),
            "{kind}: no finite {column}"
        );
    }
}

#[test]
fn log_interpolation_is_exact_for_log_linear_data_and_never_extrapolates() {
    let t = [1.0, 10.0, 100.0];
    let y = [0.0, 1.0, 2.0];
    assert!((stats::interp_log_t(&t, &y, 10f64.sqrt()).unwrap() - 0.5).abs() < 1e-12);
    assert_eq!(stats::interp_log_t(&t, &y, 1000.0), None);
    assert_eq!(stats::interp_log_t(&t, &y, 0.5), None);
}

#[test]
fn aging_of_identical_replicas_is_the_single_replica_curve() {
    // Averaging a replica with itself changes nothing; only true origins are kept.
    let times = schedule_times(5, 40.0, 0.1, 30.0);
    let traj = random_walk(500, [30.0, 30.0], &times, 0.05, 3);
    let p = overlap::Params::default();
    let one = overlap::aging_curves(&[&traj], &p).unwrap();
    let two = overlap::aging_curves(&[&traj, &traj], &p).unwrap();
    assert_eq!(one.len(), 5, "one curve per time origin");
    for (a, b) in one.iter().zip(&two) {
        assert_eq!(a.0, b.0);
        assert_eq!(a.1, b.1);
        for (x, y) in a.2.iter().zip(&b.2) {
            assert!((x - y).abs() < 1e-12);
        }
    }
}

#[test]
fn every_origin_lags_keep_only_lags_each_origin_realises() {
    let times = schedule_times(4, 40.0, 0.1, 30.0);
    let traj = random_walk(50, [30.0, 30.0], &times, 0.05, 3);
    let lags = lags::every_origin(&[&traj], None, 1e-6).unwrap().unwrap();
    let all = lags::select(&[&traj], None, 1e-6).unwrap();
    assert!(!lags.is_empty() && lags.len() < all.len());
    // Kept: lags with at least one pair per origin; dropped: the rest.
    for l in &all {
        let kept = lags.contains(&l.t);
        assert_eq!(
            l.pairs.len() >= 4,
            kept,
            "lag {} with {} pairs",
            l.t,
            l.pairs.len()
        );
    }
    // A request is kept as given.
    assert_eq!(
        lags::every_origin(&[&traj], Some(vec![1.0]), 1e-6).unwrap(),
        Some(vec![1.0])
    );
}

#[test]
fn chi4_peaks_table_reports_chi4_at_tau_alpha_inside_the_lags() {
    let times = schedule_times(10, 60.0, 0.1, 50.0);
    let traj = random_walk(800, [40.0, 40.0], &times, 0.05, 5);
    let mut p = chi4::Params {
        a: 0.6,
        n: vec![100.0, 5000.0],
        lags: None,
        rel_tol: 1e-6,
    };
    chi4::clamp_sizes(&mut p, traj.n());
    assert_eq!(p.n, vec![100.0, 800.0]);
    p.lags = lags::every_origin(&[&traj], None, 1e-6).unwrap();
    let b = chi4::peaks_table(&[&traj], &p).unwrap();
    let ta = col(&b, "tau_alpha");
    assert!(ta[0].is_finite() && ta[0] > 0.0);
    let c = chi4::compute_pooled(&[&traj], &p).unwrap();
    let (n, t, chi) = (col(&c, "N"), col(&c, "t"), col(&c, "chi4"));
    let rows: Vec<usize> = (0..n.len()).filter(|&i| n[i] == 100.0).collect();
    let ts: Vec<f64> = rows.iter().map(|&i| t[i]).collect();
    let cs: Vec<f64> = rows.iter().map(|&i| chi[i]).collect();
    let k = ts.partition_point(|&x| x <= ta[0]);
    let (lo, hi) = (cs[k - 1].min(cs[k]), cs[k - 1].max(cs[k]));
    let at = col(&b, "chi4_tau_alpha")[0];
    assert!(
        at >= lo - 1e-12 && at <= hi + 1e-12,
        "{at} not in [{lo}, {hi}]"
    );
}

#[test]
fn times_in_units_of_tau_alpha_pick_the_nearest_lag_and_never_extrapolate() {
    let lags = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0];
    let tau = 1.1;
    let r = lags::in_units(&lags, tau, "tau_alpha", &[1.0, 0.1, 8.5], 1e-6).unwrap();
    assert_eq!(r[0].lag, 1.0);
    assert!((r[0].rel_diff - (1.0 / 1.1 - 1.0)).abs() < 1e-12);
    assert_eq!(r[1].lag, 0.1);
    assert!((r[1].requested - 0.11).abs() < 1e-12);
    // 8.5 x 1.1 = 9.35: nearest in ln t is 10.
    assert_eq!(r[2].lag, 10.0);
    // 10 tau_alpha = 11 > 10: refused, with the numbers.
    let e = err_text(lags::in_units(&lags, tau, "tau_alpha", &[10.0], 1e-6));
    assert!(
        e.contains("10 tau_alpha") && e.contains("extrapolate"),
        "{e}"
    );
    let e = err_text(lags::in_units(&lags, tau, "tau_alpha", &[0.05], 1e-6));
    assert!(e.contains("outside the recorded lags"), "{e}");
    let e = err_text(lags::in_units(&lags, f64::NAN, "tau_alpha", &[1.0], 1e-6));
    assert!(e.contains("not a positive time"), "{e}");
}

/// An intruder (species 2) drifting at `v(t)` with weak noise among random
/// walkers of paper I's bath species (radii 1 : 1.25, masses 1 : 25/16, 50:50).
fn drifting_intruder(v: impl Fn(f64) -> f64, seed: u64) -> Trajectory {
    let times: Vec<f64> = (0..=400).map(|k| k as f64 * 0.25).collect();
    let mut traj = random_walk(61, [30.0, 30.0], &times, 0.01, seed);
    traj.radii = vec![1.0, 1.25, 2.0];
    traj.masses = vec![1.0, 25.0 / 16.0, 4.0];
    traj.species[0] = 2;
    // x(t) = integral of v from 0 to t (trapezoids on a fine grid).
    for f in &mut traj.frames {
        let k = 1000;
        let h = f.time / k as f64;
        let x: f64 = (0..k)
            .map(|j| 0.5 * h * (v(j as f64 * h) + v((j + 1) as f64 * h)))
            .sum();
        f.x[0] += x;
    }
    traj
}

fn velocity_row(traj: &Trajectory, drive: Option<intruder::DriveParams>) -> RecordBatch {
    let p = intruder::VelocityParams {
        species: 2,
        t_start: 0.0,
        blocks: 10,
        drive,
        kick_rate_factor: None,
    };
    intruder::velocity_table(&[traj], &p).unwrap()
}

/// The first value of column `name`.
fn first(b: &RecordBatch, name: &str) -> f64 {
    col(b, name)[0]
}

#[test]
fn intruder_stationarity_flags_a_transient_and_reports_the_bath() {
    // Steady drift: the halves agree, flagged stationary; the bath (random
    // walkers) does not drift, so v_rel = v.
    let steady = velocity_row(&drifting_intruder(|_| 0.5, 7), None);
    assert_eq!(first(&steady, "stationary"), 1.0);
    assert!((first(&steady, "v") - 0.5).abs() < 4.0 * first(&steady, "v_err"));
    assert!(first(&steady, "v_bath").abs() < 4.0 * first(&steady, "v_bath_err"));
    assert!((first(&steady, "v_rel") - first(&steady, "v")).abs() < 0.02);
    assert!((first(&steady, "snr") - first(&steady, "v") / first(&steady, "v_err")).abs() < 1e-12);
    // 30 small, 30 large, the intruder (disk 0 was small).
    let m = 30.0 + 30.0 * 25.0 / 16.0 + 4.0;
    assert!(
        (first(&steady, "mass_total") - m).abs() < 1e-9,
        "{}",
        first(&steady, "mass_total")
    );
    // A transient still running (v relaxing from 0 to 0.5 with time constant 30):
    // the halves differ and the point is flagged, not silently averaged.
    let relaxing = velocity_row(
        &drifting_intruder(|t| 0.5 * (1.0 - (-t / 30.0).exp()), 7),
        None,
    );
    assert_eq!(first(&relaxing, "stationary"), 0.0);
    assert!(first(&relaxing, "v_second") > first(&relaxing, "v_first"));
}

#[test]
fn intruder_drive_velocity_is_eq7_of_paper_i() {
    // v_dr = p_dr / m_eff with the golden p_dr of eps = 0.9, T = gamma = 1 at
    // eta = 0.3, 0.6, 0.8 (Enskog rates 0.9423, 4.876, 22.82), m_eff = 25/41.
    let traj = drifting_intruder(|_| 0.0, 1);
    let d = intruder::DriveParams {
        eps: 0.9,
        gamma: 1.0,
        temperature: 1.0,
    };
    for (eta, v) in [(0.3, 2.697), (0.6, 1.287), (0.8, 0.774)] {
        let got = intruder::drive_velocity(&traj, eta, &d);
        assert!((got - v).abs() < 2e-3, "eta {eta}: v_dr {got} vs {v}");
    }
    // The table's scaled columns of Fig. 5 at the box's own packing fraction.
    let row = velocity_row(&traj, Some(d.clone()));
    let eta = intruder::packing_fraction(&traj);
    let v_dr = intruder::drive_velocity(&traj, eta, &d);
    assert!((first(&row, "v_dr") - v_dr).abs() < 1e-12);
    assert!((first(&row, "vdr2_sqrt_eta") - v_dr * v_dr * eta.sqrt()).abs() < 1e-12);
    assert!((first(&row, "v_over_vdr") - first(&row, "v") / v_dr).abs() < 1e-12);
}

#[test]
fn intruder_kick_columns_follow_the_enskog_rate_and_the_drift() {
    // The force-kick interval is 1 / (factor x the bath's Enskog rate) at the
    // drive's T (the simulation's rule), and the collision momentum is the
    // reduced mass times the relative speed: thermal at rest, ~ m_red v at speed.
    let d = intruder::DriveParams {
        eps: 0.9,
        gamma: 1.0,
        temperature: 1.0,
    };
    let p = |k: Option<f64>, drive: Option<intruder::DriveParams>| intruder::VelocityParams {
        species: 2,
        t_start: 0.0,
        blocks: 10,
        drive,
        kick_rate_factor: k,
    };
    let (slow, fast) = (
        drifting_intruder(|_| 0.0, 3),
        drifting_intruder(|_| 50.0, 3),
    );
    let row = |t: &Trajectory, k: f64| {
        intruder::velocity_table(&[t], &p(Some(k), Some(d.clone()))).unwrap()
    };
    let (a, b) = (row(&slow, 1e4), row(&slow, 1e2));
    // Rate factor 100 times smaller: interval 100 times longer.
    assert!((first(&b, "kick_dt") / first(&a, "kick_dt") - 100.0).abs() < 1e-9);
    let v_dr = first(&a, "v_dr");
    let eta = intruder::packing_fraction(&slow);
    let omega = crate::sim::enskog::collision_frequency(
        eta,
        &[1.0, 1.25],
        &[1.0, 25.0 / 16.0],
        &[0.5, 0.5],
        1.0,
    );
    assert!((first(&a, "kick_dt") * 1e4 * omega - 1.0).abs() < 1e-12);
    assert!(v_dr > 0.0);
    // 30 small and 30 large disks: mean bath mass (1 + 25/16) / 2, intruder 4.
    let mb = (1.0 + 25.0 / 16.0) / 2.0;
    let m_red = 4.0 * mb / (4.0 + mb);
    let v0 = first(&a, "v");
    let want = m_red * (v0 * v0 + 2.0 / m_red).sqrt();
    assert!((first(&a, "collision_momentum") - want).abs() < 1e-12);
    let c = row(&fast, 1e4);
    let ratio = first(&c, "collision_momentum") / (m_red * 50.0);
    assert!((ratio - 1.0).abs() < 0.01, "{ratio}");
    // Without the drive's T there is no Enskog rate: a clear error.
    let e = intruder::velocity_table(&[&slow], &p(Some(1e4), None)).unwrap_err();
    assert!(
        e.to_string().contains("`kick_rate_factor` needs `drive"),
        "{e}"
    );
    let e = intruder::velocity_table(&[&slow], &p(Some(0.0), Some(d.clone()))).unwrap_err();
    assert!(e.to_string().contains("must be positive"), "{e}");
}

#[test]
fn intruder_diffusion_recovers_d_and_needs_a_lag_window() {
    // A Brownian intruder with D = 0.3 (random-walk frames, no velocities: T_x NaN).
    let times: Vec<f64> = (0..=600).map(|k| k as f64 * 0.5).collect();
    let trajs: Vec<_> = (0..4)
        .map(|s| {
            let mut t = random_walk(20, [40.0, 40.0], &times, 0.3, 10 + s);
            t.radii.push(2.0);
            t.masses.push(4.0);
            t.species[0] = 2;
            t
        })
        .collect();
    let refs: Vec<&Trajectory> = trajs.iter().collect();
    let p = intruder::DiffusionParams {
        species: 2,
        lag_min: 1.0,
        lag_max: 10.0,
    };
    let b = intruder::diffusion_table(&refs, &p).unwrap();
    let get = |n: &str| first(&b, n);
    let (d, e) = (get("D"), get("D_err"));
    assert!((d - 0.3).abs() < 4.0 * e && e < 0.05, "D = {d} +- {e}");
    assert!(get("T_x").is_nan());
    let bad = intruder::DiffusionParams {
        lag_min: 5.0,
        lag_max: 5.0,
        ..p.clone()
    };
    let msg = err_text(intruder::diffusion_table(&refs, &bad));
    assert!(msg.contains("lag_min < lag_max"), "{msg}");
    let none = intruder::DiffusionParams {
        lag_min: 1000.0,
        lag_max: 2000.0,
        ..p
    };
    let msg = err_text(intruder::diffusion_table(&refs, &none));
    assert!(msg.contains("fewer than three frame pairs"), "{msg}");
}

#[test]
fn aging_tau_alpha_error_is_the_replica_jackknife() {
    // One waiting time is one origin per replica: leaving one of two replicas out
    // leaves the other, so the jackknife error is half the two replicas' difference.
    let times = schedule_times(5, 40.0, 0.1, 30.0);
    let slow = random_walk(2000, [50.0, 50.0], &times, 0.05, 3);
    let fast = random_walk(2000, [50.0, 50.0], &times, 0.1, 4);
    let p = overlap::Params {
        lags: Some(Schedule::log_lags(0.1, 30.0, 8)),
        ..Default::default()
    };
    let tau_of = |trajs: &[&Trajectory]| {
        let (_, ag) = overlap::aging(trajs, &p).unwrap();
        (col(&ag, "tau_alpha"), col(&ag, "tau_alpha_err"))
    };
    let (ts, es) = tau_of(&[&slow]);
    let (tf, _) = tau_of(&[&fast]);
    let (tb, eb) = tau_of(&[&slow, &fast]);
    assert!(
        es.iter().all(|e| e.is_nan()),
        "one replica has no error: {es:?}"
    );
    let mut checked = 0;
    for i in 0..tb.len() {
        if !(ts[i].is_finite() && tf[i].is_finite()) {
            continue;
        }
        let want = (ts[i] - tf[i]).abs() / 2.0;
        assert!(
            want > 0.0 && (eb[i] - want).abs() < 1e-9 * want,
            "{} vs {want}",
            eb[i]
        );
        // The slower walk relaxes later; the pooled tau lies between the two.
        assert!(ts[i] > tf[i] && tb[i] < ts[i] && tb[i] > tf[i]);
        checked += 1;
    }
    assert_eq!(checked, 5);
    let (_, same) = tau_of(&[&slow, &slow]);
    assert!(
        same.iter().all(|&e| e == 0.0),
        "identical replicas: {same:?}"
    );
}

/// Every column paper I's intruder analyses write, and every column the intruder
/// pipelines derive in their joins (`derive: - {name: ...}`), has a unit and a
/// description in src/table/columns.rs.
#[test]
fn every_intruder_column_is_described() {
    let d = intruder::DriveParams {
        eps: 0.9,
        gamma: 1.0,
        temperature: 1.0,
    };
    let traj = drifting_intruder(|_| 0.5, 3);
    let p = intruder::VelocityParams {
        species: 2,
        t_start: 0.0,
        blocks: 10,
        drive: Some(d),
        kick_rate_factor: Some(1e4),
    };
    let mut tables = vec![
        intruder::velocity_table(&[&traj], &p).unwrap(),
        intruder::compute_path(&traj, &p).unwrap(),
        intruder::diffusion_table(
            &[&traj, &traj],
            &intruder::DiffusionParams {
                species: 2,
                lag_min: 1.0,
                lag_max: 10.0,
            },
        )
        .unwrap(),
    ];
    let mut moving = ballistic(200, [20.0, 10.0], &[0.0], 3);
    moving.frames[0].vx.iter_mut().for_each(|v| *v = 1.0);
    tables.push(
        intruder::compute_profile(
            &moving,
            &intruder::ProfileParams {
                times: vec![0.0],
                bins: 4,
                exclude_species: None,
            },
        )
        .unwrap(),
    );
    let mut names: Vec<String> = tables
        .iter()
        .flat_map(|b| {
            b.schema()
                .fields()
                .iter()
                .map(|f| f.name().clone())
                .collect::<Vec<_>>()
        })
        .collect();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    for k in 1..=6 {
        let text = std::fs::read_to_string(dir.join(format!("intruder-fig{k}.yaml"))).unwrap();
        let spec: serde_json::Value = serde_saphyr::from_str(&text).unwrap();
        for stage in spec["stages"].as_array().unwrap() {
            for dv in stage["params"]["derive"].as_array().into_iter().flatten() {
                names.push(dv["name"].as_str().unwrap().to_string());
            }
        }
    }
    assert!(
        names.iter().any(|n| n == "kick_over_collision"),
        "{names:?}"
    );
    for n in &names {
        assert!(
            crate::table::columns::describe(n).is_some(),
            "column `{n}` has no row in src/table/columns.rs"
        );
    }
}
