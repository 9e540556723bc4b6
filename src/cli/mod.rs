//! The `repro` command line. Each area owns its subcommands in its own file and they
//! are flattened into one `repro` command here.

use clap::{Parser, Subcommand};

pub mod figs;
pub mod pipeline;
pub mod root;
pub mod runs;
pub mod sim;
pub mod what_if;

pub use pipeline::{TOY_KINDS, registry};

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

/// `repro kinds`: one paragraph per registered kind, from the registry itself.
fn kinds() {
    let reg = registry();
    for name in reg.names() {
        let k = reg.get(&name).expect("listed kind");
        println!("{name}\n    {}", k.describe());
        let details = k.details();
        // Kinds without their own listing: the keys their typed parameters accept.
        if !details.starts_with("parameters:") {
            let keys = crate::pipeline::registry::param_keys(|v| k.validate(v));
            if !keys.is_empty() {
                println!("    parameters: {}", keys.join(", "));
            }
        }
        for line in details.lines() {
            println!("    {line}");
        }
        println!(
            "    code: {} (with what it imports: {} modules, {} crates)",
            k.modules()
                .iter()
                .map(|m| format!("src/{}.rs", crate::pipeline::fingerprint::module_key(m)))
                .collect::<Vec<_>>()
                .join(", "),
            reg.modules(&name).len(),
            reg.crates(&name).len()
        );
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
