//! The analysed window of a run. Paper H: "for each packing fraction we select
//! for the analysis the time window such that the system is in a steady state".
//! Where the start of production is measured not to be stationary
//! (`pipelines/stationarity.yaml`: tau_alpha(t0), T and P over the run), its
//! earliest time origins are left out of every average.

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
}
