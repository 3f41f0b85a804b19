//! `fmi2Status` (standard section 2.1.3) as a Rust enum; the raw int lives in [`crate::c`].

use std::fmt;

/// A status returned by an FMI 2.0 function.
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

#[cfg(test)]
mod tests {
    use super::Status;

    #[test]
    fn raw_values_round_trip() {
        for raw in -1..7 {
            assert_eq!(Status::from_raw(raw).raw(), raw);
        }
        assert_eq!(Status::from_raw(2).to_string(), "fmi2Discard");
        assert!(Status::from_raw(1).is_success() && !Status::from_raw(2).is_success());
    }
}
