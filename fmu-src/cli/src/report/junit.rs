//! JUnit XML, as CI servers read test reports (the Jenkins `junit-10.xsd` structure, which
//! GitLab, GitHub test-report actions and Azure Pipelines read too): one `<testsuite>` per FMU,
//! one `<testcase>` per rule checked, a `<failure>` per finding, the notes in the test case's
//! `<system-out>` (the rule passed; the standard permits what the note describes), and
//! `<skipped>` for a rule whose step did not run.

use super::rules::{checked, Checked};
use super::Report;
use std::fmt::Write as _;
use validate::Finding;

/// The reports as one `<testsuites>` document.
pub fn render(reports: &[Report]) -> String {
    let suites: Vec<(String, Counts)> = reports.iter().map(suite).collect();
    let total = suites.iter().fold(Counts::default(), |a, (_, c)| a.add(c));
    let mut s = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        s,
        "<testsuites name=\"actuator-fmu validate\" tests=\"{}\" failures=\"{}\" errors=\"0\">",
        total.tests, total.failures
    );
    for (xml, _) in suites {
        s += &xml;
    }
    s += "</testsuites>\n";
    s
}

#[derive(Default)]
struct Counts {
    tests: usize,
    failures: usize,
    skipped: usize,
}

impl Counts {
    fn add(self, o: &Counts) -> Counts {
        Counts {
            tests: self.tests + o.tests,
            failures: self.failures + o.failures,
            skipped: self.skipped + o.skipped,
        }
    }
}

/// One FMU's `<testsuite>` and its counts (a test case with a finding counts as one failure).
fn suite(r: &Report) -> (String, Counts) {
    let rules = checked(r);
    let counts = Counts {
        tests: rules.len(),
        failures: rules
            .iter()
            .filter(|c| c.results.iter().any(|f| f.is_required()))
            .count(),
        skipped: rules.iter().filter(|c| c.skipped.is_some()).count(),
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" errors=\"0\" skipped=\"{}\">",
        esc(&r.fmu),
        counts.tests,
        counts.failures,
        counts.skipped
    );
    for c in &rules {
        s += &case(&r.fmu, c);
    }
    s += "  </testsuite>\n";
    (s, counts)
}

fn case(fmu: &str, c: &Checked) -> String {
    let mut s = format!(
        "    <testcase name=\"{}: {}\" classname=\"{}\"",
        esc(&c.id),
        esc(&c.title),
        esc(fmu)
    );
    let (findings, notes): (Vec<&Finding>, Vec<&Finding>) =
        c.results.iter().copied().partition(|f| f.is_required());
    if findings.is_empty() && notes.is_empty() && c.skipped.is_none() {
        return s + "/>\n";
    }
    s += ">\n";
    if let Some(why) = c.skipped {
        let _ = writeln!(s, "      <skipped message=\"{}\"/>", esc(why));
    }
    for f in findings {
        // message: rule, clause and what is wrong; the text adds where.
        let message = format!("[{}] {} ({})", f.check, f.message, f.clause);
        let _ = writeln!(
            s,
            "      <failure type=\"{}\" message=\"{}\">{}: {}</failure>",
            esc(&f.check),
            esc(&message),
            esc(&f.location),
            esc(&f.message)
        );
    }
    if !notes.is_empty() {
        let text: Vec<String> = notes.iter().map(|n| n.to_string()).collect();
        let _ = writeln!(
            s,
            "      <system-out>{}</system-out>",
            esc(&text.join("\n"))
        );
    }
    s + "    </testcase>\n"
}

/// `text` as XML 1.0 character data or attribute value: the five markup characters as
/// entities, line breaks and tabs as character references (kept in attributes), and the
/// characters XML 1.0 does not allow (other C0 controls, U+FFFE, U+FFFF) as U+FFFD.
pub fn esc(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s += "&amp;",
            '<' => s += "&lt;",
            '>' => s += "&gt;",
            '"' => s += "&quot;",
            '\'' => s += "&apos;",
            '\n' => s += "&#10;",
            '\r' => s += "&#13;",
            '\t' => s += "&#9;",
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => s.push('\u{FFFD}'),
            c => s.push(c),
        }
    }
    s
}
