//! The FMI 2.0 C layer over `fmu-core`: Co-Simulation, and Model Exchange for a model that also
//! implements `ModelExchange`.
//!
//! [`export_model!`] emits every `fmi2*` C function for a model type; each converts pointers and
//! calls the version-neutral [`fmu_core::Instance`] with its [`calls`] entry (its name and the
//! states FMI 2.0 allows it in). Everything else (state machine, variables, steps, FMU states,
//! descriptions) is `fmu-core`'s.

pub mod calls;
mod export;
pub mod ffi;
pub mod me;
pub mod states;

pub use fmu_core;
