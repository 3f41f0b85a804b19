//! What `validate` prints: one [`Report`] per FMU, written in the format `--format` names.
//!
//! - `text`: one line per finding or note and a summary line per FMU (for people).
//! - `json`: the reports as a JSON array, a stable interface (`docs/validate-output.md`).
//! - `junit`: JUnit XML, one `<testsuite>` per FMU and one `<testcase>` per rule ([`junit`]).
//! - `sarif`: SARIF 2.1.0 for code-scanning tools ([`sarif`]).
//! - `github`: GitHub Actions workflow commands, one annotation per result ([`github`]).
//!
//! The exit status does not depend on the format: 0 without findings, 1 with any, 2 on bad input.

mod clauses;
mod github;
mod junit;
mod rules;
mod sarif;

pub use rules::Stage;

use validate::{Finding, PlatformBinary};

/// `--format`: how `validate` writes its reports on stdout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Lines for people: each finding and note, then a summary per FMU.
    Text,
    /// A JSON array of reports (documented, versioned by `format_version`).
    Json,
    /// JUnit XML: a test suite per FMU, a test case per rule.
    Junit,
    /// SARIF 2.1.0 (GitHub code scanning, other static-analysis viewers).
    Sarif,
    /// GitHub Actions workflow commands: `::error` per finding, `::notice` per note.
    Github,
}

/// Version of the JSON report's shape: raised when a field is removed or changes its meaning;
/// a new field leaves it as it is.
pub const FORMAT_VERSION: u32 = 1;

/// The FMI version of an FMU, as the report names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Fmi {
    /// FMI 2.0.
    #[serde(rename = "2.0")]
    V2,
    /// FMI 3.0.
    #[serde(rename = "3.0")]
    V3,
}

/// What `validate` found in one FMU.
#[derive(serde::Serialize)]
pub struct Report {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The FMU's path as given on the command line.
    pub fmu: String,
    /// FMI version of the description; None when it could not be read.
    pub fmi_version: Option<Fmi>,
    /// The groups of rules that ran.
    pub checked: Vec<Stage>,
    /// What the standard requires and the FMU violates (exit 1).
    pub findings: Vec<Finding>,
    /// What the standard permits but a robust FMU would do otherwise (exit 0).
    pub notes: Vec<Finding>,
    /// Every platform binary: format, architectures, exported functions, glibc needs.
    pub binaries: Vec<PlatformBinary>,
}

impl Report {
    /// Findings first, then notes.
    pub fn results(&self) -> impl Iterator<Item = &Finding> {
        self.findings.iter().chain(&self.notes)
    }
}

/// The reports in `format`, ready for stdout (ends with a newline).
pub fn render(reports: &[Report], format: Format) -> String {
    match format {
        Format::Text => text(reports),
        Format::Json => json(reports),
        Format::Junit => junit::render(reports),
        Format::Sarif => sarif::render(reports),
        Format::Github => github::render(reports),
    }
}

fn text(reports: &[Report]) -> String {
    let mut s = String::new();
    for r in reports {
        for f in r.results() {
            s += &format!("{}: {f}\n", r.fmu);
        }
        s += &summary(r);
        s.push('\n');
    }
    s
}

/// `<fmu>: OK (no findings[, N note(s)])` or `<fmu>: N finding(s)[, N note(s)]`.
pub fn summary(r: &Report) -> String {
    let notes = match r.notes.len() {
        0 => String::new(),
        n => format!(", {n} note(s)"),
    };
    match r.findings.len() {
        0 => format!("{}: OK (no findings{notes})", r.fmu),
        n => format!("{}: {n} finding(s){notes}", r.fmu),
    }
}

fn json(reports: &[Report]) -> String {
    // Serializing plain structs of strings and numbers cannot fail.
    let mut s = serde_json::to_string_pretty(reports).unwrap_or_default();
    s.push('\n');
    s
}

/// The line of `modelDescription.xml` a finding's location names
/// (`modelDescription.xml:LINE (variable 'x')`), if it names one.
pub fn description_line(location: &str) -> Option<u64> {
    let rest = location.strip_prefix("modelDescription.xml:")?;
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok().filter(|&n| n > 0)
}

#[cfg(test)]
mod tests;
