//! `actuator-fmu`: simulate and validate FMI 2.0 Co-Simulation FMUs.
//!
//! Exit status: 0 success (validate: no finding), 1 failure (validate: findings; simulate, gap:
//! the FMU failed after initialization), 2 bad input: usage, unreadable or bad data, an FMU that
//! cannot be opened, instantiated or initialized (refused parameters, GUID), FMI 3.0, an output
//! path that is an input.
//! `main` only parses arguments and dispatches: one module per subcommand.

#[macro_use]
mod common;
mod gap_cmd;
mod probe;
mod simulate;
mod validate;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "actuator-fmu",
    version,
    about = "Simulate and validate FMI 2.0 Co-Simulation FMUs",
    after_help = "Exit status: 0 success; 1 validate found problems, or the FMU failed after \
                  initialization (simulate, gap); 2 bad input: usage, unreadable or bad data, \
                  an FMU that cannot be opened, instantiated or initialized, FMI 3.0, an --out \
                  that is an input."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate an FMU with inputs from a CSV file and write every output to a CSV file.
    Simulate(simulate::Args),
    /// Check FMUs against the FMI 2.0 standard (model description and a state-machine probe).
    Validate(validate::Args),
    /// The gap workflow: calibrate, locate the disagreement, name the missing effect, report.
    Gap(gap_cmd::Args),
    /// Internal: the state-machine probe of `validate`, run in a child process.
    #[command(name = "__probe", hide = true)]
    Probe(probe::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Validate(a) => validate::run(a),
        Command::Gap(a) => gap_cmd::run(a),
        Command::Probe(a) => probe::run(a),
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("actuator-fmu: error: {}", e.message);
            std::process::exit(e.code);
        }
    }
}
