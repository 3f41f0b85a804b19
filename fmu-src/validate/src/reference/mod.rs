//! `validate --reference`: simulate an FMU's experiments and compare the result with reference
//! results in a tolerance tube. This is no rule of FMI 2.0.4 or FMI 3.0.2: the references come
//! from the layered standard FMI-LS-REF (a manifest in `extra/org.fmi-standard.fmi-ls-ref/`,
//! [`manifest`]) or from the user, and a result outside the tube ([`tube`], csv-compare's
//! method) is a finding only because the user asked for the comparison.
//!
//! The runs go through the host's simulation ([`host::FmuRef::simulator`]: Co-Simulation or
//! Model Exchange as `actuator-fmu simulate` runs them), inputs from the stimuli CSV, outputs
//! recorded at the communication points.

pub mod manifest;
pub mod tube;

use crate::{Finding, Severity};
use host::csv::{read_csv_with_text, sample_interval, CsvError, Table, TimeAxis};
use host::fmi3::Fmu3;
use host::md::DefaultExperiment;
use host::view::Causality;
use host::{
    FmiVersion, Fmu, FmuRef, HostError, InputSeries, ModelView, OpenOptions, SimulationRequest,
    Unpacked,
};
use manifest::Experiment;
use std::path::{Path, PathBuf};
pub use tube::{Exit, Tolerances, Tube};

/// The check id of every reference result.
pub const CHECK: &str = "reference-result";
/// What a reference result rests on: not the FMI standard.
pub const CLAUSE: &str = "not an FMI rule: reference results (FMI-LS-REF or --reference FILE) \
                          compared in a csv-compare tube, checked because --reference asked";

/// Why the comparison could not be made at all (the command's input, not the FMU's results).
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    /// A file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The manifest is not an FMI-LS-REF manifest the check can read.
    #[error("{}: {cause}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong.
        cause: manifest::ManifestError,
    },
    /// A CSV given by the user is not readable.
    #[error(transparent)]
    Csv(#[from] host::csv::CsvError),
    /// The FMU could not be opened.
    #[error("{}: {source}", path.display())]
    Open {
        /// The FMU.
        path: PathBuf,
        /// Why.
        source: HostError,
    },
}

/// What to compare.
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// A reference CSV of the user (None: the FMU's own FMI-LS-REF experiments).
    pub file: Option<PathBuf>,
    /// The stimuli of `file` (None: no inputs).
    pub inputs: Option<PathBuf>,
    /// The tube's size.
    pub tolerances: Tolerances,
}

fn result(severity: Severity, location: &str, message: String) -> Finding {
    Finding {
        check: CHECK.into(),
        location: location.into(),
        message,
        severity,
        clause: CLAUSE.into(),
    }
}

/// Runs the experiments of `req` on the FMU at `path` and compares them: a finding per signal
/// that leaves its tube (its first exit), a note per experiment that passes or is not run.
pub fn check_reference(path: &Path, req: &Request) -> Result<Vec<Finding>, ReferenceError> {
    // Kept until the CSVs are read: the manifest's files live in its extracted tree.
    let mut _unpacked = None;
    let experiments = match &req.file {
        Some(file) => vec![user_experiment(file, req.inputs.as_deref())?],
        None => {
            let unpacked = Unpacked::open(path).map_err(|source| ReferenceError::Open {
                path: path.to_path_buf(),
                source,
            })?;
            let manifest = unpacked.dir.join(manifest::LS_DIR).join(manifest::MANIFEST);
            let loc = format!("{}/{}", manifest::LS_DIR, manifest::MANIFEST);
            if !manifest.is_file() {
                let msg = format!(
                    "the FMU carries no reference results (no {loc}); give --reference=FILE"
                );
                return Ok(vec![result(Severity::Note, &loc, msg)]);
            }
            let read = manifest::read(&manifest);
            _unpacked = Some(unpacked);
            match read {
                Ok(ex) => ex,
                Err(e) => return Ok(vec![result(Severity::Finding, &loc, e.to_string())]),
            }
        }
    };
    // An FMU the host cannot run (no binary for this platform, clocks) has its own findings
    // from the other checks; here it only means the references are not compared.
    let opened = match open(path) {
        Ok(o) => o,
        Err(e) => {
            let msg = format!("not run: {e}");
            return Ok(vec![result(Severity::Note, "reference experiments", msg)]);
        }
    };
    let fmu = opened.as_ref();
    let view = fmu.view();
    let mut out = Vec::new();
    for ex in &experiments {
        out.extend(run_experiment(fmu, &view, ex, req)?);
    }
    Ok(out)
}

/// The user's reference `file` (and stimuli `inputs`) as an experiment over the reference's
/// span, stepped at the stimuli's (else the reference's) sample interval.
fn user_experiment(file: &Path, inputs: Option<&Path>) -> Result<Experiment, ReferenceError> {
    let reference = read_trace(file)?;
    let stimuli = inputs.map(read_trace).transpose()?;
    let step = stimuli
        .as_ref()
        .and_then(Table::sample_interval)
        .or_else(|| reference.sample_interval());
    Ok(Experiment {
        name: file.display().to_string(),
        start: reference.time.first().copied(),
        stop: reference.time.last().copied(),
        step,
        references: Some(file.to_path_buf()),
        stimuli: inputs.map(Path::to_path_buf),
        ..Experiment::default()
    })
}

/// An opened FMU of either version.
enum Opened {
    Fmi2(Box<Fmu>),
    Fmi3(Box<Fmu3>),
}

impl Opened {
    fn as_ref(&self) -> FmuRef<'_> {
        match self {
            Opened::Fmi2(f) => FmuRef::Fmi2(f),
            Opened::Fmi3(f) => FmuRef::Fmi3(f),
        }
    }
}

fn open(path: &Path) -> Result<Opened, ReferenceError> {
    let err = |source| ReferenceError::Open {
        path: path.to_path_buf(),
        source,
    };
    Ok(match host::fmi_version_of(path).map_err(err)? {
        FmiVersion::Fmi2 => Opened::Fmi2(Box::new(
            Fmu::open_with(path, &OpenOptions::default()).map_err(err)?,
        )),
        FmiVersion::Fmi3 => Opened::Fmi3(Box::new(Fmu3::open_with(path, None).map_err(err)?)),
    })
}

/// A reference result or its stimuli: a time on two rows is an event, the values before and
/// after it (as an importer records a Model Exchange run, and as FMPy reads inputs).
fn read_trace(path: &Path) -> Result<Table, CsvError> {
    read_csv_with_text(path, &[], TimeAxis::JumpsAllowed)
}

/// Reads a CSV of the experiment: a user's file that cannot be read is an error of the
/// command, one the FMU carries a finding (`Ok(Err(finding))`).
fn read_table(
    path: &Path,
    user: bool,
    loc: &str,
) -> Result<Result<Table, Finding>, ReferenceError> {
    match read_trace(path) {
        Ok(t) => Ok(Ok(t)),
        Err(e) if user => Err(e.into()),
        Err(e) => Ok(Err(result(
            Severity::Finding,
            loc,
            format!("unreadable: {e}"),
        ))),
    }
}

/// One experiment: run, then each reference column naming a scalar variable in its tube.
fn run_experiment(
    fmu: FmuRef<'_>,
    view: &ModelView,
    ex: &Experiment,
    req: &Request,
) -> Result<Vec<Finding>, ReferenceError> {
    let user = req.file.is_some();
    let loc = format!("reference experiment '{}'", ex.name);
    if let Some(why) = &ex.unsupported {
        return Ok(vec![result(
            Severity::Note,
            &loc,
            format!("not run: {why}"),
        )]);
    }
    let Some(ref_path) = &ex.references else {
        return Ok(vec![result(
            Severity::Note,
            &loc,
            "no references to compare".into(),
        )]);
    };
    let reference = match read_table(ref_path, user, &loc)? {
        Ok(t) => t,
        Err(f) => return Ok(vec![f]),
    };
    let stimuli = match ex
        .stimuli
        .as_deref()
        .map(|p| read_table(p, user, &loc))
        .transpose()?
    {
        Some(Err(f)) => return Ok(vec![f]),
        Some(Ok(t)) => Some(t),
        None => None,
    };
    let compared: Vec<String> = reference
        .names
        .iter()
        .filter(|n| view.scalar(n).is_some())
        .cloned()
        .collect();
    let mut out = Vec::new();
    let ignored: Vec<&str> = reference
        .all_names()
        .filter(|n| !compared.contains(n))
        .map(String::as_str)
        .collect();
    if !ignored.is_empty() {
        let msg = format!(
            "columns not compared (no numeric variable of the FMU): {}",
            ignored.join(", ")
        );
        out.push(result(Severity::Note, &loc, msg));
    }
    if compared.is_empty() || reference.time.is_empty() {
        let msg = "no reference column names a variable of the FMU".to_string();
        out.push(result(Severity::Finding, &loc, msg));
        return Ok(out);
    }
    let sim = request(view, ex, &reference, stimuli.as_ref(), compared.clone());
    let res = match fmu.simulator().and_then(|mut s| s.run(&sim)) {
        Ok(r) => r,
        Err(e) => {
            out.push(result(
                Severity::Finding,
                &loc,
                format!("the run failed: {e}"),
            ));
            return Ok(out);
        }
    };
    if let Some(t) = res.ended_by_fmu {
        out.push(result(
            Severity::Finding,
            &loc,
            format!("the FMU ended the run at t = {t} s"),
        ));
    }
    out.extend(compare(
        &loc,
        &reference,
        &res.time,
        &res.names,
        &res.columns,
        req.tolerances,
        &sim,
    ));
    Ok(out)
}

/// The host request of experiment `ex`: its grid (else the DefaultExperiment's, else the
/// reference's span and sample interval), its tolerance, the stimuli's input columns.
fn request(
    view: &ModelView,
    ex: &Experiment,
    reference: &Table,
    stimuli: Option<&Table>,
    outputs: Vec<String>,
) -> SimulationRequest {
    let de = view
        .default_experiment
        .clone()
        .unwrap_or(DefaultExperiment {
            start_time: None,
            stop_time: None,
            tolerance: None,
            step_size: None,
        });
    let t = &reference.time;
    let start = ex.start.or(de.start_time).unwrap_or(t[0]);
    let stop = ex.stop.or(de.stop_time).unwrap_or(t[t.len() - 1]);
    let step = ex
        .step
        .or(de.step_size)
        .or_else(|| stimuli.and_then(Table::sample_interval))
        .or_else(|| sample_interval(t))
        .unwrap_or((stop - start).max(1e-3) / 500.0);
    let inputs = stimuli.map(|s| input_series(view, s)).unwrap_or_default();
    SimulationRequest {
        inputs,
        outputs,
        tolerance: ex.tolerance.or(de.tolerance),
        record_events: false,
        ..SimulationRequest::new(start, stop, step)
    }
}

/// The stimuli's columns that name inputs of the FMU (the others are not the FMU's to take).
fn input_series(view: &ModelView, stimuli: &Table) -> InputSeries {
    let is_input = |n: &str| {
        view.scalar(n)
            .is_some_and(|v| v.causality == Causality::Input)
    };
    InputSeries {
        time: stimuli.time.clone(),
        columns: stimuli
            .names
            .iter()
            .zip(&stimuli.columns)
            .filter(|(n, _)| is_input(n))
            .map(|(n, c)| (n.clone(), c.clone()))
            .collect(),
        text: Vec::new(),
    }
}

/// Each recorded signal in the tube of its reference column: findings for those that leave it,
/// in the order of their exit times, or one note that every signal stayed inside.
fn compare(
    loc: &str,
    reference: &Table,
    time: &[f64],
    names: &[String],
    columns: &[Vec<f64>],
    tol: Tolerances,
    sim: &SimulationRequest,
) -> Vec<Finding> {
    let mut exits: Vec<(Exit, &str, f64, f64)> = Vec::new();
    for (name, values) in names.iter().zip(columns) {
        let Some(r) = reference.column(name) else {
            continue;
        };
        let tube = Tube::new(&reference.time, r, tol);
        if let Some(e) = tube.first_exit(time, values) {
            exits.push((e, name, tube.dy, tube.dx));
        }
    }
    exits.sort_by(|a, b| a.0.time.total_cmp(&b.0.time));
    if exits.is_empty() {
        let msg = format!(
            "passed: {} signal(s) within the tube (value {} of the range + {}, time {} of the \
             span) over [{}, {}] s, step {} s",
            names.len(),
            tol.rel,
            tol.abs,
            tol.time,
            sim.start_time,
            sim.stop_time,
            sim.step
        );
        return vec![result(Severity::Note, loc, msg)];
    }
    exits
        .into_iter()
        .map(|(e, name, dy, dx)| {
            let msg = format!(
                "'{name}' leaves the tube at t = {} s: {} is {:.3e} outside [{}, {}] (tube \
                 +-{dy:.3e} in value, +-{dx:.3e} s in time)",
                e.time,
                e.value,
                e.distance(),
                e.lower,
                e.upper
            );
            result(Severity::Finding, loc, msg)
        })
        .collect()
}
