//! `repro sim` and `repro bench`: run the event-driven simulator directly.

use clap::Subcommand;

#[derive(Subcommand, Debug)]
pub enum Commands {
    /// Run one simulation directly (not yet built: issue 2).
    Sim,
}

pub fn run(c: Commands) -> anyhow::Result<()> {
    match c {
        Commands::Sim => anyhow::bail!("`repro sim` is not built yet (issue 2)"),
    }
}
