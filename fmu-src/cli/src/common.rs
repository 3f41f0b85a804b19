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

use host::md::ModelDescription;
use host::Value;

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

/// Result of a subcommand: the exit status on success.
pub type CliResult = Result<i32, CliError>;

/// Parses `--set NAME=VALUE` arguments against the model description (`true`/`false` for
/// Booleans, numbers otherwise). Errors name the offending argument.
pub fn parse_sets(
    md: &ModelDescription,
    sets: &[String],
) -> Result<Vec<(String, Value)>, CliError> {
    sets.iter()
        .map(|s| {
            let (name, value) = s
                .split_once('=')
                .ok_or_else(|| CliError::input(format!("--set '{s}': expected NAME=VALUE")))?;
            let name = name.trim();
            let var = md.variable(name).ok_or_else(|| {
                CliError::input(format!("--set '{s}': the FMU has no variable '{name}'"))
            })?;
            let v = Value::parse_for(var, value)
                .map_err(|e| CliError::input(format!("--set '{s}': {e}")))?;
            Ok((name.to_string(), v))
        })
        .collect()
}
