//! The range scan of a fit (paper H, Appendix, Fig. 25): the same fit over
//! each window of x, and each parameter's spread between windows.

use anyhow::Result;
use arrow_array::RecordBatch;

use super::fitting::fit_data;
use super::params::FitParams;
use crate::fit::Data;
use crate::fit::catalogue::Form;
use crate::fit::ranges::range_scan;
use crate::table::results::quantity_batch;

/// The fit quality of each window, as the main table names it.
const REDUCED_CHI2: &str = "reduced_chi2";

/// The range scan of one group: every window's fit as rows of `ranges.parquet`
/// (the group's values, x_min, x_max, n_points, then quantity, value, error,
/// note; the parameters and `reduced_chi2`), and each parameter's spread between windows appended to `rows` as
/// `<parameter>_range_std` (NaN, with the reason in `note`, when no window fits).
pub(super) fn scan_ranges(
    p: &FitParams,
    form: &Form,
    data: Data<'_>,
    fixed: &[(&str, f64)],
    group: &[(String, f64)],
    rows: &mut Vec<(String, f64, f64)>,
    note: &mut String,
) -> Result<Vec<RecordBatch>> {
    let name = |n: &str| p.quantity_name(n);
    let fit = |d: Data<'_>| fit_data(p, Some(form), d, fixed);
    let scan = range_scan(data, &p.ranges, &fit);
    let mut windows = Vec::new();
    for (k, &(lo, hi)) in p.ranges.iter().enumerate() {
        let (points, result) = match &scan {
            Ok(s) => (s.fits[k].points, s.fits[k].result.clone()),
            Err(_) => (data.window(lo, hi).0.len(), Err("no window fits".into())),
        };
        let mut key = group.to_vec();
        key.extend([
            ("x_min".to_string(), lo),
            ("x_max".to_string(), hi),
            ("n_points".to_string(), points as f64),
        ]);
        let (quantities, why) = match result {
            // Each window's reduced chi^2 beside its parameters: where the form
            // holds (paper H, Fig. 4: the power law "only works for a narrower range").
            Ok(f) => (
                f.names
                    .iter()
                    .zip(f.params.iter().zip(&f.stderr))
                    .map(|(n, (v, e))| (name(n), *v, *e))
                    .chain([(name(REDUCED_CHI2), f.reduced_chi2, f64::NAN)])
                    .collect::<Vec<_>>(),
                f.warnings.join("; "),
            ),
            Err(e) => (
                form.params
                    .iter()
                    .copied()
                    .chain([REDUCED_CHI2])
                    .map(|n| (name(n), f64::NAN, f64::NAN))
                    .collect(),
                format!("fit failed: {e}"),
            ),
        };
        windows.push(quantity_batch(&key, &quantities, &why, None)?);
    }
    match &scan {
        Ok(s) => {
            rows.extend(
                s.spread
                    .iter()
                    .map(|sp| (format!("{}_range_std", name(&sp.name)), sp.std, f64::NAN)),
            );
            if s.spread.iter().any(|sp| sp.std.is_nan()) {
                let sep = if note.is_empty() { "" } else { "; " };
                note.push_str(&format!(
                    "{sep}range scan: fewer than two of the {} windows fit distinct sets of points, so no spread (NaN)",
                    s.fits.len()
                ));
            }
        }
        Err(e) => {
            rows.extend(
                form.params
                    .iter()
                    .map(|n| (format!("{}_range_std", name(n)), f64::NAN, f64::NAN)),
            );
            let sep = if note.is_empty() { "" } else { "; " };
            note.push_str(&format!("{sep}range scan failed: {e}"));
        }
    }
    Ok(windows)
}
