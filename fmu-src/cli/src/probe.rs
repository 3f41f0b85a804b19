//! Hidden `__probe FMU`: the part of `validate` that loads the binary, run in a child process
//! so that a crash of the FMU cannot take the validator down. Prints each probe step on stderr
//! (`@@STEP@@ name`) before running it and the findings as one JSON line on stdout
//! (`@@FINDINGS@@ [...]`).

use crate::common::CliResult;
use host::validate::{check_symbols, probe, probe_me, Finding};
use host::{Extracted, Fmu, Interface, OpenOptions};
use std::io::Write;
use std::path::PathBuf;

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
            // A binary that does not load is reported once; there is nothing to probe.
            let loadable = !symbols.iter().any(|f| f.check == "binary");
            findings.extend(symbols);
            drop(ex);
            if loadable {
                findings.extend(probe_interfaces(&a, cs, me));
            }
        }
    }
    announce("done");
    let json = serde_json::to_string(&findings).unwrap_or_else(|_| "[]".into());
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "\n{FINDINGS_MARK}{json}");
    let _ = out.flush();
    Ok(0)
}

/// The Co-Simulation probe when the FMU declares Co-Simulation, the Model Exchange probe when it
/// declares Model Exchange, each on the FMU opened with that interface.
fn probe_interfaces(a: &Args, cs: bool, me: bool) -> Vec<Finding> {
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
        if !declared {
            continue;
        }
        let opts = OpenOptions {
            interface: Some(interface),
            ..OpenOptions::default()
        };
        match Fmu::open_with(&a.fmu, &opts) {
            Err(e) => findings.push(Finding::new(
                "binary",
                a.fmu.display().to_string(),
                match interface {
                    Interface::CoSimulation => e.to_string(),
                    Interface::ModelExchange => format!("{interface}: {e}"),
                },
            )),
            Ok(fmu) => findings.extend(match interface {
                Interface::CoSimulation => probe(&fmu, &mut step),
                Interface::ModelExchange => probe_me(&fmu, &mut step),
            }),
        }
    }
    findings
}
