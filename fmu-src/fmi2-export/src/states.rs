//! The FMI 2.0 FMU-state functions over the component's ([`fmu_core::glue::Component`]).

#![allow(clippy::missing_safety_doc)]

use crate::calls;
use crate::ffi::{Component, Fmi2Byte, Fmi2Component, Fmi2FmuState, Fmi2Logger, Fmi2Status};
use fmu_core::glue::{ForeignHandle, Logger};
use fmu_core::machine::Call;
use fmu_core::{Model, Status};

/// The argument's name in this version's messages.
const HANDLE: &str = "FMUstate";

/// Check `call` (every state allows it), then run `f` on the component.
unsafe fn fmu_state_call<M: Model>(
    c: Fmi2Component,
    call: Call,
    f: impl FnOnce(&mut Component<M>) -> Status,
) -> Fmi2Status {
    Fmi2Logger::with::<M>(c, call.name, |comp| match comp.instance.check_state(call) {
        Ok(_) => f(comp),
        Err(s) => s,
    })
}

pub unsafe fn get_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    let call = calls::GET_FMU_STATE;
    fmu_state_call::<M>(c, call, |comp| comp.get_fmu_state(call.name, HANDLE, state))
}

pub unsafe fn set_fmu_state<M: Model>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    let call = calls::SET_FMU_STATE;
    Fmi2Logger::with::<M>(c, call.name, |comp| {
        let checked = match comp.instance.check_state(call) {
            Ok(checked) => checked,
            Err(s) => return s,
        };
        match comp.states.get(state) {
            Some(p) => comp.instance.restore(checked, p),
            None => comp.instance.error(
                call.name,
                "FMUstate is NULL or not a state of this instance",
            ),
        }
    })
}

pub unsafe fn free_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    let call = calls::FREE_FMU_STATE;
    fmu_state_call::<M>(c, call, |comp| {
        comp.free_fmu_state(call.name, HANDLE, state)
    })
}

pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    let call = calls::SERIALIZED_FMU_STATE_SIZE;
    fmu_state_call::<M>(c, call, |comp| {
        comp.serialized_size(call.name, HANDLE, state, size)
    })
}

pub unsafe fn serialize_fmu_state<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    out: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    let call = calls::SERIALIZE_FMU_STATE;
    fmu_state_call::<M>(c, call, |comp| {
        comp.serialize_into(call.name, HANDLE, state, (out as *mut u8, size))
    })
}

pub unsafe fn deserialize_fmu_state<M: Model>(
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let call = calls::DESERIALIZE_FMU_STATE;
    fmu_state_call::<M>(c, call, |comp| {
        let data = (bytes as *const u8, size);
        comp.deserialize_into((call.name, HANDLE), data, state, ForeignHandle::Replace)
    })
}
