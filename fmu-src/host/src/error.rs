//! Typed errors of the host.

use std::fmt;
use std::path::PathBuf;

pub use fmi_types::Status;

/// One message an FMU logged through the `fmi2CallbackLogger`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LogRecord {
    /// Instance name the FMU passed.
    pub instance: String,
    /// Status the FMU passed with the message.
    pub status: Status,
    /// Log category.
    pub category: String,
    /// The formatted message.
    pub message: String,
}

impl fmt::Display for LogRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{}] {}", self.category, self.message)
    }
}

/// Text from outside (an FMU's log, a data cell) as shown in a one-line message: at most `max`
/// characters, control characters (newlines, NUL, escape sequences) escaped.
pub fn shown(text: &str, max: usize) -> String {
    let mut out: String = text
        .chars()
        .take(max)
        .flat_map(char::escape_debug)
        .collect();
    if text.chars().count() > max {
        out.push_str("...");
    }
    out
}

/// Most logged messages quoted after an error, and the characters of each.
const SHOWN_MESSAGES: usize = 3;
const SHOWN_MESSAGE_CHARS: usize = 200;

/// Formats logged messages after an error: ` (FMU log: msg1; msg2)`, or nothing. An FMU may log
/// without bound: the last three messages are quoted, each cut and escaped, so the error stays
/// one short line.
fn fmt_messages(messages: &[LogRecord]) -> String {
    if messages.is_empty() {
        return String::new();
    }
    let skip = messages.len().saturating_sub(SHOWN_MESSAGES);
    let joined: Vec<String> = messages[skip..]
        .iter()
        .map(|m| shown(&m.message, SHOWN_MESSAGE_CHARS))
        .collect();
    let earlier = match skip {
        0 => String::new(),
        n => format!("{n} earlier message(s), then: "),
    };
    format!(" (FMU log: {earlier}{})", joined.join("; "))
}

/// The status as the function's FMI version spells it (`fmi3Discard` from `fmi3DoStep`).
fn status_name(function: &str, status: Status) -> String {
    let name = status.to_string();
    if function.starts_with("fmi3") {
        name.replacen("fmi2", "fmi3", 1)
    } else {
        name
    }
}

/// Every failure of the host.
#[derive(Debug, thiserror::Error)]
pub enum HostError {
    /// Reading a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The `.fmu` is not a readable zip archive or lacks a required entry.
    #[error("{}: not a valid FMU: {message}", path.display())]
    Archive {
        /// The FMU.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// `modelDescription.xml` is malformed or violates the schema.
    #[error("{file}:{line}:{}{message}", if *column > 0 { format!("{column}: ") } else { " ".to_string() })]
    ModelDescription {
        /// File named in the message.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (bytes) of XML syntax errors; 0 when not known.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The shared library could not be loaded or lacks a required function.
    #[error("{}: {message}", path.display())]
    Binary {
        /// The FMU.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An FMI function returned a status other than fmi2OK/fmi2Warning.
    #[error("{function} returned {}{}", status_name(function, *status), fmt_messages(messages))]
    Fmi {
        /// Name of the FMI function, e.g. `fmi2DoStep`.
        function: &'static str,
        /// The status it returned.
        status: Status,
        /// Messages the FMU logged during the call.
        messages: Vec<LogRecord>,
    },
    /// `fmi2Instantiate` returned NULL.
    #[error("fmi2Instantiate returned NULL{}", fmt_messages(messages))]
    Instantiate {
        /// Messages the FMU logged during the call.
        messages: Vec<LogRecord>,
    },
    /// An FMI 3.0 instantiation function returned NULL.
    #[error("{function} returned NULL{}", fmt_messages(messages))]
    InstantiateNull {
        /// The function, e.g. `fmi3InstantiateCoSimulation`.
        function: &'static str,
        /// Messages the FMU logged during the call.
        messages: Vec<LogRecord>,
    },
    /// A call that must give an FMU state (fmi2GetFMUstate, fmi2DeSerializeFMUstate and their
    /// FMI 3.0 counterparts) returned a success status but left the state NULL: FMI 2.0.4
    /// section 2.1.8 "makes a copy of the internal FMU state and returns a pointer to this copy",
    /// FMI 3.0.2 section 2.2.7.4 "copies the internal FMU state and returns a pointer to this copy".
    #[error("{function} returned {} but gave no FMU state (the state pointer is still NULL)", status_name(function, *status))]
    NoFmuState {
        /// The function, e.g. `fmi2GetFMUstate`.
        function: &'static str,
        /// The success status it returned (OK or Warning).
        status: Status,
    },
    /// A variable name not in the model description.
    #[error("unknown variable '{0}'")]
    UnknownVariable(String),
    /// A kind of FMU this host does not run (e.g. FMI 3.0).
    #[error("{}: {message}", path.display())]
    Unsupported {
        /// The FMU.
        path: PathBuf,
        /// What is not supported.
        message: String,
    },
    /// A request that cannot be carried out (wrong type, wrong causality, bad times).
    #[error("{0}")]
    Request(String),
}

impl HostError {
    /// The fmi2Status carried by the error, if it came from an FMI call.
    pub fn status(&self) -> Option<Status> {
        match self {
            HostError::Fmi { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// Messages the FMU logged during the failing call.
    pub fn messages(&self) -> &[LogRecord] {
        match self {
            HostError::Fmi { messages, .. }
            | HostError::Instantiate { messages }
            | HostError::InstantiateNull { messages, .. } => messages,
            _ => &[],
        }
    }
}

/// `Ok` when a call that must give an FMU state gave one (`null` false), else
/// [`HostError::NoFmuState`] with the success `status` it returned.
pub(crate) fn fmu_state_given(function: &'static str, status: Status, null: bool) -> Result<()> {
    if null {
        Err(HostError::NoFmuState { function, status })
    } else {
        Ok(())
    }
}

/// Result alias of the host.
pub type Result<T, E = HostError> = std::result::Result<T, E>;
