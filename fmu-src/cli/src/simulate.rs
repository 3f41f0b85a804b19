//! `actuator-fmu simulate FMU --data in.csv [--stop T] [--step H] [--set NAME=VALUE ...] --out out.csv`

use crate::common::{parse_sets, refuse_overwriting, run_error, CliError, CliResult};
use host::csv::{read_csv, write_csv};
use host::{simulate, Fmu, InputSeries, SimulationRequest};
use std::path::PathBuf;

/// Arguments of `simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// The FMU (.fmu file or extracted directory).
    pub fmu: PathBuf,
    /// CSV with `time` first and columns named as FMU inputs (linearly interpolated) or
    /// outputs (ignored here). Inputs without a column keep their start value.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Stop time [s] (default: the last time of the CSV, else the DefaultExperiment).
    #[arg(long)]
    pub stop: Option<f64>,
    /// Communication step [s] (default: the CSV's sample interval, else the DefaultExperiment).
    #[arg(long)]
    pub step: Option<f64>,
    /// Value set before initialization, e.g. `load_mass=2.4` or `cables_attached=false`.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Output CSV: time and every output.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `simulate`.
pub fn run(a: Args) -> CliResult {
    let mut inputs = vec![a.fmu.as_path()];
    inputs.extend(a.data.as_deref());
    refuse_overwriting(&a.out, &inputs)?;
    let fmu = Fmu::open(&a.fmu).map_err(CliError::input)?;
    let md = fmu.model_description();
    let start_values = parse_sets(md, &a.set)?;
    let de = md.default_experiment.clone().unwrap_or_default();
    let (start, stop, step, inputs) = match &a.data {
        Some(path) => {
            let table = read_csv(path).map_err(CliError::input)?;
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
            let columns = table
                .input_columns(md)
                .into_iter()
                .map(|n| {
                    let c = table.column(&n).unwrap_or_default().to_vec();
                    (n, c)
                })
                .collect();
            (
                start,
                stop,
                step,
                InputSeries {
                    time: table.time.clone(),
                    columns,
                },
            )
        }
        None => {
            let start = de.start_time.unwrap_or(0.0);
            let stop = a
                .stop
                .or(de.stop_time)
                .ok_or_else(|| CliError::input("no --data: give --stop"))?;
            let step = a
                .step
                .or(de.step_size)
                .ok_or_else(|| CliError::input("no --data: give --step"))?;
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
    let req = SimulationRequest {
        start_values,
        inputs,
        ..SimulationRequest::new(start, stop, step)
    };
    let res = simulate(&fmu, &req).map_err(|e| run_error(&a.fmu.display().to_string(), e))?;
    write_csv(&a.out, &res.time, &res.names, &res.columns)
        .map_err(|e| CliError::input(format!("{}: cannot write: {e}", a.out.display())))?;
    Ok(0)
}
