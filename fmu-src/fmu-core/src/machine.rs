//! The one state machine of an instance, in names neither FMI version owns. Each version's layer
//! names its calls ([`Call`]: the C function and the states it is allowed in, from that
//! version's tables) and the states in its messages ([`StateNames`]); the instance checks each
//! call once, against the call's own states.

use serde::{Deserialize, Serialize};

/// States of an instance, Co-Simulation (FMI 2.0.4 section 4.2.4, FMI 3.0.2 section 4.2) and
/// Model Exchange (FMI 2.0.4 section 3.2.3, FMI 3.0.2 section 3.2); each is one bit so a call's
/// allowed states are a mask. An instance only ever enters the states of its interface.
/// `StepFailed` and `StepCanceled` are never entered (steps are synchronous; a failed step
/// goes to `Error`); they stay so that the layers' tables can list them as the standard does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u32)]
pub enum MachineState {
    Instantiated = 1,
    InitializationMode = 2,
    /// Between steps of Co-Simulation: FMI 2.0's `StepComplete`, FMI 3.0's Step Mode.
    StepMode = 4,
    StepFailed = 8,
    StepCanceled = 16,
    Terminated = 32,
    Error = 64,
    EventMode = 128,
    ContinuousTimeMode = 256,
}

impl MachineState {
    /// Whether an instance of `interface` can be in this state.
    pub fn belongs_to(self, interface: Interface) -> bool {
        use MachineState::*;
        match self {
            StepMode | StepFailed | StepCanceled => interface == Interface::CoSimulation,
            EventMode | ContinuousTimeMode => interface == Interface::ModelExchange,
            Instantiated | InitializationMode | Terminated | Error => true,
        }
    }
}

/// The interface type an instance was created for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    ModelExchange,
    CoSimulation,
}

/// The mask of a list of states.
pub const fn mask(states: &[MachineState]) -> u32 {
    let mut mask = 0;
    let mut i = 0;
    while i < states.len() {
        mask |= states[i] as u32;
        i += 1;
    }
    mask
}

/// Every state: the calls allowed at any time (logging, reset, FMU states).
pub const ANY_STATE: u32 = mask(&[
    MachineState::Instantiated,
    MachineState::InitializationMode,
    MachineState::StepMode,
    MachineState::StepFailed,
    MachineState::StepCanceled,
    MachineState::Terminated,
    MachineState::Error,
    MachineState::EventMode,
    MachineState::ContinuousTimeMode,
]);

/// One C function of a layer: its name, which starts every message of the call, the states it
/// is allowed in (the layer's version's table) and the interface it belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Call {
    pub name: &'static str,
    /// Mask of [`MachineState`]s.
    pub allowed: u32,
    /// The interface of a function of one interface only: an instance of the other refuses it
    /// whatever its state.
    pub only: Option<Interface>,
}

impl Call {
    /// `name`, allowed in `states`.
    pub const fn new(name: &'static str, states: &[MachineState]) -> Self {
        Call {
            name,
            allowed: mask(states),
            only: None,
        }
    }

    /// `name`, allowed in every state.
    pub const fn any_state(name: &'static str) -> Self {
        Call {
            name,
            allowed: ANY_STATE,
            only: None,
        }
    }

    /// The same call, of `interface` only.
    pub const fn only(self, interface: Interface) -> Self {
        Call {
            only: Some(interface),
            ..self
        }
    }

    /// The same call, allowed in `states` too.
    pub const fn and(self, states: &[MachineState]) -> Self {
        Call {
            allowed: self.allowed | mask(states),
            ..self
        }
    }

    /// The same call, of Model Exchange only.
    pub const fn model_exchange(self) -> Self {
        self.only(Interface::ModelExchange)
    }

    /// The same call, of Co-Simulation only.
    pub const fn co_simulation(self) -> Self {
        self.only(Interface::CoSimulation)
    }
}

/// A call whose state the instance has checked ([`crate::Instance::check_state`]): the
/// instance's operations take it, so that each call is checked once, where its layer chooses.
/// Only the instance makes one (the type is non-exhaustive).
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct Checked {
    /// The C function's name, which starts every message of the call.
    pub name: &'static str,
}

impl Checked {
    pub(crate) fn of(call: Call) -> Self {
        Checked { name: call.name }
    }
}

/// How a layer's messages name the states.
#[derive(Clone, Copy)]
pub struct StateNames {
    /// The state's name in the layer's version.
    pub name: fn(MachineState) -> &'static str,
    /// The words between "not allowed in " and the name.
    pub article: &'static str,
}
