//! Builds the test FMU of `tests/fixtures` (C source + modelDescription.xml) into an `.fmu`.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};

/// The fixtures folder (this module is also included by the cli crate's tests).
pub fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../host/tests/fixtures")
}

/// The fixture's modelDescription.xml text.
pub fn fixture_md() -> String {
    std::fs::read_to_string(fixtures().join("modelDescription.xml")).unwrap()
}

/// Compiles `tests/fixtures/testfmu.c` with `defines` (e.g. `["-DLAX"]`) and zips it with
/// `md_xml` into `dir/<name>.fmu`.
pub fn build_fmu(dir: &Path, name: &str, defines: &[&str], md_xml: &str) -> PathBuf {
    let src = fixtures().join("testfmu.c");
    let so = dir.join(format!("{name}.so"));
    let status = std::process::Command::new("cc")
        .args(["-shared", "-fPIC", "-O1"])
        .args(defines)
        .arg("-o")
        .arg(&so)
        .arg(&src)
        .arg("-lm")
        .status()
        .expect("a C compiler (cc) is needed for the test FMU");
    assert!(status.success(), "compiling the test FMU failed");
    let fmu = dir.join(format!("{name}.fmu"));
    let f = std::fs::File::create(&fmu).unwrap();
    let mut z = zip::ZipWriter::new(f);
    let opts = zip::write::SimpleFileOptions::default();
    z.start_file("modelDescription.xml", opts).unwrap();
    z.write_all(md_xml.as_bytes()).unwrap();
    z.start_file("binaries/linux64/Dummy.so", opts).unwrap();
    z.write_all(&std::fs::read(&so).unwrap()).unwrap();
    z.finish().unwrap();
    fmu
}
