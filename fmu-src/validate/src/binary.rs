//! Platform binaries: present, of the platform's format and architecture, exporting every
//! FMI function (FMI 2.0.4 sections 2.1, 2.3 and 4.2).

use super::layout::Survey;
use super::rules::names_one_file;
use super::Finding;
use host::binary::Slice;
use host::ffi::{COMMON_AND_CO_SIMULATION_ONLY, FMI2_ME_FUNCTIONS};
use host::md::ModelDescription;
use host::Interface;
use host::{Extracted, LIB_SUFFIX, PLATFORM};
use std::path::Path;

/// File-level checks (FMI 2.0.4 section 2.3): archive entries with `/` as path separator, and
/// the binary for this platform, `binaries/linux64/<modelIdentifier>.so`. Without it, the FMU
/// is still conforming when it ships another implementation ("either sources or one of the
/// binaries for a particular machine"): a note that it is not probed here. A finding when
/// `binaries/linux64/` holds other files (a library not named after the modelIdentifier) or when
/// there is no implementation at all (empty platform folders are none).
pub fn check_files(fmu: &Extracted) -> Vec<Finding> {
    let survey = Survey::of(&fmu.dir);
    let mut f: Vec<Finding> = survey.backslash_finding().into_iter().collect();
    let Some(id) = fmu
        .declared_model_identifier(fmu.default_interface())
        .filter(|id| names_one_file(id))
    else {
        return f;
    };
    let lib = format!("{id}.{LIB_SUFFIX}");
    if survey
        .folder(PLATFORM)
        .is_some_and(|h| h.files.contains(&lib))
    {
        return f;
    }
    let loc = format!("binaries/{PLATFORM}/");
    let folders = survey.folder_list();
    if survey.folder(PLATFORM).is_some_and(|h| !h.files.is_empty()) {
        let m = format!("no binary {lib} (platforms present: {folders})");
        f.push(Finding::new("binary", loc, m));
    } else if let Some(other) = survey.implementation(id, PLATFORM, |_| true) {
        let m = format!("no binary {lib} for this platform: not probed here (the FMU's implementation: {other})");
        f.push(Finding::new("binary-not-probed", loc, m));
    } else {
        let m = format!(
            "no binary {lib} and no other implementation: no {id} library under binaries/ \
             (platforms present: {folders}) and no sources/"
        );
        f.push(Finding::new("binary", loc, m));
    }
    f
}

/// Every binary under `binaries/<platform>/<modelIdentifier>.<so|dll|dylib>`, read without
/// loading it ([`host::binary`]), with the findings it raises: a format or architecture that is
/// not the platform's (FMI 2.0.4 section 2.4), or a function of an interface the description
/// declares missing from a slice (sections 2.1, 3.2 and 4.2).
pub fn check_platform_binaries(fmu: &Extracted) -> (Vec<Finding>, Vec<PlatformBinary>) {
    let (mut findings, mut binaries) = (Vec::new(), Vec::new());
    let mut ids: Vec<&str> = [Interface::CoSimulation, Interface::ModelExchange]
        .into_iter()
        .filter_map(|i| fmu.declared_model_identifier(i))
        .filter(|id| names_one_file(id))
        .collect();
    ids.dedup();
    for platform in platform_dirs(&fmu.dir, false) {
        let Some((format, archs)) = host::binary::expected_format(&platform) else {
            continue;
        };
        let ext = library_extension(format);
        for id in &ids {
            let entry = format!("binaries/{platform}/{id}.{ext}");
            let Ok(bytes) = std::fs::read(fmu.dir.join(&entry)) else {
                continue;
            };
            let need = required_functions(&fmu.model_description, id);
            match check_binary(&bytes, &entry, &platform, format, archs, &need) {
                Ok((f, info)) => {
                    findings.extend(f);
                    binaries.push(PlatformBinary { entry, info });
                }
                Err(f) => findings.push(f),
            }
        }
    }
    (findings, binaries)
}

/// The folders under `binaries/` of the FMU extracted at `dir`, sorted by name (only
/// directories when `dirs_only`); none when there is no `binaries/`.
pub(crate) fn platform_dirs(dir: &Path, dirs_only: bool) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join("binaries"))
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .filter(|e| !dirs_only || e.path().is_dir())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// The file extension of a shared library in `format` (`ELF`, `PE` or `Mach-O`).
pub(crate) fn library_extension(format: &str) -> &'static str {
    match format {
        "PE" => "dll",
        "Mach-O" => "dylib",
        _ => "so",
    }
}

/// The functions of `need` that `slice` does not export, in the order of `need`.
pub(crate) fn missing_exports<'n>(need: &[&'n str], slice: &Slice) -> Vec<&'n str> {
    need.iter()
        .copied()
        .filter(|f| slice.exports.binary_search(&f.to_string()).is_err())
        .collect()
}

/// The functions the binary `id` must export: the common ones (FMI 2.0.4 section 2.1) and those
/// of each interface declared with that modelIdentifier (sections 3.2 and 4.2).
fn required_functions(md: &ModelDescription, id: &str) -> Vec<&'static str> {
    let cs = md
        .co_simulation
        .as_ref()
        .is_some_and(|c| c.model_identifier == id);
    let me = md
        .model_exchange
        .as_ref()
        .is_some_and(|m| m.model_identifier == id);
    let (common, cs_only) = COMMON_AND_CO_SIMULATION_ONLY;
    let mut need: Vec<&'static str> = common.to_vec();
    if cs {
        need.extend_from_slice(cs_only);
    }
    if me {
        need.extend_from_slice(FMI2_ME_FUNCTIONS);
    }
    need
}

/// Format, architectures and exports of one binary against its platform's; Err when it is not a
/// readable binary.
fn check_binary(
    bytes: &[u8],
    entry: &str,
    platform: &str,
    format: &str,
    archs: &[&str],
    need: &[&str],
) -> Result<(Vec<Finding>, host::binary::BinaryInfo), Finding> {
    let info = host::binary::inspect(bytes)
        .map_err(|e| Finding::new("binary-format", entry, e.to_string()))?;
    let mut findings = Vec::new();
    if info.format != format {
        let m = format!("is {}, but {platform} needs {format}", info.format);
        findings.push(Finding::new("binary-format", entry, m));
    }
    for slice in &info.slices {
        if !archs.contains(&slice.architecture.as_str()) {
            let m = format!("holds a {} slice, not one of {archs:?}", slice.architecture);
            findings.push(Finding::new("binary-format", entry, m));
        }
        let missing = missing_exports(need, slice);
        if !missing.is_empty() {
            let m = format!(
                "the {} slice does not export {} FMI function(s): {}",
                slice.architecture,
                missing.len(),
                missing.join(", ")
            );
            findings.push(Finding::new("symbols", entry, m));
        }
    }
    Ok((findings, info))
}

/// One platform binary of an FMU and what it is.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PlatformBinary {
    /// Path inside the archive, e.g. `binaries/win64/HydraulicJoint.dll`.
    pub entry: String,
    /// Format, architectures, exports, glibc needs.
    #[serde(flatten)]
    pub info: host::binary::BinaryInfo,
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
    match unsafe { host::ffi::load_library(&bin) } {
        Err(e) => vec![load_refused(&loc, &e.to_string(), None)],
        Ok(lib) => host::ffi::missing_symbols(&lib)
            .into_iter()
            .map(|s| Finding::new("symbols", &loc, format!("does not export {s}")))
            .collect(),
    }
}

/// What the dynamic loader's `message` says this host lacks, if it names a dependency rather
/// than a defect of the binary: a shared library the binary links
/// (`libgfortran.so.3: cannot open shared object file`) or a newer C library
/// (`version 'GLIBC_2.38' not found`).
fn missing_dependency(message: &str) -> Option<&str> {
    if let Some((before, _)) = message.split_once(": cannot open shared object file") {
        // the library's name is the last word before (`... cannot be loaded: libx.so.3`)
        return before.rsplit(' ').next();
    }
    let version = message.split_once("version `")?.1.split_once('\'')?.0;
    version.starts_with("GLIBC").then_some(version)
}

/// The result for a binary (`loc`) the dynamic loader refused with `message`. A dependency this
/// host lacks is no defect of an FMI 2.0 FMU ("Shared libraries should be statically linked
/// against their dependencies", FMI 2.0.4 section 2.3: a "should"): a note that the binary is not
/// probed here. FMI 3.0.2 section 2.5 makes `documentation/externalDependencies.{txt|html}` a
/// must for such a dependency: `external_dependencies` says, for an FMI 3.0 FMU, whether it is
/// present (a finding when it is not). Any other refusal is a finding.
pub fn load_refused(loc: &str, message: &str, external_dependencies: Option<bool>) -> Finding {
    let clause3 = |mut f: Finding| {
        if external_dependencies.is_some() {
            f.clause = super::fmi3::classify3(&f.check).to_string();
        }
        f
    };
    let Some(dependency) = missing_dependency(message) else {
        return clause3(Finding::new("binary", loc, message));
    };
    if external_dependencies == Some(false) {
        let m = format!(
            "{message}: it depends on {dependency}, and documentation/externalDependencies.\
             {{txt|html}}, which must document such a dependency, is absent"
        );
        return clause3(Finding::new("binary", loc, m));
    }
    let m = format!("{message}: this host lacks {dependency}; not probed here");
    clause3(Finding::new("binary-not-probed", loc, m))
}
