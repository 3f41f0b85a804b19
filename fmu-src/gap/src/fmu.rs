//! The [`GridModel`] of an FMI 2.0 or FMI 3.0 Co-Simulation FMU through the `host` crate: the
//! measured inputs drive it (linearly interpolated at the communication points), the
//! communication step is the data's sample interval, and the outputs are compared at the data's
//! times. Both versions are read through the one view of their description ([`ModelView`], its
//! scalar variables), so the conventions (Boolean `<effect>.enabled`, Real `<effect>.<name>`,
//! `[calibrate]`) are read the same way.

use crate::sim::{GridModel, SimError};
use crate::spec::{ParamKind, ParamSpec};
use crate::workflow::{Data, GapError};
use host::csv::{format_number, sample_interval};
use host::fmi3::{Fmu3, Inputs3, Request3, Simulator3};
use host::view::{Causality, ModelView, VarKind, Variability};
use host::{Fmu, InputSeries, SimulationRequest, SimulationResult, Value};
use std::sync::Mutex;

/// The FMU a [`FmuSimulator`] runs, with a pool of reusable instances.
enum Backend<'a> {
    Fmi2 {
        fmu: &'a Fmu,
        pool: Mutex<Vec<host::Simulator<'a>>>,
    },
    Fmi3 {
        fmu: &'a Fmu3,
        pool: Mutex<Vec<Simulator3<'a>>>,
        /// The measured inputs as FMI 3.0 input columns.
        inputs: Inputs3,
    },
}

/// Takes an instance from `pool` (or makes one), runs `run` on it and puts it back.
fn pooled<S>(
    pool: &Mutex<Vec<S>>,
    make: impl FnOnce() -> host::Result<S>,
    run: impl FnOnce(&mut S) -> host::Result<SimulationResult>,
) -> Result<SimulationResult, SimError> {
    let popped = pool.lock().unwrap_or_else(|e| e.into_inner()).pop();
    let mut sim = match popped {
        Some(s) => s,
        None => make()?,
    };
    let res = run(&mut sim).map_err(SimError::from);
    pool.lock().unwrap_or_else(|e| e.into_inner()).push(sim);
    res
}

/// An FMU with the measured inputs and time grid.
pub struct FmuSimulator<'a> {
    backend: Backend<'a>,
    params: Vec<ParamSpec>,
    outputs: Vec<String>,
    time: Vec<f64>,
    step: f64,
    inputs: InputSeries,
}

impl<'a> FmuSimulator<'a> {
    /// Settable variables are the parameters (fixed or tunable) and the inputs (whose start
    /// value applies when the data have no column for them).
    /// `view` is the view of `fmu`'s description.
    pub fn new(fmu: &'a Fmu, view: &ModelView, data: &Data) -> Result<Self, GapError> {
        let backend = Backend::Fmi2 {
            fmu,
            pool: Mutex::new(Vec::new()),
        };
        Self::with_backend(backend, view, data)
    }

    /// [`FmuSimulator::new`] for an FMI 3.0 FMU.
    pub fn new3(fmu: &'a Fmu3, view: &ModelView, data: &Data) -> Result<Self, GapError> {
        let inputs = Inputs3 {
            time: data.time.clone(),
            columns: data
                .inputs
                .iter()
                .map(|(n, c)| (n.clone(), c.iter().map(|&x| format_number(x)).collect()))
                .collect(),
        };
        let backend = Backend::Fmi3 {
            fmu,
            pool: Mutex::new(Vec::new()),
            inputs,
        };
        Self::with_backend(backend, view, data)
    }

    fn with_backend(backend: Backend<'a>, md: &ModelView, data: &Data) -> Result<Self, GapError> {
        let mut params = Vec::new();
        for v in md.scalars() {
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
        let step = sample_interval(&data.time)
            .ok_or_else(|| GapError::Usage("the data need at least two rows".into()))?;
        Ok(FmuSimulator {
            backend,
            params,
            // The workflow compares numbers: String outputs are not simulated for it.
            outputs: md
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

    /// The FMI 3.0 request for `set` over the first `n` samples: the same start values as
    /// text (Booleans `true`/`false`, integers without a fraction).
    fn request3(&self, set: &[(usize, f64)], n: usize, inputs: &Inputs3) -> Request3 {
        let mut req = Request3::new(self.time[0], self.time[n.max(2) - 1], self.step);
        req.start_values = set
            .iter()
            .map(|&(i, v)| {
                let p = &self.params[i];
                let text = match p.kind {
                    ParamKind::Boolean => (v >= 0.5).to_string(),
                    ParamKind::Integer => format_number(v.round()),
                    ParamKind::Real => format_number(v),
                };
                (p.name.clone(), text)
            })
            .collect();
        req.inputs = inputs.clone();
        req.outputs = self.outputs.clone();
        req
    }

    fn run(&self, set: &[(usize, f64)], n: usize) -> Result<SimulationResult, SimError> {
        match &self.backend {
            Backend::Fmi2 { fmu, pool } => {
                let req = self.request(set, n);
                pooled(pool, || host::Simulator::new(fmu), |s| s.run(&req))
            }
            Backend::Fmi3 { fmu, pool, inputs } => {
                let req = self.request3(set, n, inputs);
                pooled(pool, || Simulator3::new(fmu), |s| s.run(&req))
            }
        }
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
