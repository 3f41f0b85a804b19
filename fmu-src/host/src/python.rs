//! FMUs whose binary expects a Python runtime already in the process.
//!
//! PythonFMU (and similar tools) ship a binary that calls the CPython API without linking
//! libpython: its dynamic symbol table has undefined `Py*`/`_Py*` symbols and no `libpython`
//! among its needed libraries, so `dlopen` fails with "undefined symbol: _Py_NoneStruct".
//! Such a binary is recognised from its symbol table (goblin), a Python runtime is found (the
//! interpreter given by the user, else `python3` on PATH), its shared libpython is loaded with
//! global symbols before the FMU, and the interpreter's `sys.path` is put on PYTHONPATH so
//! the embedded interpreter imports what that Python has installed.

use crate::error::{HostError, Result};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Whether the ELF binary at `bin` uses the CPython API without linking libpython.
pub fn needs_python(bin: &Path) -> bool {
    let Ok(bytes) = std::fs::read(bin) else {
        return false;
    };
    let Ok(goblin::Object::Elf(elf)) = goblin::Object::parse(&bytes) else {
        return false;
    };
    if elf.libraries.iter().any(|l| l.starts_with("libpython")) {
        return false;
    }
    elf.dynsyms.iter().any(|s| {
        s.is_import()
            && elf
                .dynstrtab
                .get_at(s.st_name)
                .is_some_and(|n| n.starts_with("Py") || n.starts_with("_Py"))
    })
}

/// The runtime loaded for such FMUs (once per process).
static RUNTIME: OnceLock<std::result::Result<PathBuf, RuntimeError>> = OnceLock::new();

/// Why no Python runtime could be loaded.
#[derive(Clone, Debug, thiserror::Error)]
enum RuntimeError {
    /// The interpreter could not be started.
    #[error("cannot run {}: {cause}", .python.display())]
    NotRun {
        /// The interpreter.
        python: PathBuf,
        /// The system's reason.
        cause: String,
    },
    /// The interpreter's query failed.
    #[error("{} -c failed ({status})", .python.display())]
    QueryFailed {
        /// The interpreter.
        python: PathBuf,
        /// Its exit status.
        status: std::process::ExitStatus,
    },
    /// The interpreter has no shared libpython.
    #[error("{} has no shared libpython", .python.display())]
    NoSharedLibrary {
        /// The interpreter.
        python: PathBuf,
    },
    /// libpython could not be loaded.
    #[error("cannot load {}: {cause}", .library.display())]
    NotLoaded {
        /// The library.
        library: PathBuf,
        /// The loader's reason.
        cause: String,
    },
}

/// Loads a Python runtime for the FMU `fmu` (named in messages): `python` is the interpreter
/// the user named, else `python3` on PATH. Returns the libpython loaded.
pub fn ensure_runtime(fmu: &Path, python: Option<&Path>) -> Result<PathBuf> {
    RUNTIME
        .get_or_init(|| load_runtime(python))
        .clone()
        .map_err(|why| HostError::Binary {
            path: fmu.to_path_buf(),
            message: format!(
                "its binary needs a Python runtime (libpython) in the process, as FMUs made by \
                 PythonFMU do: {why}; install python3 with its shared library or name one with \
                 --python /path/to/python3"
            ),
        })
}

fn load_runtime(python: Option<&Path>) -> std::result::Result<PathBuf, RuntimeError> {
    let exe = python.map_or_else(|| PathBuf::from("python3"), Path::to_path_buf);
    const QUERY: &str = "import sys, sysconfig\n\
        print(sysconfig.get_config_var('LIBDIR') or '')\n\
        print(sysconfig.get_config_var('INSTSONAME') or sysconfig.get_config_var('LDLIBRARY') or '')\n\
        print(':'.join(p for p in sys.path if p))";
    let out = Command::new(&exe)
        .args(["-c", QUERY])
        .output()
        .map_err(|e| RuntimeError::NotRun {
            python: exe.clone(),
            cause: e.to_string(),
        })?;
    if !out.status.success() {
        return Err(RuntimeError::QueryFailed {
            python: exe,
            status: out.status,
        });
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let mut lines = text.lines();
    let (libdir, soname, path) = (
        lines.next().unwrap_or(""),
        lines.next().unwrap_or(""),
        lines.next().unwrap_or(""),
    );
    if soname.is_empty() || soname.ends_with(".a") {
        return Err(RuntimeError::NoSharedLibrary { python: exe });
    }
    let lib = Path::new(libdir).join(soname);
    // SAFETY: loading the Python runtime the FMU was made for; RTLD_GLOBAL makes its symbols
    // visible to the FMU binary loaded next.
    let handle = unsafe {
        libloading::os::unix::Library::open(
            Some(&lib),
            libloading::os::unix::RTLD_NOW | libloading::os::unix::RTLD_GLOBAL,
        )
    }
    .map_err(|e| RuntimeError::NotLoaded {
        library: lib.clone(),
        cause: e.to_string(),
    })?;
    // The runtime stays loaded for the life of the process (FMU binaries refer to it).
    std::mem::forget(handle);
    // The embedded interpreter computes its paths from the installation of libpython, not
    // from a virtual environment: give it the interpreter's own sys.path. Set once, before the
    // FMU is loaded, while no FMU thread runs.
    let joined = match std::env::var_os("PYTHONPATH") {
        Some(old) if !old.is_empty() => format!("{path}:{}", old.to_string_lossy()),
        _ => path.to_string(),
    };
    std::env::set_var("PYTHONPATH", joined);
    Ok(lib)
}
