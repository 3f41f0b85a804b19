//! The validator against a real FMU: the state-machine probe and the file checks on the test FMU
//! of host/tests/fixtures (compiled here), conforming, lax and with a broken FMU state.
// Host side: runs in the user's process, not inside an FMU; the FMUs' bit-determinism (the
// workspace clippy.toml) does not bind it.
#![allow(clippy::disallowed_methods)]

#[path = "../../host/tests/common/mod.rs"]
mod common;

use host::Fmu;
use std::path::PathBuf;

/// The test FMU compiled with `defines` as `name`, in a directory that lives as long as the
/// first of the pair.
fn built(name: &str, defines: &[&str]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = common::build_fmu(dir.path(), name, defines, &common::fixture_md());
    (dir, path)
}

/// The probe's results on the test FMU compiled with `defines` as `name`, every case run.
fn probed(name: &str, defines: &[&str]) -> Vec<validate::Finding> {
    let (_dir, path) = built(name, defines);
    let fmu = Fmu::open(&path).unwrap();
    validate::probe(&fmu, &mut |_| true)
}

fn dummy() -> (tempfile::TempDir, Fmu) {
    let (dir, path) = built("Dummy", &[]);
    let fmu = Fmu::open(&path).unwrap();
    (dir, fmu)
}

/// Whether a crash in a case is a finding or a note depends on the case's kind in the one
/// registry: every case the probe announces is there, the wrong calls among them as such.
#[test]
fn every_case_the_probe_announces_is_registered_with_its_kind() {
    let (_d, fmu) = dummy();
    let mut kinds = Vec::new();
    validate::probe(&fmu, &mut |s| {
        kinds.push((s.to_string(), validate::probe_case(s).map(|c| c.kind)));
        true
    });
    let legal = ["normal-run", "fmu-state"];
    for (name, kind) in kinds {
        let expected = if legal.contains(&name.as_str()) {
            validate::CaseKind::Legal
        } else {
            validate::CaseKind::WrongCall
        };
        assert_eq!(kind, Some(expected), "{name}");
    }
}

#[test]
fn probe_finds_nothing_in_a_conforming_fmu() {
    let (_d, fmu) = dummy();
    let mut steps = Vec::new();
    let f = validate::probe(&fmu, &mut |s| {
        steps.push(s.to_string());
        true
    });
    assert_eq!(f, vec![]);
    assert_eq!(
        steps,
        vec![
            "normal-run",
            "fmu-state",
            "do-step-before-init",
            "negative-step",
            "wrong-communication-point",
            "unknown-value-reference",
            "nan-input",
            "fixed-parameter-after-init",
            "wrong-type",
            "do-step-after-terminate"
        ]
    );
    let ex = host::Extracted::open(fmu.path()).unwrap();
    assert_eq!(validate::check_symbols(&ex), vec![]);
    assert_eq!(validate::check_files(&ex), vec![]);
}

#[test]
fn probe_notes_every_wrong_call_a_lax_fmu_accepts() {
    let (_dir, path) = built("Lax", &["-DLAX", "-DMISSING_SYMBOL"]);
    let fmu = Fmu::open(&path).unwrap();
    assert_eq!(fmu.missing_functions(), vec!["fmi2GetStringStatus"]);
    let f = validate::probe(&fmu, &mut |_| true);
    let locs: Vec<&str> = f.iter().map(|x| x.location.as_str()).collect();
    assert_eq!(
        locs,
        vec![
            "probe do-step-before-init",
            "probe negative-step",
            "probe wrong-communication-point",
            "probe unknown-value-reference",
            "probe nan-input",
            "probe fixed-parameter-after-init",
            "probe wrong-type",
            "probe do-step-after-terminate"
        ]
    );
    // The standard leaves the answer to a call the importer must not make (or to a NaN) to the
    // FMU: each is a note, none a finding.
    assert!(
        f.iter()
            .all(|x| x.message.contains("returned fmi2OK;") && !x.is_required()),
        "{f:#?}"
    );
    let ex = host::Extracted::open(&path).unwrap();
    let s = validate::check_symbols(&ex);
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].message, "does not export fmi2GetStringStatus");
    // skipping a case through the callback
    let f = validate::probe(&fmu, &mut |s| s != "negative-step");
    assert_eq!(f.len(), 7);
}

#[test]
fn check_files_reports_a_missing_binary() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("modelDescription.xml"),
        common::fixture_md(),
    )
    .unwrap();
    std::fs::create_dir_all(dir.path().join("binaries/win64")).unwrap();
    let ex = host::Extracted::open(dir.path()).unwrap();
    let f = validate::check_files(&ex);
    assert_eq!(f.len(), 1);
    assert!(f[0].is_required());
    assert!(
        f[0].message
            .starts_with("no binary Dummy.so and no other implementation"),
        "{}",
        f[0]
    );
    assert!(Fmu::open(dir.path())
        .err()
        .unwrap()
        .to_string()
        .contains("no binary for this platform"));
}

#[test]
fn probe_reports_a_get_fmu_state_that_gives_no_state() {
    // fmi2GetFMUstate "makes a copy of the internal FMU state and returns a pointer to this
    // copy" (FMI 2.0.4 section 2.1.8); this one returns fmi2OK and leaves the pointer NULL.
    let f = probed("NoStateGiven", &["-DNO_STATE_GIVEN"]);
    assert_eq!(f.len(), 1, "{f:#?}");
    assert_eq!(f[0].location, "probe fmu-state");
    assert!(f[0].is_required(), "{f:#?}");
    let m = &f[0].message;
    assert!(m.starts_with("fmi2GetFMUstate returned fmi2OK"), "{m}");
    assert!(m.contains("no FMU state"), "{m}");
}

#[test]
fn probe_catches_a_state_that_is_not_fully_restored() {
    let f = probed("BrokenState", &["-DBROKEN_STATE"]);
    assert_eq!(f.len(), 1, "{f:#?}");
    assert_eq!(f[0].location, "probe fmu-state");
    assert!(
        f[0].message
            .contains("after fmi2SetFMUstate the outputs differ"),
        "{f:#?}"
    );
}

#[test]
fn a_reset_failing_after_terminate_is_a_note() {
    // fmi2Reset answering fmi2Error (a vendor runtime the host lacks) is allowed for any call
    // (FMI 2.0.4 section 2.1.3); the probe says what it did not run.
    let f = probed("ResetFails", &["-DRESET_FAILS"]);
    assert_eq!(f.len(), 1, "{f:#?}");
    assert_eq!(f[0].check, "probe-reset");
    assert!(!f[0].is_required(), "{f:#?}");
    assert!(f[0].message.contains("fmi2Reset"), "{f:#?}");
    assert!(
        f[0].message.contains("the vendor runtime is not installed"),
        "{f:#?}"
    );
    assert!(f[0].message.contains("not probed"), "{f:#?}");
}

#[test]
fn a_library_this_host_lacks_is_a_note_not_a_finding() {
    // The binary links libnotthere.so, built for the link and then deleted: the FMU is not
    // defective ("should be statically linked", FMI 2.0.4 section 2.3), this host lacks it.
    let dir = tempfile::tempdir().unwrap();
    let stub = dir.path().join("notthere.c");
    std::fs::write(&stub, "int notthere_answer(void) { return 42; }\n").unwrap();
    let lib = dir.path().join("libnotthere.so");
    let status = std::process::Command::new("cc")
        .args(["-shared", "-fPIC", "-o"])
        .arg(&lib)
        .arg(&stub)
        .status()
        .unwrap();
    assert!(status.success());
    let link = [
        "-Wl,--no-as-needed".to_string(),
        format!("-L{}", dir.path().display()),
        "-lnotthere".to_string(),
    ];
    let link: Vec<&str> = link.iter().map(String::as_str).collect();
    let path = common::build_fmu(dir.path(), "Linked", &link, &common::fixture_md());
    std::fs::remove_file(&lib).unwrap();
    let ex = host::Extracted::open(&path).unwrap();
    let f = validate::check_symbols(&ex);
    assert_eq!(f.len(), 1, "{f:#?}");
    assert_eq!(f[0].check, "binary-not-probed");
    assert!(!f[0].is_required(), "{f:#?}");
    assert!(f[0].message.contains("lacks libnotthere.so"), "{f:#?}");
}
