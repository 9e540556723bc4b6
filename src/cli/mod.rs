//! The `repro` command line. Each area owns its subcommands in its own file and they
//! are flattened into one `repro` command here.

use clap::{Parser, Subcommand};

pub mod figs;
pub mod pipeline;
pub mod sim;

/// Regenerate the figures of the driven-granular-fluid papers from YAML specs.
#[derive(Parser, Debug)]
#[command(name = "repro", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    #[command(flatten)]
    Sim(sim::Commands),
    #[command(flatten)]
    Pipeline(pipeline::Commands),
    #[command(flatten)]
    Figs(figs::Commands),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Sim(c) => sim::run(c),
        Command::Pipeline(c) => pipeline::run(c),
        Command::Figs(c) => figs::run(c),
    }
}
