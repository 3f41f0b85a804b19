//! The FMI 2.0 description rules on small descriptions, each breaking one rule.

use super::{check_effect_convention, check_model_description, combination_allowed};
use crate::Finding;
use host::md::{Causality, ModelDescription, ModelExchange, Variability};

fn md_with_vars(vars: &str, structure: &str) -> ModelDescription {
    let xml = format!(
        r#"<fmiModelDescription fmiVersion="2.0" modelName="T" guid="{{g}}">
<CoSimulation modelIdentifier="T"/>
<UnitDefinitions><Unit name="m"><DisplayUnit name="mm" factor="1000"/></Unit></UnitDefinitions>
<ModelVariables>
{vars}
</ModelVariables>
<ModelStructure>{structure}</ModelStructure>
</fmiModelDescription>"#
    );
    ModelDescription::parse(&xml, "md.xml").unwrap()
}

const GOOD_VARS: &str = r#"<ScalarVariable name="y" valueReference="0" causality="output"><Real unit="m" displayUnit="mm"/></ScalarVariable>
<ScalarVariable name="p" valueReference="1" causality="parameter" variability="fixed"><Real start="1" min="0" max="2"/></ScalarVariable>
<ScalarVariable name="u" valueReference="2" causality="input"><Real start="0"/></ScalarVariable>"#;
const GOOD_STRUCT: &str = r#"<Outputs><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#;

/// The good variables with the `<ModelStructure>` content `structure`.
fn with_structure(structure: &str) -> ModelDescription {
    md_with_vars(GOOD_VARS, structure)
}

/// The good description with the variables `vars`.
fn with_vars(vars: &str) -> ModelDescription {
    md_with_vars(vars, GOOD_STRUCT)
}

/// The good description with `from` replaced by `to` in its variables.
fn replaced(from: &str, to: &str) -> ModelDescription {
    with_vars(&GOOD_VARS.replace(from, to))
}

/// The good description with `var` added after its variables.
fn with_extra(var: &str) -> ModelDescription {
    with_vars(&format!("{GOOD_VARS}\n{var}"))
}

/// Asserts that `md` has no result of the check `check`.
fn assert_no_finding(md: &ModelDescription, check: &str) {
    let found = check_model_description(md);
    assert!(!found.iter().any(|f| f.check == check), "{found:#?}");
}

fn checks(md: &ModelDescription) -> Vec<String> {
    check_model_description(md)
        .iter()
        .map(|f| f.check.clone())
        .collect()
}

fn only(md: &ModelDescription, check: &str) -> Finding {
    let all = check_model_description(md);
    assert_eq!(all.len(), 1, "expected exactly one finding, got {all:#?}");
    assert_eq!(all[0].check, check, "{all:#?}");
    all[0].clone()
}

#[test]
fn a_correct_description_has_no_findings() {
    assert_eq!(
        checks(&md_with_vars(GOOD_VARS, GOOD_STRUCT)),
        Vec::<String>::new()
    );
}

#[test]
fn the_fixture_description_has_no_findings() {
    let xml = include_str!("../../../host/tests/fixtures/modelDescription.xml");
    let md = ModelDescription::parse(xml, "md.xml").unwrap();
    assert_eq!(check_model_description(&md), vec![]);
}

#[test]
fn root_attributes() {
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.guid.clear();
    assert_eq!(only(&md, "guid").message, "guid is missing or empty");
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.fmi_version = "3.0".into();
    only(&md, "fmi-version");
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.model_name = " ".into();
    only(&md, "model-name");
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.co_simulation = None;
    only(&md, "co-simulation");
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.co_simulation.as_mut().unwrap().model_identifier = "9 bad".into();
    assert!(only(&md, "model-identifier").clause.contains("§4.3.1"));
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.model_exchange = Some(ModelExchange {
        model_identifier: "9 bad".into(),
        ..Default::default()
    });
    assert!(only(&md, "model-identifier").clause.contains("§3.3.1"));
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.co_simulation.as_mut().unwrap().can_serialize_fmu_state = true;
    only(&md, "capability-flags");
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.variable_naming_convention = Some("dotted".into());
    only(&md, "naming-convention");
    let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    md.default_experiment = Some(host::md::DefaultExperiment {
        start_time: Some(1.0),
        stop_time: Some(0.0),
        ..Default::default()
    });
    only(&md, "default-experiment");
}

#[test]
fn duplicate_names_and_value_references() {
    let f = only(&with_extra("<ScalarVariable name=\"p\" valueReference=\"9\" causality=\"local\"><Real/></ScalarVariable>"), "unique-names");
    assert!(f.message.contains("already used on line"), "{f}");
    let f = only(&with_extra("<ScalarVariable name=\"q\" valueReference=\"1\" causality=\"parameter\" variability=\"fixed\"><Real start=\"3\"/></ScalarVariable>"), "unique-value-references");
    assert!(
        f.message.contains("valueReference 1 is shared by p, q"),
        "{f}"
    );
    // A Real and a Boolean may share a number (value references are per base type),
    // and a local may alias an output.
    assert_eq!(
        checks(&with_extra("<ScalarVariable name=\"b\" valueReference=\"1\" causality=\"local\" variability=\"discrete\"><Boolean/></ScalarVariable>\n<ScalarVariable name=\"y_alias\" valueReference=\"0\"><Real/></ScalarVariable>")),
        Vec::<String>::new()
    );
}

#[test]
fn an_input_may_alias_variables_that_cannot_be_set() {
    // FMI 2.0.4 section 2.2.7 forbids aliases between two variables that can be set with
    // fmi2SetXXX; a calculated local (initial defaults to calculated) cannot be set.
    let f = with_extra(
        "<ScalarVariable name=\"u_shown\" valueReference=\"2\" causality=\"local\"><Real/></ScalarVariable>\n\
         <ScalarVariable name=\"u_pin\" valueReference=\"2\" causality=\"local\" variability=\"continuous\"><Real/></ScalarVariable>",
    );
    assert_eq!(checks(&f), Vec::<String>::new());
    // a calculated parameter aliased with a parameter (the standard's own example, b := a)
    let f = md_with_vars(
        &format!("{GOOD_VARS}\n<ScalarVariable name=\"p2\" valueReference=\"1\" causality=\"calculatedParameter\" variability=\"fixed\"><Real/></ScalarVariable>"),
        r#"<Outputs><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/><Unknown index="4"/></InitialUnknowns>"#,
    );
    assert_eq!(checks(&f), Vec::<String>::new());
    // an input and a local whose start can be set (initial exact) are two settable aliases
    let f = only(
        &with_extra("<ScalarVariable name=\"x0\" valueReference=\"2\" causality=\"local\" initial=\"exact\"><Real start=\"1\"/></ScalarVariable>"),
        "unique-value-references",
    );
    assert!(f.message.contains("can be set"), "{f}");
}

#[test]
fn causality_variability_combinations() {
    for (c, v) in [
        ("parameter", "continuous"),
        ("input", "fixed"),
        ("output", "tunable"),
        ("independent", "discrete"),
        ("calculatedParameter", "constant"),
    ] {
        let all = check_model_description(&with_extra(&format!("<ScalarVariable name=\"z\" valueReference=\"9\" causality=\"{c}\" variability=\"{v}\"><Real start=\"0\"/></ScalarVariable>")));
        assert!(
            all.iter().any(|f| f.check == "causality-variability"),
            "{c}/{v}: {all:#?}"
        );
    }
    assert!(combination_allowed(
        Causality::Output,
        Variability::Constant
    ));
    assert!(!combination_allowed(
        Causality::Input,
        Variability::Constant
    ));
}

#[test]
fn initial_not_allowed() {
    let f = only(&with_extra("<ScalarVariable name=\"z\" valueReference=\"9\" causality=\"parameter\" variability=\"fixed\" initial=\"calculated\"><Real/></ScalarVariable>"), "initial");
    assert!(f.message.contains("initial=\"calculated\""), "{f}");
    only(&with_extra("<ScalarVariable name=\"z\" valueReference=\"9\" causality=\"input\" initial=\"exact\"><Real start=\"1\"/></ScalarVariable>"), "initial");
}

#[test]
fn start_required_and_forbidden() {
    let f = only(&replaced("<Real start=\"0\"/>", "<Real/>"), "start");
    assert!(f.message.contains("required"), "{f}");
    assert!(f.location.contains("variable 'u'"), "{f}");
    let f = only(
        &replaced(
            "<Real unit=\"m\" displayUnit=\"mm\"/>",
            "<Real unit=\"m\" start=\"2\"/>",
        ),
        "start",
    );
    assert!(f.message.contains("not allowed"), "{f}");
}

#[test]
fn continuous_non_real_and_independent() {
    let f = only(&with_extra("<ScalarVariable name=\"b\" valueReference=\"9\" causality=\"local\"><Boolean/></ScalarVariable>"), "variability-type");
    assert!(
        f.message.contains("variability defaults to continuous"),
        "{f}"
    );
    only(&with_extra("<ScalarVariable name=\"t\" valueReference=\"9\" causality=\"independent\"><Real/></ScalarVariable>\n<ScalarVariable name=\"t2\" valueReference=\"10\" causality=\"independent\"><Real/></ScalarVariable>"), "independent");
}

#[test]
fn ranges() {
    let f = only(
        &replaced(
            "start=\"1\" min=\"0\" max=\"2\"",
            "start=\"3\" min=\"0\" max=\"2\"",
        ),
        "start-range",
    );
    assert_eq!(
        f.message,
        "start 3 is outside [0, 2] (the schema: \"max >= start >= min required\")"
    );
    assert!(checks(&replaced(
        "start=\"1\" min=\"0\" max=\"2\"",
        "start=\"1\" min=\"2\" max=\"0\""
    ))
    .contains(&"min-max".to_string()));
    only(
        &replaced(
            "start=\"1\" min=\"0\" max=\"2\"",
            "start=\"1\" nominal=\"0\"",
        ),
        "nominal",
    );
}

#[test]
fn units_and_display_units_must_be_declared() {
    let f = only(
        &replaced("unit=\"m\" displayUnit=\"mm\"", "unit=\"rad\""),
        "unit-declared",
    );
    assert!(f.message.contains("unit 'rad' is not defined"), "{f}");
    let f = only(
        &replaced("displayUnit=\"mm\"", "displayUnit=\"km\""),
        "display-unit-declared",
    );
    assert!(
        f.message
            .contains("'km' is not a <DisplayUnit> of unit 'm'"),
        "{f}"
    );
    only(
        &replaced(
            "<Real start=\"0\"/>",
            "<Real start=\"0\" declaredType=\"Angle\"/>",
        ),
        "declared-type",
    );
}

#[test]
fn outputs_must_match_model_structure() {
    let f = only(
        &with_structure(
            r#"<Outputs></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
        ),
        "outputs-listed",
    );
    assert!(f.message.contains("output 'y' (index 1) is missing"), "{f}");
    let all = check_model_description(&with_structure(
        r#"<Outputs><Unknown index="1"/><Unknown index="2"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
    ));
    assert!(
        all.iter().any(
            |f| f.check == "outputs-listed" && f.message.contains("'p' is listed in <Outputs>")
        ),
        "{all:#?}"
    );
    let f = only(
        &with_structure(
            r#"<Outputs><Unknown index="1" dependencies="7"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
        ),
        "model-structure",
    );
    assert!(f.message.contains("dependency 7"), "{f}");
    let all = check_model_description(&with_structure(
        r#"<Outputs><Unknown index="1"/><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
    ));
    assert!(
        all.iter()
            .any(|f| f.message.contains("lists index 1 twice")),
        "{all:#?}"
    );
    let md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
    let mut md2 = md.clone();
    md2.model_structure.present = false;
    only(&md2, "model-structure");
}

#[test]
fn effect_convention() {
    let md = ModelDescription::parse(
        include_str!("../../../host/tests/fixtures/modelDescription.xml"),
        "md.xml",
    )
    .unwrap();
    assert_eq!(check_effect_convention(&host::ModelView::from(&md)), vec![]);
    let bad = |from: &str, to: &str| {
        let xml =
            include_str!("../../../host/tests/fixtures/modelDescription.xml").replace(from, to);
        assert_ne!(
            xml,
            include_str!("../../../host/tests/fixtures/modelDescription.xml")
        );
        check_effect_convention(&host::ModelView::from(
            &ModelDescription::parse(&xml, "md.xml").unwrap(),
        ))
    };
    let f = bad(
        r#"<Real start="0.5" min="0.01" max="5" unit="N.s/m"/>"#,
        r#"<Real start="0.5" min="0.01" unit="N.s/m"/>"#,
    );
    assert_eq!(f.len(), 1);
    assert!(f[0].message.contains("finite min < max"), "{f:?}");
    let f = bad(
        r#"<Real start="0.5" min="0.01" max="5" unit="N.s/m"/>"#,
        r#"<Real start="0.5" min="0.01" max="5"/>"#,
    );
    assert_eq!(f[0].message, "an effect parameter needs a unit");
    let f = bad(r#"<Boolean start="false"/>"#, r#"<Boolean start="true"/>"#);
    assert_eq!(
        f[0].message,
        "an effect switch must start false (effect off)"
    );
    let f = bad("[calibrate] spring stiffness", "spring stiffness");
    assert!(f[0].message.contains("[calibrate]"));
    let f = bad(r#"name="damping.d""#, r#"name="dampingd""#);
    assert!(
        f[0].message.contains("no parameter 'damping.<name>'"),
        "{f:?}"
    );
}

#[test]
fn initial_unknowns_required_and_allowed() {
    let f = only(
        &with_structure(r#"<Outputs><Unknown index="1"/></Outputs>"#),
        "initial-unknowns",
    );
    assert!(f.message.contains("'y' (index 1) must be listed"), "{f}");
    let f = only(
        &with_structure(
            r#"<Outputs><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/><Unknown index="3"/></InitialUnknowns>"#,
        ),
        "initial-unknowns",
    );
    assert!(f.message.contains("'u' may not be listed"), "{f}");
}

/// FMI 2.0.4 section 2.2.8 demands the states defined through `<Derivatives>` in
/// `<InitialUnknowns>`: a variable that only a `derivative` attribute names (its derivative not in
/// `<Derivatives>`, as Co-Simulation exporters write) is not demanded, and may be listed.
#[test]
fn a_state_not_defined_through_derivatives_is_not_demanded() {
    let vars = r#"<ScalarVariable name="y" valueReference="0" causality="output"><Real/></ScalarVariable>
<ScalarVariable name="x" valueReference="1" causality="local" variability="continuous" initial="calculated"><Real/></ScalarVariable>
<ScalarVariable name="der(x)" valueReference="2" causality="local" variability="continuous" initial="calculated"><Real derivative="2"/></ScalarVariable>"#;
    let iu = |list: &str| {
        format!(
            r#"<Outputs><Unknown index="1"/></Outputs><InitialUnknowns>{list}</InitialUnknowns>"#
        )
    };
    let unlisted = md_with_vars(vars, &iu(r#"<Unknown index="1"/>"#));
    assert_no_finding(&unlisted, "initial-unknowns");
    let listed = md_with_vars(vars, &iu(r#"<Unknown index="1"/><Unknown index="2"/>"#));
    assert_no_finding(&listed, "initial-unknowns");
    // Defined through <Derivatives>, the state and its derivative are demanded.
    let defined = md_with_vars(
        vars,
        r#"<Outputs><Unknown index="1"/></Outputs><Derivatives><Unknown index="3"/></Derivatives><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
    );
    let demanded: Vec<String> = check_model_description(&defined)
        .into_iter()
        .filter(|f| f.check == "initial-unknowns")
        .map(|f| f.message)
        .collect();
    assert!(
        demanded
            .iter()
            .any(|m| m.contains("'x' (index 2) must be listed")),
        "{demanded:?}"
    );
    assert!(
        demanded
            .iter()
            .any(|m| m.contains("'der(x)' (index 3) must be listed")),
        "{demanded:?}"
    );
}

/// FMI 2.0.4 section 2.2.8: the exporting tool orders `<Outputs>` and `<Derivatives>` (the order
/// defines the output and state vectors); only `<InitialUnknowns>` is ordered by index. A repeat
/// stays a finding everywhere.
#[test]
fn only_initial_unknowns_are_ordered_by_index() {
    let vars = r#"<ScalarVariable name="y1" valueReference="0" causality="output"><Real/></ScalarVariable>
<ScalarVariable name="y2" valueReference="1" causality="output"><Real/></ScalarVariable>"#;
    let reversed = md_with_vars(
        vars,
        r#"<Outputs><Unknown index="2"/><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/><Unknown index="2"/></InitialUnknowns>"#,
    );
    assert_no_finding(&reversed, "model-structure");
    let repeated = md_with_vars(
        vars,
        r#"<Outputs><Unknown index="1"/><Unknown index="2"/><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/><Unknown index="2"/></InitialUnknowns>"#,
    );
    assert!(check_model_description(&repeated)
        .iter()
        .any(|f| f.message.contains("<Outputs> lists index 1 twice")));
    let unordered = md_with_vars(
        vars,
        r#"<Outputs><Unknown index="1"/><Unknown index="2"/></Outputs><InitialUnknowns><Unknown index="2"/><Unknown index="1"/></InitialUnknowns>"#,
    );
    assert!(check_model_description(&unordered).iter().any(|f| f
        .message
        .contains("<InitialUnknowns> must be ordered by index")));
}
