//! `actuator-fmu simulate FMU --data in.csv [--stop T] [--step H] [--set NAME=VALUE ...]
//! [--interface cs|me] --out out.csv`, for FMI 2.0 and FMI 3.0 FMUs: the same arguments, grid
//! and output file; FMI 3.0 runs take every FMI 3.0 type in the CSV (arrays one column each,
//! elements row-major separated by spaces, or one column per element `u[1]`; Binary as hex).

use crate::common::{parse_sets, refuse_overwriting, run_error, set_target, CliError, CliResult};
use host::csv::{
    format_number, read_csv_for, read_csv_with_text, sample_interval, write_csv_text, TimeAxis,
};
use host::fmi3::{simulate3_then, Causality3, Fmu3, Inputs3, ModelDescription3, Request3};
use host::md::DefaultExperiment;
use host::view::ModelView;
use host::{
    simulate_then, FmiVersion, Fmu, InputSeries, Interface, SimulationRequest, SimulationResult,
};
use std::path::{Path, PathBuf};

/// Arguments of `simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// The FMU (.fmu file or extracted directory).
    pub fmu: PathBuf,
    /// CSV with `time` first and columns named as FMU inputs or outputs (ignored here).
    /// Continuous Real inputs are interpolated linearly; discrete ones (Integer, Boolean,
    /// Enumeration, String, Real with variability="discrete") are held from row to row.
    /// A time on two rows is a jump (as FMPy reads it): the first row holds the values just
    /// before, the second those from then on (an input event in Model Exchange).
    /// Inputs without a column keep their start value.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Stop time [s] (default: the last time of the CSV, else the DefaultExperiment, else
    /// start + 1 s).
    #[arg(long)]
    pub stop: Option<f64>,
    /// Communication step [s] (default: the CSV's sample interval; else, Co-Simulation, the
    /// FMU's fixedInternalStepSize (FMI 3.0) or DefaultExperiment stepSize, Model Exchange
    /// 10^(round(log10(stop - start)) - 3), either doubled until at most 1000 steps; else a
    /// round step giving 500 to 1000 steps; as FMPy's simulate_fmu chooses).
    #[arg(long)]
    pub step: Option<f64>,
    /// Value set before initialization, e.g. `load_mass=2.4` or `cables_attached=false`.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Output CSV: time and every output; an FMU without outputs: its continuous states (at
    /// most 5), else its first 5 variables (Model Exchange: also a row before and one after
    /// each event, at its time; all as FMPy's simulate_fmu records them).
    #[arg(long)]
    pub out: PathBuf,
    /// Variables to record, comma-separated, in this order (default: every output, FMI 3.0
    /// aliases of outputs after them; without outputs as --out says; as FMPy records them);
    /// any variable or alias name.
    #[arg(long, value_name = "NAME,...", value_delimiter = ',')]
    pub outputs: Vec<String>,
    /// Relative tolerance (default: the DefaultExperiment's). Co-Simulation: passed to
    /// fmi2SetupExperiment / fmi3EnterInitializationMode (no --tolerance and no
    /// DefaultExperiment tolerance: toleranceDefined = false, the FMU's own). Model Exchange:
    /// the host integrator's relative tolerance (else 1e-5), passed to the FMU only when given;
    /// as FMPy's simulate_fmu.
    #[arg(long, value_name = "RTOL")]
    pub tolerance: Option<f64>,
    /// How the FMU runs: its interface, the hang limit, the Python runtime.
    #[command(flatten)]
    pub run: crate::common::RunArgs,
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

/// Where a run starts and stops and its communication step [s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TimeGrid {
    /// Start time [s].
    pub start: f64,
    /// Stop time [s], not before `start`.
    pub stop: f64,
    /// Communication step [s], positive.
    pub step: f64,
}

/// The time grid of a run and the checks of `--step`, `--stop` and `--tolerance`, shared by
/// FMI 2.0 and FMI 3.0 so that both take the same defaults and refuse the same arguments with
/// the same messages in the same order. `data_time` is the time column read from `--data`
/// (unused without `--data`); `experiment` is the FMU's DefaultExperiment; `cs_step` the step
/// the FMU's description gives a Co-Simulation run (None for Model Exchange, see
/// [`cs_step`]).
pub(crate) fn time_grid(
    a: &Args,
    data_time: &[f64],
    (experiment, cs_step): (&DefaultExperiment, Option<f64>),
) -> Result<TimeGrid, CliError> {
    let grid = match &a.data {
        Some(path) => grid_of_data(a, path, data_time)?,
        None => grid_of_experiment(a, experiment, cs_step),
    };
    check_grid(&grid)?;
    check_tolerance(a.tolerance)?;
    Ok(grid)
}

/// A run on the `--data` CSV at `path`: from its first row to `--stop`, else its last row, by
/// `--step`, else its sample interval (rows at one time have none).
fn grid_of_data(a: &Args, path: &Path, time: &[f64]) -> Result<TimeGrid, CliError> {
    let start = time[0];
    let stop = a.stop.unwrap_or(*time.last().unwrap_or(&start));
    let step = a.step.or(sample_interval(time)).ok_or_else(|| {
        CliError::input(format!(
            "{}: the rows are at one time, so there is no sample interval: give --step",
            path.display()
        ))
    })?;
    Ok(TimeGrid { start, stop, step })
}

/// The step FMPy's `simulate_fmu` takes from the description of a Co-Simulation run:
/// `fixedInternalStepSize` (FMI 3.0), else the DefaultExperiment's `stepSize`. Model Exchange
/// runs: NaN, FMPy's default `step_size` for the run's span, `10^(round(log10(stop - start)) -
/// 3)`, whatever the description says (`simulate_fmu`'s ME output interval).
pub(crate) fn cs_step(
    interface: Interface,
    fixed_internal: Option<f64>,
    experiment: &DefaultExperiment,
) -> Option<f64> {
    match interface {
        Interface::CoSimulation => fixed_internal.or(experiment.step_size),
        Interface::ModelExchange => Some(f64::NAN),
    }
}

/// A run without data: the DefaultExperiment's start (else 0), `--stop`, else its stop (else
/// 1 s after the start), `--step`, else `cs_step` doubled while it gives more than 1000 steps
/// (FMPy's rule), else [`auto_interval`].
fn grid_of_experiment(a: &Args, experiment: &DefaultExperiment, cs_step: Option<f64>) -> TimeGrid {
    let start = experiment.start_time.unwrap_or(0.0);
    let stop = a.stop.or(experiment.stop_time).unwrap_or(start + 1.0);
    let span = stop - start;
    let by_span = (span > 0.0).then(|| 10f64.powf(span.log10().round() - 3.0));
    let cs_step = cs_step.and_then(|h| if h.is_nan() { by_span } else { Some(h) });
    let fitted = cs_step
        .filter(|h| *h > 0.0 && span.is_finite())
        .map(|mut h| {
            while span / h > 1000.0 {
                h *= 2.0;
            }
            h
        });
    let step = a
        .step
        .or(fitted)
        .or(cs_step)
        .unwrap_or_else(|| auto_interval(stop - start));
    TimeGrid { start, stop, step }
}

/// Refuses a step that is not a positive finite number and a stop before the start (or not
/// finite), whichever option or default gave them: the host could not lay out the grid.
fn check_grid(grid: &TimeGrid) -> Result<(), CliError> {
    let TimeGrid { start, stop, step } = *grid;
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
    Ok(())
}

/// Refuses a `--tolerance` that is not a positive finite number: no integrator can meet it.
fn check_tolerance(tolerance: Option<f64>) -> Result<(), CliError> {
    match tolerance.filter(|t| !(*t > 0.0 && t.is_finite())) {
        Some(tol) => Err(CliError::input(format!(
            "--tolerance must be a positive number, got {tol}"
        ))),
        None => Ok(()),
    }
}

/// The `--data` CSV at `path` as the inputs of an FMI 2.0 run: every column must be an input
/// or an output of the FMU; the inputs' columns are kept, numbers and text apart.
fn read_inputs(path: &Path, md: &ModelView) -> Result<InputSeries, CliError> {
    let table = read_csv_for(path, md).map_err(CliError::input)?;
    table.check_against(md).map_err(CliError::input)?;
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
    Ok(series)
}

/// Runs `simulate`.
pub fn run(a: Args) -> CliResult {
    let version = host::fmi_version_of(&a.fmu).map_err(CliError::input)?;
    let mut inputs = vec![a.fmu.as_path()];
    inputs.extend(a.data.as_deref());
    refuse_overwriting(&a.out, &inputs)?;
    let save = |res: SimulationResult, ended_how: &str| save(&a, &res, ended_how);
    match version {
        FmiVersion::Fmi2 => run2(&a, save),
        FmiVersion::Fmi3 => run3(&a, save),
    }
}

/// Writes a run's result to `--out` while the FMU is still instantiated, and marks it written
/// for the supervisor: an FMU that crashes while being freed after this loses nothing.
/// `ended_how` says how the FMU ends a run early, when it did.
fn save(a: &Args, res: &SimulationResult, ended_how: &str) -> CliResult {
    write_csv_text(&a.out, &res.time, &res.names, &res.columns, &res.text)
        .map_err(|e| CliError::input(format!("{}: cannot write: {e}", a.out.display())))?;
    if let Some(t) = res.ended_by_fmu {
        eprintln!(
            "{}: the FMU ended the simulation at t = {t} ({ended_how}); {} rows up to that time \
             written to {}",
            a.fmu.display(),
            res.time.len(),
            a.out.display()
        );
    }
    host::watch::mark_results_written()
        .map_err(|e| CliError::input(format!("cannot tell the supervisor: {e}")))?;
    Ok(0)
}

/// An FMI 2.0 run, its result handed to `save` before the instance is freed.
fn run2(a: &Args, save: impl FnOnce(SimulationResult, &str) -> CliResult) -> CliResult {
    let opts = a.run.open_options();
    let fmu = Fmu::open_with(&a.fmu, &opts).map_err(CliError::input)?;
    let md = ModelView::from(fmu.model_description());
    let start_values = parse_sets(&md, &a.set)?;
    let experiment = md.default_experiment.clone().unwrap_or_default();
    let inputs = match &a.data {
        Some(path) => read_inputs(path, &md)?,
        None => InputSeries::default(),
    };
    let cs = cs_step(fmu.interface(), None, &experiment);
    let grid = time_grid(a, &inputs.time, (&experiment, cs))?;
    let req = SimulationRequest {
        start_values,
        inputs,
        record_events: true,
        tolerance: a.tolerance,
        outputs: a.outputs.clone(),
        ..SimulationRequest::new(grid.start, grid.stop, grid.step)
    };
    let how = match fmu.interface() {
        Interface::CoSimulation => "fmi2DoStep returned fmi2Discard with fmi2Terminated",
        Interface::ModelExchange => "it set terminateSimulation",
    };
    simulate_then(&fmu, &req, |res| save(res, how))
        .map_err(|e| run_error(&a.fmu.display().to_string(), e))?
}

/// An FMI 3.0 run, its result handed to `save` before the instance is freed.
fn run3(a: &Args, save: impl FnOnce(SimulationResult, &str) -> CliResult) -> CliResult {
    let interface = crate::common::InterfaceArg::host(a.run.interface);
    let fmu = Fmu3::open_with(&a.fmu, interface).map_err(CliError::input)?;
    let described = fmu.model_description().with_aliases();
    let md: &ModelDescription3 = &described;
    if fmu.interface() == Interface::CoSimulation
        && host::fmi3::clocks_in_co_simulation(md) == host::fmi3::ClocksInCs::Ignored
    {
        eprintln!(
            "{}: note: the FMU has clocks but no hasEventMode=\"true\" (FMI 3.0.2 section 4.4: \
             \"If the FMU has clocks, then hasEventMode must be true\"): Co-Simulation runs \
             without Event Mode and the FMU ignores its clocks",
            a.fmu.display()
        );
    }
    if let Some(missing) = fmu.event_mode_function_missing() {
        eprintln!(
            "{}: note: the FMU has clocks and hasEventMode=\"true\" but its binary does not \
             export {missing} (FMI 3.0.2 section 2.5: \"The FMU must implement all API functions \
             declared in fmi3Functions.h\"): Co-Simulation runs without Event Mode and the FMU \
             ignores its clocks",
            a.fmu.display()
        );
    }
    let start_values = parse_sets3(md, &a.set)?;
    let experiment = md.default_experiment.clone().unwrap_or_default();
    let inputs = match &a.data {
        Some(path) => read_inputs3(path, md)?,
        None => Inputs3::default(),
    };
    let fixed = md
        .co_simulation
        .as_ref()
        .and_then(|c| c.fixed_internal_step_size);
    let cs = cs_step(fmu.interface(), fixed, &experiment);
    let grid = time_grid(a, &inputs.time, (&experiment, cs))?;
    let req = Request3 {
        start_values,
        tolerance: a.tolerance,
        inputs,
        outputs: a.outputs.clone(),
        record_events: true,
        ..Request3::new(grid.start, grid.stop, grid.step)
    };
    let how = match fmu.interface() {
        Interface::CoSimulation => "fmi3DoStep returned terminateSimulation",
        Interface::ModelExchange => "the Model Exchange FMU returned terminateSimulation",
    };
    simulate3_then(&fmu, &req, |res| save(res, how))
        .map_err(|e| run_error(&a.fmu.display().to_string(), e))?
}

/// `--set NAME=VALUE` as (name, text): the host parses the text as the variable's type (an
/// array's elements separated by spaces) and checks causality and range.
fn parse_sets3(md: &ModelDescription3, sets: &[String]) -> Result<Vec<(String, String)>, CliError> {
    sets.iter()
        .map(|s| {
            let (name, value, var) = set_target(s, |name| md.variable(name))?;
            if !matches!(
                var.causality,
                Causality3::Parameter | Causality3::StructuralParameter | Causality3::Input
            ) {
                return Err(CliError::input(format!(
                    "--set '{s}': '{name}' is {}: only parameters, structural parameters and \
                     inputs can be set",
                    var.causality
                )));
            }
            Ok((name.to_string(), value.to_string()))
        })
        .collect()
}

/// The `--data` CSV of an FMI 3.0 run as text columns: a variable's own column is read as text
/// (an array's elements separated by spaces, Binary as hex), any other (an element `u[2]`) as a
/// number.
fn read_inputs3(path: &Path, md: &ModelDescription3) -> Result<Inputs3, CliError> {
    let text: Vec<String> = md.variables.iter().map(|v| v.name.clone()).collect();
    let table = read_csv_with_text(path, &text, TimeAxis::JumpsAllowed).map_err(CliError::input)?;
    let mut columns: Vec<(String, Vec<String>)> = table
        .names
        .iter()
        .zip(&table.columns)
        .map(|(n, c)| (n.clone(), c.iter().map(|&x| format_number(x)).collect()))
        .collect();
    columns.extend(table.text.iter().cloned());
    Ok(Inputs3 {
        time: table.time,
        columns,
    })
}
