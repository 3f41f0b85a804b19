//! The calls a `fmi3_api_*` input is decoded into (`arbitrary`), and their argument kinds.

use super::arbitrary::{self, Arbitrary};

/// A float: special values, small and unit-scaled ones, or any bit pattern.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum F {
    Zero,
    Neg,
    Small(u16),
    Unit(u8),
    Big,
    Nan,
    Inf,
    NegInf,
    Raw(u64),
}

impl F {
    pub fn get(self) -> f64 {
        match self {
            F::Zero => 0.0,
            F::Neg => -1e-3,
            F::Small(k) => (k as f64 + 1.0) * 1e-5,
            F::Unit(k) => k as f64 / 255.0,
            F::Big => 1e300,
            F::Nan => f64::NAN,
            F::Inf => f64::INFINITY,
            F::NegInf => f64::NEG_INFINITY,
            F::Raw(b) => f64::from_bits(b),
        }
    }
}

/// A value reference: a variable of the table, `time`, an event indicator (some beyond the
/// model's count), or any number.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Vr {
    Valid(u8),
    Time,
    Indicator(u8),
    Unknown(u32),
}

/// A value for a variable: scaled into its [min, max] (when it has one), its start, or anything.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Val {
    InRange(u8),
    Start,
    Any(F),
}

/// How an array is passed: as long as it should be, with another count (0 to 8), or as NULL
/// with a count of 0 to 2.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Count {
    Match,
    Other(u8),
    Null(u8),
}

/// The types of the getters and setters: those the models have variables of, and some they
/// have none of.
#[derive(Arbitrary, Debug, Clone, Copy, PartialEq)]
pub enum Ty {
    Float64,
    Int32,
    Boolean,
    String,
    Binary,
    Clock,
    Float32,
    UInt64,
}

#[derive(Arbitrary, Debug)]
pub enum Lifecycle {
    /// Co-Simulation (or Model Exchange when `me`); `bad` picks a wrong argument (0: none).
    Instantiate {
        me: bool,
        bad: u8,
        logger: bool,
        event_mode: bool,
        required: u8,
    },
    ScheduledExecution,
    Free,
    SetDebugLogging {
        on: bool,
        cats: Vec<u8>,
        null: bool,
    },
    EnterInit {
        tolerance: Option<F>,
        start: F,
        stop: Option<F>,
    },
    ExitInit,
    Terminate,
    Reset,
}

/// `fmi3Get<Ty>` / `fmi3Set<Ty>`.
#[derive(Arbitrary, Debug)]
pub struct Access {
    pub ty: Ty,
    pub get: bool,
    pub vrs: Vec<Vr>,
    pub null_vrs: bool,
    pub vals: Vec<Val>,
    pub count: Count,
    /// Raw bytes for Boolean setters (any non-zero byte is true) and Binary values.
    pub bytes: Vec<u8>,
}

/// `fmi3DoStep`: the step and which output pointers are NULL (bit mask).
#[derive(Arbitrary, Debug)]
pub struct Step {
    pub kind: StepKind,
    pub null_outputs: u8,
}

#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum StepKind {
    /// communicationStepSize in (0, 0.05]
    Normal(u8),
    /// currentCommunicationPoint off by this amount
    WrongTime(F, u8),
    /// any step size (at most 1 s: a long integration is not a bug)
    Bad(F),
}

#[derive(Arbitrary, Debug)]
pub enum MeOp {
    SetTime(F),
    SetContinuousStates {
        x: Vec<F>,
        count: Count,
    },
    /// 0 derivatives, 1 event indicators, 2 states, 3 nominals
    GetArray {
        which: u8,
        count: Count,
    },
    CompletedIntegratorStep {
        no_set_prior: bool,
        null_outputs: u8,
    },
    UpdateDiscreteStates {
        null_outputs: u8,
    },
    EnterEventMode,
    EnterContinuousTimeMode,
    NumberOf {
        indicators: bool,
        null: bool,
    },
    Derivative {
        adjoint: bool,
        unknowns: Vec<Vr>,
        knowns: Vec<Vr>,
        seed: Vec<F>,
        seed_count: Count,
        sensitivity_count: Count,
    },
}

#[derive(Arbitrary, Debug)]
pub enum StateOp {
    Get {
        slot: u8,
        reuse: bool,
        null: bool,
    },
    /// `from`: 0 an own state, 1 one of the other instance, 2 a foreign pointer, 3 NULL
    Set {
        slot: u8,
        from: u8,
    },
    Free {
        slot: u8,
        null: bool,
    },
    Serialize {
        slot: u8,
        short: bool,
    },
    Deserialize {
        slot: u8,
        flip: Option<(u16, u8)>,
        truncate: Option<u16>,
        raw: Option<Vec<u8>>,
        into_own: bool,
    },
}

#[derive(Arbitrary, Debug)]
pub enum Op {
    Life(Lifecycle),
    Access(Access),
    Step(Step),
    Me(MeOp),
    State(StateOp),
    Unsupported(u8),
    NullInstance(u8),
}

impl Op {
    /// True for the calls that make an instance (run even when there is none).
    pub fn creates(&self) -> bool {
        matches!(
            self,
            Op::Life(Lifecycle::Instantiate { .. } | Lifecycle::ScheduledExecution)
                | Op::NullInstance(_)
        )
    }
}

/// One call on the first or the second instance.
#[derive(Arbitrary, Debug)]
pub struct Call {
    pub second: bool,
    pub op: Op,
}

/// One fuzz input: a sequence of calls (the first 64 are run).
#[derive(Arbitrary, Debug)]
pub struct Input {
    pub calls: Vec<Call>,
}
