//! FMI 2.0 types shared by every crate that touches the standard: the exporter
//! (`fmi2-export`), the host and its validator (`host`), and the gap workflow (`gap`).
//!
//! - [`c`]: the C ABI of `fmi2FunctionTypes.h` (handles, scalar types, status codes, callbacks);
//! - [`Status`]: `fmi2Status` as a Rust enum;
//! - [`schema`]: the vocabulary of `modelDescription.xml` (causality, variability, initial, type
//!   element) and the combinations FMI 2.0 allows;
//! - [`effects`]: this project's candidate-effect convention (`<effect>.enabled` plus Real
//!   `<effect>.<name>` parameters with unit and range; `[calibrate]` tags), read the same way by
//!   the exporter's table check, the validator and the gap workflow.
//!
//! The crate knows no physics, no model and no C library: it only names what the standard names.
//! The `fmi` crate family (rust-fmi) was weighed for this role: its `fmi-sys` needs libclang at
//! build time, which CI and cross-builds would then need too, and its schema types carry FMI 3.0
//! and Model-Exchange parts none of our crates use; the few dozen lines here are the whole need.

pub mod c;
pub mod effects;
pub mod schema;
mod status;

pub use schema::{Causality, Initial, VarKind, Variability};
pub use status::Status;
