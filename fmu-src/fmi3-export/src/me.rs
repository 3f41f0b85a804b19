//! The FMI 3.0 Model Exchange functions (FMI 3.0.2 chapter 3) over the Model Exchange of the
//! shared [`fmi2_export::Instance`] (`fmi2_export::me_instance`): this module converts pointers,
//! checks the FMI 3.0 state first (with the FMI 3.0 state names) and maps each call onto the
//! instance's, whose own check then passes (every mask here lies inside the instance's, tested in
//! `ffi`). `catch_unwind` at every entry through [`with_component`].
//!
//! States: Instantiated, Initialization Mode, Event Mode (entered by
//! `fmi3ExitInitializationMode` and `fmi3EnterEventMode`), Continuous-Time Mode (entered by
//! `fmi3EnterContinuousTimeMode`), Terminated and the error state.

#![allow(clippy::missing_safety_doc)]

use crate::c::*;
use crate::ffi::{allowed, slice, slice_mut, with_component, Component};
use crate::EVENT_INDICATOR_VALUE_REFERENCE;
use fmi2_export::instance::{Interface, Status};
use fmi2_export::me_instance::{EventInfo, Knowns};
use fmi2_export::Model;

/// Refuse a Model Exchange function on a Co-Simulation instance, then check the state.
fn check_me<M: Model>(comp: &mut Component<M>, func: &str, mask: u32) -> Result<(), Status> {
    if comp.instance.interface != Interface::ModelExchange {
        return Err(comp.instance.error(
            func,
            "a Model Exchange function called on a Co-Simulation instance",
        ));
    }
    comp.check(func, mask)
}

/// The value of event indicator `k` (value reference [`EVENT_INDICATOR_VALUE_REFERENCE`]` + k`)
/// at the instance's current time, states and inputs; `None` when the model has no such
/// indicator.
pub(crate) fn event_indicator<M: Model>(comp: &Component<M>, k: usize) -> Option<f64> {
    let me = M::model_exchange()?;
    if k >= me.event_indicators {
        return None;
    }
    let mut z = vec![0.0; me.event_indicators];
    let i = &comp.instance;
    (me.indicators)(&i.model, &i.vars, i.time, &mut z);
    Some(z[k])
}

/// The position of an event indicator's value reference, when it is one of the model's.
pub(crate) fn event_indicator_index<M: Model>(vr: Fmi3ValueReference) -> Option<usize> {
    let n = M::model_exchange().map_or(0, |me| me.event_indicators);
    let k = vr.checked_sub(EVENT_INDICATOR_VALUE_REFERENCE)? as usize;
    (k < n).then_some(k)
}

/// A mode change or a call without arrays: check the state, then call the instance.
unsafe fn simple<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    mask: u32,
    f: impl FnOnce(&mut Component<M>) -> Status,
) -> Fmi3Status {
    with_component::<M>(c, func, |comp| match check_me(comp, func, mask) {
        Ok(()) => f(comp),
        Err(s) => s,
    })
}

/// A call of either interface (directional and adjoint derivatives): check the state, then call
/// the instance.
unsafe fn either_interface<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    mask: u32,
    f: impl FnOnce(&mut Component<M>) -> Status,
) -> Fmi3Status {
    with_component::<M>(c, func, |comp| match comp.check(func, mask) {
        Ok(()) => f(comp),
        Err(s) => s,
    })
}

pub unsafe fn enter_event_mode<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    const F: &str = "fmi3EnterEventMode";
    simple::<M>(c, F, allowed::ENTER_EVENT_MODE, |comp| {
        comp.instance.enter_event_mode()
    })
}

pub unsafe fn enter_continuous_time_mode<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    const F: &str = "fmi3EnterContinuousTimeMode";
    simple::<M>(c, F, allowed::ENTER_CONTINUOUS_TIME_MODE, |comp| {
        comp.instance.enter_continuous_time_mode()
    })
}

pub unsafe fn set_time<M: Model>(c: Fmi3Instance, t: Fmi3Float64) -> Fmi3Status {
    simple::<M>(c, "fmi3SetTime", allowed::SET_TIME, |comp| {
        comp.instance.set_time(t)
    })
}

/// `fmi3UpdateDiscreteStates`: the instance's event update (iterated to a fixed point), its
/// event info written to the six outputs (`nextEventTime` 0 when not defined). Every output
/// pointer must be valid.
#[allow(clippy::too_many_arguments)]
pub unsafe fn update_discrete_states<M: Model>(
    c: Fmi3Instance,
    need_update: *mut Fmi3Boolean,
    terminate: *mut Fmi3Boolean,
    nominals_changed: *mut Fmi3Boolean,
    values_changed: *mut Fmi3Boolean,
    next_defined: *mut Fmi3Boolean,
    next: *mut Fmi3Float64,
) -> Fmi3Status {
    const F: &str = "fmi3UpdateDiscreteStates";
    simple::<M>(c, F, allowed::UPDATE_DISCRETE_STATES, |comp| {
        if need_update.is_null()
            || terminate.is_null()
            || nominals_changed.is_null()
            || values_changed.is_null()
            || next_defined.is_null()
            || next.is_null()
        {
            return comp.instance.error(F, "an output argument is NULL");
        }
        let mut info = EventInfo::default();
        let s = comp.instance.new_discrete_states(&mut info);
        if s == Status::Ok {
            *need_update = info.new_discrete_states_needed;
            *terminate = info.terminate_simulation;
            *nominals_changed = info.nominals_of_continuous_states_changed;
            *values_changed = info.values_of_continuous_states_changed;
            *next_defined = info.next_event_time.is_some();
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
    const F: &str = "fmi3CompletedIntegratorStep";
    simple::<M>(c, F, allowed::COMPLETED_INTEGRATOR_STEP, |comp| {
        if enter_event_mode.is_null() || terminate.is_null() {
            return comp
                .instance
                .error(F, "enterEventMode or terminateSimulation is NULL");
        }
        let (s, event, stop) = comp.instance.completed_integrator_step();
        if s == Status::Ok {
            *enter_event_mode = event;
            *terminate = stop;
        }
        s
    })
}

pub unsafe fn set_continuous_states<M: Model>(
    c: Fmi3Instance,
    x: *const Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    const F: &str = "fmi3SetContinuousStates";
    simple::<M>(c, F, allowed::SET_CONTINUOUS_STATES, |comp| {
        match slice(x, n) {
            Some(x) => comp.instance.set_continuous_states(x),
            None => comp.instance.error(F, "continuousStates is NULL"),
        }
    })
}

/// An array getter: check the state and the pointer, then let the instance fill the array.
unsafe fn get_array<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    what: &str,
    mask: u32,
    p: *mut Fmi3Float64,
    n: usize,
    f: impl FnOnce(&mut Component<M>, &mut [f64]) -> Status,
) -> Fmi3Status {
    simple::<M>(c, func, mask, |comp| match slice_mut(p, n) {
        Some(out) => f(comp, out),
        None => comp.instance.error(func, format!("{what} is NULL")),
    })
}

pub unsafe fn get_continuous_state_derivatives<M: Model>(
    c: Fmi3Instance,
    dx: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    const F: &str = "fmi3GetContinuousStateDerivatives";
    get_array::<M>(
        c,
        F,
        "derivatives",
        allowed::GET_DERIVATIVES,
        dx,
        n,
        |comp, dx| comp.instance.get_derivatives(dx),
    )
}

pub unsafe fn get_event_indicators<M: Model>(
    c: Fmi3Instance,
    z: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    const F: &str = "fmi3GetEventIndicators";
    get_array::<M>(
        c,
        F,
        "eventIndicators",
        allowed::GET_EVENT_INDICATORS,
        z,
        n,
        |comp, z| comp.instance.get_event_indicators(z),
    )
}

pub unsafe fn get_continuous_states<M: Model>(
    c: Fmi3Instance,
    x: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    const F: &str = "fmi3GetContinuousStates";
    get_array::<M>(
        c,
        F,
        "continuousStates",
        allowed::GET_CONTINUOUS_STATES,
        x,
        n,
        |comp, x| comp.instance.get_continuous_states(x),
    )
}

pub unsafe fn get_nominals_of_continuous_states<M: Model>(
    c: Fmi3Instance,
    nominals: *mut Fmi3Float64,
    n: usize,
) -> Fmi3Status {
    const F: &str = "fmi3GetNominalsOfContinuousStates";
    get_array::<M>(
        c,
        F,
        "nominals",
        allowed::GET_NOMINALS,
        nominals,
        n,
        |comp, v| comp.instance.get_nominals(v),
    )
}

/// `fmi3GetNumberOfContinuousStates` / `fmi3GetNumberOfEventIndicators` (any state of a Model
/// Exchange instance): the fixed counts of the model description.
pub unsafe fn get_number_of<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    event_indicators: bool,
    n: *mut usize,
) -> Fmi3Status {
    simple::<M>(c, func, allowed::ANY, |comp| {
        if n.is_null() {
            return comp.instance.error(func, "the output argument is NULL");
        }
        let me = M::model_exchange();
        *n = if event_indicators {
            me.map_or(0, |me| me.event_indicators)
        } else {
            me.map_or(0, |me| me.states)
        };
        Status::Ok
    })
}

/// The arrays of `fmi3GetDirectionalDerivative` and `fmi3GetAdjointDerivative`: every variable
/// is a scalar, so `nSeed` equals the number of seeded variables and `nSensitivity` the number
/// of variables the result is for.
struct DerivativeArgs<'a> {
    unknowns: &'a [Fmi3ValueReference],
    knowns: &'a [Fmi3ValueReference],
    seed: &'a [f64],
    sensitivity: &'a mut [f64],
}

/// The arrays of `fmi3GetDirectionalDerivative` and `fmi3GetAdjointDerivative` as the importer
/// passed them, pointer and length each (one argument for the two calls' common signature).
pub struct RawDerivativeArgs {
    pub unknowns: (*const Fmi3ValueReference, usize),
    pub knowns: (*const Fmi3ValueReference, usize),
    pub seed: (*const Fmi3Float64, usize),
    pub sensitivity: (*mut Fmi3Float64, usize),
}

/// What `fmi3GetDirectionalDerivative` and `fmi3GetAdjointDerivative` share: the state check,
/// then the arrays converted and checked ([`derivative_args`]), then `body` on them.
unsafe fn derivative_call<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    raw: RawDerivativeArgs,
    adjoint: bool,
    body: impl FnOnce(&mut Component<M>, DerivativeArgs<'_>) -> Status,
) -> Fmi3Status {
    either_interface::<M>(
        c,
        func,
        allowed::DIRECTIONAL_DERIVATIVE,
        |comp| match derivative_args(comp, func, raw, adjoint) {
            Ok(args) => body(comp, args),
            Err(s) => s,
        },
    )
}

/// Convert and check the arrays: the adjoint seeds the unknowns and gives one sensitivity per
/// known, the directional derivative the other way round.
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
        (Some(unknowns), Some(knowns), Some(seed), Some(sensitivity)) => Ok(DerivativeArgs {
            unknowns,
            knowns,
            seed,
            sensitivity,
        }),
        _ => Err(comp
            .instance
            .error(func, "unknowns, knowns, seed or sensitivity is NULL")),
    }
}

/// `fmi3GetDirectionalDerivative` (Model Exchange; Co-Simulation in Step Mode at the
/// communication point): `sensitivity = J seed` for the unknowns
/// (derivatives, outputs) with respect to the knowns (states, inputs and Float64 parameters,
/// FMI 3.0.2 section 2.4.8), section 3.2.4; the instance's directional derivative (the model's
/// analytic Jacobian for derivatives with respect to states, differences of the model's
/// evaluation for the other knowns).
pub unsafe fn get_directional_derivative<M: Model>(
    c: Fmi3Instance,
    raw: RawDerivativeArgs,
) -> Fmi3Status {
    const F: &str = "fmi3GetDirectionalDerivative";
    derivative_call::<M>(c, F, raw, false, |comp, args| {
        comp.instance.directional_derivative(
            F,
            Knowns::WithParameters,
            (args.unknowns, args.knowns, args.seed, args.sensitivity),
        )
    })
}

/// `fmi3GetAdjointDerivative` (as the directional one): `sensitivity = seed^T J`, FMI 3.0.2 section
/// 3.2.4, one column `J e_j` of the same directional derivative per known `j`:
/// `sensitivity_j = sum_i seed_i J_ij` (the instance evaluates the model's state Jacobian once
/// for all columns and keeps it while the point does not change). Nothing is written unless
/// every column succeeds.
pub unsafe fn get_adjoint_derivative<M: Model>(
    c: Fmi3Instance,
    raw: RawDerivativeArgs,
) -> Fmi3Status {
    const F: &str = "fmi3GetAdjointDerivative";
    derivative_call::<M>(c, F, raw, true, |comp, args| {
        if let Some(v) = args.seed.iter().find(|v| !v.is_finite()) {
            return comp
                .instance
                .error(F, format!("seed holds {v}, not a finite number"));
        }
        let mut column = vec![0.0; args.unknowns.len()];
        let mut out = vec![0.0; args.knowns.len()];
        for (o, &known) in out.iter_mut().zip(args.knowns) {
            let s = comp.instance.directional_derivative(
                F,
                Knowns::WithParameters,
                (args.unknowns, &[known], &[1.0], &mut column),
            );
            if s != Status::Ok {
                return s;
            }
            *o = column.iter().zip(args.seed).map(|(j, v)| j * v).sum();
        }
        args.sensitivity.copy_from_slice(&out);
        Status::Ok
    })
}

/// `fmi3SetFloat64` in Continuous-Time Mode: continuous inputs as the instance sets them, and
/// continuous-time states as `fmi3SetContinuousStates` would (FMI 3.0.2 section 3.2.1 allows
/// both). The states' values are checked (finite) before anything changes; the inputs are set
/// first (the instance's checks refuse the call as a whole), then the states.
pub(crate) fn set_float64_in_continuous_time_mode<M: Model>(
    comp: &mut Component<M>,
    func: &str,
    vrs: &[Fmi3ValueReference],
    vals: &[f64],
) -> Status {
    let Some(me) = M::model_exchange() else {
        return comp
            .instance
            .set_values(func, fmi2_export::VarType::Real, vrs, vals);
    };
    let table = M::variables();
    let state_of = |vr: Fmi3ValueReference| {
        me.state_variables
            .iter()
            .position(|&(x, _)| table[x].value_reference == vr)
    };
    let mut updates = Vec::new();
    let (mut input_vrs, mut input_vals) = (Vec::new(), Vec::new());
    for (&vr, &v) in vrs.iter().zip(vals) {
        match state_of(vr) {
            Some(k) if !v.is_finite() => {
                let name = table[me.state_variables[k].0].name;
                return comp
                    .instance
                    .error(func, format!("state '{name}' = {v} is not finite"));
            }
            Some(k) => updates.push((k, v)),
            None => {
                input_vrs.push(vr);
                input_vals.push(v);
            }
        }
    }
    if updates.is_empty() || !input_vrs.is_empty() {
        let s = comp
            .instance
            .set_values(func, fmi2_export::VarType::Real, &input_vrs, &input_vals);
        if s != Status::Ok || updates.is_empty() {
            return s;
        }
    }
    let mut x = vec![0.0; me.states];
    let s = comp.instance.get_continuous_states(&mut x);
    if s != Status::Ok {
        return s;
    }
    for (k, v) in updates {
        x[k] = v;
    }
    comp.instance.set_continuous_states(&x)
}
