//! What every column the project publishes means: its unit and a one-line
//! description, written into each Parquet field's metadata (`unit`,
//! `description`; pandas and pyarrow show them) by [`super::to_parquet_bytes`].
//!
//! Units: lengths in r1 (small-disk radius), times in r1 sqrt(m1/T), wavenumbers
//! in 1/r1; "1" is dimensionless. A suffix `_err` is the 1-sigma error of its base
//! column, `t_over_X` is t in units of the measured time X.

use super::results;

/// (column, unit, description), one line each.
const COLUMNS: &[(&str, &str, &str)] = &[
    ("phi", "1", "packing fraction (area fraction of the disks)"),
    ("eps", "1", "coefficient of normal restitution"),
    (
        "replica",
        "1",
        "replica index (independent seed at one state point)",
    ),
    ("replicas", "1", "number of replicas pooled"),
    (
        "N",
        "1",
        "mean number of particles in a sub-box (the whole system when it equals the particle number)",
    ),
    ("N_sub", "1", "mean number of particles in a sub-box"),
    (
        "a",
        "r1",
        "mobility cut-off of the overlap (paper H, Eq. 5); in g_ab tables: species of the first particle",
    ),
    ("t", "r1 sqrt(m1/T)", "lag time between the two frames"),
    (
        "t0",
        "r1 sqrt(m1/T)",
        "waiting time: the time origin, measured from the first frame",
    ),
    (
        "Q",
        "1",
        "overlap: fraction of particles that moved less than a (paper H, Eq. 5-7)",
    ),
    (
        "n_origins",
        "1",
        "number of (replica, time origin) pairs averaged at this lag",
    ),
    (
        "tau_alpha",
        "r1 sqrt(m1/T)",
        "structural relaxation time: Q(tau_alpha) = 1/e",
    ),
    (
        "chi4",
        "1",
        "dynamic susceptibility N [<Q_r^2> - <Q_r>^2] (paper H, Eq. 14)",
    ),
    ("tau4", "r1 sqrt(m1/T)", "time of the chi4(t) peak"),
    ("chi4P", "1", "height of the chi4(t) peak"),
    (
        "chi4_tau_alpha",
        "1",
        "chi4 at t = tau_alpha, interpolated in ln t",
    ),
    ("q", "1/r1", "wavenumber: shell mean of |q|"),
    (
        "q2",
        "1/r1^2",
        "shell mean of q^2 (the abscissa of OZ fits)",
    ),
    (
        "S4",
        "1",
        "four-point structure factor S4(q, t) (paper H, Eq. 16)",
    ),
    ("n_vectors", "1", "number of wave vectors in the shell"),
    (
        "species",
        "1",
        "species (0 small, 1 large, 2 intruder; -1 all particles)",
    ),
    (
        "select",
        "1",
        "subset: 0 every particle of the group, +1 fastest, -1 slowest fraction",
    ),
    (
        "fraction",
        "1",
        "fraction of the group selected (1 when select = 0)",
    ),
    (
        "msd",
        "r1^2",
        "mean squared displacement Delta(t) (paper H, Eq. 9)",
    ),
    ("dx", "r1", "displacement along one axis"),
    (
        "P",
        "1",
        "probability density (van Hove: per unit dx, 1/r1) or fraction of clusters of size Nc",
    ),
    ("b", "1", "species of the second particle"),
    ("r", "r1", "distance between particle centres"),
    ("g", "1", "partial pair correlation g_ab(r)"),
    (
        "r_min",
        "r1",
        "first minimum of g_ab(r) after its main peak",
    ),
    ("kind", "1", "cluster kind: 0 slow, 1 fast"),
    ("Nc", "1", "number of particles in a cluster"),
    ("Rg", "r1", "radius of gyration of a cluster"),
    ("spans", "1", "whether the cluster spans the periodic box"),
    ("n_clusters", "1", "number of clusters in the bin"),
    ("v", "sqrt(T/m1)", "intruder velocity along x"),
    ("n_blocks", "1", "number of time blocks averaged"),
    ("x", "r1", "position along x"),
    ("y", "r1", "position along y"),
    ("Px", "sqrt(m1 T)/r1^2", "momentum density along x"),
    // Paper I: the pulled intruder and the compacted front (Figs. 1-6).
    (
        "force",
        "T/r1",
        "force pulling the intruder along x (paper I, Eq. 3)",
    ),
    (
        "temperature",
        "T",
        "bath temperature the drive holds (paper I, Eq. 7)",
    ),
    (
        "v_first",
        "sqrt(T/m1)",
        "intruder velocity over the first half of the time blocks",
    ),
    (
        "v_second",
        "sqrt(T/m1)",
        "intruder velocity over the second half of the time blocks",
    ),
    (
        "stationary",
        "1",
        "1 if v_first and v_second agree within three errors, else 0",
    ),
    ("snr", "1", "signal to noise ratio v / v_err"),
    (
        "v_bath",
        "sqrt(T/m1)",
        "centre-of-mass velocity of the bath along x (intruder left out)",
    ),
    (
        "v_rel",
        "sqrt(T/m1)",
        "intruder velocity relative to the bath, v - v_bath",
    ),
    (
        "mass_total",
        "m1",
        "mass of all particles (the bath drifts at F / (gamma mass_total), paper I Eq. 11)",
    ),
    (
        "v_dr",
        "sqrt(T/m1)",
        "drive velocity p_dr / m_eff of paper I, Eq. 7",
    ),
    (
        "v_over_vdr",
        "1",
        "intruder velocity over the drive velocity (paper I, Fig. 5)",
    ),
    (
        "vdr2_sqrt_eta",
        "T/m1",
        "v_dr^2 eta^(1/2), the force scale of paper I, Fig. 5",
    ),
    (
        "force_scaled",
        "1",
        "F / (v_dr^2 eta^(1/2)), the abscissa of paper I, Fig. 5",
    ),
    (
        "kick_dt",
        "r1 sqrt(m1/T)",
        "interval between two force kicks, 1 / (kick_rate_factor omega_E)",
    ),
    (
        "collision_momentum",
        "sqrt(m1 T)",
        "momentum one collision exchanges with the intruder, m_red (v^2 + 2T/m_red)^(1/2)",
    ),
    (
        "kick_impulse",
        "sqrt(m1 T)",
        "impulse of one force kick, F kick_dt",
    ),
    (
        "kick_over_collision",
        "1",
        "kick impulse over a collision's momentum (fits keep <= 0.01: the kicks resolve the force)",
    ),
    (
        "v_hot",
        "sqrt(T/m1)",
        "intruder velocity at T = 1 at the same (eta, F)",
    ),
    (
        "v_cold_over_hot",
        "1",
        "intruder velocity at T = 0.04 over that at T = 1 (paper I, Fig. 6)",
    ),
    ("mobility", "r1 sqrt(m1/T)/m1", "intruder mobility v / F"),
    (
        "mu_over_einstein",
        "1",
        "small-F mobility over the Einstein mobility D / T_x at F = 0 (1 in linear response)",
    ),
    (
        "D",
        "r1^2/(r1 sqrt(m1/T))",
        "intruder diffusion coefficient along x at F = 0",
    ),
    (
        "T_x",
        "T",
        "intruder kinetic temperature along x, m0 <vx^2>",
    ),
    (
        "mu_einstein",
        "r1 sqrt(m1/T)/m1",
        "mobility the Einstein relation predicts, D / T_x",
    ),
    (
        "vx",
        "sqrt(T/m1)",
        "velocity along x (cell average in velocity fields)",
    ),
    (
        "vy",
        "sqrt(T/m1)",
        "velocity along y (cell average in velocity fields)",
    ),
    (
        "x_cm",
        "r1",
        "centre of the compacted front: mean x weighted by the positive part of Px",
    ),
    (
        "Px_cm",
        "sqrt(m1 T)/r1^2",
        "mean momentum density profile Px at the front centre x_cm (to mark it)",
    ),
    (
        "width",
        "r1",
        "width of the front from the second moment of x weighted by the positive part of Px",
    ),
    (
        "eta_wall",
        "1",
        "packing fraction of the strip at the far wall (the compacted bath, paper I Fig. 1)",
    ),
    (
        "multiple",
        "1",
        "requested time in units of the measured time",
    ),
    (
        "requested",
        "r1 sqrt(m1/T)",
        "requested time: multiple x the measured time",
    ),
    (
        "lag_below",
        "r1 sqrt(m1/T)",
        "recorded lag at or below the request",
    ),
    (
        "lag_above",
        "r1 sqrt(m1/T)",
        "recorded lag at or above the request",
    ),
    (
        "weight_above",
        "1",
        "weight of lag_above in the interpolation in ln t: ln(requested/lag_below) / ln(lag_above/lag_below)",
    ),
    (results::QUANTITY, "", "name of a fitted or measured number"),
    (results::VALUE, "as the quantity", "its value"),
    (results::ERROR, "as the quantity", "its 1-sigma error"),
    (results::NOTE, "", "fit warnings, or `fit failed: ` and why"),
    (results::OURS, "as the quantity", "our value"),
    (results::PAPER, "as the quantity", "the paper's value"),
    (
        results::TOLERANCE,
        "as the quantity",
        "largest accepted |ours - paper|",
    ),
    (
        results::VERDICT,
        "",
        "agree, disagree, out_of_reach, unreliable or missing",
    ),
    (results::REASON, "", "why the verdict"),
    (
        results::SOURCE,
        "",
        "where the paper's value comes from: figure (measured in paper H) or ref12 (quoted from its reference 12)",
    ),
    (
        "short",
        "",
        "the short reason a figure's verdict line prints (empty: the reason's first clause)",
    ),
    (
        "x_min",
        "as the fitted x",
        "lower end of the fit window of a range scan",
    ),
    (
        "x_max",
        "as the fitted x",
        "upper end of the fit window of a range scan",
    ),
    ("n_points", "1", "number of data points in the fit window"),
    (
        "jk_unit",
        "1",
        "the set of replicas a row was computed from (rows sharing it are one jackknife unit)",
    ),
    ("X", "1", "collapse abscissa sqrt(N)/xi (paper H, Fig. 19)"),
    ("Y", "1", "collapse ordinate chi4P xi^-g"),
];

/// Whether column `name` counts something (origins, vectors, clusters, blocks,
/// pairs, replicas): such columns are published as Int64 (see
/// [`super::counts_as_integers`]) and summed, not averaged, when replicas are
/// pooled. `Nc` is not among them by name: it is a count in cluster tables but a
/// bin centre in size distributions, so the cluster observable types it itself.
pub fn is_count(name: &str) -> bool {
    name.starts_with("n_") || matches!(name, "replicas" | "replica" | "counts" | "count")
}

/// Unit and description of column `name`, if it is a known column (or `X_err` /
/// `t_over_X` of one).
pub fn describe(name: &str) -> Option<(String, String)> {
    let find = |n: &str| COLUMNS.iter().find(|c| c.0 == n);
    if let Some(c) = find(name) {
        return Some((c.1.to_string(), c.2.to_string()));
    }
    if let Some(base) = name.strip_suffix("_err")
        && let Some(c) = find(base)
    {
        return Some((c.1.to_string(), format!("1-sigma error of {base}")));
    }
    if let Some((base, k)) = super::replicas::parse_jk(name)
        && let Some((unit, _)) = describe(base)
    {
        return Some((
            unit,
            format!("{base} with replica {k} left out (replica jackknife)"),
        ));
    }
    if let Some(unit) = name.strip_prefix("t_over_") {
        return Some((
            "1".into(),
            format!("lag time t in units of the measured {unit}"),
        ));
    }
    None
}
