//! Raw FMI 2.0 C types (fmi2FunctionTypes.h) and the function table resolved from a binary.

use crate::error::{HostError, LogRecord, Result, Status};
use libloading::Library;
use std::collections::VecDeque;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::marker::PhantomData;
use std::panic::AssertUnwindSafe;
use std::path::Path;
use std::sync::{Mutex, MutexGuard, PoisonError};

pub use fmi_types::c::{
    Boolean as Fmi2Boolean, CallbackFunctions, Component, FmuState, RawStatus, ValueReference,
};

extern "C" {
    /// csrc/logger.c: formats with vsnprintf, then hands the message to the route set with
    /// `fmi2host_set_route`.
    pub fn fmi2host_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: RawStatus,
        category: *const c_char,
        message: *const c_char,
        ...
    );
    /// csrc/logger.c: where `fmi2host_logger` delivers formatted messages.
    fn fmi2host_set_route(route: LogRoute);
    /// csrc/logger.c: calloc
    pub fn fmi2host_calloc(nobj: usize, size: usize) -> *mut c_void;
    /// csrc/logger.c: free
    pub fn fmi2host_free(obj: *mut c_void);
}

/// `(componentEnvironment, instanceName, status, category, message)`, the message formatted.
type LogRoute = extern "C" fn(*mut c_void, *const c_char, RawStatus, *const c_char, *const c_char);

/// The addresses of the logger environments of type `T` that live instances were given, the
/// only environment pointers a logger follows. An FMU must pass back the pointer it was given
/// (FMI 2.0.4 section 2.1.5, FMI 3.0.2 section 2.3.1); some pass a constant such as `(void*)1`.
/// A message with a pointer not listed goes to the only live instance, or is dropped when
/// several are live, instead of the run crashing on it. The lock also keeps an environment from
/// being dropped while a message is delivered to it.
pub(crate) struct LiveEnvs<T>(Mutex<Vec<usize>>, PhantomData<fn(&T)>);

impl<T> LiveEnvs<T> {
    /// No environment listed.
    pub(crate) const fn new() -> Self {
        LiveEnvs(Mutex::new(Vec::new()), PhantomData)
    }

    fn listed(&self) -> MutexGuard<'_, Vec<usize>> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Calls `deliver` with the live environment `env` names (see [`LiveEnvs`]). Called by the
    /// loggers the FMU calls, it never unwinds: a panic ends the delivery, not the C caller.
    pub(crate) fn deliver(&self, env: *mut c_void, deliver: impl FnOnce(&T)) {
        let _ = std::panic::catch_unwind(AssertUnwindSafe(|| {
            let live = self.listed();
            let target = match live.iter().find(|&&p| p == env as usize) {
                Some(&p) => p,
                None if live.len() == 1 => live[0],
                None => return,
            };
            // SAFETY: only `LiveEnv::new` lists addresses, each of a `Box<T>` it owns; its drop
            // withdraws the address under this lock (held until `deliver` returns) before the
            // box is freed.
            deliver(unsafe { &*(target as *const T) });
        }));
    }
}

/// A boxed logger environment, listed in its registry while it lives.
pub(crate) struct LiveEnv<T: 'static> {
    env: Box<T>,
    registry: &'static LiveEnvs<T>,
}

impl<T> LiveEnv<T> {
    /// Boxes `env` and lists it in `registry`.
    pub(crate) fn new(env: T, registry: &'static LiveEnvs<T>) -> Self {
        let env = Box::new(env);
        registry.listed().push(&*env as *const T as usize);
        LiveEnv { env, registry }
    }

    /// The pointer handed to the FMU as its environment.
    pub(crate) fn as_ptr(&self) -> *mut c_void {
        &*self.env as *const T as *mut c_void
    }
}

impl<T> std::ops::Deref for LiveEnv<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.env
    }
}

impl<T> Drop for LiveEnv<T> {
    fn drop(&mut self) {
        let me = self.as_ptr() as usize;
        self.registry.listed().retain(|&p| p != me);
    }
}

/// The sinks of live FMI 2.0 instances.
static LIVE_SINKS: LiveEnvs<LogSink> = LiveEnvs::new();

/// The log sink of an FMI 2.0 instance, listed for the logger while it lives.
pub(crate) fn live_sink(sink: LogSink) -> LiveEnv<LogSink> {
    static ROUTE: std::sync::Once = std::sync::Once::new();
    // SAFETY: sets a function pointer the C shim reads; `Once` orders it before any instance
    // (and so any logger call) made after this returns.
    ROUTE.call_once(|| unsafe { fmi2host_set_route(log_sink) });
    LiveEnv::new(sink, &LIVE_SINKS)
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
fn cstr_lossy(p: *const c_char) -> String {
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
fn bounded(mut s: String) -> String {
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

/// The record of a message an FMU logged with the raw status `status` (both versions' status
/// values are alike), its category and message as C strings, the message cut by [`bounded`].
pub(crate) fn log_record(
    instance: String,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) -> LogRecord {
    LogRecord {
        instance,
        status: Status::from_raw(status),
        category: cstr_lossy(category),
        message: bounded(cstr_lossy(message)),
    }
}

/// The route of the C shim's formatted messages: stores the record in the sink of the live
/// instance `env` names (see [`LiveEnvs`]). Never unwinds across the C boundary.
extern "C" fn log_sink(
    env: *mut c_void,
    instance: *const c_char,
    status: RawStatus,
    category: *const c_char,
    message: *const c_char,
) {
    LIVE_SINKS.deliver(env, |sink| {
        let record = log_record(cstr_lossy(instance), status, category, message);
        let status = record.status.to_string();
        sink.keep(record, &status);
    });
}

/// Names of every function an FMI 2.0 Co-Simulation binary must export (FMI 2.0.4, 2.1 and 4.2).
pub use fmi_types::c::{
    COMMON_AND_CO_SIMULATION_ONLY, CO_SIMULATION_FUNCTIONS as FMI2_CS_FUNCTIONS,
};

/// Declares a table of a binary's C functions once: each field with the symbol it is looked up
/// by, whether the binary must export it (`required`: no table without it; `optional`: `None`
/// when absent) and its C signature. The typed getters and setters, one pair a value type, go
/// under `values $Get, $Set`: a line `T: need get_x "fmiXGetX", set_x "fmiXSetX";` declares
/// `get_x` of signature `$Get<T>` and `set_x` of `$Set<T>`, both required or both optional.
/// Generates the struct (the fields, then the getters, then the setters), `SYMBOLS` (the symbols
/// in field order) and `resolve_table`, which takes the values of the fields listed under
/// `given` (made by the caller: fallbacks and sub-tables).
macro_rules! function_table {
    (
        $(#[$meta:meta])*
        pub struct $table:ident {
            $($field:ident: $need:ident $symbol:literal $sig:ty,)*
        }
        $(values $get_sig:ident, $set_sig:ident {
            $($t:ty: $vneed:ident $get:ident $get_symbol:literal, $set:ident $set_symbol:literal;)*
        })?
        given {
            $($(#[$given_meta:meta])* $given:ident: $given_ty:ty,)*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy)]
        #[allow(missing_docs, clippy::type_complexity)]
        pub struct $table {
            $(pub $field: function_table!(@type $need $sig),)*
            $(
                $(pub $get: function_table!(@type $vneed $get_sig<$t>),)*
                $(pub $set: function_table!(@type $vneed $set_sig<$t>),)*
            )?
            $($(#[$given_meta])* pub $given: $given_ty,)*
        }

        impl $table {
            /// The symbols of the table's functions, in field order.
            pub const SYMBOLS: &'static [&'static str] =
                &[$($symbol,)* $($($get_symbol,)* $($set_symbol,)*)?];

            /// The table of `lib`; Err names the first required function it does not export.
            ///
            /// # Safety
            /// `lib`'s exports must have the standard signatures.
            #[allow(clippy::too_many_arguments)]
            pub(crate) unsafe fn resolve_table(
                lib: &libloading::Library,
                $($given: $given_ty,)*
            ) -> Result<Self, $crate::ffi::LoadError> {
                Ok($table {
                    $($field: function_table!(@get lib $need $symbol),)*
                    $($($get: function_table!(@get lib $vneed $get_symbol),)*)?
                    $($($set: function_table!(@get lib $vneed $set_symbol),)*)?
                    $($given,)*
                })
            }
        }
    };
    (@type required $sig:ty) => { $sig };
    (@type optional $sig:ty) => { Option<$sig> };
    (@get $lib:ident required $symbol:literal) => { $crate::ffi::required($lib, $symbol)? };
    (@get $lib:ident optional $symbol:literal) => { $crate::ffi::sym($lib, $symbol) };
}
pub(crate) use function_table;

type C = Component;
type Vr = *const ValueReference;
/// A call that takes only the instance (`fmi2Terminate`, `fmi2EnterEventMode`, ...).
type Call = unsafe extern "C" fn(C) -> RawStatus;
/// `fmi2Get<Type>(c, vr[], nvr, value[])`.
pub(crate) type Get<T> = unsafe extern "C" fn(C, Vr, usize, *mut T) -> RawStatus;
/// `fmi2Set<Type>(c, vr[], nvr, value[])`.
pub(crate) type Set<T> = unsafe extern "C" fn(C, Vr, usize, *const T) -> RawStatus;
/// `fmi2Get<Type>Status(c, kind, value)`.
pub(crate) type GetStatus<T> = unsafe extern "C" fn(C, c_int, *mut T) -> RawStatus;
/// A call that fills or reads a vector of the continuous states' size (`fmi2GetDerivatives`, ...).
pub(crate) type StateVector<T> = unsafe extern "C" fn(C, T, usize) -> RawStatus;
/// `fmi2GetFMUstate` and `fmi2FreeFMUstate`.
type StateCall = unsafe extern "C" fn(C, *mut FmuState) -> RawStatus;

function_table! {
    /// Function pointers of one loaded binary. Required ones are plain, the rest optional (the
    /// host works without them; `validate` reports every missing one).
    pub struct Functions {
        get_types_platform: optional "fmi2GetTypesPlatform" unsafe extern "C" fn() -> *const c_char,
        get_version: optional "fmi2GetVersion" unsafe extern "C" fn() -> *const c_char,
        set_debug_logging: optional "fmi2SetDebugLogging"
            unsafe extern "C" fn(C, Fmi2Boolean, usize, *const *const c_char) -> RawStatus,
        instantiate: required "fmi2Instantiate"
            unsafe extern "C" fn(
                *const c_char,
                c_int,
                *const c_char,
                *const c_char,
                *const CallbackFunctions,
                Fmi2Boolean,
                Fmi2Boolean,
            ) -> C,
        free_instance: required "fmi2FreeInstance" unsafe extern "C" fn(C),
        setup_experiment: required "fmi2SetupExperiment"
            unsafe extern "C" fn(C, Fmi2Boolean, f64, f64, Fmi2Boolean, f64) -> RawStatus,
        enter_initialization_mode: required "fmi2EnterInitializationMode" Call,
        exit_initialization_mode: required "fmi2ExitInitializationMode" Call,
        terminate: required "fmi2Terminate" Call,
        reset: required "fmi2Reset" Call,
        get_fmu_state: optional "fmi2GetFMUstate" StateCall,
        set_fmu_state: optional "fmi2SetFMUstate" unsafe extern "C" fn(C, FmuState) -> RawStatus,
        free_fmu_state: optional "fmi2FreeFMUstate" StateCall,
        serialized_fmu_state_size: optional "fmi2SerializedFMUstateSize"
            unsafe extern "C" fn(C, FmuState, *mut usize) -> RawStatus,
        serialize_fmu_state: optional "fmi2SerializeFMUstate"
            unsafe extern "C" fn(C, FmuState, *mut c_char, usize) -> RawStatus,
        deserialize_fmu_state: optional "fmi2DeSerializeFMUstate"
            unsafe extern "C" fn(C, *const c_char, usize, *mut FmuState) -> RawStatus,
        cancel_step: optional "fmi2CancelStep" Call,
        get_status: optional "fmi2GetStatus" GetStatus<RawStatus>,
        get_real_status: optional "fmi2GetRealStatus" GetStatus<f64>,
        get_integer_status: optional "fmi2GetIntegerStatus" GetStatus<c_int>,
        get_boolean_status: optional "fmi2GetBooleanStatus" GetStatus<Fmi2Boolean>,
        get_string_status: optional "fmi2GetStringStatus" GetStatus<*const c_char>,
        get_directional_derivative: optional "fmi2GetDirectionalDerivative"
            unsafe extern "C" fn(C, Vr, usize, Vr, usize, *const f64, *mut f64) -> RawStatus,
        set_real_input_derivatives: optional "fmi2SetRealInputDerivatives"
            unsafe extern "C" fn(C, Vr, usize, *const c_int, *const f64) -> RawStatus,
        get_real_output_derivatives: optional "fmi2GetRealOutputDerivatives"
            unsafe extern "C" fn(C, Vr, usize, *const c_int, *mut f64) -> RawStatus,
    }
    values Get, Set {
        f64: required get_real "fmi2GetReal", set_real "fmi2SetReal";
        c_int: required get_integer "fmi2GetInteger", set_integer "fmi2SetInteger";
        Fmi2Boolean: required get_boolean "fmi2GetBoolean", set_boolean "fmi2SetBoolean";
        *const c_char: optional get_string "fmi2GetString", set_string "fmi2SetString";
    }
    given {
        /// `fmi2DoStep`, or for a Model Exchange run of a binary without it a stand-in.
        do_step: DoStep,
        /// The Model Exchange functions, when the binary exports all of them.
        me: Option<MeFunctions>,
    }
}

/// `fmi2DoStep(c, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint)`.
type DoStep = unsafe extern "C" fn(C, f64, f64, Fmi2Boolean) -> RawStatus;

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

function_table! {
    /// The FMI 2.0 Model Exchange functions (FMI 2.0.4 section 3.2).
    pub struct MeFunctions {
        enter_event_mode: required "fmi2EnterEventMode" Call,
        new_discrete_states: required "fmi2NewDiscreteStates"
            unsafe extern "C" fn(C, *mut EventInfo) -> RawStatus,
        enter_continuous_time_mode: required "fmi2EnterContinuousTimeMode" Call,
        completed_integrator_step: required "fmi2CompletedIntegratorStep"
            unsafe extern "C" fn(C, Fmi2Boolean, *mut Fmi2Boolean, *mut Fmi2Boolean) -> RawStatus,
        set_time: required "fmi2SetTime" unsafe extern "C" fn(C, f64) -> RawStatus,
        set_continuous_states: required "fmi2SetContinuousStates" StateVector<*const f64>,
        get_derivatives: required "fmi2GetDerivatives" StateVector<*mut f64>,
        get_event_indicators: required "fmi2GetEventIndicators" StateVector<*mut f64>,
        get_continuous_states: required "fmi2GetContinuousStates" StateVector<*mut f64>,
        get_nominals_of_continuous_states: required "fmi2GetNominalsOfContinuousStates"
            StateVector<*mut f64>,
    }
    given {}
}

/// The functions only the Model Exchange interface has (FMI 2.0.4 section 3.2).
pub const FMI2_ME_FUNCTIONS: &[&str] = MeFunctions::SYMBOLS;

/// Stands in for `fmi2DoStep` in a binary without it (Model Exchange only): never called on a
/// Model Exchange instance; returns fmi2Error should anything call it.
unsafe extern "C" fn absent_do_step(_: C, _: f64, _: f64, _: Fmi2Boolean) -> RawStatus {
    fmi_types::c::ERROR
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
    let me = MeFunctions::resolve_table(lib);
    let do_step = match sym::<DoStep>(lib, "fmi2DoStep") {
        Some(f) => f,
        None if model_exchange => absent_do_step as DoStep,
        None => return Err(LoadError::MissingFunction("fmi2DoStep")),
    };
    if let (true, Err(absent)) = (model_exchange, &me) {
        return Err(absent.clone());
    }
    Functions::resolve_table(lib, do_step, me.ok())
}
