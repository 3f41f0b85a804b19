//! The FMI 3.0 C ABI over [`Instance`] (Co-Simulation here, Model Exchange in [`crate::me`],
//! FMU states in [`crate::states`]): pointer checks, logging, instantiation, variable access
//! with `time` and the event indicators as this version's own variables, and steps.
//! `catch_unwind` at every entry ([`fmu_core::glue`]). [`crate::export_fmi3!`] emits the
//! `#[no_mangle]` symbols, each a call to a function here.
//!
//! States (FMI 3.0.2 section 4.2, Co-Simulation with `eventModeUsed = false`): Instantiated,
//! Initialization Mode, Step Mode, Terminated, and the error state a failed step leaves (only
//! `fmi3SetFMUState`, `fmi3Reset` and `fmi3FreeInstance` continue from it; getters still answer
//! for diagnosis), named as [`crate::calls::STATE_NAMES`] says.

#![allow(clippy::missing_safety_doc)]

use crate::calls;
use fmi_types::c3::*;
use fmu_core::glue::{self, c_str, slice, slice_mut, Logger};
use fmu_core::machine::Call;
use fmu_core::variables::index_of;
use fmu_core::xml3::TIME_VALUE_REFERENCE;
use fmu_core::{Experiment, Instance, Interface, Model, Status, VarType};

/// The environment's logger (`fmi3LogMessageCallback`, not variadic).
pub struct Fmi3Logger {
    logger: Fmi3LogMessageCallback,
    environment: Fmi3InstanceEnvironment,
}

impl Logger for Fmi3Logger {
    const MAGIC: u64 = 0x4146_4d55_4933_4353; // "AFMUI3CS"

    fn log(&self, status: Status, category: &str, message: &str) {
        let Some(logger) = self.logger else { return };
        let (category, message) = glue::log_strings(category, message);
        // SAFETY: the logger is the environment's function; both strings live for the call.
        unsafe {
            logger(
                self.environment,
                status.raw(),
                category.as_ptr(),
                message.as_ptr(),
            )
        }
    }
}

/// What an `fmi3Instance` points to.
pub type Component<M> = glue::Component<M, Fmi3Logger>;

pub fn get_version() -> Fmi3String {
    c"3.0".as_ptr()
}

/// A new instance of `interface` after the checks every instantiation makes: a non-empty name
/// and the model description's token. A null handle (the reason logged) otherwise.
unsafe fn new_component<M: Model>(
    func: &str,
    (instance_name, token): (Fmi3String, Fmi3String),
    logging_on: Fmi3Boolean,
    interface: Interface,
    logger: Fmi3Logger,
) -> Fmi3Instance {
    let refuse = |msg: String| {
        logger.log(Status::Error, "logStatusError", &msg);
        std::ptr::null_mut()
    };
    let name = c_str(instance_name).unwrap_or("");
    if name.is_empty() {
        return refuse(format!("{func}: instanceName must be a non-empty string"));
    }
    let expected = fmu_core::xml::guid::<M>();
    match c_str(token) {
        Some(t) if t == expected => {}
        t => {
            return refuse(format!(
                "{func}: instantiationToken {t:?} does not match this binary's {expected}"
            ))
        }
    }
    let names = calls::STATE_NAMES;
    match Instance::with_interface(name, expected, logging_on, interface, names) {
        Some(instance) => Component::<M>::into_handle(instance, logger),
        None => refuse(format!("{func}: {} does not offer Model Exchange", M::NAME)),
    }
}

/// `fmi3InstantiateCoSimulation`: `eventModeUsed` must be false (no Event Mode in Co-Simulation,
/// `hasEventMode="false"`) and no intermediate variables can be required
/// (`providesIntermediateUpdate="false"`); the token must match the model description.
/// `earlyReturnAllowed` is accepted: this FMU never returns early.
pub unsafe fn instantiate_co_simulation<M: Model>(
    names: (Fmi3String, Fmi3String),
    event_mode_used: Fmi3Boolean,
    n_required_intermediate: usize,
    logging_on: Fmi3Boolean,
    (environment, logger): (Fmi3InstanceEnvironment, Fmi3LogMessageCallback),
) -> Fmi3Instance {
    const F: &str = "fmi3InstantiateCoSimulation";
    let logger = Fmi3Logger {
        logger,
        environment,
    };
    glue::instantiate(|| {
        let refusal = if event_mode_used {
            format!("{F}: eventModeUsed = true, but {} has no Event Mode in Co-Simulation (hasEventMode=\"false\")", M::NAME)
        } else if n_required_intermediate > 0 {
            format!("{F}: {} provides no intermediate update (providesIntermediateUpdate=\"false\"); nRequiredIntermediateVariables must be 0", M::NAME)
        } else {
            return new_component::<M>(F, names, logging_on, Interface::CoSimulation, logger);
        };
        logger.log(Status::Error, "logStatusError", &refusal);
        std::ptr::null_mut()
    })
}

/// `fmi3InstantiateModelExchange`: the instance's Model Exchange (the model's `ModelExchange`
/// implementation); refused for a model without one.
pub unsafe fn instantiate_model_exchange<M: Model>(
    names: (Fmi3String, Fmi3String),
    logging_on: Fmi3Boolean,
    (environment, logger): (Fmi3InstanceEnvironment, Fmi3LogMessageCallback),
) -> Fmi3Instance {
    const F: &str = "fmi3InstantiateModelExchange";
    let logger = Fmi3Logger {
        logger,
        environment,
    };
    glue::instantiate(|| new_component::<M>(F, names, logging_on, Interface::ModelExchange, logger))
}

/// `fmi3InstantiateScheduledExecution`: not offered.
pub fn instantiate_refused<M: Model>(
    func: &str,
    interface: &str,
    environment: Fmi3InstanceEnvironment,
    logger: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    glue::instantiate(|| {
        let logger = Fmi3Logger {
            logger,
            environment,
        };
        let msg = format!(
            "{func}: {} does not offer {interface} in FMI 3.0 (Model Exchange and Co-Simulation only)",
            M::NAME
        );
        logger.log(Status::Error, "logStatusError", &msg);
        std::ptr::null_mut()
    })
}

/// `fmi3FreeInstance`: frees the instance and every FMU state it still owns.
pub unsafe fn free_instance<M: Model>(c: Fmi3Instance) {
    glue::free_component::<M, Fmi3Logger>(c)
}

/// A function for a feature this FMU does not offer: `fmi3Error` with the reason logged.
pub unsafe fn unsupported<M: Model>(c: Fmi3Instance, func: &'static str, why: &str) -> Fmi3Status {
    Fmi3Logger::with::<M>(c, func, |comp| comp.instance.error(func, why))
}

pub unsafe fn set_debug_logging<M: Model>(
    c: Fmi3Instance,
    logging_on: Fmi3Boolean,
    n: usize,
    categories: *const Fmi3String,
) -> Fmi3Status {
    let call = calls::SET_DEBUG_LOGGING;
    Fmi3Logger::with::<M>(c, call.name, |comp| {
        let Some(cats) = slice(categories, n) else {
            return comp.instance.error(call.name, "categories is NULL");
        };
        let names: Option<Vec<&str>> = cats.iter().map(|&p| c_str(p)).collect();
        let Some(names) = names else {
            return comp
                .instance
                .error(call.name, "a category is NULL or not UTF-8");
        };
        comp.instance.call(call, |i, call| {
            i.set_debug_logging(call, logging_on, &names)
        })
    })
}

/// `fmi3EnterInitializationMode`: the experiment (start, stop, tolerance, which goes to the
/// model's tolerance parameters as in FMI 2.0's `fmi2SetupExperiment`), then Initialization
/// Mode.
pub unsafe fn enter_initialization_mode<M: Model>(
    c: Fmi3Instance,
    (tolerance_defined, tolerance): (Fmi3Boolean, Fmi3Float64),
    start_time: Fmi3Float64,
    (stop_time_defined, stop_time): (Fmi3Boolean, Fmi3Float64),
) -> Fmi3Status {
    let experiment = Experiment {
        start: start_time,
        stop: stop_time_defined.then_some(stop_time),
        tolerance: tolerance_defined.then_some(tolerance),
    };
    Fmi3Logger::checked::<M>(c, calls::ENTER_INITIALIZATION_MODE, |comp, call| {
        comp.instance
            .enter_initialization_mode_with(call, experiment)
    })
}

pub unsafe fn exit_initialization_mode<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::EXIT_INITIALIZATION_MODE, |comp, call| {
        comp.instance.exit_initialization_mode(call)
    })
}

pub unsafe fn terminate<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::TERMINATE, |comp, call| {
        comp.instance.terminate(call)
    })
}

pub unsafe fn reset<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::RESET, |comp, call| comp.instance.reset(call))
}

/// `nValues` must equal `nValueReferences`: every variable is a scalar.
fn check_counts<M: Model>(
    comp: &mut Component<M>,
    func: &str,
    nvr: usize,
    nvalues: usize,
) -> Status {
    if nvr == nvalues {
        return Status::Ok;
    }
    comp.instance.error(
        func,
        format!("nValues = {nvalues} differs from nValueReferences = {nvr} (every variable is a scalar)"),
    )
}

/// The position of an event indicator's value reference, when it is one of the model's.
pub(crate) fn event_indicator_index<M: Model>(vr: Fmi3ValueReference) -> Option<usize> {
    use fmu_core::xml3::EVENT_INDICATOR_VALUE_REFERENCE;
    let n = M::model_exchange().map_or(0, |me| me.event_indicators);
    let k = vr.checked_sub(EVENT_INDICATOR_VALUE_REFERENCE)? as usize;
    (k < n).then_some(k)
}

/// The value of one of this version's own Float64 variables (`time`, an event indicator), or
/// `None` for a variable of the table.
fn own_variable<M: Model>(instance: &Instance<M>, ty: VarType, vr: u32) -> Option<f64> {
    if ty != VarType::Real {
        return None;
    }
    if vr == TIME_VALUE_REFERENCE {
        return Some(instance.time);
    }
    let k = event_indicator_index::<M>(vr)?;
    Some(instance.event_indicator(k).unwrap_or(f64::NAN))
}

/// Shared body of the Float64, Int32 and Boolean getters. `time` (the independent variable) is
/// answered with the current time and the event indicators with their values.
unsafe fn get_typed<M: Model, T: Copy>(
    c: Fmi3Instance,
    (call, ty): (Call, VarType),
    (vr, nvr): (*const Fmi3ValueReference, usize),
    (value, nvalues): (*mut T, usize),
    convert: impl Fn(f64) -> T,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, call, |comp, call| {
        if check_counts(comp, call.name, nvr, nvalues) != Status::Ok {
            return Status::Error;
        }
        let (Some(vrs), Some(out)) = (slice(vr, nvr), slice_mut(value, nvalues)) else {
            return comp
                .instance
                .error(call.name, "valueReferences or values is NULL");
        };
        let is_own = |v: u32| {
            ty == VarType::Real
                && (v == TIME_VALUE_REFERENCE || event_indicator_index::<M>(v).is_some())
        };
        let table_vrs: Vec<u32> = vrs.iter().copied().filter(|&v| !is_own(v)).collect();
        let mut buf = vec![0.0; table_vrs.len()];
        let s = comp.instance.get_values(call, ty, &table_vrs, &mut buf);
        if s == Status::Ok {
            let mut from_table = buf.into_iter();
            for (o, &v) in out.iter_mut().zip(vrs) {
                let x = match own_variable(&comp.instance, ty, v) {
                    Some(x) => x,
                    None => from_table.next().unwrap_or(f64::NAN),
                };
                *o = convert(x);
            }
        }
        s
    })
}

/// Shared body of the Float64, Int32 and Boolean setters.
unsafe fn set_typed<M: Model, T: Copy>(
    c: Fmi3Instance,
    (call, ty): (Call, VarType),
    (vr, nvr): (*const Fmi3ValueReference, usize),
    (value, nvalues): (*const T, usize),
    convert: impl Fn(T) -> f64,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, call, |comp, call| {
        if check_counts(comp, call.name, nvr, nvalues) != Status::Ok {
            return Status::Error;
        }
        let (Some(vrs), Some(vals)) = (slice(vr, nvr), slice(value, nvalues)) else {
            return comp
                .instance
                .error(call.name, "valueReferences or values is NULL");
        };
        if ty == VarType::Real && vrs.contains(&TIME_VALUE_REFERENCE) {
            return comp.instance.error(
                call.name,
                format!("'time' (value reference {TIME_VALUE_REFERENCE}) is the independent variable and cannot be set"),
            );
        }
        let vals: Vec<f64> = vals.iter().map(|&x| convert(x)).collect();
        let continuous_time = comp.instance.state == fmu_core::MachineState::ContinuousTimeMode;
        if ty == VarType::Real && continuous_time {
            return comp.instance.set_reals_and_states(call, vrs, &vals);
        }
        comp.instance.set_values(call, ty, vrs, &vals)
    })
}

pub unsafe fn get_float64<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut Fmi3Float64,
    nvalues: usize,
) -> Fmi3Status {
    let call = (calls::GET_FLOAT64, VarType::Real);
    get_typed::<M, f64>(c, call, (vr, nvr), (value, nvalues), |x| x)
}

pub unsafe fn get_int32<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut Fmi3Int32,
    nvalues: usize,
) -> Fmi3Status {
    let call = (calls::GET_INT32, VarType::Integer);
    get_typed::<M, i32>(c, call, (vr, nvr), (value, nvalues), |x| x as i32)
}

pub unsafe fn get_boolean<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut Fmi3Boolean,
    nvalues: usize,
) -> Fmi3Status {
    let call = (calls::GET_BOOLEAN, VarType::Boolean);
    get_typed::<M, bool>(c, call, (vr, nvr), (value, nvalues), |x| x != 0.0)
}

pub unsafe fn set_float64<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const Fmi3Float64,
    nvalues: usize,
) -> Fmi3Status {
    let call = (calls::SET_FLOAT64, VarType::Real);
    set_typed::<M, f64>(c, call, (vr, nvr), (value, nvalues), |x| x)
}

pub unsafe fn set_int32<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const Fmi3Int32,
    nvalues: usize,
) -> Fmi3Status {
    let call = (calls::SET_INT32, VarType::Integer);
    set_typed::<M, i32>(c, call, (vr, nvr), (value, nvalues), |x| x as f64)
}

/// Booleans from the importer are read as bytes: any non-zero byte is true.
pub unsafe fn set_boolean<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const Fmi3Boolean,
    nvalues: usize,
) -> Fmi3Status {
    let call = (calls::SET_BOOLEAN, VarType::Boolean);
    let bytes = (value as *const u8, nvalues);
    set_typed::<M, u8>(c, call, (vr, nvr), bytes, |x| (x != 0) as i32 as f64)
}

/// Getters and setters of a type this FMU has no variable of (Float32, Int8, ..., String,
/// Binary): an empty list with `nValues = 0` succeeds (`nValues` equals `nValueReferences` when
/// every reference is a scalar, FMI 3.0.2 section 2.2.6.2); any reference is refused, naming the
/// variable's type when the reference exists.
pub unsafe fn no_variables_of_type<M: Model>(
    c: Fmi3Instance,
    call: Call,
    type_name: &str,
    (vr, nvr): (*const Fmi3ValueReference, usize),
    nvalues: usize,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, call, |comp, call| {
        let Some(vrs) = slice(vr, nvr) else {
            return comp.instance.error(call.name, "valueReferences is NULL");
        };
        let Some(&v) = vrs.first() else {
            return check_counts(comp, call.name, nvr, nvalues);
        };
        let table = M::variables();
        let message = if v == TIME_VALUE_REFERENCE {
            format!("value reference {v} ('time') is Float64, not {type_name}")
        } else if let Some(i) = index_of(table, v) {
            let kind = match table[i].vtype {
                VarType::Real => "Float64",
                VarType::Integer => "Int32",
                VarType::Boolean => "Boolean",
                _ => "another type",
            };
            let name = table[i].name;
            format!("value reference {v} ('{name}') is {kind}, not {type_name}")
        } else {
            format!("unknown value reference {v}")
        };
        comp.instance.error(call.name, message)
    })
}

/// The outputs of `fmi3DoStep` besides its status.
pub struct StepOutputs {
    pub event_handling_needed: *mut Fmi3Boolean,
    pub terminate_simulation: *mut Fmi3Boolean,
    pub early_return: *mut Fmi3Boolean,
    pub last_successful_time: *mut Fmi3Float64,
}

/// `fmi3DoStep` without Event Mode and early return: the outputs are `eventHandlingNeeded`,
/// `terminateSimulation` and `earlyReturn` false and `lastSuccessfulTime` the time reached (on a
/// failed step, the time of the last good communication point; the status is `fmi3Error`).
pub unsafe fn do_step<M: Model>(
    c: Fmi3Instance,
    current: Fmi3Float64,
    h: Fmi3Float64,
    outputs: StepOutputs,
) -> Fmi3Status {
    Fmi3Logger::checked::<M>(c, calls::DO_STEP, |comp, call| {
        let (Some(event), Some(terminate), Some(early), Some(last)) = (
            outputs.event_handling_needed.as_mut(),
            outputs.terminate_simulation.as_mut(),
            outputs.early_return.as_mut(),
            outputs.last_successful_time.as_mut(),
        ) else {
            return comp.instance.error(
                call.name,
                "eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL",
            );
        };
        let s = comp.instance.do_step(call, current, h);
        (*event, *terminate, *early) = (false, false, false);
        *last = comp.instance.time;
        s
    })
}

#[cfg(test)]
mod tests {
    use super::{free_instance, instantiate_co_simulation, no_variables_of_type};
    use crate::calls;
    use fmi_types::c3::{FMI3_ERROR, FMI3_OK};
    use std::ffi::CString;
    use test_oscillator::Oscillator;

    /// `fmi3SetFloat32(instance, vrs, 0, NULL, 2)` (a fuzz input): two values for no reference
    /// is an invalid call and gets fmi3Error; no values for no reference succeeds.
    #[test]
    fn a_type_without_variables_refuses_values_without_references() {
        let token = CString::new(fmu_core::xml::guid::<Oscillator>()).unwrap();
        let names = (c"fuzz".as_ptr(), token.as_ptr());
        let env = (std::ptr::null_mut(), None);
        // SAFETY: valid strings; the instance is freed at the end.
        unsafe {
            let c = instantiate_co_simulation::<Oscillator>(names, false, 0, false, env);
            assert!(!c.is_null());
            let call = calls::setter("fmi3SetFloat32");
            let no_vrs = (std::ptr::null(), 0);
            let s = no_variables_of_type::<Oscillator>(c, call, "Float32", no_vrs, 2);
            assert_eq!(s, FMI3_ERROR);
            let s = no_variables_of_type::<Oscillator>(c, call, "Float32", no_vrs, 0);
            assert_eq!(s, FMI3_OK);
            free_instance::<Oscillator>(c);
        }
    }
}
