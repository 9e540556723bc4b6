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
    (
        "small",
        "intruder_eps09_cold[force=10000,phi=0.775,temperature=0.04]",
        1.218e8,
    ),
];

/// Planned collisions of one configuration of the repository's experiments.
fn planned(profile: &str, want: &str) -> f64 {
    let ws = Workspace::new(std::path::Path::new(env!("CARGO_MANIFEST_DIR")));
    let reg = repro::stages::registry();
    let ids = [
        "intruder-fig1",
        "intruder-fig3",
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
    reg.work(&node.kind, &node.params).unwrap().collisions
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
        if measured.max(p) >= 1e6 && !(0.5..=2.0).contains(&ratio) {
            bad.push(format!(
                "{label} ({profile}): measured/planned = {ratio:.2}"
            ));
        }
    }
    assert!(bad.is_empty(), "outside a factor 2:\n{}", bad.join("\n"));
}
