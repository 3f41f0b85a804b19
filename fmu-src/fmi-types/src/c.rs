//! The C ABI of FMI 2.0 (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`), shared by the exported
//! functions of our FMUs and by the host that calls foreign ones.

use std::ffi::{c_char, c_int, c_uint, c_void};

/// `fmi2Component`
pub type Component = *mut c_void;
/// `fmi2ComponentEnvironment`
pub type ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`
pub type FmuState = *mut c_void;
/// `fmi2ValueReference`
pub type ValueReference = c_uint;
/// `fmi2Real`
pub type Real = f64;
/// `fmi2Integer`
pub type Integer = c_int;
/// `fmi2Boolean` (an int; [`TRUE`] = 1, [`FALSE`] = 0)
pub type Boolean = c_int;
/// `fmi2String`
pub type FmiString = *const c_char;
/// `fmi2Byte`
pub type Byte = c_char;
/// `fmi2Status` as the raw int (see [`crate::Status`])
pub type RawStatus = c_int;
/// `fmi2StatusKind`
pub type StatusKind = c_int;
/// `fmi2Type`
pub type FmiType = c_int;

/// `fmi2True`
pub const TRUE: Boolean = 1;
/// `fmi2False`
pub const FALSE: Boolean = 0;
/// `fmi2OK`
pub const OK: RawStatus = 0;
/// `fmi2Warning`
pub const WARNING: RawStatus = 1;
/// `fmi2Discard`
pub const DISCARD: RawStatus = 2;
/// `fmi2Error`
pub const ERROR: RawStatus = 3;
/// `fmi2Fatal`
pub const FATAL: RawStatus = 4;
/// `fmi2ModelExchange`
pub const MODEL_EXCHANGE: FmiType = 0;
/// `fmi2CoSimulation`
pub const CO_SIMULATION: FmiType = 1;
/// `fmi2DoStepStatus`, `fmi2PendingStatus`, `fmi2LastSuccessfulTime`, `fmi2Terminated`
pub mod status_kind {
    use super::StatusKind;
    /// `fmi2DoStepStatus`
    pub const DO_STEP_STATUS: StatusKind = 0;
    /// `fmi2PendingStatus`
    pub const PENDING_STATUS: StatusKind = 1;
    /// `fmi2LastSuccessfulTime`
    pub const LAST_SUCCESSFUL_TIME: StatusKind = 2;
    /// `fmi2Terminated`
    pub const TERMINATED: StatusKind = 3;
}

/// `fmi2CallbackLogger` (C-variadic: the message is a printf format).
pub type CallbackLogger =
    unsafe extern "C" fn(ComponentEnvironment, FmiString, RawStatus, FmiString, FmiString, ...);

/// `fmi2CallbackFunctions`. Every pointer is nullable on the C side (an FMU must check), so
/// each is an `Option` here, which has the layout of a nullable C function pointer.
#[repr(C)]
pub struct CallbackFunctions {
    /// `logger`
    pub logger: Option<CallbackLogger>,
    /// `allocateMemory` (calloc semantics)
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    /// `freeMemory`
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    /// `stepFinished` (NULL: asynchronous steps not used)
    pub step_finished: Option<unsafe extern "C" fn(ComponentEnvironment, RawStatus)>,
    /// `componentEnvironment`
    pub component_environment: ComponentEnvironment,
}

/// The functions of the FMI 2.0 Co-Simulation interface (standard sections 2.1 and 4.2), in the
/// order of the header files: what every CS binary exports, no more and no less.
pub const CO_SIMULATION_FUNCTIONS: &[&str] = &[
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

/// [`CO_SIMULATION_FUNCTIONS`] split where the functions only Co-Simulation has begin (section
/// 4.2, from `fmi2SetRealInputDerivatives` on): before it, those Model Exchange has too
/// (section 2.1).
pub const COMMON_AND_CO_SIMULATION_ONLY: (&[&str], &[&str]) = CO_SIMULATION_FUNCTIONS.split_at(25);
const _: () = assert!(matches!(
    COMMON_AND_CO_SIMULATION_ONLY.1[0].as_bytes(),
    b"fmi2SetRealInputDerivatives"
));
