//! `fmu-package`: zip `modelDescription.xml`, `documentation/`, `extra/` and the shared library into
//! `<out>.fmu` (the layout of FMI 2.0.4 section 2.4 and FMI 3.0.2 section 2.5). Entries are written in a fixed order with a fixed
//! timestamp and permissions, so building twice gives byte-identical archives.

mod macho;

use clap::Parser;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

#[derive(Parser)]
#[command(about = "Package an FMI 2.0 or FMI 3.0 FMU reproducibly")]
struct Args {
    /// Directory holding modelDescription.xml, documentation/ (from fmu-binary's describe) and,
    /// optionally, the icon model.png and extra/ (files of layered standards).
    #[arg(long)]
    model_dir: PathBuf,
    /// A compiled shared library as `PLATFORM=PATH` (FMI 2.0 platform names: linux64, win64,
    /// darwin64; FMI 3.0 platform tuples: x86_64-linux, aarch64-linux, x86_64-windows,
    /// x86_64-darwin, aarch64-darwin), stored as `binaries/PLATFORM/<identifier>.<so|dll|dylib>`. Repeatable. For
    /// darwin64, `PATH+PATH` joins single-architecture dylibs into one universal binary.
    #[arg(long, required = true)]
    binary: Vec<String>,
    /// modelIdentifier: the name of the libraries inside binaries/.
    #[arg(long)]
    identifier: String,
    /// The .fmu to write.
    #[arg(long)]
    out: PathBuf,
}

/// Files of `dir` (recursively), sorted, as paths relative to `dir`.
fn files_below(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in fs::read_dir(&d)? {
            let p = entry?.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).expect("below dir").to_path_buf());
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Why an FMU cannot be packaged; each names the file or argument and the cause.
#[derive(Debug, thiserror::Error)]
enum PackageError {
    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: modelIdentifier is not \"{identifier}\"", path.display())]
    Identifier { path: PathBuf, identifier: String },
    #[error("{}: {source}", dir.display())]
    List {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("--binary {spec}: expected PLATFORM=PATH")]
    BinarySpec { spec: String },
    #[error("--binary {spec}: unknown platform '{platform}'")]
    Platform { spec: String, platform: String },
    #[error("--binary {spec}: {source}")]
    Universal {
        spec: String,
        source: macho::UniversalError,
    },
    #[error("cannot create {}: {source}", path.display())]
    Create {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("writing {}: {source}", path.display())]
    Zip {
        path: PathBuf,
        source: zip::result::ZipError,
    },
    #[error("writing {}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot write {}: {source}", path.display())]
    Rename {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The bytes of `path`.
fn read(path: &Path) -> Result<Vec<u8>, PackageError> {
    fs::read(path).map_err(|source| PackageError::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// The archive's entries: name, bytes and Unix mode, in the order they are written.
type Entries = Vec<(String, Vec<u8>, u32)>;

/// `modelDescription.xml` (checked to name `identifier`), the icon and the documentation.
fn model_entries(args: &Args) -> Result<Entries, PackageError> {
    let md_path = args.model_dir.join("modelDescription.xml");
    let description = read(&md_path)?;
    let needle = format!("modelIdentifier=\"{}\"", args.identifier);
    if !String::from_utf8_lossy(&description).contains(&needle) {
        return Err(PackageError::Identifier {
            path: md_path,
            identifier: args.identifier.clone(),
        });
    }
    let mut entries = vec![("modelDescription.xml".into(), description, 0o644)];
    let icon = args.model_dir.join("model.png");
    if icon.is_file() {
        entries.push(("model.png".into(), read(&icon)?, 0o644));
    }
    // documentation/, then extra/ (layered standards' files, FMI 3.0.2 section 2.5; FMI 2.0
    // archives carry it too, as the Modelica Reference-FMUs do for FMI-LS-REF)
    for folder in ["documentation", "extra"] {
        let dir = args.model_dir.join(folder);
        if !dir.is_dir() {
            continue;
        }
        let files = files_below(&dir).map_err(|source| PackageError::List {
            dir: dir.clone(),
            source,
        })?;
        for rel in files {
            let name = format!("{folder}/{}", rel.to_string_lossy().replace('\\', "/"));
            entries.push((name, read(&dir.join(&rel))?, 0o644));
        }
    }
    Ok(entries)
}

/// One `--binary PLATFORM=PATH[+PATH]` as its archive entry.
fn binary_entry(spec: &str, identifier: &str) -> Result<(String, Vec<u8>, u32), PackageError> {
    let (platform, paths) = spec
        .split_once('=')
        .ok_or_else(|| PackageError::BinarySpec { spec: spec.into() })?;
    let ext = match platform {
        // FMI 2.0 platform names, then the FMI 3.0 platform tuples (FMI 3.0.2 section 2.5.1.1:
        // one folder per architecture, no universal binary).
        "linux64" | "x86_64-linux" | "aarch64-linux" => "so",
        "win64" | "x86_64-windows" => "dll",
        "darwin64" | "x86_64-darwin" | "aarch64-darwin" => "dylib",
        other => {
            return Err(PackageError::Platform {
                spec: spec.into(),
                platform: other.into(),
            })
        }
    };
    let slices = paths
        .split('+')
        .map(|p| read(Path::new(p)))
        .collect::<Result<Vec<_>, _>>()?;
    let data = match slices.len() {
        1 => slices.into_iter().next().unwrap_or_default(),
        _ => macho::universal(&slices).map_err(|source| PackageError::Universal {
            spec: spec.into(),
            source,
        })?,
    };
    Ok((
        format!("binaries/{platform}/{identifier}.{ext}"),
        data,
        0o755,
    ))
}

/// Writes `entries` to `out` through a temporary file renamed at the end, so a failed run
/// leaves no partial archive under the final name.
fn write_archive(out: &Path, entries: Entries) -> Result<(), PackageError> {
    if let Some(parent) = out.parent() {
        fs::create_dir_all(parent).map_err(|source| PackageError::Create {
            path: parent.to_path_buf(),
            source,
        })?;
    }
    let tmp = out.with_extension("fmu.partial");
    let file = fs::File::create(&tmp).map_err(|source| PackageError::Create {
        path: tmp.clone(),
        source,
    })?;
    let mut zip = ZipWriter::new(file);
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
    let zerr = |source| PackageError::Zip {
        path: tmp.clone(),
        source,
    };
    for (name, data, mode) in entries {
        zip.start_file(name, options.unix_permissions(mode))
            .map_err(zerr)?;
        zip.write_all(&data).map_err(|source| PackageError::Write {
            path: tmp.clone(),
            source,
        })?;
    }
    zip.finish().map_err(zerr)?;
    fs::rename(&tmp, out).map_err(|source| PackageError::Rename {
        path: out.to_path_buf(),
        source,
    })
}

fn package(args: &Args) -> Result<(), PackageError> {
    let mut entries = model_entries(args)?;
    for spec in &args.binary {
        entries.push(binary_entry(spec, &args.identifier)?);
    }
    write_archive(&args.out, entries)
}

fn main() {
    let args = Args::parse();
    if let Err(e) = package(&args) {
        eprintln!("fmu-package: {e}");
        std::process::exit(2);
    }
}
