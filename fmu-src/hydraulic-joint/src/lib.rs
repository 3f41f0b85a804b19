//! HydraulicJoint FMU: the NEUROexos agonist/antagonist hydraulic shoulder joint
//! (paper: "Description, Characterization and Assessment of a Bio-Inspired Shoulder Joint-First
//! Link Robot for Neuro-Robotic Applications"), a model for Co-Simulation and Model Exchange
//! (built into FMI 2.0 and FMI 3.0 FMUs by `fmu-binary`).
//!
//! Modules: [`physics`] (pure equations), [`controller`] (the 40 Hz position controller),
//! [`plant`] (state vector and right-hand side), [`vars`] (variable table), [`model`] (the
//! FMI model), [`me`] (its Model Exchange side), [`docs`] (the HTML documentation with
//! derivations and parameter tables).
// Unit tests use the platform libm as an independent reference (workspace clippy.toml).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod controller;
pub mod docs;
pub mod me;
pub mod model;
pub mod physics;
pub mod plant;
pub mod vars;

pub use model::HydraulicJoint;
pub use vars::{V, VARIABLES};

/// The variable table follows the FMI rules and the candidate-effect convention.
#[test]
fn the_variable_table_is_consistent() {
    let problems = fmu_core::table_problems::<HydraulicJoint>();
    assert!(problems.is_empty(), "{problems:#?}");
}
