//! The FMI 2.0 functions as the instance checks them: each one's name and the states it is
//! allowed in (FMI 2.0.4 tables of sections 3.2.3 and 4.2.4), and the names FMI 2.0 gives the
//! states in messages.

use fmu_core::machine::MachineState::{self, *};
use fmu_core::machine::{Call, StateNames};

/// States in FMI 2.0 messages: the names of the standard's tables (`StepComplete`).
pub const STATE_NAMES: StateNames = StateNames {
    name: state_name,
    article: "state ",
};

fn state_name(s: MachineState) -> &'static str {
    match s {
        Instantiated => "Instantiated",
        InitializationMode => "InitializationMode",
        StepMode => "StepComplete",
        StepFailed => "StepFailed",
        StepCanceled => "StepCanceled",
        Terminated => "Terminated",
        Error => "Error",
        EventMode => "EventMode",
        ContinuousTimeMode => "ContinuousTimeMode",
    }
}

const GET_STATES: &[MachineState] = &[
    InitializationMode,
    StepMode,
    StepFailed,
    StepCanceled,
    Terminated,
    Error,
    EventMode,
    ContinuousTimeMode,
];
/// Integer and Boolean variables are not set in Continuous-Time Mode (checked per variable:
/// only continuous inputs are).
const SET_STATES: &[MachineState] = &[
    Instantiated,
    InitializationMode,
    StepMode,
    EventMode,
    ContinuousTimeMode,
];
const STATUS_STATES: &[MachineState] = &[StepMode, StepFailed, StepCanceled, Terminated];
const ME_ARRAY_STATES: &[MachineState] = &[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
];

pub const SET_DEBUG_LOGGING: Call = Call::any_state("fmi2SetDebugLogging");
pub const RESET: Call = Call::any_state("fmi2Reset");
pub const GET_FMU_STATE: Call = Call::any_state("fmi2GetFMUstate");
pub const SET_FMU_STATE: Call = Call::any_state("fmi2SetFMUstate");
pub const FREE_FMU_STATE: Call = Call::any_state("fmi2FreeFMUstate");
pub const SERIALIZED_FMU_STATE_SIZE: Call = Call::any_state("fmi2SerializedFMUstateSize");
pub const SERIALIZE_FMU_STATE: Call = Call::any_state("fmi2SerializeFMUstate");
pub const DESERIALIZE_FMU_STATE: Call = Call::any_state("fmi2DeSerializeFMUstate");
pub const SETUP_EXPERIMENT: Call = Call::new("fmi2SetupExperiment", &[Instantiated]);
pub const ENTER_INITIALIZATION_MODE: Call =
    Call::new("fmi2EnterInitializationMode", &[Instantiated]);
pub const EXIT_INITIALIZATION_MODE: Call =
    Call::new("fmi2ExitInitializationMode", &[InitializationMode]);
pub const TERMINATE: Call = Call::new(
    "fmi2Terminate",
    &[StepMode, StepFailed, EventMode, ContinuousTimeMode],
);
pub const GET_REAL: Call = Call::new("fmi2GetReal", GET_STATES);
pub const GET_INTEGER: Call = Call::new("fmi2GetInteger", GET_STATES);
pub const GET_BOOLEAN: Call = Call::new("fmi2GetBoolean", GET_STATES);
pub const GET_STRING: Call = Call::new("fmi2GetString", GET_STATES);
pub const SET_REAL: Call = Call::new("fmi2SetReal", SET_STATES);
pub const SET_INTEGER: Call = Call::new("fmi2SetInteger", SET_STATES);
pub const SET_BOOLEAN: Call = Call::new("fmi2SetBoolean", SET_STATES);
pub const SET_STRING: Call = Call::new("fmi2SetString", SET_STATES);
pub const DO_STEP: Call = Call::new("fmi2DoStep", &[StepMode]).co_simulation();
/// The status queries; `name` is the function's.
pub const fn status(name: &'static str) -> Call {
    Call::new(name, STATUS_STATES).co_simulation()
}
/// Initial unknowns in Initialization Mode, Model Exchange at the states, Co-Simulation at the
/// communication point (FMI 2.0.4 sections 3.2.3 and 4.2.4: also after a failed or canceled
/// step, for debugging).
pub const GET_DIRECTIONAL_DERIVATIVE: Call = Call::new(
    "fmi2GetDirectionalDerivative",
    &[
        InitializationMode,
        StepMode,
        StepFailed,
        StepCanceled,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ],
);
// Model Exchange only (FMI 2.0.4 section 3.2.3).
pub const ENTER_EVENT_MODE: Call =
    Call::new("fmi2EnterEventMode", &[EventMode, ContinuousTimeMode]).model_exchange();
pub const NEW_DISCRETE_STATES: Call =
    Call::new("fmi2NewDiscreteStates", &[EventMode]).model_exchange();
pub const ENTER_CONTINUOUS_TIME_MODE: Call =
    Call::new("fmi2EnterContinuousTimeMode", &[EventMode]).model_exchange();
pub const COMPLETED_INTEGRATOR_STEP: Call =
    Call::new("fmi2CompletedIntegratorStep", &[ContinuousTimeMode]).model_exchange();
pub const SET_TIME: Call =
    Call::new("fmi2SetTime", &[EventMode, ContinuousTimeMode]).model_exchange();
pub const SET_CONTINUOUS_STATES: Call =
    Call::new("fmi2SetContinuousStates", &[ContinuousTimeMode]).model_exchange();
pub const GET_EVENT_INDICATORS: Call =
    Call::new("fmi2GetEventIndicators", ME_ARRAY_STATES).model_exchange();
pub const GET_CONTINUOUS_STATES: Call =
    Call::new("fmi2GetContinuousStates", ME_ARRAY_STATES).model_exchange();
pub const GET_DERIVATIVES: Call = Call::new(
    "fmi2GetDerivatives",
    &[EventMode, ContinuousTimeMode, Terminated, Error],
)
.model_exchange();
pub const GET_NOMINALS_OF_CONTINUOUS_STATES: Call = Call::new(
    "fmi2GetNominalsOfContinuousStates",
    &[
        Instantiated,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ],
)
.model_exchange();
