//! Opening an FMU of either FMI version for the commands that work on its scalar variables
//! (`gap`, `design`): both versions are described to them by the one view of the model
//! description ([`ModelView`]) and simulated through their own calls.

use crate::common::CliError;
use gap::fmu::FmuSimulator;
use gap::{Data, GapError};
use host::fmi3::Fmu3;
use host::{FmiVersion, Fmu, FmuRef, ModelView, OpenOptions};
use std::path::Path;

/// An opened FMU of either version with the view of its description.
pub struct AnyFmu {
    opened: Opened,
    view: ModelView,
}

/// The binding of the version the description declares.
enum Opened {
    /// FMI 2.0 (Co-Simulation or Model Exchange).
    Fmi2(Box<Fmu>),
    /// FMI 3.0 (Co-Simulation or Model Exchange).
    Fmi3(Box<Fmu3>),
}

impl AnyFmu {
    /// Opens `path` as the FMI version its description declares.
    pub fn open(path: &Path, opts: &OpenOptions) -> Result<AnyFmu, CliError> {
        Ok(match host::fmi_version_of(path).map_err(CliError::input)? {
            FmiVersion::Fmi2 => {
                let fmu = Fmu::open_with(path, opts).map_err(CliError::input)?;
                let view = ModelView::from(fmu.model_description());
                AnyFmu {
                    opened: Opened::Fmi2(Box::new(fmu)),
                    view,
                }
            }
            FmiVersion::Fmi3 => {
                let fmu = Fmu3::open_with(path, opts.interface).map_err(CliError::input)?;
                let view = ModelView::from(fmu.model_description());
                AnyFmu {
                    opened: Opened::Fmi3(Box::new(fmu)),
                    view,
                }
            }
        })
    }

    /// The view of the description.
    pub fn view(&self) -> &ModelView {
        &self.view
    }

    /// The gap workflow's simulator of this FMU on `data`.
    pub fn simulator(&self, data: &Data) -> Result<FmuSimulator<'_>, GapError> {
        let fmu = match &self.opened {
            Opened::Fmi2(f) => FmuRef::Fmi2(f),
            Opened::Fmi3(f) => FmuRef::Fmi3(f),
        };
        FmuSimulator::new(fmu, &self.view, data)
    }
}
