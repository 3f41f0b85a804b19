//! Shared helpers of the subcommands: errors with exit codes, `--set` parsing, stdout lines.

/// `println!` that never panics: a stdout that was closed (`actuator-fmu gap ... | head -1`) or
/// fails loses the summary line, never the run (its results are in the files it wrote, and the
/// exit status stays that of the work). `println!` panics on a broken pipe.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

use host::view::{Causality, ModelView};
use host::{Interface, Value};
use std::path::PathBuf;

/// `--interface`: which FMI interface of the FMU runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum InterfaceArg {
    /// Co-Simulation: the FMU integrates itself.
    Cs,
    /// Model Exchange: the host integrates the FMU with its Rosenbrock solver.
    Me,
}

impl InterfaceArg {
    /// The host's interface for the option (None: Co-Simulation where offered, else ME).
    pub fn host(arg: Option<InterfaceArg>) -> Option<Interface> {
        arg.map(|a| match a {
            InterfaceArg::Cs => Interface::CoSimulation,
            InterfaceArg::Me => Interface::ModelExchange,
        })
    }
}

/// The options of every command that runs the FMU.
#[derive(clap::Args, Clone, Debug)]
pub struct RunArgs {
    /// FMI interface to run: cs (Co-Simulation) or me (Model Exchange, integrated by the host
    /// with its stiff Rosenbrock solver, events located). Default: cs where the FMU offers it,
    /// else me.
    #[arg(long, value_enum, value_name = "cs|me")]
    pub interface: Option<InterfaceArg>,
    /// Longest one FMU call may take [s] before the run is stopped as hung (0: no limit).
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    pub timeout: f64,
    /// Python interpreter whose runtime an FMU needing one (made by PythonFMU) gets
    /// (default: python3 on PATH).
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
}

impl RunArgs {
    /// The host's options for opening the FMU.
    pub fn open_options(&self) -> host::OpenOptions {
        host::OpenOptions {
            python: self.python.clone(),
            interface: InterfaceArg::host(self.interface),
        }
    }
}

/// An error that ends the program with `code` after printing `message`.
#[derive(Debug)]
pub struct CliError {
    /// Exit status.
    pub code: i32,
    /// One clear line.
    pub message: String,
}

impl CliError {
    /// Bad usage, bad data, an FMU that cannot be opened: exit status 2.
    pub fn input(message: impl std::fmt::Display) -> Self {
        CliError {
            code: 2,
            message: message.to_string(),
        }
    }

    /// A failure while running: exit status 1.
    pub fn failure(message: impl std::fmt::Display) -> Self {
        CliError {
            code: 1,
            message: message.to_string(),
        }
    }
}

/// The exit status of a host error met while running an FMU: an FMU that cannot be
/// instantiated or initialized (NULL from fmi2Instantiate, a GUID it refuses, parameters it
/// refuses) is a bad FMU or bad input, exit 2; a failure after initialization is the FMU
/// failing during the run, exit 1.
pub fn run_error(context: &str, e: host::HostError) -> CliError {
    use host::HostError;
    let setup = match &e {
        HostError::Instantiate { .. }
        | HostError::InstantiateNull { .. }
        | HostError::Unsupported { .. } => true,
        HostError::Fmi { function, .. } => matches!(
            *function,
            "fmi2Instantiate"
                | "fmi2SetupExperiment"
                | "fmi2EnterInitializationMode"
                | "fmi2ExitInitializationMode"
                | "fmi3EnterConfigurationMode"
                | "fmi3ExitConfigurationMode"
                | "fmi3EnterInitializationMode"
                | "fmi3ExitInitializationMode"
        ),
        HostError::Request(_) | HostError::UnknownVariable(_) => true,
        _ => false,
    };
    if setup {
        CliError::input(format!("{context}: {e}"))
    } else {
        CliError::failure(format!("{context}: simulation failed: {e}"))
    }
}

/// Refuses an output path that is one of the inputs (the same file, however it is named):
/// writing it would destroy the user's data.
pub fn refuse_overwriting(
    out: &std::path::Path,
    inputs: &[&std::path::Path],
) -> Result<(), CliError> {
    let Ok(out_real) = out.canonicalize() else {
        return Ok(()); // does not exist yet: cannot be an input
    };
    for input in inputs {
        if input.canonicalize().is_ok_and(|i| i == out_real) {
            return Err(CliError::input(format!(
                "--out {} is the input {}: refusing to overwrite it",
                out.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// Result of a subcommand: the exit status on success.
pub type CliResult = Result<i32, CliError>;

/// Splits the `--set NAME=VALUE` argument `set` into its trimmed name and its value text, and
/// finds the variable it names with `lookup`: FMI 2.0 and FMI 3.0 keep their variables in types
/// of their own, the argument's form and its two messages are the same for both.
pub fn set_target<'s, 'm, V>(
    set: &'s str,
    lookup: impl FnOnce(&str) -> Option<&'m V>,
) -> Result<(&'s str, &'s str, &'m V), CliError> {
    let (name, value) = set
        .split_once('=')
        .ok_or_else(|| CliError::input(format!("--set '{set}': expected NAME=VALUE")))?;
    let name = name.trim();
    let var = lookup(name).ok_or_else(|| {
        CliError::input(format!("--set '{set}': the FMU has no variable '{name}'"))
    })?;
    Ok((name, value, var))
}

/// Parses `--set NAME=VALUE` arguments against the model description (`true`/`false` for
/// Booleans, numbers otherwise). Errors name the offending argument.
pub fn parse_sets(md: &ModelView, sets: &[String]) -> Result<Vec<(String, Value)>, CliError> {
    sets.iter()
        .map(|s| {
            let (name, value, var) = set_target(s, |name| md.scalar(name))?;
            if !matches!(var.causality, Causality::Parameter | Causality::Input) {
                return Err(CliError::input(format!(
                    "--set '{s}': '{name}' is {} {}: only parameters and inputs can be set",
                    if var.causality == Causality::Output {
                        "an"
                    } else {
                        "a"
                    },
                    var.causality
                )));
            }
            let v = Value::parse_for(var, value)
                .map_err(|e| CliError::input(format!("--set '{s}': {e}")))?;
            Ok((name.to_string(), v))
        })
        .collect()
}

/// `--set` arguments as numbers (Booleans 0/1) for the gap workflow and experiment design, which
/// fix numeric settings only.
pub fn numeric_sets(
    md: &ModelView,
    sets: &[String],
    command: &str,
) -> Result<Vec<(String, f64)>, CliError> {
    parse_sets(md, sets)?
        .into_iter()
        .map(|(n, v)| match v {
            Value::Real(x) => Ok((n, x)),
            Value::Boolean(b) => Ok((n, f64::from(u8::from(b)))),
            Value::Text(_) => Err(CliError::input(format!(
                "--set '{n}': a String parameter cannot be fixed for {command} (numbers and \
                 Booleans only)"
            ))),
        })
        .collect()
}
