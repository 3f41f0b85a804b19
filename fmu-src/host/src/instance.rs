//! One FMI 2.0 Co-Simulation instance (RAII: dropping it calls fmi2FreeInstance).

use crate::error::{fmu_state_given, HostError, LogRecord, Result, Status};
use crate::ffi::{self, CallbackFunctions, Component, FmuState, LiveEnv, LogSink, RawStatus};
use crate::fmu::Fmu;
use crate::kind::Interface;
use crate::watch::{self, Call};
use ffi::Fmi2Boolean;
use std::ffi::{c_char, c_int, CString};
use std::sync::atomic::{AtomicUsize, Ordering};

/// `fmi2CoSimulation` for fmi2Instantiate's fmuType.
const FMI2_COSIMULATION: c_int = 1;
/// `fmi2ModelExchange` for fmi2Instantiate's fmuType.
const FMI2_MODEL_EXCHANGE: c_int = 0;

/// Options of [`Fmu::instantiate_with`] (default: all off).
#[derive(Clone, Debug, Default)]
pub struct InstanceOptions {
    /// `visible`
    pub visible: bool,
    /// `loggingOn`. Off by default, as in FMPy: an FMU's debug messages (ours log every step when
    /// it is on) cost time in every call, and error messages arrive without it (the standard's
    /// `logStatusError` is not debug logging; ours and the Reference FMUs log errors either way).
    pub logging_on: bool,
    /// Print every logged message to stderr as it arrives.
    pub echo_log: bool,
}

/// A saved FMU state (fmi2FMUstate), freed with the instance that made it.
pub struct FmuStateHandle {
    raw: FmuState,
}

/// A live instance of an [`Fmu`]. Not `Sync`; `Send` so it can move to a worker thread.
pub struct Instance<'a> {
    pub(crate) fmu: &'a Fmu,
    pub(crate) component: Component,
    // Boxed so their addresses stay fixed while the FMU holds pointers to them.
    _callbacks: Box<CallbackFunctions>,
    /// The instance's `componentEnvironment`.
    log: LiveEnv<LogSink>,
    _name: CString,
    states: Vec<FmuState>,
}

// SAFETY: an FMI 2.0 instance may be used from any thread as long as calls are not concurrent;
// `Instance` is not `Sync` and its methods take `&mut self` for every FMI call.
unsafe impl Send for Instance<'_> {}

impl Fmu {
    /// Instantiates a Co-Simulation instance named `name` with default options.
    pub fn instantiate(&self, name: &str) -> Result<Instance<'_>> {
        self.instantiate_with(name, &InstanceOptions::default())
    }

    /// Instantiates with explicit options.
    pub fn instantiate_with(&self, name: &str, opts: &InstanceOptions) -> Result<Instance<'_>> {
        let once = self
            .model_description()
            .co_simulation
            .as_ref()
            .is_some_and(|c| c.can_be_instantiated_only_once_per_process);
        in_instance_slot(&self.live_instances, once, || {
            self.instantiate_inner(name, opts)
        })
    }

    fn instantiate_inner(&self, name: &str, opts: &InstanceOptions) -> Result<Instance<'_>> {
        let cname = CString::new(name)
            .map_err(|_| HostError::Request("instance name contains a NUL byte".into()))?;
        let md = self.model_description();
        let guid = CString::new(md.guid.clone())
            .map_err(|_| HostError::Request("GUID contains a NUL byte".into()))?;
        let uri = CString::new(self.extracted().resource_uri())
            .map_err(|_| HostError::Request("resource path contains a NUL byte".into()))?;
        let log = ffi::live_sink(LogSink {
            records: Default::default(),
            echo: opts.echo_log,
        });
        let callbacks = Box::new(CallbackFunctions {
            logger: Some(ffi::fmi2host_logger),
            allocate_memory: Some(ffi::fmi2host_calloc),
            free_memory: Some(ffi::fmi2host_free),
            step_finished: None,
            component_environment: log.as_ptr(),
        });
        let _watch = watch::enter(Call::Instantiate, None);
        // SAFETY: all pointers are valid NUL-terminated strings / boxed structs that outlive
        // the instance (they are owned by it).
        let component = unsafe {
            (self.functions.instantiate)(
                cname.as_ptr(),
                match self.interface() {
                    Interface::CoSimulation => FMI2_COSIMULATION,
                    Interface::ModelExchange => FMI2_MODEL_EXCHANGE,
                },
                guid.as_ptr(),
                uri.as_ptr(),
                &*callbacks,
                opts.visible as c_int,
                opts.logging_on as c_int,
            )
        };
        if component.is_null() {
            let messages = log.take();
            return Err(HostError::Instantiate { messages });
        }
        Ok(Instance {
            fmu: self,
            component,
            _callbacks: callbacks,
            log,
            _name: cname,
            states: Vec::new(),
        })
    }
}

/// Methods of an instance type, each calling the FMI function in its field of the binary's
/// function table with the instance (field `$handle`) alone: marked as `Call::$call` for the
/// supervisor (`$watch`: [`watch::enter`] or [`watch::enter3`]), its status checked as
/// `$function`. An `optional` function the binary lacks is an error naming it. FMI 2.0 and
/// FMI 3.0 share these calls' shape.
macro_rules! instance_calls {
    (
        $handle:ident, $watch:path;
        $($(#[$doc:meta])* $method:ident: $call:ident $function:literal $($need:ident)?;)*
    ) => {$(
        $(#[$doc])*
        pub fn $method(&mut self) -> Result<Status> {
            let f = instance_calls!(@fn self.fmu.functions.$method, $function, $($need)?);
            let _watch = $watch(Call::$call, None);
            // SAFETY: the instance is live (it is freed only when dropped).
            let raw = unsafe { f(self.$handle) };
            self.check($function, raw)
        }
    )*};
    (@fn $f:expr, $function:literal, optional) => { $crate::instance::exported($f, $function)? };
    (@fn $f:expr, $function:literal, ) => { $f };
}
pub(crate) use instance_calls;

/// The method of an instance type that hands the experiment (tolerance, start and stop time)
/// to the FMU with the function in field `$method`: fmi2SetupExperiment and
/// fmi3EnterInitializationMode take the same arguments. Marked and checked as in
/// [`instance_calls`].
macro_rules! experiment_call {
    ($(#[$doc:meta])* $method:ident, $handle:ident, $watch:path, $call:ident, $function:literal) => {
        $(#[$doc])*
        pub fn $method(
            &mut self,
            tolerance: Option<f64>,
            start_time: f64,
            stop_time: Option<f64>,
        ) -> Result<Status> {
            let f = self.fmu.functions.$method;
            let given = $crate::instance::given;
            let ((tol_given, tol), (stop_given, stop)) = (given(tolerance), given(stop_time));
            let _watch = $watch(Call::$call, Some(start_time));
            // SAFETY: the instance is live (it is freed only when dropped).
            let raw = unsafe { f(self.$handle, tol_given, tol, start_time, stop_given, stop) };
            self.check($function, raw)
        }
    };
}
pub(crate) use experiment_call;

/// Methods of an FMI 2.0 instance getting and setting the values of one type with the
/// function table's field of the same name.
macro_rules! typed_values {
    ($($t:ty: $get:ident $get_name:literal, $set:ident $set_name:literal;)*) => {$(
        #[doc = concat!($get_name, " into `out` (same length as `vrs`).")]
        pub fn $get(&mut self, vrs: &[u32], out: &mut [$t]) -> Result<Status> {
            let f = self.fmu.functions.$get;
            self.get_values(($get_name, f), vrs, out)
        }

        #[doc = concat!($set_name, " with `values` (same length as `vrs`).")]
        pub fn $set(&mut self, vrs: &[u32], values: &[$t]) -> Result<Status> {
            let f = self.fmu.functions.$set;
            self.set_values(($set_name, f), vrs, values)
        }
    )*};
}

impl<'a> Instance<'a> {
    /// The FMU this instance belongs to.
    pub fn fmu(&self) -> &'a Fmu {
        self.fmu
    }

    /// Takes (and clears) every message logged so far.
    pub fn take_log(&mut self) -> Vec<LogRecord> {
        self.log.take()
    }

    /// Converts a raw status: OK/Warning pass (warnings stay in the log), anything else becomes
    /// [`HostError::Fmi`] carrying the messages logged during the call.
    pub(crate) fn check(&mut self, function: &'static str, raw: RawStatus) -> Result<Status> {
        self.log.check(function, raw)
    }

    experiment_call!(
        /// fmi2SetupExperiment
        setup_experiment, component, watch::enter, SetupExperiment, "fmi2SetupExperiment"
    );

    instance_calls!(component, watch::enter;
        /// fmi2EnterInitializationMode
        enter_initialization_mode: EnterInitializationMode "fmi2EnterInitializationMode";
        /// fmi2ExitInitializationMode
        exit_initialization_mode: ExitInitializationMode "fmi2ExitInitializationMode";
        /// fmi2Terminate
        terminate: Terminate "fmi2Terminate";
        /// fmi2Reset: back to the state after fmi2Instantiate (start values restored).
        reset: Reset "fmi2Reset";
    );

    /// fmi2DoStep(currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint)
    pub fn do_step(&mut self, t: f64, h: f64, no_set_prior: bool) -> Result<Status> {
        let _watch = watch::enter(Call::DoStep, Some(t));
        // SAFETY: component is a live instance of this binary.
        let raw =
            unsafe { (self.fmu.functions.do_step)(self.component, t, h, no_set_prior as c_int) };
        self.check("fmi2DoStep", raw)
    }

    typed_values! {
        f64: get_real "fmi2GetReal", set_real "fmi2SetReal";
        // c_int is i32 on every platform FMUs are built for
        i32: get_integer "fmi2GetInteger", set_integer "fmi2SetInteger";
    }

    /// fmi2GetBoolean
    pub fn get_boolean(&mut self, vrs: &[u32], out: &mut [bool]) -> Result<Status> {
        check_len(vrs.len(), out.len())?;
        let mut raw_vals = vec![0 as Fmi2Boolean; vrs.len()];
        let f = self.fmu.functions.get_boolean;
        let st = self.get_values(("fmi2GetBoolean", f), vrs, &mut raw_vals)?;
        for (o, r) in out.iter_mut().zip(raw_vals) {
            *o = r != 0;
        }
        Ok(st)
    }

    /// fmi2SetBoolean
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<Status> {
        let raw_vals: Vec<Fmi2Boolean> = values.iter().map(|&b| b as Fmi2Boolean).collect();
        let f = self.fmu.functions.set_boolean;
        self.set_values(("fmi2SetBoolean", f), vrs, &raw_vals)
    }

    /// The getter `name` of one type into `out` (same length as `vrs`).
    fn get_values<T>(
        &mut self,
        (name, f): (&'static str, ffi::Get<T>),
        vrs: &[u32],
        out: &mut [T],
    ) -> Result<Status> {
        check_len(vrs.len(), out.len())?;
        let _watch = watch::enter(Call::Get, None);
        // SAFETY: both slices have vrs.len() elements.
        let raw = unsafe { f(self.component, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        self.check(name, raw)
    }

    /// The setter `name` of one type with `values` (same length as `vrs`).
    fn set_values<T>(
        &mut self,
        (name, f): (&'static str, ffi::Set<T>),
        vrs: &[u32],
        values: &[T],
    ) -> Result<Status> {
        check_len(vrs.len(), values.len())?;
        let _watch = watch::enter(Call::Set, None);
        // SAFETY: both slices have vrs.len() elements.
        let raw = unsafe { f(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check(name, raw)
    }

    /// fmi2GetString (copies the strings)
    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>> {
        let f = exported(self.fmu.functions.get_string, "fmi2GetString")?;
        let mut ptrs: Vec<*const c_char> = vec![std::ptr::null(); vrs.len()];
        let _watch = watch::enter(Call::Get, None);
        // SAFETY: both buffers have vrs.len() elements.
        let raw = unsafe { f(self.component, vrs.as_ptr(), vrs.len(), ptrs.as_mut_ptr()) };
        self.check("fmi2GetString", raw)?;
        Ok(ptrs
            .into_iter()
            .map(|p| {
                if p.is_null() {
                    String::new()
                } else {
                    // SAFETY: the FMU returns NUL-terminated strings valid until the next call.
                    unsafe { std::ffi::CStr::from_ptr(p) }
                        .to_string_lossy()
                        .into_owned()
                }
            })
            .collect())
    }

    /// fmi2SetString
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<Status> {
        check_len(vrs.len(), values.len())?;
        let f = exported(self.fmu.functions.set_string, "fmi2SetString")?;
        let owned = c_strings(values, "string value")?;
        let ptrs: Vec<*const c_char> = owned.iter().map(|c| c.as_ptr()).collect();
        let _watch = watch::enter(Call::Set, None);
        // SAFETY: both buffers have vrs.len() elements; the strings outlive the call.
        let raw = unsafe { f(self.component, vrs.as_ptr(), vrs.len(), ptrs.as_ptr()) };
        self.check("fmi2SetString", raw)
    }

    /// fmi2SetDebugLogging: `categories` empty means all categories.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<Status> {
        let f = exported(self.fmu.functions.set_debug_logging, "fmi2SetDebugLogging")?;
        let owned = c_strings(categories, "category")?;
        let ptrs: Vec<*const c_char> = owned.iter().map(|c| c.as_ptr()).collect();
        let cats = if ptrs.is_empty() {
            std::ptr::null()
        } else {
            ptrs.as_ptr()
        };
        let _watch = watch::enter(Call::Other, None);
        // SAFETY: ptrs has ptrs.len() valid C strings (or NULL with 0).
        let raw = unsafe { f(self.component, on as c_int, ptrs.len(), cats) };
        self.check("fmi2SetDebugLogging", raw)
    }

    /// fmi2GetBooleanStatus(fmi2Terminated = 3): whether the FMU ended the simulation itself
    /// (after fmi2DoStep returned fmi2Discard).
    pub fn terminated(&mut self) -> Result<bool> {
        let f = self.fmu.functions.get_boolean_status;
        Ok(self.status_value(("fmi2GetBooleanStatus", f), 3)? != 0)
    }

    /// fmi2GetRealStatus(fmi2LastSuccessfulTime = 2): the time of the last successful step.
    pub fn last_successful_time(&mut self) -> Result<f64> {
        let f = self.fmu.functions.get_real_status;
        self.status_value(("fmi2GetRealStatus", f), 2)
    }

    /// The status query `name` of one type for `kind` (FMI 2.0.4 section 4.2.3).
    fn status_value<T: Default>(
        &mut self,
        (name, f): (&'static str, Option<ffi::GetStatus<T>>),
        kind: c_int,
    ) -> Result<T> {
        let f = exported(f, name)?;
        let mut value = T::default();
        let _watch = watch::enter(Call::Other, None);
        // SAFETY: value is a valid out pointer.
        let raw = unsafe { f(self.component, kind, &mut value) };
        self.check(name, raw)?;
        Ok(value)
    }

    /// fmi2GetFMUstate: saves the current state; the handle is valid while this instance lives.
    pub fn get_fmu_state(&mut self) -> Result<FmuStateHandle> {
        let f = exported(self.fmu.functions.get_fmu_state, "fmi2GetFMUstate")?;
        let mut state: FmuState = std::ptr::null_mut();
        let _watch = watch::enter(Call::FmuState, None);
        // SAFETY: state is a valid out pointer (NULL asks the FMU to allocate).
        let raw = unsafe { f(self.component, &mut state) };
        let status = self.check("fmi2GetFMUstate", raw)?;
        fmu_state_given("fmi2GetFMUstate", status, state.is_null())?;
        self.states.push(state);
        Ok(FmuStateHandle { raw: state })
    }

    /// fmi2SetFMUstate: restores a state saved by this instance.
    pub fn set_fmu_state(&mut self, state: &FmuStateHandle) -> Result<Status> {
        let f = exported(self.fmu.functions.set_fmu_state, "fmi2SetFMUstate")?;
        if !self.states.contains(&state.raw) {
            return Err(HostError::Request(
                "FMU state does not belong to this instance".into(),
            ));
        }
        let _watch = watch::enter(Call::FmuState, None);
        // SAFETY: the state was produced by this instance and not yet freed.
        let raw = unsafe { f(self.component, state.raw) };
        self.check("fmi2SetFMUstate", raw)
    }

    /// fmi2SerializedFMUstateSize + fmi2SerializeFMUstate
    pub fn serialize_fmu_state(&mut self, state: &FmuStateHandle) -> Result<Vec<u8>> {
        let fs = exported(
            self.fmu.functions.serialized_fmu_state_size,
            "fmi2SerializedFMUstateSize",
        )?;
        let f = exported(
            self.fmu.functions.serialize_fmu_state,
            "fmi2SerializeFMUstate",
        )?;
        if !self.states.contains(&state.raw) {
            return Err(HostError::Request(
                "FMU state does not belong to this instance".into(),
            ));
        }
        let mut size = 0usize;
        let _watch = watch::enter(Call::FmuState, None);
        // SAFETY: valid state of this instance, valid out pointer.
        let raw = unsafe { fs(self.component, state.raw, &mut size) };
        self.check("fmi2SerializedFMUstateSize", raw)?;
        let mut buf = vec![0u8; size];
        // SAFETY: buf has `size` bytes.
        let raw = unsafe {
            f(
                self.component,
                state.raw,
                buf.as_mut_ptr() as *mut c_char,
                size,
            )
        };
        self.check("fmi2SerializeFMUstate", raw)?;
        Ok(buf)
    }

    /// fmi2DeSerializeFMUstate: a new state handle from bytes.
    pub fn deserialize_fmu_state(&mut self, bytes: &[u8]) -> Result<FmuStateHandle> {
        let f = exported(
            self.fmu.functions.deserialize_fmu_state,
            "fmi2DeSerializeFMUstate",
        )?;
        let mut state: FmuState = std::ptr::null_mut();
        let _watch = watch::enter(Call::FmuState, None);
        // SAFETY: bytes is a valid buffer of its length; state is a valid out pointer.
        let raw = unsafe {
            f(
                self.component,
                bytes.as_ptr() as *const c_char,
                bytes.len(),
                &mut state,
            )
        };
        let status = self.check("fmi2DeSerializeFMUstate", raw)?;
        fmu_state_given("fmi2DeSerializeFMUstate", status, state.is_null())?;
        self.states.push(state);
        Ok(FmuStateHandle { raw: state })
    }

    /// fmi2FreeFMUstate for one saved state.
    pub fn free_fmu_state(&mut self, state: FmuStateHandle) -> Result<Status> {
        let f = exported(self.fmu.functions.free_fmu_state, "fmi2FreeFMUstate")?;
        let Some(pos) = self.states.iter().position(|s| *s == state.raw) else {
            return Err(HostError::Request(
                "FMU state does not belong to this instance".into(),
            ));
        };
        self.states.swap_remove(pos);
        let mut raw_state = state.raw;
        let _watch = watch::enter(Call::FmuState, None);
        // SAFETY: state produced by this instance, removed from the list so freed once.
        let raw = unsafe { f(self.component, &mut raw_state) };
        self.check("fmi2FreeFMUstate", raw)
    }

    /// The raw component pointer (for probes that must call functions with bad arguments).
    pub fn component(&self) -> Component {
        self.component
    }
}

impl Drop for Instance<'_> {
    fn drop(&mut self) {
        if let Some(f) = self.fmu.functions.free_fmu_state {
            for mut s in std::mem::take(&mut self.states) {
                let _watch = watch::enter(Call::FmuState, None);
                // SAFETY: each state was produced by this instance and is freed once.
                unsafe { f(self.component, &mut s) };
            }
        }
        let _watch = watch::enter(Call::FreeInstance, None);
        // SAFETY: component is live; freed exactly once here.
        unsafe { (self.fmu.functions.free_instance)(self.component) };
        self.fmu.live_instances.fetch_sub(1, Ordering::SeqCst);
    }
}

fn check_len(a: usize, b: usize) -> Result<()> {
    if a == b {
        Ok(())
    } else {
        Err(HostError::Request(format!(
            "{a} value references but {b} values"
        )))
    }
}

/// `texts` as C strings; Err when one (a `what`) contains a NUL byte.
fn c_strings(texts: &[&str], what: &str) -> Result<Vec<CString>> {
    texts
        .iter()
        .map(|v| CString::new(*v))
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| HostError::Request(format!("{what} contains a NUL byte")))
}

/// Runs `instantiate` in a slot reserved in `live` (the FMU's live instances) first, so that two
/// threads cannot both pass the check: refused when the FMU declares
/// canBeInstantiatedOnlyOncePerProcess (`once`) and an instance is alive; the slot is given back
/// when instantiation fails.
pub(crate) fn in_instance_slot<T>(
    live: &AtomicUsize,
    once: bool,
    instantiate: impl FnOnce() -> Result<T>,
) -> Result<T> {
    let before = live.fetch_add(1, Ordering::SeqCst);
    let result = if once && before > 0 {
        Err(HostError::Request(
            "the FMU declares canBeInstantiatedOnlyOncePerProcess and an instance is alive".into(),
        ))
    } else {
        instantiate()
    };
    if result.is_err() {
        live.fetch_sub(1, Ordering::SeqCst);
    }
    result
}

/// An optional argument as the C calls take it: (whether it is given, its value or 0).
pub(crate) fn given<B: From<bool>>(x: Option<f64>) -> (B, f64) {
    (B::from(x.is_some()), x.unwrap_or(0.0))
}

/// The error for a function the binary does not export.
pub(crate) fn missing(name: &str) -> HostError {
    HostError::Request(format!("the FMU binary does not export {name}"))
}

/// An optional function `f` of the binary, called `name`; Err when it is not exported.
pub(crate) fn exported<T>(f: Option<T>, name: &str) -> Result<T> {
    f.ok_or_else(|| missing(name))
}
