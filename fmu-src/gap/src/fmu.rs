//! The [`GridModel`] of an FMI 2.0 Co-Simulation FMU through the `host` crate: the measured
//! inputs drive it (linearly interpolated at the communication points), the communication step
//! is the data's sample interval, and the outputs are compared at the data's times.

use crate::sim::{GridModel, SimError};
use crate::spec::{ParamKind, ParamSpec};
use crate::workflow::{Data, GapError};
use host::csv::sample_interval;
use host::md::{Causality, VarKind, Variability};
use host::{Fmu, InputSeries, SimulationRequest, Value};
use std::sync::Mutex;

/// An FMU with the measured inputs and time grid.
pub struct FmuSimulator<'a> {
    fmu: &'a Fmu,
    params: Vec<ParamSpec>,
    outputs: Vec<String>,
    time: Vec<f64>,
    step: f64,
    inputs: InputSeries,
    pool: Mutex<Vec<host::Simulator<'a>>>,
}

impl<'a> FmuSimulator<'a> {
    /// Settable variables are the parameters (fixed or tunable) and the inputs (whose start
    /// value applies when the data have no column for them).
    pub fn new(fmu: &'a Fmu, data: &Data) -> Result<Self, GapError> {
        let md = fmu.model_description();
        let mut params = Vec::new();
        for v in &md.model_variables {
            let settable = (v.causality == Causality::Parameter
                && matches!(v.variability, Variability::Fixed | Variability::Tunable))
                || v.causality == Causality::Input;
            if !settable {
                continue;
            }
            let kind = match v.kind {
                VarKind::Real => ParamKind::Real,
                VarKind::Integer | VarKind::Enumeration => ParamKind::Integer,
                VarKind::Boolean => ParamKind::Boolean,
                VarKind::String => continue,
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
                start: v.start.as_ref().and_then(|s| s.as_f64()).unwrap_or(0.0),
                min: v.min,
                max: v.max,
                unit: md.effective_unit(v).unwrap_or("").to_string(),
                description,
            });
        }
        let step = sample_interval(&data.time)
            .ok_or_else(|| GapError::Usage("the data need at least two rows".into()))?;
        Ok(FmuSimulator {
            fmu,
            params,
            // The workflow compares numbers: String outputs are not simulated for it.
            outputs: md
                .with_causality(Causality::Output)
                .filter(|v| v.kind != VarKind::String)
                .map(|v| v.name.clone())
                .collect(),
            time: data.time.clone(),
            step,
            inputs: InputSeries {
                time: data.time.clone(),
                columns: data.inputs.clone(),
                ..Default::default()
            },
            pool: Mutex::new(Vec::new()),
        })
    }

    /// The simulation request for `set` over the first `n` samples.
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
        req
    }
}

impl GridModel for FmuSimulator<'_> {
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }

    fn output_names(&self) -> &[String] {
        &self.outputs
    }

    fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        let req = self.request(set, n);
        let popped = self.pool.lock().unwrap_or_else(|e| e.into_inner()).pop();
        let mut sim = match popped {
            Some(s) => s,
            None => host::Simulator::new(self.fmu)?,
        };
        let res = sim.run(&req).map_err(SimError::from);
        self.pool
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(sim);
        let res = res?;
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
