//! The C types of FMI 3.0 (`fmi3PlatformTypes.h`, `fmi3FunctionTypes.h`), written by hand: the
//! exported functions need about twenty plain types (integers, floats, `bool`, pointers and
//! three callback pointers), which read directly against the standard's headers, while a
//! generated binding (bindgen) would need libclang and a build script on every machine and for
//! every cross target, for no type that is hard to write.

use std::ffi::{c_char, c_int, c_void};

/// `fmi3Status` (a C enum: `int`): OK 0, Warning 1, Discard 2, Error 3, Fatal 4.
pub type Fmi3Status = c_int;
pub const FMI3_OK: Fmi3Status = 0;
pub const FMI3_ERROR: Fmi3Status = 3;

pub type Fmi3Instance = *mut c_void;
pub type Fmi3InstanceEnvironment = *mut c_void;
pub type Fmi3FmuState = *mut c_void;
pub type Fmi3ValueReference = u32;
pub type Fmi3Float32 = f32;
pub type Fmi3Float64 = f64;
pub type Fmi3Int8 = i8;
pub type Fmi3UInt8 = u8;
pub type Fmi3Int16 = i16;
pub type Fmi3UInt16 = u16;
pub type Fmi3Int32 = i32;
pub type Fmi3UInt32 = u32;
pub type Fmi3Int64 = i64;
pub type Fmi3UInt64 = u64;
/// C99 `bool`, the same size and values as Rust's `bool` for values the FMU writes. Arrays the
/// importer passes in are read as bytes (any non-zero byte is true), never as `bool`.
pub type Fmi3Boolean = bool;
pub type Fmi3Char = c_char;
pub type Fmi3String = *const c_char;
pub type Fmi3Byte = u8;
pub type Fmi3Binary = *const u8;
pub type Fmi3Clock = bool;
/// `fmi3DependencyKind` and `fmi3IntervalQualifier` (C enums).
pub type Fmi3DependencyKind = c_int;
pub type Fmi3IntervalQualifier = c_int;

/// `fmi3LogMessageCallback` (not variadic in FMI 3.0).
pub type Fmi3LogMessageCallback = Option<
    unsafe extern "C" fn(
        env: Fmi3InstanceEnvironment,
        status: Fmi3Status,
        category: Fmi3String,
        message: Fmi3String,
    ),
>;
/// `fmi3ClockUpdateCallback`.
pub type Fmi3ClockUpdateCallback = Option<unsafe extern "C" fn(env: Fmi3InstanceEnvironment)>;
/// `fmi3IntermediateUpdateCallback`.
pub type Fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(
        env: Fmi3InstanceEnvironment,
        time: Fmi3Float64,
        set_requested: Fmi3Boolean,
        get_allowed: Fmi3Boolean,
        step_finished: Fmi3Boolean,
        can_return_early: Fmi3Boolean,
        early_return_requested: *mut Fmi3Boolean,
        early_return_time: *mut Fmi3Float64,
    ),
>;
/// `fmi3LockPreemptionCallback` / `fmi3UnlockPreemptionCallback`.
pub type Fmi3PreemptionCallback = Option<unsafe extern "C" fn()>;
