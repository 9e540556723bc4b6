//! The planned CPU time of the stages that are not simulations (analyses, fits,
//! plots, tables), calibrated on the CPU time recorded stages took.
//!
//! Per kind, CPU s = c * (input bytes)^alpha * (inputs)^beta: alpha and beta
//! are shared by the kind, c is the median over the recorded stages of the
//! same parameters (a chi4_peaks over eight subsystem sizes costs four times
//! one over a single size per byte), or over the whole kind for parameters
//! never run. The number of inputs matters beside their bytes: chi4_peaks over
//! six replicas of a ci run costs twice what it costs over two replicas of the
//! same bytes at small (each replica brings its own time origins). Inputs below [`FLOOR_BYTES`] count as that much: such a stage costs
//! what its own work costs (a collapse fit, a synthetic survey), which its
//! parameters fix.
//!
//! The calibration shipped with the code (`stage_cost.json`, compiled in) is
//! regenerated from a store with `repro calibrate src/pipeline/stage_cost.json`.

use std::collections::{BTreeMap, HashMap};
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::canon::canonical;
use super::store::Store;

/// Inputs smaller than this count as this many bytes.
pub const FLOOR_BYTES: f64 = 1e5;
/// Recorded CPU times count as this at least (the clock ticks in 0.01 s).
pub const FLOOR_SECONDS: f64 = 0.005;
/// Samples that measure alpha: at least this many CPU seconds ...
const SLOPE_MIN_SECONDS: f64 = 0.05;
/// ... in a parameter set whose inputs span at least this factor (e).
const SLOPE_MIN_SPAN: f64 = 0.3;

/// The calibration of every kind of stage that was recorded.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Calibration {
    /// How many stages it was fitted on, and when.
    pub source: String,
    pub kinds: BTreeMap<String, KindCost>,
}

/// One kind: CPU s = exp(ln_c) * max(bytes, FLOOR_BYTES)^alpha * max(inputs, 1)^beta.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct KindCost {
    pub alpha: f64,
    pub beta: f64,
    /// Median over every recorded stage of the kind.
    pub ln_c: f64,
    /// Median per parameter set ([`signature`]).
    pub params: BTreeMap<String, f64>,
    pub stages: usize,
}

/// One recorded stage.
#[derive(Debug, Clone)]
pub struct Sample {
    pub kind: String,
    pub signature: String,
    pub input_bytes: u64,
    pub inputs: usize,
    pub cpu_s: f64,
}

/// A stage's parameters without its seed (replicas of one configuration cost
/// alike), hashed.
pub fn signature(params: &Value) -> String {
    let mut p = params.clone();
    if let Value::Object(m) = &mut p {
        m.remove("seed");
    }
    blake3::hash(canonical(&p).as_bytes()).to_hex()[..16].to_string()
}

fn ln_bytes(b: u64) -> f64 {
    (b as f64).max(FLOOR_BYTES).ln()
}

fn ln_inputs(n: usize) -> f64 {
    (n.max(1) as f64).ln()
}

impl KindCost {
    /// Planned CPU seconds of a stage with parameters of `signature` reading
    /// `input_bytes` from `inputs` inputs.
    pub fn seconds(&self, signature: &str, input_bytes: u64, inputs: usize) -> f64 {
        let ln_c = self.params.get(signature).copied().unwrap_or(self.ln_c);
        (ln_c + self.alpha * ln_bytes(input_bytes) + self.beta * ln_inputs(inputs)).exp()
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl Calibration {
    /// The calibration compiled into the binary.
    pub fn shipped() -> &'static Calibration {
        static C: OnceLock<Calibration> = OnceLock::new();
        C.get_or_init(|| {
            serde_json::from_str(include_str!("stage_cost.json"))
                .expect("src/pipeline/stage_cost.json is a calibration")
        })
    }

    /// Planned CPU seconds of a stage of `kind` with `params` reading
    /// `input_bytes` from `inputs` inputs; `None` for a kind never recorded.
    pub fn seconds(
        &self,
        kind: &str,
        params: &Value,
        input_bytes: u64,
        inputs: usize,
    ) -> Option<f64> {
        Some(
            self.kinds
                .get(kind)?
                .seconds(&signature(params), input_bytes, inputs),
        )
    }

    /// Fit every kind of `samples`.
    pub fn fit(samples: &[Sample], source: String) -> Calibration {
        let mut by_kind: BTreeMap<&str, BTreeMap<&str, Vec<&Sample>>> = BTreeMap::new();
        for s in samples {
            by_kind
                .entry(&s.kind)
                .or_default()
                .entry(&s.signature)
                .or_default()
                .push(s);
        }
        let ln_s = |s: &Sample| s.cpu_s.max(FLOOR_SECONDS).ln();
        let mut kinds = BTreeMap::new();
        for (kind, groups) in by_kind {
            // alpha and beta: the slopes of ln CPU against ln bytes and ln
            // inputs within parameter sets (pooled, each set centred), where
            // the inputs vary enough; beta 0 where their number never varies.
            let mut m = [[0.0; 2]; 2];
            let mut v = [0.0; 2];
            let mut points = 0;
            for g in groups.values() {
                let pts: Vec<[f64; 3]> = g
                    .iter()
                    .filter(|s| s.cpu_s >= SLOPE_MIN_SECONDS && s.input_bytes as f64 > FLOOR_BYTES)
                    .map(|s| [ln_bytes(s.input_bytes), ln_inputs(s.inputs), ln_s(s)])
                    .collect();
                if pts.len() < 3 {
                    continue;
                }
                let (lo, hi) = pts
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[0]), b.max(p[0])));
                if hi - lo < SLOPE_MIN_SPAN {
                    continue;
                }
                let n = pts.len() as f64;
                let mean = |k: usize| pts.iter().map(|p| p[k]).sum::<f64>() / n;
                let mu = [mean(0), mean(1), mean(2)];
                for p in &pts {
                    let (x, y) = ([p[0] - mu[0], p[1] - mu[1]], p[2] - mu[2]);
                    for a in 0..2 {
                        v[a] += x[a] * y;
                        for b in 0..2 {
                            m[a][b] += x[a] * x[b];
                        }
                    }
                }
                points += pts.len();
            }
            let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
            let (alpha, beta) = if points < 6 || m[0][0] <= 0.0 {
                (1.0, 0.0)
            } else if m[1][1] > 1e-9 * m[0][0] && det > 1e-6 * m[0][0] * m[1][1] {
                (
                    (v[0] * m[1][1] - v[1] * m[0][1]) / det,
                    (m[0][0] * v[1] - m[1][0] * v[0]) / det,
                )
            } else {
                (v[0] / m[0][0], 0.0)
            };
            let (alpha, beta) = (alpha.clamp(0.0, 2.0), beta.clamp(-1.0, 2.0));
            let offset =
                |s: &Sample| ln_s(s) - alpha * ln_bytes(s.input_bytes) - beta * ln_inputs(s.inputs);
            let params: BTreeMap<String, f64> = groups
                .iter()
                .map(|(sig, g)| {
                    let c = median(g.iter().map(|s| offset(s)).collect());
                    (sig.to_string(), (c * 1e4).round() / 1e4)
                })
                .collect();
            let all: Vec<f64> = groups.values().flatten().map(|s| offset(s)).collect();
            let stages = all.len();
            kinds.insert(
                kind.to_string(),
                KindCost {
                    alpha: (alpha * 1e4).round() / 1e4,
                    beta: (beta * 1e4).round() / 1e4,
                    ln_c: (median(all) * 1e4).round() / 1e4,
                    params,
                    stages,
                },
            );
        }
        Calibration { source, kinds }
    }
}

/// Every stage of the store that is not a simulation (`is_simulation` says
/// which kinds are) and recorded its CPU time, with the bytes of its inputs as
/// stored. A stage whose inputs are gone from the store is left out.
pub fn samples(store: &Store, is_simulation: impl Fn(&str, &Value) -> bool) -> Vec<Sample> {
    let entries = store.entries();
    let bytes: HashMap<&str, u64> = entries
        .iter()
        .map(|e| (e.digest.as_str(), store.entry_bytes(e)))
        .collect();
    entries
        .iter()
        .filter(|e| !is_simulation(&e.kind, &e.params))
        .filter_map(|e| {
            let cpu_s = e.cpu_s?;
            let input_bytes = e
                .inputs
                .iter()
                .map(|(_, d)| bytes.get(d.as_str()).copied())
                .sum::<Option<u64>>()?;
            Some(Sample {
                kind: e.kind.clone(),
                signature: signature(&e.params),
                input_bytes,
                inputs: e.inputs.len(),
                cpu_s,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn sample(kind: &str, params: &Value, bytes: u64, inputs: usize, cpu_s: f64) -> Sample {
        Sample {
            kind: kind.into(),
            signature: signature(params),
            input_bytes: bytes,
            inputs,
            cpu_s,
        }
    }

    /// Synthetic stages with a known law: CPU = c_p * bytes^1.4 * inputs^0.7,
    /// c differing fourfold between two parameter sets, with a +-10% scatter.
    #[test]
    fn the_fit_recovers_a_known_power_law_per_parameter_set() {
        let (one, eight) = (json!({"n": [250]}), json!({"n": [8, 16, 32]}));
        let law = |c: f64, b: u64, k: usize| c * (b as f64).powf(1.4) * (k as f64).powf(0.7);
        let mut s = Vec::new();
        let mut scatter = [0.9, 1.0, 1.1].iter().cycle();
        for (p, c) in [(&one, 1e-9), (&eight, 4e-9)] {
            for mb in [2.0, 5.0, 15.0, 40.0, 200.0] {
                let b = (mb * 1e6) as u64;
                for k in [2, 6, 2] {
                    s.push(sample(
                        "peaks",
                        p,
                        b,
                        k,
                        law(c, b, k) * scatter.next().unwrap(),
                    ));
                }
            }
        }
        let cal = Calibration::fit(&s, "synthetic".into());
        let kind = &cal.kinds["peaks"];
        assert!((kind.alpha - 1.4).abs() < 0.03, "{}", kind.alpha);
        assert!((kind.beta - 0.7).abs() < 0.1, "{}", kind.beta);
        let b = 20_000_000u64;
        for (p, c) in [(&one, 1e-9), (&eight, 4e-9)] {
            for k in [2, 4] {
                let want = law(c, b, k);
                let got = cal.seconds("peaks", p, b, k).unwrap();
                assert!((got / want - 1.0).abs() < 0.15, "{got} against {want}");
            }
        }
        // The seed is not part of a parameter set; unknown sets get the kind's median.
        let seeded = json!({"n": [250], "seed": 7});
        assert_eq!(
            cal.seconds("peaks", &seeded, b, 2),
            cal.seconds("peaks", &one, b, 2)
        );
        let other = cal.seconds("peaks", &json!({"n": [1]}), b, 2).unwrap();
        assert!(other > cal.seconds("peaks", &one, b, 2).unwrap());
        assert!(other < cal.seconds("peaks", &eight, b, 2).unwrap());
        assert_eq!(cal.seconds("unknown", &one, b, 2), None);
    }

    /// A stage that reads a few kilobytes costs its own work: its parameters'
    /// median, however small its input.
    #[test]
    fn a_stage_with_a_small_input_costs_its_parameters_median() {
        let p = json!({"realisations": 400});
        let s: Vec<Sample> = [5.0, 6.0, 7.0]
            .iter()
            .map(|&c| sample("survey", &p, 0, 0, c))
            .collect();
        let cal = Calibration::fit(&s, "synthetic".into());
        for b in [0, 1000, 90_000] {
            let got = cal.seconds("survey", &p, b, 0).unwrap();
            assert!((got - 6.0).abs() < 1e-2, "{got}");
        }
    }

    #[test]
    fn the_shipped_calibration_reads_and_covers_the_common_kinds() {
        let c = Calibration::shipped();
        for k in ["tau_alpha", "chi4_peaks", "s4", "fit", "plot", "table"] {
            assert!(c.kinds.contains_key(k), "{k} missing from stage_cost.json");
        }
    }
}
