//! The result tables and their one schema: a fit's quantity table (`quantity,
//! value, error, note`, after the group's columns, with the replica refits
//! `jk_unit, value_jk0 ..` when it has them), a fit's replica jackknife file
//! (`jk_unit, replica, quantity, value`) and `compare`'s verdicts (`quantity,
//! ours, ours_err, paper, tolerance, verdict, reason`). Writers and readers of
//! these tables name their columns through this module only.

use std::sync::Arc;

use anyhow::{Context, Result, bail};
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch, StringArray};
use arrow_schema::DataType;

use super::replicas::{JK_UNIT, jk_column};

/// Name of a fitted or measured number.
pub const QUANTITY: &str = "quantity";
/// Its value.
pub const VALUE: &str = "value";
/// Its 1-sigma error.
pub const ERROR: &str = "error";
/// Fit warnings, or `fit failed: ` and why.
pub const NOTE: &str = "note";
/// The replica left out of a jackknife refit.
pub const REPLICA: &str = "replica";
/// Our value, in the compare table.
pub const OURS: &str = "ours";
/// Our 1-sigma error, in the compare table.
pub const OURS_ERR: &str = "ours_err";
/// The paper's value.
pub const PAPER: &str = "paper";
/// Largest accepted |ours - paper|.
pub const TOLERANCE: &str = "tolerance";
/// `agree`, `disagree`, `out_of_reach`, `unreliable` or `missing`.
pub const VERDICT: &str = "verdict";
/// Why the verdict.
pub const REASON: &str = "reason";
/// Where the paper's value comes from: `figure` or `ref12` ([`Source`]).
pub const SOURCE: &str = "source";

/// A column of a result table: its name and Arrow type.
pub type Column = (&'static str, DataType);

/// The columns of a quantity table after the group's.
pub const QUANTITY_COLUMNS: [Column; 4] = [
    (QUANTITY, DataType::Utf8),
    (VALUE, DataType::Float64),
    (ERROR, DataType::Float64),
    (NOTE, DataType::Utf8),
];

/// The columns of a fit's replica jackknife file after the group's: one row per
/// refit and reported number.
pub const JACKKNIFE_COLUMNS: [Column; 4] = [
    (JK_UNIT, DataType::Float64),
    (REPLICA, DataType::Float64),
    (QUANTITY, DataType::Utf8),
    (VALUE, DataType::Float64),
];

/// The columns of the compare table.
pub const COMPARE_COLUMNS: [Column; 8] = [
    (QUANTITY, DataType::Utf8),
    (OURS, DataType::Float64),
    (OURS_ERR, DataType::Float64),
    (PAPER, DataType::Float64),
    (TOLERANCE, DataType::Float64),
    (VERDICT, DataType::Utf8),
    (REASON, DataType::Utf8),
    (SOURCE, DataType::Utf8),
];

/// Column of a quantity table holding each quantity refitted with replica k
/// left out (`join` turns it into `NAME_jkK`).
pub fn value_jk(k: usize) -> String {
    jk_column(VALUE, k)
}

/// The group's values as constant float columns of `rows` rows.
fn group_columns(group: &[(String, f64)], rows: usize) -> Vec<(String, ArrayRef)> {
    group
        .iter()
        .map(|(k, v)| {
            (
                k.clone(),
                Arc::new(Float64Array::from(vec![*v; rows])) as ArrayRef,
            )
        })
        .collect()
}

/// `b` with the group's values in front, as constant float columns (a
/// `group_by` stage's row group of a table other than its quantity table).
pub fn led_by_group(group: &[(String, f64)], b: &RecordBatch) -> Result<RecordBatch> {
    let mut cols = group_columns(group, b.num_rows());
    let schema = b.schema();
    cols.extend(
        schema
            .fields()
            .iter()
            .zip(b.columns())
            .map(|(f, c)| (f.name().clone(), c.clone())),
    );
    Ok(RecordBatch::try_from_iter(cols)?)
}

/// `lead` followed by `arrays` named and typed by `columns`.
fn batch(
    mut lead: Vec<(String, ArrayRef)>,
    columns: &[Column],
    arrays: Vec<ArrayRef>,
) -> Result<RecordBatch> {
    for ((name, ty), a) in columns.iter().zip(arrays) {
        if a.data_type() != ty {
            bail!("result column '{name}' is {}, not {ty}", a.data_type());
        }
        lead.push((name.to_string(), a));
    }
    Ok(RecordBatch::try_from_iter(lead)?)
}

/// Replica samples of a fit on the rows of one unit: the unit and, per replica
/// k, every reported number refitted with replica k left out.
pub type UnitSamples = (f64, Vec<Vec<f64>>);

/// Quantity table: the group's values as leading columns, then one row per
/// (quantity, value, error) with the one `note`; with the replica samples of a
/// fit on one unit's rows, `jk_unit` and `value_jk0 ..` after them (NaN for
/// rows without a refit, such as the reduced chi-square).
pub fn quantity_batch(
    group: &[(String, f64)],
    rows: &[(String, f64, f64)],
    note: &str,
    samples: Option<&UnitSamples>,
) -> Result<RecordBatch> {
    let n = rows.len();
    let mut cols = batch(
        group_columns(group, n),
        &QUANTITY_COLUMNS,
        vec![
            Arc::new(StringArray::from(
                rows.iter().map(|r| r.0.clone()).collect::<Vec<_>>(),
            )),
            Arc::new(Float64Array::from(
                rows.iter().map(|r| r.1).collect::<Vec<_>>(),
            )),
            Arc::new(Float64Array::from(
                rows.iter().map(|r| r.2).collect::<Vec<_>>(),
            )),
            Arc::new(StringArray::from(vec![note; n])),
        ],
    )?;
    if let Some((unit, per_replica)) = samples {
        let mut all: Vec<(String, ArrayRef)> = cols
            .schema()
            .fields()
            .iter()
            .zip(cols.columns())
            .map(|(f, c)| (f.name().clone(), c.clone()))
            .collect();
        all.push((
            JK_UNIT.to_string(),
            Arc::new(Float64Array::from(vec![*unit; n])),
        ));
        for (k, v) in per_replica.iter().enumerate() {
            let v: Vec<f64> = (0..n)
                .map(|i| v.get(i).copied().unwrap_or(f64::NAN))
                .collect();
            all.push((value_jk(k), Arc::new(Float64Array::from(v))));
        }
        cols = RecordBatch::try_from_iter(all)?;
    }
    Ok(cols)
}

/// One row of a fit's replica jackknife file: the unit and replica left out, a
/// reported number and its refitted value.
pub struct Refit {
    pub unit: f64,
    pub replica: usize,
    pub quantity: String,
    pub value: f64,
}

/// A fit's replica jackknife file: the group's values, then one row per refit.
pub fn jackknife_batch(group: &[(String, f64)], refits: &[Refit]) -> Result<RecordBatch> {
    batch(
        group_columns(group, refits.len()),
        &JACKKNIFE_COLUMNS,
        vec![
            Arc::new(Float64Array::from(
                refits.iter().map(|r| r.unit).collect::<Vec<_>>(),
            )),
            Arc::new(Float64Array::from(
                refits.iter().map(|r| r.replica as f64).collect::<Vec<_>>(),
            )),
            Arc::new(StringArray::from(
                refits
                    .iter()
                    .map(|r| r.quantity.clone())
                    .collect::<Vec<_>>(),
            )),
            Arc::new(Float64Array::from(
                refits.iter().map(|r| r.value).collect::<Vec<_>>(),
            )),
        ],
    )
}

/// One row of a quantity table as read back.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantityRow {
    pub quantity: String,
    /// NaN where null.
    pub value: f64,
    /// NaN where null or when the table has no `error` column.
    pub error: f64,
    /// Empty when the table has no `note` column.
    pub note: String,
}

fn floats<'a>(b: &'a RecordBatch, name: &str) -> Option<&'a Float64Array> {
    b.column_by_name(name)?.as_any().downcast_ref()
}

fn strings<'a>(b: &'a RecordBatch, name: &str) -> Option<&'a StringArray> {
    b.column_by_name(name)?.as_any().downcast_ref()
}

fn float_at(a: &Float64Array, i: usize) -> f64 {
    if a.is_null(i) { f64::NAN } else { a.value(i) }
}

/// The rows of a quantity table; None when `b` is not one (no string `quantity`
/// and float `value` columns).
pub fn read_quantities(b: &RecordBatch) -> Option<Vec<QuantityRow>> {
    let (q, v) = (strings(b, QUANTITY)?, floats(b, VALUE)?);
    let (e, note) = (floats(b, ERROR), strings(b, NOTE));
    Some(
        (0..b.num_rows())
            .map(|i| QuantityRow {
                quantity: q.value(i).to_string(),
                value: float_at(v, i),
                error: e.map_or(f64::NAN, |e| float_at(e, i)),
                note: note.map_or(String::new(), |n| n.value(i).to_string()),
            })
            .collect(),
    )
}

/// The `compare` stage's verdict on one key number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Verdict {
    Agree,
    Disagree,
    /// The paper's value is beyond what this profile can reach (too few particles,
    /// too short a run).
    OutOfReach,
    /// Our number exists but cannot be trusted (e.g. a fit that did not converge).
    Unreliable,
    /// We have no number.
    Missing,
}

impl Verdict {
    pub const ALL: [Verdict; 5] = [
        Verdict::Agree,
        Verdict::Disagree,
        Verdict::OutOfReach,
        Verdict::Unreliable,
        Verdict::Missing,
    ];

    /// As compare.parquet spells it.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Agree => "agree",
            Verdict::Disagree => "disagree",
            Verdict::OutOfReach => "out_of_reach",
            Verdict::Unreliable => "unreliable",
            Verdict::Missing => "missing",
        }
    }

    /// For readers: `out of reach`.
    pub fn label(self) -> &'static str {
        match self {
            Verdict::OutOfReach => "out of reach",
            v => v.as_str(),
        }
    }

    pub fn parse(s: &str) -> Option<Verdict> {
        Verdict::ALL.into_iter().find(|v| v.as_str() == s)
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Where a paper value comes from: measured in one of the paper's own figures,
/// or quoted by paper H from its reference 12 ("we had shown in 12"), with that
/// paper's data, sizes and fit ranges. A quoted number is not what paper H's
/// data give, so agreeing with it is a different claim.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    #[default]
    Figure,
    Ref12,
}

impl Source {
    pub const ALL: [Source; 2] = [Source::Figure, Source::Ref12];

    /// As compare.parquet spells it.
    pub fn as_str(self) -> &'static str {
        match self {
            Source::Figure => "figure",
            Source::Ref12 => "ref12",
        }
    }

    /// For readers.
    pub fn label(self) -> &'static str {
        match self {
            Source::Figure => "measured (figure)",
            Source::Ref12 => "quoted (ref. 12)",
        }
    }

    pub fn parse(s: &str) -> Option<Source> {
        Source::ALL.into_iter().find(|v| v.as_str() == s)
    }
}

impl PartialEq<&str> for Verdict {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

/// One key number as the `compare` stage reported it.
#[derive(Clone, Debug)]
pub struct Compared {
    pub quantity: String,
    pub ours: f64,
    /// Our quoted 1-sigma error (NaN when the fit gave none).
    pub ours_err: f64,
    pub paper: f64,
    pub tolerance: f64,
    pub verdict: Verdict,
    pub reason: String,
    pub source: Source,
}

/// The compare table's columns, one entry per paper value.
#[derive(Clone, Debug, Default)]
pub struct CompareColumns {
    pub quantity: Vec<String>,
    pub ours: Vec<f64>,
    pub ours_err: Vec<f64>,
    pub paper: Vec<f64>,
    pub tolerance: Vec<f64>,
    pub verdict: Vec<String>,
    pub reason: Vec<String>,
    pub source: Vec<Source>,
}

impl CompareColumns {
    /// The compare table.
    pub fn batch(self) -> Result<RecordBatch> {
        batch(
            Vec::new(),
            &COMPARE_COLUMNS,
            vec![
                Arc::new(StringArray::from(self.quantity)),
                Arc::new(Float64Array::from(self.ours)),
                Arc::new(Float64Array::from(self.ours_err)),
                Arc::new(Float64Array::from(self.paper)),
                Arc::new(Float64Array::from(self.tolerance)),
                Arc::new(StringArray::from(self.verdict)),
                Arc::new(StringArray::from(self.reason)),
                Arc::new(StringArray::from_iter_values(
                    self.source.iter().map(|s| s.as_str()),
                )),
            ],
        )
    }
}

/// The rows of one batch of a compare table (`ours`, `ours_err` NaN where null).
pub fn read_compare(b: &RecordBatch) -> Result<Vec<Compared>> {
    let s = |n: &str| strings(b, n).with_context(|| format!("no string column '{n}'"));
    let f = |n: &str| floats(b, n).with_context(|| format!("no float column '{n}'"));
    let (q, o, oe, p, t) = (
        s(QUANTITY)?,
        f(OURS)?,
        f(OURS_ERR)?,
        f(PAPER)?,
        f(TOLERANCE)?,
    );
    let (ver, why) = (s(VERDICT)?, s(REASON)?);
    // Tables written before the column existed hold figure values only.
    let src = strings(b, SOURCE);
    (0..b.num_rows())
        .map(|i| {
            Ok(Compared {
                quantity: q.value(i).to_string(),
                ours: float_at(o, i),
                ours_err: float_at(oe, i),
                paper: p.value(i),
                tolerance: t.value(i),
                verdict: Verdict::parse(ver.value(i))
                    .with_context(|| format!("unknown verdict '{}'", ver.value(i)))?,
                reason: why.value(i).to_string(),
                source: match src {
                    Some(c) => Source::parse(c.value(i))
                        .with_context(|| format!("unknown source '{}'", c.value(i)))?,
                    None => Source::Figure,
                },
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the writers write, the readers read back, column names and types
    /// as the schema says.
    #[test]
    fn result_tables_round_trip_through_their_schema() {
        let group = [("phi".to_string(), 0.7)];
        let rows = [
            ("a".to_string(), 1.0, 0.1),
            ("b".to_string(), 2.0, f64::NAN),
        ];
        let samples = (3.0, vec![vec![1.1, 2.1], vec![0.9]]);
        let b = quantity_batch(&group, &rows, "n", Some(&samples)).unwrap();
        let schema = b.schema();
        let names: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
        assert_eq!(
            names,
            [
                "phi",
                QUANTITY,
                VALUE,
                ERROR,
                NOTE,
                JK_UNIT,
                "value_jk0",
                "value_jk1"
            ]
        );
        let back = read_quantities(&b).unwrap();
        assert_eq!(back[1].quantity, "b");
        assert_eq!(back[0].note, "n");
        assert!(back[1].error.is_nan());
        assert!(floats(&b, "value_jk1").unwrap().value(1).is_nan());
        let c = CompareColumns {
            quantity: vec!["x".into()],
            ours: vec![1.0],
            ours_err: vec![0.1],
            paper: vec![1.1],
            tolerance: vec![0.2],
            verdict: vec!["agree".into()],
            reason: vec!["close".into()],
            source: vec![Source::Ref12],
        }
        .batch()
        .unwrap();
        for (f, (name, ty)) in c.schema_ref().fields().iter().zip(&COMPARE_COLUMNS) {
            assert_eq!((f.name().as_str(), f.data_type()), (*name, ty));
        }
        let r = read_compare(&c).unwrap();
        assert_eq!((r[0].verdict.as_str(), r[0].paper), ("agree", 1.1));
        assert_eq!(r[0].source, Source::Ref12);
    }
}
