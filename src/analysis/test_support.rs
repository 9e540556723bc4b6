//! What the tests of several modules share: reading a table's float columns,
//! the text of an expected error, and the frame times of a schedule.

use arrow_array::{Array, Float64Array, RecordBatch};

use crate::traj::Schedule;

/// A Float64 column of a table.
pub(crate) fn col(b: &RecordBatch, name: &str) -> Vec<f64> {
    b.column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<Float64Array>()
        .unwrap()
        .values()
        .to_vec()
}

/// The first value of column `name`.
pub(crate) fn first(b: &RecordBatch, name: &str) -> f64 {
    col(b, name)[0]
}

/// The whole error chain of a result that must be an error.
pub(crate) fn err_text<T: std::fmt::Debug>(r: anyhow::Result<T>) -> String {
    format!("{:#}", r.unwrap_err())
}

/// Frame times from t = 0 of `origins` origins `spacing` apart, each followed by
/// lags from `min` to `max`, 8 a decade.
pub(crate) fn schedule_times(origins: usize, spacing: f64, min: f64, max: f64) -> Vec<f64> {
    Schedule {
        start: 0.0,
        origins,
        origin_spacing: spacing,
        lags: Schedule::log_lags(min, max, 8),
    }
    .times()
}
