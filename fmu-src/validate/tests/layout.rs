//! The implementation an FMI 2.0 FMU ships (FMI 2.0.4 section 2.3: "at least one
//! implementation, in other words, either sources or one of the binaries for a particular
//! machine") and the path separators of its archive, on archives zipped here from a few entries.
// Host side: runs in the user's process, not inside an FMU; the FMUs' bit-determinism (the
// workspace clippy.toml) does not bind it.
#![allow(clippy::disallowed_methods)]

#[path = "../../host/tests/common/mod.rs"]
mod common;

use std::io::Write;
use std::path::PathBuf;
use validate::{check_files, Finding};

/// An FMU zipped from the fixture's description and `entries` (name, bytes; a name ending in
/// `/` is a folder entry).
fn zipped(entries: &[(&str, &[u8])]) -> (tempfile::TempDir, PathBuf) {
    zipped_with(&common::fixture_md(), entries)
}

/// An FMU zipped from the description `md` and `entries`, as [`zipped`].
fn zipped_with(md: &str, entries: &[(&str, &[u8])]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("M.fmu");
    let mut z = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    z.start_file("modelDescription.xml", opts).unwrap();
    z.write_all(md.as_bytes()).unwrap();
    for (name, bytes) in entries {
        if let Some(folder) = name.strip_suffix('/') {
            z.add_directory(folder, opts).unwrap();
        } else {
            z.start_file(*name, opts).unwrap();
            z.write_all(bytes).unwrap();
        }
    }
    z.finish().unwrap();
    (dir, path)
}

/// `check_files` of the FMU made of `entries`.
fn files_of(entries: &[(&str, &[u8])]) -> Vec<Finding> {
    let (_dir, path) = zipped(entries);
    check_files(&host::Extracted::open(&path).unwrap())
}

/// Asserts that the message of `f` contains `part`.
fn assert_says(f: &Finding, part: &str) {
    assert!(f.message.contains(part), "{f}");
}

/// The only result of the FMU made of `entries`, which must be a note of the check `check`.
fn only_note(entries: &[(&str, &[u8])], check: &str) -> Finding {
    let found = files_of(entries);
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!(found[0].check, check, "{found:#?}");
    assert!(!found[0].is_required(), "{found:#?}");
    found[0].clone()
}

#[test]
fn a_binary_for_another_platform_only_is_a_note_not_a_finding() {
    let f = only_note(&[("binaries/win64/Dummy.dll", b"MZ")], "binary-not-probed");
    assert!(f.message.contains("not probed here"), "{f}");
    assert!(f.message.contains("binaries/win64/Dummy.dll"), "{f}");
    assert!(f.clause.contains("§2.3"), "{f}");
}

#[test]
fn sources_without_binaries_are_a_note_not_a_finding() {
    let f = only_note(&[("sources/model.c", b"int x;")], "binary-not-probed");
    assert!(f.message.contains("sources/"), "{f}");
}

#[test]
fn an_empty_platform_folder_beside_another_binary_is_no_finding() {
    let entries: &[(&str, &[u8])] = &[
        ("binaries/linux64/", b""),
        ("binaries/linux32/", b""),
        ("binaries/win64/Dummy.dll", b"MZ"),
    ];
    let f = only_note(entries, "binary-not-probed");
    assert!(f.message.contains("binaries/win64/Dummy.dll"), "{f}");
}

#[test]
fn no_implementation_at_all_is_a_finding() {
    // empty folders are no implementation
    let found = files_of(&[("binaries/linux64/", b""), ("binaries/win64/", b"")]);
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!(found[0].check, "binary");
    assert!(found[0].is_required());
    assert_says(&found[0], "no other implementation");
    assert_says(&found[0], "no sources/");
    // a library in the host's folder not named after the modelIdentifier stays a finding,
    // even beside another platform's binary
    let found = files_of(&[
        ("binaries/linux64/dummy-1.so", b"\x7fELF"),
        ("binaries/win64/Dummy.dll", b"MZ"),
    ]);
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!(found[0].check, "binary");
    assert_says(&found[0], "no binary Dummy.so");
}

#[test]
fn backslash_path_separators_are_a_finding_of_their_own() {
    // APPNOTE.TXT 4.4.17.1: "All slashes MUST be forward slashes"; the binary is there, under a
    // name no importer looks for, so the finding is the separator, not a missing binary.
    let found = files_of(&[("binaries\\win64\\Dummy.dll", b"MZ")]);
    let zip_path: Vec<&Finding> = found.iter().filter(|f| f.check == "zip-path").collect();
    assert_eq!(zip_path.len(), 1, "{found:#?}");
    assert!(zip_path[0].is_required());
    assert_says(zip_path[0], "binaries\\win64\\Dummy.dll");
    assert!(zip_path[0].clause.contains("4.4.17"), "{}", zip_path[0]);
    assert!(
        found.iter().all(|f| f.check != "binary"),
        "no second finding on the binary: {found:#?}"
    );
}

/// FMI 2.0.4 section 2.3: the binary is `binaries/linux64/<modelIdentifier>.so`. A model
/// identifier that is not a C identifier (its own finding) still names the file an importer looks
/// for, so a library named otherwise is reported missing rather than passed over.
#[test]
fn a_library_not_named_after_an_invalid_model_identifier_is_reported_missing() {
    let md = common::fixture_md().replace(
        "modelIdentifier=\"Dummy\"",
        "modelIdentifier=\"water-tank\"",
    );
    let files = |name: &str| {
        let (_dir, path) = zipped_with(&md, &[(name, b"\x7fELF")]);
        check_files(&host::Extracted::open(&path).unwrap())
    };
    let found = files("binaries/linux64/watertank.so");
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!(found[0].check, "binary", "{found:#?}");
    assert_says(&found[0], "no binary water-tank.so");
    assert_eq!(files("binaries/linux64/water-tank.so"), vec![]);
}
