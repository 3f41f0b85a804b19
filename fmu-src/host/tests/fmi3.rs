//! The FMI 3.0 side of the host against the Modelica Reference-FMUs built as FMI 3.0
//! (tests/fixtures/reference-fmus-fmi3, BSD-2; see their README).

use host::fmi3::{Causality3, ModelDescription3, Type3, Values};
use host::{fmi_version_of, FmiVersion, Unpacked};
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/fixtures/reference-fmus-fmi3")
        .join(format!("{name}.fmu"))
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
