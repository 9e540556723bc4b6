//! The analysed window of a run. Paper H: "for each packing fraction we select
//! for the analysis the time window such that the system is in a steady state".
//! The rule that chooses it per phi ([`steady_window`]) reads the trends of
//! tau_alpha(t0), T and P (`pipelines/stationarity.yaml`); where the start of
//! production is not steady, its earliest time origins are left out
//! ([`skip_origins`]) of every analysis of the experiment's runs.

use anyhow::{Result, bail};

use crate::traj::{Schedule, Trajectory};

/// The trajectory from its origin `floor(fraction x origins)` on: the earlier
/// origins and the frames before that origin are dropped, so that no pair of
/// frames starts in the left-out window. Needs the run's schedule.
pub fn skip_origins(traj: &Trajectory, fraction: f64) -> Result<Trajectory> {
    if !(fraction.is_finite() && (0.0..1.0).contains(&fraction)) {
        bail!("`skip_origins` is the fraction of time origins left out, in [0, 1); got {fraction}");
    }
    let Some(s) = &traj.schedule else {
        bail!(
            "`skip_origins` needs the run's schedule of time origins (every simulation records one; this trajectory has none)"
        );
    };
    let skip = (fraction * s.origins as f64).floor() as usize;
    if skip == 0 {
        return Ok(traj.clone());
    }
    if skip >= s.origins {
        bail!(
            "`skip_origins: {fraction}` leaves none of the {} time origins",
            s.origins
        );
    }
    let start = s.start + skip as f64 * s.origin_spacing;
    let tol = 1e-12 * start.abs().max(1.0);
    Ok(Trajectory {
        frames: traj
            .frames
            .iter()
            .filter(|f| f.time >= start - tol)
            .cloned()
            .collect(),
        schedule: Some(Schedule {
            start,
            origins: s.origins - skip,
            ..s.clone()
        }),
        ..traj.clone()
    })
}

/// The relative change of a sampled quantity x(t) between the halves of
/// `[start, end]` (second half's mean minus the first's, over the mean), with
/// its error from `blocks` equal blocks in time: the scatter of the block means
/// about their half's mean (`blocks - 2` degrees of freedom), so that samples
/// correlated over less than a block count once. None when a block is empty.
pub fn halves_drift(
    t: &[f64],
    x: &[f64],
    start: f64,
    end: f64,
    blocks: usize,
) -> Option<(f64, f64)> {
    if blocks < 4 || blocks % 2 != 0 || end <= start {
        return None;
    }
    let width = (end - start) / blocks as f64;
    let mut sums = vec![(0.0, 0usize); blocks];
    for (&ti, &xi) in t.iter().zip(x) {
        if ti < start || ti > end || !xi.is_finite() {
            continue;
        }
        let b = (((ti - start) / width) as usize).min(blocks - 1);
        sums[b].0 += xi;
        sums[b].1 += 1;
    }
    if sums.iter().any(|s| s.1 == 0) {
        return None;
    }
    let means: Vec<f64> = sums.iter().map(|s| s.0 / s.1 as f64).collect();
    let h = blocks / 2;
    let avg = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (m1, m2) = (avg(&means[..h]), avg(&means[h..]));
    let scale = avg(&means).abs();
    let ss: f64 = means[..h].iter().map(|b| (b - m1).powi(2)).sum::<f64>()
        + means[h..].iter().map(|b| (b - m2).powi(2)).sum::<f64>();
    let var = ss / (blocks - 2) as f64;
    Some(((m2 - m1) / scale, (var * 2.0 / h as f64).sqrt() / scale))
}

/// The trends the rule reads over one candidate window at one phi, each in
/// units of its error: tau_alpha(t0) over the kept origins, T and P between
/// the halves of the kept production. NaN: not measured (left out of the rule).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trends {
    pub tau_alpha: f64,
    pub temperature: f64,
    pub pressure: f64,
}

impl Trends {
    /// The largest of the three in size (NaN ones left out; 0 if none is measured).
    pub fn largest(&self) -> f64 {
        [self.tau_alpha, self.temperature, self.pressure]
            .iter()
            .filter(|z| z.is_finite())
            .fold(0.0, |m: f64, z| m.max(z.abs()))
    }
}

/// The window the rule chose at one phi.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    /// The fraction of time origins left out, earliest first ([`skip_origins`]).
    pub skip_origins: f64,
    /// Whether the kept window shows no trend: false when even the late
    /// window does (the run needs a longer relaxation).
    pub steady: bool,
}

/// The rule: the whole production is the window when none of its trends lies
/// beyond `threshold` errors of zero; else its late part (origins from
/// `late_skip` on, the second half of production for T and P) when none of
/// the late trends does; else the late part, marked not steady.
pub fn steady_window(whole: &Trends, late: &Trends, late_skip: f64, threshold: f64) -> Window {
    if whole.largest() <= threshold {
        Window {
            skip_origins: 0.0,
            steady: true,
        }
    } else {
        Window {
            skip_origins: late_skip,
            steady: late.largest() <= threshold,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::independent_slow;

    /// With half the origins left out, exactly the frames of the second half
    /// remain, and the lag keeps one pair per remaining origin.
    #[test]
    fn skipping_origins_leaves_out_exactly_the_early_window() {
        let mut traj = independent_slow(200, [20.0, 20.0], 8, 0.3, 1.0, 3);
        let sched = Schedule {
            start: 0.0,
            origins: 8,
            origin_spacing: 10.0,
            lags: vec![1.0],
        };
        let times: Vec<f64> = traj.frames.iter().map(|f| f.time).collect();
        assert_eq!(sched.times(), times, "the synthetic run's frames");
        traj.schedule = Some(sched);
        let late = skip_origins(&traj, 0.5).unwrap();
        assert_eq!(late.frames.len(), 8);
        assert_eq!(late.frames[0].time, 40.0);
        assert_eq!(late.schedule.as_ref().unwrap().origins, 4);
        assert_eq!(late.pairs_at_lag(1.0, 1e-9).len(), 4);
        assert_eq!(late.frames[..], traj.frames[8..]);
        assert_eq!(skip_origins(&traj, 0.0).unwrap(), traj);
        let e = skip_origins(&traj, 1.0).unwrap_err().to_string();
        assert!(e.contains("[0, 1)"), "{e}");
        traj.schedule = None;
        let e = skip_origins(&traj, 0.5).unwrap_err().to_string();
        assert!(e.contains("schedule"), "{e}");
    }

    /// Uncorrelated noise about a constant: the drift over its error scatters
    /// as a t variable with blocks - 2 degrees of freedom (sd sqrt(6/4) = 1.22
    /// with 8 blocks), and a trend of ten noise errors is seen far beyond 3.
    #[test]
    fn halves_drift_reads_noise_as_noise_and_a_trend_as_a_trend() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let noise = Normal::new(0.0, 0.02).unwrap();
        let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.1).collect();
        let mut zs = Vec::new();
        for _ in 0..400 {
            let x: Vec<f64> = t.iter().map(|_| 1.0 + noise.sample(&mut rng)).collect();
            let (d, e) = halves_drift(&t, &x, 0.0, 40.0, 8).unwrap();
            zs.push(d / e);
        }
        let sd = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
        assert!((1.0..1.45).contains(&sd), "sd of drift/error {sd}");
        let beyond = zs.iter().filter(|z| z.abs() > 3.0).count() as f64 / zs.len() as f64;
        assert!(beyond < 0.05, "beyond 3 errors: {beyond}");
        // The noise error of the halves' difference is 0.02 sqrt(2 / 200) = 0.002.
        let x: Vec<f64> = t
            .iter()
            .map(|&ti| 1.0 + 0.001 * ti + noise.sample(&mut rng))
            .collect();
        let (d, e) = halves_drift(&t, &x, 0.0, 40.0, 8).unwrap();
        assert!((d - 0.0196).abs() < 0.006 && d / e > 3.0, "{d} +- {e}");
        // A window with an empty block, or an odd number of blocks, reads nothing.
        assert!(halves_drift(&t, &x, 0.0, 80.0, 8).is_none());
        assert!(halves_drift(&t, &x, 0.0, 40.0, 7).is_none());
    }

    /// The whole production when it shows no trend; the late part when the
    /// trend is the start's; the late part marked not steady when it lasts.
    #[test]
    fn the_rule_keeps_the_earliest_window_without_a_trend() {
        let calm = Trends {
            tau_alpha: -1.2,
            temperature: 2.9,
            pressure: f64::NAN,
        };
        let early = Trends {
            temperature: 3.5,
            ..calm
        };
        let w = steady_window(&calm, &early, 0.5, 3.0);
        assert_eq!((w.skip_origins, w.steady), (0.0, true));
        let w = steady_window(&early, &calm, 0.5, 3.0);
        assert_eq!((w.skip_origins, w.steady), (0.5, true));
        let lasting = Trends {
            tau_alpha: -4.0,
            ..calm
        };
        let w = steady_window(&early, &lasting, 0.5, 3.0);
        assert_eq!((w.skip_origins, w.steady), (0.5, false));
        assert_eq!(calm.largest(), 2.9);
    }
}
