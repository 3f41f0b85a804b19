//! Shared part of the `fmi_api_*` targets: random FMI 2.0 call sequences with random and hostile
//! arguments through the generic C entry points of `fmi2-export` (`ffi`, `states`: exactly what
//! each exported `fmi2*` symbol of an FMI 2.0 `fmu-binary` calls). One target per model
//! (HydraulicJoint, TwistedString, the Oscillator test model).
//!
//! Besides "no crash, no panic across the ABI, no sanitizer finding", each call checks what the
//! standard and the layer promise:
//! - a call that returns fmi2Error on a live instance has logged a message (logStatusError);
//! - fmi2OK/fmi2Warning from a getter gives finite values;
//! - a serialized FMU state deserializes into a state that serializes to the same bytes.

use fmi2_export::ffi::*;
use fmi2_export::fmu_core::Model;
use libfuzzer_sys::arbitrary::{self, Arbitrary};

/// The C entry points the targets call, under one name.
mod ffi {
    pub use fmi2_export::ffi::*;
    pub use fmi2_export::states::*;
}
use std::cell::RefCell;
use std::ffi::{c_char, c_int, c_void, CStr};

#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum F {
    Zero,
    Neg,
    Small(u16),
    Unit(u8),
    Big,
    Nan,
    Inf,
    NegInf,
    Raw(u64),
}

impl F {
    fn get(self) -> f64 {
        match self {
            F::Zero => 0.0,
            F::Neg => -1e-3,
            F::Small(k) => (k as f64 + 1.0) * 1e-5,
            F::Unit(k) => k as f64 / 255.0,
            F::Big => 1e300,
            F::Nan => f64::NAN,
            F::Inf => f64::INFINITY,
            F::NegInf => f64::NEG_INFINITY,
            F::Raw(b) => f64::from_bits(b),
        }
    }
}

/// A value reference: mostly valid ones (index into the table), sometimes unknown.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Vr {
    Valid(u8),
    Unknown(u32),
}

/// A value for a variable: a value scaled into its [min, max] (when it has one), or anything.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Val {
    InRange(u8),
    Start,
    Any(F),
}

#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Step {
    /// communicationStepSize in (0, 0.05]
    Normal(u8),
    /// currentCommunicationPoint off by this amount
    WrongTime(F, u8),
    Bad(F),
}

#[derive(Arbitrary, Debug)]
pub enum Op {
    Instantiate {
        bad: u8,
        logging: bool,
    },
    Free,
    SetDebugLogging {
        on: bool,
        cats: Vec<u8>,
        null: bool,
    },
    Setup {
        start: F,
        stop_defined: bool,
        stop: F,
    },
    EnterInit,
    ExitInit,
    Terminate,
    Reset,
    SetReal {
        vrs: Vec<Vr>,
        vals: Vec<Val>,
        null: bool,
    },
    SetInteger {
        vrs: Vec<Vr>,
        vals: Vec<i32>,
    },
    SetBoolean {
        vrs: Vec<Vr>,
        vals: Vec<i32>,
    },
    GetReal {
        vrs: Vec<Vr>,
        null: bool,
    },
    GetInteger {
        vrs: Vec<Vr>,
    },
    GetBoolean {
        vrs: Vec<Vr>,
    },
    Strings {
        get: bool,
        vrs: Vec<Vr>,
    },
    DoStep(Step),
    GetState {
        slot: u8,
        reuse: bool,
        null: bool,
    },
    SetState {
        slot: u8,
        foreign: bool,
    },
    FreeState {
        slot: u8,
    },
    Serialize {
        slot: u8,
        short: bool,
    },
    Deserialize {
        slot: u8,
        flip: Option<(u16, u8)>,
        truncate: Option<u16>,
    },
    Status {
        which: u8,
        kind: i32,
        null: bool,
    },
    Unsupported(u8),
    NullComponent(u8),
}

/// One fuzz input: a sequence of calls.
#[derive(Arbitrary, Debug)]
pub struct Input {
    ops: Vec<Op>,
}

thread_local! {
    static LOG: RefCell<Vec<(c_int, String, String)>> = const { RefCell::new(Vec::new()) };
}

/// The logger, declared with the fixed arguments plus the one `%s` argument the layer always
/// passes; on x86-64 System V a variadic call to it is ABI-compatible.
unsafe extern "C" fn logger(
    _env: *mut c_void,
    _name: *const c_char,
    status: c_int,
    category: *const c_char,
    format: *const c_char,
    message: *const c_char,
) {
    assert_eq!(
        CStr::from_ptr(format).to_bytes(),
        b"%s",
        "logger format must be \"%s\""
    );
    let cat = CStr::from_ptr(category).to_string_lossy().into_owned();
    let msg = CStr::from_ptr(message).to_string_lossy().into_owned();
    LOG.with(|l| l.borrow_mut().push((status, cat, msg)));
}

fn callbacks() -> Fmi2CallbackFunctions {
    type Fixed = unsafe extern "C" fn(
        *mut c_void,
        *const c_char,
        c_int,
        *const c_char,
        *const c_char,
        *const c_char,
    );
    // SAFETY: see `logger`; only ever called with exactly these six arguments.
    let l: Fmi2CallbackLogger = unsafe { std::mem::transmute::<Fixed, Fmi2CallbackLogger>(logger) };
    Fmi2CallbackFunctions {
        logger: Some(l),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    }
}

fn take_log() -> Vec<(c_int, String, String)> {
    LOG.with(|l| std::mem::take(&mut *l.borrow_mut()))
}

/// An fmi2Error from a live instance must come with a logged error message.
fn check_logged(status: c_int, what: &str) {
    let log = take_log();
    if status == FMI2_ERROR {
        assert!(
            log.iter()
                .any(|(s, _, m)| *s == FMI2_ERROR && !m.is_empty()),
            "{what} returned fmi2Error without a logged message"
        );
    }
    assert!(
        (0..=4).contains(&status),
        "{what}: status {status} out of range"
    );
}

struct Driver<M: Model> {
    c: Fmi2Component,
    states: Vec<Fmi2FmuState>,
    time: f64,
    cb: Box<Fmi2CallbackFunctions>,
    _m: std::marker::PhantomData<M>,
}

impl<M: Model> Driver<M> {
    fn vr(&self, v: Vr) -> u32 {
        let n = M::variables().len();
        match v {
            Vr::Valid(i) => (i as usize % n) as u32,
            Vr::Unknown(x) => (n as u32).saturating_add(x),
        }
    }

    fn value(&self, vr: u32, v: Val) -> f64 {
        let var = M::variables().get(vr as usize);
        match (v, var) {
            (Val::InRange(k), Some(var)) => {
                let lo = var.min.unwrap_or(var.start - 1.0);
                let hi = var.max.unwrap_or(var.start + 1.0);
                lo + (hi - lo) * k as f64 / 255.0
            }
            (Val::Start, Some(var)) => var.start,
            (Val::Any(f), _) => f.get(),
            (Val::InRange(_) | Val::Start, None) => 0.5,
        }
    }

    unsafe fn instantiate(&mut self, bad: u8, logging: bool) {
        self.free();
        let guid = std::ffi::CString::new(fmi2_export::fmu_core::xml::guid::<M>()).unwrap();
        let name = c"fuzz";
        let (n, ty, g, f) = match bad % 8 {
            0 => (std::ptr::null(), 1, guid.as_ptr(), &*self.cb as *const _),
            1 => (c"".as_ptr(), 1, guid.as_ptr(), &*self.cb as *const _),
            2 => (name.as_ptr(), 2, guid.as_ptr(), &*self.cb as *const _),
            3 => (name.as_ptr(), 1, c"{nope}".as_ptr(), &*self.cb as *const _),
            4 => (name.as_ptr(), 1, std::ptr::null(), &*self.cb as *const _),
            5 => (name.as_ptr(), 1, guid.as_ptr(), std::ptr::null()),
            _ => (name.as_ptr(), 1, guid.as_ptr(), &*self.cb as *const _),
        };
        self.c = ffi::instantiate::<M>(n, ty, g, f, logging as c_int);
        let log = take_log();
        if bad % 8 < 5 {
            assert!(
                self.c.is_null(),
                "bad instantiate argument {} accepted",
                bad % 8
            );
            assert!(!log.is_empty(), "refused fmi2Instantiate logged nothing");
        } else if bad % 8 == 5 {
            assert!(
                self.c.is_null(),
                "fmi2Instantiate without callbacks accepted"
            );
        } else {
            assert!(!self.c.is_null(), "valid fmi2Instantiate refused: {log:?}");
        }
        self.time = 0.0;
    }

    unsafe fn free(&mut self) {
        if !self.c.is_null() {
            ffi::free_instance::<M>(self.c);
        }
        self.c = std::ptr::null_mut();
        self.states.clear();
        take_log();
    }

    unsafe fn run(&mut self, op: &Op) {
        if self.c.is_null() {
            if let Op::Instantiate { bad, logging } = op {
                self.instantiate(*bad, *logging);
            } else {
                self.instantiate(7, false);
            }
            return;
        }
        let c = self.c;
        let n_vars = M::variables().len();
        let s = match op {
            Op::Instantiate { bad, logging } => {
                self.instantiate(*bad, *logging);
                return;
            }
            Op::Free => {
                self.free();
                return;
            }
            Op::SetDebugLogging { on, cats, null } => {
                let names = [
                    c"logStatusError".as_ptr(),
                    c"logStatusWarning".as_ptr(),
                    c"logEvents".as_ptr(),
                    c"logAll".as_ptr(),
                    c"bogus".as_ptr(),
                    std::ptr::null(),
                ];
                let list: Vec<Fmi2String> = cats.iter().map(|&k| names[k as usize % 6]).collect();
                let p = if *null {
                    std::ptr::null()
                } else {
                    list.as_ptr()
                };
                ffi::set_debug_logging::<M>(c, *on as c_int, list.len(), p)
            }
            Op::Setup {
                start,
                stop_defined,
                stop,
            } => {
                let st = start.get();
                let s =
                    ffi::setup_experiment::<M>(c, 0, 0.0, st, *stop_defined as c_int, stop.get());
                if s == FMI2_OK {
                    self.time = st;
                }
                s
            }
            Op::EnterInit => ffi::enter_initialization_mode::<M>(c),
            Op::ExitInit => ffi::exit_initialization_mode::<M>(c),
            Op::Terminate => ffi::terminate::<M>(c),
            Op::Reset => {
                let s = ffi::reset::<M>(c);
                if s == FMI2_OK {
                    self.time = 0.0;
                }
                s
            }
            Op::SetReal { vrs, vals, null } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let vals: Vec<f64> = vrs
                    .iter()
                    .zip(vals.iter().chain(std::iter::repeat(&Val::Start)))
                    .map(|(&vr, &v)| self.value(vr, v))
                    .collect();
                let p = if *null {
                    std::ptr::null()
                } else {
                    vals.as_ptr()
                };
                ffi::set_real::<M>(c, vrs.as_ptr(), vrs.len(), p)
            }
            Op::SetInteger { vrs, vals } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let vals: Vec<i32> = (0..vrs.len())
                    .map(|i| vals.get(i).copied().unwrap_or(0))
                    .collect();
                ffi::set_integer::<M>(c, vrs.as_ptr(), vrs.len(), vals.as_ptr())
            }
            Op::SetBoolean { vrs, vals } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let vals: Vec<i32> = (0..vrs.len())
                    .map(|i| vals.get(i).copied().unwrap_or(1))
                    .collect();
                ffi::set_boolean::<M>(c, vrs.as_ptr(), vrs.len(), vals.as_ptr())
            }
            Op::GetReal { vrs, null } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let mut out = vec![0.0; vrs.len()];
                let p = if *null {
                    std::ptr::null_mut()
                } else {
                    out.as_mut_ptr()
                };
                let s = ffi::get_real::<M>(c, vrs.as_ptr(), vrs.len(), p);
                if s <= 1 {
                    assert!(
                        out.iter().all(|x| x.is_finite()),
                        "fmi2GetReal gave non-finite values"
                    );
                }
                s
            }
            Op::GetInteger { vrs } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let mut out = vec![0; vrs.len()];
                ffi::get_integer::<M>(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
            }
            Op::GetBoolean { vrs } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let mut out = vec![7; vrs.len()];
                let s = ffi::get_boolean::<M>(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr());
                if s <= 1 {
                    assert!(
                        out.iter().all(|&b| b == 0 || b == 1),
                        "fmi2GetBoolean gave {out:?}"
                    );
                }
                s
            }
            Op::Strings { get, vrs } => {
                let vrs: Vec<u32> = vrs.iter().map(|&v| self.vr(v)).collect();
                let mut out = vec![std::ptr::null(); vrs.len()];
                if *get {
                    ffi::get_string::<M>(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
                } else {
                    ffi::set_string::<M>(c, vrs.as_ptr(), vrs.len(), out.as_ptr())
                }
            }
            Op::DoStep(step) => {
                let (t, h) = match *step {
                    Step::Normal(k) => (self.time, (k as f64 + 1.0) * 0.05 / 256.0),
                    Step::WrongTime(d, k) => (self.time + d.get(), (k as f64 + 1.0) * 1e-3),
                    // huge steps are limited to 1 s of model time: a long integration is not a bug
                    Step::Bad(f) => (self.time, f.get().min(1.0)),
                };
                let s = ffi::do_step::<M>(c, t, h, 1);
                if s == FMI2_OK {
                    self.time = t + h;
                    let mut out = vec![0.0; n_vars];
                    let vrs: Vec<u32> = (0..n_vars as u32)
                        .filter(|&i| {
                            M::variables()[i as usize].vtype == fmi2_export::fmu_core::VarType::Real
                        })
                        .collect();
                    let s2 = ffi::get_real::<M>(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr());
                    assert_eq!(
                        s2,
                        FMI2_OK,
                        "fmi2GetReal after a good step failed: {:?}",
                        take_log()
                    );
                    assert!(
                        out.iter().all(|x| x.is_finite()),
                        "non-finite value after fmi2OK step"
                    );
                }
                s
            }
            Op::GetState { slot, reuse, null } => {
                let mut st: Fmi2FmuState = std::ptr::null_mut();
                if *reuse && !self.states.is_empty() {
                    st = self.states[*slot as usize % self.states.len()];
                }
                let p = if *null {
                    std::ptr::null_mut()
                } else {
                    &mut st as *mut _
                };
                let s = ffi::get_fmu_state::<M>(c, p);
                if s == FMI2_OK && !self.states.contains(&st) {
                    self.states.push(st);
                }
                s
            }
            Op::SetState { slot, foreign } => {
                let st = if *foreign || self.states.is_empty() {
                    8usize as Fmi2FmuState
                } else {
                    self.states[*slot as usize % self.states.len()]
                };
                ffi::set_fmu_state::<M>(c, st)
            }
            Op::FreeState { slot } => {
                if self.states.is_empty() {
                    let mut st: Fmi2FmuState = 16usize as Fmi2FmuState;
                    ffi::free_fmu_state::<M>(c, &mut st)
                } else {
                    let i = *slot as usize % self.states.len();
                    let mut st = self.states[i];
                    let s = ffi::free_fmu_state::<M>(c, &mut st);
                    if s == FMI2_OK {
                        assert!(st.is_null(), "fmi2FreeFMUstate did not clear the handle");
                        self.states.swap_remove(i);
                    }
                    s
                }
            }
            Op::Serialize { slot, short } => {
                let st = if self.states.is_empty() {
                    std::ptr::null_mut()
                } else {
                    self.states[*slot as usize % self.states.len()]
                };
                let mut size = 0usize;
                let s = ffi::serialized_fmu_state_size::<M>(c, st, &mut size);
                check_logged(s, "fmi2SerializedFMUstateSize");
                if s != FMI2_OK {
                    return;
                }
                let n = if *short { size.saturating_sub(1) } else { size };
                let mut buf = vec![0 as c_char; n.max(1)];
                let s = ffi::serialize_fmu_state::<M>(c, st, buf.as_mut_ptr(), n);
                if *short {
                    assert_eq!(s, FMI2_ERROR, "serialize into a short buffer accepted");
                } else {
                    assert_eq!(s, FMI2_OK);
                    // round trip: deserialize, serialize again, same bytes
                    let mut st2: Fmi2FmuState = std::ptr::null_mut();
                    let s2 = ffi::deserialize_fmu_state::<M>(c, buf.as_ptr(), n, &mut st2);
                    assert_eq!(
                        s2,
                        FMI2_OK,
                        "own serialized state refused: {:?}",
                        take_log()
                    );
                    self.states.push(st2);
                    let mut size2 = 0usize;
                    assert_eq!(
                        ffi::serialized_fmu_state_size::<M>(c, st2, &mut size2),
                        FMI2_OK
                    );
                    let mut buf2 = vec![0 as c_char; size2];
                    assert_eq!(
                        ffi::serialize_fmu_state::<M>(c, st2, buf2.as_mut_ptr(), size2),
                        FMI2_OK
                    );
                    assert_eq!(
                        buf[..n],
                        buf2[..],
                        "serialize/deserialize round trip differs"
                    );
                }
                s
            }
            Op::Deserialize {
                slot,
                flip,
                truncate,
            } => {
                // start from a real serialized state (or garbage) and damage it
                let mut bytes: Vec<u8> = b"AFMUST01garbage".to_vec();
                if !self.states.is_empty() {
                    let st = self.states[*slot as usize % self.states.len()];
                    let mut size = 0usize;
                    if ffi::serialized_fmu_state_size::<M>(c, st, &mut size) == FMI2_OK {
                        let mut buf = vec![0u8; size];
                        let s = ffi::serialize_fmu_state::<M>(
                            c,
                            st,
                            buf.as_mut_ptr() as *mut c_char,
                            size,
                        );
                        assert_eq!(s, FMI2_OK);
                        bytes = buf;
                    }
                    take_log();
                }
                if let Some((pos, x)) = flip {
                    if !bytes.is_empty() {
                        let i = *pos as usize % bytes.len();
                        bytes[i] ^= x;
                    }
                }
                if let Some(k) = truncate {
                    bytes.truncate(*k as usize % (bytes.len() + 1));
                }
                let mut st: Fmi2FmuState = std::ptr::null_mut();
                let s = ffi::deserialize_fmu_state::<M>(
                    c,
                    bytes.as_ptr() as *const c_char,
                    bytes.len(),
                    &mut st,
                );
                if s == FMI2_OK {
                    self.states.push(st);
                }
                s
            }
            Op::Status { which, kind, null } => {
                let mut r = 0.0f64;
                let mut i: c_int = 0;
                let mut sp: Fmi2String = std::ptr::null();
                macro_rules! p {
                    ($x:expr) => {
                        if *null {
                            std::ptr::null_mut()
                        } else {
                            $x
                        }
                    };
                }
                let f = match which % 5 {
                    0 => "fmi2GetStatus",
                    1 => "fmi2GetIntegerStatus",
                    2 => "fmi2GetStringStatus",
                    3 => {
                        return check_logged(
                            ffi::get_real_status::<M>(c, *kind, p!(&mut r)),
                            "fmi2GetRealStatus",
                        )
                    }
                    _ => {
                        return check_logged(
                            ffi::get_boolean_status::<M>(c, *kind, p!(&mut i)),
                            "fmi2GetBooleanStatus",
                        )
                    }
                };
                let is_null = *null || (which % 5 == 2 && p!(&mut sp).is_null());
                ffi::get_status::<M>(c, f, *kind, is_null)
            }
            Op::Unsupported(k) => {
                let (f, why) = match k % 4 {
                    0 => ("fmi2GetDirectionalDerivative", "not provided"),
                    1 => ("fmi2SetRealInputDerivatives", "not provided"),
                    2 => ("fmi2GetRealOutputDerivatives", "not provided"),
                    _ => ("fmi2CancelStep", "not provided"),
                };
                ffi::unsupported::<M>(c, f, why)
            }
            Op::NullComponent(k) => {
                let n = std::ptr::null_mut();
                let s = match k % 6 {
                    0 => ffi::do_step::<M>(n, 0.0, 0.1, 1),
                    1 => ffi::exit_initialization_mode::<M>(n),
                    2 => ffi::get_real::<M>(n, std::ptr::null(), 0, std::ptr::null_mut()),
                    3 => ffi::reset::<M>(n),
                    4 => ffi::set_fmu_state::<M>(n, std::ptr::null_mut()),
                    _ => {
                        ffi::free_instance::<M>(n);
                        FMI2_ERROR
                    }
                };
                assert_eq!(
                    s, FMI2_ERROR,
                    "call on a NULL component did not return fmi2Error"
                );
                take_log();
                return;
            }
        };
        check_logged(s, &format!("{op:?}"));
    }
}

unsafe fn drive<M: Model>(ops: &[Op]) {
    let mut d = Driver::<M> {
        c: std::ptr::null_mut(),
        states: Vec::new(),
        time: 0.0,
        cb: Box::new(callbacks()),
        _m: std::marker::PhantomData,
    };
    for op in ops.iter().take(64) {
        d.run(op);
    }
    d.free();
}

/// Run one input on model `M`.
pub fn run<M: Model>(input: &Input) {
    take_log();
    // SAFETY: every pointer passed is valid or deliberately NULL/foreign (which the layer checks).
    unsafe { drive::<M>(&input.ops) }
}
