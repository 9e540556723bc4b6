//! Studies over built figures: what the key numbers are, how they scatter between
//! master seeds, and how they are reported.
//!
//! - [`results`]: reading a built figure (`results/ID/`): compare table, fit
//!   tables, provenance.
//! - [`variant`]: building figures from variants of the spec catalogue (master
//!   seed, N, replicas, any profile parameter), changed in memory; the cache store
//!   is shared, so a variant already computed is not recomputed.
//! - [`golden`]: the CI regression: golden bands from several master seeds, and
//!   the check of a built figure against them.
//! - [`coverage`]: whether quoted errors cover the seed-to-seed scatter.
//! - [`frontier`]: accuracy of the key numbers against their CPU cost.
//! - [`plan`]: the planned cost of a build, and with `--check` beside the CPU
//!   time its built simulations took.
//! - [`report`]: the gallery and the table of every key number, written from the
//!   compare tables (never typed by hand): one model, rendered as Markdown and as
//!   an HTML scoreboard with a page per figure.

pub mod built;
pub mod coverage;
pub mod frontier;
pub mod golden;
pub mod plan;
pub mod report;
pub mod results;
pub mod variant;
