//! What a stage is planned to cost in CPU seconds: a long stage (a simulation)
//! what its kind's cost model says ([`Planned`], registered with the kind), any
//! other stage from its parameters and the bytes it reads
//! ([`super::calibration`]). One model for the Slurm
//! executor's time limits, the core-hour totals of `--dry-run`, the executors'
//! estimate of the end, and `repro plan` ([`crate::study::plan`], which
//! compares it with the CPU time every recorded stage took).

use std::collections::HashMap;

use serde_json::Value;

use super::calibration::Calibration;
use super::graph::Graph;
use super::registry::Registry;
use super::stage::Planned;
use super::store::Store;

/// Stages of a kind never recorded ([`Calibration`] has none): time from the
/// bytes they read. Measured on the ci profile (2026-11-24,
/// docs/measurements.md): the slowest per input byte was `chi4_peaks` at 4.4
/// MB/s (tau_alpha 23-69 MB/s); half that speed, plus 0.2 s (the median stage
/// of a ci build).
pub const ANALYSIS_BYTES_PER_SECOND: f64 = 2e6;
pub const ANALYSIS_SECONDS: f64 = 0.2;

/// Planned CPU seconds of a stage: a long stage from its kind's cost model,
/// any other stage of `kind` from its parameters and the bytes it reads from
/// its `inputs` inputs, calibrated on recorded stages ([`Calibration::shipped`]).
pub fn seconds(
    planned: Option<&Planned>,
    kind: &str,
    params: &Value,
    input_bytes: u64,
    inputs: usize,
) -> f64 {
    match planned {
        Some(p) => p.cpu_seconds,
        None => Calibration::shipped()
            .seconds(kind, params, input_bytes, inputs)
            .unwrap_or(ANALYSIS_SECONDS + input_bytes as f64 / ANALYSIS_BYTES_PER_SECOND),
    }
}

/// Planned CPU seconds of every node of `graph`, reading its inputs' sizes
/// from `built` (node -> bytes of its output, for the nodes in the store), an
/// input not built yet counted at its planned output size (a simulation's
/// trajectory) or as small (anything else): what the progress line's estimate
/// of the end starts from.
pub fn node_seconds(graph: &Graph, reg: &Registry, built: &HashMap<usize, u64>) -> Vec<f64> {
    let planned: Vec<Option<Planned>> = graph
        .nodes
        .iter()
        .map(|n| reg.planned(&n.kind, &n.parsed))
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
                    None => planned[j].as_ref().map_or(0, |p| p.output_bytes),
                })
                .sum();
            seconds(
                planned[i].as_ref(),
                &n.kind,
                &n.params,
                bytes,
                n.inputs.len(),
            )
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
    fn a_planned_stage_costs_its_plan_and_another_its_input_bytes() {
        let p = Planned {
            cpu_seconds: 3600.0,
            memory_bytes: 0.0,
            output_bytes: 0,
            counts: Vec::new(),
        };
        assert_eq!(seconds(Some(&p), "simulate", &Value::Null, 0, 0), 3600.0);
        assert_eq!(
            seconds(None, "never recorded", &Value::Null, 2_000_000, 1),
            1.2
        );
    }
}
