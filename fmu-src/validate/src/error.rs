//! Why a runtime probe could not make its check: a call the standard allows failed, or the FMU
//! gave a value the run cannot go on from. The probes turn these into findings of the normal
//! run (or of the check they interrupted) with this text as the message.

use host::HostError;
use std::fmt;

/// A failure of a probe's legal calling sequence.
#[derive(Debug, thiserror::Error)]
pub enum ProbeError {
    /// An FMI call failed (its function, status and logged messages in the host error).
    #[error(transparent)]
    Call(#[from] HostError),
    /// A failure at a named stage of the run (a step, after a reset, after a restored state).
    #[error("{stage}: {source}")]
    At {
        /// Where in the sequence.
        stage: Stage,
        /// What failed there.
        #[source]
        source: Box<ProbeError>,
    },
    /// A Real output is NaN or infinite after a communication step.
    #[error("output vr {value_reference} is {value} after step {step}")]
    OutputNotFinite {
        /// The output's value reference.
        value_reference: u32,
        /// Its value.
        value: f64,
        /// The step after which it was read (0 is the first).
        step: usize,
        /// The communication point reached.
        time: f64,
    },
    /// A state derivative is NaN or infinite.
    #[error("derivative {index} is {value} at t = {time}")]
    DerivativeNotFinite {
        /// Position of the derivative in the state vector.
        index: usize,
        /// Its value.
        value: f64,
        /// The time of the states.
        time: f64,
    },
    /// `newDiscreteStates` / `fmi3UpdateDiscreteStates` keeps asking for another iteration.
    #[error("the event iteration still needs iterations after {limit} calls")]
    EventIterationEndless {
        /// The most calls the probe makes.
        limit: usize,
        /// The time of the event.
        time: f64,
    },
}

impl ProbeError {
    /// This failure located at `stage`.
    pub fn at(self, stage: Stage) -> ProbeError {
        ProbeError::At {
            stage,
            source: Box::new(self),
        }
    }
}

/// Where in a probe's sequence a call failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stage {
    /// Communication step `k` (0 is the first).
    Step(usize),
    /// Reset after terminate.
    AfterTerminate,
    /// Initialization and the first step after a reset.
    AfterReset,
    /// The steps after a state was restored with the named call.
    AfterRestore(&'static str),
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Stage::Step(k) => write!(f, "step {k}"),
            Stage::AfterTerminate => f.write_str("after terminate"),
            Stage::AfterReset => f.write_str("after reset"),
            Stage::AfterRestore(call) => write!(f, "after {call}"),
        }
    }
}

/// What a check found: `Ok(None)` conforming, `Ok(Some(message))` a finding, `Err` a failing
/// call the standard allows.
pub type Verdict = Result<Option<String>, ProbeError>;

/// A failing call located at `stage`, for `map_err`.
pub(crate) fn at(stage: Stage) -> impl Fn(HostError) -> ProbeError {
    move |e| ProbeError::Call(e).at(stage)
}
