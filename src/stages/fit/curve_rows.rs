//! The rows of a collapse's data as its curves take them: x, y, y's error and
//! the curve's value (`curve_by`) of each row of `where`.

use anyhow::Result;

use super::params::CollapseParams;
use crate::fit::collapse::{Curve, curves_by};
use crate::stages::tables::{Columns, pick};

/// The rows of `where` of a collapse's data, column by column.
pub(super) struct CurveRows<'a> {
    curve_by: &'a str,
    pub(super) x: Vec<f64>,
    pub(super) y: Vec<f64>,
    e: Vec<f64>,
    by: Vec<f64>,
}

impl<'a> CurveRows<'a> {
    /// `rows` of `c`: x, y, y's error and the curve's value, as `p` names them.
    pub(super) fn read(p: &'a CollapseParams, c: &Columns, rows: &[usize]) -> Result<Self> {
        Ok(CurveRows {
            curve_by: &p.curve_by,
            x: pick(c.col(&p.x)?, rows),
            y: pick(c.col(&p.y)?, rows),
            e: pick(c.col(&p.y_err)?, rows),
            by: pick(c.col(&p.curve_by)?, rows),
        })
    }

    /// The curves of the rows with y values `ys` (the rows' own, or a replica
    /// sample's), but those `keep` leaves out.
    pub(super) fn curves(&self, ys: &[f64], keep: impl Fn(&Curve) -> bool) -> Vec<Curve> {
        curves_by(self.curve_by, &self.x, ys, &self.e, &self.by)
            .into_iter()
            .filter(|cv| keep(cv))
            .collect()
    }
}
