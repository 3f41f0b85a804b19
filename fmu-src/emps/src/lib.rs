//! EMPS: the electro-mechanical positioning system of the Nonlinear System Identification
//! Benchmarks (A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", 2019):
//! a Maxon DC motor driving a ball-screw positioning unit that carries a load, under the logged
//! dSPACE controller (P position loop around a P velocity loop, 1 kHz, +-10 V, drive gain).
//! Base parameters to calibrate (mass, viscous friction, offset) and candidate effects from the
//! physics of a ball-screw drive (Coulomb and asymmetric friction, a flexibility, backlash,
//! friction along the screw, a controller delay), following the candidate-effect convention.
//!
//! Modules: [`physics`] (pure equations with their sources), [`plant`] (state vector and
//! right-hand side), [`controller`] (the sampled cascade law), [`vars`] (variable table),
//! [`model`] (the FMI model), [`me`] (its Model Exchange formulation), [`docs`] (the HTML documentation with derivations).
// Unit tests use the platform libm as an independent reference (workspace clippy.toml).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod controller;
pub mod docs;
pub mod me;
pub mod model;
pub mod physics;
pub mod plant;
pub mod vars;

pub use model::Emps;
pub use vars::{V, VARIABLES};

/// The variable table follows the FMI rules and the candidate-effect convention.
#[test]
fn the_variable_table_is_consistent() {
    let problems = fmu_core::table_problems::<Emps>();
    assert!(problems.is_empty(), "{problems:#?}");
}
