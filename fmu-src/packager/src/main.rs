//! `fmu-package`: zip `modelDescription.xml`, `documentation/` and the shared library into
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
    /// optionally, the icon model.png.
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

fn package(args: &Args) -> Result<(), String> {
    let read = |p: &Path| fs::read(p).map_err(|e| format!("cannot read {}: {e}", p.display()));
    let description = read(&args.model_dir.join("modelDescription.xml"))?;
    let needle = format!("modelIdentifier=\"{}\"", args.identifier);
    if !String::from_utf8_lossy(&description).contains(&needle) {
        return Err(format!(
            "{}: modelIdentifier is not \"{}\"",
            args.model_dir.join("modelDescription.xml").display(),
            args.identifier
        ));
    }
    let mut entries: Vec<(String, Vec<u8>, u32)> =
        vec![("modelDescription.xml".into(), description, 0o644)];
    let icon = args.model_dir.join("model.png");
    if icon.is_file() {
        entries.push(("model.png".into(), read(&icon)?, 0o644));
    }
    let doc_dir = args.model_dir.join("documentation");
    if doc_dir.is_dir() {
        for rel in files_below(&doc_dir).map_err(|e| format!("{}: {e}", doc_dir.display()))? {
            let name = format!("documentation/{}", rel.to_string_lossy().replace('\\', "/"));
            entries.push((name, read(&doc_dir.join(&rel))?, 0o644));
        }
    }
    for spec in &args.binary {
        let (platform, paths) = spec
            .split_once('=')
            .ok_or_else(|| format!("--binary {spec}: expected PLATFORM=PATH"))?;
        let ext = match platform {
            // FMI 2.0 platform names, then the FMI 3.0 platform tuples (FMI 3.0.2 section 2.5.1.1:
            // one folder per architecture, no universal binary).
            "linux64" | "x86_64-linux" | "aarch64-linux" => "so",
            "win64" | "x86_64-windows" => "dll",
            "darwin64" | "x86_64-darwin" | "aarch64-darwin" => "dylib",
            other => return Err(format!("--binary {spec}: unknown platform '{other}'")),
        };
        let slices = paths
            .split('+')
            .map(|p| read(Path::new(p)))
            .collect::<Result<Vec<_>, _>>()?;
        let data = match slices.len() {
            1 => slices.into_iter().next().unwrap_or_default(),
            _ => macho::universal(&slices).map_err(|e| format!("--binary {spec}: {e}"))?,
        };
        let name = format!("binaries/{platform}/{}.{ext}", args.identifier);
        entries.push((name, data, 0o755));
    }

    if let Some(parent) = args.out.parent() {
        fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
    }
    let tmp = args.out.with_extension("fmu.partial");
    let file =
        fs::File::create(&tmp).map_err(|e| format!("cannot create {}: {e}", tmp.display()))?;
    let mut zip = ZipWriter::new(file);
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
    let zerr = |e: zip::result::ZipError| format!("writing {}: {e}", tmp.display());
    for (name, data, mode) in entries {
        zip.start_file(name, options.unix_permissions(mode))
            .map_err(zerr)?;
        zip.write_all(&data)
            .map_err(|e| format!("writing {}: {e}", tmp.display()))?;
    }
    zip.finish().map_err(zerr)?;
    fs::rename(&tmp, &args.out).map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    Ok(())
}

fn main() {
    let args = Args::parse();
    if let Err(e) = package(&args) {
        eprintln!("fmu-package: {e}");
        std::process::exit(2);
    }
}
