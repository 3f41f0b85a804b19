//! The FMI 3.0 Model Exchange functions (FMI 3.0.2 chapter 3) and the directional and adjoint
//! derivatives of both interfaces, over the instance's ([`fmu_core::me_instance`],
//! [`fmu_core::directional`]): this module converts pointers after the state check.
//!
//! States: Instantiated, Initialization Mode, Event Mode (entered by
//! `fmi3ExitInitializationMode` and `fmi3EnterEventMode`), Continuous-Time Mode (entered by
//! `fmi3EnterContinuousTimeMode`), Terminated and the error state.

#![allow(clippy::missing_safety_doc)]

use crate::calls;
use crate::ffi::{Component, Fmi3Logger};
use fmi_types::c3::*;
use fmu_core::glue::{slice, slice_mut, Logger};
use fmu_core::machine::Call;
use fmu_core::{Checked, EventInfo, Knowns, Model, Status};

pub unsafe fn enter_event_mode<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::ENTER_EVENT_MODE, |comp, call| {
        comp.instance.enter_event_mode(call)
    })
}

pub unsafe fn enter_continuous_time_mode<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::ENTER_CONTINUOUS_TIME_MODE, |comp, call| {
        comp.instance.enter_continuous_time_mode(call)
    })
}

pub unsafe fn set_time<M: Model>(c: Fmi3Instance, t: Fmi3Float64) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::SET_TIME, |comp, call| {
        comp.instance.set_time(call, t)
    })
}

/// The outputs of `fmi3UpdateDiscreteStates` besides its status.
pub struct DiscreteStateOutputs {
    pub need_update: *mut Fmi3Boolean,
    pub terminate: *mut Fmi3Boolean,
    pub nominals_changed: *mut Fmi3Boolean,
    pub values_changed: *mut Fmi3Boolean,
    pub next_defined: *mut Fmi3Boolean,
    pub next: *mut Fmi3Float64,
}

/// `fmi3UpdateDiscreteStates`: the instance's event update (iterated to a fixed point), its
/// event info written to the six outputs (`nextEventTime` 0 when not defined). Every output
/// pointer must be valid.
pub unsafe fn update_discrete_states<M: Model>(
    c: Fmi3Instance,
    out: DiscreteStateOutputs,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::UPDATE_DISCRETE_STATES, |comp, call| {
        let pointers = (
            out.need_update.as_mut(),
            out.terminate.as_mut(),
            out.nominals_changed.as_mut(),
            out.values_changed.as_mut(),
            out.next_defined.as_mut(),
            out.next.as_mut(),
        );
        let (Some(need), Some(stop), Some(nominals), Some(values), Some(defined), Some(next)) =
            pointers
        else {
            return comp.instance.error(call.name, "an output argument is NULL");
        };
        let mut info = EventInfo::default();
        let s = comp.instance.new_discrete_states(call, &mut info);
        if s == Status::Ok {
            *need = info.new_discrete_states_needed;
            *stop = info.terminate_simulation;
            *nominals = info.nominals_of_continuous_states_changed;
            *values = info.values_of_continuous_states_changed;
            *defined = info.next_event_time.is_some();
            *next = info.next_event_time.unwrap_or(0.0);
        }
        s
    })
}

/// `fmi3CompletedIntegratorStep`: no step events, no termination requested.
pub unsafe fn completed_integrator_step<M: Model>(
    c: Fmi3Instance,
    enter_event_mode: *mut Fmi3Boolean,
    terminate: *mut Fmi3Boolean,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::COMPLETED_INTEGRATOR_STEP, |comp, call| {
        let (Some(event), Some(stop)) = (enter_event_mode.as_mut(), terminate.as_mut()) else {
            return comp
                .instance
                .error(call.name, "enterEventMode or terminateSimulation is NULL");
        };
        let (s, enter, end) = comp.instance.completed_integrator_step(call);
        if s == Status::Ok {
            (*event, *stop) = (enter, end);
        }
        s
    })
}

pub unsafe fn set_continuous_states<M: Model>(
    c: Fmi3Instance,
    x: *const Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::SET_CONTINUOUS_STATES, |comp, call| {
        match slice(x, n) {
            Some(x) => comp.instance.set_continuous_states(call, x),
            None => comp.instance.error(call.name, "continuousStates is NULL"),
        }
    })
}

/// An array getter: check the state and the pointer, then let the instance fill the array.
unsafe fn get_array<M: Model>(
    c: Fmi3Instance,
    (call, what): (Call, &str),
    (p, n): (*mut Fmi3Float64, usize),
    f: impl FnOnce(&mut Component<M>, Checked, &mut [f64]) -> Status,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, call, |comp, call| match slice_mut(p, n) {
        Some(out) => f(comp, call, out),
        None => comp.instance.error(call.name, format!("{what} is NULL")),
    })
}

pub unsafe fn get_continuous_state_derivatives<M: Model>(
    c: Fmi3Instance,
    dx: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    let call = (calls::GET_CONTINUOUS_STATE_DERIVATIVES, "derivatives");
    get_array::<M>(c, call, (dx, n), |comp, call, dx| {
        comp.instance.get_derivatives(call, dx)
    })
}

pub unsafe fn get_event_indicators<M: Model>(
    c: Fmi3Instance,
    z: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    let call = (calls::GET_EVENT_INDICATORS, "eventIndicators");
    get_array::<M>(c, call, (z, n), |comp, call, z| {
        comp.instance.get_event_indicators(call, z)
    })
}

pub unsafe fn get_continuous_states<M: Model>(
    c: Fmi3Instance,
    x: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    let call = (calls::GET_CONTINUOUS_STATES, "continuousStates");
    get_array::<M>(c, call, (x, n), |comp, call, x| {
        comp.instance.get_continuous_states(call, x)
    })
}

pub unsafe fn get_nominals_of_continuous_states<M: Model>(
    c: Fmi3Instance,
    nominals: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    let call = (calls::GET_NOMINALS_OF_CONTINUOUS_STATES, "nominals");
    get_array::<M>(c, call, (nominals, n), |comp, call, v| {
        comp.instance.get_nominals(call, v)
    })
}

/// `fmi3GetNumberOfContinuousStates` / `fmi3GetNumberOfEventIndicators` (any state of a Model
/// Exchange instance): the fixed counts of the model description.
pub unsafe fn get_number_of<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    event_indicators: bool,
    n: *mut usize,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::count(func), |comp, call| {
        let Some(n) = n.as_mut() else {
            return comp
                .instance
                .error(call.name, "the output argument is NULL");
        };
        let me = M::model_exchange();
        *n = if event_indicators {
            me.map_or(0, |me| me.event_indicators)
        } else {
            me.map_or(0, |me| me.states)
        };
        Status::Ok
    })
}

/// The arrays of `fmi3GetDirectionalDerivative` and `fmi3GetAdjointDerivative` as the importer
/// passed them, pointer and length each (one argument for the two calls' common signature).
pub struct RawDerivativeArgs {
    pub unknowns: (*const Fmi3ValueReference, usize),
    pub knowns: (*const Fmi3ValueReference, usize),
    pub seed: (*const Fmi3Float64, usize),
    pub sensitivity: (*mut Fmi3Float64, usize),
}

/// The arrays converted and checked: every variable is a scalar, so `nSeed` equals the number
/// of seeded variables and `nSensitivity` the number of variables the result is for (the
/// adjoint seeds the unknowns and gives one sensitivity per known, the directional derivative
/// the other way round).
type DerivativeArgs<'a> = (&'a [u32], &'a [u32], &'a [f64], &'a mut [f64]);

unsafe fn derivative_args<'a, M: Model>(
    comp: &mut Component<M>,
    func: &str,
    raw: RawDerivativeArgs,
    adjoint: bool,
) -> Result<DerivativeArgs<'a>, Status> {
    let ((unknowns, n_unknowns), (knowns, n_knowns)) = (raw.unknowns, raw.knowns);
    let ((seed, n_seed), (sensitivity, n_sensitivity)) = (raw.seed, raw.sensitivity);
    let (seed_len, sensitivity_len) = if adjoint {
        (n_unknowns, n_knowns)
    } else {
        (n_knowns, n_unknowns)
    };
    if n_seed != seed_len || n_sensitivity != sensitivity_len {
        return Err(comp.instance.error(
            func,
            format!(
                "nSeed = {n_seed} and nSensitivity = {n_sensitivity}, expected {seed_len} and \
                 {sensitivity_len} (every variable is a scalar)"
            ),
        ));
    }
    match (
        slice(unknowns, n_unknowns),
        slice(knowns, n_knowns),
        slice(seed, n_seed),
        slice_mut(sensitivity, n_sensitivity),
    ) {
        (Some(u), Some(k), Some(seed), Some(sensitivity)) => Ok((u, k, seed, sensitivity)),
        _ => Err(comp
            .instance
            .error(func, "unknowns, knowns, seed or sensitivity is NULL")),
    }
}

/// `fmi3GetDirectionalDerivative` (Model Exchange; Co-Simulation in Step Mode at the
/// communication point): `sensitivity = J seed` for the unknowns (derivatives, outputs) with
/// respect to the knowns (states, inputs and Float64 parameters, FMI 3.0.2 section 2.4.8),
/// section 3.2.4.
pub unsafe fn get_directional_derivative<M: Model>(
    c: Fmi3Instance,
    raw: RawDerivativeArgs,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::GET_DIRECTIONAL_DERIVATIVE, |comp, call| {
        match derivative_args(comp, call.name, raw, false) {
            Ok(args) => comp
                .instance
                .directional_derivative(call, Knowns::WithParameters, args),
            Err(s) => s,
        }
    })
}

/// `fmi3GetAdjointDerivative` (as the directional one): `sensitivity = seed^T J`, FMI 3.0.2
/// section 3.2.4.
pub unsafe fn get_adjoint_derivative<M: Model>(
    c: Fmi3Instance,
    raw: RawDerivativeArgs,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(
        c,
        calls::GET_ADJOINT_DERIVATIVE,
        |comp, call| match derivative_args(comp, call.name, raw, true) {
            Ok(args) => comp.instance.adjoint_derivative(call, args),
            Err(s) => s,
        },
    )
}
