//! What a stage is planned to cost in CPU seconds, from the work it plans
//! ([`Work`]: collisions, kicks of the drive, force kicks, stored frames) or, for
//! analyses, fits and plots, from its parameters and the bytes it reads
//! ([`super::calibration`]). One model for the Slurm
//! executor's time limits, the core-hour totals of `--dry-run`, the executors'
//! estimate of the end, and `repro plan` ([`crate::study::plan`], which
//! compares it with the CPU time every recorded stage took).

use std::collections::HashMap;

use serde_json::Value;

use super::calibration::Calibration;
use super::graph::Graph;
use super::registry::Registry;
use super::stage::Work;
use super::store::Store;

/// Measured driven collisions per CPU second at phi = 0.78 (docs/measurements.md,
/// `repro bench` at 10^4 disks and more, 2026-11-22 and 11-23, the lower end of
/// each range; 10^3: the recorded runs of N = 500-4000, 2026-11-26): (N, rate).
const SPEED: &[(f64, f64)] = &[
    (1e3, 1.3e6),
    (1e4, 1.0e6),
    (1e5, 0.75e6),
    (1e6, 0.46e6),
    (4e6, 0.40e6),
];

/// CPU seconds per kick of the drive and per force kick of an intruder, and per
/// disk of a stored frame (the Parquet encoding and write), fitted by least
/// squares to the recorded simulations of the ci profile (docs/measurements.md,
/// 2026-11-26): a kick draws random numbers and repredicts its disks' events; a
/// force kick repredicts the intruder's only.
pub const SECONDS_PER_DRIVE_KICK: f64 = 0.35e-6;
pub const SECONDS_PER_FORCE_KICK: f64 = 0.15e-6;
pub const SECONDS_PER_FRAME_DISK: f64 = 0.15e-6;

/// Collisions per CPU second at N disks: log-linear between the measured sizes,
/// the end values outside them.
pub fn collisions_per_second(n: f64) -> f64 {
    if n <= SPEED[0].0 {
        return SPEED[0].1;
    }
    for w in SPEED.windows(2) {
        let ((n0, r0), (n1, r1)) = (w[0], w[1]);
        if n <= n1 {
            let f = (n / n0).ln() / (n1 / n0).ln();
            return r0 + f * (r1 - r0);
        }
    }
    SPEED[SPEED.len() - 1].1
}

/// How much more a collision costs at packing fraction `phi` than at 0.65-0.805,
/// from the recorded runs of the small profile (docs/measurements.md,
/// 2026-11-26).
///
/// Near jamming a collision comes with more cell crossings and stale events:
/// 1 + 0.43 (phi - 0.805) / (0.845 - phi), about 1.3 at 0.82 and 4 at 0.84
/// (driven and elastic runs of N = 2000 at 0.84 took 3-7 times the collisions'
/// cost at 0.78).
///
/// In a dilute fluid a disk crosses cells and leaves its neighbour shell
/// several times between two collisions, the more the longer its free path,
/// ~ 1 / (phi g(phi)) with the contact value g of Henderson's equation of state:
/// 1 + 0.5 (r(phi) - r(0.65)), r the free path over its value at 0.7; about
/// 1.3 at 0.6, 2 at 0.5 and 5.4 at 0.3 (elastic runs of N = 4000-16000 at
/// 0.3 took 5-10 times the plan without it, and pulled intruders at eta = 0.3
/// 4-9 times).
pub fn density_factor(phi: f64) -> f64 {
    let p = phi.min(0.8425);
    let jamming = 1.0 + 0.43 * ((p - 0.805) / (0.845 - p)).max(0.0);
    let free_path = |f: f64| {
        let g = (1.0 - 7.0 * f / 16.0) / (1.0 - f).powi(2);
        1.0 / (f * g)
    };
    let dilute = if phi > 0.0 && phi < 0.65 {
        let r = |f: f64| free_path(f) / free_path(0.7);
        1.0 + 0.5 * (r(phi) - r(0.65))
    } else {
        1.0
    };
    jamming * dilute
}

/// What a collision of a pulled intruder's collapsing layer costs, in dense
/// collisions: the eps = 0.7 runs at F = 2048-8192 (N = 500), where most
/// collisions are the layer's, made 2.0-2.5 x 10^6 collisions per CPU s where
/// a dense collision's rate is 1.3 x 10^6 (docs/measurements.md, 2026-11-27).
const LAYER_COST: f64 = 0.5;

/// Planned CPU seconds of a simulation doing `w`. The collisions a pulling
/// force adds cost what a collision at 0.65-0.805 does, whatever the mean
/// packing: the recorded heated runs (N = 500-2000, F = 3 x 10^3 - 10^5) made
/// 0.8-2.1 x 10^6 collisions per CPU s at every phi from 0.3 to 0.8, where the
/// dilute factor would say 0.24 x 10^6 at 0.3 (docs/measurements.md).
pub fn simulation_seconds(w: &Work) -> f64 {
    let n = w.n as f64;
    let at_rest = w.collisions - w.forced_collisions;
    let forced = w.forced_collisions - w.layer_collisions + LAYER_COST * w.layer_collisions;
    (at_rest * density_factor(w.phi) + forced) / collisions_per_second(n)
        + w.drive_kicks * SECONDS_PER_DRIVE_KICK
        + w.force_kicks * SECONDS_PER_FORCE_KICK
        + n * w.frames as f64 * SECONDS_PER_FRAME_DISK
}

/// Stages of a kind never recorded ([`Calibration`] has none): time from the
/// bytes they read. Measured on the ci profile (2026-11-24,
/// docs/measurements.md): the slowest per input byte was `chi4_peaks` at 4.4
/// MB/s (tau_alpha 23-69 MB/s); half that speed, plus 0.2 s (the median stage
/// of a ci build).
pub const ANALYSIS_BYTES_PER_SECOND: f64 = 2e6;
pub const ANALYSIS_SECONDS: f64 = 0.2;

/// Planned CPU seconds of a stage: a simulation from its work, any other stage
/// of `kind` from its parameters and the bytes it reads from its `inputs`
/// inputs, calibrated on recorded stages ([`Calibration::shipped`]).
pub fn seconds(
    work: Option<&Work>,
    kind: &str,
    params: &Value,
    input_bytes: u64,
    inputs: usize,
) -> f64 {
    match work {
        Some(w) => simulation_seconds(w),
        None => Calibration::shipped()
            .seconds(kind, params, input_bytes, inputs)
            .unwrap_or(ANALYSIS_SECONDS + input_bytes as f64 / ANALYSIS_BYTES_PER_SECOND),
    }
}

/// Bytes a simulation's trajectory is planned to hold: x and y (f64) per disk
/// and frame (what a stage reading it reads, before it exists).
pub fn trajectory_bytes(w: &Work) -> u64 {
    w.n * w.frames * 16
}

/// Planned CPU seconds of every node of `graph`, reading its inputs' sizes
/// from `built` (node -> bytes of its output, for the nodes in the store), an
/// input not built yet counted at its planned trajectory size (a simulation)
/// or as small (anything else): what the progress line's estimate of the end
/// starts from.
pub fn node_seconds(graph: &Graph, reg: &Registry, built: &HashMap<usize, u64>) -> Vec<f64> {
    let work: Vec<Option<Work>> = graph
        .nodes
        .iter()
        .map(|n| reg.work(&n.kind, &n.parsed))
        .collect();
    graph
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let bytes = n
                .inputs
                .iter()
                .map(|&j| match built.get(&j) {
                    Some(&b) => b,
                    None => work[j].as_ref().map_or(0, trajectory_bytes),
                })
                .sum();
            seconds(work[i].as_ref(), &n.kind, &n.params, bytes, n.inputs.len())
        })
        .collect()
}

/// Bytes of the output of every (node, key) of `cached` found in `store`:
/// what [`node_seconds`] reads the sizes of built inputs from.
pub fn built_bytes<'a>(
    store: &Store,
    cached: impl IntoIterator<Item = (usize, &'a str)>,
) -> HashMap<usize, u64> {
    cached
        .into_iter()
        .filter_map(|(i, key)| Some((i, store.entry_bytes(&store.lookup(key)?))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speed_interpolates_between_measured_sizes() {
        assert_eq!(collisions_per_second(500.0), 1.3e6);
        assert_eq!(collisions_per_second(1e4), 1.0e6);
        assert_eq!(collisions_per_second(1e6), 0.46e6);
        assert_eq!(collisions_per_second(1e7), 0.40e6);
        let mid = collisions_per_second(10f64.powf(5.5));
        assert!((mid - 0.605e6).abs() < 1.0, "{mid}");
    }

    #[test]
    fn every_kind_of_work_adds_its_measured_cost() {
        let w = Work {
            n: 1_000_000,
            phi: 0.78,
            collisions: 0.46e6 * 3600.0,
            forced_collisions: 0.0,
            layer_collisions: 0.0,
            drive_kicks: 0.0,
            force_kicks: 0.0,
            frames: 0,
        };
        assert!((simulation_seconds(&w) - 3600.0).abs() < 1e-6);
        let more = Work {
            drive_kicks: 1e6,
            force_kicks: 1e6,
            frames: 10,
            ..w
        };
        let extra =
            1e6 * (SECONDS_PER_DRIVE_KICK + SECONDS_PER_FORCE_KICK) + 1e7 * SECONDS_PER_FRAME_DISK;
        assert!((simulation_seconds(&more) - 3600.0 - extra).abs() < 1e-6);
        assert_eq!(
            seconds(None, "never recorded", &Value::Null, 2_000_000, 1),
            1.2
        );
        // Near jamming and in a dilute fluid a collision costs more.
        let dense = Work { phi: 0.84, ..w };
        let f = simulation_seconds(&dense) / 3600.0;
        assert!((f - density_factor(0.84)).abs() < 1e-9);
        let dilute = Work { phi: 0.3, ..w };
        assert!((simulation_seconds(&dilute) / 3600.0 - density_factor(0.3)).abs() < 1e-9);
        // A force's collisions, in the compacted layer, cost a dense one's.
        let forced = Work {
            forced_collisions: w.collisions,
            ..dilute
        };
        assert!((simulation_seconds(&forced) - 3600.0).abs() < 1e-6);
        // Those of a collapsing layer cost half that.
        let layer = Work {
            layer_collisions: w.collisions,
            ..forced
        };
        assert!((simulation_seconds(&layer) - 1800.0).abs() < 1e-6);
    }

    #[test]
    fn a_collision_costs_most_near_jamming_and_in_a_dilute_fluid() {
        // One between 0.65 and 0.805, continuous at both ends.
        for phi in [0.65, 0.7, 0.78, 0.805] {
            assert!((density_factor(phi) - 1.0).abs() < 1e-12, "{phi}");
        }
        assert!((density_factor(0.6499999) - 1.0).abs() < 1e-5);
        // The measured excess: ~4 at 0.84, ~1.3 at 0.82; ~5 at 0.3, ~2 at 0.5.
        assert!(
            (3.5..4.5).contains(&density_factor(0.84)),
            "{}",
            density_factor(0.84)
        );
        assert!((1.2..1.4).contains(&density_factor(0.82)));
        assert!(
            (4.5..6.0).contains(&density_factor(0.3)),
            "{}",
            density_factor(0.3)
        );
        assert!(
            (1.7..2.3).contains(&density_factor(0.5)),
            "{}",
            density_factor(0.5)
        );
        // Rising away from the middle, finite past jamming.
        assert!(density_factor(0.4) > density_factor(0.5));
        assert!(density_factor(0.86).is_finite() && density_factor(0.86) >= density_factor(0.84));
    }
}
