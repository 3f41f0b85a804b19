//! Hidden `__probe FMU`: the part of `validate` that loads the binary, run in a child process
//! so that a crash of the FMU cannot take the validator down. Prints each probe step on stderr
//! (`@@STEP@@ name`) before running it and the findings as one JSON line on stdout
//! (`@@FINDINGS@@ [...]`).

use crate::common::CliResult;
use host::validate::{check_symbols, probe, Finding};
use host::{Extracted, Fmu};
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
            let symbols = check_symbols(&ex);
            // A binary that does not load is reported once; there is nothing to probe.
            let loadable = !symbols.iter().any(|f| f.check == "binary");
            findings.extend(symbols);
            drop(ex);
            if loadable {
                match Fmu::open(&a.fmu) {
                    Err(e) => findings.push(Finding::new(
                        "binary",
                        a.fmu.display().to_string(),
                        e.to_string(),
                    )),
                    Ok(fmu) => findings.extend(probe(&fmu, &mut |name| {
                        if a.skip.iter().any(|s| s == name) {
                            false
                        } else {
                            announce(name);
                            true
                        }
                    })),
                }
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
