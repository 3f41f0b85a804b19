//! The FMI 3.0 binding of the Model Exchange loop: the `fmi3*` Model Exchange calls (FMI 3.0.2
//! section 3) on an [`Instance3`] made with `fmi3InstantiateModelExchange`, and the loop run
//! after initialization with the inputs and recorder of [`crate::fmi3`]'s runs.

use crate::error::{HostError, Result};
use crate::ffi::function_table;
use crate::fmi3::ffi::{
    update_discrete_states, Bool3, Call3, RawStatus3, StateVector3, UpdateDiscreteStates3,
};
use crate::fmi3::instance::Instance3;
use crate::fmi3::simulate::{InputPlan3, Recorder3, Request3};
use crate::me::clocks::ClockSchedule;
use crate::me::{derivatives_taken, Bound, EventInfo, ModelExchange, StateSlice, StepOutcome};
use crate::run::{self, ModelExchangeOf};
use crate::watch::{self, Call};
use std::ffi::c_void;

type I = *mut c_void;

function_table! {
    /// The FMI 3.0 Model Exchange functions (FMI 3.0.2 section 3.2).
    pub struct MeFunctions3 {
        enter_event_mode: required "fmi3EnterEventMode" Call3,
        update_discrete_states: required "fmi3UpdateDiscreteStates" UpdateDiscreteStates3,
        enter_continuous_time_mode: required "fmi3EnterContinuousTimeMode" Call3,
        completed_integrator_step: required "fmi3CompletedIntegratorStep"
            unsafe extern "C" fn(I, Bool3, *mut Bool3, *mut Bool3) -> RawStatus3,
        set_time: required "fmi3SetTime" unsafe extern "C" fn(I, f64) -> RawStatus3,
        set_continuous_states: required "fmi3SetContinuousStates" StateVector3<*const f64>,
        get_continuous_state_derivatives: required "fmi3GetContinuousStateDerivatives"
            StateVector3<*mut f64>,
        get_event_indicators: required "fmi3GetEventIndicators" StateVector3<*mut f64>,
        get_continuous_states: required "fmi3GetContinuousStates" StateVector3<*mut f64>,
        get_nominals_of_continuous_states: required "fmi3GetNominalsOfContinuousStates"
            StateVector3<*mut f64>,
        get_number_of_event_indicators: required "fmi3GetNumberOfEventIndicators"
            unsafe extern "C" fn(I, *mut usize) -> RawStatus3,
        get_number_of_continuous_states: required "fmi3GetNumberOfContinuousStates"
            unsafe extern "C" fn(I, *mut usize) -> RawStatus3,
        get_directional_derivative: optional "fmi3GetDirectionalDerivative"
            unsafe extern "C" fn(
                I,
                *const u32,
                usize,
                *const u32,
                usize,
                *const f64,
                usize,
                *mut f64,
                usize,
            ) -> RawStatus3,
    }
    given {}
}

/// An FMI 3.0 Model Exchange instance with its state and derivative value references.
pub struct Fmi3Me<'i, 'a> {
    inst: &'i mut Instance3<'a>,
    f: MeFunctions3,
    /// The sizes, the step flag and each derivative's states (`dependencies` of its
    /// `<ContinuousStateDerivative>`, inputs left out; none without directional derivatives).
    bound: Bound,
    /// (state, derivative) value references when every state is a scalar and the FMU provides
    /// directional derivatives (FMI 3.0.2 section 2.4.8: `<ContinuousStateDerivative>` in the
    /// order of the state vector, each naming its state with `derivative`).
    directional: Option<(Vec<u32>, Vec<u32>)>,
    /// Scratch of the directional derivative calls: the knowns' value references and seed.
    known: Vec<u32>,
    seed: Vec<f64>,
    time: f64,
    /// The periodic input clocks and their next ticks.
    clocks: ClockSchedule,
}

impl<'i, 'a> Fmi3Me<'i, 'a> {
    /// Binds `inst`, which must have been instantiated as Model Exchange.
    pub fn new(inst: &'i mut Instance3<'a>) -> Result<Self> {
        let f = inst.fmu.functions.me.ok_or_else(|| {
            HostError::Request("the FMU binary does not export the Model Exchange functions".into())
        })?;
        let mut me = Fmi3Me {
            f,
            bound: Bound::default(),
            directional: None,
            known: Vec::new(),
            seed: Vec::new(),
            time: 0.0,
            clocks: ClockSchedule::default(),
            inst,
        };
        me.bound.states = me.count(
            f.get_number_of_continuous_states,
            "fmi3GetNumberOfContinuousStates",
        )?;
        me.bound.indicators = me.count(
            f.get_number_of_event_indicators,
            "fmi3GetNumberOfEventIndicators",
        )?;
        let md = me.inst.fmu.model_description();
        let element = md.model_exchange.as_ref();
        me.bound.needs_step = element.is_some_and(|e| e.flag("needsCompletedIntegratorStep"));
        let provides = element.is_some_and(|e| e.flag("providesDirectionalDerivatives"))
            && f.get_directional_derivative.is_some();
        let mut states = Vec::new();
        let mut derivatives = Vec::new();
        for u in &md.model_structure.continuous_state_derivatives {
            let scalar = |vr: u32| md.by_vr(vr).is_some_and(|v| !v.is_array());
            match md.by_vr(u.value_reference).and_then(|d| d.derivative) {
                Some(s) if scalar(s) && scalar(u.value_reference) => {
                    states.push(s);
                    derivatives.push(u.value_reference);
                }
                _ => break,
            }
        }
        if provides && states.len() == me.bound.states {
            // FMI 3.0.2 section 2.4.8: dependencies by value reference, absent: every known
            me.bound.dependencies = md
                .model_structure
                .continuous_state_derivatives
                .iter()
                .map(|u| {
                    let deps = u.dependencies.as_ref()?;
                    Some(
                        deps.iter()
                            .filter_map(|vr| states.iter().position(|s| s == vr))
                            .collect(),
                    )
                })
                .collect();
            me.directional = Some((states, derivatives));
        }
        Ok(me)
    }

    fn count(
        &mut self,
        f: unsafe extern "C" fn(I, *mut usize) -> RawStatus3,
        name: &'static str,
    ) -> Result<usize> {
        let mut n = 0usize;
        let _w = watch::enter3(Call::Other, None);
        // SAFETY: live instance, valid out pointer.
        let raw = unsafe { f(self.inst.instance, &mut n) };
        self.inst.check(name, raw)?;
        Ok(n)
    }

    fn call(&mut self, name: &'static str, raw: RawStatus3) -> Result<()> {
        self.inst.check(name, raw).map(drop)
    }

    /// Calls `f`, a function taking a vector of the states' size, on `x` (watched as `call`).
    fn vector<S: StateSlice>(&mut self, call: Call, f: StateVector3<S::Ptr>, x: S) -> RawStatus3 {
        let _w = watch::enter3(call, Some(self.time));
        let (ptr, len) = x.raw();
        // SAFETY: ptr points to len elements (StateSlice); live Model Exchange instance.
        unsafe { f(self.inst.instance, ptr, len) }
    }
}

impl ModelExchange for Fmi3Me<'_, '_> {
    fn bound(&self) -> &Bound {
        &self.bound
    }

    fn set_time(&mut self, t: f64) -> Result<()> {
        self.time = t;
        let _w = watch::enter3(Call::SetTime, Some(t));
        // SAFETY: live Model Exchange instance.
        let raw = unsafe { (self.f.set_time)(self.inst.instance, t) };
        self.call("fmi3SetTime", raw)
    }

    fn set_states(&mut self, x: &[f64]) -> Result<()> {
        let raw = self.vector(Call::SetContinuousStates, self.f.set_continuous_states, x);
        self.call("fmi3SetContinuousStates", raw)
    }

    fn get_states(&mut self, x: &mut [f64]) -> Result<()> {
        let raw = self.vector(Call::GetContinuousStates, self.f.get_continuous_states, x);
        self.call("fmi3GetContinuousStates", raw)
    }

    fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<bool> {
        let raw = self.vector(
            Call::GetDerivatives,
            self.f.get_continuous_state_derivatives,
            dx,
        );
        derivatives_taken(self.inst.check("fmi3GetContinuousStateDerivatives", raw))
    }

    fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<()> {
        let raw = self.vector(Call::GetEventIndicators, self.f.get_event_indicators, z);
        self.call("fmi3GetEventIndicators", raw)
    }

    fn get_nominals(&mut self, x: &mut [f64]) -> Result<()> {
        let raw = self.vector(
            Call::GetNominals,
            self.f.get_nominals_of_continuous_states,
            x,
        );
        self.call("fmi3GetNominalsOfContinuousStates", raw)
    }

    fn enter_event_mode(&mut self) -> Result<()> {
        let _w = watch::enter3(Call::EnterEventMode, Some(self.time));
        // SAFETY: live Model Exchange instance.
        let raw = unsafe { (self.f.enter_event_mode)(self.inst.instance) };
        self.call("fmi3EnterEventMode", raw)
    }

    fn new_discrete_states(&mut self) -> Result<EventInfo> {
        let f = self.f.update_discrete_states;
        let (raw, u) = update_discrete_states(f, self.inst.instance, self.time);
        self.call("fmi3UpdateDiscreteStates", raw)?;
        Ok(EventInfo {
            new_discrete_states_needed: u.needed,
            terminate_simulation: u.terminate,
            nominals_changed: u.nominals_changed,
            values_changed: u.values_changed,
            next_event_time: u.next_event_time,
        })
    }

    fn enter_continuous_time_mode(&mut self) -> Result<()> {
        let _w = watch::enter3(Call::EnterContinuousTimeMode, Some(self.time));
        // SAFETY: live Model Exchange instance.
        let raw = unsafe { (self.f.enter_continuous_time_mode)(self.inst.instance) };
        self.call("fmi3EnterContinuousTimeMode", raw)
    }

    fn completed_integrator_step(&mut self) -> Result<StepOutcome> {
        let (mut enter, mut terminate) = (0 as Bool3, 0 as Bool3);
        let _w = watch::enter3(Call::CompletedIntegratorStep, Some(self.time));
        // SAFETY: valid out pointers; the host never sets an earlier state.
        let raw = unsafe {
            (self.f.completed_integrator_step)(self.inst.instance, 1, &mut enter, &mut terminate)
        };
        self.call("fmi3CompletedIntegratorStep", raw)?;
        Ok(StepOutcome {
            enter_event_mode: enter != 0,
            terminate_simulation: terminate != 0,
        })
    }

    fn activate_clocks(&mut self, t: f64) -> Result<Vec<u32>> {
        let due = self.clocks.due(t);
        if !due.is_empty() {
            ClockSchedule::activate(self.inst, &due, t)?;
        }
        Ok(due)
    }

    fn inquire_clocks(&mut self, t: f64) -> Result<Vec<u32>> {
        self.clocks.inquire(self.inst, t)
    }

    fn clocks_after_event(&mut self, t: f64, ticked: &[u32]) -> Result<()> {
        self.clocks.after_event(self.inst, t, ticked)
    }

    fn next_clock_tick(&self) -> Option<f64> {
        self.clocks.next_tick()
    }

    fn provides_directional_derivative(&self) -> bool {
        self.directional.is_some()
    }

    fn state_derivative_seed(&mut self, columns: &[usize], out: &mut [f64]) -> Result<()> {
        let (Some(f), Some((states, derivatives))) =
            (self.f.get_directional_derivative, self.directional.as_ref())
        else {
            return Err(HostError::Request(
                "the FMU provides no directional derivatives".into(),
            ));
        };
        if out.len() != derivatives.len() {
            return Err(HostError::Request(
                "Jacobian column of the wrong length".into(),
            ));
        }
        self.known.clear();
        self.known.extend(columns.iter().map(|&j| states[j]));
        self.seed.resize(columns.len(), 1.0);
        let _w = watch::enter3(Call::DirectionalDerivative, Some(self.time));
        // SAFETY: unknowns/sensitivity have out.len() elements, knowns/seed columns.len().
        let raw = unsafe {
            f(
                self.inst.instance,
                derivatives.as_ptr(),
                derivatives.len(),
                self.known.as_ptr(),
                self.known.len(),
                self.seed.as_ptr(),
                self.seed.len(),
                out.as_mut_ptr(),
                out.len(),
            )
        };
        self.call("fmi3GetDirectionalDerivative", raw)
    }
}

impl<'a> ModelExchangeOf for Fmi3Me<'_, 'a> {
    type Instance = Instance3<'a>;

    fn instance(&mut self) -> &mut Instance3<'a> {
        self.inst
    }
}

/// Runs [`run::integrate`] on `inst` (initialized, in Event Mode) with the input clocks of
/// `clocks`: the recorded times and, when the FMU ended the run, its time.
pub(crate) fn run(
    inst: &mut Instance3<'_>,
    req: &Request3,
    (inputs, clocks): (&mut InputPlan3<'_>, ClockSchedule),
    recorder: &mut Recorder3,
) -> Result<(Vec<f64>, Option<f64>)> {
    let md = inst.fmu.model_description();
    let settings = run::me_settings(
        (req.start_time, req.stop_time, req.step),
        req.tolerance,
        md.default_experiment.as_ref().and_then(|d| d.tolerance),
        req.record_events,
    )?;
    let mut fmu = Fmi3Me::new(inst)?;
    fmu.time = req.start_time;
    fmu.clocks = clocks;
    run::integrate(&mut fmu, &settings, inputs, recorder)
}
