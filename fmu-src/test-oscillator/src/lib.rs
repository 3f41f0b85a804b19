//! `Oscillator`: a damped spring-mass oscillator `m x'' + c x' + k x = F` used to test the generic
//! FMI layer (state machine, FMU states, logging) independently of the actuator models.
//! Integrated with classical RK4 on fixed sub-steps of at most `max_substep`.
//! `fail_at` makes a step fail on purpose at that time, to test the error path.
//!
//! Modules: [`vars`] (variable table), [`model`] (the FMI model), [`docs`] (documentation): the
//! layout every model crate follows (see ARCHITECTURE.md, "Adding a model").
// Unit tests use the platform libm as an independent reference (workspace clippy.toml).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod docs;
pub mod model;
pub mod vars;

pub use model::Oscillator;
pub use vars::{V, VARIABLES};

/// The variable table follows the FMI rules and the candidate-effect convention.
#[test]
fn the_variable_table_is_consistent() {
    let problems = fmu_core::table_problems::<Oscillator>();
    assert!(problems.is_empty(), "{problems:#?}");
}
