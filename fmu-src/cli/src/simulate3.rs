//! `actuator-fmu simulate` for FMI 3.0 Co-Simulation FMUs: the same arguments and files as for
//! FMI 2.0, with every FMI 3.0 type in the CSV (arrays one column each, elements row-major
//! separated by spaces, or one column per element `u[1]`; Binary as hex).

use crate::common::{refuse_overwriting, run_error, set_target, CliError, CliResult};
use crate::simulate::{time_grid, Args};
use host::csv::{format_number, read_csv_with_text, write_csv_text};
use host::fmi3::{simulate3, Causality3, Fmu3, Inputs3, ModelDescription3, Request3};
use host::md::DefaultExperiment;

/// Runs `simulate` on an FMI 3.0 FMU.
pub fn run(a: Args) -> CliResult {
    let mut inputs = vec![a.fmu.as_path()];
    inputs.extend(a.data.as_deref());
    refuse_overwriting(&a.out, &inputs)?;
    let interface = crate::common::InterfaceArg::host(a.interface);
    let fmu = Fmu3::open_with(&a.fmu, interface).map_err(CliError::input)?;
    let md = fmu.model_description();
    let start_values = parse_sets3(md, &a.set)?;
    let experiment = md
        .default_experiment
        .as_ref()
        .map(DefaultExperiment::from)
        .unwrap_or_default();
    let inputs = match &a.data {
        Some(path) => read_inputs(path, md)?,
        None => Inputs3::default(),
    };
    let grid = time_grid(&a, &inputs.time, &experiment)?;
    let req = Request3 {
        start_values,
        tolerance: a.tolerance,
        inputs,
        record_events: true,
        ..Request3::new(grid.start, grid.stop, grid.step)
    };
    let res = simulate3(&fmu, &req).map_err(|e| run_error(&a.fmu.display().to_string(), e))?;
    write_csv_text(&a.out, &res.time, &res.names, &res.columns, &res.text)
        .map_err(|e| CliError::input(format!("{}: cannot write: {e}", a.out.display())))?;
    if let Some(t) = res.ended_by_fmu {
        eprintln!(
            "{}: the FMU ended the simulation at t = {t} ({} returned terminateSimulation); {} \
             rows up to that time written to {}",
            a.fmu.display(),
            match fmu.interface() {
                host::Interface::CoSimulation => "fmi3DoStep",
                host::Interface::ModelExchange => "the Model Exchange FMU",
            },
            res.time.len(),
            a.out.display()
        );
    }
    Ok(0)
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

/// The `--data` CSV as text columns: a variable's own column is read as text (an array's
/// elements separated by spaces, Binary as hex), any other (an element `u[2]`) as a number.
fn read_inputs(path: &std::path::Path, md: &ModelDescription3) -> Result<Inputs3, CliError> {
    let text: Vec<String> = md.variables.iter().map(|v| v.name.clone()).collect();
    let table = read_csv_with_text(path, &text).map_err(CliError::input)?;
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
