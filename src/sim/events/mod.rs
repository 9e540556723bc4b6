//! The event machinery the engine runs on:
//!
//! - [`calendar`]: the event calendar, an O(1) calendar queue of one pending
//!   event per disk.
//! - [`disk`]: one disk's hot state and the codes of non-disk event partners.
//! - [`pair_scan`]: the earliest collision of a disk with its neighbour list
//!   (scalar and SSE2, the same bits).
//! - [`cache_hints`]: prefetch hints (no result depends on them).
//!
//! The cell list and the neighbour lists hold engine state: they are in
//! [`engine`](super::engine) (its `cells` and `neighbour_lists`).

pub(crate) mod cache_hints;
pub mod calendar;
pub(crate) mod disk;
pub(crate) mod pair_scan;
