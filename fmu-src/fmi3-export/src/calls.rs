//! The FMI 3.0 functions as the instance checks them: each one's name and the states it is
//! allowed in (FMI 3.0.2 section 4.2.1 and the state machine of figure 32 for Co-Simulation
//! without Event Mode, clocks and configuration; section 3.2 for Model Exchange), and the names
//! FMI 3.0 gives the states in messages.

use fmu_core::machine::MachineState::{self, *};
use fmu_core::machine::{Call, StateNames};

/// States in FMI 3.0 messages: the names of its state machine (`Step Mode`).
pub const STATE_NAMES: StateNames = StateNames {
    name: state_name,
    article: "",
};

fn state_name(s: MachineState) -> &'static str {
    match s {
        Instantiated => "Instantiated",
        InitializationMode => "Initialization Mode",
        StepMode => "Step Mode",
        StepFailed | StepCanceled => "Step Discarded",
        Terminated => "Terminated",
        Error => "the error state (after fmi3Error)",
        EventMode => "Event Mode",
        ContinuousTimeMode => "Continuous-Time Mode",
    }
}

const ME_ARRAY_STATES: &[MachineState] = &[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
];

/// A getter `name`.
pub const fn getter(name: &'static str) -> Call {
    let states = [InitializationMode, StepMode, Terminated, Error];
    Call::new(name, &states).and(&[EventMode, ContinuousTimeMode])
}

/// A setter `name`; in Continuous-Time Mode the instance takes continuous inputs (and states)
/// only.
pub const fn setter(name: &'static str) -> Call {
    let states = [Instantiated, InitializationMode, StepMode];
    Call::new(name, &states).and(&[EventMode, ContinuousTimeMode])
}

pub const SET_DEBUG_LOGGING: Call = Call::any_state("fmi3SetDebugLogging");
pub const RESET: Call = Call::any_state("fmi3Reset");
pub const SET_FMU_STATE: Call = Call::any_state("fmi3SetFMUState");
pub const ENTER_INITIALIZATION_MODE: Call =
    Call::new("fmi3EnterInitializationMode", &[Instantiated]);
pub const EXIT_INITIALIZATION_MODE: Call =
    Call::new("fmi3ExitInitializationMode", &[InitializationMode]);
pub const TERMINATE: Call = Call::new("fmi3Terminate", &[StepMode, EventMode, ContinuousTimeMode]);
pub const GET_FLOAT64: Call = getter("fmi3GetFloat64");
pub const GET_INT32: Call = getter("fmi3GetInt32");
pub const GET_BOOLEAN: Call = getter("fmi3GetBoolean");
pub const SET_FLOAT64: Call = setter("fmi3SetFloat64");
pub const SET_INT32: Call = setter("fmi3SetInt32");
pub const SET_BOOLEAN: Call = setter("fmi3SetBoolean");
pub const DO_STEP: Call = Call::new("fmi3DoStep", &[StepMode]);
/// fmi3GetDirectionalDerivative and fmi3GetAdjointDerivative: Initialization Mode, Model
/// Exchange, and Co-Simulation in Step Mode (FMI 3.0.2 sections 2.3.3 and 4.2.1).
const DERIVATIVE_STATES: &[MachineState] = &[
    InitializationMode,
    StepMode,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
];
pub const GET_DIRECTIONAL_DERIVATIVE: Call =
    Call::new("fmi3GetDirectionalDerivative", DERIVATIVE_STATES);
pub const GET_ADJOINT_DERIVATIVE: Call = Call::new("fmi3GetAdjointDerivative", DERIVATIVE_STATES);
// Model Exchange (FMI 3.0.2 section 3.2): Continuous-Time Mode -> fmi3EnterEventMode -> Event
// Mode -> fmi3EnterContinuousTimeMode.
pub const ENTER_EVENT_MODE: Call =
    Call::new("fmi3EnterEventMode", &[ContinuousTimeMode]).model_exchange();
pub const UPDATE_DISCRETE_STATES: Call =
    Call::new("fmi3UpdateDiscreteStates", &[EventMode]).model_exchange();
pub const ENTER_CONTINUOUS_TIME_MODE: Call =
    Call::new("fmi3EnterContinuousTimeMode", &[EventMode]).model_exchange();
pub const COMPLETED_INTEGRATOR_STEP: Call =
    Call::new("fmi3CompletedIntegratorStep", &[ContinuousTimeMode]).model_exchange();
pub const SET_TIME: Call =
    Call::new("fmi3SetTime", &[EventMode, ContinuousTimeMode]).model_exchange();
pub const SET_CONTINUOUS_STATES: Call =
    Call::new("fmi3SetContinuousStates", &[ContinuousTimeMode]).model_exchange();
pub const GET_CONTINUOUS_STATE_DERIVATIVES: Call = Call::new(
    "fmi3GetContinuousStateDerivatives",
    &[EventMode, ContinuousTimeMode, Terminated, Error],
)
.model_exchange();
pub const GET_EVENT_INDICATORS: Call =
    Call::new("fmi3GetEventIndicators", ME_ARRAY_STATES).model_exchange();
pub const GET_CONTINUOUS_STATES: Call =
    Call::new("fmi3GetContinuousStates", ME_ARRAY_STATES).model_exchange();
pub const GET_NOMINALS_OF_CONTINUOUS_STATES: Call = Call::new(
    "fmi3GetNominalsOfContinuousStates",
    &[
        Instantiated,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ],
)
.model_exchange();
/// The fixed counts of the model description, in any state of a Model Exchange instance.
pub const fn count(name: &'static str) -> Call {
    Call::any_state(name).model_exchange()
}
