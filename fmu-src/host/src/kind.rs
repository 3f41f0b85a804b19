//! What kind of FMU a file is, read before anything is extracted or loaded: the FMI version of
//! its model description, and the interface a command runs it through. The commands dispatch on
//! these (FMI 2.0 or 3.0; Co-Simulation or Model Exchange), each kind having its own module.

use crate::error::{HostError, Result};
use std::io::Read;
use std::path::Path;

/// The FMI major version of an FMU.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum FmiVersion {
    /// FMI 2.0 (`fmiVersion="2.0"`).
    Fmi2,
    /// FMI 3.0 (`fmiVersion="3.x"`, or a 3.0 beta/rc).
    Fmi3,
}

/// The interface an FMU is run through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    /// Co-Simulation: the FMU integrates itself (`fmi2DoStep`, `fmi3DoStep`).
    CoSimulation,
    /// Model Exchange: the host integrates the FMU's derivatives.
    ModelExchange,
}

impl Interface {
    /// Parses `cs` / `me` (as `--interface` takes them).
    pub fn parse(s: &str) -> Option<Interface> {
        match s {
            "cs" | "CoSimulation" => Some(Interface::CoSimulation),
            "me" | "ModelExchange" => Some(Interface::ModelExchange),
            _ => None,
        }
    }
}

impl std::fmt::Display for Interface {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Interface::CoSimulation => "Co-Simulation",
            Interface::ModelExchange => "Model Exchange",
        })
    }
}

/// Largest modelDescription.xml read (as when the FMU is opened).
const MAX_DESCRIPTION_BYTES: u64 = 64 << 20;

/// The FMI version of the FMU at `path` (an `.fmu` or an extracted directory), from the root
/// element's `fmiVersion` alone: only `modelDescription.xml` is read.
pub fn fmi_version_of(path: &Path) -> Result<FmiVersion> {
    let xml = read_description(path)?;
    let v = crate::fmu::fmi_version(&xml).unwrap_or("");
    match v.split('.').next() {
        Some("2") => Ok(FmiVersion::Fmi2),
        Some("3") => Ok(FmiVersion::Fmi3),
        _ => Err(unsupported_version(path, v)),
    }
}

/// The refusal of an FMU at `path` declaring `fmiVersion` `version`, which is neither 2.x nor 3.x.
pub(crate) fn unsupported_version(path: &Path, version: &str) -> HostError {
    HostError::Unsupported {
        path: path.to_path_buf(),
        message: format!(
            "fmiVersion \"{}\" is not supported (FMI 2.0 and 3.0 are)",
            crate::error::shown(version, 20)
        ),
    }
}

/// The `fmiVersion` the FMU at `path` declares, as written; None when it cannot be read.
pub fn declared_fmi_version(path: &Path) -> Option<String> {
    let xml = read_description(path).ok()?;
    crate::fmu::fmi_version(&xml).map(str::to_string)
}

/// The text of `modelDescription.xml` of the FMU at `path` (an `.fmu` or an extracted
/// directory), without extracting anything else: at most [`MAX_DESCRIPTION_BYTES`], lossy UTF-8
/// (the description parser reports text that is not UTF-8).
pub fn read_description(path: &Path) -> Result<String> {
    let io = |source| HostError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bad = |message: String| HostError::Archive {
        path: path.to_path_buf(),
        message,
    };
    let mut bytes = Vec::new();
    if std::fs::metadata(path).map_err(io)?.is_dir() {
        let f = std::fs::File::open(path.join("modelDescription.xml"))
            .map_err(|_| bad("no modelDescription.xml at the top level".into()))?;
        f.take(MAX_DESCRIPTION_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(io)?;
    } else {
        let file = std::fs::File::open(path).map_err(io)?;
        let mut zip =
            zip::ZipArchive::new(file).map_err(|e| bad(format!("not a zip archive: {e}")))?;
        let entry = zip
            .by_name("modelDescription.xml")
            .map_err(|_| bad("no modelDescription.xml at the top level".into()))?;
        entry
            .take(MAX_DESCRIPTION_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| bad(format!("modelDescription.xml cannot be read: {e}")))?;
    }
    if bytes.len() as u64 > MAX_DESCRIPTION_BYTES {
        return Err(bad(format!(
            "modelDescription.xml is larger than {MAX_DESCRIPTION_BYTES} bytes"
        )));
    }
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}
