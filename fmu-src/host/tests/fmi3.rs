//! The FMI 3.0 side of the host against the toy FMUs of tests/fixtures/toy-fmus built as FMI 3.0
//! (plain C models behind their own FMI 3.0 frame), compiled here with gcc into a directory
//! laid out as an extracted FMU.
// Host side: runs in the user's process, not inside an FMU; the FMUs' bit-determinism (the
// workspace clippy.toml) does not bind it.
#![allow(clippy::disallowed_methods)]

use host::fmi3::{Causality3, ModelDescription3, Type3, Values};
use host::{fmi_version_of, FmiVersion, Unpacked};
use std::path::PathBuf;
use std::process::Command;
use std::sync::Mutex;

/// The C source of each toy model.
const SOURCES: [(&str, &str); 6] = [
    ("Dahlquist", "dahlquist.c"),
    ("VanDerPol", "van_der_pol.c"),
    ("Stair", "stair.c"),
    ("Resource", "resource.c"),
    ("StateSpace", "state_space.c"),
    ("Clocks", "clocks.c"),
];

/// The directory of the toy model `name` built as FMI 3.0 (modelDescription.xml and
/// binaries/x86_64-linux/<name>.so) under Cargo's temporary directory for integration tests,
/// compiled the first time this process asks for it.
fn fixture(name: &str) -> PathBuf {
    static BUILT: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/toy-fmus");
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("toy-fmus")
        .join(name);
    let mut built = BUILT.lock().unwrap();
    if built.iter().any(|b| b == name) {
        return dir;
    }
    let (_, source) = SOURCES.iter().find(|(n, _)| *n == name).unwrap();
    let bin = dir.join("binaries/x86_64-linux");
    std::fs::create_dir_all(&bin).unwrap();
    let status = Command::new("gcc")
        .args([
            "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-O2",
        ])
        .arg("-DFMI3")
        .arg("-o")
        .arg(bin.join(format!("{name}.so")))
        .arg(src.join(source))
        .arg("-lm")
        .status()
        .expect("gcc is needed to build the toy FMUs");
    assert!(status.success(), "gcc failed on {source}");
    std::fs::copy(
        src.join(format!("{name}.fmi3.xml")),
        dir.join("modelDescription.xml"),
    )
    .unwrap();
    built.push(name.to_string());
    dir
}

fn description(name: &str) -> ModelDescription3 {
    let u = Unpacked::open(fixture(name)).unwrap();
    ModelDescription3::parse(&u.xml, &u.description_file()).unwrap()
}

#[test]
fn every_fixture_is_read_as_fmi3_with_its_interfaces() {
    for name in [
        "Dahlquist",
        "VanDerPol",
        "Stair",
        "Resource",
        "StateSpace",
        "Clocks",
    ] {
        assert_eq!(fmi_version_of(&fixture(name)).unwrap(), FmiVersion::Fmi3);
        let md = description(name);
        assert!(md.fmi_version.starts_with("3."), "{name}");
        assert!(!md.instantiation_token.is_empty(), "{name}");
        let cs_me = md.co_simulation.is_some() && md.model_exchange.is_some();
        assert_eq!(cs_me, name != "Clocks", "{name}");
        assert_eq!(md.scheduled_execution.is_some(), name == "Clocks", "{name}");
    }
}

#[test]
fn state_space_arrays_take_their_size_from_structural_parameters() {
    let md = description("StateSpace");
    let m = md.variable("m").unwrap();
    assert_eq!(
        (m.ty, m.causality, m.start.clone()),
        (
            Type3::UInt64,
            Causality3::StructuralParameter,
            Some(Values::UInt64(vec![3]))
        )
    );
    let a = md.variable("A").unwrap();
    assert_eq!(md.shape(a).unwrap(), vec![3, 3]);
    assert_eq!(md.shape(md.variable("u").unwrap()).unwrap(), vec![3]);
    assert_eq!(md.variable("der(x)").unwrap().derivative, Some(11));
    assert_eq!(md.model_structure.outputs[0].value_reference, 10);
}

#[test]
fn clocks_are_read_with_their_interval_variability() {
    let md = description("Clocks");
    let c = md.variable("inClock3").unwrap();
    assert_eq!(c.ty, Type3::Clock);
    assert_eq!(c.interval_variability.as_deref(), Some("countdown"));
    assert_eq!(
        md.variable("totalInClockTicks").unwrap().clocks,
        vec![1001, 1002, 1003]
    );
}

#[test]
fn dahlquist_co_simulation_follows_the_closed_form() {
    // der(x) = -k x from x(0) = 1, here with k = 2: x(t) = exp(-2 t) (the FMU steps with the
    // closed form, so only rounding separates them)
    let fmu = host::fmi3::Fmu3::open(fixture("Dahlquist")).unwrap();
    let req = host::fmi3::Request3 {
        start_values: vec![("k".into(), "2".into())],
        ..host::fmi3::Request3::new(0.0, 1.0, 0.1)
    };
    let res = host::fmi3::simulate3(&fmu, &req).unwrap();
    let x = res.column("x").unwrap();
    assert_eq!(x.len(), 11);
    for (n, xn) in x.iter().enumerate() {
        let expected = (-2.0 * res.time[n]).exp();
        assert!(
            (xn - expected).abs() < 1e-12,
            "x[{n}] = {xn}, expected {expected}"
        );
    }
    // the same driver again after fmi3Reset gives the same bits
    let mut sim = host::fmi3::Simulator3::new(&fmu).unwrap();
    let first = sim.run(&req).unwrap();
    let again = sim.run(&req).unwrap();
    assert_eq!(first.column("x"), again.column("x"));
    assert_eq!(first.column("x"), Some(x));
}

#[test]
fn stair_ends_the_run_at_its_last_successful_time() {
    let fmu = host::fmi3::Fmu3::open(fixture("Stair")).unwrap();
    let res = host::fmi3::simulate3(&fmu, &host::fmi3::Request3::new(0.0, 10.0, 0.5)).unwrap();
    assert_eq!(res.ended_by_fmu, Some(9.0));
    assert_eq!(res.time.last(), Some(&9.0));
    assert_eq!(res.column("counter").unwrap().last(), Some(&10.0));
}

#[test]
fn typed_calls_move_arrays_and_report_the_fmus_refusals() {
    let fmu = host::fmi3::Fmu3::open(fixture("StateSpace")).unwrap();
    let mut inst = fmu.instantiate("t").unwrap();
    // u (vr 9) is a 3-element input: set before initialization, read back
    inst.set(&[9], &Values::Float64(vec![0.5, -1.0, 2.0]))
        .unwrap();
    assert_eq!(
        inst.get(Type3::Float64, &[9], 3).unwrap(),
        Values::Float64(vec![0.5, -1.0, 2.0])
    );
    // m (vr 1) is UInt64; n_values too small for the array is refused by the FMU, not a crash
    assert_eq!(
        inst.get(Type3::UInt64, &[1], 1).unwrap(),
        Values::UInt64(vec![3])
    );
    let e = inst.get(Type3::Float64, &[4], 2).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("fmi3GetFloat64 returned fmi3Error"),
        "{e}"
    );
}

#[test]
fn the_version_is_read_from_the_description_alone_and_others_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let md = dir.path().join("modelDescription.xml");
    for (text, want) in [
        (
            "<fmiModelDescription fmiVersion=\"2.0\"/>",
            Some(FmiVersion::Fmi2),
        ),
        (
            "<fmiModelDescription fmiVersion='3.0-rc.1'/>",
            Some(FmiVersion::Fmi3),
        ),
        ("<fmiModelDescription fmiVersion=\"1.0\"/>", None),
        ("<fmiModelDescription/>", None),
    ] {
        std::fs::write(&md, text).unwrap();
        match (fmi_version_of(dir.path()), want) {
            (Ok(v), Some(w)) => assert_eq!(v, w, "{text}"),
            (Err(e), None) => assert!(e.to_string().contains("is not supported"), "{e}"),
            (got, _) => panic!("{text}: {:?}", got.map_err(|e| e.to_string())),
        }
    }
    std::fs::remove_file(&md).unwrap();
    let e = fmi_version_of(dir.path()).unwrap_err().to_string();
    assert!(e.contains("no modelDescription.xml"), "{e}");
    let not_zip = dir.path().join("x.fmu");
    std::fs::write(&not_zip, b"not a zip").unwrap();
    let e = fmi_version_of(&not_zip).unwrap_err().to_string();
    assert!(e.contains("not a zip archive"), "{e}");
}
