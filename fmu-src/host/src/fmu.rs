//! Opening an `.fmu`: extraction, model description, binary.

use crate::error::{HostError, Result};
use crate::ffi::{self, Functions};
use crate::md::ModelDescription;
use libloading::Library;
use std::path::{Path, PathBuf};

/// Platform folder of the binaries on this machine (FMI 2.0.4 section 2.3).
pub const PLATFORM: &str = "linux64";
/// Shared library suffix on this platform.
pub const LIB_SUFFIX: &str = "so";

/// An FMU extracted and parsed, without its binary loaded.
pub struct Extracted {
    /// Where the archive was opened from.
    pub path: PathBuf,
    /// Root of the extracted tree (holds modelDescription.xml).
    pub dir: PathBuf,
    /// The parsed description.
    pub model_description: ModelDescription,
    _tempdir: Option<tempfile::TempDir>,
}

impl Extracted {
    /// Extracts `path` (an `.fmu` zip, or an already extracted directory) and parses its
    /// `modelDescription.xml`.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let meta = std::fs::metadata(&path).map_err(|source| HostError::Io {
            path: path.clone(),
            source,
        })?;
        let (dir, tempdir) = if meta.is_dir() {
            (path.clone(), None)
        } else {
            let td = tempfile::Builder::new()
                .prefix("fmu-host-")
                .tempdir()
                .map_err(|source| HostError::Io {
                    path: std::env::temp_dir(),
                    source,
                })?;
            extract(&path, td.path())?;
            (td.path().to_path_buf(), Some(td))
        };
        let md_path = dir.join("modelDescription.xml");
        let xml = std::fs::read(&md_path).map_err(|_| HostError::Archive {
            path: path.clone(),
            message: "no modelDescription.xml at the top level".into(),
        })?;
        let xml = String::from_utf8(xml).map_err(|e| HostError::ModelDescription {
            file: format!("{}!modelDescription.xml", path.display()),
            line: 1,
            column: 0,
            message: format!("not UTF-8: {e}"),
        })?;
        let model_description =
            ModelDescription::parse(&xml, &format!("{}!modelDescription.xml", path.display()))?;
        Ok(Extracted {
            path,
            dir,
            model_description,
            _tempdir: tempdir,
        })
    }

    /// The `modelIdentifier` of the CoSimulation element.
    pub fn model_identifier(&self) -> Result<&str> {
        self.model_description
            .co_simulation
            .as_ref()
            .map(|c| c.model_identifier.as_str())
            .ok_or_else(|| HostError::Archive {
                path: self.path.clone(),
                message:
                    "modelDescription.xml has no <CoSimulation> element (not a Co-Simulation FMU)"
                        .into(),
            })
    }

    /// Path of the binary for this platform: `binaries/linux64/<modelIdentifier>.so`.
    pub fn binary_path(&self) -> Result<PathBuf> {
        let id = self.model_identifier()?;
        Ok(self
            .dir
            .join("binaries")
            .join(PLATFORM)
            .join(format!("{id}.{LIB_SUFFIX}")))
    }

    /// `file://` URI of the resources folder, as fmi2Instantiate expects.
    pub fn resource_uri(&self) -> String {
        file_uri(&self.dir.join("resources"))
    }
}

/// Extracts the zip at `archive` into `dest`, refusing entries that escape it.
fn extract(archive: &Path, dest: &Path) -> Result<()> {
    let bad = |message: String| HostError::Archive {
        path: archive.to_path_buf(),
        message,
    };
    let file = std::fs::File::open(archive).map_err(|source| HostError::Io {
        path: archive.to_path_buf(),
        source,
    })?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| bad(format!("not a zip archive: {e}")))?;
    for i in 0..zip.len() {
        let mut entry = zip
            .by_index(i)
            .map_err(|e| bad(format!("entry {i}: {e}")))?;
        let Some(rel) = entry.enclosed_name() else {
            return Err(bad(format!("entry '{}' escapes the archive", entry.name())));
        };
        let out = dest.join(rel);
        let io = |source| HostError::Io {
            path: out.clone(),
            source,
        };
        if entry.is_dir() {
            std::fs::create_dir_all(&out).map_err(io)?;
            continue;
        }
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(io)?;
        }
        let mut f = std::fs::File::create(&out).map_err(io)?;
        std::io::copy(&mut entry, &mut f)
            .map_err(|e| bad(format!("entry '{}': {e}", entry.name())))?;
    }
    Ok(())
}

/// Percent-encodes a path as a `file://` URI (RFC 8089).
pub fn file_uri(path: &Path) -> String {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut s = String::from("file://");
    for b in abs.to_string_lossy().bytes() {
        if b.is_ascii_alphanumeric() || b"/-_.~".contains(&b) {
            s.push(b as char);
        } else {
            s.push_str(&format!("%{b:02X}"));
        }
    }
    s
}

/// An opened FMU: extracted tree, parsed description and loaded binary.
///
/// `Fmu` is `Send + Sync`: share it by reference between threads, each with its own
/// [`crate::Instance`] (FMI 2.0 allows concurrent use of different instances unless
/// `canBeInstantiatedOnlyOncePerProcess`).
pub struct Fmu {
    pub(crate) functions: Functions,
    /// Instances alive now (for `canBeInstantiatedOnlyOncePerProcess`).
    pub(crate) live_instances: std::sync::atomic::AtomicUsize,
    // Field order matters: the library is unloaded before the extracted files are removed.
    _library: Library,
    extracted: Extracted,
}

impl Fmu {
    /// Opens an `.fmu` (or an extracted FMU directory), parses the description and loads
    /// `binaries/linux64/<modelIdentifier>.so`, resolving the FMI 2.0 functions.
    pub fn open(path: impl AsRef<Path>) -> Result<Fmu> {
        let extracted = Extracted::open(path)?;
        let bin = extracted.binary_path()?;
        if !bin.is_file() {
            return Err(HostError::Archive {
                path: extracted.path.clone(),
                message: format!(
                    "no binary for this platform (expected binaries/{PLATFORM}/{})",
                    bin.file_name().unwrap_or_default().to_string_lossy()
                ),
            });
        }
        let rel = format!(
            "binaries/{PLATFORM}/{}",
            bin.file_name().unwrap_or_default().to_string_lossy()
        );
        let bad = |message: ffi::LoadError| HostError::Binary {
            path: extracted.path.clone(),
            message: format!("{rel} {message}"),
        };
        // SAFETY: loading an FMU's binary is the purpose of the host; the FMU is trusted.
        let library = unsafe { ffi::load_library(&bin) }.map_err(bad)?;
        // SAFETY: the symbols are FMI 2.0 functions with the standard signatures.
        let functions = unsafe { ffi::resolve(&library) }.map_err(bad)?;
        Ok(Fmu {
            functions,
            live_instances: std::sync::atomic::AtomicUsize::new(0),
            _library: library,
            extracted,
        })
    }

    /// The parsed `modelDescription.xml`.
    pub fn model_description(&self) -> &ModelDescription {
        &self.extracted.model_description
    }

    /// The extracted files.
    pub fn extracted(&self) -> &Extracted {
        &self.extracted
    }

    /// The path the FMU was opened from.
    pub fn path(&self) -> &Path {
        &self.extracted.path
    }

    /// Names of FMI 2.0 CS functions the binary does not export.
    pub fn missing_functions(&self) -> Vec<&'static str> {
        ffi::missing_symbols(&self._library)
    }
}
