//! TwistedString FMU: linear twisted-string actuator of Urukalo, Jovanovic, Rodic ("Modeling,
//! Development and Control of Linear Twisted-String Actuator"): maxon 20 W DC motor, GP 26 A
//! 19.2:1 gearhead, four 1 mm strings twisted into a helix, return spring, vertical load on
//! linear guides, and the ESCON/sbRIO cascade controller (Fig. 11, Table 5).
//!
//! Modules: [`physics`] (pure equations), [`controller`] (the cascade control laws), [`plant`]
//! (state vector and right-hand side), [`vars`] (variable table), [`model`] (the FMI model),
//! [`me`] (its Model Exchange formulation), [`docs`] (the HTML documentation with derivations
//! and parameter tables).
// Unit tests use the platform libm as an independent reference (workspace clippy.toml).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod controller;
pub mod docs;
pub mod me;
pub mod model;
pub mod physics;
pub mod plant;
pub mod vars;

pub use model::TwistedString;
pub use vars::{V, VARIABLES};

/// The variable table follows the FMI rules and the candidate-effect convention.
#[test]
fn the_variable_table_is_consistent() {
    let problems = fmu_core::table_problems::<TwistedString>();
    assert!(problems.is_empty(), "{problems:#?}");
}
