//! `repro figure`, `list`, `status`, `why`, `gc`: the pipeline commands.

use clap::Subcommand;

#[derive(Subcommand, Debug)]
pub enum Commands {
    /// Build one figure from its pipeline spec (not yet built: issue 4).
    Figure,
}

pub fn run(c: Commands) -> anyhow::Result<()> {
    match c {
        Commands::Figure => anyhow::bail!("`repro figure` is not built yet (issue 4)"),
    }
}
