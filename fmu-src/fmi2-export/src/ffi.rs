//! The FMI 2.0 C ABI over [`Instance`]: pointer checks, `catch_unwind` at every entry, logging
//! through the environment's C-variadic logger (always with a `"%s"` format), FMU-state handles.
//!
//! [`crate::export_model!`] emits the `#[no_mangle] extern "C"` symbols, each a one-line call to
//! the generic function of the same name here.

#![allow(clippy::missing_safety_doc, clippy::too_many_arguments)]

use crate::instance::{allowed, Instance, Interface, Snapshot, Status};
use crate::me_instance::EventInfo;
use crate::{Model, VarType};
use std::collections::BTreeSet;
use std::ffi::{c_int, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The C types of `fmi2FunctionTypes.h`, under the names the exported functions use.
pub use fmi2_types::c::{
    Boolean as Fmi2Boolean, Byte as Fmi2Byte, CallbackFunctions as Fmi2CallbackFunctions,
    CallbackLogger as Fmi2CallbackLogger, Component as Fmi2Component,
    ComponentEnvironment as Fmi2ComponentEnvironment, FmiString as Fmi2String, FmiType as Fmi2Type,
    FmuState as Fmi2FmuState, Integer as Fmi2Integer, RawStatus as Fmi2Status, Real as Fmi2Real,
    StatusKind as Fmi2StatusKind, ValueReference as Fmi2ValueReference,
    CO_SIMULATION as FMI2_COSIMULATION, DISCARD as FMI2_DISCARD, ERROR as FMI2_ERROR,
    MODEL_EXCHANGE as FMI2_MODEL_EXCHANGE, OK as FMI2_OK,
};

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

const MAGIC: u64 = 0x4146_4d55_4932_4353; // "AFMUI2CS"

/// What `fmi2Component` points to.
pub struct Component<M: Model> {
    magic: u64,
    instance: Instance<M>,
    logger: Option<Fmi2CallbackLogger>,
    environment: Fmi2ComponentEnvironment,
    name: CString,
    /// FMU states handed out by this instance and not yet freed.
    states: BTreeSet<usize>,
}

impl<M: Model> Component<M> {
    /// Pass queued messages to the logger (filtered by category) and clear the queue.
    fn flush_log(&mut self) {
        let entries = std::mem::take(&mut self.instance.log);
        let Some(logger) = self.logger else { return };
        for e in entries {
            if !self.instance.category_enabled(e.category) {
                continue;
            }
            call_logger(
                logger,
                self.environment,
                &self.name,
                e.status.raw(),
                e.category,
                &e.message,
            );
        }
    }
}

fn call_logger(
    logger: Fmi2CallbackLogger,
    env: Fmi2ComponentEnvironment,
    name: &CStr,
    status: Fmi2Status,
    category: &str,
    message: &str,
) {
    let category = CString::new(category).unwrap_or_default();
    let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
    // SAFETY: the logger is the environment's function; every pointer is a valid C string that
    // lives for the call, and the format "%s" consumes exactly the one argument passed.
    unsafe {
        logger(
            env,
            name.as_ptr(),
            status,
            category.as_ptr(),
            c"%s".as_ptr(),
            message.as_ptr(),
        );
    }
}

fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

/// Run `f` on the instance behind `c`, catching panics (the instance then goes to the error state)
/// and flushing the log. A null or foreign pointer gives `fmi2Error`.
unsafe fn with_component<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    f: impl FnOnce(&mut Component<M>) -> Status,
) -> Fmi2Status {
    if c.is_null() {
        return FMI2_ERROR;
    }
    let comp = &mut *(c as *mut Component<M>);
    if comp.magic != MAGIC {
        return FMI2_ERROR;
    }
    let status = match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(s) => s,
        Err(payload) => {
            let msg = panic_message(payload);
            comp.instance.state = crate::MachineState::Error;
            comp.instance.error(func, format!("internal error: {msg}"))
        }
    };
    // Logging itself must not unwind into C either.
    let _ = catch_unwind(AssertUnwindSafe(|| comp.flush_log()));
    status.raw()
}

/// A slice from a C array, or `None` when the pointer is null while `n > 0`.
unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts(p, n))
    }
}

unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(p, n))
    }
}

unsafe fn c_str<'a>(p: Fmi2String) -> Option<&'a str> {
    if p.is_null() {
        None
    } else {
        CStr::from_ptr(p).to_str().ok()
    }
}

pub fn get_types_platform() -> Fmi2String {
    c"default".as_ptr()
}

pub fn get_version() -> Fmi2String {
    c"2.0".as_ptr()
}

/// `fmi2Instantiate`: Co-Simulation, or Model Exchange for a model that provides it; the GUID
/// must match the model description.
pub unsafe fn instantiate<M: Model>(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    guid: Fmi2String,
    _resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let (logger, env) = if functions.is_null() {
            (None, std::ptr::null_mut())
        } else {
            ((*functions).logger, (*functions).component_environment)
        };
        let name_str = c_str(instance_name).unwrap_or("");
        let name = CString::new(name_str).unwrap_or_default();
        let fail = |msg: String| {
            if let Some(logger) = logger {
                call_logger(logger, env, &name, FMI2_ERROR, "logStatusError", &msg);
            }
            std::ptr::null_mut()
        };
        if functions.is_null() {
            return std::ptr::null_mut();
        }
        if instance_name.is_null() || name_str.is_empty() {
            return fail("fmi2Instantiate: instanceName must be a non-empty string".into());
        }
        let has_me = M::model_exchange().is_some();
        let interface = match fmu_type {
            FMI2_COSIMULATION => Interface::CoSimulation,
            FMI2_MODEL_EXCHANGE if has_me => Interface::ModelExchange,
            _ if has_me => {
                return fail(format!(
                    "fmi2Instantiate: {} supports Model Exchange (fmuType 0) and Co-Simulation \
                     (fmuType 1), not fmuType {fmu_type}",
                    M::NAME
                ))
            }
            _ => {
                return fail(format!(
                    "fmi2Instantiate: {} supports Co-Simulation (fmuType 1) only, not fmuType {fmu_type}",
                    M::NAME
                ))
            }
        };
        let expected = crate::xml::guid::<M>();
        match c_str(guid) {
            Some(g) if g == expected => {}
            g => {
                return fail(format!(
                    "fmi2Instantiate: GUID {g:?} does not match this binary's {expected}"
                ))
            }
        }
        let Some(instance) =
            Instance::with_interface(name_str, expected, logging_on != 0, interface)
        else {
            return fail("fmi2Instantiate: Model Exchange is not provided".into());
        };
        let comp = Box::new(Component::<M> {
            magic: MAGIC,
            instance,
            logger,
            environment: env,
            name,
            states: BTreeSet::new(),
        });
        Box::into_raw(comp) as Fmi2Component
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// `fmi2FreeInstance`: frees the instance and every FMU state it still owns.
pub unsafe fn free_instance<M: Model>(c: Fmi2Component) {
    if c.is_null() || (*(c as *mut Component<M>)).magic != MAGIC {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let mut comp = Box::from_raw(c as *mut Component<M>);
        comp.magic = 0;
        for p in std::mem::take(&mut comp.states) {
            drop(Box::from_raw(p as *mut Snapshot<M>));
        }
    }));
}

pub unsafe fn set_debug_logging<M: Model>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    with_component::<M>(c, "fmi2SetDebugLogging", |comp| {
        let Some(cats) = slice(categories, n) else {
            return comp
                .instance
                .error("fmi2SetDebugLogging", "categories is NULL");
        };
        let mut names = Vec::with_capacity(n);
        for &p in cats {
            match c_str(p) {
                Some(s) => names.push(s),
                None => {
                    return comp
                        .instance
                        .error("fmi2SetDebugLogging", "a category is NULL or not UTF-8")
                }
            }
        }
        comp.instance.set_debug_logging(logging_on != 0, &names)
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
    with_component::<M>(c, "fmi2SetupExperiment", |comp| {
        let stop = (stop_time_defined != 0).then_some(stop_time);
        let tolerance = (tolerance_defined != 0).then_some(tolerance);
        comp.instance.setup_experiment(start_time, stop, tolerance)
    })
}

pub unsafe fn enter_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    with_component::<M>(c, "fmi2EnterInitializationMode", |comp| {
        comp.instance.enter_initialization_mode()
    })
}

pub unsafe fn exit_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    with_component::<M>(c, "fmi2ExitInitializationMode", |comp| {
        comp.instance.exit_initialization_mode()
    })
}

pub unsafe fn terminate<M: Model>(c: Fmi2Component) -> Fmi2Status {
    with_component::<M>(c, "fmi2Terminate", |comp| comp.instance.terminate())
}

pub unsafe fn reset<M: Model>(c: Fmi2Component) -> Fmi2Status {
    with_component::<M>(c, "fmi2Reset", |comp| comp.instance.reset())
}

/// Shared body of the three numeric getters.
unsafe fn get_typed<M: Model, T: Copy>(
    c: Fmi2Component,
    func: &'static str,
    ty: VarType,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut T,
    convert: impl Fn(f64) -> T,
) -> Fmi2Status {
    with_component::<M>(c, func, |comp| {
        let (Some(vrs), Some(out)) = (slice(vr, n), slice_mut(value, n)) else {
            return comp.instance.error(func, "vr or value is NULL");
        };
        let mut buf = vec![0.0; n];
        let s = comp.instance.get_values(func, ty, vrs, &mut buf);
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
    func: &'static str,
    ty: VarType,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const T,
    convert: impl Fn(T) -> f64,
) -> Fmi2Status {
    with_component::<M>(c, func, |comp| {
        let (Some(vrs), Some(vals)) = (slice(vr, n), slice(value, n)) else {
            return comp.instance.error(func, "vr or value is NULL");
        };
        let vals: Vec<f64> = vals.iter().map(|&x| convert(x)).collect();
        comp.instance.set_values(func, ty, vrs, &vals)
    })
}

pub unsafe fn get_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    get_typed::<M, f64>(c, "fmi2GetReal", VarType::Real, vr, n, value, |x| x)
}

pub unsafe fn get_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    get_typed::<M, c_int>(c, "fmi2GetInteger", VarType::Integer, vr, n, value, |x| {
        x as c_int
    })
}

pub unsafe fn get_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    get_typed::<M, c_int>(c, "fmi2GetBoolean", VarType::Boolean, vr, n, value, |x| {
        (x != 0.0) as c_int
    })
}

pub unsafe fn set_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    set_typed::<M, f64>(c, "fmi2SetReal", VarType::Real, vr, n, value, |x| x)
}

pub unsafe fn set_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    set_typed::<M, c_int>(c, "fmi2SetInteger", VarType::Integer, vr, n, value, |x| {
        x as f64
    })
}

pub unsafe fn set_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    set_typed::<M, c_int>(c, "fmi2SetBoolean", VarType::Boolean, vr, n, value, |x| {
        (x != 0) as i32 as f64
    })
}

/// `fmi2GetString`/`fmi2SetString`: these models have no String variables, so any reference is
/// unknown; an empty list succeeds.
pub unsafe fn no_strings<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    vr: *const Fmi2ValueReference,
    n: usize,
    mask: u32,
) -> Fmi2Status {
    with_component::<M>(c, func, |comp| {
        if let Err(s) = comp.instance.check_state(func, mask) {
            return s;
        }
        let Some(vrs) = slice(vr, n) else {
            return comp.instance.error(func, "vr is NULL");
        };
        match vrs.first() {
            None => Status::Ok,
            Some(v) => comp.instance.error(
                func,
                format!("value reference {v} is not a String variable"),
            ),
        }
    })
}

pub unsafe fn get_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    no_strings::<M>(c, "fmi2GetString", vr, n, allowed::GET)
}

pub unsafe fn set_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    _value: *const Fmi2String,
) -> Fmi2Status {
    no_strings::<M>(c, "fmi2SetString", vr, n, allowed::SET)
}

/// Look up an FMU state handed out by this instance.
fn own_state<M: Model>(comp: &Component<M>, s: Fmi2FmuState) -> Option<*mut Snapshot<M>> {
    comp.states
        .contains(&(s as usize))
        .then_some(s as *mut Snapshot<M>)
}

pub unsafe fn get_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    const F: &str = "fmi2GetFMUstate";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.instance.check_state(F, allowed::ANY) {
            return s;
        }
        if state.is_null() {
            return comp.instance.error(F, "FMUstate is NULL");
        }
        let snap = comp.instance.snapshot();
        if (*state).is_null() {
            let p = Box::into_raw(Box::new(snap));
            comp.states.insert(p as usize);
            *state = p as Fmi2FmuState;
        } else {
            match own_state(comp, *state) {
                Some(p) => *p = snap,
                None => {
                    return comp
                        .instance
                        .error(F, "*FMUstate is not a state of this instance")
                }
            }
        }
        Status::Ok
    })
}

pub unsafe fn set_fmu_state<M: Model>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    const F: &str = "fmi2SetFMUstate";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.instance.check_state(F, allowed::ANY) {
            return s;
        }
        match own_state(comp, state) {
            Some(p) => comp.instance.restore(&*p),
            None => comp
                .instance
                .error(F, "FMUstate is NULL or not a state of this instance"),
        }
    })
}

pub unsafe fn free_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    const F: &str = "fmi2FreeFMUstate";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.instance.check_state(F, allowed::ANY) {
            return s;
        }
        if state.is_null() {
            return comp.instance.error(F, "FMUstate is NULL");
        }
        if (*state).is_null() {
            return Status::Ok;
        }
        match own_state(comp, *state) {
            Some(p) => {
                comp.states.remove(&(p as usize));
                drop(Box::from_raw(p));
                *state = std::ptr::null_mut();
                Status::Ok
            }
            None => comp
                .instance
                .error(F, "*FMUstate is not a state of this instance"),
        }
    })
}

/// Serialize an owned state, or log why not.
fn serialized<M: Model>(
    comp: &mut Component<M>,
    f: &str,
    s: Fmi2FmuState,
) -> Result<Vec<u8>, Status> {
    let Some(p) = own_state(comp, s) else {
        return Err(comp
            .instance
            .error(f, "FMUstate is NULL or not a state of this instance"));
    };
    // SAFETY: `p` is a live snapshot owned by this instance.
    let snap = unsafe { &*p };
    comp.instance
        .serialize(snap)
        .map_err(|e| comp.instance.error(f, e))
}

pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    const F: &str = "fmi2SerializedFMUstateSize";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.instance.check_state(F, allowed::ANY) {
            return s;
        }
        if size.is_null() {
            return comp.instance.error(F, "size is NULL");
        }
        match serialized(comp, F, state) {
            Ok(bytes) => {
                *size = bytes.len();
                Status::Ok
            }
            Err(s) => s,
        }
    })
}

pub unsafe fn serialize_fmu_state<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    out: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    const F: &str = "fmi2SerializeFMUstate";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.instance.check_state(F, allowed::ANY) {
            return s;
        }
        if out.is_null() {
            return comp.instance.error(F, "serializedState is NULL");
        }
        match serialized(comp, F, state) {
            Ok(bytes) if bytes.len() <= size => {
                std::ptr::copy_nonoverlapping(bytes.as_ptr(), out as *mut u8, bytes.len());
                Status::Ok
            }
            Ok(bytes) => comp.instance.error(
                F,
                format!(
                    "buffer of {size} bytes is smaller than the state's {} bytes",
                    bytes.len()
                ),
            ),
            Err(s) => s,
        }
    })
}

pub unsafe fn deserialize_fmu_state<M: Model>(
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    const F: &str = "fmi2DeSerializeFMUstate";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.instance.check_state(F, allowed::ANY) {
            return s;
        }
        if state.is_null() {
            return comp.instance.error(F, "FMUstate is NULL");
        }
        let Some(data) = slice(bytes as *const u8, size) else {
            return comp.instance.error(F, "serializedState is NULL");
        };
        let snap = match comp.instance.deserialize(data) {
            Ok(s) => s,
            Err(e) => return comp.instance.error(F, e),
        };
        if !(*state).is_null() {
            if let Some(p) = own_state(comp, *state) {
                *p = snap;
                return Status::Ok;
            }
        }
        let p = Box::into_raw(Box::new(snap));
        comp.states.insert(p as usize);
        *state = p as Fmi2FmuState;
        Status::Ok
    })
}

/// Functions this FMU declares it does not provide: they log why and return `fmi2Error`.
pub unsafe fn unsupported<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    why: &'static str,
) -> Fmi2Status {
    with_component::<M>(c, func, |comp| comp.instance.error(func, why))
}

pub unsafe fn do_step<M: Model>(
    c: Fmi2Component,
    current: Fmi2Real,
    h: Fmi2Real,
    _no_set_prior: Fmi2Boolean,
) -> Fmi2Status {
    with_component::<M>(c, "fmi2DoStep", |comp| comp.instance.do_step(current, h))
}

/// `fmi2GetStatus`: no step is ever pending, so the status is not available.
pub unsafe fn get_status<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    kind: Fmi2StatusKind,
    value_is_null: bool,
) -> Fmi2Status {
    with_component::<M>(c, func, |comp| {
        if let Err(s) = comp.instance.check_cs_state(func, allowed::STATUS) {
            return s;
        }
        if value_is_null {
            return comp.instance.error(func, "value is NULL");
        }
        comp.instance.push_log(
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
    kind: Fmi2StatusKind,
    answered_kind: Fmi2StatusKind,
    value: *mut T,
    read: impl FnOnce(&Instance<M>) -> T,
) -> Fmi2Status {
    if kind != answered_kind {
        return get_status::<M>(c, func, kind, value.is_null());
    }
    with_component::<M>(c, func, |comp| {
        if let Err(s) = comp.instance.check_cs_state(func, allowed::STATUS) {
            return s;
        }
        if value.is_null() {
            return comp.instance.error(func, "value is NULL");
        }
        *value = read(&comp.instance);
        Status::Ok
    })
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` (kind 2) gives the current time.
pub unsafe fn get_real_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    status_value::<M, _>(c, "fmi2GetRealStatus", kind, 2, value, |i| i.time)
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` (kind 3) is always false.
pub unsafe fn get_boolean_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    status_value::<M, _>(c, "fmi2GetBooleanStatus", kind, 3, value, |_| 0)
}

/// `fmi2SetTime`.
pub unsafe fn set_time<M: Model>(c: Fmi2Component, t: Fmi2Real) -> Fmi2Status {
    with_component::<M>(c, "fmi2SetTime", |comp| comp.instance.set_time(t))
}

/// `fmi2SetContinuousStates`.
pub unsafe fn set_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *const Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    const F: &str = "fmi2SetContinuousStates";
    with_component::<M>(c, F, |comp| match slice(x, nx) {
        Some(x) => comp.instance.set_continuous_states(x),
        None => comp.instance.error(F, "x is NULL"),
    })
}

/// `fmi2EnterEventMode`.
pub unsafe fn enter_event_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    with_component::<M>(c, "fmi2EnterEventMode", |comp| {
        comp.instance.enter_event_mode()
    })
}

/// `fmi2EnterContinuousTimeMode`.
pub unsafe fn enter_continuous_time_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    with_component::<M>(c, "fmi2EnterContinuousTimeMode", |comp| {
        comp.instance.enter_continuous_time_mode()
    })
}

/// `fmi2NewDiscreteStates`.
pub unsafe fn new_discrete_states<M: Model>(
    c: Fmi2Component,
    info: *mut Fmi2EventInfo,
) -> Fmi2Status {
    const F: &str = "fmi2NewDiscreteStates";
    with_component::<M>(c, F, |comp| {
        if info.is_null() {
            return comp.instance.error(F, "fmi2eventInfo is NULL");
        }
        let mut e = EventInfo::default();
        let s = comp.instance.new_discrete_states(&mut e);
        if s == Status::Ok {
            *info = Fmi2EventInfo {
                new_discrete_states_needed: e.new_discrete_states_needed as Fmi2Boolean,
                terminate_simulation: e.terminate_simulation as Fmi2Boolean,
                nominals_of_continuous_states_changed: e.nominals_of_continuous_states_changed
                    as Fmi2Boolean,
                values_of_continuous_states_changed: e.values_of_continuous_states_changed
                    as Fmi2Boolean,
                next_event_time_defined: e.next_event_time.is_some() as Fmi2Boolean,
                next_event_time: e.next_event_time.unwrap_or(0.0),
            };
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
    const F: &str = "fmi2CompletedIntegratorStep";
    with_component::<M>(c, F, |comp| {
        if enter_event_mode.is_null() || terminate_simulation.is_null() {
            return comp
                .instance
                .error(F, "enterEventMode or terminateSimulation is NULL");
        }
        let (s, event, terminate) = comp.instance.completed_integrator_step();
        if s == Status::Ok {
            *enter_event_mode = event as Fmi2Boolean;
            *terminate_simulation = terminate as Fmi2Boolean;
        }
        s
    })
}

/// Shared body of the four functions that fill a real array of the model's size.
unsafe fn get_array<M: Model>(
    c: Fmi2Component,
    func: &'static str,
    p: *mut Fmi2Real,
    n: usize,
    get: impl FnOnce(&mut Instance<M>, &mut [f64]) -> Status,
) -> Fmi2Status {
    with_component::<M>(c, func, |comp| match slice_mut(p, n) {
        Some(out) => get(&mut comp.instance, out),
        None => comp.instance.error(func, "the array is NULL"),
    })
}

/// `fmi2GetDerivatives`.
pub unsafe fn get_derivatives<M: Model>(
    c: Fmi2Component,
    dx: *mut Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    get_array::<M>(c, "fmi2GetDerivatives", dx, nx, |i, out| {
        i.get_derivatives(out)
    })
}

/// `fmi2GetEventIndicators`.
pub unsafe fn get_event_indicators<M: Model>(
    c: Fmi2Component,
    z: *mut Fmi2Real,
    ni: usize,
) -> Fmi2Status {
    get_array::<M>(c, "fmi2GetEventIndicators", z, ni, |i, out| {
        i.get_event_indicators(out)
    })
}

/// `fmi2GetContinuousStates`.
pub unsafe fn get_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *mut Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    get_array::<M>(c, "fmi2GetContinuousStates", x, nx, |i, out| {
        i.get_continuous_states(out)
    })
}

/// `fmi2GetNominalsOfContinuousStates`.
pub unsafe fn get_nominals_of_continuous_states<M: Model>(
    c: Fmi2Component,
    n: *mut Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    get_array::<M>(c, "fmi2GetNominalsOfContinuousStates", n, nx, |i, out| {
        i.get_nominals(out)
    })
}

/// `fmi2GetDirectionalDerivative`: Model Exchange and Co-Simulation of a model with an analytic
/// Jacobian.
pub unsafe fn get_directional_derivative<M: Model>(
    c: Fmi2Component,
    unknowns: *const Fmi2ValueReference,
    n_unknown: usize,
    knowns: *const Fmi2ValueReference,
    n_known: usize,
    dv_known: *const Fmi2Real,
    dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    const F: &str = "fmi2GetDirectionalDerivative";
    with_component::<M>(c, F, |comp| {
        let arrays = (
            slice(unknowns, n_unknown),
            slice(knowns, n_known),
            slice(dv_known, n_known),
            slice_mut(dv_unknown, n_unknown),
        );
        let (Some(u), Some(k), Some(dv), Some(dz)) = arrays else {
            return comp.instance.error(F, "an array argument is NULL");
        };
        comp.instance.get_directional_derivative(u, k, dv, dz)
    })
}

/// Export every FMI 2.0 function (Model Exchange and Co-Simulation) for model type `$model` from this `cdylib`.
#[macro_export]
macro_rules! export_model {
    ($model:ty) => {
        /// The exported model type, named where the macro is invoked (so a bare name resolves).
        type Fmi2ExportedModel = $model;

        mod fmi2_exports {
            #![allow(non_snake_case, unused_imports, clippy::missing_safety_doc)]
            use super::Fmi2ExportedModel as M;
            use $crate::ffi::*;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> Fmi2String {
                get_types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> Fmi2String {
                get_version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Fmi2Component,
                on: Fmi2Boolean,
                n: usize,
                cats: *const Fmi2String,
            ) -> Fmi2Status {
                set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: Fmi2String,
                ty: Fmi2Type,
                guid: Fmi2String,
                res: Fmi2String,
                f: *const Fmi2CallbackFunctions,
                visible: Fmi2Boolean,
                logging: Fmi2Boolean,
            ) -> Fmi2Component {
                instantiate::<M>(name, ty, guid, res, f, visible, logging)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
                free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: Fmi2Component,
                tol_defined: Fmi2Boolean,
                tol: Fmi2Real,
                start: Fmi2Real,
                stop_defined: Fmi2Boolean,
                stop: Fmi2Real,
            ) -> Fmi2Status {
                setup_experiment::<M>(c, tol_defined, tol, start, stop_defined, stop)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
                enter_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
                exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
                terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
                reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Real,
            ) -> Fmi2Status {
                get_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Integer,
            ) -> Fmi2Status {
                get_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                get_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2String,
            ) -> Fmi2Status {
                get_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Real,
            ) -> Fmi2Status {
                set_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Integer,
            ) -> Fmi2Status {
                set_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Boolean,
            ) -> Fmi2Status {
                set_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2String,
            ) -> Fmi2Status {
                set_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: Fmi2Component,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(
                c: Fmi2Component,
                s: Fmi2FmuState,
            ) -> Fmi2Status {
                set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                c: Fmi2Component,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Fmi2Component,
                s: Fmi2FmuState,
                size: *mut usize,
            ) -> Fmi2Status {
                serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Fmi2Component,
                s: Fmi2FmuState,
                b: *mut Fmi2Byte,
                size: usize,
            ) -> Fmi2Status {
                serialize_fmu_state::<M>(c, s, b, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Fmi2Component,
                b: *const Fmi2Byte,
                size: usize,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                deserialize_fmu_state::<M>(c, b, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Fmi2Component,
                unknowns: *const Fmi2ValueReference,
                n_unknown: usize,
                knowns: *const Fmi2ValueReference,
                n_known: usize,
                dv_known: *const Fmi2Real,
                dv_unknown: *mut Fmi2Real,
            ) -> Fmi2Status {
                get_directional_derivative::<M>(
                    c, unknowns, n_unknown, knowns, n_known, dv_known, dv_unknown,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _order: *const Fmi2Integer,
                _v: *const Fmi2Real,
            ) -> Fmi2Status {
                unsupported::<M>(
                    c,
                    "fmi2SetRealInputDerivatives",
                    "inputs are not interpolated (canInterpolateInputs=\"false\")",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _order: *const Fmi2Integer,
                _v: *mut Fmi2Real,
            ) -> Fmi2Status {
                unsupported::<M>(
                    c,
                    "fmi2GetRealOutputDerivatives",
                    "output derivatives are not provided (maxOutputDerivativeOrder=\"0\")",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: Fmi2Component,
                t: Fmi2Real,
                h: Fmi2Real,
                no_set_prior: Fmi2Boolean,
            ) -> Fmi2Status {
                do_step::<M>(c, t, h, no_set_prior)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
                unsupported::<M>(
                    c,
                    "fmi2CancelStep",
                    "steps are never asynchronous (canRunAsynchronuously=\"false\")",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Status,
            ) -> Fmi2Status {
                get_status::<M>(c, "fmi2GetStatus", k, v.is_null())
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Real,
            ) -> Fmi2Status {
                get_real_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Integer,
            ) -> Fmi2Status {
                get_status::<M>(c, "fmi2GetIntegerStatus", k, v.is_null())
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                get_boolean_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetTime(c: Fmi2Component, t: Fmi2Real) -> Fmi2Status {
                set_time::<M>(c, t)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetContinuousStates(
                c: Fmi2Component,
                x: *const Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                set_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterEventMode(c: Fmi2Component) -> Fmi2Status {
                enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2NewDiscreteStates(
                c: Fmi2Component,
                info: *mut Fmi2EventInfo,
            ) -> Fmi2Status {
                new_discrete_states::<M>(c, info)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(c: Fmi2Component) -> Fmi2Status {
                enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
                c: Fmi2Component,
                no_set_prior: Fmi2Boolean,
                enter_event_mode: *mut Fmi2Boolean,
                terminate: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                completed_integrator_step::<M>(c, no_set_prior, enter_event_mode, terminate)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDerivatives(
                c: Fmi2Component,
                dx: *mut Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                get_derivatives::<M>(c, dx, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetEventIndicators(
                c: Fmi2Component,
                z: *mut Fmi2Real,
                ni: usize,
            ) -> Fmi2Status {
                get_event_indicators::<M>(c, z, ni)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetContinuousStates(
                c: Fmi2Component,
                x: *mut Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                get_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
                c: Fmi2Component,
                n: *mut Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                get_nominals_of_continuous_states::<M>(c, n, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2String,
            ) -> Fmi2Status {
                get_status::<M>(c, "fmi2GetStringStatus", k, v.is_null())
            }

            /// Every exported model's variable table follows FMI 2.0 (names, units, ranges,
            /// causality/variability/initial) and the candidate-effect convention.
            #[test]
            fn variable_table_is_consistent() {
                let vars = <M as $crate::Model>::variables();
                let mut problems = $crate::xml::check_table(vars);
                if let Some(me) = <M as $crate::Model>::model_exchange() {
                    problems.extend(me.check(vars));
                }
                assert!(problems.is_empty(), "{problems:#?}");
            }
        }
    };
}
