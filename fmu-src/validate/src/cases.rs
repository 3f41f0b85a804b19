//! The wrong-call cases every probe makes: a fresh instance, brought to a state, given a call
//! the state machine does not allow (FMI 2.0.4 sections 3.2.3 and 4.2.4, FMI 3.0.2 sections
//! 2.3, 3.2 and 4.2). The importer must not make such a call, so the answer is the FMU's: a
//! note unless it is the error status. The versions differ in how their messages write a
//! status ([`Dialect`]) and in how a failing set-up counts ([`SetupFailure`]).

use super::instance::{Probed, ProbedFmu};
use super::Finding;
use host::me::ModelExchange;
use host::{HostError, Status};
use std::fmt::Display;

/// A probe's callback that says whether to run a case (by name), and its findings so far.
pub(crate) type Progress<'p> = (&'p mut dyn FnMut(&str) -> bool, &'p mut Vec<Finding>);

/// Builds a finding with the clause of one version and interface.
pub(crate) type MakeFinding = fn(&str, String, String) -> Finding;

/// How one FMI version's probe messages write a status and what they advise.
pub(crate) struct Dialect {
    /// The error status, by name.
    pub error: &'static str,
    /// A status, by name.
    pub status_name: fn(Status) -> String,
    /// What would warn the importer instead of an accepted call.
    pub advice: &'static str,
    /// Whether an error answer needs a logged message: the FMI 2.0 probe instantiates with
    /// logging on; the FMI 3.0 host instantiates with `loggingOn = fmi3False`, with which the
    /// FMU must not call the logger (FMI 3.0.2 section 2.3.1).
    pub error_needs_log: bool,
}

/// The FMI 2.0 probes' spelling.
pub(crate) const FMI2: Dialect = Dialect {
    error: "fmi2Error",
    status_name: |s| s.to_string(),
    advice: "fmi2Error with a logged message would warn the importer",
    error_needs_log: true,
};

/// The FMI 3.0 probes' spelling.
pub(crate) const FMI3: Dialect = Dialect {
    error: "fmi3Error",
    status_name: |s| match s {
        Status::Ok => "fmi3OK".to_string(),
        s => format!("fmi3{s:?}"),
    },
    advice: "fmi3Error would warn the importer",
    error_needs_log: false,
};

/// How a wrong-call case counts a failure before its call.
#[derive(Clone, Copy)]
pub(crate) enum SetupFailure {
    /// A finding of the normal run; a failing instantiation's message starts with the text.
    NormalRun(&'static str),
    /// The answer to the case's call (the FMI 3.0 Model Exchange probe).
    Answer,
}

/// One wrong-call case of a probe.
pub(crate) struct WrongCall<'c> {
    /// The case's name (`negative-step`).
    pub name: &'c str,
    /// The call, as the messages name it.
    pub what: &'c str,
    /// The time to initialize at before the call; None to call before initialization.
    pub init_at: Option<f64>,
    /// The check of an accepted call (`probe-wrong-call`, `probe-nan`).
    pub accepted: &'static str,
}

/// The probe of one version and interface: its spelling, its clauses and how a failing set-up
/// counts.
#[derive(Clone, Copy)]
pub(crate) struct CaseRules {
    /// The version's spelling.
    pub dialect: &'static Dialect,
    /// Findings with the clauses of this version and interface.
    pub finding: MakeFinding,
    /// How a failure before the call counts.
    pub setup: SetupFailure,
}

/// Where a wrong-call case failed before its call.
enum Setup {
    Instantiate,
    Initialize,
    Bind,
}

impl CaseRules {
    /// Runs `case` on a fresh instance of `fmu` (when `step` lets it run): `call` is the wrong
    /// call; its answer becomes a finding or nothing.
    pub fn run<'f, F: ProbedFmu>(
        &self,
        fmu: &'f F,
        case: &WrongCall<'_>,
        (step, f): Progress<'_>,
        call: &mut dyn FnMut(&mut F::Instance<'f>) -> Result<Status, HostError>,
    ) {
        if !step(case.name) {
            return;
        }
        let outcome = set_up(fmu, case.init_at).map(|mut inst| call(&mut inst));
        f.extend(self.settle(case, outcome));
    }

    /// The normal run a Co-Simulation probe starts with, case `name`, when `step` lets it run:
    /// `run` answers `Some(message)` when the FMU cannot reset. Whether the probe goes on: the
    /// other cases assume a working FMU, and an FMU that cannot reset may lack a runtime on this
    /// host, so the cases would fail for the same reason.
    pub fn normal_run<E: Display>(
        &self,
        name: &str,
        (step, f): Progress<'_>,
        run: impl FnOnce() -> Result<Option<String>, E>,
    ) -> bool {
        if !step(name) {
            return false;
        }
        let (check, m) = match run() {
            Ok(None) => return true,
            Ok(Some(m)) => ("probe-reset", m),
            Err(e) => (
                "probe-normal-run",
                format!(
                    "instantiate, initialize, 10 steps, terminate, reset, re-initialize, step \
                     failed: {e}"
                ),
            ),
        };
        f.push((self.finding)(check, format!("probe {name}"), m));
        false
    }

    /// [`Self::run`] for a call on the instance bound as Model Exchange.
    pub fn run_me<F: ProbedFmu>(
        &self,
        fmu: &F,
        case: &WrongCall<'_>,
        (step, f): Progress<'_>,
        call: &mut dyn FnMut(&mut dyn ModelExchange) -> Result<(), HostError>,
    ) {
        if !step(case.name) {
            return;
        }
        let outcome = set_up(fmu, case.init_at).and_then(|mut inst| {
            let mut me = inst.model_exchange().map_err(|e| (Setup::Bind, e))?;
            Ok(call(&mut me).map(|()| Status::Ok))
        });
        f.extend(self.settle(case, outcome));
    }

    /// The finding of a case's outcome: a failed set-up, or the call's answer.
    fn settle(
        &self,
        case: &WrongCall<'_>,
        outcome: Result<Result<Status, HostError>, (Setup, HostError)>,
    ) -> Option<Finding> {
        let loc = format!("probe {}", case.name);
        let answer = match (outcome, self.setup) {
            (Ok(answer), _) => answer,
            (Err((_, e)), SetupFailure::Answer) => Err(e),
            (Err((stage, e)), SetupFailure::NormalRun(instantiate)) => {
                let m = match stage {
                    Setup::Instantiate => format!("{instantiate}{e}"),
                    Setup::Initialize => format!("initialization failed: {e}"),
                    Setup::Bind => e.to_string(),
                };
                return Some((self.finding)("probe-normal-run", loc, m));
            }
        };
        let (check, m) = match judge(self.dialect, case.what, answer)? {
            Answer::Accepted(m) => (case.accepted, m),
            Answer::Unlogged(m) => ("probe-log", m),
            Answer::Unusual(m) => ("probe-wrong-call", m),
            Answer::Failed(m) => ("probe-normal-run", m),
        };
        Some((self.finding)(check, loc, m))
    }
}

/// The FMU's answer to a wrong call, judged; the message names the call.
enum Answer {
    /// A success status: the FMU accepted the call.
    Accepted(String),
    /// The error status without a logged message where the version wants one.
    Unlogged(String),
    /// A failure status other than the error status.
    Unusual(String),
    /// Something other than the call's status failed.
    Failed(String),
}

/// The answer `answer` to the call `what`; None for the error status as the version wants it.
fn judge(d: &Dialect, what: &str, answer: Result<Status, HostError>) -> Option<Answer> {
    match answer {
        Ok(st) => Some(Answer::Accepted(format!(
            "{what} returned {}; {}",
            (d.status_name)(st),
            d.advice
        ))),
        Err(HostError::Fmi {
            status: Status::Error,
            messages,
            ..
        }) => (d.error_needs_log && messages.is_empty()).then(|| {
            Answer::Unlogged(format!("{what} returned {} but logged no message", d.error))
        }),
        Err(HostError::Fmi { status, .. }) => Some(Answer::Unusual(format!(
            "{what} returned {}; {} is the usual answer",
            (d.status_name)(status),
            d.error
        ))),
        Err(e) => Some(Answer::Failed(format!("{what}: {e}"))),
    }
}

/// A fresh instance of `fmu`, initialized at `init_at` when given.
fn set_up<F: ProbedFmu>(
    fmu: &F,
    init_at: Option<f64>,
) -> Result<F::Instance<'_>, (Setup, HostError)> {
    let mut inst = fmu.instantiate().map_err(|e| (Setup::Instantiate, e))?;
    if let Some(t0) = init_at {
        inst.initialize(t0).map_err(|e| (Setup::Initialize, e))?;
    }
    Ok(inst)
}

/// The communication step of the Co-Simulation probes: the default experiment's step size when
/// it is a positive number (1 ms otherwise), at most 10 ms so that 10 steps stay near the start.
pub(crate) fn probe_step(step_size: Option<f64>) -> f64 {
    step_size
        .filter(|h| *h > 0.0 && h.is_finite())
        .unwrap_or(1e-3)
        .min(1e-2)
}

/// The answer of `fmi2Reset` / `fmi3Reset` (`version`: `fmi2`, `fmi3`) after terminate in a
/// normal run: the error status, which any call may return, as the message that ends the run
/// (`Ok(Some)`); another failure as itself.
pub(crate) fn reset_answer<T>(
    version: &str,
    answer: Result<T, HostError>,
) -> Result<Option<String>, HostError> {
    match answer {
        Err(
            e @ HostError::Fmi {
                status: Status::Error,
                ..
            },
        ) => Ok(Some(format!(
            "{version}Reset after {version}Terminate: {e}; re-initialization and the other \
             cases not probed"
        ))),
        other => other.map(|_| None),
    }
}

/// A value reference no variable has: 1000 above the largest (0 without variables).
pub(crate) fn unknown_value_reference(vrs: impl Iterator<Item = u32>) -> u32 {
    vrs.max().unwrap_or(0).saturating_add(1000)
}

/// Whether a probe case's call is part of a legal calling sequence or one the importer must not
/// make: a call in a state the state machine does not allow (FMI 2.0.4 sections 3.2.3 and
/// 4.2.4, FMI 3.0.2 section 2.3: "If such functionality is used anyway, undefined behavior
/// results") or with an argument the caller must not pass (a step size that is not > 0.0, a
/// communication point other than the current time, a value reference or type the FMU does not
/// have, a fixed parameter after initialization), and NaN, which the standard does not mention.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaseKind {
    /// A legal calling sequence: a crash in it is a finding.
    Legal,
    /// A call the importer must not make: a crash in it is a note.
    WrongCall,
}

/// One probe case of [`PROBE_CASES`]: its name and what kind of call it makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeCase {
    /// The name the probe announces before running it (`negative-step`).
    pub name: &'static str,
    /// Legal sequence or forbidden call.
    pub kind: CaseKind,
}

/// A case of a legal calling sequence.
const fn legal(name: &'static str) -> ProbeCase {
    ProbeCase {
        name,
        kind: CaseKind::Legal,
    }
}

/// A case whose call the importer must not make.
const fn wrong_call(name: &'static str) -> ProbeCase {
    ProbeCase {
        name,
        kind: CaseKind::WrongCall,
    }
}

/// Every probe case, in the order the probes run them: FMI 2.0 Co-Simulation ([`super::probe`]),
/// FMI 2.0 Model Exchange ([`super::probe_me`]), FMI 3.0 Co-Simulation and Model Exchange
/// ([`super::probe3`], [`super::probe3_me`]). The kind of each decides whether a crash in it is
/// a finding or a note ([`wrong_call_crash`]).
pub const PROBE_CASES: &[ProbeCase] = &[
    legal("normal-run"),
    legal("fmu-state"),
    wrong_call("do-step-before-init"),
    wrong_call("negative-step"),
    wrong_call("wrong-communication-point"),
    wrong_call("unknown-value-reference"),
    wrong_call("nan-input"),
    wrong_call("nan-parameter"),
    wrong_call("fixed-parameter-after-init"),
    wrong_call("wrong-type"),
    wrong_call("do-step-after-terminate"),
    legal("me-normal-run"),
    legal("me-directional-derivatives"),
    legal("me-state-event"),
    legal("me-fmu-state"),
    wrong_call("me-derivatives-before-init"),
    wrong_call("me-set-states-in-event-mode"),
    legal("fmi3-normal-run"),
    legal("fmi3-fmu-state"),
    wrong_call("fmi3-do-step-before-init"),
    wrong_call("fmi3-negative-step"),
    wrong_call("fmi3-do-step-after-terminate"),
    wrong_call("fmi3-wrong-communication-point"),
    wrong_call("fmi3-unknown-value-reference"),
    wrong_call("fmi3-fixed-parameter-after-init"),
    legal("fmi3-me-normal-run"),
    legal("fmi3-me-directional-derivatives"),
    legal("fmi3-me-state-event"),
    legal("fmi3-me-fmu-state"),
    wrong_call("fmi3-me-derivatives-before-init"),
    wrong_call("fmi3-me-set-states-in-event-mode"),
];

/// The probe case called `name`, of any version and interface.
pub fn probe_case(name: &str) -> Option<ProbeCase> {
    PROBE_CASES.iter().find(|c| c.name == name).copied()
}

/// The note for a crash or hang (`what`: "the FMU crashed (SIGSEGV 11)") in the probe case
/// `step` when its call is one the importer must not make (the outcome is undefined, so it is
/// advice, not a finding); None for a step of a legal sequence, where a crash stays a finding.
pub fn wrong_call_crash(step: &str, what: &str) -> Option<Finding> {
    if probe_case(step)?.kind != CaseKind::WrongCall {
        return None;
    }
    let nan = step.starts_with("nan-");
    let check = if nan { "probe-nan" } else { "probe-wrong-call" };
    let error = if step.starts_with("fmi3-") {
        "fmi3Error"
    } else {
        "fmi2Error"
    };
    let m = format!(
        "{what} on a call the importer must not make, whose outcome the standard leaves \
         undefined; returning {error} would warn the importer"
    );
    let mut f = Finding::new(check, format!("probe {step}"), m);
    f.clause = if step.starts_with("fmi3-") {
        super::probe3::clause3(check)
    } else if step.starts_with("me-") {
        "FMI 2.0.4 §3.2.3: the importer must not make this call, so the answer is the FMU's"
    } else {
        super::classify(check).1
    }
    .to_string();
    Some(f)
}
