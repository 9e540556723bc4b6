//! One disk's hot state, as every collision prediction reads it, and the codes
//! that stand for a pending event's partner when it is not a disk.

pub(crate) const NONE: u32 = u32::MAX;
/// Partner codes >= CROSS mean "leave the cell" in direction `code - CROSS`
/// (0: +x, 1: -x, 2: +y, 3: -y).
pub(crate) const CROSS: u32 = u32::MAX - 8;
/// Partner codes of "hit the wall" of axis `code - WALL` (0: x, 1: y).
pub(crate) const WALL: u32 = CROSS + 5;
/// Partner code of "predict anew" (the intruder's root finder gave up, or
/// nothing happened within its horizon).
pub(crate) const REPREDICT: u32 = CROSS + 7;
/// Partner code of "leave the neighbour-list shell".
pub(crate) const SHELL: u32 = CROSS + 4;

/// The state of one disk that every collision prediction reads, packed in one
/// cache line: scanning a neighbour costs one memory access instead of seven.
/// Serialised as part of the engine's state without `radius`, `te` and
/// `next`, which are rebuilt from it (the species' radius, the calendar, the
/// cell list).
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
#[repr(C, align(64))]
pub(crate) struct Disk {
    pub(crate) x: f64,
    pub(crate) y: f64,
    pub(crate) vx: f64,
    pub(crate) vy: f64,
    /// Time at which `x`, `y` are valid (lazy update).
    pub(crate) t: f64,
    #[serde(skip)]
    pub(crate) radius: f64,
    /// Time of this disk's pending event (a copy of its calendar time, read while
    /// scanning neighbours from the line that is loaded anyway).
    #[serde(skip)]
    pub(crate) te: f64,
    /// Next disk in the same cell.
    #[serde(skip)]
    pub(crate) next: u32,
    /// Velocity changes so far: events predicted with an older value are stale.
    pub(crate) count: u32,
}
