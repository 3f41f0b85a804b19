//! The FMI 2.0 C ABI over [`Instance`]: pointer checks, logging through the environment's
//! C-variadic logger (always with a `"%s"` format), instantiation, variable access, steps and
//! FMU-state handles (the Model Exchange functions are in [`crate::me`]). `catch_unwind` at
//! every entry ([`fmu_core::glue`]).
//!
//! [`crate::export_model!`] emits the `#[no_mangle] extern "C"` symbols, each a one-line call to
//! the generic function of the same name here.

#![allow(clippy::missing_safety_doc)]

use crate::calls;
use fmu_core::glue::{self, c_str, slice, slice_mut, Logger};
use fmu_core::machine::Call;
use fmu_core::{Experiment, Instance, Interface, Model, Status, VarType};
use std::ffi::{c_int, CString};

/// The C types of `fmi2FunctionTypes.h`, under the names the exported functions use.
pub use fmi_types::c::{
    Boolean as Fmi2Boolean, Byte as Fmi2Byte, CallbackFunctions as Fmi2CallbackFunctions,
    CallbackLogger as Fmi2CallbackLogger, Component as Fmi2Component,
    ComponentEnvironment as Fmi2ComponentEnvironment, FmiString as Fmi2String, FmiType as Fmi2Type,
    FmuState as Fmi2FmuState, Integer as Fmi2Integer, RawStatus as Fmi2Status, Real as Fmi2Real,
    StatusKind as Fmi2StatusKind, ValueReference as Fmi2ValueReference,
    CO_SIMULATION as FMI2_COSIMULATION, DISCARD as FMI2_DISCARD, ERROR as FMI2_ERROR,
    MODEL_EXCHANGE as FMI2_MODEL_EXCHANGE, OK as FMI2_OK,
};

/// The environment's logger with the instance name it is called with.
pub struct Fmi2Logger {
    logger: Option<Fmi2CallbackLogger>,
    environment: Fmi2ComponentEnvironment,
    name: CString,
}

impl Logger for Fmi2Logger {
    const MAGIC: u64 = 0x4146_4d55_4932_4353; // "AFMUI2CS"

    fn log(&self, status: Status, category: &str, message: &str) {
        let Some(logger) = self.logger else { return };
        let (category, message) = glue::log_strings(category, message);
        // SAFETY: the logger is the environment's function; every pointer is a valid C string
        // that lives for the call, and the format "%s" consumes exactly the one argument passed.
        unsafe {
            logger(
                self.environment,
                self.name.as_ptr(),
                status.raw(),
                category.as_ptr(),
                c"%s".as_ptr(),
                message.as_ptr(),
            );
        }
    }
}

/// What `fmi2Component` points to.
pub type Component<M> = glue::Component<M, Fmi2Logger>;

/// Check `call`, then run `op` on the instance behind `c`.
pub(crate) unsafe fn checked<M: Model>(
    c: Fmi2Component,
    call: Call,
    op: impl FnOnce(&mut Instance<M>, fmu_core::Checked) -> Status,
) -> Fmi2Status {
    Fmi2Logger::checked::<M>(c, call, |comp, call| op(&mut comp.instance, call))
}

pub fn get_types_platform() -> Fmi2String {
    c"default".as_ptr()
}

pub fn get_version() -> Fmi2String {
    c"2.0".as_ptr()
}

/// The interface `fmuType` asks for, when the model offers it.
fn interface_of<M: Model>(fmu_type: Fmi2Type) -> Option<Interface> {
    match fmu_type {
        FMI2_COSIMULATION => Some(Interface::CoSimulation),
        FMI2_MODEL_EXCHANGE if M::model_exchange().is_some() => Some(Interface::ModelExchange),
        _ => None,
    }
}

/// Why `fmuType` is refused: the interfaces the model offers.
fn interface_refusal<M: Model>(fmu_type: Fmi2Type) -> String {
    let offered = if M::model_exchange().is_some() {
        "Model Exchange (fmuType 0) and Co-Simulation (fmuType 1),"
    } else {
        "Co-Simulation (fmuType 1) only,"
    };
    format!(
        "fmi2Instantiate: {} supports {offered} not fmuType {fmu_type}",
        M::NAME
    )
}

/// `fmi2Instantiate`: Co-Simulation, or Model Exchange for a model that provides it; the GUID
/// must match the model description.
pub unsafe fn instantiate<M: Model>(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    guid: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    glue::instantiate(|| {
        let Some(functions) = functions.as_ref() else {
            return std::ptr::null_mut();
        };
        let name_str = c_str(instance_name).unwrap_or("");
        let logger = Fmi2Logger {
            logger: functions.logger,
            environment: functions.component_environment,
            name: CString::new(name_str).unwrap_or_default(),
        };
        let fail = |msg: &str| {
            logger.log(Status::Error, "logStatusError", msg);
            std::ptr::null_mut()
        };
        if instance_name.is_null() || name_str.is_empty() {
            return fail("fmi2Instantiate: instanceName must be a non-empty string");
        }
        let Some(interface) = interface_of::<M>(fmu_type) else {
            return fail(&interface_refusal::<M>(fmu_type));
        };
        let expected = fmu_core::xml::guid::<M>();
        match c_str(guid) {
            Some(g) if g == expected => {}
            g => {
                let msg =
                    format!("fmi2Instantiate: GUID {g:?} does not match this binary's {expected}");
                return fail(&msg);
            }
        }
        let names = calls::STATE_NAMES;
        match Instance::with_interface(name_str, expected, logging_on != 0, interface, names) {
            Some(instance) => Component::<M>::into_handle(instance, logger),
            None => fail("fmi2Instantiate: Model Exchange is not provided"),
        }
    })
}

/// `fmi2FreeInstance`: frees the instance and every FMU state it still owns.
pub unsafe fn free_instance<M: Model>(c: Fmi2Component) {
    glue::free_component::<M, Fmi2Logger>(c)
}

pub unsafe fn set_debug_logging<M: Model>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    const F: &str = "fmi2SetDebugLogging";
    Fmi2Logger::with::<M>(c, F, |comp| {
        let Some(cats) = slice(categories, n) else {
            return comp.instance.error(F, "categories is NULL");
        };
        let names: Option<Vec<&str>> = cats.iter().map(|&p| c_str(p)).collect();
        let Some(names) = names else {
            return comp.instance.error(F, "a category is NULL or not UTF-8");
        };
        comp.instance.call(calls::SET_DEBUG_LOGGING, |i, call| {
            i.set_debug_logging(call, logging_on != 0, &names)
        })
    })
}

pub unsafe fn setup_experiment<M: Model>(
    c: Fmi2Component,
    tolerance_defined: Fmi2Boolean,
    tolerance: Fmi2Real,
    start_time: Fmi2Real,
    stop_time_defined: Fmi2Boolean,
    stop_time: Fmi2Real,
) -> Fmi2Status {
    let experiment = Experiment {
        start: start_time,
        stop: (stop_time_defined != 0).then_some(stop_time),
        tolerance: (tolerance_defined != 0).then_some(tolerance),
    };
    checked::<M>(c, calls::SETUP_EXPERIMENT, |i, call| {
        i.setup_experiment(call, experiment)
    })
}

pub unsafe fn enter_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    checked::<M>(c, calls::ENTER_INITIALIZATION_MODE, |i, call| {
        i.enter_initialization_mode(call)
    })
}

pub unsafe fn exit_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    checked::<M>(c, calls::EXIT_INITIALIZATION_MODE, |i, call| {
        i.exit_initialization_mode(call)
    })
}

pub unsafe fn terminate<M: Model>(c: Fmi2Component) -> Fmi2Status {
    checked::<M>(c, calls::TERMINATE, |i, call| i.terminate(call))
}

pub unsafe fn reset<M: Model>(c: Fmi2Component) -> Fmi2Status {
    checked::<M>(c, calls::RESET, |i, call| i.reset(call))
}

/// Shared body of the three numeric getters.
unsafe fn get_typed<M: Model, T: Copy>(
    c: Fmi2Component,
    call: Call,
    ty: VarType,
    (vr, n): (*const Fmi2ValueReference, usize),
    value: *mut T,
    convert: impl Fn(f64) -> T,
) -> Fmi2Status {
    Fmi2Logger::with::<M>(c, call.name, |comp| {
        let (Some(vrs), Some(out)) = (slice(vr, n), slice_mut(value, n)) else {
            return comp.instance.error(call.name, "vr or value is NULL");
        };
        let mut buf = vec![0.0; n];
        let s = comp
            .instance
            .call(call, |i, call| i.get_values(call, ty, vrs, &mut buf));
        if s == Status::Ok {
            for (o, x) in out.iter_mut().zip(buf) {
                *o = convert(x);
            }
        }
        s
    })
}

/// Shared body of the three numeric setters.
unsafe fn set_typed<M: Model, T: Copy>(
    c: Fmi2Component,
    call: Call,
    ty: VarType,
    (vr, n): (*const Fmi2ValueReference, usize),
    value: *const T,
    convert: impl Fn(T) -> f64,
) -> Fmi2Status {
    Fmi2Logger::with::<M>(c, call.name, |comp| {
        let (Some(vrs), Some(vals)) = (slice(vr, n), slice(value, n)) else {
            return comp.instance.error(call.name, "vr or value is NULL");
        };
        let vals: Vec<f64> = vals.iter().map(|&x| convert(x)).collect();
        comp.instance
            .call(call, |i, call| i.set_values(call, ty, vrs, &vals))
    })
}

pub unsafe fn get_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    get_typed::<M, f64>(c, calls::GET_REAL, VarType::Real, (vr, n), value, |x| x)
}

pub unsafe fn get_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    let call = calls::GET_INTEGER;
    get_typed::<M, c_int>(c, call, VarType::Integer, (vr, n), value, |x| x as c_int)
}

pub unsafe fn get_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    let call = calls::GET_BOOLEAN;
    get_typed::<M, c_int>(c, call, VarType::Boolean, (vr, n), value, |x| {
        (x != 0.0) as c_int
    })
}

pub unsafe fn set_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    set_typed::<M, f64>(c, calls::SET_REAL, VarType::Real, (vr, n), value, |x| x)
}

pub unsafe fn set_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    let call = calls::SET_INTEGER;
    set_typed::<M, c_int>(c, call, VarType::Integer, (vr, n), value, |x| x as f64)
}

pub unsafe fn set_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    let call = calls::SET_BOOLEAN;
    set_typed::<M, c_int>(c, call, VarType::Boolean, (vr, n), value, |x| {
        (x != 0) as i32 as f64
    })
}

/// `fmi2GetString`/`fmi2SetString`: these models have no String variables, so any reference is
/// unknown; an empty list succeeds.
unsafe fn no_strings<M: Model>(
    c: Fmi2Component,
    call: Call,
    vr: *const Fmi2ValueReference,
    n: usize,
) -> Fmi2Status {
    checked::<M>(c, call, |i, call| match slice(vr, n) {
        None => i.error(call.name, "vr is NULL"),
        Some([]) => Status::Ok,
        Some([v, ..]) => i.error(
            call.name,
            format!("value reference {v} is not a String variable"),
        ),
    })
}

pub unsafe fn get_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    no_strings::<M>(c, calls::GET_STRING, vr, n)
}

pub unsafe fn set_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    _value: *const Fmi2String,
) -> Fmi2Status {
    no_strings::<M>(c, calls::SET_STRING, vr, n)
}

/// Functions this FMU declares it does not provide: they log why and return `fmi2Error`.
pub unsafe fn unsupported<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    why: &'static str,
) -> Fmi2Status {
    Fmi2Logger::with::<M>(c, func, |comp| comp.instance.error(func, why))
}

pub unsafe fn do_step<M: Model>(
    c: Fmi2Component,
    current: Fmi2Real,
    h: Fmi2Real,
    _no_set_prior: Fmi2Boolean,
) -> Fmi2Status {
    checked::<M>(c, calls::DO_STEP, |i, call| i.do_step(call, current, h))
}

/// `fmi2GetStatus`: no step is ever pending, so the status is not available.
pub unsafe fn get_status<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    kind: Fmi2StatusKind,
    value_is_null: bool,
) -> Fmi2Status {
    checked::<M>(c, calls::status(func), |i, _| {
        if value_is_null {
            return i.error(func, "value is NULL");
        }
        i.push_log(
            Status::Discard,
            "logStatusWarning",
            format!("{func}: status kind {kind} is not available (steps are never asynchronous)"),
        );
        Status::Discard
    })
}

/// A status query that is answered for one `kind` (`read` gives the value) and is not
/// available for the others.
unsafe fn status_value<M: Model, T>(
    c: Fmi2Component,
    func: &'static str,
    (kind, answered_kind): (Fmi2StatusKind, Fmi2StatusKind),
    value: *mut T,
    read: impl FnOnce(&Instance<M>) -> T,
) -> Fmi2Status {
    if kind != answered_kind {
        return get_status::<M>(c, func, kind, value.is_null());
    }
    checked::<M>(c, calls::status(func), |i, _| match value.as_mut() {
        None => i.error(func, "value is NULL"),
        Some(value) => {
            *value = read(i);
            Status::Ok
        }
    })
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` (kind 2) gives the current time.
pub unsafe fn get_real_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    status_value::<M, _>(c, "fmi2GetRealStatus", (kind, 2), value, |i| i.time)
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` (kind 3) is always false.
pub unsafe fn get_boolean_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    status_value::<M, _>(c, "fmi2GetBooleanStatus", (kind, 3), value, |_| 0)
}
