//! The observables a pipeline can ask for, by name: one line each in [`OBSERVABLES`]
//! (name, what it computes, its function). The generic
//! analysis stage (`stages::analyse`) turns every line into a stage kind, and
//! [`super::run`] calls the same line on one trajectory: a name means one thing.
//!
//! Each function gets every trajectory gathered into the stage (replicas of one
//! state point) and pools them: observables built on blocks pool (replica, time
//! origin) blocks in one jackknife; the others are computed per replica and pooled
//! seed to seed ([`pool::seed_to_seed`]); lists of objects (clusters, paths) are
//! concatenated with a `replica` column. The table's metadata says which.

use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::{ArrayRef, Int64Array, RecordBatch};
use serde::de::DeserializeOwned;
use serde_json::Value;

use super::pool::{self, Errors};
use super::{chi4, clusters, front, gr, intruder, lags, msd, overlap, s4, van_hove};
use crate::pipeline::registry::typed;
use crate::table::f64_batch;
use crate::traj::Trajectory;

/// What an observable returns: its main table, further tables by file name (e.g.
/// `tau.parquet`), and how its errors were estimated.
pub struct Tables {
    pub main: RecordBatch,
    pub extra: Vec<(&'static str, RecordBatch)>,
    pub errors: Errors,
    /// The main table with each replica left out, when the observable derives
    /// them from its per-replica pieces (cheaper than the analysis stage's
    /// recomputation on the other replicas); empty otherwise.
    pub left_out: Vec<RecordBatch>,
}

impl Tables {
    fn one(main: RecordBatch, errors: Errors) -> Self {
        Tables {
            main,
            extra: Vec::new(),
            errors,
            left_out: Vec::new(),
        }
    }
}

/// One observable reachable from a pipeline.
pub struct Observable {
    /// Its name in specs (`kind: chi4`).
    pub name: &'static str,
    /// One line: what it computes and its columns.
    pub describe: &'static str,
    /// Check parameters (typed; unknown keys and wrong types are errors).
    pub validate: fn(&Value) -> Result<()>,
    /// Compute it from the gathered trajectories.
    pub compute: fn(&[&Trajectory], &Value) -> Result<Tables>,
    /// How `at` (times in units of a measured time) reads it between lags.
    pub at: lags::AtLag,
    /// Whether it takes the drive of its runs (`drive`, `kick_rate_factor`):
    /// the analysis stage reads them from the runs it analyses.
    pub takes_drive: bool,
}

/// The lags realised by every time origin when none are requested.
fn overlap_params(name: &str, trajs: &[&Trajectory], v: &Value) -> Result<overlap::Params> {
    let mut p: overlap::Params = typed(name, v)?;
    p.lags = lags::every_origin(trajs, p.lags.take(), p.rel_tol)?;
    Ok(p)
}

fn chi4_params(name: &str, v: &Value) -> Result<chi4::Params> {
    let p: chi4::Params = typed(name, v)?;
    if p.n.is_empty() {
        bail!(
            "parameters of analysis `{name}`: `n` (sub-box particle numbers) is empty; give at least one, e.g. n: [100, 400]"
        );
    }
    Ok(p)
}

fn chi4_pooled(name: &str, trajs: &[&Trajectory], v: &Value) -> Result<chi4::Params> {
    let mut p = chi4_params(name, v)?;
    chi4::clamp_sizes(&mut p, trajs.first().map_or(0, |t| t.n()));
    p.lags = lags::every_origin(trajs, p.lags.take(), p.rel_tol)?;
    Ok(p)
}

fn jackknife(trajs: &[&Trajectory]) -> Errors {
    Errors::Jackknife {
        replicas: trajs.len(),
    }
}

/// Per replica, then pooled seed to seed.
fn per_replica<P: DeserializeOwned>(
    name: &str,
    trajs: &[&Trajectory],
    v: &Value,
    f: fn(&Trajectory, &P) -> Result<RecordBatch>,
) -> Result<Tables> {
    let p: P = typed(name, v)?;
    let tables = trajs.iter().map(|t| f(t, &p)).collect::<Result<Vec<_>>>()?;
    let (main, errors) = pool::seed_to_seed(&tables)?;
    Ok(Tables::one(main, errors))
}

/// Per replica, rows concatenated with a `replica` column first.
fn concat<P: DeserializeOwned>(
    name: &str,
    trajs: &[&Trajectory],
    v: &Value,
    f: fn(&Trajectory, &P) -> Result<RecordBatch>,
) -> Result<RecordBatch> {
    let p: P = typed(name, v)?;
    let mut out = Vec::new();
    for (r, t) in trajs.iter().enumerate() {
        let b = f(t, &p)?;
        let mut cols: Vec<(String, ArrayRef)> = vec![(
            "replica".into(),
            Arc::new(Int64Array::from(vec![r as i64; b.num_rows()])),
        )];
        for (fd, c) in b.schema().fields().iter().zip(b.columns()) {
            cols.push((fd.name().clone(), c.clone()));
        }
        out.push(RecordBatch::try_from_iter(cols)?);
    }
    let Some(first) = out.first() else {
        bail!("analysis `{name}`: no trajectory");
    };
    arrow_select_concat(&first.schema(), &out)
}

fn arrow_select_concat(
    schema: &arrow_schema::SchemaRef,
    batches: &[RecordBatch],
) -> Result<RecordBatch> {
    let mut cols: Vec<ArrayRef> = Vec::new();
    for i in 0..schema.fields().len() {
        let parts: Vec<&dyn arrow_array::Array> =
            batches.iter().map(|b| b.column(i).as_ref()).collect();
        cols.push(concat_arrays(&parts)?);
    }
    Ok(RecordBatch::try_new(schema.clone(), cols)?)
}

/// Concatenate float, integer or boolean arrays of one type.
fn concat_arrays(parts: &[&dyn arrow_array::Array]) -> Result<ArrayRef> {
    use arrow_array::{Array, BooleanArray, Float64Array};
    fn any<'a>(p: &&'a dyn Array) -> &'a dyn std::any::Any {
        p.as_any()
    }
    if parts.iter().all(|p| any(p).is::<Float64Array>()) {
        let v: Vec<Option<f64>> = parts
            .iter()
            .flat_map(|p| any(p).downcast_ref::<Float64Array>().unwrap().iter())
            .collect();
        return Ok(Arc::new(Float64Array::from(v)));
    }
    if parts.iter().all(|p| any(p).is::<Int64Array>()) {
        let v: Vec<Option<i64>> = parts
            .iter()
            .flat_map(|p| any(p).downcast_ref::<Int64Array>().unwrap().iter())
            .collect();
        return Ok(Arc::new(Int64Array::from(v)));
    }
    if parts.iter().all(|p| any(p).is::<BooleanArray>()) {
        let v: Vec<Option<bool>> = parts
            .iter()
            .flat_map(|p| any(p).downcast_ref::<BooleanArray>().unwrap().iter())
            .collect();
        return Ok(Arc::new(BooleanArray::from(v)));
    }
    bail!(
        "cannot concatenate columns of type {:?}",
        parts[0].data_type()
    )
}

/// Every observable, one line each. A new observable is one function in its module
/// of `src/analysis` and one line here.
pub static OBSERVABLES: &[Observable] = &[
    Observable {
        name: "overlap",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "Q(t) (paper H, Eq. 5-7) pooled over replicas and time origins: t, Q, Q_err, n_origins",
        validate: |v| typed::<overlap::Params>("overlap", v).map(drop),
        compute: |t, v| {
            let p = overlap_params("overlap", t, v)?;
            let (lag, q, n) = overlap::q_curve(t, &p)?;
            let b = f64_batch(&[
                ("t", lag),
                ("Q", q.iter().map(|e| e.value).collect()),
                ("Q_err", q.iter().map(|e| e.err).collect()),
                ("n_origins", n.iter().map(|&k| k as f64).collect()),
            ])?;
            Ok(Tables::one(b, jackknife(t)))
        },
    },
    Observable {
        name: "tau_alpha",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "tau_alpha where Q = 1/e, pooled replicas, jackknife error: one row tau_alpha, tau_alpha_err, replicas",
        validate: |v| typed::<overlap::Params>("tau_alpha", v).map(drop),
        compute: |t, v| {
            let p = overlap_params("tau_alpha", t, v)?;
            let tau = overlap::tau_alpha(t, &p)?;
            let b = f64_batch(&[
                ("tau_alpha", vec![tau.value]),
                ("tau_alpha_err", vec![tau.err]),
                ("replicas", vec![t.len() as f64]),
            ])?;
            Ok(Tables::one(b, jackknife(t)))
        },
    },
    Observable {
        name: "q_levels",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "time-density superposition test (Fig. 5): t where Q = each level and t/tau_alpha, one jackknife: level, t, t_err, tau_alpha, t_over_tau_alpha, t_over_tau_alpha_err",
        validate: |v| typed::<overlap::LevelParams>("q_levels", v).map(drop),
        compute: |t, v| {
            let mut p: overlap::LevelParams = typed("q_levels", v)?;
            p.lags = lags::every_origin(t, p.lags.take(), p.rel_tol)?;
            Ok(Tables::one(overlap::q_levels(t, &p)?, jackknife(t)))
        },
    },
    Observable {
        name: "aging",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "Q(t; t0) per waiting time t0 averaged over replicas (Fig. 2): t0, t, Q; tau.parquet: t0, tau_alpha, tau_alpha_err (replica jackknife)",
        validate: |v| typed::<overlap::Params>("aging", v).map(drop),
        compute: |t, v| {
            let p = overlap_params("aging", t, v)?;
            let (main, tau) = overlap::aging(t, &p)?;
            Ok(Tables {
                main,
                extra: vec![("tau.parquet", tau)],
                errors: Errors::Mean { replicas: t.len() },
                left_out: Vec::new(),
            })
        },
    },
    Observable {
        name: "chi4",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "chi4(t) (paper H, Eq. 14) per sub-box size N, pooled replicas: N, t, Q, chi4, chi4_err, n_origins",
        validate: |v| chi4_params("chi4", v).map(drop),
        compute: |t, v| {
            let p = chi4_pooled("chi4", t, v)?;
            Ok(Tables::one(chi4::compute_pooled(t, &p)?, jackknife(t)))
        },
    },
    Observable {
        name: "chi4_peaks",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "chi4 peak per sub-box size with tau_alpha and chi4(tau_alpha): N, tau4, chi4P, tau_alpha, chi4_tau_alpha (+ _err)",
        validate: |v| chi4_params("chi4_peaks", v).map(drop),
        compute: |t, v| {
            let p = chi4_pooled("chi4_peaks", t, v)?;
            Ok(Tables::one(chi4::peaks_table(t, &p)?, jackknife(t)))
        },
    },
    Observable {
        name: "s4",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "four-point structure factor S4(q, t) per shell, q = 0 first (chi4 of the whole system), time origins of every replica pooled: L, t, q, q2, S4, S4_err, n_vectors",
        validate: |v| typed::<s4::Params>("s4", v).map(drop),
        compute: |t, v| {
            let p: s4::Params = typed("s4", v)?;
            let b = s4::compute_pooled(t, &p)?;
            Ok(Tables::one(b, Errors::TimeBlocks { replicas: t.len() }))
        },
    },
    Observable {
        name: "msd",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "mean-squared displacement, all / per species / fastest and slowest fractions: t, species, select, fraction, msd, msd_err, n_origins",
        validate: |v| typed::<msd::Params>("msd", v).map(drop),
        compute: |t, v| {
            let mut p: msd::Params = typed("msd", v)?;
            p.lags = lags::every_origin(t, p.lags.take(), p.rel_tol)?;
            let tables = t
                .iter()
                .map(|x| msd::compute(x, &p))
                .collect::<Result<Vec<_>>>()?;
            let (main, errors) = pool::seed_to_seed(&tables)?;
            Ok(Tables::one(main, errors))
        },
    },
    Observable {
        name: "diffusion",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "D from the long-time MSD slope over [fit_min_tau, fit_max_tau] x tau_alpha (Fig. 9), one jackknife: D, D_err, tau_alpha, tau_alpha_err, t_fit_min, t_fit_max, points",
        validate: |v| typed::<msd::DiffusionParams>("diffusion", v).map(drop),
        compute: |t, v| {
            let p: msd::DiffusionParams = typed("diffusion", v)?;
            Ok(Tables::one(msd::diffusion(t, &p)?, jackknife(t)))
        },
    },
    Observable {
        name: "van_hove",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "self part of the van Hove function P(dx, t): t, dx, P, P_err",
        validate: |v| typed::<van_hove::Params>("van_hove", v).map(drop),
        compute: |t, v| per_replica("van_hove", t, v, van_hove::compute),
    },
    Observable {
        name: "gr",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "partial pair correlations g_ab(r) with their first minima: a, b, r, g, r_min",
        validate: |v| typed::<gr::Params>("gr", v).map(drop),
        compute: |t, v| per_replica("gr", t, v, gr::compute),
    },
    Observable {
        name: "clusters",
        at: lags::AtLag::Nearest,
        takes_drive: false,
        describe: "slow and fast clusters (Eq. 10) with size and radius of gyration, every replica: replica, t, t0, kind, Nc, Rg, spans",
        validate: |v| typed::<clusters::Params>("clusters", v).map(drop),
        compute: |t, v| {
            let b = concat("clusters", t, v, clusters::compute)?;
            // Nc is a particle count here (a bin centre in `cluster_sizes`).
            let b = crate::table::integer_columns(&b, |c| c == "Nc")?;
            Ok(Tables::one(b, Errors::Rows { replicas: t.len() }))
        },
    },
    Observable {
        name: "cluster_sizes",
        at: lags::AtLag::Nearest,
        takes_drive: false,
        describe: "log-binned cluster size distribution P(Nc) of the clusters of every replica: t, kind, Nc, P, P_err, n_clusters",
        validate: |v| typed::<clusters::Params>("cluster_sizes", v).map(drop),
        compute: |t, v| {
            let p: clusters::Params = typed("cluster_sizes", v)?;
            let rows = concat("cluster_sizes", t, v, clusters::compute)?;
            let b = clusters::sizes_table(&rows, &p)?;
            // Clusters of one time origin, and of overlapping origins, are not
            // independent: the fits of P(Nc) take their errors from the replicas.
            let left_out = if t.len() >= 2 {
                clusters::sizes_left_out(&rows, &p, &b)?
            } else {
                Vec::new()
            };
            let mut tables = Tables::one(b, Errors::Rows { replicas: t.len() });
            tables.left_out = left_out;
            Ok(tables)
        },
    },
    Observable {
        name: "mobility_snapshot",
        at: lags::AtLag::Nearest,
        takes_drive: false,
        describe: "one frame per replica with each disk's mobility class over the first lag (Fig. 10): replica, t, t0, x, y, radius, class (0 slow, 1 fast, 2 neither)",
        validate: |v| typed::<clusters::Params>("mobility_snapshot", v).map(drop),
        compute: |t, v| {
            let b = concat("mobility_snapshot", t, v, clusters::compute_snapshot)?;
            Ok(Tables::one(b, Errors::Rows { replicas: t.len() }))
        },
    },
    Observable {
        name: "intruder_velocity",
        at: lags::AtLag::Interpolate,
        takes_drive: true,
        describe: "stationary intruder velocity over time blocks of every replica (paper I): v, v_err, v_first, v_second, stationary, snr, v_bath, v_rel (+ _err), mass_total, n_blocks; with drive: {eps, gamma, temperature} also v_dr, v_over_vdr, vdr2_sqrt_eta; with kick_rate_factor (and drive) also kick_dt, collision_momentum",
        validate: |v| typed::<intruder::VelocityParams>("intruder_velocity", v).map(drop),
        compute: |t, v| {
            let p: intruder::VelocityParams = typed("intruder_velocity", v)?;
            let b = intruder::velocity_table(t, &p)?;
            Ok(Tables::one(b, Errors::TimeBlocks { replicas: t.len() }))
        },
    },
    Observable {
        name: "intruder_path",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "intruder path of every replica (paper I, Fig. 4 inset): replica, t, x, v",
        validate: |v| typed::<intruder::VelocityParams>("intruder_path", v).map(drop),
        compute: |t, v| {
            let b = concat("intruder_path", t, v, intruder::compute_path)?;
            Ok(Tables::one(b, Errors::Rows { replicas: t.len() }))
        },
    },
    Observable {
        name: "intruder_diffusion",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "intruder diffusion along x at F = 0 and the Einstein mobility (paper I): D, T_x, mu_einstein = D / T_x (+ _err over replicas)",
        validate: |v| typed::<intruder::DiffusionParams>("intruder_diffusion", v).map(drop),
        compute: |t, v| {
            let p: intruder::DiffusionParams = typed("intruder_diffusion", v)?;
            Ok(Tables::one(
                intruder::diffusion_table(t, &p)?,
                Errors::Rows { replicas: t.len() },
            ))
        },
    },
    Observable {
        name: "momentum_profile",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "momentum density profile Px(x) at given times (paper I): t, x, Px (+ Px_err over replicas)",
        validate: |v| typed::<intruder::ProfileParams>("momentum_profile", v).map(drop),
        compute: |t, v| per_replica("momentum_profile", t, v, intruder::compute_profile),
    },
    Observable {
        name: "velocity_field",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "bath velocity field on square cells at given times, pooled over replicas (paper I, Fig. 1): t, x, y, vx, vy; intruder.parquet: t, x, y (mean over replicas)",
        validate: |v| typed::<front::FieldParams>("velocity_field", v).map(drop),
        compute: |t, v| {
            let p: front::FieldParams = typed("velocity_field", v)?;
            let (main, intruder) = front::velocity_field(t, &p)?;
            Ok(Tables {
                main,
                extra: vec![("intruder.parquet", intruder)],
                errors: Errors::Mean { replicas: t.len() },
                left_out: Vec::new(),
            })
        },
    },
    Observable {
        name: "front",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        describe: "momentum front from Px(x) (paper I, Fig. 2): quantity, value, error, note for V_cm, V_br, V_ratio, eta_wall (jackknife over replicas); positions.parquet: t, x_cm, Px_cm, width, eta_wall (+ _err); lines.parquet: the fitted x_cm(t), width(t)",
        validate: |v| typed::<front::FrontParams>("front", v).map(drop),
        compute: |t, v| {
            let p: front::FrontParams = typed("front", v)?;
            let [main, positions, lines] = front::front(t, &p)?;
            Ok(Tables {
                main,
                extra: vec![("positions.parquet", positions), ("lines.parquet", lines)],
                errors: Errors::ReplicaJackknife { replicas: t.len() },
                left_out: Vec::new(),
            })
        },
    },
];

/// Run the observable `kind` (one of [`OBSERVABLES`]) on one trajectory,
/// with its parameters given as a JSON/YAML value (unknown keys and wrong types are
/// errors naming the kind). The same function a pipeline's analysis stage calls on
/// the replicas it gathers; this returns the main table.
pub fn run(kind: &str, params: Value, traj: &Trajectory) -> Result<RecordBatch> {
    Ok((find(kind)?.compute)(&[traj], &params)?.main)
}

/// The observable called `name`, or an error listing them all.
pub fn find(name: &str) -> Result<&'static Observable> {
    OBSERVABLES.iter().find(|o| o.name == name).ok_or_else(|| {
        anyhow::anyhow!(
            "unknown analysis kind `{name}`; known kinds: {}",
            OBSERVABLES
                .iter()
                .map(|o| o.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::{ballistic, independent_slow};
    use crate::analysis::test_support::{col, err_text, schedule_times};

    #[test]
    fn bad_parameters_are_clear_errors() {
        let traj = independent_slow(100, [10.0, 10.0], 2, 0.5, 1.0, 1);
        let e = err_text(overlap::compute(
            &traj,
            &overlap::Params {
                a: 0.0,
                ..Default::default()
            },
        ));
        assert!(e.contains("`a`") && e.contains("> 0"), "{e}");
        let e = err_text(chi4::compute(
            &traj,
            &chi4::Params {
                a: 0.6,
                n: vec![1e6],
                lags: None,
                rel_tol: 1e-6,
                variance: chi4::Variance::default(),
            },
        ));
        assert!(e.contains("N = 1000000") && e.contains("(0, 100]"), "{e}");
        let e = err_text(overlap::compute(
            &traj,
            &overlap::Params {
                lags: Some(vec![3.7]),
                ..Default::default()
            },
        ));
        assert!(e.contains("lag 3.7") && e.contains("not realised"), "{e}");
        let e = err_text(s4::compute(
            &traj,
            &s4::Params {
                a: 0.6,
                lags: vec![1.0],
                n: None,
                q_max: 0.1,
                dq: None,
                tolerance: 1e-6,
                rel_tol: 1e-6,
            },
        ));
        assert!(e.contains("q_max"), "{e}");
        let e = err_text(run(
            "chi4",
            serde_json::json!({"n": [10], "bogus": 1}),
            &traj,
        ));
        assert!(e.contains("'chi4'") && e.contains("bogus"), "{e}");
        let e = err_text(run("chi5", serde_json::json!({}), &traj));
        assert!(e.contains("chi5") && e.contains("chi4_peaks"), "{e}");
        // Every kind is dispatched (a missing arm would report an unknown kind).
        for kind in OBSERVABLES.iter().map(|o| o.name) {
            let e = format!(
                "{:#}",
                run(kind, serde_json::json!({"bogus": 1}), &traj).unwrap_err()
            );
            assert!(e.contains(&format!("'{kind}'")), "{kind}: {e}");
        }
    }

    #[test]
    fn every_kind_runs_from_json_parameters() {
        use serde_json::json;
        let times = schedule_times(4, 20.0, 0.1, 10.0);
        let mut traj = ballistic(400, [30.0, 30.0], &times, 8);
        traj.species[0] = 2;
        traj.radii.push(2.0);
        traj.masses.push(4.0);
        let cut = json!([[1.2, 1.3, 2.0], [1.3, 1.5, 2.0], [2.0, 2.0, 2.5]]);
        let cases = [
            ("overlap", json!({"lags": [0.1, 1.0]}), "Q"),
            ("tau_alpha", json!({"a": 0.6}), "tau_alpha"),
            ("q_levels", json!({"levels": [0.6]}), "t_over_tau_alpha"),
            ("diffusion", json!({"fit_min_tau": 1.0}), "D"),
            ("aging", json!({"lags": [0.1, 1.0]}), "t0"),
            ("chi4", json!({"n": [50, 100], "lags": [1.0]}), "chi4"),
            ("chi4_peaks", json!({"n": [50]}), "tau4"),
            ("s4", json!({"lags": [1.0], "q_max": 1.0}), "S4"),
            ("msd", json!({"fractions": [0.1]}), "msd"),
            ("van_hove", json!({"lags": [1.0]}), "P"),
            ("gr", json!({"r_max": 5.0}), "g"),
            ("clusters", json!({"lags": [1.0], "cutoffs": cut}), "Rg"),
            ("cluster_sizes", json!({"lags": [1.0], "cutoffs": cut}), "P"),
            ("mobility_snapshot", json!({"lags": [1.0]}), "class"),
            ("intruder_velocity", json!({"blocks": 2}), "v"),
            ("intruder_path", json!({}), "x"),
            ("momentum_profile", json!({"times": [1.0], "bins": 6}), "Px"),
            (
                "intruder_diffusion",
                json!({"lag_min": 0.5, "lag_max": 10.0}),
                "D",
            ),
            (
                "velocity_field",
                json!({"times": [1.0], "cells_x": 5}),
                "vx",
            ),
            (
                "front",
                json!({"bin": 2.0, "fit": [0.0, 10.0], "compact": [0.0, 10.0], "wall": {"width": 5.0}}),
                "value",
            ),
        ];
        assert_eq!(cases.len(), OBSERVABLES.len());
        for (kind, params, column) in cases {
            let b = run(kind, params, &traj).unwrap_or_else(|e| panic!("{kind}: {e:#}"));
            assert!(b.num_rows() > 0, "{kind}: empty table");
            assert!(
                col(&b, column).iter().any(|v| v.is_finite()),
                "{kind}: no finite {column}"
            );
        }
    }
}
