//! What a simulation is planned to cost, from its configuration alone: disks,
//! stored frames and collisions (with the measured collision rate over Enskog's),
//! for the executors' resource requests (the `simulate` kind's
//! [`StageKind::plan`](crate::pipeline::StageKind::plan)).

use crate::pipeline::stage::Work;
use crate::sim::SimConfig;

/// Planned work of a `simulate` stage, for Slurm's resource requests: N, the
/// frames it keeps, and its collisions: N x (collision rate per disk) / 2 x (the
/// relaxation and production time), plus ~100 per disk for the compression
/// (docs/sim.md).
/// The rate per disk is the Enskog frequency at T = 1 times the measured ratio of
/// the real rate to it (docs/sim.md: 1.01 at phi = 0.60 up to 1.46 at 0.805).
pub fn planned_work(cfg: &SimConfig) -> Work {
    let nf = cfg.n as f64;
    let large = cfg.n_large() as f64 / nf;
    // The bath's two species (an intruder, species 2, is left out, as in the run).
    let omega = crate::sim::enskog::collision_frequency(
        cfg.phi,
        &cfg.radii()[..2],
        &cfg.species_masses()[..2],
        &[1.0 - large, large],
        1.0,
    );
    let frames = cfg.schedule.times().len() as u64;
    // omega counts collisions per disk; each collision involves two disks.
    let collisions =
        nf * (omega / 2.0 * enskog_ratio(cfg.phi) * (cfg.relax_time + cfg.schedule.end()) + 100.0);
    Work {
        n: cfg.n as u64,
        collisions,
        frames,
    }
}

/// Measured collision rate over the Enskog frequency at the measured T, by phi
/// (docs/sim.md, N = 4000, eps = 0.9); linear between, the end values outside.
fn enskog_ratio(phi: f64) -> f64 {
    const R: &[(f64, f64)] = &[
        (0.60, 1.007),
        (0.65, 1.012),
        (0.70, 1.033),
        (0.72, 1.048),
        (0.74, 1.067),
        (0.76, 1.105),
        (0.78, 1.18),
        (0.79, 1.24),
        (0.80, 1.36),
        (0.805, 1.46),
    ];
    if phi <= R[0].0 {
        return R[0].1;
    }
    for w in R.windows(2) {
        if phi <= w[1].0 {
            let f = (phi - w[0].0) / (w[1].0 - w[0].0);
            return w[0].1 + f * (w[1].1 - w[0].1);
        }
    }
    R[R.len() - 1].1
}
