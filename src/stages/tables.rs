//! What the adapters share: reading trajectories and tables from upstream
//! artifacts, picking an input by the stage that made it, and row filters.

use std::collections::BTreeMap;

use anyhow::{Context, Result, bail};
use arrow_array::{Array, Float64Array, Int64Array, RecordBatch, StringArray};
use serde::Deserialize;

use crate::pipeline::Artifact;
use crate::pipeline::stage::Holds;
use crate::table::results::{ERROR, QUANTITY, VALUE};
use crate::traj::Trajectory;

/// Every input that is a simulated trajectory, decoded.
pub fn trajectories(kind: &str, inputs: &[Artifact]) -> Result<Vec<Trajectory>> {
    let sims: Vec<&Artifact> = inputs
        .iter()
        .filter(|a| a.kind.holds == Holds::Trajectory)
        .collect();
    if sims.is_empty() {
        bail!(
            "{kind}: no simulated trajectory among the inputs ({}); gather a `simulate` experiment",
            inputs
                .iter()
                .map(|a| a.label.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    sims.iter()
        .map(|a| {
            crate::table::trajectory::from_parquet_bytes(a.read("parquet")?)
                .with_context(|| format!("{kind}: decoding the trajectory of {}", a.label))
        })
        .collect()
}

/// The names of the stages the inputs come from, sorted, each once.
pub fn source_stages(inputs: &[Artifact]) -> Vec<&str> {
    let mut v: Vec<&str> = inputs
        .iter()
        .flat_map(|a| a.ids.iter().map(|id| id.stage.as_str()))
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// The inputs produced by stage `name`.
pub fn inputs_of<'a>(kind: &str, inputs: &'a [Artifact], name: &str) -> Result<Vec<&'a Artifact>> {
    let v: Vec<&Artifact> = inputs.iter().filter(|a| a.is_from(name)).collect();
    if v.is_empty() {
        let known = source_stages(inputs);
        bail!(
            "{kind}: no input comes from stage '{name}'; the inputs come from: {} (add it to `gather`)",
            known.join(", ")
        );
    }
    Ok(v)
}

/// A table of numeric columns as floats (integer counts included; string columns
/// are kept separately).
#[derive(Clone, Debug, Default)]
pub struct Columns {
    pub rows: usize,
    pub f64: BTreeMap<String, Vec<f64>>,
    pub str: BTreeMap<String, Vec<String>>,
    pub source: String,
}

impl Columns {
    /// All record batches of the `parquet` files of `arts`, concatenated.
    pub fn read(arts: &[&Artifact]) -> Result<Columns> {
        Self::read_file(arts, "parquet")
    }

    /// All record batches of the files with extension `ext` of `arts`, concatenated,
    /// with each artifact's numeric point values (phi, ...) added as columns.
    pub fn read_file(arts: &[&Artifact], ext: &str) -> Result<Columns> {
        let mut c = Columns {
            source: arts
                .iter()
                .map(|a| a.label.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            ..Columns::default()
        };
        for a in arts {
            let (batches, _) = crate::table::read_parquet_bytes(a.read(ext)?)
                .with_context(|| format!("reading the table of {}", a.label))?;
            for b in batches {
                let rows = c.rows;
                c.push(&b)?;
                // The producing stage's point (phi, ...) as columns, unless present.
                for (k, v) in &a.point {
                    if let Some(x) = v.as_f64()
                        && b.schema().column_with_name(k).is_none()
                    {
                        let col = c.f64.entry(k.clone()).or_default();
                        col.resize(rows, f64::NAN);
                        col.resize(c.rows, x);
                    }
                }
            }
        }
        for v in c.f64.values_mut() {
            v.resize(c.rows, f64::NAN);
        }
        for v in c.str.values_mut() {
            v.resize(c.rows, String::new());
        }
        Ok(c)
    }

    /// One record batch as columns.
    pub fn from_batch(b: &RecordBatch) -> Result<Columns> {
        let mut c = Columns {
            source: "a computed table".into(),
            ..Columns::default()
        };
        c.push(b)?;
        Ok(c)
    }

    fn push(&mut self, b: &RecordBatch) -> Result<()> {
        for (f, col) in b.schema().fields().iter().zip(b.columns()) {
            if let Some(x) = col.as_any().downcast_ref::<Float64Array>() {
                let v = self.f64.entry(f.name().clone()).or_default();
                v.resize(self.rows, f64::NAN);
                v.extend((0..x.len()).map(|i| if x.is_null(i) { f64::NAN } else { x.value(i) }));
            } else if let Some(x) = col.as_any().downcast_ref::<Int64Array>() {
                // Counts and indices: read as numbers like any other column.
                let v = self.f64.entry(f.name().clone()).or_default();
                v.resize(self.rows, f64::NAN);
                v.extend((0..x.len()).map(|i| {
                    if x.is_null(i) {
                        f64::NAN
                    } else {
                        x.value(i) as f64
                    }
                }));
            } else if let Some(x) = col.as_any().downcast_ref::<StringArray>() {
                let v = self.str.entry(f.name().clone()).or_default();
                v.resize(self.rows, String::new());
                v.extend((0..x.len()).map(|i| x.value(i).to_string()));
            }
        }
        self.rows += b.num_rows();
        Ok(())
    }

    /// Column `name` as floats, or an error listing the columns there are.
    pub fn col(&self, name: &str) -> Result<&[f64]> {
        self.f64.get(name).map(|v| v.as_slice()).with_context(|| {
            format!(
                "table from {} has no numeric column '{name}'; its columns: {}",
                self.source,
                self.f64.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })
    }

    /// Row indices passing `filter`.
    pub fn select(&self, filter: &Where) -> Result<Vec<usize>> {
        let mut keep = vec![true; self.rows];
        for (name, cond) in filter {
            let c = self.col(name)?;
            for (k, &v) in keep.iter_mut().zip(c) {
                *k &= cond.accepts(v);
            }
        }
        Ok((0..self.rows).filter(|&i| keep[i]).collect())
    }

    /// Value of a `quantity` row of a fit table (columns quantity, value, error).
    pub fn quantity(&self, name: &str) -> Result<(f64, f64)> {
        self.quantity_in(name, &[])
    }

    /// Value of a `quantity` row of a fit table in the row group `group` (a
    /// `group_by` fit's): the first row named `name` whose group columns the
    /// table has equal the group's values; columns it lacks are ignored.
    pub fn quantity_in(&self, name: &str, group: &[(String, f64)]) -> Result<(f64, f64)> {
        let q = self.str.get(QUANTITY).with_context(|| {
            format!(
                "table from {} has no 'quantity' column (not a fit table)",
                self.source
            )
        })?;
        let in_group = |i: usize| {
            group
                .iter()
                .all(|(k, v)| self.col(k).map_or(true, |c| c[i] == *v))
        };
        let i = (0..q.len())
            .position(|i| q[i] == name && in_group(i))
            .with_context(|| {
                format!(
                    "fit table from {} reports no quantity '{name}'{}; it has: {}",
                    self.source,
                    if group.is_empty() {
                        String::new()
                    } else {
                        format!(" in the group {group:?}")
                    },
                    q.join(", ")
                )
            })?;
        Ok((self.col(VALUE)?[i], self.col(ERROR)?[i]))
    }
    /// The value a text's reference `NAME.FIELD[@COLUMN=VALUE,...]` names
    /// ([`crate::table::references`]): a fit table's row `field` (in the row
    /// group `row`), or else column `field` at its one row (the row whose
    /// columns equal the values of `row`, within 1e-9 relative), with its
    /// error from `FIELD_err` (NaN without one).
    pub fn value_of(&self, field: &str, row: &[(String, f64)]) -> Result<(f64, f64)> {
        for (c, _) in row {
            self.col(c)?;
        }
        if self.str.contains_key(QUANTITY) {
            return self.quantity_in(field, row);
        }
        let col = self.col(field)?;
        let filter: Where = row
            .iter()
            .map(|(c, v)| (c.clone(), Cond::Equal(*v)))
            .collect();
        let rows = self.select(&filter)?;
        let [i] = rows[..] else {
            bail!(
                "table from {} has {} rows{}: name one as {field}@COLUMN=VALUE",
                self.source,
                rows.len(),
                if row.is_empty() {
                    String::new()
                } else {
                    format!(" with {row:?}")
                }
            );
        };
        let err = self
            .f64
            .get(&format!("{field}_err"))
            .map_or(f64::NAN, |e| e[i]);
        Ok((col[i], err))
    }
}

/// A condition on one column: equal to a value (within 1e-9 relative), or in a range.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Cond {
    Equal(f64),
    Range {
        #[serde(default)]
        min: Option<f64>,
        #[serde(default)]
        max: Option<f64>,
    },
    OneOf(Vec<f64>),
}

impl Cond {
    pub fn accepts(&self, v: f64) -> bool {
        let eq = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300);
        match self {
            Cond::Equal(x) => eq(v, *x),
            Cond::Range { min, max } => {
                min.is_none_or(|m| v >= m - 1e-12) && max.is_none_or(|m| v <= m + 1e-12)
            }
            Cond::OneOf(xs) => xs.iter().any(|&x| eq(v, x)),
        }
    }
}

/// Row filter: every listed column must satisfy its condition.
pub type Where = BTreeMap<String, Cond>;

/// The values of `v` at `rows`.
pub fn pick(v: &[f64], rows: &[usize]) -> Vec<f64> {
    rows.iter().map(|&i| v[i]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_select_rows() {
        assert!(Cond::Equal(0.78).accepts(0.78));
        assert!(!Cond::Equal(0.78).accepts(0.785));
        let r = Cond::Range {
            min: None,
            max: Some(0.80),
        };
        assert!(r.accepts(0.80) && !r.accepts(0.805));
        assert!(Cond::OneOf(vec![0.6, 0.7]).accepts(0.7));
    }
}
