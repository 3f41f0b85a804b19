//! The FMI 2.0 binding of the Model Exchange loop: the `fmi2*` Model Exchange calls on an
//! [`Instance`] made with `fmi2ModelExchange`.

use crate::error::{HostError, Result, Status};
use crate::ffi::{EventInfo as RawEventInfo, Fmi2Boolean, MeFunctions, RawStatus, StateVector};
use crate::instance::{missing, Instance};
use crate::md::ModelDescription;
use crate::me::{
    derivatives_taken, Bound, EventInfo, ModelExchange, Settings, StateSlice, StepOutcome,
};
use crate::run::{self, ModelExchangeOf};
use crate::simulate::{InputPlan, Recorder};
use crate::watch::{self, Call};

/// An FMI 2.0 Model Exchange instance with its state and derivative value references.
pub struct Fmi2Me<'i, 'a> {
    inst: &'i mut Instance<'a>,
    f: MeFunctions,
    /// Value references of the states, in the order of `<Derivatives>` (FMI 2.0.4 section
    /// 2.2.8: that order is the order of the continuous-state vector).
    state_vrs: Vec<u32>,
    /// Value references of the derivatives, same order.
    derivative_vrs: Vec<u32>,
    /// The sizes, the step flag and each derivative's states (`<Derivatives>` `dependencies`,
    /// inputs left out).
    bound: Bound,
    directional: bool,
    /// Scratch of the directional derivative calls: the knowns' value references and seed.
    known: Vec<u32>,
    seed: Vec<f64>,
    /// The time of the last `fmi2SetTime` (for the call marks).
    time: f64,
}

impl<'i, 'a> Fmi2Me<'i, 'a> {
    /// Binds `inst`, which must have been instantiated as Model Exchange.
    pub fn new(inst: &'i mut Instance<'a>) -> Result<Self> {
        let fmu = inst.fmu;
        let f = fmu
            .functions
            .me
            .ok_or_else(|| missing("the Model Exchange functions"))?;
        let md = fmu.model_description();
        let (state_vrs, derivative_vrs) = state_references(md)?;
        let me = md.model_exchange.as_ref();
        let bound = Bound {
            states: state_vrs.len(),
            indicators: md.number_of_event_indicators.unwrap_or(0) as usize,
            needs_step: !me.is_some_and(|m| m.completed_integrator_step_not_needed),
            dependencies: state_dependencies(md),
        };
        Ok(Fmi2Me {
            bound,
            known: Vec::new(),
            seed: Vec::new(),
            f,
            state_vrs,
            derivative_vrs,
            directional: me.is_some_and(|m| m.provides_directional_derivative)
                && fmu.functions.get_directional_derivative.is_some(),
            time: 0.0,
            inst,
        })
    }

    fn call(&mut self, name: &'static str, raw: RawStatus) -> Result<Status> {
        self.inst.check(name, raw)
    }

    /// Calls `f`, a function taking a vector of the states' size, on `x` (watched as `call`).
    fn vector<S: StateSlice>(&mut self, call: Call, f: StateVector<S::Ptr>, x: S) -> RawStatus {
        let _w = watch::enter(call, Some(self.time));
        let (ptr, len) = x.raw();
        // SAFETY: ptr points to len elements (StateSlice); live Model Exchange instance.
        unsafe { f(self.inst.component, ptr, len) }
    }
}

/// (state, derivative) value references from `<ModelStructure><Derivatives>`: each derivative
/// names its state with the `derivative` attribute (1-based index into ModelVariables).
fn state_references(md: &ModelDescription) -> Result<(Vec<u32>, Vec<u32>)> {
    let bad = |m: String| HostError::Request(format!("Model Exchange: {m}"));
    let mut states = Vec::new();
    let mut derivatives = Vec::new();
    for u in &md.model_structure.derivatives {
        let d = md
            .model_variables
            .get(u.index.wrapping_sub(1))
            .ok_or_else(|| bad(format!("<Derivatives> index {} is no variable", u.index)))?;
        let s = d
            .derivative
            .and_then(|k| md.model_variables.get(k.wrapping_sub(1)))
            .ok_or_else(|| {
                bad(format!(
                    "derivative '{}' does not name its state (derivative attribute)",
                    d.name
                ))
            })?;
        states.push(s.value_reference);
        derivatives.push(d.value_reference);
    }
    Ok((states, derivatives))
}

/// Per derivative of `<Derivatives>`: the positions in the state vector of the states among its
/// `dependencies` (1-based ModelVariables indices; inputs are not states and left out), `None`
/// when the attribute is absent (FMI 2.0.4 section 2.2.8: it may then depend on every known).
fn state_dependencies(md: &ModelDescription) -> Vec<Option<Vec<usize>>> {
    let derivatives = &md.model_structure.derivatives;
    // the state of each derivative as its 1-based variable index
    let states: Vec<Option<usize>> = derivatives
        .iter()
        .map(|u| {
            md.model_variables
                .get(u.index.wrapping_sub(1))
                .and_then(|d| d.derivative)
        })
        .collect();
    derivatives
        .iter()
        .map(|u| {
            let deps = u.dependencies.as_ref()?;
            Some(
                deps.iter()
                    .filter_map(|&v| states.iter().position(|&s| s == Some(v)))
                    .collect(),
            )
        })
        .collect()
}

fn flag(b: Fmi2Boolean) -> bool {
    b != 0
}

impl ModelExchange for Fmi2Me<'_, '_> {
    fn bound(&self) -> &Bound {
        &self.bound
    }

    fn set_time(&mut self, t: f64) -> Result<()> {
        self.time = t;
        let _w = watch::enter(Call::SetTime, Some(t));
        // SAFETY: live Model Exchange instance of this binary.
        let raw = unsafe { (self.f.set_time)(self.inst.component, t) };
        self.call("fmi2SetTime", raw).map(drop)
    }

    fn set_states(&mut self, x: &[f64]) -> Result<()> {
        let raw = self.vector(Call::SetContinuousStates, self.f.set_continuous_states, x);
        self.call("fmi2SetContinuousStates", raw).map(drop)
    }

    fn get_states(&mut self, x: &mut [f64]) -> Result<()> {
        let raw = self.vector(Call::GetContinuousStates, self.f.get_continuous_states, x);
        self.call("fmi2GetContinuousStates", raw).map(drop)
    }

    fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<bool> {
        let raw = self.vector(Call::GetDerivatives, self.f.get_derivatives, dx);
        derivatives_taken(self.call("fmi2GetDerivatives", raw))
    }

    fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<()> {
        let raw = self.vector(Call::GetEventIndicators, self.f.get_event_indicators, z);
        self.call("fmi2GetEventIndicators", raw).map(drop)
    }

    fn get_nominals(&mut self, x: &mut [f64]) -> Result<()> {
        let raw = self.vector(
            Call::GetNominals,
            self.f.get_nominals_of_continuous_states,
            x,
        );
        self.call("fmi2GetNominalsOfContinuousStates", raw)
            .map(drop)
    }

    fn enter_event_mode(&mut self) -> Result<()> {
        let _w = watch::enter(Call::EnterEventMode, Some(self.time));
        // SAFETY: live Model Exchange instance of this binary.
        let raw = unsafe { (self.f.enter_event_mode)(self.inst.component) };
        self.call("fmi2EnterEventMode", raw).map(drop)
    }

    fn new_discrete_states(&mut self) -> Result<EventInfo> {
        let mut info = RawEventInfo::default();
        let _w = watch::enter(Call::NewDiscreteStates, Some(self.time));
        // SAFETY: info is a valid fmi2EventInfo.
        let raw = unsafe { (self.f.new_discrete_states)(self.inst.component, &mut info) };
        self.call("fmi2NewDiscreteStates", raw)?;
        Ok(EventInfo {
            new_discrete_states_needed: flag(info.new_discrete_states_needed),
            terminate_simulation: flag(info.terminate_simulation),
            nominals_changed: flag(info.nominals_of_continuous_states_changed),
            values_changed: flag(info.values_of_continuous_states_changed),
            next_event_time: flag(info.next_event_time_defined).then_some(info.next_event_time),
        })
    }

    fn enter_continuous_time_mode(&mut self) -> Result<()> {
        let _w = watch::enter(Call::EnterContinuousTimeMode, Some(self.time));
        // SAFETY: live Model Exchange instance of this binary.
        let raw = unsafe { (self.f.enter_continuous_time_mode)(self.inst.component) };
        self.call("fmi2EnterContinuousTimeMode", raw).map(drop)
    }

    fn completed_integrator_step(&mut self) -> Result<StepOutcome> {
        let (mut enter, mut terminate): (Fmi2Boolean, Fmi2Boolean) = (0, 0);
        let _w = watch::enter(Call::CompletedIntegratorStep, Some(self.time));
        // SAFETY: valid out pointers. noSetFMUStatePriorToCurrentPoint: the host never goes back.
        let raw = unsafe {
            (self.f.completed_integrator_step)(self.inst.component, 1, &mut enter, &mut terminate)
        };
        self.call("fmi2CompletedIntegratorStep", raw)?;
        Ok(StepOutcome {
            enter_event_mode: flag(enter),
            terminate_simulation: flag(terminate),
        })
    }

    fn provides_directional_derivative(&self) -> bool {
        self.directional
    }

    fn state_derivative_seed(&mut self, columns: &[usize], out: &mut [f64]) -> Result<()> {
        let f = self
            .inst
            .fmu
            .functions
            .get_directional_derivative
            .ok_or_else(|| missing("fmi2GetDirectionalDerivative"))?;
        if out.len() != self.derivative_vrs.len() {
            return Err(HostError::Request(
                "Jacobian column of the wrong length".into(),
            ));
        }
        self.known.clear();
        self.known
            .extend(columns.iter().map(|&j| self.state_vrs[j]));
        self.seed.resize(columns.len(), 1.0);
        let _w = watch::enter(Call::DirectionalDerivative, Some(self.time));
        // SAFETY: vUnknown_ref/dvUnknown have out.len() elements, vKnown_ref/dvKnown
        // columns.len().
        let raw = unsafe {
            f(
                self.inst.component,
                self.derivative_vrs.as_ptr(),
                self.derivative_vrs.len(),
                self.known.as_ptr(),
                self.known.len(),
                self.seed.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        self.call("fmi2GetDirectionalDerivative", raw).map(drop)
    }
}

impl<'a> ModelExchangeOf for Fmi2Me<'_, 'a> {
    type Instance = Instance<'a>;

    fn instance(&mut self) -> &mut Instance<'a> {
        self.inst
    }
}

/// Integrates `inst` (instantiated as Model Exchange, initialized) from `settings.start` with
/// [`run::integrate`]: the recorded times and, when the FMU ended the run, its time.
pub(crate) fn integrate(
    inst: &mut Instance<'_>,
    settings: &Settings,
    inputs: &mut InputPlan<'_>,
    recorder: &mut Recorder,
) -> Result<(Vec<f64>, Option<f64>)> {
    let mut fmu = Fmi2Me::new(inst)?;
    fmu.time = settings.start;
    run::integrate(&mut fmu, settings, inputs, recorder)
}
