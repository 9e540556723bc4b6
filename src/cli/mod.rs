//! The `repro` command line. Each area owns its subcommands in its own file and they
//! are flattened into one `repro` command here.

use clap::{Parser, Subcommand};

use crate::pipeline::Registry;

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
    /// List the stage kinds a pipeline can use, with what each does.
    Kinds,
}

/// The registry the command line runs with: every kind of the library
/// (`stages::registry()`), and the framework's toy kinds in test builds only
/// (the `toy-kinds` feature, which the shipped binary does not have).
pub fn registry() -> Registry {
    #[allow(unused_mut)]
    let mut r = crate::stages::registry();
    #[cfg(feature = "toy-kinds")]
    crate::pipeline::toy::register(&mut r);
    r
}

/// `repro kinds`: one paragraph per registered kind, from the registry itself.
fn kinds() {
    let reg = registry();
    for name in reg.names() {
        let k = reg.get(&name).expect("listed kind");
        println!("{name}\n    {}", k.describe());
        for line in k.details().lines() {
            println!("    {line}");
        }
        println!("    code: src/{}", k.modules().join(", src/"));
    }
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Sim(c) => sim::run(c),
        Command::Pipeline(c) => pipeline::run(c),
        Command::Figs(c) => figs::run(c),
        Command::Kinds => {
            kinds();
            Ok(())
        }
    }
}
