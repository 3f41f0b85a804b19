//! The FMI 2.0 Model Exchange functions (FMI 2.0.4 section 3.2) and the directional derivative
//! of both interfaces, over the instance's ([`fmu_core::me_instance`],
//! [`fmu_core::directional`]).

#![allow(clippy::missing_safety_doc)]

use crate::calls;
use crate::ffi::{
    checked, Fmi2Boolean, Fmi2Component, Fmi2Logger, Fmi2Real, Fmi2Status, Fmi2ValueReference,
};
use fmu_core::glue::{slice, slice_mut, Logger};
use fmu_core::machine::Call;
use fmu_core::{Checked, EventInfo, Instance, Model, Status};

/// `fmi2EventInfo` of `fmi2FunctionTypes.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct Fmi2EventInfo {
    pub new_discrete_states_needed: Fmi2Boolean,
    pub terminate_simulation: Fmi2Boolean,
    pub nominals_of_continuous_states_changed: Fmi2Boolean,
    pub values_of_continuous_states_changed: Fmi2Boolean,
    pub next_event_time_defined: Fmi2Boolean,
    pub next_event_time: Fmi2Real,
}

impl From<EventInfo> for Fmi2EventInfo {
    fn from(e: EventInfo) -> Self {
        Fmi2EventInfo {
            new_discrete_states_needed: e.new_discrete_states_needed as Fmi2Boolean,
            terminate_simulation: e.terminate_simulation as Fmi2Boolean,
            nominals_of_continuous_states_changed: e.nominals_of_continuous_states_changed
                as Fmi2Boolean,
            values_of_continuous_states_changed: e.values_of_continuous_states_changed
                as Fmi2Boolean,
            next_event_time_defined: e.next_event_time.is_some() as Fmi2Boolean,
            next_event_time: e.next_event_time.unwrap_or(0.0),
        }
    }
}

/// `fmi2SetTime`.
pub unsafe fn set_time<M: Model>(c: Fmi2Component, t: Fmi2Real) -> Fmi2Status {
    checked::<M>(c, calls::SET_TIME, |i, call| i.set_time(call, t))
}

/// `fmi2SetContinuousStates`.
pub unsafe fn set_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *const Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    let call = calls::SET_CONTINUOUS_STATES;
    Fmi2Logger::with::<M>(c, call.name, |comp| match slice(x, nx) {
        Some(x) => comp
            .instance
            .call(call, |i, call| i.set_continuous_states(call, x)),
        None => comp.instance.error(call.name, "x is NULL"),
    })
}

/// `fmi2EnterEventMode`.
pub unsafe fn enter_event_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    checked::<M>(c, calls::ENTER_EVENT_MODE, |i, call| {
        i.enter_event_mode(call)
    })
}

/// `fmi2EnterContinuousTimeMode`.
pub unsafe fn enter_continuous_time_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    checked::<M>(c, calls::ENTER_CONTINUOUS_TIME_MODE, |i, call| {
        i.enter_continuous_time_mode(call)
    })
}

/// `fmi2NewDiscreteStates`.
pub unsafe fn new_discrete_states<M: Model>(
    c: Fmi2Component,
    info: *mut Fmi2EventInfo,
) -> Fmi2Status {
    let call = calls::NEW_DISCRETE_STATES;
    Fmi2Logger::with::<M>(c, call.name, |comp| {
        let Some(info) = info.as_mut() else {
            return comp.instance.error(call.name, "fmi2eventInfo is NULL");
        };
        let mut e = EventInfo::default();
        let s = comp
            .instance
            .call(call, |i, call| i.new_discrete_states(call, &mut e));
        if s == Status::Ok {
            *info = e.into();
        }
        s
    })
}

/// `fmi2CompletedIntegratorStep`.
pub unsafe fn completed_integrator_step<M: Model>(
    c: Fmi2Component,
    _no_set_prior: Fmi2Boolean,
    enter_event_mode: *mut Fmi2Boolean,
    terminate_simulation: *mut Fmi2Boolean,
) -> Fmi2Status {
    let call = calls::COMPLETED_INTEGRATOR_STEP;
    Fmi2Logger::with::<M>(c, call.name, |comp| {
        let (Some(event), Some(terminate)) =
            (enter_event_mode.as_mut(), terminate_simulation.as_mut())
        else {
            return comp
                .instance
                .error(call.name, "enterEventMode or terminateSimulation is NULL");
        };
        comp.instance.call(call, |i, call| {
            let (s, enter, stop) = i.completed_integrator_step(call);
            if s == Status::Ok {
                *event = enter as Fmi2Boolean;
                *terminate = stop as Fmi2Boolean;
            }
            s
        })
    })
}

/// Shared body of the four functions that fill a real array of the model's size.
unsafe fn get_array<M: Model>(
    c: Fmi2Component,
    call: Call,
    (p, n): (*mut Fmi2Real, usize),
    get: impl FnOnce(&mut Instance<M>, Checked, &mut [f64]) -> Status,
) -> Fmi2Status {
    Fmi2Logger::with::<M>(c, call.name, |comp| match slice_mut(p, n) {
        Some(out) => comp.instance.call(call, |i, call| get(i, call, out)),
        None => comp.instance.error(call.name, "the array is NULL"),
    })
}

/// `fmi2GetDerivatives`.
pub unsafe fn get_derivatives<M: Model>(
    c: Fmi2Component,
    dx: *mut Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    get_array::<M>(c, calls::GET_DERIVATIVES, (dx, nx), |i, call, out| {
        i.get_derivatives(call, out)
    })
}

/// `fmi2GetEventIndicators`.
pub unsafe fn get_event_indicators<M: Model>(
    c: Fmi2Component,
    z: *mut Fmi2Real,
    ni: usize,
) -> Fmi2Status {
    get_array::<M>(c, calls::GET_EVENT_INDICATORS, (z, ni), |i, call, out| {
        i.get_event_indicators(call, out)
    })
}

/// `fmi2GetContinuousStates`.
pub unsafe fn get_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *mut Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    get_array::<M>(c, calls::GET_CONTINUOUS_STATES, (x, nx), |i, call, out| {
        i.get_continuous_states(call, out)
    })
}

/// `fmi2GetNominalsOfContinuousStates`.
pub unsafe fn get_nominals_of_continuous_states<M: Model>(
    c: Fmi2Component,
    n: *mut Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    let call = calls::GET_NOMINALS_OF_CONTINUOUS_STATES;
    get_array::<M>(c, call, (n, nx), |i, call, out| i.get_nominals(call, out))
}

/// `fmi2GetDirectionalDerivative`: Model Exchange and Co-Simulation of a model with an analytic
/// Jacobian.
#[allow(clippy::too_many_arguments)]
pub unsafe fn get_directional_derivative<M: Model>(
    c: Fmi2Component,
    unknowns: *const Fmi2ValueReference,
    n_unknown: usize,
    knowns: *const Fmi2ValueReference,
    n_known: usize,
    dv_known: *const Fmi2Real,
    dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    let call = calls::GET_DIRECTIONAL_DERIVATIVE;
    Fmi2Logger::with::<M>(c, call.name, |comp| {
        let arrays = (
            slice(unknowns, n_unknown),
            slice(knowns, n_known),
            slice(dv_known, n_known),
            slice_mut(dv_unknown, n_unknown),
        );
        let (Some(u), Some(k), Some(dv), Some(dz)) = arrays else {
            return comp.instance.error(call.name, "an array argument is NULL");
        };
        comp.instance.call(call, |i, call| {
            i.get_directional_derivative(call, u, k, dv, dz)
        })
    })
}
