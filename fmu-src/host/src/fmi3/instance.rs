//! An opened FMI 3.0 FMU ([`Fmu3`]) and one Co-Simulation instance of it ([`Instance3`], RAII:
//! dropping it calls fmi3FreeInstance).

use super::ffi::{self, Bool3, Env3, Functions3, RawStatus3};
use super::md::ModelDescription3;
use super::value::{Type3, Values};
use crate::error::{HostError, LogRecord, Result, Status};
use crate::ffi::LiveEnv;
use crate::fmu::{binary_under, check_library_name, Unpacked};
use crate::instance::{experiment_call, exported, in_instance_slot, instance_calls};
use crate::kind::Interface;
use crate::watch::{self, Call};
use libloading::Library;
use std::ffi::{c_char, c_void, CStr, CString};
use std::path::Path;
use std::ptr::null;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The platform tuple folder of this machine's binaries (FMI 3.0.2 section 2.5.1.4:
/// `<architecture>-<operating system>`).
pub const PLATFORM_TUPLE: &str = if cfg!(all(target_arch = "x86_64", target_os = "linux")) {
    "x86_64-linux"
} else if cfg!(all(target_arch = "aarch64", target_os = "linux")) {
    "aarch64-linux"
} else if cfg!(all(target_arch = "x86_64", target_os = "macos")) {
    "x86_64-darwin"
} else if cfg!(all(target_arch = "aarch64", target_os = "macos")) {
    "aarch64-darwin"
} else if cfg!(all(target_arch = "x86_64", target_os = "windows")) {
    "x86_64-windows"
} else {
    "unknown"
};

/// The clause a `modelIdentifier` that is no C identifier violates.
const IDENTIFIER_CLAUSE: &str =
    "FMI 3.0.2 section 2.4.5: modelIdentifier is a short class name according to C syntax";

/// An opened FMI 3.0 FMU: extracted tree, parsed description, loaded Co-Simulation binary.
pub struct Fmu3 {
    pub(crate) functions: Functions3,
    /// The interface its instances are made for.
    interface: Interface,
    /// Co-Simulation instances are made with `eventModeUsed = true` (see
    /// [`clocks_in_co_simulation`]).
    event_mode: bool,
    live_instances: AtomicUsize,
    model_description: ModelDescription3,
    // Field order matters: the library is unloaded before the extracted files are removed.
    library: Library,
    unpacked: Unpacked,
}

impl Fmu3 {
    /// Opens an FMI 3.0 `.fmu` (or extracted directory) for Co-Simulation: parses the
    /// description, refuses what the host does not run (no `<CoSimulation>`, a clock of no
    /// kind the standard defines), loads
    /// `binaries/<platform tuple>/<modelIdentifier>.so` and resolves the functions.
    pub fn open(path: impl AsRef<Path>) -> Result<Fmu3> {
        Fmu3::open_with(path, Some(Interface::CoSimulation))
    }

    /// [`Fmu3::open`] for `interface` (None: Co-Simulation where the FMU offers it, else Model
    /// Exchange): for Model Exchange the `<ModelExchange>` element's binary and functions.
    pub fn open_with(path: impl AsRef<Path>, interface: Option<Interface>) -> Result<Fmu3> {
        let unpacked = Unpacked::open(path)?;
        let md = ModelDescription3::parse(&unpacked.xml, &unpacked.description_file())?;
        let fmu = unpacked.path.clone();
        let interface = interface.unwrap_or(
            if md.co_simulation.is_none() && md.model_exchange.is_some() {
                Interface::ModelExchange
            } else {
                Interface::CoSimulation
            },
        );
        let refused = no_interface(&md).or_else(|| crate::me::clocks::refusal(&md));
        if let Some(reason) = refused {
            return Err(HostError::Unsupported {
                path: fmu,
                message: reason,
            });
        }
        let (element, name) = match interface {
            Interface::CoSimulation => (&md.co_simulation, "CoSimulation"),
            Interface::ModelExchange => (&md.model_exchange, "ModelExchange"),
        };
        let cs = element.as_ref().ok_or_else(|| HostError::Unsupported {
            path: fmu.clone(),
            message: format!("the FMU has no <{name}> element"),
        })?;
        check_library_name(&cs.model_identifier, &fmu, IDENTIFIER_CLAUSE)?;
        let bin = binary_under(&unpacked.dir, &fmu, PLATFORM_TUPLE, &cs.model_identifier)?;
        let rel = format!(
            "binaries/{PLATFORM_TUPLE}/{}",
            bin.file_name().unwrap_or_default().to_string_lossy()
        );
        if !bin.is_file() {
            return Err(HostError::Archive {
                path: fmu,
                message: format!("no binary for this platform (expected {rel})"),
            });
        }
        let bad = |message: String| HostError::Binary {
            path: fmu.clone(),
            message: format!("{rel} {message}"),
        };
        // SAFETY: loading an FMU's binary is the purpose of the host; the FMU is trusted.
        let library = unsafe { crate::ffi::load_library(&bin) }.map_err(|e| bad(e.to_string()))?;
        // SAFETY: the symbols are FMI 3.0 functions with the standard signatures.
        let functions = unsafe { ffi::resolve(&library) }.map_err(|e| bad(e.to_string()))?;
        let cs_missing =
            functions.instantiate_co_simulation.is_none() || functions.do_step.is_none();
        if interface == Interface::CoSimulation && cs_missing {
            return Err(bad(
                "does not export fmi3InstantiateCoSimulation and fmi3DoStep, which its \
                 <CoSimulation> element requires"
                    .into(),
            ));
        }
        if interface == Interface::ModelExchange
            && (functions.instantiate_model_exchange.is_none() || functions.me.is_none())
        {
            return Err(bad(
                "does not export fmi3InstantiateModelExchange and the Model Exchange functions \
                 its <ModelExchange> element requires"
                    .into(),
            ));
        }
        let event_mode = interface == Interface::CoSimulation
            && clocks_in_co_simulation(&md) == ClocksInCs::EventMode
            && functions
                .events
                .is_some_and(|e| e.enter_step_mode.is_some());
        Ok(Fmu3 {
            functions,
            interface,
            event_mode,
            live_instances: AtomicUsize::new(0),
            model_description: md,
            library,
            unpacked,
        })
    }

    /// The interface its instances are made for.
    pub fn interface(&self) -> Interface {
        self.interface
    }

    /// Whether its Co-Simulation instances use Event Mode (`eventModeUsed = true`): when it has
    /// clocks and `hasEventMode` (FMI 3.0.2 section 2.3.1: "For FMUs that have clocks,
    /// eventModeUsed = fmi3True is required").
    pub fn event_mode_used(&self) -> bool {
        self.event_mode
    }

    /// The Event Mode function a Co-Simulation binary does not export although its description
    /// asks for Event Mode (clocks and `hasEventMode`): its instances then run without it.
    /// None when nothing is missing or Event Mode is not asked for.
    pub fn event_mode_function_missing(&self) -> Option<&'static str> {
        let asked = self.interface == Interface::CoSimulation
            && clocks_in_co_simulation(&self.model_description) == ClocksInCs::EventMode;
        match self.functions.events {
            _ if !asked => None,
            None => ["fmi3EnterEventMode", "fmi3UpdateDiscreteStates"]
                .into_iter()
                // SAFETY: only the address is looked up, never called.
                .find(|n| unsafe { crate::ffi::sym::<*const c_void>(&self.library, n) }.is_none()),
            Some(e) => e.enter_step_mode.is_none().then_some("fmi3EnterStepMode"),
        }
    }

    /// `earlyReturnAllowed`: with Event Mode, when the FMU declares `mightReturnEarlyFromDoStep`
    /// (the run then continues from `lastSuccessfulTime`, FMI 3.0.2 section 4.2.1).
    pub fn early_return_allowed(&self) -> bool {
        self.event_mode
            && self
                .model_description
                .co_simulation
                .as_ref()
                .is_some_and(|c| c.flag("mightReturnEarlyFromDoStep"))
    }

    /// The parsed description.
    pub fn model_description(&self) -> &ModelDescription3 {
        &self.model_description
    }

    /// The path the FMU was opened from.
    pub fn path(&self) -> &Path {
        &self.unpacked.path
    }

    /// The `resourcePath` fmi3Instantiate* takes: the absolute path of `resources/` with a
    /// trailing separator (FMI 3.0.2 section 2.3.1; a path, no longer FMI 2.0's URI).
    pub fn resource_path(&self) -> String {
        let dir = std::path::absolute(self.unpacked.dir.join("resources"))
            .unwrap_or_else(|_| self.unpacked.dir.join("resources"));
        let mut s = dir.to_string_lossy().into_owned();
        s.push(std::path::MAIN_SEPARATOR);
        s
    }

    /// Instantiates (Co-Simulation: `eventModeUsed` and `earlyReturnAllowed` as
    /// [`Fmu3::event_mode_used`] and [`Fmu3::early_return_allowed`] say, no intermediate
    /// variables; logging off).
    pub fn instantiate(&self, name: &str) -> Result<Instance3<'_>> {
        let element = match self.interface {
            Interface::CoSimulation => &self.model_description.co_simulation,
            Interface::ModelExchange => &self.model_description.model_exchange,
        };
        let once = element
            .as_ref()
            .is_some_and(|c| c.flag("canBeInstantiatedOnlyOncePerProcess"));
        in_instance_slot(&self.live_instances, once, || self.instantiate_inner(name))
    }

    fn instantiate_inner(&self, name: &str) -> Result<Instance3<'_>> {
        let nul = |what: &str| HostError::Request(format!("{what} contains a NUL byte"));
        let cname = CString::new(name).map_err(|_| nul("instance name"))?;
        let token = CString::new(self.model_description.instantiation_token.clone())
            .map_err(|_| nul("instantiationToken"))?;
        let resources = CString::new(self.resource_path()).map_err(|_| nul("resource path"))?;
        let env = Env3::boxed(name);
        let (n, t, r) = (cname.as_ptr(), token.as_ptr(), resources.as_ptr());
        let (env_ptr, log) = (env.as_ptr(), Some(ffi::log_message as _));
        // SAFETY (both calls): every pointer is a valid NUL-terminated string or the boxed
        // environment, all owned by the instance and alive as long as it is; no intermediate
        // variables (NULL, 0).
        let (function, instance) = if self.interface == Interface::ModelExchange {
            let function = "fmi3InstantiateModelExchange";
            let f = exported(self.functions.instantiate_model_exchange, function)?;
            let _watch = watch::enter3(Call::Instantiate, None);
            (function, unsafe { f(n, t, r, 0, 0, env_ptr, log) })
        } else {
            let function = "fmi3InstantiateCoSimulation";
            let f = exported(self.functions.instantiate_co_simulation, function)?;
            let event_mode = Bool3::from(self.event_mode_used());
            let early_return = Bool3::from(self.early_return_allowed());
            let _watch = watch::enter3(Call::Instantiate, None);
            let instance = unsafe {
                f(
                    n,
                    t,
                    r,
                    0,
                    0,
                    event_mode,
                    early_return,
                    null(),
                    0,
                    env_ptr,
                    log,
                    None,
                )
            };
            (function, instance)
        };
        self.instantiated(instance, env, cname, function)
    }

    /// The instance `fmi3Instantiate*` returned, or its error when it returned NULL.
    fn instantiated(
        &self,
        instance: ffi::Instance3,
        env: LiveEnv<Env3>,
        cname: CString,
        function: &'static str,
    ) -> Result<Instance3<'_>> {
        if instance.is_null() {
            let messages = env.sink.take();
            return Err(HostError::InstantiateNull { function, messages });
        }
        Ok(Instance3 {
            fmu: self,
            instance,
            env,
            _name: cname,
        })
    }
}

/// What a Co-Simulation run does with the clocks of `md`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClocksInCs {
    /// No clocks.
    None,
    /// Clocks and `hasEventMode`: the run uses Event Mode and drives them.
    EventMode,
    /// Clocks without `hasEventMode`, which FMI 3.0.2 section 4.4 asks for ("If the FMU has
    /// clocks, then hasEventMode must be true"): the instance runs without Event Mode and the
    /// FMU ignores its clocks.
    Ignored,
}

/// What a Co-Simulation run does with the clocks of `md`.
pub fn clocks_in_co_simulation(md: &ModelDescription3) -> ClocksInCs {
    if !md.variables.iter().any(|v| v.ty == Type3::Clock) {
        ClocksInCs::None
    } else if md
        .co_simulation
        .as_ref()
        .is_some_and(|c| c.flag("hasEventMode"))
    {
        ClocksInCs::EventMode
    } else {
        ClocksInCs::Ignored
    }
}

/// Why `validate`'s runtime probes do not run an FMU, naming what they lack; None if they can.
/// The probes call the functions of each state without Event Mode in Co-Simulation and set no
/// clock: an FMU with clocks is left to `simulate`.
pub fn unsupported(md: &ModelDescription3) -> Option<String> {
    if let Some(reason) = no_interface(md) {
        return Some(reason);
    }
    let clocks: Vec<&str> = md
        .variables
        .iter()
        .filter(|v| v.ty == Type3::Clock)
        .map(|v| v.name.as_str())
        .take(3)
        .collect();
    if !clocks.is_empty() {
        return Some(format!(
            "the probes do not drive FMI 3.0 clocks (the FMU declares Clock variables such as \
             '{}'); simulate runs them",
            clocks.join("', '")
        ));
    }
    None
}

/// Why an FMU offers no interface this host runs (neither Co-Simulation nor Model Exchange).
fn no_interface(md: &ModelDescription3) -> Option<String> {
    if md.co_simulation.is_none() && md.model_exchange.is_none() {
        let offers: Vec<&str> = [(md.scheduled_execution.is_some(), "Scheduled Execution")]
            .iter()
            .filter(|(on, _)| *on)
            .map(|(_, n)| *n)
            .collect();
        return Some(format!(
            "FMI 3.0 {} is not supported by this command (FMI 3.0 Co-Simulation and Model \
             Exchange are): the FMU offers neither <CoSimulation> nor <ModelExchange>",
            if offers.is_empty() {
                "without an interface".to_string()
            } else {
                offers.join(" or ")
            }
        ));
    }
    None
}

/// What fmi3DoStep reported besides its status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepOutcome {
    /// `terminateSimulation`: the FMU asks to end the run.
    pub terminate: bool,
    /// `eventHandlingNeeded`: the FMU met an event at `lastSuccessfulTime` (Event Mode only).
    pub event_handling_needed: bool,
    /// `lastSuccessfulTime`: how far the step got.
    pub last_successful_time: f64,
    /// `earlyReturn`
    pub early_return: bool,
    /// The status (OK or Warning; Discard when the FMU ended the run).
    pub status: Status,
}

/// A live FMI 3.0 Co-Simulation instance. Not `Sync`; `Send` so it can move to a worker
/// thread.
pub struct Instance3<'a> {
    pub(crate) fmu: &'a Fmu3,
    pub(crate) instance: ffi::Instance3,
    // Boxed so its address stays fixed while the FMU holds it.
    env: LiveEnv<Env3>,
    _name: CString,
}

// SAFETY: an FMI 3.0 instance may be used from any thread as long as its functions are not
// called concurrently (the standard leaves thread safety within one instance to the importer);
// `Instance3` is not `Sync` and every call takes `&mut self`.
unsafe impl Send for Instance3<'_> {}

impl<'a> Instance3<'a> {
    /// The FMU this instance belongs to.
    pub fn fmu(&self) -> &'a Fmu3 {
        self.fmu
    }

    /// Takes (and clears) every message logged so far.
    pub fn take_log(&mut self) -> Vec<LogRecord> {
        self.env.sink.take()
    }

    /// Converts a raw status as [`crate::Instance`] does.
    pub(crate) fn check(&mut self, function: &'static str, raw: RawStatus3) -> Result<Status> {
        self.env.sink.check(function, raw)
    }

    experiment_call!(
        /// fmi3EnterInitializationMode(tolerance, startTime, stopTime)
        enter_initialization_mode,
        instance,
        watch::enter3,
        EnterInitializationMode,
        "fmi3EnterInitializationMode"
    );

    instance_calls!(instance, watch::enter3;
        /// fmi3ExitInitializationMode (to Step Mode, event mode not being used)
        exit_initialization_mode: ExitInitializationMode "fmi3ExitInitializationMode";
        /// fmi3EnterConfigurationMode (structural parameters may then be set)
        enter_configuration_mode: Other "fmi3EnterConfigurationMode" optional;
        /// fmi3ExitConfigurationMode
        exit_configuration_mode: Other "fmi3ExitConfigurationMode" optional;
        /// fmi3Terminate
        terminate: Terminate "fmi3Terminate";
        /// fmi3Reset: back to the state after instantiation.
        reset: Reset "fmi3Reset";
    );

    /// fmi3DoStep(currentCommunicationPoint, communicationStepSize,
    /// noSetFMUStatePriorToCurrentPoint). `fmi3Discard` with `terminateSimulation` true comes
    /// back as an outcome with `terminate` set (the FMU ended the run; FMI 3.0.2 section
    /// 4.2.1), any other status but OK/Warning as an error.
    pub fn do_step(&mut self, t: f64, h: f64, no_set_prior: bool) -> Result<StepOutcome> {
        let f = exported(self.fmu.functions.do_step, "fmi3DoStep")?;
        let (mut event, mut terminate, mut early) = (0 as Bool3, 0 as Bool3, 0 as Bool3);
        let mut last = t;
        let _watch = watch::enter3(Call::DoStep, Some(t));
        // SAFETY: instance is live; every out pointer is a valid local.
        let raw = unsafe {
            f(
                self.instance,
                t,
                h,
                no_set_prior as Bool3,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            )
        };
        let status = Status::from_raw(raw);
        if status == Status::Discard && terminate != 0 {
            return Ok(StepOutcome {
                terminate: true,
                event_handling_needed: event != 0,
                last_successful_time: last,
                early_return: early != 0,
                status,
            });
        }
        let status = self.check("fmi3DoStep", raw)?;
        Ok(StepOutcome {
            terminate: terminate != 0,
            event_handling_needed: event != 0,
            last_successful_time: last,
            early_return: early != 0,
            status,
        })
    }

    /// fmi3Get{type}: `n_values` values (the elements of every array among `vrs`) of type `ty`.
    pub fn get(&mut self, ty: Type3, vrs: &[u32], n_values: usize) -> Result<Values> {
        let (i, f) = (self.instance, &self.fmu.functions);
        let (nv, p) = (vrs.len(), vrs.as_ptr());
        let _watch = watch::enter3(Call::Get, None);
        macro_rules! get {
            ($fun:ident, $variant:ident, $zero:expr, $name:literal) => {{
                let mut out = vec![$zero; n_values];
                // SAFETY: `out` holds n_values elements, `vrs` nv references.
                let raw = unsafe { (f.$fun)(i, p, nv, out.as_mut_ptr(), n_values) };
                self.check($name, raw)?;
                Values::$variant(out)
            }};
        }
        Ok(match ty {
            Type3::Float32 => get!(get_float32, Float32, 0.0f32, "fmi3GetFloat32"),
            Type3::Float64 => get!(get_float64, Float64, 0.0f64, "fmi3GetFloat64"),
            Type3::Int8 => get!(get_int8, Int8, 0i8, "fmi3GetInt8"),
            Type3::UInt8 => get!(get_uint8, UInt8, 0u8, "fmi3GetUInt8"),
            Type3::Int16 => get!(get_int16, Int16, 0i16, "fmi3GetInt16"),
            Type3::UInt16 => get!(get_uint16, UInt16, 0u16, "fmi3GetUInt16"),
            Type3::Int32 => get!(get_int32, Int32, 0i32, "fmi3GetInt32"),
            Type3::UInt32 => get!(get_uint32, UInt32, 0u32, "fmi3GetUInt32"),
            Type3::Int64 | Type3::Enumeration => get!(get_int64, Int64, 0i64, "fmi3GetInt64"),
            Type3::UInt64 => get!(get_uint64, UInt64, 0u64, "fmi3GetUInt64"),
            Type3::Boolean => {
                let mut out = vec![0 as Bool3; n_values];
                // SAFETY: `out` holds n_values bytes.
                let raw = unsafe { (f.get_boolean)(i, p, nv, out.as_mut_ptr(), n_values) };
                self.check("fmi3GetBoolean", raw)?;
                Values::Boolean(out.into_iter().map(|b| b != 0).collect())
            }
            Type3::String => {
                let mut out: Vec<*const c_char> = vec![std::ptr::null(); n_values];
                // SAFETY: `out` holds n_values pointers.
                let raw = unsafe { (f.get_string)(i, p, nv, out.as_mut_ptr(), n_values) };
                self.check("fmi3GetString", raw)?;
                Values::String(out.into_iter().map(copy_string).collect())
            }
            Type3::Binary => {
                let mut sizes = vec![0usize; n_values];
                let mut ptrs: Vec<*const u8> = vec![std::ptr::null(); n_values];
                // SAFETY: both buffers hold n_values elements.
                let raw = unsafe {
                    (f.get_binary)(i, p, nv, sizes.as_mut_ptr(), ptrs.as_mut_ptr(), n_values)
                };
                self.check("fmi3GetBinary", raw)?;
                let values = ptrs.into_iter().zip(sizes).map(copy_binary);
                Values::Binary(values.collect::<Result<_>>()?)
            }
            Type3::Clock => {
                return Err(HostError::Request(
                    "Clock variables are not supported".into(),
                ))
            }
        })
    }

    /// fmi3Set{type} of `values` (every element of every array among `vrs`, in order).
    pub fn set(&mut self, vrs: &[u32], values: &Values) -> Result<Status> {
        let (i, f) = (self.instance, &self.fmu.functions);
        let (nv, p) = (vrs.len(), vrs.as_ptr());
        let n = values.len();
        let _watch = watch::enter3(Call::Set, None);
        macro_rules! set {
            ($fun:ident, $x:expr, $name:literal) => {{
                // SAFETY: the buffer holds n values, `vrs` nv references.
                let raw = unsafe { (f.$fun)(i, p, nv, $x.as_ptr(), n) };
                self.check($name, raw)
            }};
        }
        match values {
            Values::Float32(x) => set!(set_float32, x, "fmi3SetFloat32"),
            Values::Float64(x) => set!(set_float64, x, "fmi3SetFloat64"),
            Values::Int8(x) => set!(set_int8, x, "fmi3SetInt8"),
            Values::UInt8(x) => set!(set_uint8, x, "fmi3SetUInt8"),
            Values::Int16(x) => set!(set_int16, x, "fmi3SetInt16"),
            Values::UInt16(x) => set!(set_uint16, x, "fmi3SetUInt16"),
            Values::Int32(x) => set!(set_int32, x, "fmi3SetInt32"),
            Values::UInt32(x) => set!(set_uint32, x, "fmi3SetUInt32"),
            Values::Int64(x) => set!(set_int64, x, "fmi3SetInt64"),
            Values::UInt64(x) => set!(set_uint64, x, "fmi3SetUInt64"),
            Values::Boolean(x) => {
                let bytes: Vec<Bool3> = x.iter().map(|&b| b as Bool3).collect();
                set!(set_boolean, bytes, "fmi3SetBoolean")
            }
            Values::String(x) => {
                let owned: Vec<CString> = x
                    .iter()
                    .map(|s| CString::new(s.as_str()))
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| HostError::Request("string value contains a NUL byte".into()))?;
                let ptrs: Vec<*const c_char> = owned.iter().map(|c| c.as_ptr()).collect();
                set!(set_string, ptrs, "fmi3SetString")
            }
            Values::Binary(x) => {
                let sizes: Vec<usize> = x.iter().map(Vec::len).collect();
                let ptrs: Vec<*const u8> = x.iter().map(|b| b.as_ptr()).collect();
                // SAFETY: sizes and ptrs hold n elements; each pointer has its size in bytes.
                let raw = unsafe { (f.set_binary)(i, p, nv, sizes.as_ptr(), ptrs.as_ptr(), n) };
                self.check("fmi3SetBinary", raw)
            }
        }
    }
}

impl Drop for Instance3<'_> {
    fn drop(&mut self) {
        let _watch = watch::enter3(Call::FreeInstance, None);
        // SAFETY: instance is live; freed exactly once here.
        unsafe { (self.fmu.functions.free_instance)(self.instance) };
        self.fmu.live_instances.fetch_sub(1, Ordering::SeqCst);
    }
}

fn copy_string(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: the FMU returns NUL-terminated strings valid until its next call.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Largest Binary value copied from an FMU (bytes): a size that is garbage must not exhaust
/// memory.
const MAX_BINARY_BYTES: usize = 1 << 28;

fn copy_binary((p, size): (*const u8, usize)) -> Result<Vec<u8>> {
    if p.is_null() || size == 0 {
        return Ok(Vec::new());
    }
    if size > MAX_BINARY_BYTES {
        return Err(HostError::Request(format!(
            "fmi3GetBinary returned a value of {size} bytes (limit {MAX_BINARY_BYTES})"
        )));
    }
    // SAFETY: the FMU returns `size` readable bytes at p, valid until its next call.
    Ok(unsafe { std::slice::from_raw_parts(p, size) }.to_vec())
}
