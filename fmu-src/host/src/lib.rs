//! Host for FMI 2.0 and FMI 3.0 FMUs, Co-Simulation and Model Exchange (any conforming FMU, not
//! only this project's).
//!
//! - [`Fmu::open`] extracts an FMI 2.0 `.fmu`, parses `modelDescription.xml` ([`md`]) and loads
//!   the binary; [`fmi3::Fmu3`] does the same for FMI 3.0 ([`fmi3::md`]).
//! - [`view`] is one view of a model description of either version, for code that names,
//!   ranges and sets variables ([`ModelView`]).
//! - [`Fmu::instantiate`] gives an RAII [`Instance`] with typed calls; a failed call is a
//!   [`HostError::Fmi`] carrying the status and the messages the FMU logged.
//! - [`simulate`] / [`Simulator`] (FMI 2.0) and [`fmi3::simulate3`] / [`fmi3::Simulator3`] run
//!   a whole simulation, the Co-Simulation steps and the Model Exchange integration written
//!   once for both versions ([`CoSimulationStep`]); [`FmuRef`] / [`AnySimulator`] run either
//!   version from one [`SimulationRequest`].
//! - [`csv`] reads measured/input CSV files with located errors and writes results.
//! - [`watch`] marks each FMI call on a page a supervising process reads (crash and hang
//!   reports); [`python`] provides the Python runtime PythonFMU binaries expect.
#![warn(missing_docs)]

mod any;
pub mod binary;
pub mod csv;
mod error;
pub mod ffi;
pub mod fmi3;
mod fmu;
mod fmu_state3;
mod instance;
pub mod kind;
pub mod md;
pub mod md_common;
pub mod me;
pub mod python;
mod run;
mod simulate;
pub mod view;
pub mod watch;
mod xml;

pub use any::{AnySimulator, FmuRef};
pub use error::{shown, HostError, LogRecord, Result, Status};
pub use fmu::{file_uri, Extracted, Fmu, OpenOptions, Unpacked, LIB_SUFFIX, PLATFORM};
pub use fmu_state3::FmuStateHandle3;
pub use instance::{FmuStateHandle, Instance, InstanceOptions};
pub use kind::{fmi_version_of, FmiVersion, Interface};
pub use md::ModelDescription;
pub use run::CoSimulationStep;
pub use simulate::{
    communication_points, hold_index, interpolate, simulate, simulate_then, InputSeries, Simulated,
    SimulationRequest, SimulationResult, Simulator, TextColumns, Value,
};
pub use view::ModelView;
