//! What the engine derives from its state
//! ([`EngineState`](super::state::EngineState)): the padded box and its cell
//! grid, the cell list, neighbour lists, pending events and their calendar,
//! the prefetch pipeline. `Engine::from_state` (in setup.rs) builds all of it
//! from the state alone, the same way for a new engine and a resumed one: a
//! resume continues bit for bit only if nothing here carries history.

use super::parts::{Book, Lists, Pipeline, SHELL_FRACTION};
use crate::sim::events::calendar::EventCalendar;
use crate::sim::model::walls;

/// Everything rebuilt from the state.
pub(super) struct Derived {
    /// The engine's box: the physical box, padded on walled axes.
    pub(super) lx: f64,
    pub(super) ly: f64,
    /// Length of each walled axis (the walls are at 0 and there); infinity
    /// on periodic axes.
    pub(super) wall_len: [f64; 2],
    pub(super) has_walls: bool,
    /// The cell grid: cells per axis and their widths.
    pub(super) ncx: usize,
    pub(super) ncy: usize,
    pub(super) wx: f64,
    pub(super) wy: f64,
    /// Largest radius.
    pub(super) rmax: f64,
    /// First disk of each cell, and the number of disks in it (kick partners
    /// are drawn without a walk).
    pub(super) head: Vec<u32>,
    pub(super) occupancy: Vec<u32>,
    /// Previous disk in the same cell, and each disk's cell.
    pub(super) prev: Vec<u32>,
    pub(super) cell: Vec<u32>,
    /// Per-disk event partner, list centre and list length, packed so that a
    /// prediction touches one line for them instead of five arrays.
    pub(super) bk: Vec<Book>,
    pub(super) calendar: EventCalendar,
    /// The neighbour lists and their shell.
    pub(super) lists: Lists,
    /// The prefetch pipeline's state.
    pub(super) pipeline: Pipeline,
}

/// The box and cell grid of a state, and the neighbour lists' dimensions.
pub(super) struct Geometry {
    pub(super) lx: f64,
    pub(super) ly: f64,
    pub(super) wall_len: [f64; 2],
    pub(super) ncx: usize,
    pub(super) ncy: usize,
    pub(super) rmax: f64,
    pub(super) shell: f64,
    /// A packing bound on a neighbour list's length.
    pub(super) cap_max: usize,
    /// The box holds 5x5 cells: neighbour lists can be used.
    pub(super) lists_fit: bool,
}

impl Geometry {
    /// The geometry of box `box_size` with `walls` and disks of `radii`.
    /// Fails if the box is too small for a 3x3 cell list or between its walls.
    pub(super) fn of(box_size: [f64; 2], walls: [bool; 2], radii: &[f64]) -> anyhow::Result<Self> {
        let rmax = radii.iter().copied().fold(0.0, f64::max);
        let rmin = radii.iter().copied().fold(f64::INFINITY, f64::min);
        let shell = SHELL_FRACTION * rmin;
        let pad = walls::padding(rmax, shell);
        let wall_len = [0, 1].map(|k| if walls[k] { box_size[k] } else { f64::INFINITY });
        let [lx, ly] = [0, 1].map(|k| box_size[k] + if walls[k] { pad } else { 0.0 });
        let ncx = (lx / (2.0 * rmax)).floor() as usize;
        let ncy = (ly / (2.0 * rmax)).floor() as usize;
        anyhow::ensure!(
            ncx >= 3 && ncy >= 3,
            "box {:.3} x {:.3} is smaller than 3 cells of one large-disk diameter ({:.3}); use more particles",
            box_size[0],
            box_size[1],
            2.0 * rmax
        );
        for k in 0..2 {
            anyhow::ensure!(
                wall_len[k] > 4.0 * rmax,
                "walls: the box ({:.3} between the walls of axis {}) must be wider than two large-disk diameters ({:.3})",
                wall_len[k],
                ["x", "y"][k],
                4.0 * rmax
            );
        }
        // Disks of radius r - shell around the list centres never overlap, and those
        // in a list lie within r_i + 2 r_max + shell of the centre: an area bound.
        let cap_max = (((rmax + 2.0 * rmax + shell) / (rmin - shell))
            .powi(2)
            .floor() as usize
            + 4)
        .min(u8::MAX as usize);
        Ok(Geometry {
            lx,
            ly,
            wall_len,
            ncx,
            ncy,
            rmax,
            shell,
            cap_max,
            lists_fit: ncx >= 5 && ncy >= 5,
        })
    }
}
