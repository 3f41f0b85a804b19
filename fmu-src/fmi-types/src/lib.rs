//! The FMI vocabulary both versions use, shared by every crate that touches the standard: the
//! exporter (`fmu-core` and its `fmi2-export` and `fmi3-export` layers), the host and its
//! validator (`host`), and the gap workflow (`gap`).
//!
//! - [`c`]: the C ABI of FMI 2.0 (`fmi2FunctionTypes.h`: handles, scalar types, status codes,
//!   callbacks);
//! - [`c3`]: the C ABI of FMI 3.0 (`fmi3PlatformTypes.h`, `fmi3FunctionTypes.h`);
//! - [`Status`]: `fmi2Status` as a Rust enum (the FMI 3.0 codes are the same numbers);
//! - [`schema`]: the vocabulary of `modelDescription.xml` (causality, variability, initial, type
//!   element) and the combinations the standard allows.
//!
//! The crate knows no physics, no model and no C library: it only names what the standard names.
//! The `fmi` crate family (rust-fmi) was weighed for this role: its `fmi-sys` needs libclang at
//! build time, which CI and cross-builds would then need too; the few dozen lines here are the
//! whole need.

pub mod c;
pub mod c3;
pub mod schema;
mod status;

pub use schema::{Causality, Initial, VarKind, Variability};
pub use status::Status;
