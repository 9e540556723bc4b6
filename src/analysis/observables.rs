//! The observables a pipeline can ask for, by name: one line each in [`OBSERVABLES`]
//! (name, what it computes, its function of its typed parameters). The generic
//! analysis stage (`stages::analyse`) turns every line into a stage kind, and
//! [`run`] calls the same line on one trajectory: a name means one thing.
//!
//! Each function gets every trajectory gathered into the stage (replicas of one
//! state point) and pools them: observables built on blocks pool (replica, time
//! origin) blocks in one jackknife; the others are computed per replica and pooled
//! seed to seed ([`pool::seed_to_seed`]); lists of objects (clusters, paths) are
//! concatenated with a `replica` column. The table's metadata says which.

use std::any::Any;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use arrow_array::{ArrayRef, Int64Array, RecordBatch};
use serde::de::DeserializeOwned;
use serde_json::Value;

use super::observable_params::{Lags, LagsFrom, ObservableParams, checked};
use super::pool::{self, Errors};
use super::{chi4, clusters, front, gr, intruder, lags, msd, order, overlap, s4, van_hove};
use crate::pipeline::registry::{param_keys, typed};
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
    /// How `at` (times in units of a measured time) reads it between lags.
    pub at: lags::AtLag,
    /// Whether it takes the drive of its runs (`drive`, `kick_rate_factor`):
    /// the analysis stage reads them from the runs it analyses.
    pub takes_drive: bool,
    /// Whether it analyses the window its experiment names
    /// ([`crate::analysis::window`]): every observable but the one that
    /// measures the window itself (aging, over every origin).
    pub windowed: bool,
    /// The modules of [`MEMBERS`] its function runs (with what they import):
    /// its stages' key covers these, not the other observables' modules.
    /// tests/keys.rs checks that every member module named in its line is here.
    pub modules: &'static [&'static str],
    /// Its parameters' type and its function of them.
    typed: &'static dyn TypedCompute,
}

/// The modules that compute observables. The catalogues ([`CATALOGUES`]) name
/// them all; an observable's key follows their edges only to its own
/// ([`Observable::modules`]), so an edit of one observable's code reruns the
/// stages of the observables that run it and no others.
pub const MEMBERS: &[&str] = &[
    "analysis/chi4",
    "analysis/clusters",
    "analysis/front",
    "analysis/gr",
    "analysis/intruder",
    "analysis/msd",
    "analysis/order",
    "analysis/overlap",
    "analysis/s4",
    "analysis/van_hove",
];

/// The modules that name every observable to dispatch by name: this one and
/// the parameter types' trait implementations. Their own text is in every
/// observable's key.
pub const CATALOGUES: &[&str] = &["analysis/observables", "analysis/observable_params"];

impl Observable {
    /// The catalogues' edges to the member modules this observable does not
    /// run: what its key does not follow ([`crate::pipeline::StageKind::not_followed`]).
    pub fn not_followed(&self) -> Vec<(&'static str, &'static str)> {
        CATALOGUES
            .iter()
            .flat_map(|c| {
                MEMBERS
                    .iter()
                    .filter(|m| !self.modules.contains(m))
                    .map(move |m| (*c, *m))
            })
            .collect()
    }
}

impl Observable {
    /// Parse its parameters into their type, once (unknown keys and wrong types
    /// are errors naming the kind and the key); `lags` says whether they give
    /// the lags or `at:` sets them after.
    pub fn parse(&self, params: &Value, lags: LagsFrom) -> Result<Box<dyn ObservableParams>> {
        self.typed.parse(self.name, params, lags)
    }

    /// Compute it from the gathered trajectories, with parameters from [`Self::parse`].
    pub fn compute(&self, trajs: &[&Trajectory], params: &dyn ObservableParams) -> Result<Tables> {
        self.typed.compute(self.name, trajs, params)
    }

    /// The keys its parameters accept, read from their type ([`param_keys`]).
    pub fn param_keys(&self) -> Vec<String> {
        param_keys(|v| self.parse(v, LagsFrom::Params).map(drop))
    }
}

/// An observable's function of its own parameters type `P`: the parse into `P`
/// and the one way back from [`ObservableParams`] for every observable.
struct Typed<P>(fn(&[&Trajectory], &P) -> Result<Tables>);

/// [`Typed`] with its parameters type erased, as an [`Observable`] holds it.
trait TypedCompute: Sync {
    fn parse(&self, kind: &str, v: &Value, lags: LagsFrom) -> Result<Box<dyn ObservableParams>>;
    fn compute(
        &self,
        kind: &str,
        trajs: &[&Trajectory],
        p: &dyn ObservableParams,
    ) -> Result<Tables>;
}

impl<P: ObservableParams + DeserializeOwned> TypedCompute for Typed<P> {
    fn parse(&self, kind: &str, v: &Value, lags: LagsFrom) -> Result<Box<dyn ObservableParams>> {
        let mut p: P = typed(kind, v)?;
        checked(kind, &mut p, lags)?;
        Ok(Box::new(p))
    }

    fn compute(
        &self,
        kind: &str,
        trajs: &[&Trajectory],
        p: &dyn ObservableParams,
    ) -> Result<Tables> {
        let any: &dyn Any = p;
        let p = any.downcast_ref::<P>().with_context(|| {
            format!("internal: analysis `{kind}` given parameters parsed by another kind")
        })?;
        (self.0)(trajs, p)
    }
}

/// `p` at every lag each time origin realises, unless it gives its lags.
fn at_every_origin<P: ObservableParams + Clone>(trajs: &[&Trajectory], p: &P) -> Result<P> {
    let mut p = p.clone();
    if let Some(Lags::Optional {
        lags: given,
        rel_tol,
    }) = p.lags()
    {
        *given = lags::every_origin(trajs, given.take(), rel_tol)?;
    }
    Ok(p)
}

fn chi4_pooled(trajs: &[&Trajectory], p: &chi4::Params) -> Result<chi4::Params> {
    let mut p = at_every_origin(trajs, p)?;
    chi4::resolve_sizes(&mut p, trajs.first().map_or(0, |t| t.n()));
    Ok(p)
}

fn jackknife(trajs: &[&Trajectory]) -> Errors {
    Errors::Jackknife {
        replicas: trajs.len(),
    }
}

/// Per replica, then pooled seed to seed.
fn per_replica<P>(
    trajs: &[&Trajectory],
    p: &P,
    f: fn(&Trajectory, &P) -> Result<RecordBatch>,
) -> Result<Tables> {
    let tables = trajs.iter().map(|t| f(t, p)).collect::<Result<Vec<_>>>()?;
    let (main, errors) = pool::seed_to_seed(&tables)?;
    Ok(Tables::one(main, errors))
}

/// Per replica, rows concatenated with a `replica` column first.
fn concat<P>(
    name: &str,
    trajs: &[&Trajectory],
    p: &P,
    f: fn(&Trajectory, &P) -> Result<RecordBatch>,
) -> Result<RecordBatch> {
    let mut out = Vec::new();
    for (r, t) in trajs.iter().enumerate() {
        let b = f(t, p)?;
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
/// of `src/analysis`, its parameters type made an [`ObservableParams`]
/// (`observable_params.rs`), and one line here.
pub static OBSERVABLES: &[Observable] = &[
    Observable {
        name: "overlap",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/overlap"],
        describe: "Q(t) (paper H, Eq. 5-7) pooled over replicas and time origins: t, Q, Q_err, n_origins",
        typed: &Typed(|t, p: &overlap::Params| {
            let p = at_every_origin(t, p)?;
            let (lag, q, n) = overlap::q_curve(t, &p)?;
            let b = f64_batch(&[
                ("t", lag),
                ("Q", q.iter().map(|e| e.value).collect()),
                ("Q_err", q.iter().map(|e| e.err).collect()),
                ("n_origins", n.iter().map(|&k| k as f64).collect()),
            ])?;
            Ok(Tables::one(b, jackknife(t)))
        }),
    },
    Observable {
        name: "tau_alpha",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/overlap"],
        describe: "tau_alpha where Q = 1/e, pooled replicas, jackknife error: one row tau_alpha, tau_alpha_err, replicas",
        typed: &Typed(|t, p: &overlap::Params| {
            let p = at_every_origin(t, p)?;
            let tau = overlap::tau_alpha(t, &p)?;
            let b = f64_batch(&[
                ("tau_alpha", vec![tau.value]),
                ("tau_alpha_err", vec![tau.err]),
                ("replicas", vec![t.len() as f64]),
            ])?;
            Ok(Tables::one(b, jackknife(t)))
        }),
    },
    Observable {
        name: "q_levels",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/overlap"],
        describe: "time-density superposition test (Fig. 5): t where Q = each level and t/tau_alpha, one jackknife: level, t, t_err, tau_alpha, t_over_tau_alpha, t_over_tau_alpha_err",
        typed: &Typed(|t, p: &overlap::LevelParams| {
            let p = at_every_origin(t, p)?;
            Ok(Tables::one(overlap::q_levels(t, &p)?, jackknife(t)))
        }),
    },
    Observable {
        name: "aging",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: false,
        modules: &["analysis/overlap"],
        describe: "Q(t; t0) per waiting time t0 averaged over replicas (Fig. 2): t0, t, Q; tau.parquet: t0, tau_alpha, tau_alpha_err (replica jackknife)",
        typed: &Typed(|t, p: &overlap::Params| {
            let p = at_every_origin(t, p)?;
            let (main, tau) = overlap::aging(t, &p)?;
            Ok(Tables {
                main,
                extra: vec![("tau.parquet", tau)],
                errors: Errors::Mean { replicas: t.len() },
                left_out: Vec::new(),
            })
        }),
    },
    Observable {
        name: "chi4",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/chi4"],
        describe: "chi4(t) (paper H, Eq. 14) per sub-box size N, pooled replicas: N, t, Q, chi4, chi4_err, n_origins",
        typed: &Typed(|t, p: &chi4::Params| {
            let p = chi4_pooled(t, p)?;
            Ok(Tables::one(chi4::compute_pooled(t, &p)?, jackknife(t)))
        }),
    },
    Observable {
        name: "chi4_peaks",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/chi4"],
        describe: "chi4 peak per sub-box size with tau_alpha and chi4(tau_alpha): N, tau4, chi4P, tau_alpha, chi4_tau_alpha (+ _err)",
        typed: &Typed(|t, p: &chi4::Params| {
            let p = chi4_pooled(t, p)?;
            Ok(Tables::one(chi4::peaks_table(t, &p)?, jackknife(t)))
        }),
    },
    Observable {
        name: "s4",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/s4"],
        describe: "four-point structure factor S4(q, t) per shell, q = 0 first (chi4 of the whole system), time origins of every replica pooled: L, t, q, q2, S4, S4_err, n_vectors",
        typed: &Typed(|t, p: &s4::Params| {
            let b = s4::compute_pooled(t, p)?;
            Ok(Tables::one(b, Errors::TimeBlocks { replicas: t.len() }))
        }),
    },
    Observable {
        name: "msd",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/msd"],
        describe: "mean-squared displacement, all / per species / fastest and slowest fractions: t, species, select, fraction, msd, msd_err, n_origins",
        typed: &Typed(|t, p: &msd::Params| {
            let p = at_every_origin(t, p)?;
            let tables = t
                .iter()
                .map(|x| msd::compute(x, &p))
                .collect::<Result<Vec<_>>>()?;
            let (main, errors) = pool::seed_to_seed(&tables)?;
            Ok(Tables::one(main, errors))
        }),
    },
    Observable {
        name: "diffusion",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/msd"],
        describe: "D from the long-time MSD slope over [fit_min_tau, fit_max_tau] x tau_alpha (Fig. 9), one jackknife: D, D_err, tau_alpha, tau_alpha_err, t_fit_min, t_fit_max, points",
        typed: &Typed(|t, p: &msd::DiffusionParams| {
            Ok(Tables::one(msd::diffusion(t, p)?, jackknife(t)))
        }),
    },
    Observable {
        name: "van_hove",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/van_hove"],
        describe: "self part of the van Hove function P(dx, t): t, dx, P, P_err",
        typed: &Typed(|t, p: &van_hove::Params| per_replica(t, p, van_hove::compute)),
    },
    Observable {
        name: "gr",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/gr"],
        describe: "partial pair correlations g_ab(r) with their first minima: a, b, r, g, r_min",
        typed: &Typed(|t, p: &gr::Params| per_replica(t, p, gr::compute)),
    },
    Observable {
        name: "order",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/order"],
        describe: "bond-orientational order and local composition of every recorded frame: t, psi6 (mean |psi6_j|), psi6_global (|mean psi6_j|), small_fraction_var (variance of the small-disk fraction over the sub-boxes of chi4 / its binomial value; 1 random, > 1 demixed)",
        typed: &Typed(|t, p: &order::Params| per_replica(t, p, order::compute)),
    },
    Observable {
        name: "clusters",
        at: lags::AtLag::Nearest,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/clusters"],
        describe: "slow and fast clusters (Eq. 10) with size and radius of gyration, every replica: replica, t, t0, kind, Nc, Rg, spans",
        typed: &Typed(|t, p: &clusters::Params| {
            let b = concat("clusters", t, p, clusters::compute)?;
            // Nc is a particle count here (a bin centre in `cluster_sizes`).
            let b = crate::table::integer_columns(&b, |c| c == "Nc")?;
            Ok(Tables::one(b, Errors::Rows { replicas: t.len() }))
        }),
    },
    Observable {
        name: "cluster_sizes",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/clusters"],
        describe: "log-binned cluster size distribution P(Nc) of the clusters of every replica: t, kind, Nc, P, P_err, n_clusters",
        typed: &Typed(|t, p: &clusters::Params| {
            let rows = concat("cluster_sizes", t, p, clusters::compute)?;
            let b = clusters::sizes_table(&rows, p)?;
            // Clusters of one time origin, and of overlapping origins, are not
            // independent: the fits of P(Nc) take their errors from the replicas.
            let left_out = if t.len() >= 2 {
                clusters::sizes_left_out(&rows, p, &b)?
            } else {
                Vec::new()
            };
            let mut tables = Tables::one(b, Errors::Rows { replicas: t.len() });
            tables.left_out = left_out;
            Ok(tables)
        }),
    },
    Observable {
        name: "mobility_snapshot",
        at: lags::AtLag::Nearest,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/clusters"],
        describe: "one frame per replica with each disk's mobility class over the first lag (Fig. 10): replica, t, t0, x, y, radius, class (0 slow, 1 fast, 2 neither)",
        typed: &Typed(|t, p: &clusters::Params| {
            let b = concat("mobility_snapshot", t, p, clusters::compute_snapshot)?;
            Ok(Tables::one(b, Errors::Rows { replicas: t.len() }))
        }),
    },
    Observable {
        name: "intruder_velocity",
        at: lags::AtLag::Interpolate,
        takes_drive: true,
        windowed: true,
        modules: &["analysis/intruder"],
        describe: "stationary intruder velocity over time blocks of every replica (paper I): v, v_err, v_first, v_second, stationary, snr, v_bath, v_rel (+ _err), mass_total, n_blocks; with drive: {eps, gamma, temperature} also v_dr, v_over_vdr, vdr2_sqrt_eta; with kick_rate_factor (and drive) also kick_dt, collision_momentum",
        typed: &Typed(|t, p: &intruder::VelocityParams| {
            let b = intruder::velocity_table(t, p)?;
            Ok(Tables::one(b, Errors::TimeBlocks { replicas: t.len() }))
        }),
    },
    Observable {
        name: "intruder_path",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/intruder"],
        describe: "intruder path of every replica (paper I, Fig. 4 inset): replica, t, x, v",
        typed: &Typed(|t, p: &intruder::VelocityParams| {
            let b = concat("intruder_path", t, p, intruder::compute_path)?;
            Ok(Tables::one(b, Errors::Rows { replicas: t.len() }))
        }),
    },
    Observable {
        name: "intruder_diffusion",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/intruder"],
        describe: "intruder diffusion along x at F = 0 and the Einstein mobility (paper I): D, T_x, mu_einstein = D / T_x (+ _err over replicas)",
        typed: &Typed(|t, p: &intruder::DiffusionParams| {
            Ok(Tables::one(
                intruder::diffusion_table(t, p)?,
                Errors::Rows { replicas: t.len() },
            ))
        }),
    },
    Observable {
        name: "momentum_profile",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/intruder"],
        describe: "momentum density profile Px(x) at given times (paper I): t, x, Px (+ Px_err over replicas)",
        typed: &Typed(|t, p: &intruder::ProfileParams| {
            per_replica(t, p, intruder::compute_profile)
        }),
    },
    Observable {
        name: "velocity_field",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/front"],
        describe: "bath velocity field on square cells at given times, pooled over replicas (paper I, Fig. 1): t, x, y, vx, vy; intruder.parquet: t, x, y (mean over replicas)",
        typed: &Typed(|t, p: &front::FieldParams| {
            let (main, intruder) = front::velocity_field(t, p)?;
            Ok(Tables {
                main,
                extra: vec![("intruder.parquet", intruder)],
                errors: Errors::Mean { replicas: t.len() },
                left_out: Vec::new(),
            })
        }),
    },
    Observable {
        name: "front",
        at: lags::AtLag::Interpolate,
        takes_drive: false,
        windowed: true,
        modules: &["analysis/front"],
        describe: "momentum front from Px(x) (paper I, Fig. 2): quantity, value, error, note for V_cm, V_br, V_ratio, eta_wall (jackknife over replicas); positions.parquet: t, x_cm, Px_cm, width, eta_wall (+ _err); lines.parquet: the fitted x_cm(t), width(t)",
        typed: &Typed(|t, p: &front::FrontParams| {
            let [main, positions, lines] = front::front(t, p)?;
            Ok(Tables {
                main,
                extra: vec![("positions.parquet", positions), ("lines.parquet", lines)],
                errors: Errors::ReplicaJackknife { replicas: t.len() },
                left_out: Vec::new(),
            })
        }),
    },
];

/// Run the observable `kind` (one of [`OBSERVABLES`]) on one trajectory,
/// with its parameters given as a JSON/YAML value (unknown keys and wrong types are
/// errors naming the kind). The same function a pipeline's analysis stage calls on
/// the replicas it gathers; this returns the main table.
pub fn run(kind: &str, params: Value, traj: &Trajectory) -> Result<RecordBatch> {
    let obs = find(kind)?;
    let p = obs.parse(&params, LagsFrom::Params)?;
    Ok(obs.compute(&[traj], p.as_ref())?.main)
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
                fractions: Vec::new(),
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

    /// Lags set on the parsed parameters (as `at:` sets them) give the table
    /// of the same lags in the parameters; the lags' checks name the key.
    #[test]
    fn lags_set_after_the_parse_equal_lags_given() {
        use serde_json::json;
        let traj = ballistic(400, [30.0, 30.0], &schedule_times(4, 20.0, 0.1, 10.0), 8);
        for (kind, rest) in [("overlap", json!({})), ("s4", json!({"q_max": 1.0}))] {
            let obs = find(kind).unwrap();
            let mut p = obs.parse(&rest, LagsFrom::At).unwrap();
            let mut other = p.clone();
            p.set_lags(vec![1.0]);
            other.set_lags(vec![0.1]);
            let mut given = rest.clone();
            given["lags"] = json!([1.0]);
            let set = obs.compute(&[&traj], p.as_ref()).unwrap().main;
            assert_eq!(set, run(kind, given, &traj).unwrap(), "{kind}");
            assert_ne!(set, obs.compute(&[&traj], other.as_ref()).unwrap().main);
        }
        let s4 = find("s4").unwrap();
        let e = err_text(s4.parse(&json!({"q_max": 1.0}), LagsFrom::Params));
        assert!(e.contains("'s4'") && e.contains("`lags`"), "{e}");
        let e = err_text(
            find("overlap")
                .unwrap()
                .parse(&json!({"lags": [1.0]}), LagsFrom::At),
        );
        assert!(e.contains("`at` or `lags`, not both"), "{e}");
        let e = err_text(find("gr").unwrap().parse(&json!({}), LagsFrom::At));
        assert!(e.contains("`gr` is not computed at lags"), "{e}");
    }

    #[test]
    fn the_drive_is_set_typed() {
        use crate::analysis::drive::DriveParams;
        let obs = find("intruder_velocity").unwrap();
        let mut p = obs
            .parse(&serde_json::json!({"blocks": 2}), LagsFrom::Params)
            .unwrap();
        assert_eq!(p.drive(), (None, None));
        let drive = DriveParams {
            eps: 0.7,
            gamma: 1.0,
            temperature: 1.0,
        };
        p.set_drive(drive.clone(), Some(1000.0));
        assert_eq!(p.drive(), (Some(&drive), Some(1000.0)));
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
            ("order", json!({"cutoff": 1.4, "n": 40}), "psi6"),
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
