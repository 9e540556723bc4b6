//! The real stage kinds: thin adapters from the pipeline framework to the library.
//!
//! - [`simulate`]: one seeded simulation (one replica at one packing fraction) with
//!   run lengths set in units of an estimated tau_alpha(phi) ([`run_length`],
//!   what downstream stages read of a run); [`simulate_cost`] what one is
//!   planned to cost (registered beside the kind, outside its key).
//! - [`analyse`]: every observable of `src/analysis` (Q(t), tau_alpha, aging, chi4,
//!   S4, MSD, van Hove, g_ab, clusters, intruder, ...) as a stage kind of its name,
//!   pooling the gathered replicas.
//! - [`fit`]: fits of a table column (power law, VFT, ...) and the finite-size
//!   scaling collapse.
//! - [`join`]: two tables joined by key columns, with derived columns.
//! - [`compare`]: fitted numbers against the paper's values, with a verdict.
//! - [`plot`]: a figure drawn from tables.
//! - [`synthetic`]: synthetic data with known truth (the fits' stability map).
//! - [`compression`]: how far the initial compression gets (stability maps).
//! - [`run_summary`]: a simulation's own measurements as a row (stability maps).
//! - [`script`]: one's own analysis or plot as a command in any language.
//!
//! Each kind names its own file (`file!()`); its code fingerprint hashes every
//! module that file reaches through the import graph short of the framework,
//! and the lock entries of the crates they use (`pipeline::fingerprint`), so
//! editing a plot adapter never reruns a simulation and no module a kind runs
//! is left out of its key (tests/keys.rs checks both against a second reading
//! of the sources).
//! The statistics of the fits live in the library ([`crate::fit::uncertainty`]);
//! these files read parameters and tables, call it and write tables.

pub mod analyse;
pub mod compare;
pub mod compression;
pub mod fit;
pub mod join;
pub mod joint_fit;
pub mod plot;
pub mod run_length;
pub mod run_summary;
pub mod script;
pub mod simulate;
pub mod simulate_cost;
pub mod steady_window;
pub mod synthetic;
pub mod tables;
#[cfg(test)]
pub(crate) mod test_support;
pub mod verdict_line;

use crate::pipeline::Registry;

/// The registry the binary runs with: the framework's kind (`table`) and every
/// kind of the library.
pub fn registry() -> Registry {
    let mut r = Registry::framework();
    register(&mut r);
    r
}

/// Register every real stage kind.
pub fn register(r: &mut Registry) {
    r.register_planned(simulate::Simulate, simulate_cost::planned);
    analyse::register(r);
    r.register(fit::Fit);
    r.register(fit::Collapse);
    r.register(join::Join);
    r.register(joint_fit::JointFit);
    r.register(compare::Compare);
    r.register(plot::Plot);
    r.register(synthetic::SyntheticCoverage);
    r.register(synthetic::SyntheticDivergence);
    r.register(run_summary::RunSummary);
    r.register(compression::Compression);
    r.register(script::Script);
    r.register(steady_window::SteadyWindow);
    r.register(steady_window::Window);
}
