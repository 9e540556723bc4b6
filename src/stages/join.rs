//! `join`: the rows of one table with the matching row of another by key columns
//! (phi, eps, a, N, ...), and derived columns (D vs tau_alpha, chi4 vs xi,
//! t/tau_alpha, sqrt(N)/xi) built from the joined columns.

use std::sync::Arc;

use anyhow::{Result, bail};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray};
use serde::Deserialize;
use serde_json::Value;

use super::tables::{Columns, inputs_of};
use crate::analysis::pool;
use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::table::results::{ERROR, NOTE, QUANTITY, VALUE, value_jk};
use crate::table::to_parquet_bytes;

/// A column computed from two others of the joined row (or from one and a
/// number).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Derived {
    pub name: String,
    pub op: Op,
    pub a: Operand,
    #[serde(default)]
    pub b: Option<Operand>,
    #[serde(default)]
    pub propagate_errors: bool,
    /// What the column means, carried in its field metadata (`description`)
    /// into the published table and its README: a figure's own column needs
    /// no row in src/table/columns.rs.
    #[serde(default)]
    pub describe: Option<String>,
}

/// An input of a derived column: a column of the joined row, or a number
/// (exact: no error, no replica samples), e.g. the 1 of 1/((t/tau0)^beta + 1).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Operand {
    Number(f64),
    Column(String),
}

impl Operand {
    /// The column's name; None for a number.
    fn column(&self) -> Option<&str> {
        match self {
            Operand::Column(c) => Some(c),
            Operand::Number(_) => None,
        }
    }
}

/// How a derived column is computed from `a` (and `b`).
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Op {
    /// a / b
    Divide,
    /// a b
    Multiply,
    /// a + b: a curve shifted by a number, a sum of two columns
    Add,
    /// a - b: a residual against a model column
    Subtract,
    /// a^b: a model's power of a rescaled time, (t/tau0)^beta
    Power,
    /// sqrt(a) / b
    SqrtDivide,
    /// b ln a: Fig. 6's x = beta ln(t/tau0)
    LnTimes,
    /// 1 / a (no `b`): d_f from a fitted 1/d_f, with `NAME_err` = a_err / a^2
    /// when the table has `a_err`
    Reciprocal,
    /// ln a (no `b`), with `NAME_err` = a_err / |a|: a ratio's trend fitted in ln
    Ln,
}

impl Op {
    /// Reads only `a`.
    fn unary(self) -> bool {
        matches!(self, Op::Reciprocal | Op::Ln)
    }

    /// Can carry first-order errors of independent inputs (`propagate_errors`).
    fn propagates(self) -> bool {
        matches!(self, Op::Divide | Op::Multiply | Op::Add | Op::Subtract)
    }

    /// The op applied to one row's inputs (`b` unused by a unary op).
    fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Op::Divide => a / b,
            Op::Multiply => a * b,
            Op::Add => a + b,
            Op::Subtract => a - b,
            Op::Power => a.powf(b),
            Op::SqrtDivide => a.sqrt() / b,
            Op::LnTimes => b * a.ln(),
            Op::Reciprocal => 1.0 / a,
            Op::Ln => a.ln(),
        }
    }

    /// A unary op's first-order error from a's: |d(1/a)/da| = 1/a^2,
    /// |d ln a/da| = 1/|a|.
    fn unary_error(self, a: f64, a_err: f64) -> f64 {
        match self {
            Op::Ln => a_err / a.abs(),
            _ => a_err / (a * a),
        }
    }

    /// The first-order error of independent a and b (`propagate_errors`):
    /// absolute errors in quadrature for a sum or difference, relative ones
    /// for a product or ratio.
    fn binary_error(self, a: f64, a_err: f64, b: f64, b_err: f64) -> f64 {
        match self {
            Op::Add | Op::Subtract => a_err.hypot(b_err),
            _ => {
                let rel = |x: f64, e: f64| if e == 0.0 { 0.0 } else { e / x };
                self.apply(a, b).abs() * rel(a, a_err).hypot(rel(b, b_err))
            }
        }
    }
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JoinParams {
    pub left: String,
    pub right: String,
    pub on: Vec<String>,
    #[serde(default)]
    pub derive: Vec<Derived>,
}

pub struct Join;

/// A fit table (rows `quantity, value, error` per group of the key columns `on`)
/// as one row per group, each quantity a column `NAME` with its error `NAME_err`;
/// plus `unreliable` (1 where the fit's note says so, else 0); any other table
/// unchanged. This is how a fitted xi joins the data (chi4 vs xi).
fn wide(c: Columns, on: &[String]) -> Result<Columns> {
    let (Some(names), Some(value), Some(error)) =
        (c.str.get(QUANTITY), c.f64.get(VALUE), c.f64.get(ERROR))
    else {
        return Ok(c);
    };
    let keys: Vec<&Vec<f64>> = on.iter().filter_map(|k| c.f64.get(k)).collect();
    let mut group_of = Vec::with_capacity(c.rows);
    let mut firsts: Vec<usize> = Vec::new();
    for i in 0..c.rows {
        let g = firsts
            .iter()
            .position(|&j| keys.iter().all(|k| same(k[i], k[j])));
        group_of.push(g.unwrap_or_else(|| {
            firsts.push(i);
            firsts.len() - 1
        }));
    }
    let mut out = Columns {
        rows: firsts.len(),
        source: c.source.clone(),
        ..Columns::default()
    };
    for k in on.iter().filter(|k| c.f64.contains_key(*k)) {
        out.f64
            .insert(k.clone(), firsts.iter().map(|&j| c.f64[k][j]).collect());
    }
    // 1 where the fit's note says its numbers are unreliable (a plot marks them).
    if let Some(notes) = c.str.get(NOTE) {
        let flag = firsts
            .iter()
            .map(|&j| f64::from(u8::from(notes[j].contains("unreliable"))))
            .collect();
        out.f64.insert("unreliable".into(), flag);
    }
    // A fit on one unit's rows carries its numbers refitted with each replica
    // left out (`value_jkK`): they become `NAME_jkK` beside `jk_unit`, the
    // replica jackknife columns a fit across the groups reads.
    let samples: Vec<&Vec<f64>> = (0..pool::MAX_JK_REPLICAS)
        .map_while(|k| c.f64.get(&value_jk(k)))
        .collect();
    if let (Some(units), false) = (c.f64.get(pool::JK_UNIT), samples.is_empty()) {
        out.f64.insert(
            pool::JK_UNIT.into(),
            firsts.iter().map(|&j| units[j]).collect(),
        );
    }
    for i in 0..c.rows {
        let jk = samples
            .iter()
            .enumerate()
            .filter(|_| c.f64.contains_key(pool::JK_UNIT))
            .map(|(k, v)| (pool::jk_column(&names[i], k), v[i]));
        for (col, v) in [
            (names[i].clone(), value[i]),
            (format!("{}_err", names[i]), error[i]),
        ]
        .into_iter()
        .chain(jk)
        {
            if on.contains(&col) {
                bail!(
                    "join: fit table of {} reports a quantity '{col}', which is also a key",
                    c.source
                );
            }
            out.f64
                .entry(col)
                .or_insert_with(|| vec![f64::NAN; firsts.len()])[group_of[i]] = v;
        }
    }
    Ok(out)
}

/// The side of the join each column comes from, and the replica unit of each
/// output row on either side.
struct Origin {
    left: std::collections::BTreeSet<String>,
    right: std::collections::BTreeSet<String>,
    left_unit: Option<Vec<f64>>,
    right_unit: Option<Vec<f64>>,
}

/// The replica jackknife samples (`NAME_jkK`) of a derived column: its op
/// applied to the samples of `a` and `b`, a column without samples (a key
/// such as q or phi) counting as exact. So a fit to a ratio or a rescaled
/// axis (S4/chi4 against q xi) refits with the replica left out of both
/// factors and its error counts the normaliser's fluctuation. Empty where
/// neither input has samples, or where an input's samples come from other
/// runs than the row's `jk_unit` (tables of different experiments: their
/// replicas do not pair).
fn derived_samples(
    f64s: &std::collections::BTreeMap<String, Vec<f64>>,
    origin: &Origin,
    d: &Derived,
) -> Vec<Vec<f64>> {
    let Some(unit) = f64s.get(pool::JK_UNIT) else {
        return Vec::new();
    };
    let operands: Vec<&Operand> = std::iter::once(&d.a).chain(d.b.as_ref()).collect();
    // A number has no samples: exact, like a key column.
    let inputs: Vec<&str> = operands.iter().filter_map(|o| o.column()).collect();
    let count = |n: &str| {
        (0..pool::MAX_JK_REPLICAS)
            .take_while(|&k| f64s.contains_key(&pool::jk_column(n, k)))
            .count()
    };
    let counts: Vec<usize> = inputs.iter().map(|n| count(n)).collect();
    let r = counts.iter().copied().max().unwrap_or(0);
    if r < 2 || counts.iter().any(|&c| c != 0 && c != r) {
        return Vec::new();
    }
    // Samples pair only where the input's side has the row's unit.
    let paired = |n: &str| {
        let side = if origin.left.contains(n) {
            Some(&origin.left_unit)
        } else if origin.right.contains(n) {
            Some(&origin.right_unit)
        } else {
            None
        };
        match side {
            Some(Some(u)) => u.iter().zip(unit).all(|(a, b)| a.to_bits() == b.to_bits()),
            Some(None) => false,
            // A column derived earlier in this join: paired by construction.
            None => true,
        }
    };
    if inputs
        .iter()
        .zip(&counts)
        .any(|(n, &c)| c > 0 && !paired(n))
    {
        return Vec::new();
    }
    // Row i of operand o in sample k (a number is the same in every row).
    let value = |o: Option<&Operand>, k: usize, i: usize| -> f64 {
        match o {
            Some(Operand::Number(v)) => *v,
            Some(Operand::Column(n)) => f64s
                .get(&pool::jk_column(n, k))
                .or_else(|| f64s.get(n))
                .map_or(f64::NAN, |v| v[i]),
            None => f64::NAN,
        }
    };
    (0..r)
        .map(|k| {
            (0..unit.len())
                .map(|i| {
                    d.op.apply(value(Some(&d.a), k, i), value(d.b.as_ref(), k, i))
                })
                .collect()
        })
        .collect()
}

/// The number of rows of the joined table (that of any of its columns).
fn unit_rows(f64s: &std::collections::BTreeMap<String, Vec<f64>>) -> usize {
    f64s.values().next().map_or(0, Vec::len)
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300)
}

impl StageKind for Join {
    type Params = JoinParams;
    fn name(&self) -> &str {
        "join"
    }
    fn describe(&self) -> &str {
        "rows of `left` with the matching row of `right` by key columns `on`, plus derived columns"
    }
    fn details(&self) -> String {
        "parameters: left (stage), right (stage), on: [phi, ...], derive: [{name, op: divide|multiply|add|subtract|power|sqrt_divide|ln_times, a, b} or {name, op: reciprocal|ln, a}], a and b a column or a number; with divide, multiply, add or subtract, propagate_errors: true adds NAME_err from a_err, b_err (independent, first order)\n\
         example: {name: d_vs_tau, kind: join, gather: [msd_fit, tau_table], params: {left: msd_fit, right: tau_table, on: [phi], derive: [{name: t_over_tau, op: divide, a: t, b: tau_alpha}]}}"
            .into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<JoinParams> {
        let p: JoinParams = typed("join", params)?;
        if p.on.is_empty() {
            bail!("join: `on` is empty; give the key columns, e.g. on: [phi]");
        }
        for d in &p.derive {
            if d.propagate_errors && !d.op.propagates() {
                bail!(
                    "join: derived column '{}': `propagate_errors` works with op divide, multiply, add or subtract, not {:?}",
                    d.name,
                    d.op
                );
            }
            if d.op.unary() != d.b.is_none() {
                bail!(
                    "join: derived column '{}': op {:?} {}",
                    d.name,
                    d.op,
                    if d.b.is_none() {
                        "needs `b` (the second column, or a number)"
                    } else {
                        "reads only `a`; remove `b`"
                    }
                );
            }
            if d.a.column().is_none() && d.b.as_ref().is_none_or(|b| b.column().is_none()) {
                bail!(
                    "join: derived column '{}': op {:?} reads no column, only numbers; give a column as `a` or `b`",
                    d.name,
                    d.op
                );
            }
        }
        Ok(p)
    }
    fn run(&self, _ctx: &StageCtx, p: &JoinParams, inputs: &[Artifact]) -> Result<Output> {
        // A fit table on either side is one row per group (a self-join widens one).
        let l = wide(Columns::read(&inputs_of("join", inputs, &p.left)?)?, &p.on)?;
        let r = wide(Columns::read(&inputs_of("join", inputs, &p.right)?)?, &p.on)?;
        for (side, c) in [(&p.left, &l), (&p.right, &r)] {
            for k in &p.on {
                if !c.f64.contains_key(k) {
                    bail!(
                        "join: key '{k}' is not a column of stage '{side}' (its columns: {})",
                        c.f64
                            .keys()
                            .chain(c.str.keys())
                            .cloned()
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                }
            }
        }
        let mut matched = Vec::with_capacity(l.rows);
        for i in 0..l.rows {
            let j = (0..r.rows).find(|&j| p.on.iter().all(|k| same(l.f64[k][i], r.f64[k][j])));
            let Some(j) = j else {
                let key: Vec<String> =
                    p.on.iter()
                        .map(|k| format!("{k} = {}", l.f64[k][i]))
                        .collect();
                bail!("join: no row of stage '{}' has {}", p.right, key.join(", "));
            };
            matched.push(j);
        }
        let mut cols: Vec<(String, ArrayRef)> = Vec::new();
        let mut f64s: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
        for (k, v) in &l.f64 {
            f64s.insert(k.clone(), v.clone());
        }
        for (k, v) in &r.f64 {
            if !f64s.contains_key(k) {
                f64s.insert(k.clone(), matched.iter().map(|&j| v[j]).collect());
            }
        }
        // Which side each column came from, for pairing replica samples.
        let origin = Origin {
            left: l.f64.keys().cloned().collect(),
            right: r.f64.keys().cloned().collect(),
            left_unit: l.f64.get(pool::JK_UNIT).cloned(),
            right_unit: r
                .f64
                .get(pool::JK_UNIT)
                .map(|u| matched.iter().map(|&j| u[j]).collect()),
        };
        for d in &p.derive {
            let samples = derived_samples(&f64s, &origin, d);
            for (k, v) in samples.into_iter().enumerate() {
                f64s.insert(pool::jk_column(&d.name, k), v);
            }
            let rows = unit_rows(&f64s);
            // An operand's values in every row (a number repeated), and its
            // errors (none for a number or a column without `_err`).
            let get = |o: &Operand| -> Result<(Vec<f64>, Option<Vec<f64>>)> {
                match o {
                    Operand::Number(v) => Ok((vec![*v; rows], None)),
                    Operand::Column(n) => {
                        let v = f64s.get(n).cloned().ok_or_else(|| {
                            anyhow::anyhow!(
                                "join: derived column '{}' reads '{n}', which neither table has (columns: {})",
                                d.name,
                                f64s.keys().cloned().collect::<Vec<_>>().join(", ")
                            )
                        })?;
                        Ok((v, f64s.get(&format!("{n}_err")).cloned()))
                    }
                }
            };
            let (a, a_err) = get(&d.a)?;
            let Some(b) = &d.b else {
                if let Some(e) = a_err {
                    let err = a
                        .iter()
                        .zip(&e)
                        .map(|(&x, &e)| d.op.unary_error(x, e))
                        .collect();
                    f64s.insert(format!("{}_err", d.name), err);
                }
                f64s.insert(
                    d.name.clone(),
                    a.iter().map(|&x| d.op.apply(x, f64::NAN)).collect(),
                );
                continue;
            };
            let (b, b_err) = get(b)?;
            let v: Vec<f64> = a.iter().zip(&b).map(|(x, y)| d.op.apply(*x, *y)).collect();
            if d.propagate_errors {
                let zeros = vec![0.0; v.len()];
                let (ea, eb) = (
                    a_err.as_ref().unwrap_or(&zeros),
                    b_err.as_ref().unwrap_or(&zeros),
                );
                let err = (0..v.len())
                    .map(|i| d.op.binary_error(a[i], ea[i], b[i], eb[i]))
                    .collect();
                f64s.insert(format!("{}_err", d.name), err);
            }
            f64s.insert(d.name.clone(), v);
        }
        for (k, v) in f64s {
            cols.push((k, Arc::new(Float64Array::from(v))));
        }
        for (k, v) in &l.str {
            cols.push((k.clone(), Arc::new(StringArray::from(v.clone()))));
        }
        let b = with_descriptions(RecordBatch::try_from_iter(cols)?, &p.derive)?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}

/// The batch with each described derived column's meaning in its field
/// metadata (`description`), which the published README reads.
fn with_descriptions(b: RecordBatch, derive: &[Derived]) -> Result<RecordBatch> {
    let fields: Vec<arrow_schema::Field> = b
        .schema()
        .fields()
        .iter()
        .map(|f| {
            match derive
                .iter()
                .find(|d| &d.name == f.name())
                .and_then(|d| d.describe.clone())
            {
                Some(what) => f.as_ref().clone().with_metadata(
                    [("description".to_string(), what)]
                        .into_iter()
                        .collect::<std::collections::HashMap<String, String>>(),
                ),
                None => f.as_ref().clone(),
            }
        })
        .collect();
    Ok(RecordBatch::try_new(
        Arc::new(arrow_schema::Schema::new(fields)),
        b.columns().to_vec(),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Kind;
    use crate::stages::test_support::artifact;
    use crate::table::f64_batch;

    /// `propagate_errors`: a ratio and a product of independent numbers carry
    /// the first-order error (relative errors added in quadrature; a column
    /// without `_err` is exact); without it no `_err` column appears, and an op
    /// that cannot propagate is refused by name.
    #[test]
    fn ratios_and_products_propagate_independent_errors() {
        let dir = tempfile::tempdir().unwrap();
        let left = f64_batch(&[
            ("phi", vec![0.6, 0.775]),
            ("v", vec![3.0, 8.0]),
            ("v_err", vec![0.3, 0.4]),
            ("dt", vec![0.5, 0.25]),
        ])
        .unwrap();
        let right = f64_batch(&[
            ("phi", vec![0.775, 0.6]),
            ("v_hot", vec![4.0, 2.0]),
            ("v_hot_err", vec![0.3, 0.1]),
        ])
        .unwrap();
        let inputs = [
            artifact(dir.path(), "cold", left),
            artifact(dir.path(), "hot", right),
        ];
        let params: Value = serde_saphyr::from_str(
            "{left: cold, right: hot, on: [phi], derive: [\
             {name: ratio, op: divide, a: v, b: v_hot, propagate_errors: true}, \
             {name: impulse, op: multiply, a: v, b: dt, propagate_errors: true}, \
             {name: plain, op: divide, a: v, b: v_hot, describe: cold over hot}, \
             {name: ln_ratio, op: ln, a: ratio}]}",
        )
        .unwrap();
        Join.validate(&params).unwrap();
        let ctx = StageCtx::new(0, "join".into(), None);
        let out = Join.run_params(&ctx, &params, &inputs).unwrap();
        let (b, _) = crate::table::read_parquet_bytes(out.files["parquet"].clone()).unwrap();
        // A described derived column carries its meaning in its field metadata.
        let schema = b[0].schema();
        let meaning = |n: &str| {
            schema
                .field_with_name(n)
                .unwrap()
                .metadata()
                .get("description")
                .cloned()
        };
        assert_eq!(meaning("plain").as_deref(), Some("cold over hot"));
        assert_eq!(meaning("ratio"), None);
        let c = Columns::from_batch(&b[0]).unwrap();
        let col = |n: &str| c.col(n).unwrap().to_vec();
        // phi 0.6: 3 / 2 with 10% and 5% relative errors.
        let (r, re) = (col("ratio"), col("ratio_err"));
        assert_eq!(r, vec![1.5, 2.0]);
        assert!((re[0] - 1.5 * (0.1f64.powi(2) + 0.05f64.powi(2)).sqrt()).abs() < 1e-12);
        assert!((re[1] - 2.0 * (0.05f64.powi(2) + 0.075f64.powi(2)).sqrt()).abs() < 1e-12);
        // dt has no error: the product's relative error is v's.
        let ie = col("impulse_err");
        assert!((ie[0] - 1.5 * 0.1).abs() < 1e-12 && (ie[1] - 2.0 * 0.05).abs() < 1e-12);
        assert!(!c.f64.contains_key("plain_err"));
        // ln of the ratio: its error is the ratio's relative error.
        let (l, le) = (col("ln_ratio"), col("ln_ratio_err"));
        assert!((l[0] - 1.5f64.ln()).abs() < 1e-12 && (l[1] - 2.0f64.ln()).abs() < 1e-12);
        assert!((le[0] - re[0] / 1.5).abs() < 1e-12 && (le[1] - re[1] / 2.0).abs() < 1e-12);
        let bad: Value = serde_saphyr::from_str(
            "{left: cold, right: hot, on: [phi], derive: [{name: l, op: ln_times, a: v, b: dt, propagate_errors: true}]}",
        )
        .unwrap();
        let e = Join.validate(&bad).unwrap_err().to_string();
        assert!(e.contains("'l'") && e.contains("propagate_errors"), "{e}");
        // An op outside the closed set is refused with the valid ones.
        let unknown: Value = serde_saphyr::from_str(
            "{left: cold, right: hot, on: [phi], derive: [{name: l, op: log10, a: v}]}",
        )
        .unwrap();
        let e = format!("{:#}", Join.validate(&unknown).unwrap_err());
        assert!(
            e.contains("log10") && e.contains("reciprocal") && e.contains("ln"),
            "{e}"
        );
    }

    /// A derived column carries replica samples where its inputs do: the op on
    /// the samples of both factors (a key such as q counting as exact), so a
    /// fit to S4/chi4 against q xi refits with the replica left out of the
    /// normaliser too; none where the right table's replicas are other runs.
    #[test]
    fn derived_columns_carry_the_replica_samples_of_their_inputs() {
        let dir = tempfile::tempdir().unwrap();
        let left = f64_batch(&[
            ("phi", vec![0.6, 0.7]),
            ("q", vec![0.5, 0.25]),
            ("S4", vec![4.0, 9.0]),
            ("S4_jk0", vec![3.0, 8.0]),
            ("S4_jk1", vec![5.0, 10.0]),
            ("jk_unit", vec![1.0, 2.0]),
        ])
        .unwrap();
        let right = |unit: f64| {
            f64_batch(&[
                ("phi", vec![0.7, 0.6]),
                ("chi4", vec![3.0, 2.0]),
                ("chi4_jk0", vec![2.0, 1.0]),
                ("chi4_jk1", vec![4.0, 4.0]),
                ("xi", vec![8.0, 4.0]),
                ("xi_jk0", vec![6.0, 2.0]),
                ("xi_jk1", vec![10.0, 6.0]),
                ("jk_unit", vec![unit + 1.0, unit]),
            ])
            .unwrap()
        };
        let params: Value = serde_saphyr::from_str(
            "{left: s4, right: peaks, on: [phi], derive: [\
             {name: ratio, op: divide, a: S4, b: chi4}, \
             {name: q_xi, op: multiply, a: q, b: xi}, \
             {name: inverse, op: reciprocal, a: ratio}]}",
        )
        .unwrap();
        let ctx = StageCtx::new(0, "join".into(), None);
        let joined = |unit: f64| {
            let inputs = [
                artifact(dir.path(), "s4", left.clone()),
                artifact(dir.path(), "peaks", right(unit)),
            ];
            let out = Join.run_params(&ctx, &params, &inputs).unwrap();
            let (b, _) = crate::table::read_parquet_bytes(out.files["parquet"].clone()).unwrap();
            Columns::from_batch(&b[0]).unwrap()
        };
        let c = joined(1.0);
        let col = |n: &str| c.col(n).unwrap().to_vec();
        assert_eq!(col("ratio"), vec![2.0, 3.0]);
        assert_eq!(col("ratio_jk0"), vec![3.0, 4.0]);
        assert_eq!(col("ratio_jk1"), vec![1.25, 2.5]);
        assert_eq!(col("q_xi_jk0"), vec![1.0, 1.5]);
        assert_eq!(col("q_xi_jk1"), vec![3.0, 2.5]);
        // A column derived in the same join pairs with its own samples.
        assert_eq!(col("inverse_jk0"), vec![1.0 / 3.0, 0.25]);
        assert!(!c.f64.contains_key("ratio_jk2"));
        // Other runs on the right: their replicas do not pair with the left's.
        let c = joined(5.0);
        assert_eq!(c.col("ratio").unwrap(), &[2.0, 3.0]);
        assert!(!c.f64.contains_key("ratio_jk0") && !c.f64.contains_key("q_xi_jk0"));
    }

    /// Two fit tables (one row per quantity and group) join as one row per
    /// group, the left side widened like the right, so fits per N can be put
    /// side by side without a row per quantity.
    #[test]
    fn a_fit_table_on_the_left_is_one_row_per_group() {
        use crate::table::results::quantity_batch;
        let dir = tempfile::tempdir().unwrap();
        let fit = |amp: &str, rows: &[(f64, &str, f64)]| {
            let b: Vec<RecordBatch> = rows
                .iter()
                .map(|&(n, q, v)| {
                    let rows = [(q.to_string(), v, 0.1), (amp.to_string(), 2.0, 0.2)];
                    quantity_batch(&[("n".to_string(), n)], &rows, "", None).unwrap()
                })
                .collect();
            arrow_select::concat::concat_batches(&b[0].schema(), &b).unwrap()
        };
        let inputs = [
            artifact(
                dir.path(),
                "d_f",
                fit("A", &[(1000.0, "d_f", 1.2), (2000.0, "d_f", 1.3)]),
            ),
            artifact(
                dir.path(),
                "tau4",
                fit("B", &[(2000.0, "x", 0.9), (1000.0, "x", 0.8)]),
            ),
        ];
        let params: Value =
            serde_saphyr::from_str("{left: d_f, right: tau4, on: [\"n\"]}").unwrap();
        let ctx = StageCtx::new(0, "join".into(), None);
        let out = Join.run_params(&ctx, &params, &inputs).unwrap();
        let (b, _) = crate::table::read_parquet_bytes(out.files["parquet"].clone()).unwrap();
        let c = Columns::from_batch(&b[0]).unwrap();
        assert_eq!(c.rows, 2);
        assert_eq!(c.col("n").unwrap(), &[1000.0, 2000.0]);
        assert_eq!(c.col("d_f").unwrap(), &[1.2, 1.3]);
        assert_eq!(c.col("x").unwrap(), &[0.8, 0.9]);
        assert_eq!(c.col("d_f_err").unwrap(), &[0.1, 0.1]);
    }

    /// Sums, differences and powers, with a number as either operand: Eq. 8
    /// evaluated on the joined rows, Q_fit = 1/((t/tau0)^beta + 1), and the
    /// residual Q - Q_fit. At t/tau0 = 2 and beta = 1/2, Q_fit = 1/(sqrt 2 + 1)
    /// = sqrt 2 - 1. A number is exact: no error, no replica samples, so a
    /// shifted column keeps its own error and samples.
    #[test]
    fn sums_differences_powers_and_numbers() {
        let dir = tempfile::tempdir().unwrap();
        let left = f64_batch(&[
            ("phi", vec![0.6, 0.7]),
            ("t", vec![2.0, 8.0]),
            ("Q", vec![0.5, 0.2]),
            ("Q_err", vec![0.01, 0.02]),
            ("Q_jk0", vec![0.4, 0.1]),
            ("Q_jk1", vec![0.6, 0.3]),
            ("jk_unit", vec![1.0, 2.0]),
        ])
        .unwrap();
        let right = f64_batch(&[
            ("phi", vec![0.7, 0.6]),
            ("tau0", vec![4.0, 2.0]),
            ("beta", vec![0.5, 2.0]),
            ("beta_err", vec![0.05, 0.1]),
        ])
        .unwrap();
        let inputs = [
            artifact(dir.path(), "q", left),
            artifact(dir.path(), "fit", right),
        ];
        let params: Value = serde_saphyr::from_str(
            "{left: q, right: fit, on: [phi], derive: [\
             {name: tq, op: divide, a: t, b: tau0}, \
             {name: pw, op: power, a: tq, b: beta}, \
             {name: den, op: add, a: pw, b: 1}, \
             {name: q_fit, op: reciprocal, a: den}, \
             {name: resid, op: subtract, a: Q, b: q_fit, propagate_errors: true}, \
             {name: two_beta, op: power, a: 2, b: beta}, \
             {name: shifted, op: add, a: Q, b: 0.25, propagate_errors: true}, \
             {name: gap, op: subtract, a: 1, b: beta, propagate_errors: true}]}",
        )
        .unwrap();
        Join.validate(&params).unwrap();
        let ctx = StageCtx::new(0, "join".into(), None);
        let out = Join.run_params(&ctx, &params, &inputs).unwrap();
        let (b, _) = crate::table::read_parquet_bytes(out.files["parquet"].clone()).unwrap();
        let c = Columns::from_batch(&b[0]).unwrap();
        let col = |n: &str| c.col(n).unwrap().to_vec();
        let close = |got: Vec<f64>, want: &[f64]| {
            assert!(
                got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-12),
                "{got:?} against {want:?}"
            )
        };
        let r2 = 2f64.sqrt();
        // phi 0.6: t/tau0 = 1, Q_fit = 1/2; phi 0.7: t/tau0 = 2, beta = 1/2.
        close(col("q_fit"), &[0.5, r2 - 1.0]);
        close(col("resid"), &[0.0, 0.2 - (r2 - 1.0)]);
        // Q_fit has no error column: the residual's error is Q's.
        close(col("resid_err"), &[0.01, 0.02]);
        close(col("two_beta"), &[4.0, r2]);
        close(col("shifted"), &[0.75, 0.45]);
        close(col("shifted_err"), &[0.01, 0.02]);
        close(col("shifted_jk0"), &[0.65, 0.35]);
        close(col("shifted_jk1"), &[0.85, 0.55]);
        close(col("gap"), &[-1.0, 0.5]);
        close(col("gap_err"), &[0.1, 0.05]);
        // An op reading only numbers, and an error through a power, are refused.
        for (bad, says) in [
            ("{name: s, op: add, a: 1, b: 2}", "only numbers"),
            (
                "{name: s, op: power, a: t, b: 2, propagate_errors: true}",
                "propagate_errors",
            ),
            ("{name: s, op: subtract, a: t}", "needs `b`"),
        ] {
            let p: Value = serde_saphyr::from_str(&format!(
                "{{left: q, right: fit, on: [phi], derive: [{bad}]}}"
            ))
            .unwrap();
            let e = format!("{:#}", Join.validate(&p).unwrap_err());
            assert!(e.contains(says), "{bad}: {e}");
        }
    }
}
