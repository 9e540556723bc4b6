//! The real stage kinds: thin adapters from the pipeline framework to the library.
//!
//! - [`simulate`]: one seeded simulation (one replica at one packing fraction) with
//!   run lengths set in units of an estimated tau_alpha(phi).
//! - [`overlap`]: Q(t), tau_alpha and the aging check Q(t; t0) from pooled replicas.
//! - [`chi4`]: chi4(t) and its peaks per sub-box size.
//! - [`fits`]: fits of a table column (power law, VFT, ...) and the finite-size
//!   scaling collapse.
//! - [`plot`]: a figure drawn from tables.
//!
//! Each kind names exactly the source modules it depends on, so editing a plot
//! adapter never reruns a simulation.

pub mod chi4;
pub mod fits;
pub mod overlap;
pub mod plot;
pub mod simulate;
pub mod tables;

use crate::pipeline::Registry;

/// Register every real stage kind.
pub fn register(r: &mut Registry) {
    r.register(simulate::Simulate);
    r.register(overlap::Overlap);
    r.register(overlap::TauAlpha);
    r.register(overlap::Aging);
    r.register(chi4::Chi4);
    r.register(chi4::Chi4Peaks);
    r.register(fits::Fit);
    r.register(fits::Collapse);
    r.register(plot::Plot);
}
