//! The gap workflow: find where a model (an FMU of FMI 2.0 or 3.0 following the candidate-effect
//! convention) and a measurement disagree, name the missing effect, add it, and show the gap
//! shrink.
//!
//! The method is written against the [`GridModel`] trait so it can be tested on synthetic models;
//! [`fmu::FmuSimulator`] adapts an FMU opened by the `host` crate to it, and the CLI's `gap`
//! subcommand wires CSV, FMU, workflow and report together.
//!
//! In short ([`workflow::run`]; every step in [`method`]):
//! 1. Noise level per output from the data's second differences; AR(1) where the base residual
//!    shows correlated noise. The last 30 % of the trace is held out.
//! 2. Calibration of the base parameters by a bounded Levenberg–Marquardt ([`lm`]), directly and
//!    over growing horizons; again with the `[initial]` parameters when the record does not
//!    begin in the model's initial state.
//! 3. Diagnosis of the residual: RMS over noise, whiteness, input correlation, operating region.
//! 4. Scan and linearised screening of every candidate effect, with its visibility (what the
//!    data can show of it at all).
//! 5. Refit of the promising candidates; one is named only with ΔBIC ≥ 10, a magnitude interval
//!    excluding 0 and a lower held-out error; repeated for further effects.
//! 6. Final fit on the whole trace, with intervals checked against the sum of squares itself.
//! 7. Report ([`report`]) and plots ([`plots`]); a disagreement no candidate explains is located
//!    and shaped. [`design`] proposes experiments for candidates the data cannot show.
//!
//! Every threshold of these decisions, with the rule it states, is in [`policy`]; verdicts are
//! typed values ([`workflow::Verdict`], [`workflow::CandidateVerdict`]) put into words by
//! [`report`].

pub mod design;
pub mod fmu;
pub mod lm;
#[doc = include_str!("method.md")]
pub mod method {}
pub mod missing;
pub mod plots;
pub mod policy;
pub mod records;
pub mod records_report;
pub mod report;
pub mod sim;
pub mod spec;
pub mod stats;
pub mod validation;
pub mod workflow;

pub use sim::GridModel;
pub use spec::{EffectSpec, ParamKind, ParamSpec};
pub use workflow::{run, Config, Data, GapError, GapResult};

#[cfg(test)]
mod synthetic;
