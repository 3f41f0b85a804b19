//! Conformance checks of an FMU, each returning `Vec<Finding>`, one module per concern:
//!
//! - [`description`]: `modelDescription.xml` of an FMI 2.0 Co-Simulation FMU: schema-level
//!   attributes, unique names and value references, causality/variability/initial combinations
//!   (FMI 2.0.4 section 2.2.7, the table of allowed combinations and the table of allowed
//!   `initial` values), start required/forbidden, min <= start <= max, units and display units
//!   declared, ModelStructure complete.
//! - [`fmi3`]: an FMI 3.0 FMU's `modelDescription.xml` (FMI 3.0.2 section 2.4) and its binaries
//!   per platform tuple with the functions of its declared interfaces (section 2.5).
//! - [`schema`]: `modelDescription.xml` against the XML schema of its FMI version (attributes,
//!   their types, required ones, children in order and number), and [`naming`]: variable names
//!   against the declared naming convention.
//! - [`binary`]: the binary for this platform is present, every platform binary has the
//!   platform's format and exports every FMI function.
//! - [`probe`](mod@probe): calls in wrong states / with bad arguments must return fmi2Error
//!   (with a logged message) and not crash; a normal run must succeed. Run it in a child process
//!   (the CLI does) so that a crashing FMU becomes a finding.
//! - [`probe3`](mod@probe3): the same for FMI 3.0 Co-Simulation and Model Exchange.
//! - [`reference`]: `--reference`, the FMU's experiments (FMI-LS-REF) or a user's reference CSV
//!   run and compared in a tolerance tube; no FMI rule, checked only when asked for.
//!
//! The probes are written once where the versions agree: the Model Exchange probe
//! (`probe_me.rs`) and its checks (`me_checks.rs`: directional derivatives against finite
//! differences, the event flags at a state event, Euler runs to compare, a restored FMU state)
//! over the instance calls of either version (`instance.rs`), the wrong-call cases and how an
//! answer is judged (`cases.rs`). A call that fails in a probe's legal sequence is a
//! [`ProbeError`].
#![warn(missing_docs)]

pub mod binary;
mod cases;
pub mod description;
mod error;
pub mod fmi3;
mod instance;
mod layout;
mod me_checks;
pub mod naming;
pub mod probe;
pub mod probe3;
mod probe_me;
pub mod reference;
mod rules;
pub mod schema;

pub use binary::{
    check_files, check_platform_binaries, check_symbols, load_refused, PlatformBinary,
};
pub use cases::{probe_case, wrong_call_crash, CaseKind, ProbeCase, PROBE_CASES};
pub use description::{
    check_effect_convention, check_model_description, combination_allowed, initial_allowed,
};
pub use error::{ProbeError, Stage};
pub use fmi3::{check_model_description3, check_platform_binaries3};
pub use probe::{probe, probe_me};
pub use probe3::{probe3, probe3_me};
pub use schema::check_description_xml;

use host::md::ScalarVariable;
use std::fmt;

/// Whether the standard requires what a check found, or only permits better.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// A requirement of the FMI 2.0 standard is violated: `validate` exits 1.
    Finding,
    /// The standard permits it (e.g. how an FMU answers a call the importer must not make);
    /// reported as advice, `validate` still exits 0.
    Note,
}

/// One problem found.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Finding {
    /// Short id of the check, e.g. `causality-variability`.
    pub check: String,
    /// Where: `modelDescription.xml:LINE (variable 'x')`, a file, or a probe step.
    pub location: String,
    /// What is wrong, in one sentence.
    pub message: String,
    /// Required by the standard, or only advice.
    pub severity: Severity,
    /// The clause of the FMI 2.0.4 specification the check rests on.
    pub clause: String,
}

impl Finding {
    /// A result of the check `check`; its severity and clause follow from the check
    /// (see [`classify`]).
    pub fn new(check: &str, location: impl Into<String>, message: impl Into<String>) -> Self {
        let (severity, clause) = classify(check);
        Finding {
            check: check.to_string(),
            location: location.into(),
            message: message.into(),
            severity,
            clause: clause.to_string(),
        }
    }

    /// Whether the standard requires it (exit 1) rather than only advising it.
    pub fn is_required(&self) -> bool {
        self.severity == Severity::Finding
    }
}

/// Severity and FMI 2.0.4 clause of each check (section numbers of the FMI 2.0.4 document).
///
/// Probe calls the importer must not make (section 4.2.4: the state machine restricts the
/// environment) leave the FMU's answer open, as does a NaN the standard does not mention: an
/// FMU answering them with fmi2OK is conforming, so those results are notes, and so is a crash
/// on such a call (see [`wrong_call_crash`]). A crash in a legal sequence is a finding: section
/// 2.1.3 has every function return a status, fmi2Fatal for "a run-time exception such as access
/// violation".
pub fn classify(check: &str) -> (Severity, &'static str) {
    use Severity::{Finding as F, Note as N};
    match check {
        "fmi-version" | "model-name" | "guid" | "variable-name" | "model-description-xml" => {
            (F, "FMI 2.0.4 §2.2.1: fmiModelDescription")
        }
        "unit-declared" | "display-unit-declared" | "display-unit" | "unique-units" => {
            (F, "FMI 2.0.4 §2.2.2: UnitDefinitions")
        }
        "declared-type" | "unique-types" => (F, "FMI 2.0.4 §2.2.3: TypeDefinitions"),
        "log-categories" => (F, "FMI 2.0.4 §2.2.4: LogCategories"),
        "default-experiment" => (F, "FMI 2.0.4 §2.2.5: DefaultExperiment"),
        "model-structure" | "outputs-listed" | "initial-unknowns" | "derivative" => {
            (F, "FMI 2.0.4 §2.2.8: ModelStructure")
        }
        "naming-convention" => (F, "FMI 2.0.4 §2.2.9: variable naming conventions"),
        "archive" | "open" | "binary" | "binary-format" => (
            F,
            "FMI 2.0.4 §2.3: FMU distribution: zip layout, binaries/<platform>",
        ),
        "zip-path" => (
            F,
            "FMI 2.0.4 §2.3 and FMI 3.0.2 §2.5: the ZIP format of APPNOTE.TXT, whose section \
             4.4.17 allows only '/' as path separator",
        ),
        "fmi-version-not-checked" => (
            N,
            "FMI 2.0.4 §2.2.1 and FMI 3.0.2 §2.4.1: fmiVersion; an FMI 1.0 FMU follows neither",
        ),
        "binary-not-probed" => (
            N,
            "FMI 2.0.4 §2.3: at least one implementation, sources or a binary for one platform; \
             this host has none it can load, so the binary is not probed here",
        ),
        "platform-folder" => (
            N,
            "FMI 3.0.2 §2.5.1.4: binaries/ is named by platform tuples; further names can be \
             introduced by vendors",
        ),
        "symbols" => (F, "FMI 2.0.4 §2.1 and §4.2: every fmi2 function exported"),
        "co-simulation" => (
            F,
            "FMI 2.0.4 §2.2.1: fmiModelDescription has a ModelExchange or CoSimulation element",
        ),
        "model-identifier" | "capability-flags" => (F, "FMI 2.0.4 §4.3.1: CoSimulation element"),
        "probe-fmu-state" => (F, "FMI 2.0.4 §2.1.8: canGetAndSetFMUstate declared"),
        "probe-normal-run" => (F, "FMI 2.0.4 §4.2.4: a legal calling sequence"),
        "probe-crash" | "probe-timeout" => (F, "FMI 2.0.4 §2.1.3: every call returns a status"),
        "probe-wrong-call" => (
            N,
            "FMI 2.0.4 §4.2.4: the importer must not make this call, so the answer is the FMU's",
        ),
        "probe-nan" => (
            N,
            "FMI 2.0.4 §2.1.7: the standard does not say how fmi2SetReal treats NaN",
        ),
        "probe-reset" => (
            N,
            "FMI 2.0.4 §2.1.3: any call may return fmi2Error (\"the FMU encountered an error\")",
        ),
        "probe-log" => (N, "FMI 2.0.4 §2.1.5: logging is the FMU's choice"),
        "probe-report-garbled" => (
            N,
            "no rule of the standard: the probe's own report was overwritten by the FMU's binary",
        ),
        "unique-value-references" => (
            F,
            "FMI 2.0.4 §2.2.7: alias variables (two settable variables, or a settable one and the \
             independent one, cannot share a valueReference; at most one non-constant alias has \
             a start)",
        ),
        "effect-convention" => (F, "actuator-fmu candidate-effect convention (README)"),
        // schema-level variable attributes: causality, variability, initial, start, min/max
        _ => (F, "FMI 2.0.4 §2.2.7: ScalarVariable"),
    }
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.severity {
            Severity::Finding => "",
            Severity::Note => "note ",
        };
        write!(
            f,
            "{kind}[{}] {}: {} ({})",
            self.check, self.location, self.message, self.clause
        )
    }
}

pub(crate) fn var_loc(v: &ScalarVariable) -> String {
    format!("modelDescription.xml:{} (variable '{}')", v.line, v.name)
}
