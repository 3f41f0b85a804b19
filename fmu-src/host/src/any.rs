//! An FMU of either version run with one request: what a caller that sets numbers, Booleans
//! and text and reads the outputs back (the gap workflow, experiment design) needs, without
//! knowing which version it drives.

use crate::csv::format_number;
use crate::error::Result;
use crate::fmi3::{Fmu3, Inputs3, Request3, Simulator3};
use crate::fmu::Fmu;
use crate::simulate::{InputSeries, SimulationRequest, SimulationResult, Simulator, Value};
use crate::view::ModelView;

/// An opened FMU of either version.
#[derive(Clone, Copy)]
pub enum FmuRef<'a> {
    /// FMI 2.0.
    Fmi2(&'a Fmu),
    /// FMI 3.0.
    Fmi3(&'a Fmu3),
}

impl<'a> FmuRef<'a> {
    /// The view of its model description.
    pub fn view(self) -> ModelView {
        match self {
            FmuRef::Fmi2(fmu) => ModelView::from(fmu.model_description()),
            FmuRef::Fmi3(fmu) => ModelView::from(fmu.model_description()),
        }
    }

    /// A reusable simulator of it (one instance, reset between runs).
    pub fn simulator(self) -> Result<AnySimulator<'a>> {
        Ok(match self {
            FmuRef::Fmi2(fmu) => AnySimulator::Fmi2(Simulator::new(fmu)?),
            FmuRef::Fmi3(fmu) => AnySimulator::Fmi3 {
                simulator: Simulator3::new(fmu)?,
                inputs: None,
            },
        })
    }
}

/// A reusable simulator of either version, run with a [`SimulationRequest`].
pub enum AnySimulator<'a> {
    /// FMI 2.0: the request as it is.
    Fmi2(Simulator<'a>),
    /// FMI 3.0: the request as text, which the host parses as each variable's type.
    Fmi3 {
        /// The simulator.
        simulator: Simulator3<'a>,
        /// The last inputs with their text form: calibration runs one data set many times, and
        /// its text is written once.
        inputs: Option<(InputSeries, Inputs3)>,
    },
}

impl AnySimulator<'_> {
    /// Runs one simulation of `req`.
    pub fn run(&mut self, req: &SimulationRequest) -> Result<SimulationResult> {
        match self {
            AnySimulator::Fmi2(simulator) => simulator.run(req),
            AnySimulator::Fmi3 { simulator, inputs } => {
                let text = match inputs {
                    Some((series, text)) if *series == req.inputs => text.clone(),
                    _ => inputs
                        .insert((req.inputs.clone(), inputs3(&req.inputs)))
                        .1
                        .clone(),
                };
                simulator.run(&request3(req, text))
            }
        }
    }
}

/// `req` for an FMI 3.0 run with the inputs `inputs`: start values as text.
fn request3(req: &SimulationRequest, inputs: Inputs3) -> Request3 {
    Request3 {
        start_values: req
            .start_values
            .iter()
            .map(|(name, value)| (name.clone(), text_of(value)))
            .collect(),
        tolerance: req.tolerance,
        inputs,
        outputs: req.outputs.clone(),
        record_events: req.record_events,
        ..Request3::new(req.start_time, req.stop_time, req.step)
    }
}

/// A start value as FMI 3.0 text: numbers in their shortest round-trip form (read back
/// exactly), Booleans `true`/`false`.
fn text_of(value: &Value) -> String {
    match value {
        Value::Real(x) => format_number(*x),
        Value::Boolean(b) => b.to_string(),
        Value::Text(s) => s.clone(),
    }
}

/// Input series as FMI 3.0 text columns: numbers in their shortest round-trip form.
fn inputs3(series: &InputSeries) -> Inputs3 {
    let numbers = series.columns.iter().map(|(name, column)| {
        let cells = column.iter().map(|&x| format_number(x)).collect();
        (name.clone(), cells)
    });
    Inputs3 {
        time: series.time.clone(),
        columns: numbers.chain(series.text.iter().cloned()).collect(),
    }
}
