//! The FMI 3.0 FMU-state functions over the component's ([`fmu_core::glue::Component`]): no
//! state check (every state allows them); a state saved by this FMU's FMI 2.0 binary has the
//! same format and GUID.

#![allow(clippy::missing_safety_doc)]

use crate::calls;
use crate::ffi::Fmi3Logger;
use fmi_types::c3::*;
use fmu_core::glue::{ForeignHandle, Logger};
use fmu_core::{Model, Status};

/// The argument's name in this version's messages.
const HANDLE: &str = "FMUState";

pub unsafe fn get_fmu_state<M: Model>(c: Fmi3Instance, state: *mut Fmi3FmuState) -> Fmi3Status {
    const F: &str = "fmi3GetFMUState";
    Fmi3Logger::with::<M>(c, F, |comp| comp.get_fmu_state(F, HANDLE, state))
}

/// `fmi3SetFMUState`: a state this instance owns is restored; one the instance refuses to
/// restore (saved by an instance of the other interface) is logged, and the call still returns
/// OK as before.
pub unsafe fn set_fmu_state<M: Model>(c: Fmi3Instance, state: Fmi3FmuState) -> Fmi3Status {
    let call = calls::SET_FMU_STATE;
    Fmi3Logger::with::<M>(c, call.name, |comp| {
        let Ok(checked) = comp.instance.check_state(call) else {
            return Status::Error;
        };
        match comp.states.get(state) {
            Some(p) => {
                comp.instance.restore(checked, p);
                Status::Ok
            }
            None => comp.instance.error(
                call.name,
                "FMUState is NULL or not a state of this instance",
            ),
        }
    })
}

pub unsafe fn free_fmu_state<M: Model>(c: Fmi3Instance, state: *mut Fmi3FmuState) -> Fmi3Status {
    const F: &str = "fmi3FreeFMUState";
    Fmi3Logger::with::<M>(c, F, |comp| comp.free_fmu_state(F, HANDLE, state))
}

pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: Fmi3Instance,
    state: Fmi3FmuState,
    size: *mut usize,
) -> Fmi3Status {
    const F: &str = "fmi3SerializedFMUStateSize";
    Fmi3Logger::with::<M>(c, F, |comp| comp.serialized_size(F, HANDLE, state, size))
}

pub unsafe fn serialize_fmu_state<M: Model>(
    c: Fmi3Instance,
    state: Fmi3FmuState,
    out: *mut Fmi3Byte,
    size: usize,
) -> Fmi3Status {
    const F: &str = "fmi3SerializeFMUState";
    Fmi3Logger::with::<M>(c, F, |comp| {
        comp.serialize_into(F, HANDLE, state, (out, size))
    })
}

pub unsafe fn deserialize_fmu_state<M: Model>(
    c: Fmi3Instance,
    bytes: *const Fmi3Byte,
    size: usize,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    const F: &str = "fmi3DeserializeFMUState";
    Fmi3Logger::with::<M>(c, F, |comp| {
        comp.deserialize_into((F, HANDLE), (bytes, size), state, ForeignHandle::Refuse)
    })
}
