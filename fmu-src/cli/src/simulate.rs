//! `actuator-fmu simulate FMU --data in.csv [--stop T] [--step H] [--set NAME=VALUE ...]
//! [--interface cs|me] --out out.csv`

use crate::common::{parse_sets, refuse_overwriting, run_error, CliError, CliResult};
use host::csv::{read_csv_for, write_csv_text};
use host::{simulate, Fmu, InputSeries, SimulationRequest};
use std::path::PathBuf;

/// Arguments of `simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// The FMU (.fmu file or extracted directory).
    pub fmu: PathBuf,
    /// CSV with `time` first and columns named as FMU inputs or outputs (ignored here).
    /// Continuous Real inputs are interpolated linearly; discrete ones (Integer, Boolean,
    /// Enumeration, String, Real with variability="discrete") are held from row to row.
    /// Inputs without a column keep their start value.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Stop time [s] (default: the last time of the CSV, else the DefaultExperiment, else
    /// start + 1 s).
    #[arg(long)]
    pub stop: Option<f64>,
    /// Communication step [s] (default: the CSV's sample interval, else the DefaultExperiment,
    /// else a round step giving 500 to 1000 steps, as FMPy chooses).
    #[arg(long)]
    pub step: Option<f64>,
    /// Value set before initialization, e.g. `load_mass=2.4` or `cables_attached=false`.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Output CSV: time and every output (Model Exchange: also a row before and one after each
    /// event, at its time, as FMPy records them).
    #[arg(long)]
    pub out: PathBuf,
    /// Relative tolerance: passed to fmi2SetupExperiment, and the host's integrator tolerance
    /// for Model Exchange (default: the DefaultExperiment's, else 1e-5 as FMPy).
    #[arg(long, value_name = "RTOL")]
    pub tolerance: Option<f64>,
    /// FMI interface to run: cs (Co-Simulation) or me (Model Exchange, integrated by the host
    /// with its stiff Rosenbrock solver, events located). Default: cs where the FMU offers it,
    /// else me.
    #[arg(long, value_enum, value_name = "cs|me")]
    pub interface: Option<crate::common::InterfaceArg>,
    /// Longest one FMU call may take [s] before the run is stopped as hung (0: no limit).
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    pub timeout: f64,
    /// Python interpreter whose runtime an FMU needing one (made by PythonFMU) gets
    /// (default: python3 on PATH).
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
}

/// A round step that divides `span` into 500 to 1000 steps (FMPy's `auto_interval`, so both
/// tools record the same grid for an FMU without a DefaultExperiment step).
pub(crate) fn auto_interval(span: f64) -> f64 {
    if !(span > 0.0 && span.is_finite()) {
        return 1.0;
    }
    let h = 10f64.powf(span.log10().round() - 3.0);
    let n = span / h;
    h * if n >= 2500.0 {
        5.0
    } else if n >= 2000.0 {
        4.0
    } else if n >= 1000.0 {
        2.0
    } else if n <= 200.0 {
        0.2
    } else if n <= 250.0 {
        0.25
    } else if n <= 500.0 {
        0.5
    } else {
        1.0
    }
}

/// Runs `simulate`.
pub fn run(a: Args) -> CliResult {
    if host::fmi_version_of(&a.fmu).map_err(CliError::input)? == host::FmiVersion::Fmi3 {
        return crate::simulate3::run(a);
    }
    let mut inputs = vec![a.fmu.as_path()];
    inputs.extend(a.data.as_deref());
    refuse_overwriting(&a.out, &inputs)?;
    let opts = host::OpenOptions {
        python: a.python.clone(),
        interface: crate::common::InterfaceArg::host(a.interface),
    };
    let fmu = Fmu::open_with(&a.fmu, &opts).map_err(CliError::input)?;
    let md = fmu.model_description();
    let start_values = parse_sets(md, &a.set)?;
    let de = md.default_experiment.clone().unwrap_or_default();
    let (start, stop, step, inputs) = match &a.data {
        Some(path) => {
            let table = read_csv_for(path, md).map_err(CliError::input)?;
            table.check_against(md).map_err(CliError::input)?;
            let start = table.time[0];
            let stop = a.stop.unwrap_or(*table.time.last().unwrap_or(&start));
            let step = match a.step.or(table.sample_interval()) {
                Some(h) => h,
                None => {
                    return Err(CliError::input(format!(
                        "{}: a single row has no sample interval: give --step",
                        path.display()
                    )))
                }
            };
            let mut series = InputSeries {
                time: table.time.clone(),
                ..Default::default()
            };
            for n in table.input_columns(md) {
                if let Some(c) = table.column(&n) {
                    series.columns.push((n, c.to_vec()));
                } else if let Some(c) = table.text_column(&n) {
                    series.text.push((n, c.to_vec()));
                }
            }
            (start, stop, step, series)
        }
        None => {
            let start = de.start_time.unwrap_or(0.0);
            let stop = a.stop.or(de.stop_time).unwrap_or(start + 1.0);
            let step = a
                .step
                .or(de.step_size)
                .unwrap_or_else(|| auto_interval(stop - start));
            (start, stop, step, InputSeries::default())
        }
    };
    if !(step > 0.0 && step.is_finite()) {
        return Err(CliError::input(format!(
            "--step must be a positive number, got {step}"
        )));
    }
    if !(stop >= start && stop.is_finite()) {
        return Err(CliError::input(format!(
            "--stop {stop} is before the start time {start}"
        )));
    }
    if let Some(tol) = a.tolerance.filter(|t| !(*t > 0.0 && t.is_finite())) {
        return Err(CliError::input(format!(
            "--tolerance must be a positive number, got {tol}"
        )));
    }
    let req = SimulationRequest {
        start_values,
        inputs,
        record_events: true,
        tolerance: a.tolerance,
        ..SimulationRequest::new(start, stop, step)
    };
    let res = simulate(&fmu, &req).map_err(|e| run_error(&a.fmu.display().to_string(), e))?;
    write_csv_text(&a.out, &res.time, &res.names, &res.columns, &res.text)
        .map_err(|e| CliError::input(format!("{}: cannot write: {e}", a.out.display())))?;
    if let Some(t) = res.ended_by_fmu {
        let how = match fmu.interface() {
            host::Interface::CoSimulation => "fmi2DoStep returned fmi2Discard with fmi2Terminated",
            host::Interface::ModelExchange => "it set terminateSimulation",
        };
        eprintln!(
            "{}: the FMU ended the simulation at t = {t} ({how}); {} rows up to that time \
             written to {}",
            a.fmu.display(),
            res.time.len(),
            a.out.display()
        );
    }
    Ok(0)
}
