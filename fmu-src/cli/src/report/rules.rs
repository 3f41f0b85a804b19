//! The rules `validate` checks, by the `check` id its findings carry, for the formats that list
//! each rule checked (JUnit test cases, SARIF `tool.driver.rules`). A check id met in a finding
//! but missing here is listed all the same, titled by its clause.

use super::{Fmi, Report};
use validate::Finding;

/// A group of rules that runs as one step of `validate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// Opening the zip archive and parsing `modelDescription.xml`.
    Archive,
    /// The rules of `modelDescription.xml`.
    Description,
    /// The candidate-effect convention (`--effects`).
    Effects,
    /// The platform binaries: layout, format, exported functions.
    Binaries,
    /// The state-machine probe, which runs this platform's binary.
    Probe,
}

impl Stage {
    /// Why a rule of this stage was not checked.
    fn not_run(self) -> &'static str {
        match self {
            Stage::Archive => "the FMU could not be opened",
            Stage::Description | Stage::Binaries | Stage::Effects => {
                "not checked: modelDescription.xml could not be read"
            }
            Stage::Probe => {
                "not run: no binary for this platform, an unreadable description, or a kind of \
                 FMU the probes do not run (clocks, Scheduled Execution only)"
            }
        }
    }
}

/// A rule of the catalogue.
struct Rule {
    id: &'static str,
    stage: Stage,
    /// None: both FMI versions.
    only: Option<Fmi>,
    title: &'static str,
}

const fn rule(id: &'static str, stage: Stage, only: Option<Fmi>, title: &'static str) -> Rule {
    Rule {
        id,
        stage,
        only,
        title,
    }
}

use Stage::{Archive as A, Binaries as B, Description as D, Effects as E, Probe as P};
const V2: Option<Fmi> = Some(Fmi::V2);
const V3: Option<Fmi> = Some(Fmi::V3);

#[rustfmt::skip]
const RULES: &[Rule] = &[
    rule("archive", A, None, "the FMU is a zip archive with the FMI layout"),
    rule("zip-path", A, None, "archive paths use forward slashes (ZIP APPNOTE 4.4.17)"),
    rule("model-description-xml", A, None, "modelDescription.xml is present and well-formed"),
    rule("schema", D, None, "modelDescription.xml follows the XML schema of its FMI version"),
    rule("fmi-version", D, None, "fmiVersion names the standard's version"),
    rule("model-name", D, None, "modelName is given"),
    rule("guid", D, V2, "guid is given"),
    rule("instantiation-token", D, V3, "instantiationToken is given"),
    rule("co-simulation", D, V2, "a <ModelExchange> or <CoSimulation> element is present"),
    rule("interfaces", D, V3, "an interface element is present"),
    rule("model-identifier", D, None, "modelIdentifier is a C identifier"),
    rule("capability-flags", D, V2, "the capability flags are consistent"),
    rule("unit-declared", D, None, "every unit used is defined"),
    rule("unique-units", D, None, "unit names are unique"),
    rule("display-unit", D, None, "display units are unique per unit and well-formed"),
    rule("display-unit-declared", D, None, "a displayUnit names a display unit of its unit"),
    rule("declared-type", D, None, "a declaredType names a type of the variable's kind"),
    rule("unique-types", D, None, "type names are unique"),
    rule("log-categories", D, V2, "log categories are unique"),
    rule("default-experiment", D, V2, "the default experiment is well-formed"),
    rule("variable-name", D, None, "every variable has a name"),
    rule("unique-names", D, None, "variable names are unique"),
    rule("unique-value-references", D, None, "value references are unique per type"),
    rule("naming-convention", D, None, "names follow the declared variableNamingConvention"),
    rule("causality-variability", D, None, "causality and variability form an allowed combination"),
    rule("variability-type", D, None, "only Real (Float) variables are continuous"),
    rule("initial", D, None, "initial is allowed for the causality and variability"),
    rule("start", D, None, "start is given where required and only where allowed"),
    rule("start-range", D, V2, "start is finite and within [min, max]"),
    rule("min-max", D, V2, "min <= max"),
    rule("independent", D, None, "at most one independent variable (FMI 3.0: exactly one)"),
    rule("dimension", D, V3, "a <Dimension> refers to a structural parameter or constant"),
    rule("derivative", D, None, "derivative refers to a continuous state"),
    rule("clocks", D, V3, "clocks and clocked variables are well-formed"),
    rule("model-structure", D, None, "<ModelStructure> refers to existing variables of the right kind"),
    rule("outputs-listed", D, None, "every output is listed in <ModelStructure>"),
    rule("initial-unknowns", D, V2, "<InitialUnknowns> lists exactly the required unknowns"),
    rule("effect-convention", E, None, "the candidate-effect convention of the gap workflow"),
    rule("binary", B, None, "the binaries are in the platform folders the standard names"),
    rule("binary-not-probed", B, None, "a binary for this platform (a note when another implementation is shipped)"),
    rule("platform-folder", B, V3, "platform folders are named by the standard's tuples"),
    rule("binary-format", B, None, "each binary has the format of its platform"),
    rule("symbols", B, None, "each binary exports every function of the standard"),
    rule("probe-normal-run", P, None, "a legal calling sequence succeeds"),
    rule("probe-crash", P, None, "no call crashes"),
    rule("probe-timeout", P, None, "every call returns"),
    rule("probe-fmu-state", P, None, "a saved FMU state restores the instance"),
    rule("probe-directional-derivative", P, None, "directional derivatives agree with finite differences"),
    rule("probe-event", P, None, "the event flags tell re-initialized states"),
    rule("probe-wrong-call", P, None, "calls the importer must not make are refused"),
    rule("probe-reset", P, None, "the reset function returns the instance to its instantiated state"),
    rule("probe-nan", P, V2, "NaN inputs and parameters are refused"),
    rule("probe-log", P, V2, "a refused call logs a message"),
];

/// One rule as checked on one FMU: its results, or why it was not checked.
pub struct Checked<'r> {
    /// The check id (`causality-variability`).
    pub id: String,
    /// What the rule demands, in a few words.
    pub title: String,
    /// The clause of the standard it rests on.
    pub clause: String,
    /// Its findings and notes on this FMU.
    pub results: Vec<&'r Finding>,
    /// Set when the rule was not checked, with the reason.
    pub skipped: Option<&'static str>,
}

/// Every rule of the catalogue that applies to `r`'s FMI version and stages (the effect
/// convention only when `--effects` ran it), then every other check id `r`'s results carry.
pub fn checked(r: &Report) -> Vec<Checked<'_>> {
    let applies = |rule: &Rule| match (rule.only, r.fmi_version) {
        (_, None) => rule.stage == Stage::Archive,
        (Some(only), Some(v)) => only == v,
        (None, Some(_)) => true,
    };
    let fmi1 = r.results().any(|f| f.check == "fmi-version-not-checked");
    let not_run = |stage: Stage| match fmi1 {
        true => "not checked: an FMI 1.0 FMU",
        false => stage.not_run(),
    };
    let mut out: Vec<Checked> = RULES
        .iter()
        .filter(|rule| applies(rule))
        .filter(|rule| rule.stage != Stage::Effects || r.checked.contains(&Stage::Effects))
        .map(|rule| {
            let ran = r.checked.contains(&rule.stage);
            let mut c = of_results(r, rule.id, rule.title.to_string());
            c.skipped = (!ran && c.results.is_empty()).then(|| not_run(rule.stage));
            c
        })
        .collect();
    for f in r.results() {
        if !out.iter().any(|c| c.id == f.check) {
            out.push(of_results(r, &f.check, f.clause.clone()));
        }
    }
    out
}

fn of_results<'r>(r: &'r Report, id: &str, title: String) -> Checked<'r> {
    let results: Vec<&Finding> = r.results().filter(|f| f.check == id).collect();
    let clause = match results.first() {
        Some(f) => f.clause.clone(),
        None => clause_of(id, r.fmi_version).to_string(),
    };
    Checked {
        id: id.to_string(),
        title,
        clause,
        results,
        skipped: None,
    }
}

/// The clause a check rests on in the FMU's FMI version, as the validator cites it.
pub fn clause_of(id: &str, fmi: Option<Fmi>) -> &'static str {
    match fmi {
        Some(Fmi::V3) if id.starts_with("probe-") && id != "probe-not-run" => {
            validate::probe3::clause3(id)
        }
        Some(Fmi::V3) => validate::fmi3::classify3(id),
        _ => validate::classify(id).1,
    }
}
