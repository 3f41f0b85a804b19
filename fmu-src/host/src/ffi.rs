//! Raw FMI 2.0 C types (fmi2FunctionTypes.h) and the function table resolved from a binary.

use crate::error::{HostError, LogRecord, Result, Status};
use libloading::Library;
use std::collections::VecDeque;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::path::Path;
use std::sync::Mutex;

pub use fmi_types::c::{
    Boolean as Fmi2Boolean, CallbackFunctions, Component, FmuState, RawStatus, ValueReference,
};

extern "C" {
    /// csrc/logger.c: formats with vsnprintf, then calls `LogEnv::sink`.
    pub fn fmi2host_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: RawStatus,
        category: *const c_char,
        message: *const c_char,
        ...
    );
    /// csrc/logger.c: records `env` as a live instance's `componentEnvironment` (the logger
    /// follows no other pointer); 0 when out of memory.
    pub fn fmi2host_env_register(env: *mut c_void) -> c_int;
    /// csrc/logger.c: `env` is no longer a live instance's.
    pub fn fmi2host_env_withdraw(env: *mut c_void);
    /// csrc/logger.c: calloc
    pub fn fmi2host_calloc(nobj: usize, size: usize) -> *mut c_void;
    /// csrc/logger.c: free
    pub fn fmi2host_free(obj: *mut c_void);
}

/// Where an instance's log messages go (behind `componentEnvironment`). Layout shared with
/// `fmi2host_env` in csrc/logger.c.
#[repr(C)]
pub struct LogEnv {
    /// Called by the C shim with the formatted message.
    pub sink: extern "C" fn(*mut c_void, *const c_char, RawStatus, *const c_char, *const c_char),
    /// Points to the instance's [`LogSink`].
    pub data: *mut c_void,
}

/// Most messages an instance's sink keeps: the newest, since an error's own message comes
/// last (an FMU logging every step would otherwise fill the sink before its error).
pub const MAX_LOG_RECORDS: usize = 10_000;

/// Messages collected for one instance.
#[derive(Default)]
pub struct LogSink {
    /// Messages not yet taken, the newest [`MAX_LOG_RECORDS`] of them.
    pub records: Mutex<VecDeque<LogRecord>>,
    /// Also print each message to stderr.
    pub echo: bool,
}

impl LogSink {
    /// Keeps `record`, the newest [`MAX_LOG_RECORDS`] of them; with `echo`, prints it to stderr
    /// with `status`, its status as the FMU's version names it.
    pub(crate) fn keep(&self, record: LogRecord, status: &str) {
        if self.echo {
            eprintln!(
                "{} {status}: {}",
                crate::error::shown(&record.instance, 40),
                crate::error::shown(&record.message, 1000)
            );
        }
        if let Ok(mut r) = self.records.lock() {
            if r.len() >= MAX_LOG_RECORDS {
                r.pop_front();
            }
            r.push_back(record);
        }
    }

    /// Takes (and clears) every message kept.
    pub(crate) fn take(&self) -> Vec<LogRecord> {
        std::mem::take(&mut *self.records.lock().unwrap_or_else(|e| e.into_inner())).into()
    }

    /// The status `raw` that `function` returned: OK and Warning pass (warnings stay in the
    /// log), anything else becomes [`HostError::Fmi`] carrying the messages logged meanwhile.
    pub(crate) fn check(&self, function: &'static str, raw: c_int) -> Result<Status> {
        let status = Status::from_raw(raw);
        if status.is_success() {
            Ok(status)
        } else {
            Err(HostError::Fmi {
                function,
                status,
                messages: self.take(),
            })
        }
    }
}

/// A C string the FMU passed, as text (invalid UTF-8 replaced); empty for NULL.
pub(crate) fn cstr_lossy(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: the FMU passes NUL-terminated strings (FMI 2.0.4 section 2.1.5, FMI 3.0.2
        // section 2.2.3); p is non-null.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Longest message kept (bytes): an FMU may log without bound.
const MAX_MESSAGE_BYTES: usize = 4096;

/// `s` cut to [`MAX_MESSAGE_BYTES`] (at a character boundary, marked `...`).
pub(crate) fn bounded(mut s: String) -> String {
    if s.len() > MAX_MESSAGE_BYTES {
        let mut end = MAX_MESSAGE_BYTES;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        s.truncate(end);
        s.push_str("...");
    }
    s
}

/// Sink called from C: stores the record. Never unwinds across the C boundary.
pub extern "C" fn log_sink(
    data: *mut c_void,
    instance: *const c_char,
    status: RawStatus,
    category: *const c_char,
    message: *const c_char,
) {
    let _ = std::panic::catch_unwind(|| {
        if data.is_null() {
            return;
        }
        // SAFETY: data is the `LogSink` boxed by the instance, alive while the instance lives.
        let sink = unsafe { &*(data as *const LogSink) };
        let record = LogRecord {
            instance: cstr_lossy(instance),
            status: Status::from_raw(status),
            category: cstr_lossy(category),
            message: bounded(cstr_lossy(message)),
        };
        let status = record.status.to_string();
        sink.keep(record, &status);
    });
}

/// Names of every function an FMI 2.0 Co-Simulation binary must export (FMI 2.0.4, 2.1 and 4.2).
pub use fmi_types::c::{
    COMMON_AND_CO_SIMULATION_ONLY, CO_SIMULATION_FUNCTIONS as FMI2_CS_FUNCTIONS,
};

type C = Component;
type Vr = *const ValueReference;

/// Function pointers of one loaded binary. Required ones are plain, the rest optional (the host
/// works without them; `validate` reports every missing one).
#[derive(Clone, Copy)]
#[allow(missing_docs)]
pub struct Functions {
    pub get_types_platform: Option<unsafe extern "C" fn() -> *const c_char>,
    pub get_version: Option<unsafe extern "C" fn() -> *const c_char>,
    pub set_debug_logging:
        Option<unsafe extern "C" fn(C, Fmi2Boolean, usize, *const *const c_char) -> RawStatus>,
    pub instantiate: unsafe extern "C" fn(
        *const c_char,
        c_int,
        *const c_char,
        *const c_char,
        *const CallbackFunctions,
        Fmi2Boolean,
        Fmi2Boolean,
    ) -> C,
    pub free_instance: unsafe extern "C" fn(C),
    pub setup_experiment:
        unsafe extern "C" fn(C, Fmi2Boolean, f64, f64, Fmi2Boolean, f64) -> RawStatus,
    pub enter_initialization_mode: unsafe extern "C" fn(C) -> RawStatus,
    pub exit_initialization_mode: unsafe extern "C" fn(C) -> RawStatus,
    pub terminate: unsafe extern "C" fn(C) -> RawStatus,
    pub reset: unsafe extern "C" fn(C) -> RawStatus,
    pub get_real: unsafe extern "C" fn(C, Vr, usize, *mut f64) -> RawStatus,
    pub get_integer: unsafe extern "C" fn(C, Vr, usize, *mut c_int) -> RawStatus,
    pub get_boolean: unsafe extern "C" fn(C, Vr, usize, *mut Fmi2Boolean) -> RawStatus,
    pub get_string: Option<unsafe extern "C" fn(C, Vr, usize, *mut *const c_char) -> RawStatus>,
    pub set_real: unsafe extern "C" fn(C, Vr, usize, *const f64) -> RawStatus,
    pub set_integer: unsafe extern "C" fn(C, Vr, usize, *const c_int) -> RawStatus,
    pub set_boolean: unsafe extern "C" fn(C, Vr, usize, *const Fmi2Boolean) -> RawStatus,
    pub set_string: Option<unsafe extern "C" fn(C, Vr, usize, *const *const c_char) -> RawStatus>,
    pub get_fmu_state: Option<unsafe extern "C" fn(C, *mut FmuState) -> RawStatus>,
    pub set_fmu_state: Option<unsafe extern "C" fn(C, FmuState) -> RawStatus>,
    pub free_fmu_state: Option<unsafe extern "C" fn(C, *mut FmuState) -> RawStatus>,
    pub serialized_fmu_state_size:
        Option<unsafe extern "C" fn(C, FmuState, *mut usize) -> RawStatus>,
    pub serialize_fmu_state:
        Option<unsafe extern "C" fn(C, FmuState, *mut c_char, usize) -> RawStatus>,
    pub deserialize_fmu_state:
        Option<unsafe extern "C" fn(C, *const c_char, usize, *mut FmuState) -> RawStatus>,
    pub do_step: unsafe extern "C" fn(C, f64, f64, Fmi2Boolean) -> RawStatus,
    pub cancel_step: Option<unsafe extern "C" fn(C) -> RawStatus>,
    pub get_status: Option<unsafe extern "C" fn(C, c_int, *mut RawStatus) -> RawStatus>,
    pub get_real_status: Option<unsafe extern "C" fn(C, c_int, *mut f64) -> RawStatus>,
    pub get_integer_status: Option<unsafe extern "C" fn(C, c_int, *mut c_int) -> RawStatus>,
    pub get_boolean_status: Option<unsafe extern "C" fn(C, c_int, *mut Fmi2Boolean) -> RawStatus>,
    pub get_string_status: Option<unsafe extern "C" fn(C, c_int, *mut *const c_char) -> RawStatus>,
    pub get_directional_derivative:
        Option<unsafe extern "C" fn(C, Vr, usize, Vr, usize, *const f64, *mut f64) -> RawStatus>,
    pub set_real_input_derivatives:
        Option<unsafe extern "C" fn(C, Vr, usize, *const c_int, *const f64) -> RawStatus>,
    pub get_real_output_derivatives:
        Option<unsafe extern "C" fn(C, Vr, usize, *const c_int, *mut f64) -> RawStatus>,
    /// The Model Exchange functions, when the binary exports all of them.
    pub me: Option<MeFunctions>,
}

/// `fmi2EventInfo` (fmi2FunctionTypes.h), filled by `fmi2NewDiscreteStates`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
#[allow(missing_docs)]
pub struct EventInfo {
    pub new_discrete_states_needed: Fmi2Boolean,
    pub terminate_simulation: Fmi2Boolean,
    pub nominals_of_continuous_states_changed: Fmi2Boolean,
    pub values_of_continuous_states_changed: Fmi2Boolean,
    pub next_event_time_defined: Fmi2Boolean,
    pub next_event_time: f64,
}

/// The FMI 2.0 Model Exchange functions (FMI 2.0.4 section 3.2).
#[derive(Clone, Copy)]
#[allow(missing_docs)]
pub struct MeFunctions {
    pub enter_event_mode: unsafe extern "C" fn(C) -> RawStatus,
    pub new_discrete_states: unsafe extern "C" fn(C, *mut EventInfo) -> RawStatus,
    pub enter_continuous_time_mode: unsafe extern "C" fn(C) -> RawStatus,
    pub completed_integrator_step:
        unsafe extern "C" fn(C, Fmi2Boolean, *mut Fmi2Boolean, *mut Fmi2Boolean) -> RawStatus,
    pub set_time: unsafe extern "C" fn(C, f64) -> RawStatus,
    pub set_continuous_states: unsafe extern "C" fn(C, *const f64, usize) -> RawStatus,
    pub get_derivatives: unsafe extern "C" fn(C, *mut f64, usize) -> RawStatus,
    pub get_event_indicators: unsafe extern "C" fn(C, *mut f64, usize) -> RawStatus,
    pub get_continuous_states: unsafe extern "C" fn(C, *mut f64, usize) -> RawStatus,
    pub get_nominals_of_continuous_states: unsafe extern "C" fn(C, *mut f64, usize) -> RawStatus,
}

/// The functions only the Model Exchange interface has (FMI 2.0.4 section 3.2).
pub const FMI2_ME_FUNCTIONS: &[&str] = &[
    "fmi2EnterEventMode",
    "fmi2NewDiscreteStates",
    "fmi2EnterContinuousTimeMode",
    "fmi2CompletedIntegratorStep",
    "fmi2SetTime",
    "fmi2SetContinuousStates",
    "fmi2GetDerivatives",
    "fmi2GetEventIndicators",
    "fmi2GetContinuousStates",
    "fmi2GetNominalsOfContinuousStates",
];

/// Stands in for `fmi2DoStep` in a binary without it (Model Exchange only): never called on a
/// Model Exchange instance; returns fmi2Error should anything call it.
unsafe extern "C" fn absent_do_step(_: C, _: f64, _: f64, _: Fmi2Boolean) -> RawStatus {
    fmi_types::c::ERROR
}

/// The Model Exchange table, when every function of it is exported.
///
/// # Safety
/// `lib` must be an FMI 2.0 binary whose exports have the standard signatures.
unsafe fn resolve_me(lib: &Library) -> Option<MeFunctions> {
    Some(MeFunctions {
        enter_event_mode: sym(lib, "fmi2EnterEventMode")?,
        new_discrete_states: sym(lib, "fmi2NewDiscreteStates")?,
        enter_continuous_time_mode: sym(lib, "fmi2EnterContinuousTimeMode")?,
        completed_integrator_step: sym(lib, "fmi2CompletedIntegratorStep")?,
        set_time: sym(lib, "fmi2SetTime")?,
        set_continuous_states: sym(lib, "fmi2SetContinuousStates")?,
        get_derivatives: sym(lib, "fmi2GetDerivatives")?,
        get_event_indicators: sym(lib, "fmi2GetEventIndicators")?,
        get_continuous_states: sym(lib, "fmi2GetContinuousStates")?,
        get_nominals_of_continuous_states: sym(lib, "fmi2GetNominalsOfContinuousStates")?,
    })
}

/// Looks up `name` in `lib` as a function pointer of type `T`.
///
/// # Safety
/// `T` must be the correct function pointer type for the symbol.
pub(crate) unsafe fn sym<T: Copy>(lib: &Library, name: &str) -> Option<T> {
    let mut n = name.as_bytes().to_vec();
    n.push(0);
    lib.get::<T>(&n).ok().map(|s| *s)
}

/// [`sym`] for a function the binary must export; Err names it.
///
/// # Safety
/// As [`sym`].
pub(crate) unsafe fn required<T: Copy>(lib: &Library, name: &'static str) -> Result<T, LoadError> {
    sym(lib, name).ok_or(LoadError::MissingFunction(name))
}

/// Names in [`FMI2_CS_FUNCTIONS`] that `lib` does not export.
pub fn missing_symbols(lib: &Library) -> Vec<&'static str> {
    FMI2_CS_FUNCTIONS
        .iter()
        .copied()
        // SAFETY: only the address is looked up, never called.
        .filter(|n| unsafe { sym::<*const c_void>(lib, n) }.is_none())
        .collect()
}

/// Why a binary cannot serve as an FMI 2.0 Co-Simulation library.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LoadError {
    /// The dynamic loader refused it (its message, without the repeated path).
    #[error("cannot be loaded: {0}")]
    CannotLoad(String),
    /// A function every CS binary must export is missing.
    #[error("does not export {0}")]
    MissingFunction(&'static str),
}

/// Loads the shared library at `path`.
///
/// # Safety
/// Loading runs the library's initialisers; the binary must be a trusted FMU.
pub unsafe fn load_library(path: &Path) -> Result<Library, LoadError> {
    let _watch = crate::watch::enter(crate::watch::Call::Load, None);
    Library::new(path).map_err(|e| {
        // dlerror() repeats the path: keep only what follows it.
        let msg = e.to_string();
        let prefix = format!("{}: ", path.display());
        LoadError::CannotLoad(msg.strip_prefix(&prefix).unwrap_or(&msg).to_string())
    })
}

/// Resolves the function table; Err names the first missing required function.
///
/// # Safety
/// `lib` must be an FMI 2.0 binary whose exports have the standard signatures.
pub unsafe fn resolve(lib: &Library) -> Result<Functions, LoadError> {
    resolve_for(lib, false)
}

/// [`resolve`] for the interface used: with `model_exchange`, the Model Exchange functions are
/// required and `fmi2DoStep` is not (an ME-only binary need not export it).
///
/// # Safety
/// `lib` must be an FMI 2.0 binary whose exports have the standard signatures.
pub unsafe fn resolve_for(lib: &Library, model_exchange: bool) -> Result<Functions, LoadError> {
    let me = resolve_me(lib);
    if model_exchange && me.is_none() {
        let absent = FMI2_ME_FUNCTIONS
            .iter()
            // SAFETY: only the address is looked up, never called.
            .find(|n| sym::<*const c_void>(lib, n).is_none());
        return Err(LoadError::MissingFunction(
            absent.copied().unwrap_or("fmi2SetTime"),
        ));
    }
    type DoStep = unsafe extern "C" fn(C, f64, f64, Fmi2Boolean) -> RawStatus;
    let do_step = match sym::<DoStep>(lib, "fmi2DoStep") {
        Some(f) => f,
        None if model_exchange => absent_do_step as DoStep,
        None => return Err(LoadError::MissingFunction("fmi2DoStep")),
    };
    Ok(Functions {
        get_types_platform: sym(lib, "fmi2GetTypesPlatform"),
        get_version: sym(lib, "fmi2GetVersion"),
        set_debug_logging: sym(lib, "fmi2SetDebugLogging"),
        instantiate: required(lib, "fmi2Instantiate")?,
        free_instance: required(lib, "fmi2FreeInstance")?,
        setup_experiment: required(lib, "fmi2SetupExperiment")?,
        enter_initialization_mode: required(lib, "fmi2EnterInitializationMode")?,
        exit_initialization_mode: required(lib, "fmi2ExitInitializationMode")?,
        terminate: required(lib, "fmi2Terminate")?,
        reset: required(lib, "fmi2Reset")?,
        get_real: required(lib, "fmi2GetReal")?,
        get_integer: required(lib, "fmi2GetInteger")?,
        get_boolean: required(lib, "fmi2GetBoolean")?,
        get_string: sym(lib, "fmi2GetString"),
        set_real: required(lib, "fmi2SetReal")?,
        set_integer: required(lib, "fmi2SetInteger")?,
        set_boolean: required(lib, "fmi2SetBoolean")?,
        set_string: sym(lib, "fmi2SetString"),
        get_fmu_state: sym(lib, "fmi2GetFMUstate"),
        set_fmu_state: sym(lib, "fmi2SetFMUstate"),
        free_fmu_state: sym(lib, "fmi2FreeFMUstate"),
        serialized_fmu_state_size: sym(lib, "fmi2SerializedFMUstateSize"),
        serialize_fmu_state: sym(lib, "fmi2SerializeFMUstate"),
        deserialize_fmu_state: sym(lib, "fmi2DeSerializeFMUstate"),
        do_step,
        cancel_step: sym(lib, "fmi2CancelStep"),
        get_status: sym(lib, "fmi2GetStatus"),
        get_real_status: sym(lib, "fmi2GetRealStatus"),
        get_integer_status: sym(lib, "fmi2GetIntegerStatus"),
        get_boolean_status: sym(lib, "fmi2GetBooleanStatus"),
        get_string_status: sym(lib, "fmi2GetStringStatus"),
        get_directional_derivative: sym(lib, "fmi2GetDirectionalDerivative"),
        set_real_input_derivatives: sym(lib, "fmi2SetRealInputDerivatives"),
        get_real_output_derivatives: sym(lib, "fmi2GetRealOutputDerivatives"),
        me,
    })
}
