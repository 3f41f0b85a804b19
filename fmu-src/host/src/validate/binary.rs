//! Platform binaries: present, of the platform's format and architecture, exporting every
//! FMI function (FMI 2.0.4 sections 2.1, 2.3 and 4.2).

use super::Finding;
use crate::fmu::{Extracted, PLATFORM};

/// File-level checks: the binary for this platform exists under `binaries/linux64/`.
pub fn check_files(fmu: &Extracted) -> Vec<Finding> {
    let mut f = Vec::new();
    if let Ok(bin) = fmu.binary_path() {
        if !bin.is_file() {
            let others: Vec<String> = std::fs::read_dir(fmu.dir.join("binaries"))
                .map(|rd| {
                    rd.filter_map(|e| e.ok())
                        .map(|e| e.file_name().to_string_lossy().into_owned())
                        .collect()
                })
                .unwrap_or_default();
            f.push(Finding::new(
                "binary",
                format!("binaries/{PLATFORM}/"),
                format!(
                    "no binary {} (platforms present: {})",
                    bin.file_name().unwrap_or_default().to_string_lossy(),
                    if others.is_empty() {
                        "none".into()
                    } else {
                        others.join(", ")
                    }
                ),
            ));
        }
    }
    f
}

/// Every binary under `binaries/<platform>/<modelIdentifier>.<so|dll|dylib>`, read without
/// loading it ([`crate::binary`]), with the findings it raises: a format or architecture that is
/// not the platform's (FMI 2.0.4 section 2.4), or an FMI 2.0 Co-Simulation function missing
/// from a slice (sections 2.1 and 4.2).
pub fn check_platform_binaries(fmu: &Extracted) -> (Vec<Finding>, Vec<PlatformBinary>) {
    let (mut findings, mut binaries) = (Vec::new(), Vec::new());
    let Ok(id) = fmu.model_identifier() else {
        return (findings, binaries);
    };
    let Ok(dirs) = std::fs::read_dir(fmu.dir.join("binaries")) else {
        return (findings, binaries);
    };
    let mut platforms: Vec<String> = dirs
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    platforms.sort();
    for platform in platforms {
        let Some((format, archs)) = crate::binary::expected_format(&platform) else {
            continue;
        };
        let ext = match format {
            "PE" => "dll",
            "Mach-O" => "dylib",
            _ => "so",
        };
        let entry = format!("binaries/{platform}/{id}.{ext}");
        let Ok(bytes) = std::fs::read(fmu.dir.join(&entry)) else {
            continue;
        };
        let info = match crate::binary::inspect(&bytes) {
            Ok(info) => info,
            Err(e) => {
                findings.push(Finding::new("binary-format", &entry, e));
                continue;
            }
        };
        if info.format != format {
            let m = format!("is {}, but {platform} needs {format}", info.format);
            findings.push(Finding::new("binary-format", &entry, m));
        }
        for slice in &info.slices {
            if !archs.contains(&slice.architecture.as_str()) {
                let m = format!("holds a {} slice, not one of {archs:?}", slice.architecture);
                findings.push(Finding::new("binary-format", &entry, m));
            }
            let missing: Vec<&str> = crate::ffi::FMI2_CS_FUNCTIONS
                .iter()
                .copied()
                .filter(|f| slice.exports.binary_search(&f.to_string()).is_err())
                .collect();
            if !missing.is_empty() {
                let m = format!(
                    "the {} slice does not export {} FMI function(s): {}",
                    slice.architecture,
                    missing.len(),
                    missing.join(", ")
                );
                findings.push(Finding::new("symbols", &entry, m));
            }
        }
        binaries.push(PlatformBinary { entry, info });
    }
    (findings, binaries)
}

/// One platform binary of an FMU and what it is.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PlatformBinary {
    /// Path inside the archive, e.g. `binaries/win64/HydraulicJoint.dll`.
    pub entry: String,
    /// Format, architectures, exports, glibc needs.
    #[serde(flatten)]
    pub info: crate::binary::BinaryInfo,
}

/// Loads the binary and reports every FMI 2.0 CS function it does not export.
/// Loading runs the library's initialisers: call it in a child process for untrusted FMUs.
pub fn check_symbols(fmu: &Extracted) -> Vec<Finding> {
    let Ok(bin) = fmu.binary_path() else {
        return Vec::new();
    };
    if !bin.is_file() {
        return Vec::new();
    }
    let loc = format!(
        "binaries/{PLATFORM}/{}",
        bin.file_name().unwrap_or_default().to_string_lossy()
    );
    // SAFETY: the validator's purpose is to load the FMU (in a child process).
    match unsafe { crate::ffi::load_library(&bin) } {
        Err(e) => vec![Finding::new("binary", loc, e.to_string())],
        Ok(lib) => crate::ffi::missing_symbols(&lib)
            .into_iter()
            .map(|s| Finding::new("symbols", &loc, format!("does not export {s}")))
            .collect(),
    }
}
