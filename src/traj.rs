//! The trajectory: what a simulation stage hands to every analysis stage.
//!
//! Positions are *unwrapped* (a particle that crossed a periodic boundary keeps
//! moving away from its start), so displacements are plain differences. The box is
//! still given so analyses can fold positions back for sub-boxes, cells and FFTs.

/// One recorded configuration.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Frame {
    /// Simulated time of this frame (units: r1 sqrt(m1/T), T = 1).
    pub time: f64,
    /// Unwrapped x coordinate of every particle (units: r1).
    pub x: Vec<f64>,
    /// Unwrapped y coordinate of every particle (units: r1).
    pub y: Vec<f64>,
    /// Velocity x component of every particle; empty unless the run records velocities.
    pub vx: Vec<f64>,
    /// Velocity y component of every particle; empty unless the run records velocities.
    pub vy: Vec<f64>,
}

/// A recorded run: static particle data plus frames in increasing time.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    /// Box side lengths [Lx, Ly] (units: r1). The box spans [0, Lx) x [0, Ly).
    pub box_size: [f64; 2],
    /// Whether each axis is periodic (false: hard walls at 0 and L).
    pub periodic: [bool; 2],
    /// Species index of every particle (0 = small, 1 = large, 2 = intruder, ...).
    pub species: Vec<u8>,
    /// Radius of each species, indexed by species (units: r1).
    pub radii: Vec<f64>,
    /// Mass of each species, indexed by species (units: m1).
    pub masses: Vec<f64>,
    /// Frames in increasing time.
    pub frames: Vec<Frame>,
    /// The schedule the frames were recorded on, when known (every simulation
    /// records it). It says which frames are time origins: a lag is then served
    /// only by pairs (origin, origin + lag), so every lag of the schedule has one
    /// pair per origin and no lag is made of frames of two different origins.
    pub schedule: Option<Schedule>,
}

impl Trajectory {
    /// Number of particles.
    pub fn n(&self) -> usize {
        self.species.len()
    }

    /// Packing fraction: total disk area over box area.
    pub fn packing_fraction(&self) -> f64 {
        let area: f64 = self
            .species
            .iter()
            .map(|&s| std::f64::consts::PI * self.radii[s as usize].powi(2))
            .sum();
        area / (self.box_size[0] * self.box_size[1])
    }

    /// Recorded times.
    pub fn times(&self) -> Vec<f64> {
        self.frames.iter().map(|f| f.time).collect()
    }
}

/// When frames are recorded: blocks of log-spaced lags after evenly spaced origins.
///
/// Frame times are `start + k * origin_spacing + lag` for every origin `k` in
/// `0..origins` and every `lag` in `lags` (lag 0 is always included). This serves
/// averages over time origins (many `k`) at log-spaced lags (0.01 to 10 tau_alpha)
/// without storing every frame of a long run.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Schedule {
    /// Simulated time of the first origin (after relaxation).
    pub start: f64,
    /// Number of time origins (0: no frames; production then lasts `start`,
    /// for runs that only want the summary, as `repro sim`).
    pub origins: usize,
    /// Spacing between consecutive origins.
    pub origin_spacing: f64,
    /// Lags after each origin (positive; 0 is implied).
    pub lags: Vec<f64>,
}

impl Schedule {
    /// `per_decade` log-spaced lags from `min` to `max` inclusive.
    pub fn log_lags(min: f64, max: f64, per_decade: usize) -> Vec<f64> {
        assert!(min > 0.0 && max >= min && per_decade > 0);
        let decades = (max / min).log10();
        let n = (decades * per_decade as f64).round() as usize;
        (0..=n)
            .map(|i| min * 10f64.powf(decades * i as f64 / n.max(1) as f64))
            .collect()
    }

    /// All frame times, sorted, with coincident times (within 1e-12 relative) merged.
    pub fn times(&self) -> Vec<f64> {
        let mut t: Vec<f64> = Vec::new();
        for k in 0..self.origins {
            let t0 = self.start + k as f64 * self.origin_spacing;
            t.push(t0);
            t.extend(self.lags.iter().map(|l| t0 + l));
        }
        t.sort_by(f64::total_cmp);
        t.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs().max(1.0));
        t
    }

    /// The same recorded window (first origin to last frame, so the same
    /// simulated time) with origins every `spacing` instead of `origin_spacing`:
    /// blocks of the same lags that overlap when `spacing` is shorter than the
    /// longest lag, so every lag is realised by more time origins at the same cost
    /// (and more stored frames).
    pub fn overlapping(&self, spacing: f64) -> Schedule {
        assert!(spacing > 0.0 && spacing.is_finite());
        let span = self.origins.saturating_sub(1) as f64 * self.origin_spacing;
        Schedule {
            origins: if self.origins == 0 {
                0
            } else {
                // The slack keeps a last origin that lands exactly on the span.
                (span / spacing + 1e-9).floor() as usize + 1
            },
            origin_spacing: spacing,
            ..self.clone()
        }
    }

    /// Time of the last frame.
    pub fn end(&self) -> f64 {
        self.times().last().copied().unwrap_or(self.start)
    }
}

impl Trajectory {
    /// Index pairs (i, j), i < j, of frames separated by `lag` within `rel_tol * lag`:
    /// the time origins analyses average over at that lag. With a known
    /// [`Schedule`], i runs over the schedule's origins only (frame j may belong to a
    /// later origin's block when the blocks overlap); without one, over every frame.
    pub fn pairs_at_lag(&self, lag: f64, rel_tol: f64) -> Vec<(usize, usize)> {
        let t = self.times();
        let partner = |i: usize| {
            let target = t[i] + lag;
            let j = t.partition_point(|&x| x < target - rel_tol * lag);
            (j < t.len() && j > i && (t[j] - target).abs() <= rel_tol * lag).then_some((i, j))
        };
        match &self.schedule {
            Some(s) => self
                .origin_frames(s)
                .into_iter()
                .filter_map(partner)
                .collect(),
            None => (0..t.len()).filter_map(partner).collect(),
        }
    }

    /// Indices of the frames at the origins of `s` (an origin with no frame, say a
    /// trajectory cut short, is skipped).
    fn origin_frames(&self, s: &Schedule) -> Vec<usize> {
        let t = self.times();
        (0..s.origins)
            .filter_map(|k| {
                let t0 = s.start + k as f64 * s.origin_spacing;
                // Far below any lag, far above the rounding of a recorded time.
                let tol = 1e-9 * t0.abs().max(1.0);
                let i = t.partition_point(|&x| x < t0 - tol);
                (i < t.len() && (t[i] - t0).abs() <= tol).then_some(i)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One disk at rest, recorded at every time of `s`.
    fn at_rest(s: &Schedule) -> Trajectory {
        Trajectory {
            box_size: [1.0, 1.0],
            periodic: [true, true],
            species: vec![0],
            radii: vec![1.0],
            masses: vec![1.0],
            frames: s
                .times()
                .into_iter()
                .map(|time| Frame {
                    time,
                    x: vec![0.0],
                    y: vec![0.0],
                    vx: vec![],
                    vy: vec![],
                })
                .collect(),
            schedule: Some(s.clone()),
        }
    }

    #[test]
    fn schedule_pairs_cover_every_origin() {
        let s = Schedule {
            start: 10.0,
            origins: 4,
            origin_spacing: 50.0,
            lags: Schedule::log_lags(0.1, 10.0, 5),
        };
        let traj = at_rest(&s);
        assert_eq!(s.lags.len(), 11);
        for &lag in &s.lags {
            assert_eq!(traj.pairs_at_lag(lag, 1e-6).len(), 4, "lag {lag}");
        }
        assert!(traj.pairs_at_lag(0.37, 1e-6).is_empty());
    }

    /// Overlapping origins: same last frame (same simulated time), four times the
    /// origins, and every lag realised by at least every origin.
    #[test]
    fn overlapping_origins_keep_the_window_and_multiply_the_pairs() {
        let s = Schedule {
            start: 5.0,
            origins: 4,
            origin_spacing: 20.0,
            lags: Schedule::log_lags(0.1, 50.0, 4),
        };
        let o = s.overlapping(5.0);
        assert_eq!(o.origins, 13);
        assert!(
            (o.end() - s.end()).abs() < 1e-9,
            "{} vs {}",
            o.end(),
            s.end()
        );
        assert!(o.times().len() > 3 * s.times().len());
        let (a, b) = (at_rest(&s), at_rest(&o));
        for &lag in &s.lags {
            let (na, nb) = (
                a.pairs_at_lag(lag, 1e-9).len(),
                b.pairs_at_lag(lag, 1e-9).len(),
            );
            assert!(na >= 4 && nb >= 13, "lag {lag}: {na} and {nb} origins");
        }
        assert_eq!(
            s.overlapping(20.0),
            s,
            "the same spacing is the same schedule"
        );
    }

    /// With the schedule known, a lag is served from origins only: each of the
    /// schedule's lags once per origin, and the origin spacing (a difference between
    /// frames of two origins) only by origins that have a frame one spacing later;
    /// without it, every frame that has a partner counts.
    #[test]
    fn a_known_schedule_pairs_origins_with_their_own_lags() {
        let s = Schedule {
            start: 2.0,
            origins: 6,
            origin_spacing: 0.5,
            lags: Schedule::log_lags(0.1, 3.0, 6),
        };
        let traj = at_rest(&s);
        for &lag in &s.lags {
            let p = traj.pairs_at_lag(lag, 1e-6);
            assert_eq!(p.len(), 6, "lag {lag}: {p:?}");
            assert!(p.iter().all(|&(i, _)| {
                let k = (traj.frames[i].time - 2.0) / 0.5;
                (k - k.round()).abs() < 1e-9
            }));
        }
        let is_origin = |i: usize| {
            let k = (traj.frames[i].time - 2.0) / 0.5;
            (k - k.round()).abs() < 1e-9
        };
        let spacing = traj.pairs_at_lag(0.5, 1e-6);
        assert!(spacing.iter().all(|&(i, _)| is_origin(i)), "{spacing:?}");
        let blind = Trajectory {
            schedule: None,
            ..traj.clone()
        };
        assert!(blind.pairs_at_lag(0.5, 1e-6).len() > spacing.len());
    }
}
