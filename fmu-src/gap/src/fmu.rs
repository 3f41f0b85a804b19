//! The [`GridModel`] of an FMI 2.0 or FMI 3.0 Co-Simulation FMU through the `host` crate: the
//! measured inputs drive it (linearly interpolated at the communication points), the
//! communication step is the data's sample interval, and the outputs are compared at the data's
//! times. Both versions are read through the one view of their description ([`ModelView`], its
//! scalar variables), so the conventions (Boolean `<effect>.enabled`, Real `<effect>.<name>`,
//! `[calibrate]`) are read the same way.

use crate::sim::{GridModel, SimError};
use crate::spec::{ParamKind, ParamSpec};
use crate::workflow::{Data, GapError, InputError};
use host::csv::sample_interval;
use host::view::{Causality, ModelView, VarKind, Variability};
use host::{AnySimulator, FmuRef, InputSeries, SimulationRequest, SimulationResult, Value};
use std::sync::Mutex;

/// An FMU with the measured inputs and time grid.
pub struct FmuSimulator<'a> {
    fmu: FmuRef<'a>,
    /// Reusable simulators: one per thread running at a time.
    pool: Mutex<Vec<AnySimulator<'a>>>,
    params: Vec<ParamSpec>,
    outputs: Vec<String>,
    time: Vec<f64>,
    step: f64,
    inputs: InputSeries,
}

impl<'a> FmuSimulator<'a> {
    /// Settable variables are the parameters (fixed or tunable) and the inputs (whose start
    /// value applies when the data have no column for them); `view` is the view of `fmu`'s
    /// description.
    pub fn new(fmu: FmuRef<'a>, view: &ModelView, data: &Data) -> Result<Self, GapError> {
        let step = sample_interval(&data.time).ok_or(InputError::NoSampleInterval)?;
        Ok(FmuSimulator {
            fmu,
            pool: Mutex::new(Vec::new()),
            params: settable_params(view),
            // The workflow compares numbers: String outputs are not simulated for it.
            outputs: view
                .scalars_with(Causality::Output)
                .filter(|v| v.scalar_kind() != Some(VarKind::String))
                .map(|v| v.name.clone())
                .collect(),
            time: data.time.clone(),
            step,
            inputs: InputSeries {
                time: data.time.clone(),
                columns: data.inputs.clone(),
                ..Default::default()
            },
        })
    }

    /// The simulation request for `set` over the first `n` samples, recording the outputs the
    /// workflow compares.
    pub fn request(&self, set: &[(usize, f64)], n: usize) -> SimulationRequest {
        let mut req = SimulationRequest::new(self.time[0], self.time[n.max(2) - 1], self.step);
        req.start_values = set
            .iter()
            .map(|&(i, v)| {
                let p = &self.params[i];
                let val = match p.kind {
                    ParamKind::Boolean => Value::Boolean(v >= 0.5),
                    ParamKind::Integer => Value::Real(v.round()),
                    ParamKind::Real => Value::Real(v),
                };
                (p.name.clone(), val)
            })
            .collect();
        req.inputs = self.inputs.clone();
        req.outputs = self.outputs.clone();
        req
    }

    /// Takes a simulator from the pool (or makes one), runs `set` over the first `n` samples on
    /// it and puts it back.
    fn run(&self, set: &[(usize, f64)], n: usize) -> Result<SimulationResult, SimError> {
        let req = self.request(set, n);
        let popped = self.pool.lock().unwrap_or_else(|e| e.into_inner()).pop();
        let mut simulator = match popped {
            Some(s) => s,
            None => self.fmu.simulator()?,
        };
        let res = simulator.run(&req).map_err(SimError::from);
        self.pool
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(simulator);
        res
    }
}

/// The parameters (fixed or tunable) and inputs of `view` the workflow can set, with their
/// kind, start, range, unit and description.
fn settable_params(view: &ModelView) -> Vec<ParamSpec> {
    let mut params = Vec::new();
    for v in view.scalars() {
        let settable = (v.causality == Causality::Parameter
            && matches!(v.variability, Variability::Fixed | Variability::Tunable))
            || v.causality == Causality::Input;
        if !settable {
            continue;
        }
        let kind = match v.scalar_kind() {
            Some(VarKind::Real) => ParamKind::Real,
            Some(VarKind::Integer | VarKind::Enumeration) => ParamKind::Integer,
            Some(VarKind::Boolean) => ParamKind::Boolean,
            Some(VarKind::String) | None => continue,
        };
        // Inputs are never fitted or treated as effects: give them a description without
        // the calibration tag and a name that is what the FMU calls them.
        let description = if v.causality == Causality::Input {
            String::new()
        } else {
            v.description.clone().unwrap_or_default()
        };
        params.push(ParamSpec {
            name: v.name.clone(),
            kind,
            start: v.start_number().unwrap_or(0.0),
            min: v.min,
            max: v.max,
            unit: v.unit.clone().unwrap_or_default(),
            description,
        });
    }
    params
}

impl GridModel for FmuSimulator<'_> {
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }

    fn output_names(&self) -> &[String] {
        &self.outputs
    }

    fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        let res = self.run(set, n)?;
        // Outputs at the data's times: the communication points are start + k h, which match a
        // uniform grid; any other grid is interpolated.
        let t = &self.time[..n];
        let aligned = res.time.len() >= n
            && t.iter()
                .zip(&res.time)
                .all(|(a, b)| (a - b).abs() <= 1e-6 * self.step);
        let cols = self
            .outputs
            .iter()
            .map(|name| {
                let c = res
                    .column(name)
                    .ok_or_else(|| SimError::MissingOutput(name.clone()))?;
                if aligned {
                    Ok(c[..n].to_vec())
                } else {
                    let mut cur = 0;
                    Ok(t.iter()
                        .map(|&x| host::interpolate(&res.time, c, x, &mut cur))
                        .collect())
                }
            })
            .collect::<Result<Vec<_>, SimError>>()?;
        Ok(cols)
    }
}
