//! The planner against measured runs: the collisions it plans for paper I's
//! pulled intruder (where the force heats the bath and compacts the disks ahead
//! of it, up to hundreds of times the collisions at rest) and for runs without
//! a force, compared with the mean collisions recorded by runs of the real
//! experiments (ci: 57 master seeds; small: the built replicas). Collisions,
//! not seconds: they are what the simulation does, independent of the machine;
//! `repro plan --check` compares CPU times.

use repro::pipeline::Workspace;
use repro::study::plan::configuration;

/// (profile, simulation label without the replica, measured mean collisions per
/// run). Recorded 2026-11-26 (docs/measurements.md): `repro plan --check`
/// lists the same configurations with their CPU times.
const MEASURED: &[(&str, &str, f64)] = &[
    ("ci", "intruder_eps09[force=1,phi=0.6]", 1.033e5),
    ("ci", "intruder_eps09[force=100,phi=0.775]", 5.307e5),
    ("ci", "intruder_eps09[force=316,phi=0.5]", 1.311e5),
    ("ci", "intruder_eps09[force=316,phi=0.775]", 9.503e5),
    ("ci", "intruder_eps09[force=1000,phi=0.5]", 7.164e5),
    ("ci", "intruder_eps09[force=1000,phi=0.6]", 1.356e6),
    ("ci", "intruder_eps09[force=1000,phi=0.775]", 4.056e6),
    ("ci", "intruder_eps09[force=3162,phi=0.5]", 4.944e6),
    ("ci", "intruder_eps09[force=3162,phi=0.6]", 1.047e7),
    ("ci", "intruder_eps09[force=3162,phi=0.775]", 1.644e7),
    ("ci", "intruder_eps07[force=512,phi=0.3]", 4.836e4),
    ("ci", "intruder_eps07[force=512,phi=0.6]", 4.574e5),
    ("ci", "intruder_eps07[force=512,phi=0.75]", 1.649e6),
    ("ci", "intruder_eps07_f0[phi=0.75]", 6.159e5),
    (
        "ci",
        "intruder_eps09_cold[force=100,phi=0.775,temperature=0.04]",
        4.208e5,
    ),
    (
        "ci",
        "intruder_eps09_cold[force=1000,phi=0.6,temperature=0.04]",
        2.842e6,
    ),
    (
        "ci",
        "intruder_eps09_cold[force=1000,phi=0.775,temperature=0.04]",
        1.099e7,
    ),
    ("ci", "intruder_front[phi=0.8]", 2.734e7),
    // The strong forces of the small profile (two replicas each, one at F =
    // 31623, phi = 0.5): where the bath's collisions level off.
    ("small", "intruder_eps09[force=31623,phi=0.5]", 6.173e7),
    ("small", "intruder_eps09[force=31623,phi=0.6]", 6.853e7),
    ("small", "intruder_eps09[force=31623,phi=0.7]", 2.024e8),
    ("small", "intruder_eps09[force=31623,phi=0.775]", 8.215e7),
    ("small", "intruder_eps09[force=31623,phi=0.8]", 4.926e7),
    ("small", "intruder_eps09[force=100000,phi=0.3]", 1.593e7),
    ("small", "intruder_eps09[force=100000,phi=0.5]", 6.252e7),
    ("small", "intruder_eps09[force=100000,phi=0.6]", 1.814e7),
    ("small", "intruder_eps09[force=100000,phi=0.7]", 2.211e8),
    ("small", "intruder_eps09[force=100000,phi=0.775]", 8.144e7),
    ("small", "intruder_eps09[force=100000,phi=0.8]", 8.670e7),
    // eps = 0.7: the layer ahead of the intruder collapses under F >= 2048.
    ("small", "intruder_eps07[force=2048,phi=0.3]", 3.162e6),
    ("small", "intruder_eps07[force=2048,phi=0.5]", 4.007e7),
    ("small", "intruder_eps07[force=2048,phi=0.6]", 2.520e7),
    ("small", "intruder_eps07[force=2048,phi=0.7]", 3.824e7),
    ("small", "intruder_eps07[force=2048,phi=0.75]", 6.706e7),
    ("small", "intruder_eps07[force=2048,phi=0.8]", 1.369e8),
    ("small", "intruder_eps07[force=8192,phi=0.3]", 1.246e8),
    ("small", "intruder_eps07[force=8192,phi=0.5]", 3.093e8),
    ("small", "intruder_eps07[force=8192,phi=0.6]", 4.403e8),
    ("small", "intruder_eps07[force=8192,phi=0.7]", 2.380e8),
    ("small", "intruder_eps07[force=8192,phi=0.75]", 1.017e9),
    ("small", "intruder_eps07[force=8192,phi=0.8]", 4.973e8),
    // eps = 0.9 at phi >= 0.775 below the ceiling.
    ("small", "intruder_eps09[force=3162,phi=0.775]", 1.748e7),
    ("small", "intruder_eps09[force=3162,phi=0.8]", 1.489e7),
    ("small", "intruder_eps09[force=10000,phi=0.775]", 4.358e7),
    ("small", "intruder_eps09[force=10000,phi=0.8]", 2.785e7),
    (
        "small",
        "intruder_eps09_cold[force=1000,phi=0.6,temperature=0.04]",
        4.282e6,
    ),
    (
        "small",
        "intruder_eps09_cold[force=1000,phi=0.775,temperature=0.04]",
        4.718e7,
    ),
    (
        "small",
        "intruder_eps09_cold[force=10000,phi=0.6,temperature=0.04]",
        1.712e7,
    ),
    (
        "small",
        "intruder_eps09_cold[force=10000,phi=0.775,temperature=0.04]",
        1.541e8,
    ),
];

/// Configurations the planner is known to miss by more than a factor 2, each
/// with why; the test fails if one comes back inside (then drop it here).
const KNOWN_OUTSIDE: &[(&str, &str, &str)] = &[
    (
        "small",
        "intruder_eps07[force=2048,phi=0.3]",
        "in the dilute bath the layer hardly collapses at this force (the guard acts on 0.4% of the collisions, 2-6% at phi >= 0.5), where the layer's factor is a mean over phi (measured/planned 0.43)",
    ),
    (
        "small",
        "intruder_eps07[force=2048,phi=0.5]",
        "the layer collapses more than the mean over phi (guard on 6% of the collisions), and the two replicas differ by 1.6 in CPU time (measured/planned 2.23)",
    ),
    (
        "small",
        "intruder_eps07[force=2048,phi=0.8]",
        "the layer collapses most of all phi at F = 2048 (guard on 6.2% of the collisions; measured/planned 2.20)",
    ),
    (
        "small",
        "intruder_eps09[force=31623,phi=0.5]",
        "one replica built so far, at the ceiling already (6.2 x 10^7 collisions, as at F = 10^5) where the growth below it is still at half (measured/planned 2.01)",
    ),
    (
        "small",
        "intruder_eps09[force=100000,phi=0.6]",
        "both replicas make 1.8 x 10^7 collisions, 4 times fewer than at F = 31623 and than the neighbouring phi; not understood (measured/planned 0.2)",
    ),
];

/// Planned collisions of one configuration of the repository's experiments.
fn planned(profile: &str, want: &str) -> f64 {
    let ws = Workspace::new(std::path::Path::new(env!("CARGO_MANIFEST_DIR")));
    let reg = repro::stages::registry();
    let ids = [
        "intruder-fig1",
        "intruder-fig2",
        "intruder-fig3",
        "intruder-fig4",
        "intruder-fig5",
        "intruder-fig6",
    ]
    .map(String::from)
    .to_vec();
    let graph = ws.plan(&reg, &ids, profile).unwrap();
    let node = graph
        .nodes
        .iter()
        .find(|n| configuration(n.label()) == want)
        .unwrap_or_else(|| panic!("{want} is not a simulation of the {profile} profile"));
    let planned = reg.planned(&node.kind, &node.parsed).unwrap();
    planned
        .counts
        .iter()
        .find(|(c, _)| *c == "collisions")
        .unwrap()
        .1
}

#[test]
fn planned_collisions_of_paper_i_are_within_a_factor_2_of_the_measured() {
    let mut bad = Vec::new();
    for (profile, label, measured) in MEASURED {
        let p = planned(profile, label);
        let ratio = measured / p;
        println!("{profile:5} {label:60} planned {p:.3e} measured {measured:.3e} ratio {ratio:.2}");
        // Below ~10^6 collisions a run takes under a CPU second, start-up
        // dominates and no time limit is at stake (`repro plan --check`
        // judges from 1 CPU s): listed, not judged.
        let outside = measured.max(p) >= 1e6 && !(0.5..=2.0).contains(&ratio);
        let known = KNOWN_OUTSIDE
            .iter()
            .find(|(pr, l, _)| pr == profile && l == label);
        match (outside, known) {
            (true, None) => bad.push(format!(
                "{label} ({profile}): measured/planned = {ratio:.2}"
            )),
            (false, Some((_, _, why))) => bad.push(format!(
                "{label} ({profile}) is inside a factor 2 now ({ratio:.2}): drop it from KNOWN_OUTSIDE ({why})"
            )),
            _ => {}
        }
    }
    assert!(bad.is_empty(), "outside a factor 2:\n{}", bad.join("\n"));
}
