//! SARIF 2.1.0 (OASIS Static Analysis Results Interchange Format): one run of the tool over
//! every FMU; `tool.driver.rules` lists each rule checked, with the clause of the standard it
//! rests on; a finding is a result of level `error`, a note one of level `note`. A result's
//! location is the FMU file as given; the place inside the FMU is a logical location
//! (`modelDescription.xml:12 (variable 'x')`, `probe fmi3-normal-run`) and, when a line of
//! `modelDescription.xml` is known, a related location in that file nested in the FMU
//! (`run.artifacts`, `parentIndex`) with its line as region.

use super::rules::checked;
use super::{description_line, Report};
use serde::Serialize;
use validate::Finding;

const SCHEMA: &str =
    "https://docs.oasis-open.org/sarif/sarif/v2.1.0/errata01/os/schemas/sarif-schema-2.1.0.json";

/// The reports as one SARIF log (pretty JSON, newline at the end).
pub fn render(reports: &[Report]) -> String {
    let mut run = Run::default();
    for r in reports {
        add_report(&mut run, r);
    }
    let log = serde_json::json!({"$schema": SCHEMA, "version": "2.1.0", "runs": [run]});
    // Serializing plain structs of strings and numbers cannot fail.
    let mut s = serde_json::to_string_pretty(&log).unwrap_or_default();
    s.push('\n');
    s
}

#[derive(Serialize)]
struct Run {
    tool: Tool,
    artifacts: Vec<Artifact>,
    results: Vec<SarifResult>,
}

impl Default for Run {
    fn default() -> Self {
        let driver = Driver {
            name: "actuator-fmu validate",
            version: env!("CARGO_PKG_VERSION"),
            rules: Vec::new(),
        };
        Run {
            tool: Tool { driver },
            artifacts: Vec::new(),
            results: Vec::new(),
        }
    }
}

#[derive(Serialize)]
struct Tool {
    driver: Driver,
}

#[derive(Serialize)]
struct Driver {
    name: &'static str,
    version: &'static str,
    rules: Vec<RuleDescriptor>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct RuleDescriptor {
    id: String,
    short_description: Text,
    full_description: Text,
    #[serde(skip_serializing_if = "Option::is_none")]
    help_uri: Option<String>,
}

#[derive(Serialize)]
struct Text {
    text: String,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Artifact {
    location: ArtifactLocation,
    #[serde(skip_serializing_if = "Option::is_none")]
    parent_index: Option<usize>,
}

#[derive(Serialize, Clone)]
struct ArtifactLocation {
    uri: String,
    index: usize,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct SarifResult {
    rule_id: String,
    rule_index: usize,
    level: &'static str,
    message: Text,
    locations: Vec<Location>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    related_locations: Vec<Location>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Location {
    #[serde(skip_serializing_if = "Option::is_none")]
    id: Option<usize>,
    physical_location: PhysicalLocation,
    #[serde(skip_serializing_if = "Option::is_none")]
    message: Option<Text>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    logical_locations: Vec<LogicalLocation>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct PhysicalLocation {
    artifact_location: ArtifactLocation,
    #[serde(skip_serializing_if = "Option::is_none")]
    region: Option<Region>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Region {
    start_line: u64,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct LogicalLocation {
    name: String,
    fully_qualified_name: String,
}

/// Adds `r`'s FMU as an artifact, each rule checked on it to the driver's rules (once per id;
/// the clauses of both FMI versions when the run has both) and each finding and note as a
/// result.
fn add_report(run: &mut Run, r: &Report) {
    let fmu = artifact(run, &r.fmu, None);
    for c in checked(r) {
        let rules = &mut run.tool.driver.rules;
        match rules.iter_mut().find(|d| d.id == c.id) {
            Some(d) if !d.full_description.text.contains(&c.clause) => {
                d.full_description.text += &format!("; {}", c.clause);
            }
            Some(_) => {}
            None => rules.push(RuleDescriptor {
                id: c.id.clone(),
                short_description: Text { text: c.title },
                full_description: Text {
                    text: c.clause.clone(),
                },
                help_uri: super::clauses::help_uri(&c.clause),
            }),
        }
    }
    for f in r.results() {
        let result = result(run, &fmu, f);
        run.results.push(result);
    }
}

/// The location of artifact `uri` (nested in artifact `parent`), added to the run's
/// artifacts the first time.
fn artifact(run: &mut Run, uri: &str, parent: Option<usize>) -> ArtifactLocation {
    let found = run
        .artifacts
        .iter()
        .position(|a| a.location.uri == uri && a.parent_index == parent);
    let index = found.unwrap_or_else(|| {
        let location = ArtifactLocation {
            uri: uri.to_string(),
            index: run.artifacts.len(),
        };
        run.artifacts.push(Artifact {
            location,
            parent_index: parent,
        });
        run.artifacts.len() - 1
    });
    run.artifacts[index].location.clone()
}

fn result(run: &mut Run, fmu: &ArtifactLocation, f: &Finding) -> SarifResult {
    let rule_index = run
        .tool
        .driver
        .rules
        .iter()
        .position(|d| d.id == f.check)
        .unwrap_or_default();
    let level = if f.is_required() { "error" } else { "note" };
    let inner = f.location.split(" (").next().unwrap_or(&f.location);
    let logical = LogicalLocation {
        name: inner.to_string(),
        fully_qualified_name: format!("{}/{}", fmu.uri, f.location),
    };
    let related = description_line(&f.location).map(|line| Location {
        id: Some(0),
        physical_location: PhysicalLocation {
            artifact_location: artifact(run, "modelDescription.xml", Some(fmu.index)),
            region: Some(Region { start_line: line }),
        },
        message: Some(Text {
            text: format!("line {line} of modelDescription.xml in {}", fmu.uri),
        }),
        logical_locations: Vec::new(),
    });
    SarifResult {
        rule_id: f.check.clone(),
        rule_index,
        level,
        message: Text {
            text: format!("{}: {} ({})", f.location, f.message, f.clause),
        },
        locations: vec![Location {
            id: None,
            physical_location: PhysicalLocation {
                artifact_location: fmu.clone(),
                region: None,
            },
            message: None,
            logical_locations: vec![logical],
        }],
        related_locations: related.into_iter().collect(),
    }
}
