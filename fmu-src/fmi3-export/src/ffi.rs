//! The FMI 3.0 C ABI (Co-Simulation here, Model Exchange in [`crate::me`]) over the version-neutral [`Instance`] of `fmi2-export`
//! (state checks, value-reference and value checks, tolerance, stepping, FMU states and their
//! serialization are that instance's; this module converts pointers, maps the FMI 3.0 calls onto
//! it and keeps the FMI 3.0 state names). `catch_unwind` at every entry: no panic crosses the
//! ABI. [`crate::export_fmi3!`] emits the `#[no_mangle]` symbols, each a call to a function here.
//!
//! States (FMI 3.0.2 section 4.2, Co-Simulation with `eventModeUsed = false`): Instantiated,
//! Initialization Mode, Step Mode, Terminated, and the error state a failed step leaves (only
//! `fmi3SetFMUState`, `fmi3Reset` and `fmi3FreeInstance` continue from it; getters still answer
//! for diagnosis). They are the instance's states under their FMI 3.0 names.

#![allow(clippy::missing_safety_doc, clippy::too_many_arguments)]

use crate::c::*;
use crate::TIME_VALUE_REFERENCE;
use fmi2_export::instance::{Instance, Interface, MachineState, Snapshot, Status};
use fmi2_export::variables::index_of;
use fmi2_export::{Model, VarType};
use std::collections::BTreeSet;
use std::ffi::{CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

const MAGIC: u64 = 0x4146_4d55_4933_4353; // "AFMUI3CS"

/// Allowed-state masks of the FMI 3.0 Co-Simulation functions (FMI 3.0.2 section 4.2.1 and the
/// state machine of figure 32, without Event Mode, clocks and configuration).
pub mod allowed {
    use fmi2_export::instance::MachineState::{self, *};
    const fn m(states: &[MachineState]) -> u32 {
        let mut mask = 0;
        let mut i = 0;
        while i < states.len() {
            mask |= states[i] as u32;
            i += 1;
        }
        mask
    }
    pub const ANY: u32 = m(&[
        Instantiated,
        InitializationMode,
        StepComplete,
        StepFailed,
        StepCanceled,
        Terminated,
        Error,
        EventMode,
        ContinuousTimeMode,
    ]);
    pub const ENTER_INIT: u32 = m(&[Instantiated]);
    pub const EXIT_INIT: u32 = m(&[InitializationMode]);
    pub const TERMINATE: u32 = m(&[StepComplete, EventMode, ContinuousTimeMode]);
    pub const GET: u32 = m(&[
        InitializationMode,
        StepComplete,
        Terminated,
        Error,
        EventMode,
        ContinuousTimeMode,
    ]);
    /// Setters; in Continuous-Time Mode the shared instance takes continuous inputs only.
    pub const SET: u32 = m(&[
        Instantiated,
        InitializationMode,
        StepComplete,
        EventMode,
        ContinuousTimeMode,
    ]);
    pub const DO_STEP: u32 = m(&[StepComplete]);
    // Model Exchange (FMI 3.0.2 section 3.2, figure of the Model Exchange state machine):
    // Continuous-Time Mode -> fmi3EnterEventMode -> Event Mode -> fmi3EnterContinuousTimeMode.
    pub const ENTER_EVENT_MODE: u32 = m(&[ContinuousTimeMode]);
    pub const UPDATE_DISCRETE_STATES: u32 = m(&[EventMode]);
    pub const ENTER_CONTINUOUS_TIME_MODE: u32 = m(&[EventMode]);
    pub const COMPLETED_INTEGRATOR_STEP: u32 = m(&[ContinuousTimeMode]);
    pub const SET_TIME: u32 = m(&[EventMode, ContinuousTimeMode]);
    pub const SET_CONTINUOUS_STATES: u32 = m(&[ContinuousTimeMode]);
    pub const GET_DERIVATIVES: u32 = m(&[EventMode, ContinuousTimeMode, Terminated, Error]);
    pub const GET_EVENT_INDICATORS: u32 = m(&[
        InitializationMode,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ]);
    pub const GET_CONTINUOUS_STATES: u32 = GET_EVENT_INDICATORS;
    /// fmi3GetDirectionalDerivative and fmi3GetAdjointDerivative: Initialization Mode, Model
    /// Exchange, and Co-Simulation in Step Mode (FMI 3.0.2 sections 2.3.3 and 4.2.1).
    pub const DIRECTIONAL_DERIVATIVE: u32 = m(&[
        InitializationMode,
        StepComplete,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ]);
    pub const GET_NOMINALS: u32 = m(&[
        Instantiated,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ]);
}

/// The FMI 3.0 name of a state.
fn state_name(s: MachineState) -> &'static str {
    match s {
        MachineState::Instantiated => "Instantiated",
        MachineState::InitializationMode => "Initialization Mode",
        MachineState::StepComplete => "Step Mode",
        MachineState::StepFailed | MachineState::StepCanceled => "Step Discarded",
        MachineState::Terminated => "Terminated",
        MachineState::Error => "the error state (after fmi3Error)",
        // Model Exchange states of the shared instance, never entered by Co-Simulation.
        MachineState::EventMode => "Event Mode",
        MachineState::ContinuousTimeMode => "Continuous-Time Mode",
    }
}

/// What an `fmi3Instance` points to.
pub struct Component<M: Model> {
    magic: u64,
    pub(crate) instance: Instance<M>,
    logger: Fmi3LogMessageCallback,
    environment: Fmi3InstanceEnvironment,
    /// FMU states handed out by this instance and not yet freed.
    states: BTreeSet<usize>,
}

impl<M: Model> Component<M> {
    /// Check the state against `mask` with the FMI 3.0 state names.
    pub(crate) fn check(&mut self, func: &str, mask: u32) -> Result<(), Status> {
        let s = self.instance.state;
        if s as u32 & mask != 0 {
            Ok(())
        } else {
            Err(self.instance.error(
                func,
                format!("illegal call sequence: not allowed in {}", state_name(s)),
            ))
        }
    }

    /// Pass queued messages to the logger (filtered by category) and clear the queue. The shared
    /// instance names its FMI 2.0 function in a message's prefix; the FMI 3.0 function called
    /// replaces it.
    fn flush_log(&mut self, func: &str) {
        let entries = std::mem::take(&mut self.instance.log);
        let Some(logger) = self.logger else { return };
        for e in entries {
            if !self.instance.category_enabled(e.category) {
                continue;
            }
            let message = fmi3_message(func, e.message);
            call_logger(
                logger,
                self.environment,
                e.status.raw(),
                e.category,
                &message,
            );
        }
    }
}

/// A message of the shared instance under the FMI 3.0 function's name: its `fmi2Xxx: ` prefix
/// becomes `func: `; other messages pass unchanged.
fn fmi3_message(func: &str, message: String) -> String {
    match message.split_once(": ") {
        Some((prefix, rest)) if prefix.starts_with("fmi2") => format!("{func}: {rest}"),
        _ => message,
    }
}

fn call_logger(
    logger: unsafe extern "C" fn(Fmi3InstanceEnvironment, Fmi3Status, Fmi3String, Fmi3String),
    env: Fmi3InstanceEnvironment,
    status: Fmi3Status,
    category: &str,
    message: &str,
) {
    let category = CString::new(category).unwrap_or_default();
    let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
    // SAFETY: the logger is the environment's function; both strings live for the call.
    unsafe { logger(env, status, category.as_ptr(), message.as_ptr()) }
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

/// Run `f` on the instance behind `c`, catching panics (the instance then goes to the error
/// state) and flushing the log. A null or foreign pointer gives `fmi3Error`.
pub(crate) unsafe fn with_component<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    f: impl FnOnce(&mut Component<M>) -> Status,
) -> Fmi3Status {
    if c.is_null() {
        return FMI3_ERROR;
    }
    let comp = &mut *(c as *mut Component<M>);
    if comp.magic != MAGIC {
        return FMI3_ERROR;
    }
    let status = match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(s) => s,
        Err(payload) => {
            let msg = panic_message(payload);
            comp.instance.state = MachineState::Error;
            comp.instance.error(func, format!("internal error: {msg}"))
        }
    };
    let _ = catch_unwind(AssertUnwindSafe(|| comp.flush_log(func)));
    status.raw()
}

/// A slice from a C array, or `None` when the pointer is null while `n > 0`.
pub(crate) unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts(p, n))
    }
}

pub(crate) unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(p, n))
    }
}

unsafe fn c_str<'a>(p: Fmi3String) -> Option<&'a str> {
    if p.is_null() {
        None
    } else {
        CStr::from_ptr(p).to_str().ok()
    }
}

pub fn get_version() -> Fmi3String {
    c"3.0".as_ptr()
}

/// Log through the callback an importer passed to a refused instantiation.
fn refuse_instantiation(
    logger: Fmi3LogMessageCallback,
    env: Fmi3InstanceEnvironment,
    msg: &str,
) -> Fmi3Instance {
    if let Some(logger) = logger {
        call_logger(logger, env, FMI3_ERROR, "logStatusError", msg);
    }
    std::ptr::null_mut()
}

/// A new instance of `interface` after the checks every instantiation makes: a non-empty name
/// and the model description's token. `None` (logged) otherwise.
unsafe fn new_component<M: Model>(
    func: &str,
    instance_name: Fmi3String,
    token: Fmi3String,
    logging_on: Fmi3Boolean,
    interface: Interface,
    env: Fmi3InstanceEnvironment,
    logger: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    let name = c_str(instance_name).unwrap_or("");
    if name.is_empty() {
        return refuse_instantiation(
            logger,
            env,
            &format!("{func}: instanceName must be a non-empty string"),
        );
    }
    let expected = fmi2_export::xml::guid::<M>();
    match c_str(token) {
        Some(t) if t == expected => {}
        t => {
            return refuse_instantiation(
                logger,
                env,
                &format!(
                    "{func}: instantiationToken {t:?} does not match this binary's {expected}"
                ),
            )
        }
    }
    let Some(instance) = Instance::with_interface(name, expected, logging_on, interface) else {
        return refuse_instantiation(
            logger,
            env,
            &format!("{func}: {} does not offer Model Exchange", M::NAME),
        );
    };
    let comp = Box::new(Component::<M> {
        magic: MAGIC,
        instance,
        logger,
        environment: env,
        states: BTreeSet::new(),
    });
    Box::into_raw(comp) as Fmi3Instance
}

/// `fmi3InstantiateCoSimulation`: `eventModeUsed` must be false (no Event Mode in Co-Simulation,
/// `hasEventMode="false"`) and no intermediate variables can be required
/// (`providesIntermediateUpdate="false"`); the token must match the model description.
/// `earlyReturnAllowed` is accepted: this FMU never returns early.
pub unsafe fn instantiate_co_simulation<M: Model>(
    instance_name: Fmi3String,
    token: Fmi3String,
    event_mode_used: Fmi3Boolean,
    n_required_intermediate: usize,
    logging_on: Fmi3Boolean,
    env: Fmi3InstanceEnvironment,
    logger: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    const F: &str = "fmi3InstantiateCoSimulation";
    let result = catch_unwind(AssertUnwindSafe(|| {
        if event_mode_used {
            return refuse_instantiation(
                logger,
                env,
                &format!("{F}: eventModeUsed = true, but {} has no Event Mode in Co-Simulation (hasEventMode=\"false\")", M::NAME),
            );
        }
        if n_required_intermediate > 0 {
            return refuse_instantiation(
                logger,
                env,
                &format!("{F}: {} provides no intermediate update (providesIntermediateUpdate=\"false\"); nRequiredIntermediateVariables must be 0", M::NAME),
            );
        }
        new_component::<M>(
            F,
            instance_name,
            token,
            logging_on,
            Interface::CoSimulation,
            env,
            logger,
        )
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// `fmi3InstantiateModelExchange`: the shared instance's Model Exchange (the model's
/// `ModelExchange` implementation); refused for a model without one.
pub unsafe fn instantiate_model_exchange<M: Model>(
    instance_name: Fmi3String,
    token: Fmi3String,
    logging_on: Fmi3Boolean,
    env: Fmi3InstanceEnvironment,
    logger: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    const F: &str = "fmi3InstantiateModelExchange";
    let result = catch_unwind(AssertUnwindSafe(|| {
        new_component::<M>(
            F,
            instance_name,
            token,
            logging_on,
            Interface::ModelExchange,
            env,
            logger,
        )
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// `fmi3InstantiateScheduledExecution`: not offered.
pub fn instantiate_refused<M: Model>(
    func: &str,
    interface: &str,
    env: Fmi3InstanceEnvironment,
    logger: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    let result = catch_unwind(AssertUnwindSafe(|| {
        refuse_instantiation(
            logger,
            env,
            &format!(
                "{func}: {} does not offer {interface} in FMI 3.0 (Model Exchange and Co-Simulation only)",
                M::NAME
            ),
        )
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// `fmi3FreeInstance`: frees the instance and every FMU state it still owns.
pub unsafe fn free_instance<M: Model>(c: Fmi3Instance) {
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

/// A function for a feature this FMU does not offer: `fmi3Error` with the reason logged.
pub unsafe fn unsupported<M: Model>(c: Fmi3Instance, func: &'static str, why: &str) -> Fmi3Status {
    with_component::<M>(c, func, |comp| comp.instance.error(func, why))
}

pub unsafe fn set_debug_logging<M: Model>(
    c: Fmi3Instance,
    logging_on: Fmi3Boolean,
    n: usize,
    categories: *const Fmi3String,
) -> Fmi3Status {
    const F: &str = "fmi3SetDebugLogging";
    with_component::<M>(c, F, |comp| {
        let Some(cats) = slice(categories, n) else {
            return comp.instance.error(F, "categories is NULL");
        };
        let mut names = Vec::with_capacity(n);
        for &p in cats {
            match c_str(p) {
                Some(s) => names.push(s),
                None => return comp.instance.error(F, "a category is NULL or not UTF-8"),
            }
        }
        comp.instance.set_debug_logging(logging_on, &names)
    })
}

/// `fmi3EnterInitializationMode`: the experiment (start, stop, tolerance, which goes to the
/// model's tolerance parameters as in FMI 2.0's `fmi2SetupExperiment`), then Initialization
/// Mode. The worse of the two statuses is returned.
pub unsafe fn enter_initialization_mode<M: Model>(
    c: Fmi3Instance,
    tolerance_defined: Fmi3Boolean,
    tolerance: Fmi3Float64,
    start_time: Fmi3Float64,
    stop_time_defined: Fmi3Boolean,
    stop_time: Fmi3Float64,
) -> Fmi3Status {
    const F: &str = "fmi3EnterInitializationMode";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.check(F, allowed::ENTER_INIT) {
            return s;
        }
        let stop = stop_time_defined.then_some(stop_time);
        let tolerance = tolerance_defined.then_some(tolerance);
        let setup = comp.instance.setup_experiment(start_time, stop, tolerance);
        if setup == Status::Error {
            return setup;
        }
        match comp.instance.enter_initialization_mode() {
            Status::Ok => setup,
            s => s,
        }
    })
}

pub unsafe fn exit_initialization_mode<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    const F: &str = "fmi3ExitInitializationMode";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.check(F, allowed::EXIT_INIT) {
            return s;
        }
        comp.instance.exit_initialization_mode()
    })
}

pub unsafe fn terminate<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    const F: &str = "fmi3Terminate";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.check(F, allowed::TERMINATE) {
            return s;
        }
        comp.instance.terminate()
    })
}

pub unsafe fn reset<M: Model>(c: Fmi3Instance) -> Fmi3Status {
    with_component::<M>(c, "fmi3Reset", |comp| comp.instance.reset())
}

/// `nValues` must equal `nValueReferences`: every variable is a scalar.
fn check_counts<M: Model>(
    comp: &mut Component<M>,
    func: &str,
    nvr: usize,
    nvalues: usize,
) -> Result<(), Status> {
    if nvr == nvalues {
        Ok(())
    } else {
        Err(comp.instance.error(
            func,
            format!("nValues = {nvalues} differs from nValueReferences = {nvr} (every variable is a scalar)"),
        ))
    }
}

/// Shared body of the Float64, Int32 and Boolean getters. `time` (the independent variable) is
/// answered with the current time in `fmi3GetFloat64`.
unsafe fn get_typed<M: Model, T: Copy>(
    c: Fmi3Instance,
    func: &'static str,
    ty: VarType,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut T,
    nvalues: usize,
    convert: impl Fn(f64) -> T,
) -> Fmi3Status {
    with_component::<M>(c, func, |comp| {
        if let Err(s) = comp.check(func, allowed::GET) {
            return s;
        }
        if let Err(s) = check_counts(comp, func, nvr, nvalues) {
            return s;
        }
        let (Some(vrs), Some(out)) = (slice(vr, nvr), slice_mut(value, nvalues)) else {
            return comp
                .instance
                .error(func, "valueReferences or values is NULL");
        };
        // `time` and the event indicators are this layer's variables, not the table's.
        let is_layer_variable = |v: u32| {
            ty == VarType::Real
                && (v == TIME_VALUE_REFERENCE || crate::me::event_indicator_index::<M>(v).is_some())
        };
        let table_vrs: Vec<u32> = vrs
            .iter()
            .copied()
            .filter(|&v| !is_layer_variable(v))
            .collect();
        let mut buf = vec![0.0; table_vrs.len()];
        let s = comp.instance.get_values(func, ty, &table_vrs, &mut buf);
        if s == Status::Ok {
            let mut from_table = buf.into_iter();
            for (o, &v) in out.iter_mut().zip(vrs) {
                let x = if !is_layer_variable(v) {
                    from_table.next().unwrap_or(f64::NAN)
                } else if v == TIME_VALUE_REFERENCE {
                    comp.instance.time
                } else {
                    let k = crate::me::event_indicator_index::<M>(v).unwrap_or(usize::MAX);
                    crate::me::event_indicator(comp, k).unwrap_or(f64::NAN)
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
    func: &'static str,
    ty: VarType,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const T,
    nvalues: usize,
    convert: impl Fn(T) -> f64,
) -> Fmi3Status {
    with_component::<M>(c, func, |comp| {
        if let Err(s) = comp.check(func, allowed::SET) {
            return s;
        }
        if let Err(s) = check_counts(comp, func, nvr, nvalues) {
            return s;
        }
        let (Some(vrs), Some(vals)) = (slice(vr, nvr), slice(value, nvalues)) else {
            return comp
                .instance
                .error(func, "valueReferences or values is NULL");
        };
        if ty == VarType::Real && vrs.contains(&TIME_VALUE_REFERENCE) {
            return comp.instance.error(
                func,
                format!("'time' (value reference {TIME_VALUE_REFERENCE}) is the independent variable and cannot be set"),
            );
        }
        let vals: Vec<f64> = vals.iter().map(|&x| convert(x)).collect();
        if ty == VarType::Real && comp.instance.state == MachineState::ContinuousTimeMode {
            return crate::me::set_float64_in_continuous_time_mode(comp, func, vrs, &vals);
        }
        comp.instance.set_values(func, ty, vrs, &vals)
    })
}

pub unsafe fn get_float64<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut Fmi3Float64,
    nvalues: usize,
) -> Fmi3Status {
    get_typed::<M, f64>(
        c,
        "fmi3GetFloat64",
        VarType::Real,
        vr,
        nvr,
        value,
        nvalues,
        |x| x,
    )
}

pub unsafe fn get_int32<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut Fmi3Int32,
    nvalues: usize,
) -> Fmi3Status {
    get_typed::<M, i32>(
        c,
        "fmi3GetInt32",
        VarType::Integer,
        vr,
        nvr,
        value,
        nvalues,
        |x| x as i32,
    )
}

pub unsafe fn get_boolean<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *mut Fmi3Boolean,
    nvalues: usize,
) -> Fmi3Status {
    get_typed::<M, bool>(
        c,
        "fmi3GetBoolean",
        VarType::Boolean,
        vr,
        nvr,
        value,
        nvalues,
        |x| x != 0.0,
    )
}

pub unsafe fn set_float64<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const Fmi3Float64,
    nvalues: usize,
) -> Fmi3Status {
    set_typed::<M, f64>(
        c,
        "fmi3SetFloat64",
        VarType::Real,
        vr,
        nvr,
        value,
        nvalues,
        |x| x,
    )
}

pub unsafe fn set_int32<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const Fmi3Int32,
    nvalues: usize,
) -> Fmi3Status {
    set_typed::<M, i32>(
        c,
        "fmi3SetInt32",
        VarType::Integer,
        vr,
        nvr,
        value,
        nvalues,
        |x| x as f64,
    )
}

/// Booleans from the importer are read as bytes: any non-zero byte is true.
pub unsafe fn set_boolean<M: Model>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    value: *const Fmi3Boolean,
    nvalues: usize,
) -> Fmi3Status {
    set_typed::<M, u8>(
        c,
        "fmi3SetBoolean",
        VarType::Boolean,
        vr,
        nvr,
        value as *const u8,
        nvalues,
        |x| (x != 0) as i32 as f64,
    )
}

/// Getters and setters of a type this FMU has no variable of (Float32, Int8, ..., String,
/// Binary, Clock): an empty list succeeds; any reference is refused, naming the variable's type
/// when the reference exists.
pub unsafe fn no_variables_of_type<M: Model>(
    c: Fmi3Instance,
    func: &'static str,
    type_name: &str,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    mask: u32,
) -> Fmi3Status {
    with_component::<M>(c, func, |comp| {
        if let Err(s) = comp.check(func, mask) {
            return s;
        }
        let Some(vrs) = slice(vr, nvr) else {
            return comp.instance.error(func, "valueReferences is NULL");
        };
        let Some(&v) = vrs.first() else {
            return Status::Ok;
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
            format!(
                "value reference {v} ('{}') is {kind}, not {type_name}",
                table[i].name
            )
        } else {
            format!("unknown value reference {v}")
        };
        comp.instance.error(func, message)
    })
}

/// `fmi3DoStep` without Event Mode and early return: the outputs are `eventHandlingNeeded`,
/// `terminateSimulation` and `earlyReturn` false and `lastSuccessfulTime` the time reached (on a
/// failed step, the time of the last good communication point; the status is `fmi3Error`).
pub unsafe fn do_step<M: Model>(
    c: Fmi3Instance,
    current: Fmi3Float64,
    h: Fmi3Float64,
    event_handling_needed: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
    early_return: *mut Fmi3Boolean,
    last_successful_time: *mut Fmi3Float64,
) -> Fmi3Status {
    const F: &str = "fmi3DoStep";
    with_component::<M>(c, F, |comp| {
        if let Err(s) = comp.check(F, allowed::DO_STEP) {
            return s;
        }
        if event_handling_needed.is_null()
            || terminate_simulation.is_null()
            || early_return.is_null()
            || last_successful_time.is_null()
        {
            return comp.instance.error(
                F,
                "eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL",
            );
        }
        let s = comp.instance.do_step(current, h);
        *event_handling_needed = false;
        *terminate_simulation = false;
        *early_return = false;
        *last_successful_time = comp.instance.time;
        s
    })
}

/// Look up an FMU state handed out by this instance.
fn own_state<M: Model>(comp: &Component<M>, s: Fmi3FmuState) -> Option<*mut Snapshot<M>> {
    comp.states
        .contains(&(s as usize))
        .then_some(s as *mut Snapshot<M>)
}

pub unsafe fn get_fmu_state<M: Model>(c: Fmi3Instance, state: *mut Fmi3FmuState) -> Fmi3Status {
    const F: &str = "fmi3GetFMUState";
    with_component::<M>(c, F, |comp| {
        if state.is_null() {
            return comp.instance.error(F, "FMUState is NULL");
        }
        let snap = comp.instance.snapshot();
        if (*state).is_null() {
            let p = Box::into_raw(Box::new(snap));
            comp.states.insert(p as usize);
            *state = p as Fmi3FmuState;
            return Status::Ok;
        }
        match own_state(comp, *state) {
            Some(p) => {
                *p = snap;
                Status::Ok
            }
            None => comp
                .instance
                .error(F, "*FMUState is not a state of this instance"),
        }
    })
}

pub unsafe fn set_fmu_state<M: Model>(c: Fmi3Instance, state: Fmi3FmuState) -> Fmi3Status {
    const F: &str = "fmi3SetFMUState";
    with_component::<M>(c, F, |comp| match own_state(comp, state) {
        Some(p) => {
            comp.instance.restore(&*p);
            Status::Ok
        }
        None => comp
            .instance
            .error(F, "FMUState is NULL or not a state of this instance"),
    })
}

pub unsafe fn free_fmu_state<M: Model>(c: Fmi3Instance, state: *mut Fmi3FmuState) -> Fmi3Status {
    const F: &str = "fmi3FreeFMUState";
    with_component::<M>(c, F, |comp| {
        if state.is_null() {
            return comp.instance.error(F, "FMUState is NULL");
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
                .error(F, "*FMUState is not a state of this instance"),
        }
    })
}

/// Serialize an owned state (the format, integrity check and GUID header of the FMI 2.0 FMUs),
/// or log why not.
fn serialized<M: Model>(
    comp: &mut Component<M>,
    f: &str,
    s: Fmi3FmuState,
) -> Result<Vec<u8>, Status> {
    let Some(p) = own_state(comp, s) else {
        return Err(comp
            .instance
            .error(f, "FMUState is NULL or not a state of this instance"));
    };
    // SAFETY: `p` is a live snapshot owned by this instance.
    let snap = unsafe { &*p };
    comp.instance
        .serialize(snap)
        .map_err(|e| comp.instance.error(f, e))
}

pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: Fmi3Instance,
    state: Fmi3FmuState,
    size: *mut usize,
) -> Fmi3Status {
    const F: &str = "fmi3SerializedFMUStateSize";
    with_component::<M>(c, F, |comp| {
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
    c: Fmi3Instance,
    state: Fmi3FmuState,
    out: *mut Fmi3Byte,
    size: usize,
) -> Fmi3Status {
    const F: &str = "fmi3SerializeFMUState";
    with_component::<M>(c, F, |comp| {
        if out.is_null() {
            return comp.instance.error(F, "serializedState is NULL");
        }
        match serialized(comp, F, state) {
            Ok(bytes) if bytes.len() <= size => {
                std::ptr::copy_nonoverlapping(bytes.as_ptr(), out, bytes.len());
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
    c: Fmi3Instance,
    bytes: *const Fmi3Byte,
    size: usize,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    const F: &str = "fmi3DeserializeFMUState";
    with_component::<M>(c, F, |comp| {
        if state.is_null() {
            return comp.instance.error(F, "FMUState is NULL");
        }
        let Some(data) = slice(bytes, size) else {
            return comp.instance.error(F, "serializedState is NULL");
        };
        let snap = match comp.instance.deserialize(data) {
            Ok(s) => s,
            Err(e) => return comp.instance.error(F, e),
        };
        if !(*state).is_null() {
            match own_state(comp, *state) {
                Some(p) => {
                    *p = snap;
                    return Status::Ok;
                }
                None => {
                    return comp
                        .instance
                        .error(F, "*FMUState is not a state of this instance")
                }
            }
        }
        let p = Box::into_raw(Box::new(snap));
        comp.states.insert(p as usize);
        *state = p as Fmi3FmuState;
        Status::Ok
    })
}

#[cfg(test)]
mod tests {
    use super::{allowed, fmi3_message};
    use fmi2_export::instance::allowed as fmi2;

    /// This layer checks the FMI 3.0 state first and then calls the shared instance, whose own
    /// check must then pass: every FMI 3.0 mask lies inside the instance's mask of the same call.
    #[test]
    fn every_fmi3_mask_lies_inside_the_shared_instances() {
        for (fmi3, shared) in [
            (allowed::ENTER_INIT, fmi2::SETUP & fmi2::ENTER_INIT),
            (allowed::EXIT_INIT, fmi2::EXIT_INIT),
            (allowed::TERMINATE, fmi2::TERMINATE),
            (allowed::GET, fmi2::GET),
            (allowed::SET, fmi2::SET),
            (allowed::DO_STEP, fmi2::DO_STEP),
            (allowed::ENTER_EVENT_MODE, fmi2::ENTER_EVENT_MODE),
            (allowed::UPDATE_DISCRETE_STATES, fmi2::NEW_DISCRETE_STATES),
            (
                allowed::ENTER_CONTINUOUS_TIME_MODE,
                fmi2::ENTER_CONTINUOUS_TIME_MODE,
            ),
            (
                allowed::COMPLETED_INTEGRATOR_STEP,
                fmi2::COMPLETED_INTEGRATOR_STEP,
            ),
            (allowed::SET_TIME, fmi2::SET_TIME),
            (allowed::SET_CONTINUOUS_STATES, fmi2::SET_CONTINUOUS_STATES),
            (allowed::GET_DERIVATIVES, fmi2::GET_DERIVATIVES),
            (allowed::GET_EVENT_INDICATORS, fmi2::GET_EVENT_INDICATORS),
            (allowed::GET_CONTINUOUS_STATES, fmi2::GET_CONTINUOUS_STATES),
            (allowed::GET_NOMINALS, fmi2::GET_NOMINALS),
            (
                allowed::DIRECTIONAL_DERIVATIVE,
                fmi2::DIRECTIONAL_DERIVATIVE,
            ),
        ] {
            assert_eq!(fmi3 & !shared, 0, "{fmi3:#b} not inside {shared:#b}");
        }
        assert_eq!(allowed::ANY, fmi2::ANY);
    }

    #[test]
    fn messages_carry_the_fmi3_function_name() {
        let m = fmi3_message("fmi3DoStep", "fmi2DoStep: step failed: x".to_string());
        assert_eq!(m, "fmi3DoStep: step failed: x");
        let m = fmi3_message("fmi3DoStep", "tunable parameters changed".to_string());
        assert_eq!(m, "tunable parameters changed");
    }
}
