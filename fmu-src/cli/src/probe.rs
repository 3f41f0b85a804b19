//! Hidden `__probe FMU`: the part of `validate` that loads the binary, run in a child process
//! so that a crash of the FMU cannot take the validator down. Prints each probe step on stderr
//! (`@@STEP@@ name`) before running it and the findings as one JSON line on stdout
//! (`@@FINDINGS@@ [...]`).

use crate::common::CliResult;
use host::{Extracted, Fmu, Interface, OpenOptions};
use std::io::Write;
use std::path::PathBuf;
use validate::{check_symbols, probe, probe_me, Finding};

/// Marker of the progress lines on stderr.
pub const STEP_MARK: &str = "@@STEP@@ ";
/// Marker of the findings line on stdout.
pub const FINDINGS_MARK: &str = "@@FINDINGS@@ ";

/// Arguments of `__probe`.
#[derive(clap::Args)]
pub struct Args {
    /// The FMU.
    pub fmu: PathBuf,
    /// Probe cases not to run (they crashed in an earlier attempt).
    #[arg(long)]
    pub skip: Vec<String>,
}

fn announce(name: &str) {
    let mut e = std::io::stderr().lock();
    let _ = writeln!(e, "{STEP_MARK}{name}");
    let _ = e.flush();
}

/// Runs the probe and prints the findings.
pub fn run(a: Args) -> CliResult {
    let mut findings: Vec<Finding> = Vec::new();
    announce("load");
    if matches!(host::fmi_version_of(&a.fmu), Ok(host::FmiVersion::Fmi3)) {
        findings.extend(probe_fmi3(&a));
    } else {
        findings.extend(probe_fmi2(&a));
    }
    announce("done");
    let json = serde_json::to_string(&findings).unwrap_or_else(|_| "[]".into());
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "\n{FINDINGS_MARK}{json}");
    let _ = out.flush();
    Ok(0)
}

/// The FMI 3.0 probes: Co-Simulation when the FMU declares it, Model Exchange when it declares
/// it, each on the FMU opened with that interface.
fn probe_fmi3(a: &Args) -> Vec<Finding> {
    let unpacked = host::Unpacked::open(&a.fmu).ok();
    // FMI 3.0.2 section 2.5: a dependency on external resources must be documented there
    let documented = unpacked.as_ref().is_some_and(|u| {
        ["txt", "html"].iter().any(|ext| {
            u.dir
                .join(format!("documentation/externalDependencies.{ext}"))
                .is_file()
        })
    });
    let (cs, me) = match unpacked
        .as_ref()
        .and_then(|u| host::fmi3::ModelDescription3::parse(&u.xml, "").ok())
    {
        Some(md) => (md.co_simulation.is_some(), md.model_exchange.is_some()),
        None => (false, false),
    };
    drop(unpacked);
    probe_declared(
        a,
        (cs, me),
        |interface, step| match host::fmi3::Fmu3::open_with(&a.fmu, Some(interface)) {
            Err(e) => {
                let m = format!("{interface}: {e}");
                let loc = a.fmu.display().to_string();
                vec![validate::load_refused(&loc, &m, Some(documented))]
            }
            Ok(fmu) => match interface {
                Interface::CoSimulation => validate::probe3(&fmu, step),
                Interface::ModelExchange => validate::probe3_me(&fmu, step),
            },
        },
    )
}

/// The binary's exports and the FMI 2.0 probes.
fn probe_fmi2(a: &Args) -> Vec<Finding> {
    let mut findings: Vec<Finding> = Vec::new();
    match Extracted::open(&a.fmu) {
        Err(e) => findings.push(Finding::new(
            "open",
            a.fmu.display().to_string(),
            e.to_string(),
        )),
        Ok(ex) => {
            let cs = ex.model_description.co_simulation.is_some();
            let me = ex.model_description.model_exchange.is_some();
            let symbols = check_symbols(&ex);
            // A binary that does not load is reported once (a finding, or a note when this host
            // lacks a library it links); there is nothing to probe.
            let loadable = !symbols
                .iter()
                .any(|f| matches!(f.check.as_str(), "binary" | "binary-not-probed"));
            findings.extend(symbols);
            drop(ex);
            if loadable {
                findings.extend(probe_interfaces(a, cs, me));
            }
        }
    }
    findings
}

/// The Co-Simulation probe when the FMU declares Co-Simulation, the Model Exchange probe when it
/// declares Model Exchange, each on the FMU opened with that interface.
fn probe_interfaces(a: &Args, cs: bool, me: bool) -> Vec<Finding> {
    probe_declared(a, (cs, me), |interface, step| {
        let opts = OpenOptions {
            interface: Some(interface),
            ..OpenOptions::default()
        };
        match Fmu::open_with(&a.fmu, &opts) {
            // check_symbols loads only the Co-Simulation library: a Model Exchange library
            // this host cannot load for a dependency it lacks is a note here too
            Err(e) => vec![validate::load_refused(
                &a.fmu.display().to_string(),
                &match interface {
                    Interface::CoSimulation => e.to_string(),
                    Interface::ModelExchange => format!("{interface}: {e}"),
                },
                None,
            )],
            Ok(fmu) => match interface {
                Interface::CoSimulation => probe(&fmu, step),
                Interface::ModelExchange => probe_me(&fmu, step),
            },
        }
    })
}

/// `probe_one` for each interface the FMU declares, Co-Simulation first (the order of the case
/// lists), with a `step` that announces each case before it runs (so that a crash can be
/// attributed) and skips the cases of `--skip` (they crashed in an earlier attempt). The FMI
/// 2.0 and 3.0 probes differ only in how they open the FMU and which probe they call.
fn probe_declared(
    a: &Args,
    (cs, me): (bool, bool),
    probe_one: impl Fn(Interface, &mut dyn FnMut(&str) -> bool) -> Vec<Finding>,
) -> Vec<Finding> {
    let mut findings = Vec::new();
    let mut step = |name: &str| {
        if a.skip.iter().any(|s| s == name) {
            false
        } else {
            announce(name);
            true
        }
    };
    for (declared, interface) in [
        (cs, Interface::CoSimulation),
        (me, Interface::ModelExchange),
    ] {
        if declared {
            findings.extend(probe_one(interface, &mut step));
        }
    }
    findings
}
