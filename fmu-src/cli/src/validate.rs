//! `actuator-fmu validate FMU... [--format text|json|junit|sarif|github]`: model-description
//! checks in this process, the binary checks and state-machine probe in a child process
//! (`__probe`); the reports are written by `report`.

use crate::common::{CliError, CliResult};
use crate::probe::{FINDINGS_MARK, STEP_MARK};
use crate::report::{render, Fmi, Format, Report, Stage, FORMAT_VERSION};
use host::fmi3::ModelDescription3;
use host::{Extracted, FmiVersion, HostError, ModelView, Unpacked};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use validate::{
    check_description_xml, check_effect_convention, check_files, check_model_description,
    check_model_description3, check_platform_binaries, check_platform_binaries3, Finding,
    PlatformBinary,
};

/// Arguments of `validate`.
#[derive(clap::Args)]
pub struct Args {
    /// FMUs to check.
    #[arg(required = true)]
    pub fmus: Vec<PathBuf>,
    /// Output format: text, json (docs/validate-output.md), junit (JUnit XML), sarif (SARIF
    /// 2.1.0) or github (GitHub Actions annotations). The exit status is the same for all.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// The same as `--format json`.
    #[arg(long, conflicts_with = "format")]
    pub json: bool,
    /// Also write the reports in FORMAT to FILE (repeatable), from the same run: e.g.
    /// `--format github --output sarif=validate.sarif` in CI.
    #[arg(long, value_name = "FORMAT=FILE", value_parser = parse_output)]
    pub output: Vec<(Format, PathBuf)>,
    /// Also check the candidate-effect convention of the gap workflow (`<effect>.enabled`
    /// switches, effect parameters with unit and min/max, a `[calibrate]` default set).
    #[arg(long)]
    pub effects: bool,
    /// Seconds the state-machine probe of one FMU may take.
    #[arg(long, default_value_t = 120)]
    pub timeout: u64,
    /// Also run the FMU's reference experiments (FMI-LS-REF manifest in
    /// extra/org.fmi-standard.fmi-ls-ref/), or with `--reference=FILE` compare with the
    /// reference CSV FILE, and report each signal that leaves its tolerance tube (check
    /// `reference-result`; not an FMI rule).
    #[command(flatten)]
    pub reference: crate::validate_reference::ReferenceArgs,
}

/// Runs `validate`: exit 0 without findings (notes allowed), 1 with any, 2 when an FMU file
/// cannot be read (then nothing is printed on stdout).
pub fn run(a: Args) -> CliResult {
    let mut reports = Vec::new();
    for path in &a.fmus {
        if !path.exists() {
            return Err(CliError::input(format!("{}: no such file", path.display())));
        }
        let fmi_version = match host::fmi_version_of(path) {
            Ok(FmiVersion::Fmi2) => Some(Fmi::V2),
            Ok(FmiVersion::Fmi3) => Some(Fmi::V3),
            Err(_) => None,
        };
        let mut checked = validate_one(path, Duration::from_secs(a.timeout), a.effects)?;
        checked.findings.extend(a.reference.check(path)?);
        let (findings, notes) = checked.findings.into_iter().partition(Finding::is_required);
        reports.push(Report {
            format_version: FORMAT_VERSION,
            fmu: path.display().to_string(),
            fmi_version,
            checked: checked.stages,
            findings,
            notes,
            binaries: checked.binaries,
        });
    }
    let total: usize = reports.iter().map(|r| r.findings.len()).sum();
    let format = if a.json { Format::Json } else { a.format };
    for (format, file) in &a.output {
        std::fs::write(file, render(&reports, *format))
            .map_err(|e| CliError::input(format!("--output {}: {e}", file.display())))?;
    }
    out!("{}", render(&reports, format).trim_end_matches('\n'));
    Ok(if total == 0 { 0 } else { 1 })
}

/// What is wrong with an `--output` argument.
#[derive(Debug, thiserror::Error)]
pub enum OutputArgError {
    /// No `=` between format and file.
    #[error("'{0}': expected FORMAT=FILE")]
    Form(String),
    /// The format is not one of `--format`'s.
    #[error("'{arg}': unknown format '{format}' (text, json, junit, sarif, github)")]
    Format {
        /// The argument.
        arg: String,
        /// Its format part.
        format: String,
    },
}

/// `--output FORMAT=FILE`.
fn parse_output(arg: &str) -> Result<(Format, PathBuf), OutputArgError> {
    use clap::ValueEnum as _;
    let (format, file) = arg
        .split_once('=')
        .filter(|(_, file)| !file.is_empty())
        .ok_or_else(|| OutputArgError::Form(arg.to_string()))?;
    let format = Format::from_str(format, true).map_err(|_| OutputArgError::Format {
        arg: arg.to_string(),
        format: format.to_string(),
    })?;
    Ok((format, PathBuf::from(file)))
}

/// What `validate` checked in one FMU: its findings and notes, its binaries, the stages run.
#[derive(Default)]
struct Checked {
    findings: Vec<Finding>,
    binaries: Vec<PlatformBinary>,
    stages: Vec<Stage>,
}

impl Checked {
    /// An FMU that could not be opened or read: `finding` is all there is.
    fn unreadable(finding: Finding) -> Self {
        Checked {
            findings: vec![finding],
            stages: vec![Stage::Archive],
            ..Checked::default()
        }
    }
}

fn validate_one(path: &Path, timeout: Duration, effects: bool) -> Result<Checked, CliError> {
    let mut checked = match host::fmi_version_of(path) {
        Ok(FmiVersion::Fmi3) => validate_fmi3(path, timeout, effects)?,
        Err(HostError::Unsupported { .. }) if is_fmi1(path) => return Ok(fmi1_not_checked(path)),
        _ => validate_fmi2(path, timeout, effects)?,
    };
    // The schema of the description's FMI version and its naming convention, read from the text
    // so that they are checked even when the description cannot be parsed into a model.
    if let Ok(xml) = host::kind::read_description(path) {
        checked.findings.extend(check_description_xml(&xml));
    }
    Ok(checked)
}

/// Whether the FMU at `path` declares FMI 1.0 (`fmiVersion="1.0"`).
fn is_fmi1(path: &Path) -> bool {
    host::kind::declared_fmi_version(path).is_some_and(|v| v.starts_with("1."))
}

/// An FMI 1.0 FMU: a conforming FMU of a version whose rules are not checked here, said in a
/// note (a CI run over a repository's FMUs goes on; its other FMUs are checked).
fn fmi1_not_checked(path: &Path) -> Checked {
    let note = Finding::new(
        "fmi-version-not-checked",
        path.display().to_string(),
        "an FMI 1.0 FMU: its rules are not checked (FMI 2.0 and 3.0 are)",
    );
    Checked {
        findings: vec![note],
        ..Checked::default()
    }
}

/// The checks of an FMI 2.0 FMU: its model description (and with `effects` the candidate-effect
/// convention), its files and binaries, and the runtime probe when this platform's binary is
/// present.
fn validate_fmi2(path: &Path, timeout: Duration, effects: bool) -> Result<Checked, CliError> {
    let ex = match Extracted::open(path) {
        Ok(ex) => ex,
        Err(HostError::Io { path, source }) => {
            return Err(CliError::input(format!("{}: {source}", path.display())))
        }
        Err(e @ HostError::Unsupported { .. }) => return Err(CliError::input(e)),
        Err(e) => {
            let check = match e {
                HostError::ModelDescription { .. } => "model-description-xml",
                _ => "archive",
            };
            let finding = Finding::new(check, path.display().to_string(), e.to_string());
            return Ok(Checked::unreadable(finding));
        }
    };
    let mut stages = vec![Stage::Archive, Stage::Description, Stage::Binaries];
    let mut findings = check_model_description(&ex.model_description);
    if effects {
        stages.push(Stage::Effects);
        findings.extend(check_effect_convention(&ModelView::from(
            &ex.model_description,
        )));
    }
    findings.extend(check_files(&ex));
    let (binary_findings, binaries) = check_platform_binaries(&ex);
    findings.extend(binary_findings);
    let binary_present = ex
        .binary_path_for(ex.default_interface())
        .map(|b| b.is_file())
        .unwrap_or(false);
    drop(ex);
    if binary_present {
        findings.extend(run_probe(path, timeout, false)?);
        stages.push(Stage::Probe);
    }
    Ok(Checked {
        findings,
        binaries,
        stages,
    })
}

/// The checks of an FMI 3.0 FMU: its model description (and with `effects` the candidate-effect
/// convention) and its binaries per platform tuple (read, not loaded).
fn validate_fmi3(path: &Path, timeout: Duration, effects: bool) -> Result<Checked, CliError> {
    let unpacked = match Unpacked::open(path) {
        Ok(u) => u,
        Err(HostError::Io { path, source }) => {
            return Err(CliError::input(format!("{}: {source}", path.display())))
        }
        Err(e) => return Ok(Checked::unreadable(description_error(path, e))),
    };
    let md = match ModelDescription3::parse(&unpacked.xml, &unpacked.description_file()) {
        Ok(md) => md,
        Err(e) => return Ok(Checked::unreadable(description_error(path, e))),
    };
    let mut stages = vec![Stage::Archive, Stage::Description, Stage::Binaries];
    let mut findings = check_model_description3(&md);
    if effects {
        stages.push(Stage::Effects);
        findings.extend(check_effect_convention(&ModelView::from(&md)));
    }
    let (binary_findings, binaries) = check_platform_binaries3(&unpacked.dir, &md);
    findings.extend(binary_findings);
    // The runtime probes: FMUs with a binary for this platform, run unless the probes leave
    // them to simulate (clocks) or the host refuses them (Scheduled Execution only), which a
    // note says.
    let runnable = [
        &md.co_simulation,
        &md.model_exchange,
        &md.scheduled_execution,
    ]
    .into_iter()
    .flatten()
    .any(|i| {
        unpacked
            .dir
            .join("binaries")
            .join(host::fmi3::PLATFORM_TUPLE)
            .join(format!("{}.{}", i.model_identifier, host::LIB_SUFFIX))
            .is_file()
    });
    let refused = host::fmi3::unsupported(&md);
    drop(unpacked);
    match refused {
        None if runnable => {
            findings.extend(run_probe(path, timeout, true)?);
            stages.push(Stage::Probe);
        }
        Some(reason) if runnable => findings.push(validate::fmi3::probe_not_run(&reason)),
        _ => {}
    }
    Ok(Checked {
        findings,
        binaries,
        stages,
    })
}

/// An FMU that cannot be opened or whose description cannot be read, as one finding.
fn description_error(path: &Path, e: HostError) -> Finding {
    let check = match e {
        HostError::ModelDescription { .. } => "model-description-xml",
        _ => "archive",
    };
    let mut f = Finding::new(check, path.display().to_string(), e.to_string());
    f.clause = validate::fmi3::classify3(check).to_string();
    f
}

/// Runs the probe in child processes: a case that crashes becomes a finding and the probe is
/// run again without it, so every case is reported. `fmi3`: the crash and timeout findings
/// cite FMI 3.0.2 (every call returns a status) instead of FMI 2.0.4.
fn run_probe(path: &Path, timeout: Duration, fmi3: bool) -> Result<Vec<Finding>, CliError> {
    let mut crashed: Vec<String> = Vec::new();
    let mut findings = Vec::new();
    loop {
        match run_probe_once(path, timeout, &crashed)? {
            ProbeOutcome::Done(f) => {
                findings.extend(f);
                return Ok(findings);
            }
            ProbeOutcome::Crashed {
                step,
                mut finding,
                what,
            } => {
                if fmi3 {
                    finding.clause = validate::probe3::clause3(&finding.check).to_string();
                }
                // A crash or hang on a call the importer must not make is a note; in a legal
                // sequence it stays a finding.
                findings.push(validate::wrong_call_crash(&step, &what).unwrap_or(finding));
                let is_case =
                    validate::probe_case(&step).is_some() && !step.ends_with("normal-run");
                if !is_case || crashed.contains(&step) {
                    return Ok(findings);
                }
                crashed.push(step);
            }
        }
    }
}

enum ProbeOutcome {
    Done(Vec<Finding>),
    /// The probe crashed or hung at `step`: the finding, and what happened in a few words.
    Crashed {
        step: String,
        finding: Finding,
        what: String,
    },
}

/// A finding as the probe child reported it, unless its check id is not one (bytes outside
/// `[a-z0-9-]`) or its location or message holds a NUL (no C string an FMU logs, and none of
/// our texts, can carry one; a pointer's high bytes are NULs): an FMU that writes into memory it
/// does not own (after `fmi2FreeInstance`, say) can garble the child's report, which then
/// becomes a note saying so.
fn trusted(f: Finding) -> Finding {
    let well_formed = !f.check.is_empty()
        && f.check.len() <= 64
        && f.check
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-')
        && !f.location.contains('\0')
        && !f.message.contains('\0');
    if well_formed {
        return f;
    }
    Finding::new(
        "probe-report-garbled",
        "probe",
        "the probe's report came back garbled: the FMU wrote into memory it does not own (a \
         memory checker such as valgrind locates it)",
    )
}

/// Runs `__probe` once in a child process and turns its output, crash or hang into findings.
fn run_probe_once(
    path: &Path,
    timeout: Duration,
    skip: &[String],
) -> Result<ProbeOutcome, CliError> {
    let exe = std::env::current_exe()
        .map_err(|e| CliError::input(format!("cannot find own executable: {e}")))?;
    let mut child = Command::new(exe)
        .arg("__probe")
        .arg(path)
        .args(skip.iter().flat_map(|s| ["--skip", s.as_str()]))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| CliError::input(format!("cannot start the probe process: {e}")))?;
    let mut so = child.stdout.take().expect("piped stdout");
    let mut se = child.stderr.take().expect("piped stderr");
    // An FMU may print bytes that are not UTF-8 into the same streams: read them lossily.
    let out_t = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = so.read_to_end(&mut b);
        String::from_utf8_lossy(&b).into_owned()
    });
    let err_t = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = se.read_to_end(&mut b);
        String::from_utf8_lossy(&b).into_owned()
    });
    let started = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(st)) => break Some(st),
            Ok(None) if started.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => {
                return Err(CliError::input(format!(
                    "waiting for the probe process: {e}"
                )))
            }
        }
    };
    let stdout = out_t.join().unwrap_or_default();
    let stderr = err_t.join().unwrap_or_default();
    let last_step = stderr
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix(STEP_MARK))
        .unwrap_or("start")
        .to_string();
    let loc = format!("probe {last_step}");
    let Some(status) = status else {
        let what = format!("the FMU did not return within {} s", timeout.as_secs());
        let finding = Finding::new("probe-timeout", loc, &what);
        return Ok(ProbeOutcome::Crashed {
            step: last_step,
            finding,
            what,
        });
    };
    if let Some(json) = stdout.lines().find_map(|l| l.strip_prefix(FINDINGS_MARK)) {
        if status.success() {
            return serde_json::from_str(json)
                .map(|found: Vec<Finding>| {
                    ProbeOutcome::Done(found.into_iter().map(trusted).collect())
                })
                .map_err(|e| CliError::input(format!("probe output unreadable: {e}")));
        }
    }
    use std::os::unix::process::ExitStatusExt;
    let what = match status.signal() {
        Some(sig) => format!(
            "the FMU crashed ({} {sig})",
            crate::supervise::signal_name(sig)
        ),
        None => format!("the probe process ended with {status}"),
    };
    let finding = Finding::new("probe-crash", loc, format!("{what} during this probe step"));
    Ok(ProbeOutcome::Crashed {
        step: last_step,
        finding,
        what,
    })
}

#[cfg(test)]
mod tests {
    use super::trusted;
    use validate::{Finding, Severity};

    #[test]
    fn a_garbled_check_id_from_the_probe_child_becomes_a_note_saying_so() {
        let sound = Finding::new("probe-fmu-state", "probe fmu-state", "not restored");
        assert_eq!(trusted(sound.clone()), sound);
        let garbled = Finding {
            check: "pr\u{1}\u{fffd}be".into(),
            ..sound
        };
        let kept = trusted(garbled);
        assert_eq!(
            (kept.check.as_str(), kept.severity),
            ("probe-report-garbled", Severity::Note)
        );
        assert!(
            kept.message.contains("wrote into memory it does not own"),
            "{kept}"
        );
        let overwritten = Finding {
            message: "\u{fffd}\u{3}\0\0\u{7f}\0\0 returned fmi2OK".into(),
            ..Finding::new("unknown-value-reference", "probe", "")
        };
        assert_eq!(trusted(overwritten).check, "probe-report-garbled");
    }
}
