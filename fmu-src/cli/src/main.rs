//! `actuator-fmu`: simulate (Co-Simulation or Model Exchange), validate, find model gaps of and
//! design experiments for FMUs of FMI 2.0 and FMI 3.0.
//!
//! Exit status: 0 success (validate: no finding), 1 failure (validate: findings; simulate, gap:
//! the FMU failed after initialization), 2 bad input: usage, unreadable or bad data, an FMU that
//! cannot be opened, instantiated or initialized (refused parameters, GUID), what a command does
//! not run (Scheduled Execution, a clock of no kind the standard defines), an output
//! path that is an input, an FMU that crashed or did not return within --timeout; 3 simulate:
//! the results were written, then the FMU crashed (freeing its instance); 130 interrupted
//! (Ctrl-C, SIGTERM, SIGHUP).
//! The commands run in a supervised child process (module `supervise`).
//! `main` only parses arguments and dispatches: one module per subcommand.
// Host side: runs in the user's process, not inside an FMU; the FMUs' bit-determinism (the
// workspace clippy.toml) does not bind it.
#![allow(clippy::disallowed_methods)]

#[macro_use]
mod common;
mod design;
mod gap_cmd;
mod open;
mod probe;
mod report;
mod simulate;
mod supervise;
mod validate;
mod validate_reference;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "actuator-fmu",
    version,
    about = "Simulate, validate and find model gaps of FMI 2.0 and FMI 3.0 FMUs (Co-Simulation and Model Exchange)",
    after_help = "Exit status: 0 success; 1 validate found problems, or the FMU failed after \
                  initialization (simulate, gap); 2 bad input: usage, unreadable or bad data, \
                  an FMU that cannot be opened, instantiated or initialized, a kind of FMU the command does not run, an --out \
                  that is an input, an FMU that crashed or did not return within --timeout; \
                  3 simulate wrote its results, then the FMU crashed (freeing its instance); \
                  130 interrupted (temporary files removed)."
)]
struct Cli {
    /// Internal: this process is the supervised worker; marks FMU calls in this file.
    #[arg(long, hide = true, value_name = "WATCH")]
    supervised: Option<std::path::PathBuf>,
    /// Run in this process, without a supervising process (no crash or hang reports, no
    /// timeout, no cleanup on signals): for debugging with a debugger.
    #[arg(long, hide = true)]
    in_process: bool,
    #[command(subcommand)]
    command: Command,
}

impl Command {
    /// How to supervise the command; None for the internal probe (validate supervises it).
    fn supervision(&self) -> Option<supervise::Supervision> {
        let secs = |t: f64| (t > 0.0).then(|| std::time::Duration::from_secs_f64(t));
        let (fmu, call_timeout) = match self {
            Command::Simulate(a) => (a.fmu.display().to_string(), secs(a.run.timeout)),
            Command::Gap(a) => (a.fmu.display().to_string(), secs(a.run.timeout)),
            Command::Design(a) => (a.fmu.display().to_string(), secs(a.run.timeout)),
            Command::Validate(a) => (a.fmus[0].display().to_string(), None),
            Command::Probe(_) => return None,
        };
        Some(supervise::Supervision { fmu, call_timeout })
    }
}

#[derive(Subcommand)]
enum Command {
    /// Simulate an FMU with inputs from a CSV file and write every output to a CSV file.
    Simulate(simulate::Args),
    /// Check FMUs against the FMI 2.0.4 or FMI 3.0.2 standard (model description, binaries and a
    /// state-machine probe).
    Validate(validate::Args),
    /// The gap workflow: calibrate, locate the disagreement, name the missing effect, report.
    Gap(gap_cmd::Args),
    /// Experiment design: an input CSV that would reveal candidate effects the data cannot.
    Design(design::Args),
    /// Internal: the state-machine probe of `validate`, run in a child process.
    #[command(name = "__probe", hide = true)]
    Probe(probe::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match (&cli.supervised, cli.command.supervision()) {
        (None, Some(s)) if !cli.in_process => supervise::run(s),
        _ => {
            if let Some(path) = &cli.supervised {
                if let Err(e) = host::watch::attach(path) {
                    eprintln!("actuator-fmu: error: cannot attach to the supervisor: {e}");
                    std::process::exit(2);
                }
            }
            dispatch(cli.command)
        }
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("actuator-fmu: error: {}", e.message);
            std::process::exit(e.code);
        }
    }
}

fn dispatch(command: Command) -> common::CliResult {
    match command {
        Command::Simulate(a) => simulate::run(a),
        Command::Validate(a) => validate::run(a),
        Command::Gap(a) => gap_cmd::run(a),
        Command::Design(a) => design::run(a),
        Command::Probe(a) => probe::run(a),
    }
}
