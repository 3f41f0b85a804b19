//! Host for FMI 2.0 Co-Simulation FMUs (any conforming FMU, not only this project's).
//!
//! - [`Fmu::open`] extracts the `.fmu`, parses `modelDescription.xml` ([`md`]) and loads the
//!   binary, resolving the FMI 2.0 functions.
//! - [`Fmu::instantiate`] gives an RAII [`Instance`] with typed calls; a failed call is a
//!   [`HostError::Fmi`] carrying the status and the messages the FMU logged.
//! - [`simulate`] / [`Simulator`] run a whole simulation from a [`SimulationRequest`].
//! - [`csv`] reads measured/input CSV files with located errors and writes results.
//! - [`watch`] marks each FMI call on a page a supervising process reads (crash and hang
//!   reports); [`python`] provides the Python runtime PythonFMU binaries expect.
#![warn(missing_docs)]

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
pub mod me;
pub mod python;
mod simulate;
pub mod watch;
mod xml;

pub use error::{shown, HostError, LogRecord, Result, Status};
pub use fmu::{file_uri, Extracted, Fmu, OpenOptions, Unpacked, LIB_SUFFIX, PLATFORM};
pub use fmu_state3::FmuStateHandle3;
pub use instance::{FmuStateHandle, Instance, InstanceOptions};
pub use kind::{fmi_version_of, FmiVersion, Interface};
pub use md::ModelDescription;
pub use simulate::{
    communication_points, hold_index, interpolate, simulate, InputSeries, SimulationRequest,
    SimulationResult, Simulator, TextColumns, Value,
};
