//! What one simulation is: every model parameter, validated before anything runs.

use crate::traj::Schedule;
use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

/// Close packing of equal disks, pi / sqrt(12): no disk system can be denser.
pub const CLOSE_PACKING: f64 = 0.906_899_682_117_108_9;

/// How the mass of the large disks follows from their radius.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Masses {
    /// Equal mass density: m2/m1 = (r2/r1)^2 (paper H).
    ConstantDensity,
    /// An explicit mass ratio m2/m1.
    Ratio(f64),
}

/// Which particles receive the kicks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Drive {
    /// A random particle and a random particle of its 3x3 cell neighbourhood.
    NeighbourPairs,
    /// Two random particles (momentum conserved globally only).
    RandomPairs,
    /// One random particle at a time (paper I with friction, which removes the
    /// momentum the kicks bring).
    Single,
    /// No driving (elastic gas, free cooling).
    None,
}

/// How often particles are kicked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum KickRate {
    /// Start at the Enskog rate, then during the first 80% of the relaxation
    /// rescale the rate window by window so that the mean kinetic energy per
    /// particle is 1; the rate is then frozen (docs/sim.md explains why).
    Balanced,
    /// The Enskog collision frequency from the Jenkins-Mancini contact values
    /// at `temperature`, as kicks each particle receives per unit time, times
    /// `prefactor` (1 = as is).
    Enskog { prefactor: f64 },
    /// A fixed number of kicks each particle receives per unit time.
    PerParticle(f64),
}

/// An intruder pulled through the fluid (paper I): a third species, one
/// particle (index 0), pulled along +x by a constant force from the start of
/// the relaxation on (during compression it is a passive disk).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intruder {
    /// R_0 (small disks: 1). Paper I: 2.
    #[serde(default = "Intruder::default_radius")]
    pub radius: f64,
    /// m_0 (small disks: 1). Paper I: 4.
    #[serde(default = "Intruder::default_mass")]
    pub mass: f64,
    /// The constant force F along +x (Eqs. 3-4 of paper I), >= 0.
    pub force: f64,
    /// How F acts: `exact` (the curved path, timed by a root finder) or
    /// `kicks` (paper I's algorithm: momentum kicks F dt at regular times).
    #[serde(default)]
    pub force_mode: ForceMode,
    /// With `force_mode: kicks`: the kicks come at this many times the bath's
    /// Enskog collision frequency per particle (paper I: 10^4).
    #[serde(default = "Intruder::default_kick_rate_factor")]
    pub kick_rate_factor: f64,
    /// Start position [x/Lx, y/Ly] (fractions of the box); absent: placed at
    /// random like the disks. A chosen start holds the intruder still during
    /// the compression, so that the relaxation starts there, at rest.
    #[serde(default)]
    pub start: Option<[f64; 2]>,
}

/// How the force on the intruder is applied.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForceMode {
    /// The exact path under force and friction (Eqs. 3-4 of paper I).
    #[default]
    Exact,
    /// A train of momentum kicks F dt along x, dt = 1 / (kick_rate_factor
    /// omega_E): between them the intruder moves like any disk.
    Kicks,
}

impl Intruder {
    fn default_radius() -> f64 {
        2.0
    }
    fn default_mass() -> f64 {
        4.0
    }
    fn default_kick_rate_factor() -> f64 {
        1e4
    }

    /// Paper I's intruder (R_0 = 2, m_0 = 4) pulled by `force`.
    pub fn paper(force: f64) -> Intruder {
        Intruder {
            radius: Self::default_radius(),
            mass: Self::default_mass(),
            force,
            force_mode: ForceMode::Exact,
            kick_rate_factor: Self::default_kick_rate_factor(),
            start: None,
        }
    }
}

/// One simulation. Default: paper H at phi = 0.78, eps = 0.9.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// Number of disks.
    pub n: usize,
    /// Packing fraction (disk area over box area).
    pub phi: f64,
    /// Normal coefficient of restitution, in (0, 1].
    pub eps: f64,
    /// r2/r1 (1 = monodisperse).
    pub radius_ratio: f64,
    pub masses: Masses,
    /// Fraction of large disks.
    pub fraction_large: f64,
    pub drive: Drive,
    pub kick_rate: KickRate,
    /// Collapse guard (TC model): a collision within `collapse_tc` of either disk's
    /// previous collision is elastic. 0 disables the guard.
    pub collapse_tc: f64,
    /// The fraction of production collisions the guard may turn elastic before
    /// the run warns (its summary's `warnings` and its log): beyond it the
    /// dissipation, hence T, depends on `collapse_tc`.
    pub guard_warn: f64,
    /// Ly / Lx.
    pub aspect: f64,
    pub seed: u64,
    /// Driven relaxation before the first frame (simulated time).
    pub relax_time: f64,
    /// Frame times, measured from the end of relaxation.
    pub schedule: Schedule,
    /// Record velocities in the frames.
    pub record_velocities: bool,
    /// Samples of temperature and pressure over relaxation + production.
    pub samples: usize,
    /// Lubachevsky-Stillinger compression: relative radius growth per unit time.
    pub compression_rate: f64,
    /// Viscous friction -gamma m v on every particle (paper I), exact.
    pub gamma: f64,
    /// The temperature the driving holds (Eq. 7 of paper I sets the kick
    /// amplitude for it; paper H: 1). Also the temperature after compression.
    pub temperature: f64,
    /// Hard walls at 0 and L instead of periodic boundaries, per axis [x, y]
    /// (elastic reflection).
    pub walls: [bool; 2],
    /// An intruder (paper I), counted in the packing fraction but not in `n`.
    pub intruder: Option<Intruder>,
    /// Simulation time between checkpoints (default: about 10 minutes of
    /// planned CPU time, [`crate::sim::run::checkpoint::interval`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub checkpoint_every: Option<f64>,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            n: 10_000,
            phi: 0.78,
            eps: 0.9,
            radius_ratio: 1.43,
            masses: Masses::ConstantDensity,
            fraction_large: 0.5,
            drive: Drive::NeighbourPairs,
            kick_rate: KickRate::Balanced,
            collapse_tc: 1e-6,
            guard_warn: 0.01,
            aspect: 1.0,
            seed: 0,
            relax_time: 100.0,
            schedule: Schedule {
                start: 0.0,
                origins: 4,
                origin_spacing: 100.0,
                lags: Schedule::log_lags(0.1, 100.0, 5),
            },
            record_velocities: false,
            samples: 100,
            compression_rate: 0.02,
            gamma: 0.0,
            temperature: 1.0,
            walls: [false, false],
            intruder: None,
            checkpoint_every: None,
        }
    }
}

/// How far apart two disks at contact may be misplaced by rounding (units of
/// the small radius): the engine finds contacts to about this precision.
pub const CONTACT_PRECISION: f64 = 1e-10;

/// Speed (units of sqrt(T/m1)) below which practically every disk moves: the
/// Maxwellian tail beyond 6 thermal speeds holds a fraction exp(-18) of the disks.
const FAST_SPEED: f64 = 6.0;

/// The spacing of f64 numbers near `x` (one unit in the last place).
pub fn ulp(x: f64) -> f64 {
    let x = x.abs();
    f64::from_bits(x.to_bits() + 1) - x
}

fn finite_in(name: &str, v: f64, lo: f64, hi: f64, what: &str) -> Result<()> {
    if !(v.is_finite() && v >= lo && v <= hi) {
        bail!("{name} = {v} is invalid: {what}");
    }
    Ok(())
}

impl SimConfig {
    /// Reject impossible or unsupported values, naming the key and what is valid.
    /// The particles and box come first: the later checks read the box size.
    pub fn validate(&self) -> Result<()> {
        self.check_particles()?;
        self.check_times()?;
        self.check_driving()?;
        self.check_walls()?;
        self.check_intruder()?;
        self.check_precision()?;
        Ok(())
    }

    /// Number, sizes, masses and packing of the disks, restitution, box shape.
    fn check_particles(&self) -> Result<()> {
        if self.n < 2 {
            bail!("n = {} is invalid: need at least 2 disks", self.n);
        }
        if self.n >= (u32::MAX - 16) as usize {
            bail!("n = {} is invalid: at most {} disks", self.n, u32::MAX - 16);
        }
        if !(self.phi.is_finite() && self.phi > 0.0 && self.phi < CLOSE_PACKING) {
            bail!(
                "phi = {} is invalid: the packing fraction must be in (0, {CLOSE_PACKING:.4}) (close packing)",
                self.phi
            );
        }
        if self.phi > 0.85 {
            bail!(
                "phi = {} is out of reach: disordered disks jam near 0.84; use phi <= 0.85",
                self.phi
            );
        }
        if !(self.eps.is_finite() && self.eps > 0.0 && self.eps <= 1.0) {
            bail!(
                "eps = {} is invalid: the restitution coefficient must be in (0, 1]",
                self.eps
            );
        }
        finite_in(
            "radius_ratio",
            self.radius_ratio,
            1.0,
            10.0,
            "r2/r1 must be in [1, 10]",
        )?;
        if let Masses::Ratio(m) = self.masses
            && !(m.is_finite() && m > 0.0)
        {
            bail!("masses: ratio {m} is invalid: m2/m1 must be positive");
        }
        finite_in(
            "fraction_large",
            self.fraction_large,
            0.0,
            1.0,
            "must be in [0, 1]",
        )?;
        finite_in(
            "aspect",
            self.aspect,
            0.01,
            100.0,
            "Ly/Lx must be in [0.01, 100]",
        )?;
        Ok(())
    }

    /// Relaxation, checkpoints, frame schedule, samples and compression.
    fn check_times(&self) -> Result<()> {
        finite_in("relax_time", self.relax_time, 0.0, 1e12, "must be >= 0")?;
        if let Some(every) = self.checkpoint_every {
            finite_in(
                "checkpoint_every",
                every,
                1e-9,
                1e15,
                "the simulation time between checkpoints must be > 0",
            )?;
        }
        finite_in(
            "schedule.start",
            self.schedule.start,
            0.0,
            1e12,
            "must be >= 0",
        )?;
        finite_in(
            "schedule.origin_spacing",
            self.schedule.origin_spacing,
            0.0,
            1e12,
            "must be >= 0",
        )?;
        if self.schedule.origins == 0 && self.schedule.start <= 0.0 {
            bail!("schedule.origins = 0 (no frames) needs schedule.start > 0: the production time");
        }
        for &l in &self.schedule.lags {
            finite_in(
                "schedule.lags entry",
                l,
                f64::MIN_POSITIVE,
                1e12,
                "lags must be positive",
            )?;
        }
        if !(2..=1_000_000).contains(&self.samples) {
            bail!(
                "samples = {} is invalid: need 2 to 1000000 (at least 2 for error bars)",
                self.samples
            );
        }
        if self.schedule.end() <= 0.0 {
            bail!(
                "schedule records nothing after relaxation (last frame at t = {}): give a positive start, origin_spacing or lag",
                self.schedule.end()
            );
        }
        finite_in(
            "compression_rate",
            self.compression_rate,
            1e-7,
            1.0,
            "must be in [1e-7, 1]",
        )?;
        Ok(())
    }

    /// Kick rate, collapse guard, friction, temperature and how they combine.
    fn check_driving(&self) -> Result<()> {
        match self.kick_rate {
            KickRate::Enskog { prefactor } => finite_in(
                "kick_rate: enskog prefactor",
                prefactor,
                0.0,
                1e6,
                "must be >= 0",
            )?,
            KickRate::PerParticle(r) => {
                finite_in("kick_rate: per_particle", r, 0.0, 1e9, "must be >= 0")?
            }
            KickRate::Balanced => {}
        }
        finite_in(
            "collapse_tc",
            self.collapse_tc,
            0.0,
            1.0,
            "must be in [0, 1]",
        )?;
        finite_in(
            "guard_warn",
            self.guard_warn,
            0.0,
            1.0,
            "the fraction of collisions must be in [0, 1]",
        )?;
        finite_in(
            "gamma",
            self.gamma,
            0.0,
            1e6,
            "the friction rate must be in [0, 1e6]",
        )?;
        finite_in(
            "temperature",
            self.temperature,
            1e-12,
            1e12,
            "must be positive",
        )?;
        if self.drive == Drive::Single && self.gamma == 0.0 {
            bail!(
                "drive: single with gamma = 0 is invalid: single-particle kicks without friction heat the system without bound; use gamma > 0 or drive: neighbour_pairs"
            );
        }
        if self.gamma > 0.0 && self.kick_rate == KickRate::Balanced && self.drive != Drive::None {
            bail!(
                "kick_rate: balanced with gamma = {} is invalid: the balanced rule assumes no friction; use kick_rate: {{enskog: {{prefactor: 1}}}} (Eq. 7 of paper I then sets the amplitude for `temperature`)",
                self.gamma
            );
        }
        Ok(())
    }

    /// Walls: the box between them must not jam the compression.
    fn check_walls(&self) -> Result<()> {
        if self.walls != [false, false] {
            // Every walled axis must hold a few large disks side by side at the
            // target packing: the compression would otherwise jam against the walls.
            let box_size = self.box_size();
            let d_large = 2.0 * self.radius_ratio;
            for k in 0..2 {
                if self.walls[k] && box_size[k] < 4.0 * d_large {
                    bail!(
                        "walls = {:?} cannot fit: the box is {:.3} long between the walls of axis {} at phi = {}, less than four large-disk diameters ({:.3}); use more disks or another aspect",
                        self.walls,
                        box_size[k],
                        ["x", "y"][k],
                        self.phi,
                        4.0 * d_large
                    );
                }
            }
        }
        Ok(())
    }

    /// The intruder: its radius, mass, force, kick rate and start.
    fn check_intruder(&self) -> Result<()> {
        let Some(intr) = &self.intruder else {
            return Ok(());
        };
        finite_in(
            "intruder.radius",
            intr.radius,
            0.1,
            100.0,
            "R_0 must be in [0.1, 100] small-disk radii",
        )?;
        finite_in(
            "intruder.mass",
            intr.mass,
            1e-3,
            1e6,
            "m_0 must be in [1e-3, 1e6] small-disk masses",
        )?;
        finite_in(
            "intruder.force",
            intr.force,
            0.0,
            1e12,
            "the force pulls along +x: F must be in [0, 1e12]",
        )?;
        // The engine needs 5 x 5 cells of the largest contact range (its
        // neighbour lists) to follow the intruder.
        let box_size = self.box_size();
        let need = 5.0 * 2.0 * intr.radius.max(self.radius_ratio);
        if box_size[0] < need || box_size[1] < need {
            bail!(
                "intruder.radius = {} is too large for the box ({:.3} x {:.3} at n = {}, phi = {}): each side must hold five intruder diameters ({need:.3}); use more disks or a smaller intruder",
                intr.radius,
                box_size[0],
                box_size[1],
                self.n,
                self.phi
            );
        }
        finite_in(
            "intruder.kick_rate_factor",
            intr.kick_rate_factor,
            1.0,
            1e9,
            "the force kicks come at this multiple of the collision rate: must be in [1, 1e9]",
        )?;
        if let Some(start) = intr.start {
            for k in 0..2 {
                let (f, l) = (start[k], box_size[k]);
                let axis = ["x", "y"][k];
                if !(f.is_finite() && (0.0..1.0).contains(&f)) {
                    bail!(
                        "intruder.start = {start:?} is invalid: the {axis} fraction {f} must be in [0, 1)"
                    );
                }
                if self.walls[k] && (f * l < intr.radius || (1.0 - f) * l < intr.radius) {
                    bail!(
                        "intruder.start = {start:?} overlaps a wall of axis {axis}: the centre at {:.3} of {l:.3} must be at least R_0 = {} from the walls (fraction in [{:.4}, {:.4}])",
                        f * l,
                        intr.radius,
                        intr.radius / l,
                        1.0 - intr.radius / l
                    );
                }
            }
        }
        Ok(())
    }

    /// The simulated time at the end of the run: the longest compression (from
    /// phi = 0.3), relaxation and production.
    pub fn last_time(&self) -> f64 {
        let compress = (1.0 - (0.3f64 / self.phi).min(1.0).sqrt()) / self.compression_rate;
        compress + self.relax_time + self.schedule.end()
    }

    /// The rounding of a position (units of the small radius): half a spacing
    /// of f64 coordinates at the far side of the box.
    pub fn box_precision(&self) -> f64 {
        let [lx, ly] = self.box_size();
        0.5 * ulp(lx.max(ly))
    }

    /// The rounding of a contact through the clock: the distance a fast disk
    /// covers in half a spacing of f64 times at the run's last time (event
    /// times are rounded to it; without friction the clock is never rebased).
    pub fn clock_precision(&self) -> f64 {
        let lightest = self
            .species_masses()
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        0.5 * FAST_SPEED * (self.temperature / lightest).sqrt() * ulp(self.last_time())
    }

    /// Refuse a box so large that f64 positions cannot hold
    /// [`CONTACT_PRECISION`]: contacts would be found at the wrong distance.
    fn check_precision(&self) -> Result<()> {
        let p = self.box_precision();
        if p > CONTACT_PRECISION {
            let [lx, ly] = self.box_size();
            bail!(
                "n = {}, phi = {} is beyond the float precision limit: positions in a box side of {:.4e} small radii are rounded to {p:.2e}, coarser than the contact precision {CONTACT_PRECISION:e}; f64 holds it for box sides below 2^20 = 1048576; use fewer disks or a higher phi",
                self.n,
                self.phi,
                lx.max(ly),
            );
        }
        Ok(())
    }

    /// The warning of a run whose collapse guard turned more than `guard_warn`
    /// of its `collisions` elastic, if it did.
    pub fn guard_warning(&self, activations: u64, collisions: u64) -> Option<String> {
        let fraction = activations as f64 / collisions.max(1) as f64;
        (fraction > self.guard_warn).then(|| {
            format!(
                "the collapse guard acted on {activations} of {collisions} collisions ({fraction:.3e}), more than guard_warn = {}: T and the dynamics depend on collapse_tc = {}",
                self.guard_warn, self.collapse_tc
            )
        })
    }

    /// Radius of each species (small = 1; the intruder, if any, is species 2).
    pub fn radii(&self) -> Vec<f64> {
        let mut r = vec![1.0, self.radius_ratio];
        r.extend(self.intruder.as_ref().map(|i| i.radius));
        r
    }

    /// Mass of each species (small = 1; the intruder, if any, is species 2).
    pub fn species_masses(&self) -> Vec<f64> {
        let m2 = match self.masses {
            Masses::ConstantDensity => self.radius_ratio * self.radius_ratio,
            Masses::Ratio(m) => m,
        };
        let mut m = vec![1.0, m2];
        m.extend(self.intruder.as_ref().map(|i| i.mass));
        m
    }

    /// Number of large disks.
    pub fn n_large(&self) -> usize {
        (self.fraction_large * self.n as f64).round() as usize
    }

    /// Box [Lx, Ly] giving packing fraction phi for the disks (the intruder included).
    pub fn box_size(&self) -> [f64; 2] {
        let nl = self.n_large() as f64;
        let intruder = self.intruder.as_ref().map_or(0.0, |i| i.radius.powi(2));
        let area = std::f64::consts::PI
            * ((self.n as f64 - nl) + nl * self.radius_ratio.powi(2) + intruder);
        let lx = (area / self.phi / self.aspect).sqrt();
        [lx, lx * self.aspect]
    }
}

#[cfg(test)]
mod precision_tests {
    use super::*;

    #[test]
    fn the_paper_box_holds_contact_precision_and_a_huge_box_is_refused() {
        // Paper H's largest system: a box side of a few thousand radii, where
        // f64 positions are good to ~1e-13.
        let paper = SimConfig {
            n: 4_000_000,
            phi: 0.6,
            ..SimConfig::default()
        };
        paper.validate().unwrap();
        assert!(paper.box_precision() < 1e-12, "{}", paper.box_precision());
        // A side beyond 2^20 radii rounds positions coarser than 1e-10.
        let huge = SimConfig {
            n: 100_000_000,
            phi: 1e-4,
            ..SimConfig::default()
        };
        assert!(huge.box_size()[0] > 1_048_576.0);
        let e = format!("{:#}", huge.validate().unwrap_err());
        assert!(
            e.contains("float precision limit") && e.contains("n = 100000000"),
            "{e}"
        );
    }

    #[test]
    fn the_guard_warns_beyond_its_fraction_only() {
        let cfg = SimConfig::default();
        assert!(cfg.guard_warning(10, 10_000).is_none());
        let w = cfg.guard_warning(200, 10_000).unwrap();
        assert!(
            w.contains("guard_warn = 0.01") && w.contains("200 of 10000"),
            "{w}"
        );
    }
}
