//! Opening an FMU of either FMI version for the commands that work on its scalar variables
//! (`gap`, `design`): an FMI 3.0 FMU is described to them by the FMI 2.0-shaped view of its
//! scalar variables (`host::fmi3::fmi2_view`) and simulated through the FMI 3.0 calls.

use crate::common::CliError;
use gap::fmu::FmuSimulator;
use gap::{Data, GapError};
use host::fmi3::{fmi2_view, Fmu3};
use host::md::ModelDescription;
use host::{FmiVersion, Fmu, OpenOptions};
use std::path::Path;

/// An opened FMU of either version.
pub enum AnyFmu {
    /// FMI 2.0 Co-Simulation.
    Fmi2(Box<Fmu>),
    /// FMI 3.0 (Co-Simulation or Model Exchange) with the view of its scalar variables.
    Fmi3 {
        /// The FMU.
        fmu: Box<Fmu3>,
        /// Its scalar variables in the FMI 2.0 shape.
        view: Box<ModelDescription>,
    },
}

impl AnyFmu {
    /// Opens `path` as the FMI version its description declares.
    pub fn open(path: &Path, opts: &OpenOptions) -> Result<AnyFmu, CliError> {
        Ok(match host::fmi_version_of(path).map_err(CliError::input)? {
            FmiVersion::Fmi2 => AnyFmu::Fmi2(Box::new(
                Fmu::open_with(path, opts).map_err(CliError::input)?,
            )),
            FmiVersion::Fmi3 => {
                let fmu = Fmu3::open_with(path, opts.interface).map_err(CliError::input)?;
                let view = Box::new(fmi2_view(fmu.model_description()));
                AnyFmu::Fmi3 {
                    fmu: Box::new(fmu),
                    view,
                }
            }
        })
    }

    /// The (FMI 2.0-shaped) description.
    pub fn model_description(&self) -> &ModelDescription {
        match self {
            AnyFmu::Fmi2(f) => f.model_description(),
            AnyFmu::Fmi3 { view, .. } => view,
        }
    }

    /// The gap workflow's simulator of this FMU on `data`.
    pub fn simulator(&self, data: &Data) -> Result<FmuSimulator<'_>, GapError> {
        match self {
            AnyFmu::Fmi2(f) => FmuSimulator::new(f, data),
            AnyFmu::Fmi3 { fmu, view } => FmuSimulator::new3(fmu, view, data),
        }
    }
}
