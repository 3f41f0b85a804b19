//! The gap workflow of issue 7: find where a model (an FMI 2.0 co-simulation FMU following the
//! effect convention) and a measurement disagree, name the missing effect, add it, and show the
//! gap shrink.
//!
//! The method is written against the [`Simulator`] trait so it can be tested on synthetic models;
//! the CLI adapts the FMU host to it.

pub mod fmu;
pub mod lm;
pub mod plots;
pub mod report;
pub mod sim;
pub mod spec;
pub mod stats;
pub mod workflow;

pub use sim::Simulator;
pub use spec::{EffectSpec, ParamKind, ParamSpec};
pub use workflow::{run, Config, Data, GapError, GapResult};

#[cfg(test)]
mod synthetic;
