//! What both C layers do at the boundary, whatever the version: the component a C handle points
//! to (the instance, the environment's logger, the FMU states handed out), `catch_unwind` at
//! every entry so that no panic crosses the ABI, and C arrays and strings read safely.

#![allow(clippy::missing_safety_doc)]

use crate::instance::{Instance, Status};
use crate::machine::{Call, Checked, MachineState};
use crate::snapshot::Snapshot;
use crate::Model;
use std::collections::BTreeSet;
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The environment's logger as a layer calls it; the layer's entry points run through it.
pub trait Logger: Sized {
    /// Marks a live component of this layer: a null, foreign or freed handle lacks it.
    const MAGIC: u64;
    /// Pass one message to the environment.
    fn log(&self, status: Status, category: &str, message: &str);

    /// Run `f` on the component behind `c` ([`with_component`]).
    unsafe fn with<M: Model>(
        c: *mut c_void,
        func: &'static str,
        f: impl FnOnce(&mut Component<M, Self>) -> Status,
    ) -> c_int {
        with_component::<M, Self>(c, func, f)
    }

    /// Check `call` before anything else, then run `f` on the component with the proof.
    unsafe fn checked<M: Model>(
        c: *mut c_void,
        call: Call,
        f: impl FnOnce(&mut Component<M, Self>, Checked) -> Status,
    ) -> c_int {
        with_component::<M, Self>(c, call.name, |comp| match comp.instance.check_state(call) {
            Ok(checked) => f(comp, checked),
            Err(s) => s,
        })
    }
}

/// What a layer's C instance handle points to.
pub struct Component<M: Model, L: Logger> {
    magic: u64,
    pub instance: Instance<M>,
    pub logger: L,
    /// FMU states handed out by this instance and not yet freed.
    pub states: FmuStates<M>,
}

impl<M: Model, L: Logger> Component<M, L> {
    /// A component on the heap, as the C handle of a new instance.
    pub fn into_handle(instance: Instance<M>, logger: L) -> *mut c_void {
        let comp = Box::new(Component {
            magic: L::MAGIC,
            instance,
            logger,
            states: FmuStates::default(),
        });
        Box::into_raw(comp) as *mut c_void
    }

    /// Pass queued messages to the logger (filtered by category) and clear the queue.
    fn flush_log(&mut self) {
        for e in std::mem::take(&mut self.instance.log) {
            if self.instance.category_enabled(e.category) {
                self.logger.log(e.status, e.category, &e.message);
            }
        }
    }
}

/// What becomes of a handle the importer passes to deserialize into that this instance does not
/// own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForeignHandle {
    /// A new handle is stored in its place (FMI 2.0 layer).
    Replace,
    /// The call is refused (FMI 3.0 layer).
    Refuse,
}

/// The FMU-state functions both layers share; `handle` is the argument's name in the
/// messages (`FMUstate` in FMI 2.0, `FMUState` in FMI 3.0).
impl<M: Model, L: Logger> Component<M, L> {
    /// Store the instance's FMU state in `*slot`: a new handle when `*slot` is null, else the
    /// owned state it names.
    pub unsafe fn get_fmu_state(
        &mut self,
        func: &str,
        handle: &str,
        slot: *mut *mut c_void,
    ) -> Status {
        let Some(slot) = slot.as_mut() else {
            return self.instance.error(func, format!("{handle} is NULL"));
        };
        let snap = self.instance.snapshot();
        if slot.is_null() {
            *slot = self.states.insert(snap);
            return Status::Ok;
        }
        match self.states.get(*slot) {
            Some(p) => {
                *p = snap;
                Status::Ok
            }
            None => self.not_owned(func, &format!("*{handle}")),
        }
    }

    /// Free the owned state `*slot` and null it; a null `*slot` is nothing to free.
    pub unsafe fn free_fmu_state(
        &mut self,
        func: &str,
        handle: &str,
        slot: *mut *mut c_void,
    ) -> Status {
        let Some(slot) = slot.as_mut() else {
            return self.instance.error(func, format!("{handle} is NULL"));
        };
        if slot.is_null() {
            return Status::Ok;
        }
        if !self.states.free(*slot) {
            return self.not_owned(func, &format!("*{handle}"));
        }
        *slot = std::ptr::null_mut();
        Status::Ok
    }

    fn not_owned(&mut self, func: &str, what: &str) -> Status {
        self.instance
            .error(func, format!("{what} is not a state of this instance"))
    }

    /// The serialized bytes of the owned state `state`, or the logged reason why not.
    pub fn serialized(
        &mut self,
        func: &str,
        handle: &str,
        state: *mut c_void,
    ) -> Result<Vec<u8>, Status> {
        let Some(p) = self.states.get(state) else {
            let m = format!("{handle} is NULL or not a state of this instance");
            return Err(self.instance.error(func, m));
        };
        let bytes = self.instance.serialize(p);
        bytes.map_err(|e| self.instance.error(func, e))
    }

    /// The size of the serialized state `state` into `*size`.
    pub unsafe fn serialized_size(
        &mut self,
        func: &str,
        handle: &str,
        state: *mut c_void,
        size: *mut usize,
    ) -> Status {
        let Some(size) = size.as_mut() else {
            return self.instance.error(func, "size is NULL");
        };
        match self.serialized(func, handle, state) {
            Ok(bytes) => {
                *size = bytes.len();
                Status::Ok
            }
            Err(s) => s,
        }
    }

    /// The serialized state `state` into the importer's buffer `out` of `size` bytes.
    pub unsafe fn serialize_into(
        &mut self,
        func: &str,
        handle: &str,
        state: *mut c_void,
        (out, size): (*mut u8, usize),
    ) -> Status {
        if out.is_null() {
            return self.instance.error(func, "serializedState is NULL");
        }
        match self.serialized(func, handle, state) {
            Ok(bytes) if bytes.len() <= size => {
                std::ptr::copy_nonoverlapping(bytes.as_ptr(), out, bytes.len());
                Status::Ok
            }
            Ok(bytes) => {
                let n = bytes.len();
                let m = format!("buffer of {size} bytes is smaller than the state's {n} bytes");
                self.instance.error(func, m)
            }
            Err(s) => s,
        }
    }

    /// A state from the importer's bytes, stored in `*slot`: into the owned state `*slot` names,
    /// or a new handle when `*slot` is null (or, as `foreign` says, names no owned state).
    pub unsafe fn deserialize_into(
        &mut self,
        (func, handle): (&str, &str),
        (bytes, size): (*const u8, usize),
        slot: *mut *mut c_void,
        foreign: ForeignHandle,
    ) -> Status {
        let Some(slot) = slot.as_mut() else {
            return self.instance.error(func, format!("{handle} is NULL"));
        };
        let Some(data) = slice(bytes, size) else {
            return self.instance.error(func, "serializedState is NULL");
        };
        let snap = match self.instance.deserialize(data) {
            Ok(s) => s,
            Err(e) => return self.instance.error(func, e),
        };
        match self.states.get(*slot) {
            Some(p) => *p = snap,
            None if slot.is_null() || foreign == ForeignHandle::Replace => {
                *slot = self.states.insert(snap)
            }
            None => return self.not_owned(func, &format!("*{handle}")),
        }
        Status::Ok
    }
}

/// The component behind `c`, when `c` is a live handle of this layer.
unsafe fn component<'a, M: Model, L: Logger>(c: *mut c_void) -> Option<&'a mut Component<M, L>> {
    let comp = (c as *mut Component<M, L>).as_mut()?;
    (comp.magic == L::MAGIC).then_some(comp)
}

/// Run `f` on the component behind `c`, catching panics (the instance then goes to the error
/// state, the panic's message logged under `func`) and flushing the log. A null or foreign
/// handle gives the error status.
pub unsafe fn with_component<M: Model, L: Logger>(
    c: *mut c_void,
    func: &'static str,
    f: impl FnOnce(&mut Component<M, L>) -> Status,
) -> c_int {
    let Some(comp) = component::<M, L>(c) else {
        return Status::Error.raw();
    };
    let status = match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(s) => s,
        Err(payload) => {
            let msg = panic_message(payload);
            comp.instance.state = MachineState::Error;
            comp.instance.error(func, format!("internal error: {msg}"))
        }
    };
    // Logging itself must not unwind into C either.
    let _ = catch_unwind(AssertUnwindSafe(|| comp.flush_log()));
    status.raw()
}

/// Free the component behind `c` and every FMU state it still owns; a null or foreign handle
/// is ignored.
pub unsafe fn free_component<M: Model, L: Logger>(c: *mut c_void) {
    let Some(comp) = component::<M, L>(c) else {
        return;
    };
    let _ = catch_unwind(AssertUnwindSafe(|| {
        comp.magic = 0;
        drop(Box::from_raw(comp as *mut Component<M, L>));
    }));
}

/// Run an instantiation, catching panics: a null handle then.
pub fn instantiate(f: impl FnOnce() -> *mut c_void) -> *mut c_void {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(std::ptr::null_mut())
}

fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

/// A slice from a C array, or `None` when the pointer is null while `n > 0`.
pub unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts(p, n))
    }
}

/// A mutable slice from a C array, or `None` when the pointer is null while `n > 0`.
pub unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(p, n))
    }
}

/// A log message's category and text as C strings (a NUL inside the text becomes a space).
pub fn log_strings(category: &str, message: &str) -> (CString, CString) {
    (
        CString::new(category).unwrap_or_default(),
        CString::new(message.replace('\0', " ")).unwrap_or_default(),
    )
}

/// A C string as UTF-8, `None` when null or not UTF-8.
pub unsafe fn c_str<'a>(p: *const c_char) -> Option<&'a str> {
    if p.is_null() {
        None
    } else {
        CStr::from_ptr(p).to_str().ok()
    }
}

/// The FMU states an instance handed out as C handles and has not freed: only these are
/// accepted back, and freeing the instance frees them.
pub struct FmuStates<M: Model> {
    owned: BTreeSet<usize>,
    _model: std::marker::PhantomData<M>,
}

impl<M: Model> Default for FmuStates<M> {
    fn default() -> Self {
        FmuStates {
            owned: BTreeSet::new(),
            _model: std::marker::PhantomData,
        }
    }
}

impl<M: Model> FmuStates<M> {
    /// A new handle holding `snap`.
    pub fn insert(&mut self, snap: Snapshot<M>) -> *mut c_void {
        let p = Box::into_raw(Box::new(snap));
        self.owned.insert(p as usize);
        p as *mut c_void
    }

    /// The state behind `handle`, when this instance handed it out and has not freed it.
    pub fn get(&mut self, handle: *mut c_void) -> Option<&mut Snapshot<M>> {
        // SAFETY: an owned handle is a live `Box<Snapshot<M>>` of this set.
        self.owned
            .contains(&(handle as usize))
            .then(|| unsafe { &mut *(handle as *mut Snapshot<M>) })
    }

    /// Free the state behind `handle`; false when this instance does not own it.
    pub fn free(&mut self, handle: *mut c_void) -> bool {
        if !self.owned.remove(&(handle as usize)) {
            return false;
        }
        // SAFETY: the handle was owned, so it is a live box this set created.
        drop(unsafe { Box::from_raw(handle as *mut Snapshot<M>) });
        true
    }
}

impl<M: Model> Drop for FmuStates<M> {
    fn drop(&mut self) {
        for p in std::mem::take(&mut self.owned) {
            // SAFETY: every owned handle is a live box this set created.
            drop(unsafe { Box::from_raw(p as *mut Snapshot<M>) });
        }
    }
}
