//! Shared part of the `fmi3_api_*` targets: random FMI 3.0 call sequences with random and
//! hostile arguments through the `#[no_mangle] fmi3*` symbols `export_fmi3!` emits in the target
//! (the very functions an FMI 3.0 `fmu-binary` of the model exports), on up to two instances at
//! once (Co-Simulation or Model Exchange). One target per model.
//!
//! Besides "no crash, no panic (libFuzzer aborts on any panic, caught or not), no sanitizer
//! finding", each call checks what FMI 3.0.2 and the layer promise:
//! - every status is one of the five `fmi3Status` values; a call on a NULL instance and a call
//!   of a function this FMU does not offer return fmi3Error;
//! - an fmi3Error of a live instance with a logger comes with a logged message, and the logger
//!   gets the instance environment it was given;
//! - `nValues != nValueReferences` (every variable is a scalar; also for an empty list and the
//!   types without variables), a NULL array with a non-zero
//!   count, an unknown value reference, a clock, and any reference of a type the model has no
//!   variable of (String, Binary, Float32, UInt64) give fmi3Error (FMI 3.0.2 section 2.2.6.2);
//!   zero counts with NULL arrays never crash;
//! - an fmi3OK getter gives finite Float64 values and Booleans that are 0 or 1; an fmi3OK
//!   `fmi3DoStep` reports `lastSuccessfulTime = t + h` and leaves finite variables;
//! - the counts of `fmi3GetNumberOf...` are the model's; a serialized FMU state deserializes
//!   into one that serializes to the same bytes; `fmi3FreeInstance` works in any state,
//!   including after fmi3Error.

use crate::fmi3_exports as f;
use fmi3_export::fmi_types::c3::*;
use fmi3_export::fmu_core::xml3::{EVENT_INDICATOR_VALUE_REFERENCE, TIME_VALUE_REFERENCE};
use fmi3_export::fmu_core::{Model, VarType};
use libfuzzer_sys::arbitrary;
use std::cell::RefCell;
use std::ffi::{c_char, c_void, CStr};

#[path = "fmi3_ops.rs"]
mod ops;
pub use ops::*;

thread_local! {
    static LOG: RefCell<Vec<(Fmi3Status, String)>> = const { RefCell::new(Vec::new()) };
}

/// The instance environments handed to the two instances; the logger must get one of them back.
static ENVIRONMENTS: [u8; 2] = [1, 2];

unsafe extern "C" fn logger(
    env: Fmi3InstanceEnvironment,
    status: Fmi3Status,
    category: Fmi3String,
    message: Fmi3String,
) {
    let known = ENVIRONMENTS
        .iter()
        .any(|e| std::ptr::eq(e, env as *const u8));
    assert!(known, "logger called with instanceEnvironment {env:?}");
    assert!((0..=4).contains(&status), "logged status {status}");
    assert!(
        !category.is_null() && !message.is_null(),
        "NULL category or message"
    );
    let _ = CStr::from_ptr(category)
        .to_str()
        .expect("category not UTF-8");
    let msg = CStr::from_ptr(message).to_string_lossy().into_owned();
    LOG.with(|l| l.borrow_mut().push((status, msg)));
}

fn take_log() -> Vec<(Fmi3Status, String)> {
    LOG.with(|l| std::mem::take(&mut *l.borrow_mut()))
}

/// One live (or not yet created) instance and what the driver knows of it.
struct Inst {
    c: Fmi3Instance,
    /// FMU states this instance handed out and has not freed.
    states: Vec<Fmi3FmuState>,
    /// The current time as the driver tracks it (Co-Simulation).
    time: f64,
    /// Whether a logger was passed (else an error cannot be checked for its message).
    logs: bool,
}

impl Inst {
    const fn new() -> Self {
        Inst {
            c: std::ptr::null_mut(),
            states: Vec::new(),
            time: 0.0,
            logs: true,
        }
    }

    /// A status is valid; an fmi3Error of a live instance with a logger logged an error message.
    fn check(&self, status: Fmi3Status, what: &dyn std::fmt::Debug) {
        let log = take_log();
        assert!((0..=4).contains(&status), "{what:?}: status {status}");
        if status == FMI3_ERROR && self.logs && !self.c.is_null() {
            let logged = log.iter().any(|(s, m)| *s == FMI3_ERROR && !m.is_empty());
            assert!(
                logged,
                "{what:?} returned fmi3Error without a logged message"
            );
        }
    }

    unsafe fn free(&mut self) {
        f::fmi3FreeInstance(self.c);
        self.c = std::ptr::null_mut();
        self.states.clear();
        take_log();
    }
}

struct Driver<M: Model> {
    insts: [Inst; 2],
    _m: std::marker::PhantomData<M>,
}

/// The value references of the model's Float64 variables (table and `time`).
fn float64_vrs<M: Model>() -> Vec<u32> {
    let table = M::variables().iter().filter(|v| v.vtype == VarType::Real);
    let mut vrs: Vec<u32> = table.map(|v| v.value_reference).collect();
    vrs.push(TIME_VALUE_REFERENCE);
    vrs
}

impl<M: Model> Driver<M> {
    fn vr(v: Vr) -> u32 {
        let table = M::variables();
        match v {
            Vr::Valid(i) => table[i as usize % table.len()].value_reference,
            Vr::Time => TIME_VALUE_REFERENCE,
            Vr::Indicator(k) => EVENT_INDICATOR_VALUE_REFERENCE + k as u32 % 4,
            Vr::Unknown(x) => x,
        }
    }

    fn vrs(vrs: &[Vr]) -> Vec<u32> {
        vrs.iter().map(|&v| Self::vr(v)).collect()
    }

    /// Whether `vr` names a variable of type `ty` (Float64: also `time` and event indicators).
    fn is_of(vr: u32, ty: VarType) -> bool {
        let n_ind = M::model_exchange().map_or(0, |me| me.event_indicators) as u32;
        let own = vr == TIME_VALUE_REFERENCE
            || (EVENT_INDICATOR_VALUE_REFERENCE..EVENT_INDICATOR_VALUE_REFERENCE + n_ind)
                .contains(&vr);
        let table = M::variables()
            .iter()
            .any(|v| v.value_reference == vr && v.vtype == ty);
        table || (ty == VarType::Real && own)
    }

    fn value(vr: u32, v: Val) -> f64 {
        let var = M::variables().iter().find(|x| x.value_reference == vr);
        match (v, var) {
            (Val::InRange(k), Some(var)) => {
                let lo = var.min.unwrap_or(var.start - 1.0);
                let hi = var.max.unwrap_or(var.start + 1.0);
                lo + (hi - lo) * k as f64 / 255.0
            }
            (Val::Start, Some(var)) => var.start,
            (Val::Any(x), _) => x.get(),
            (Val::InRange(_) | Val::Start, None) => 0.5,
        }
    }

    unsafe fn run(&mut self, call: &Call) {
        let k = call.second as usize;
        if self.insts[k].c.is_null() && !call.op.creates() {
            // most sequences should reach the interesting states: create a Co-Simulation or
            // Model Exchange instance first
            let me = matches!(call.op, Op::Me(_));
            self.instantiate(
                k,
                &Lifecycle::Instantiate {
                    me,
                    bad: 0,
                    logger: true,
                    event_mode: false,
                    required: 0,
                },
            );
        }
        match &call.op {
            Op::Life(l) => self.lifecycle(k, l),
            Op::Access(a) => self.access(k, a),
            Op::Step(s) => self.step(k, s),
            Op::Me(m) => self.model_exchange(k, m),
            Op::State(s) => self.state(k, s),
            Op::Unsupported(u) => self.unsupported(k, *u),
            Op::NullInstance(n) => null_instance(*n),
        }
    }
}

unsafe fn drive<M: Model>(calls: &[Call]) {
    let mut d = Driver::<M> {
        insts: [Inst::new(), Inst::new()],
        _m: std::marker::PhantomData,
    };
    for call in calls.iter().take(64) {
        d.run(call);
    }
    for inst in &mut d.insts {
        inst.free();
    }
}

/// Run one input on model `M`.
pub fn run<M: Model>(input: &Input) {
    take_log();
    // SAFETY: every pointer passed is valid for the count passed with it, or deliberately NULL
    // or foreign where the standard lets the FMU check it.
    unsafe { drive::<M>(&input.calls) }
}

/// Calls on a NULL instance: fmi3Error, never a dereference.
unsafe fn null_instance(k: u8) {
    let n = std::ptr::null_mut();
    let (mut b1, mut b2, mut b3, mut t) = (false, false, false, 0.0);
    let s = match k % 8 {
        0 => f::fmi3DoStep(n, 0.0, 0.1, false, &mut b1, &mut b2, &mut b3, &mut t),
        1 => f::fmi3ExitInitializationMode(n),
        2 => f::fmi3GetFloat64(n, std::ptr::null(), 0, std::ptr::null_mut(), 0),
        3 => f::fmi3Reset(n),
        4 => f::fmi3SetFMUState(n, std::ptr::null_mut()),
        5 => f::fmi3EnterEventMode(n),
        6 => f::fmi3GetContinuousStateDerivatives(n, std::ptr::null_mut(), 0),
        _ => {
            f::fmi3FreeInstance(n);
            FMI3_ERROR
        }
    };
    assert_eq!(
        s, FMI3_ERROR,
        "call on a NULL instance did not return fmi3Error"
    );
    take_log();
}

/// `n` elements, NULL or not as `count` says, with the pointer to pass.
fn counted<T: Clone>(values: &[T], count: Count, fill: T) -> (Vec<T>, bool) {
    match count {
        Count::Match => (values.to_vec(), false),
        Count::Other(k) => {
            let mut v = values.to_vec();
            v.resize(k as usize % 9, fill);
            (v, false)
        }
        Count::Null(k) => (vec![fill; k as usize % 3], true),
    }
}

fn ptr<T>(v: &[T], null: bool) -> *const T {
    if null {
        std::ptr::null()
    } else {
        v.as_ptr()
    }
}

fn ptr_mut<T>(v: &mut [T], null: bool) -> *mut T {
    if null {
        std::ptr::null_mut()
    } else {
        v.as_mut_ptr()
    }
}

#[path = "fmi3_calls.rs"]
mod calls;
#[path = "fmi3_me.rs"]
mod me;
#[path = "fmi3_states.rs"]
mod states;
