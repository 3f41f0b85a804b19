//! Opening an `.fmu`: extraction, model description, binary.

use crate::error::{HostError, Result};
use crate::ffi::{self, Functions};
use crate::kind::Interface;
use crate::md::ModelDescription;
use libloading::Library;
use std::io::Read;
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

/// An FMU's files on disk and the text of its `modelDescription.xml`, before the description is
/// parsed: what every FMI version shares (extraction with its bounds, the size and encoding of
/// the description).
pub struct Unpacked {
    /// Where the archive was opened from.
    pub path: PathBuf,
    /// Root of the extracted tree (holds modelDescription.xml).
    pub dir: PathBuf,
    /// The text of `modelDescription.xml`.
    pub xml: String,
    pub(crate) tempdir: Option<tempfile::TempDir>,
}

impl Unpacked {
    /// Extracts `path` (an `.fmu` zip, or an already extracted directory) and reads its
    /// `modelDescription.xml` (at most 64 MiB, UTF-8).
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
        if std::fs::metadata(&md_path).is_ok_and(|m| m.len() > MAX_DESCRIPTION_BYTES) {
            return Err(HostError::Archive {
                path: path.clone(),
                message: format!(
                    "modelDescription.xml is larger than {MAX_DESCRIPTION_BYTES} bytes"
                ),
            });
        }
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
        Ok(Unpacked {
            path,
            dir,
            xml,
            tempdir,
        })
    }

    /// The `fmiVersion` of the root element (read without parsing the rest).
    pub fn fmi_version(&self) -> Option<&str> {
        fmi_version(&self.xml)
    }

    /// `file` for messages about the description: `<fmu>!modelDescription.xml`.
    pub fn description_file(&self) -> String {
        format!("{}!modelDescription.xml", self.path.display())
    }
}

/// Checks that `id`, a `modelIdentifier`, can name a library inside the FMU: not empty, not `.`
/// or `..`, no path separator or NUL. An identifier that is not a C identifier (`clause`) but
/// passes, such as `watertank-c`, is the FMU's defect that `validate` reports; for a shared
/// library it only names the file (functions are not prefixed, FMI 2.0.4 section 2.2.1), so the
/// run goes on. Anything else, such as `../x` or an absolute path, could name a library outside
/// the FMU and is refused.
pub(crate) fn check_library_name(id: &str, fmu: &Path, clause: &str) -> Result<()> {
    let names_a_path = id.is_empty()
        || id == "."
        || id == ".."
        || id.contains(['/', '\\', '\0'])
        || Path::new(id).is_absolute();
    if names_a_path {
        let shown: String = id.chars().take(60).flat_map(char::escape_debug).collect();
        return Err(HostError::Archive {
            path: fmu.to_path_buf(),
            message: format!(
                "modelIdentifier \"{shown}\" is not a C identifier and does not name a file in \
                 binaries/<platform>/ ({clause})"
            ),
        });
    }
    Ok(())
}

/// Path of `binaries/<platform>/<id>.so` under `dir`, refused when it resolves outside the FMU
/// (a symbolic link in an extracted directory given as the FMU must not lead the loader out).
pub(crate) fn binary_under(dir: &Path, fmu: &Path, platform: &str, id: &str) -> Result<PathBuf> {
    let path = dir
        .join("binaries")
        .join(platform)
        .join(format!("{id}.{LIB_SUFFIX}"));
    if let (Ok(real), Ok(root)) = (path.canonicalize(), dir.canonicalize()) {
        if !real.starts_with(&root) {
            return Err(HostError::Archive {
                path: fmu.to_path_buf(),
                message: format!("binaries/{platform}/{id}.{LIB_SUFFIX} resolves outside the FMU"),
            });
        }
    }
    Ok(path)
}

impl Extracted {
    /// Extracts `path` (an `.fmu` zip, or an already extracted directory) and parses its
    /// `modelDescription.xml`.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let unpacked = Unpacked::open(path)?;
        let path = unpacked.path.clone();
        if let Some(v) = unpacked.fmi_version().filter(|v| !v.starts_with("2.")) {
            if v.split('.').next() != Some("3") {
                return Err(crate::kind::unsupported_version(&path, v));
            }
            return Err(HostError::Unsupported {
                path: path.clone(),
                message: "FMI 3.0 is not supported by this command (FMI 2.0 only)".into(),
            });
        }
        let model_description =
            ModelDescription::parse(&unpacked.xml, &unpacked.description_file())?;
        Ok(Extracted {
            path,
            dir: unpacked.dir,
            model_description,
            _tempdir: unpacked.tempdir,
        })
    }

    /// The `modelIdentifier` of the CoSimulation element, which must be a C identifier (FMI
    /// 2.0.4 section 2.2.1: it names the library and prefixes the functions): anything else,
    /// such as `../x` or an absolute path, could name a library outside the FMU.
    pub fn model_identifier(&self) -> Result<&str> {
        self.model_identifier_for(Interface::CoSimulation)
    }

    /// The interface a run uses when none is asked for: Co-Simulation where the FMU offers it,
    /// else Model Exchange.
    pub fn default_interface(&self) -> Interface {
        let md = &self.model_description;
        if md.co_simulation.is_none() && md.model_exchange.is_some() {
            Interface::ModelExchange
        } else {
            Interface::CoSimulation
        }
    }

    /// [`Self::model_identifier`] of the element of `interface`.
    pub fn model_identifier_for(&self, interface: Interface) -> Result<&str> {
        let id =
            self.declared_model_identifier(interface).ok_or_else(|| {
                HostError::Archive {
            path: self.path.clone(),
            message: match interface {
                Interface::CoSimulation => {
                    "modelDescription.xml has no <CoSimulation> element (not a Co-Simulation FMU)"
                }
                Interface::ModelExchange => {
                    "modelDescription.xml has no <ModelExchange> element (not a Model Exchange \
                     FMU)"
                }
            }
            .into(),
        }
            })?;
        check_library_name(id, &self.path, "FMI 2.0.4 section 2.2.1")?;
        Ok(id)
    }

    /// The `modelIdentifier` of the element of `interface` as the description writes it, not
    /// checked to be a C identifier (for reports on what the archive holds under that name).
    pub fn declared_model_identifier(&self, interface: Interface) -> Option<&str> {
        let md = &self.model_description;
        match interface {
            Interface::CoSimulation => md.co_simulation.as_ref().map(|c| &c.model_identifier),
            Interface::ModelExchange => md.model_exchange.as_ref().map(|m| &m.model_identifier),
        }
        .map(String::as_str)
    }

    /// Path of the binary for this platform: `binaries/linux64/<modelIdentifier>.so`.
    pub fn binary_path(&self) -> Result<PathBuf> {
        self.binary_path_for(Interface::CoSimulation)
    }

    /// [`Self::binary_path`] of the library of `interface`.
    pub fn binary_path_for(&self, interface: Interface) -> Result<PathBuf> {
        let id = self.model_identifier_for(interface)?;
        binary_under(&self.dir, &self.path, PLATFORM, id)
    }

    /// `file://` URI of the resources folder, as fmi2Instantiate expects.
    pub fn resource_uri(&self) -> String {
        file_uri(&self.dir.join("resources"))
    }
}

/// The `fmiVersion` attribute of the root element, read before the full parse so that an FMU of
/// another standard version gets one clear message rather than schema errors.
pub fn fmi_version(xml: &str) -> Option<&str> {
    let root = &xml[xml.find("<fmiModelDescription")?..];
    let root = &root[..root.find('>')?];
    let at = root.find("fmiVersion")?;
    let rest = root[at + "fmiVersion".len()..]
        .trim_start()
        .strip_prefix('=')?
        .trim_start();
    let quote = rest.chars().next().filter(|c| *c == '"' || *c == '\'')?;
    let rest = &rest[1..];
    Some(&rest[..rest.find(quote)?])
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
    let mut total: u64 = 0;
    for i in 0..zip.len() {
        let mut entry = zip
            .by_index(i)
            .map_err(|e| bad(format!("entry {i}: {e}")))?;
        let name = crate::error::shown(entry.name(), 80);
        let Some(rel) = entry.enclosed_name() else {
            return Err(bad(format!("entry '{name}' escapes the archive")));
        };
        let out = dest.join(rel);
        // Messages name the entry in the archive, never the temporary directory.
        let io = |e: std::io::Error| bad(format!("entry '{name}' cannot be extracted: {e}"));
        if entry.is_symlink() {
            return Err(bad(format!(
                "entry '{name}' is a symbolic link: an FMU holds regular files only"
            )));
        }
        if entry.is_dir() {
            std::fs::create_dir_all(&out).map_err(io)?;
            continue;
        }
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(io)?;
        }
        let ratio = entry.size() / entry.compressed_size().max(1);
        if entry.size() > MAX_ENTRY_BYTES || (entry.size() > 1 << 20 && ratio > MAX_RATIO) {
            return Err(bad(format!(
                "entry '{name}' would extract to {} bytes ({ratio}x its compressed size; \
                 limits {MAX_ENTRY_BYTES} bytes, {MAX_RATIO}x)",
                entry.size()
            )));
        }
        let mut f = std::fs::File::create(&out).map_err(io)?;
        // The declared size may lie: count what is actually written.
        let limit = MAX_ENTRY_BYTES.min(MAX_TOTAL_BYTES - total);
        let n = std::io::copy(&mut (&mut entry).take(limit + 1), &mut f)
            .map_err(|e| bad(format!("entry '{name}': {e}")))?;
        total += n;
        if n > limit {
            return Err(bad(format!(
                "entry '{name}' extracts to more than {limit} bytes (limits: {MAX_ENTRY_BYTES} \
                 per entry, {MAX_TOTAL_BYTES} in total)"
            )));
        }
    }
    Ok(())
}

/// Limits of extraction, far above any real FMU (ours are 5 MB, binaries of large models some
/// 100 MB) and far below what fills a disk: bytes per entry, bytes in total, and the ratio of an
/// entry's size to its compressed size above which a large entry is taken for a zip bomb.
const MAX_ENTRY_BYTES: u64 = 1 << 30;
const MAX_TOTAL_BYTES: u64 = 2 << 30;
const MAX_RATIO: u64 = 1000;
/// Largest modelDescription.xml read into memory.
const MAX_DESCRIPTION_BYTES: u64 = 64 << 20;

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
    /// The interface its instances are made for.
    interface: Interface,
    /// Instances alive now (for `canBeInstantiatedOnlyOncePerProcess`).
    pub(crate) live_instances: std::sync::atomic::AtomicUsize,
    // Field order matters: the library is unloaded before the extracted files are removed.
    _library: Library,
    extracted: Extracted,
}

/// How to open an FMU.
#[derive(Clone, Debug, Default)]
pub struct OpenOptions {
    /// The Python interpreter whose runtime a binary that needs one (PythonFMU) gets; None:
    /// `python3` on PATH.
    pub python: Option<PathBuf>,
    /// The interface to run (None: [`Extracted::default_interface`]).
    pub interface: Option<Interface>,
}

impl Fmu {
    /// Opens an `.fmu` (or an extracted FMU directory), parses the description and loads
    /// `binaries/linux64/<modelIdentifier>.so`, resolving the FMI 2.0 functions.
    pub fn open(path: impl AsRef<Path>) -> Result<Fmu> {
        Fmu::open_with(path, &OpenOptions::default())
    }

    /// [`Fmu::open`] with options.
    pub fn open_with(path: impl AsRef<Path>, opts: &OpenOptions) -> Result<Fmu> {
        let extracted = Extracted::open(path)?;
        let interface = opts
            .interface
            .unwrap_or_else(|| extracted.default_interface());
        let bin = extracted.binary_path_for(interface)?;
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
        if crate::python::needs_python(&bin) {
            crate::python::ensure_runtime(&extracted.path, opts.python.as_deref())?;
        }
        // SAFETY: loading an FMU's binary is the purpose of the host; the FMU is trusted.
        let library = unsafe { ffi::load_library(&bin) }.map_err(bad)?;
        // SAFETY: the symbols are FMI 2.0 functions with the standard signatures.
        let me = interface == Interface::ModelExchange;
        let functions = unsafe { ffi::resolve_for(&library, me) }.map_err(bad)?;
        Ok(Fmu {
            functions,
            interface,
            live_instances: std::sync::atomic::AtomicUsize::new(0),
            _library: library,
            extracted,
        })
    }

    /// The interface its instances are made for.
    pub fn interface(&self) -> Interface {
        self.interface
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
