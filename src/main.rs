use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = repro::cli::Cli::parse();
    match repro::cli::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
