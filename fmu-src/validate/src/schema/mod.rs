//! `modelDescription.xml` against the XML schema of its FMI version, and the variable names
//! against the naming convention it declares.
//!
//! FMI 2.0.4 section 2.2: the schema files are "the normative definition"; FMI 3.0.2 section
//! 2.4: the file is "in XML format as specified by the XML schema file
//! `fmi3ModelDescription.xsd`". The schemas are written here as tables (`fmi2.rs`, `fmi3.rs`,
//! in the vocabulary of `model.rs`) and checked by one walk (`walk.rs`): attributes an element
//! does not have, values not of their type or enumeration, required attributes missing,
//! children out of the schema's order or beyond their number (`content.rs`), text where only
//! elements may be. Where a schema allows anything (`xs:any` in an FMI 2.0 `<Tool>`, an FMI 3.0
//! `<Annotation>`; `xs:anyAttribute` on the FMI 3.0 interface elements) nothing is checked
//! except an element the schema declares globally.

mod common;
mod content;
mod fmi2;
mod fmi3;
mod model;
mod types;
mod walk;

#[cfg(test)]
mod tests;

use super::naming::name_problem;
use super::Finding;
use model::Schema;
use quick_xml::events::Event;
use quick_xml::Reader;
use walk::{walk, Problem};

/// The most schema findings one description gets; one more says how many were left out (a
/// description broken throughout would otherwise give one per variable).
const MAX_FINDINGS: usize = 100;

/// The findings of `xml` (the text of a `modelDescription.xml`) against the schema of its FMI
/// version (the root's `fmiVersion`, 2.x or 3.x; other versions are not checked here) and
/// against its `variableNamingConvention`. Malformed XML ends the check where it starts (the
/// description parser reports it).
pub fn check_description_xml(xml: &str) -> Vec<Finding> {
    let Some(schema) = schema_of(xml) else {
        return Vec::new();
    };
    let walked = walk(schema, xml);
    let mut findings: Vec<Finding> = walked
        .problems
        .iter()
        .take(MAX_FINDINGS)
        .map(|p| schema_finding(schema, p))
        .collect();
    if walked.problems.len() > MAX_FINDINGS {
        let rest = walked.problems.len() - MAX_FINDINGS;
        let last = &walked.problems[MAX_FINDINGS];
        let mut f = schema_finding(schema, last);
        f.message = format!("{rest} further departures from the schema are not listed");
        findings.push(f);
    }
    let convention = walked.convention.as_deref().unwrap_or("flat");
    for (name, line) in &walked.names {
        if let Some(m) = name_problem(convention, name) {
            let mut f = Finding::new(
                "naming-convention",
                format!(
                    "modelDescription.xml:{line} (variable '{}')",
                    types::shown(name)
                ),
                m,
            );
            f.clause = naming_clause(schema).to_string();
            findings.push(f);
        }
    }
    findings
}

/// The schema of the FMI version the root element declares.
fn schema_of(xml: &str) -> Option<&'static Schema> {
    let mut reader = Reader::from_str(xml);
    loop {
        match reader.read_event().ok()? {
            Event::Start(e) | Event::Empty(e) => {
                let version = e
                    .try_get_attribute("fmiVersion")
                    .ok()
                    .flatten()
                    .and_then(|a| a.unescape_value().ok().map(|v| v.into_owned()))?;
                return match version.trim().split('.').next() {
                    Some("2") => Some(&fmi2::SCHEMA),
                    Some("3") => Some(&fmi3::SCHEMA),
                    _ => None,
                };
            }
            Event::Eof => return None,
            _ => {}
        }
    }
}

fn schema_finding(schema: &Schema, p: &Problem) -> Finding {
    let mut f = Finding::new(
        "schema",
        format!("modelDescription.xml:{} ({})", p.line, p.element),
        p.message.clone(),
    );
    f.clause = format!("{}: schema file {}", schema.cite, p.xsd);
    f
}

fn naming_clause(schema: &Schema) -> &'static str {
    if std::ptr::eq(schema, &fmi3::SCHEMA) {
        "FMI 3.0.2 §2.4.7: variable naming conventions"
    } else {
        "FMI 2.0.4 §2.2.9: variable naming conventions"
    }
}
