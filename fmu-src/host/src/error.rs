//! Typed errors of the host.

use std::fmt;
use std::path::PathBuf;

/// `fmi2Status` as returned by every FMI 2.0 function (FMI 2.0.4 standard, section 2.1.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Status {
    /// fmi2OK (0)
    Ok,
    /// fmi2Warning (1)
    Warning,
    /// fmi2Discard (2)
    Discard,
    /// fmi2Error (3)
    Error,
    /// fmi2Fatal (4)
    Fatal,
    /// fmi2Pending (5)
    Pending,
    /// Any other integer: not a valid fmi2Status.
    Invalid(i32),
}

impl Status {
    /// Converts the raw C enum value.
    pub fn from_raw(raw: i32) -> Self {
        match raw {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            4 => Status::Fatal,
            5 => Status::Pending,
            other => Status::Invalid(other),
        }
    }

    /// The raw C enum value.
    pub fn raw(self) -> i32 {
        match self {
            Status::Ok => 0,
            Status::Warning => 1,
            Status::Discard => 2,
            Status::Error => 3,
            Status::Fatal => 4,
            Status::Pending => 5,
            Status::Invalid(v) => v,
        }
    }

    /// True for fmi2OK and fmi2Warning, the statuses after which the result is usable.
    pub fn is_success(self) -> bool {
        matches!(self, Status::Ok | Status::Warning)
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Status::Ok => f.write_str("fmi2OK"),
            Status::Warning => f.write_str("fmi2Warning"),
            Status::Discard => f.write_str("fmi2Discard"),
            Status::Error => f.write_str("fmi2Error"),
            Status::Fatal => f.write_str("fmi2Fatal"),
            Status::Pending => f.write_str("fmi2Pending"),
            Status::Invalid(v) => write!(f, "invalid fmi2Status {v}"),
        }
    }
}

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

/// Formats logged messages after an error: `: msg1; msg2`, or nothing.
fn fmt_messages(messages: &[LogRecord]) -> String {
    if messages.is_empty() {
        String::new()
    } else {
        let joined: Vec<String> = messages.iter().map(|m| m.message.clone()).collect();
        format!(" (FMU log: {})", joined.join("; "))
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
    #[error("{function} returned {status}{}", fmt_messages(messages))]
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
    /// A variable name not in the model description.
    #[error("unknown variable '{0}'")]
    UnknownVariable(String),
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
            HostError::Fmi { messages, .. } | HostError::Instantiate { messages } => messages,
            _ => &[],
        }
    }
}

/// Result alias of the host.
pub type Result<T, E = HostError> = std::result::Result<T, E>;
