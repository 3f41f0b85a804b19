//! FMU states of an FMI 3.0 instance (FMI 3.0.2 section 2.2.7.4): save, restore, serialize and
//! deserialize, free. The calls the FMU does not export are a [`HostError::Request`].

use crate::error::{fmu_state_given, HostError, Result, Status};
use crate::fmi3::ffi::{FmuState3, RawStatus3};
use crate::fmi3::Instance3;

/// A saved FMU state of an instance (`fmi3GetFMUState`), freed with
/// [`Instance3::free_fmu_state`].
pub struct FmuStateHandle3(FmuState3);

/// `fmi3SerializedFMUStateSize`, `fmi3SerializeFMUState` and `fmi3DeserializeFMUState`.
type Serialization = (
    unsafe extern "C" fn(*mut std::ffi::c_void, FmuState3, *mut usize) -> RawStatus3,
    unsafe extern "C" fn(*mut std::ffi::c_void, FmuState3, *mut u8, usize) -> RawStatus3,
    unsafe extern "C" fn(*mut std::ffi::c_void, *const u8, usize, *mut FmuState3) -> RawStatus3,
);

impl Instance3<'_> {
    /// `fmi3GetFMUState` into a new state.
    pub fn get_fmu_state(&mut self) -> Result<FmuStateHandle3> {
        let missing = |n: &str| HostError::Request(format!("the binary does not export {n}"));
        let f = self
            .fmu
            .functions
            .get_fmu_state
            .ok_or_else(|| missing("fmi3GetFMUState"))?;
        let mut state: FmuState3 = std::ptr::null_mut();
        // SAFETY: live instance; a NULL state asks the FMU for a new one (FMI 3.0.2 section
        // 2.2.7.4).
        let raw = unsafe { f(self.instance, &mut state) };
        let status = self.check("fmi3GetFMUState", raw)?;
        fmu_state_given("fmi3GetFMUState", status, state.is_null())?;
        Ok(FmuStateHandle3(state))
    }

    /// `fmi3SetFMUState` to `saved`.
    pub fn set_fmu_state(&mut self, saved: &FmuStateHandle3) -> Result<Status> {
        let f = self.fmu.functions.set_fmu_state.ok_or_else(|| {
            HostError::Request("the binary does not export fmi3SetFMUState".into())
        })?;
        // SAFETY: live instance and a state it returned from fmi3GetFMUState, not yet freed.
        let raw = unsafe { f(self.instance, saved.0) };
        self.check("fmi3SetFMUState", raw)
    }

    /// The three serialization functions, when the binary exports all of them.
    fn serialization(&self) -> Result<Serialization> {
        let f = &self.fmu.functions;
        match (
            f.serialized_fmu_state_size,
            f.serialize_fmu_state,
            f.deserialize_fmu_state,
        ) {
            (Some(size), Some(serialize), Some(deserialize)) => Ok((size, serialize, deserialize)),
            _ => Err(HostError::Request(
                "the binary does not export the FMU state serialization functions".into(),
            )),
        }
    }

    /// `fmi3SerializedFMUStateSize` and `fmi3SerializeFMUState` of `saved`.
    pub fn serialize_fmu_state(&mut self, saved: &FmuStateHandle3) -> Result<Vec<u8>> {
        let (size, serialize, _) = self.serialization()?;
        let mut n = 0usize;
        // SAFETY: live instance, a state it returned, a valid out pointer.
        let raw = unsafe { size(self.instance, saved.0, &mut n) };
        self.check("fmi3SerializedFMUStateSize", raw)?;
        if n > 1 << 30 {
            return Err(HostError::Request(format!(
                "fmi3SerializedFMUStateSize gives {n} bytes"
            )));
        }
        let mut bytes = vec![0u8; n];
        // SAFETY: `bytes` has the n bytes the FMU asked for.
        let raw = unsafe { serialize(self.instance, saved.0, bytes.as_mut_ptr(), n) };
        self.check("fmi3SerializeFMUState", raw)?;
        Ok(bytes)
    }

    /// `fmi3DeserializeFMUState` of `bytes` into a new state.
    pub fn deserialize_fmu_state(&mut self, bytes: &[u8]) -> Result<FmuStateHandle3> {
        let (_, _, deserialize) = self.serialization()?;
        let mut state: FmuState3 = std::ptr::null_mut();
        // SAFETY: bytes the FMU serialized, of their length; a NULL state asks it for a new one.
        let raw = unsafe { deserialize(self.instance, bytes.as_ptr(), bytes.len(), &mut state) };
        let status = self.check("fmi3DeserializeFMUState", raw)?;
        fmu_state_given("fmi3DeserializeFMUState", status, state.is_null())?;
        Ok(FmuStateHandle3(state))
    }

    /// `fmi3FreeFMUState` of `saved` (before the instance is freed); `fmi3OK` without a call when
    /// the binary does not export it.
    pub fn free_fmu_state(&mut self, mut saved: FmuStateHandle3) -> Result<Status> {
        let Some(f) = self.fmu.functions.free_fmu_state else {
            return Ok(Status::Ok);
        };
        // SAFETY: live instance and a state it returned, freed once.
        let raw = unsafe { f(self.instance, &mut saved.0) };
        self.check("fmi3FreeFMUState", raw)
    }
}
