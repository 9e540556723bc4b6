//! Replica jackknife columns carried beside a table's own: `X_jkK` is column X
//! computed with replica K left out, `jk_unit` names the set of replicas a row
//! was computed from (`analysis::pool` writes them, fits refit with them).

use std::sync::Arc;

use anyhow::Result;
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch};

/// Column naming the independent unit (the set of replicas) a row was computed
/// from: rows of one analysis instance share it, rows of different state points
/// do not. A jackknife over replicas leaves a replica out of one unit at a time.
pub const JK_UNIT: &str = "jk_unit";

/// Column `X_jkK` beside a column X: its value with replica K left out.
pub fn jk_column(name: &str, k: usize) -> String {
    format!("{name}_jk{k}")
}

/// The base column and replica index of a jackknife column name.
pub fn parse_jk(name: &str) -> Option<(&str, usize)> {
    let (base, k) = name.rsplit_once("_jk")?;
    let k = k.parse().ok()?;
    (!base.is_empty()).then_some((base, k))
}

/// Give tables that differ only in their jackknife columns the same columns, so
/// that one table can hold them all. Instances of one analysis may differ there:
/// a column that no left-out replica changes gets no `X_jkK` (then `X_jkK` = X
/// for every K below the instance's replica count), and an instance whose
/// replicas could not be left out has none at all (then NaN: no jackknife
/// sample, which a fit treats as missing). Tables whose other columns differ are
/// returned unchanged, for the caller's own error.
pub fn align(batches: Vec<RecordBatch>) -> Result<Vec<RecordBatch>> {
    let own = |b: &RecordBatch| -> Vec<String> {
        b.schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .filter(|n| n != JK_UNIT && parse_jk(n).is_none())
            .collect()
    };
    let Some(first) = batches.first() else {
        return Ok(batches);
    };
    let base = own(first);
    if batches.iter().any(|b| own(b) != base) {
        return Ok(batches);
    }
    let has = |b: &RecordBatch, n: &str| b.schema().column_with_name(n).is_some();
    let replicas = |b: &RecordBatch| -> usize {
        b.schema()
            .fields()
            .iter()
            .filter_map(|f| parse_jk(f.name()).map(|(_, k)| k + 1))
            .max()
            .unwrap_or(0)
    };
    let max_k = batches.iter().map(replicas).max().unwrap_or(0);
    let any_unit = batches.iter().any(|b| has(b, JK_UNIT));
    let mut names: Vec<String> = base.clone();
    if any_unit {
        names.push(JK_UNIT.to_string());
    }
    for x in &base {
        for k in 0..max_k {
            let n = jk_column(x, k);
            if batches.iter().any(|b| has(b, &n)) {
                names.push(n);
            }
        }
    }
    batches
        .into_iter()
        .map(|b| {
            let r = replicas(&b);
            let with_unit = has(&b, JK_UNIT);
            let nan = || -> ArrayRef { Arc::new(Float64Array::from(vec![f64::NAN; b.num_rows()])) };
            let cols: Vec<(String, ArrayRef)> = names
                .iter()
                .map(|n| {
                    let c = match b.column_by_name(n) {
                        Some(c) => c.clone(),
                        None => match parse_jk(n) {
                            Some((x, k)) if with_unit && k < r => b
                                .column_by_name(x)
                                .filter(|c| c.as_any().is::<Float64Array>())
                                .cloned()
                                .unwrap_or_else(nan),
                            _ => nan(),
                        },
                    };
                    (n.clone(), c)
                })
                .collect();
            Ok(RecordBatch::try_from_iter(cols)?)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::test_support::col;
    use crate::table::f64_batch;

    #[test]
    fn unchanged_columns_are_their_own_samples_and_missing_replicas_are_nan() {
        // Instance a: t_fit changed with a replica left out; instance b: it did
        // not (no t_fit_jk columns); instance c: no jackknife at all.
        let a = f64_batch(&[
            ("D", vec![1.0]),
            ("t_fit", vec![5.0]),
            (JK_UNIT, vec![7.0]),
            ("D_jk0", vec![1.1]),
            ("D_jk1", vec![0.9]),
            ("t_fit_jk0", vec![4.0]),
            ("t_fit_jk1", vec![6.0]),
        ])
        .unwrap();
        let b = f64_batch(&[
            ("D", vec![2.0]),
            ("t_fit", vec![3.0]),
            (JK_UNIT, vec![8.0]),
            ("D_jk0", vec![2.1]),
            ("D_jk1", vec![1.9]),
        ])
        .unwrap();
        let c = f64_batch(&[("D", vec![3.0]), ("t_fit", vec![2.0])]).unwrap();
        let out = align(vec![a, b, c]).unwrap();
        assert!(out.iter().all(|o| o.schema() == out[0].schema()));
        assert_eq!(col(&out[1], "t_fit_jk1"), [3.0]);
        assert_eq!(col(&out[1], "D_jk0"), [2.1]);
        assert!(col(&out[2], "D_jk0")[0].is_nan());
        assert!(col(&out[2], JK_UNIT)[0].is_nan());
        // Other columns differing: left for the caller to refuse.
        let d = f64_batch(&[("E", vec![1.0])]).unwrap();
        let e = f64_batch(&[("D", vec![1.0])]).unwrap();
        let kept = align(vec![d, e]).unwrap();
        assert_ne!(kept[0].schema(), kept[1].schema());
        assert_eq!(parse_jk("Q_jk3"), Some(("Q", 3)));
        assert_eq!(parse_jk("n_jkx"), None);
    }
}
