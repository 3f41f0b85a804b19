//! The schema tables and their walk on small descriptions, each breaking one rule of the schema
//! files (or keeping to one the files allow and a reader might not expect).

use super::content::Automaton;
use super::model::{Content, Elem, Term, Ty};
use super::types::problem;
use super::{check_description_xml, fmi2, fmi3};
use crate::Finding;

const FMI2_HEAD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{1}">
  <CoSimulation modelIdentifier="M"/>"#;

/// An FMI 2.0 description: `extra` after `<CoSimulation>`, `vars` as the variables.
fn fmi2(extra: &str, vars: &str) -> String {
    format!(
        "{FMI2_HEAD}\n{extra}\n  <ModelVariables>\n{vars}\n  </ModelVariables>\n  \
         <ModelStructure/>\n</fmiModelDescription>\n"
    )
}

const FMI2_VAR: &str = r#"    <ScalarVariable name="x" valueReference="0" causality="output"><Real/></ScalarVariable>"#;

/// An FMI 3.0 description with `extra` after `<CoSimulation>` and `tail` after
/// `<ModelStructure>`.
fn fmi3(extra: &str, vars: &str, tail: &str) -> String {
    format!(
        "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"M\" instantiationToken=\"{{1}}\">\n\
         <CoSimulation modelIdentifier=\"M\"/>\n{extra}\n<ModelVariables>\n{vars}\n\
         </ModelVariables>\n<ModelStructure/>\n{tail}\n</fmiModelDescription>\n"
    )
}

const FMI3_VAR: &str = r#"<Float64 name="y" valueReference="1" causality="output"/>"#;

fn schema_findings(xml: &str) -> Vec<Finding> {
    check_description_xml(xml)
        .into_iter()
        .filter(|f| f.check == "schema")
        .collect()
}

/// The one schema finding of `xml`.
fn single(xml: &str) -> Finding {
    let mut f = schema_findings(xml);
    assert_eq!(f.len(), 1, "{f:#?}\n{xml}");
    f.remove(0)
}

/// [`single`], whose message contains each of `parts`.
fn single_saying(xml: &str, parts: &[&str]) {
    let f = single(xml);
    for part in parts {
        assert!(f.message.contains(part), "{part}: {}", f.message);
    }
}

#[test]
fn minimal_descriptions_of_both_versions_are_valid() {
    assert_eq!(check_description_xml(&fmi2("", FMI2_VAR)), vec![]);
    assert_eq!(check_description_xml(&fmi3("", FMI3_VAR, "")), vec![]);
}

#[test]
fn an_attribute_an_fmi3_annotation_does_not_have_is_found() {
    // fmi3Annotation.xsd: <Annotation> has the one attribute `type`; its content is free
    let tail = r#"<Annotations><Annotation type="com.example" version="1"><x a="1"/>text</Annotation></Annotations>"#;
    let f = single(&fmi3("", FMI3_VAR, tail));
    assert_eq!(f.message, "element <Annotation> has no attribute 'version'");
    assert_eq!(f.location, "modelDescription.xml:8 (<Annotation>)");
    assert_eq!(f.clause, "FMI 3.0.2 §2.4: schema file fmi3Annotation.xsd");
    assert!(f.is_required());
}

#[test]
fn an_element_out_of_the_schema_order_is_found() {
    // fmi3ModelDescription.xsd: DefaultExperiment comes before ModelVariables
    let xml = fmi3("", FMI3_VAR, "").replace(
        "<ModelStructure/>",
        "<DefaultExperiment stopTime=\"1\"/>\n<ModelStructure/>",
    );
    let f = single(&xml);
    assert_eq!(f.location, "modelDescription.xml:7 (<DefaultExperiment>)");
    assert!(f
        .message
        .starts_with("element <DefaultExperiment> is out of the schema's order"));
    assert!(
        f.message.ends_with("expected here: <ModelStructure>"),
        "{}",
        f.message
    );
    assert!(f.clause.ends_with("fmi3ModelDescription.xsd"));
}

#[test]
fn an_element_allowed_once_given_twice_is_found() {
    let de = r#"<DefaultExperiment stopTime="1"/>"#;
    let too_often = "<DefaultExperiment> is out of the schema's order or occurs too often";
    single_saying(
        &fmi2(&format!("{de}{de}"), FMI2_VAR),
        &[too_often, "<VendorAnnotations>"],
    );
}

#[test]
fn fmi2_allows_model_exchange_and_co_simulation_in_either_order() {
    // fmi2ModelDescription.xsd: the two interface elements sit in a sequence with maxOccurs="2"
    let me = r#"<ModelExchange modelIdentifier="M"/>"#;
    assert_eq!(schema_findings(&fmi2(me, FMI2_VAR)), vec![]);
}

#[test]
fn values_not_of_their_type_or_enumeration_are_found() {
    let cases = [
        (
            r#"causality="inputs""#,
            "attribute causality=\"inputs\" is not one of parameter",
        ),
        (
            r#"valueReference="-1""#,
            "attribute valueReference=\"-1\" is outside the range",
        ),
        (
            r#"variability="Continuous""#,
            "is not one of constant, fixed",
        ),
    ];
    for (attr, fragment) in cases {
        let var = format!(
            r#"    <ScalarVariable name="x" {attr} valueReference="0"><Real/></ScalarVariable>"#
        )
        .replacen(
            r#" valueReference="0""#,
            "",
            attr.starts_with("valueReference") as usize,
        );
        let f = single(&fmi2("", &var));
        assert!(f.message.contains(fragment), "{attr}: {}", f.message);
        assert!(f.clause.ends_with("fmi2ScalarVariable.xsd"), "{}", f.clause);
    }
    let f = single(&fmi2(
        "",
        &FMI2_VAR.replace("<Real/>", r#"<Real start="abc"/>"#),
    ));
    assert_eq!(
        f.message,
        "<Real> attribute start=\"abc\" is not an xs:double"
    );
}

#[test]
fn a_missing_required_attribute_is_found() {
    let f = single(&fmi2("", &FMI2_VAR.replace(r#" valueReference="0""#, "")));
    assert_eq!(
        f.message,
        "element <ScalarVariable> lacks the required attribute 'valueReference'"
    );
    let f = single(&fmi3("", FMI3_VAR, "").replace(r#" instantiationToken="{1}""#, ""));
    assert!(f.message.ends_with("'instantiationToken'"));
}

#[test]
fn a_missing_child_and_text_in_element_content_are_found() {
    // ModelVariables holds at least one variable (sequence, minOccurs 1)
    let f = single(&fmi2("", ""));
    assert_eq!(
        f.message,
        "element <ModelVariables> lacks a child element: expected <ScalarVariable>"
    );
    let f = single(&fmi2("", &FMI2_VAR.replace("<Real/>", "<Real/>text")));
    assert_eq!(
        f.message,
        "element <ScalarVariable> may not contain text (\"text\")"
    );
}

#[test]
fn a_child_an_element_never_has_is_named() {
    let f = single(&fmi2("", &FMI2_VAR.replace("<Real/>", "<Float64/>")));
    assert!(f
        .message
        .starts_with("element <ScalarVariable> has no child element <Float64>"));
    assert!(f.message.contains("<Real> or <Integer>"), "{}", f.message);
}

#[test]
fn tool_annotations_take_one_element_of_any_content() {
    // fmi2Annotation.xsd: <Tool> holds xs:any with minOccurs 0 (and maxOccurs 1)
    let free = r#"<VendorAnnotations><Tool name="t"><any x="1"><deep y="2"/>t</any></Tool></VendorAnnotations>"#;
    assert_eq!(schema_findings(&fmi2(free, FMI2_VAR)), vec![]);
    let two = r#"<VendorAnnotations><Tool name="t"><a/><b/></Tool></VendorAnnotations>"#;
    let no_further = "no further child element is allowed in <Tool>";
    single_saying(&fmi2(two, FMI2_VAR), &[no_further]);
}

#[test]
fn xml_namespace_declarations_and_xsi_attributes_are_allowed() {
    let xml = fmi2("", FMI2_VAR).replace(
        "<fmiModelDescription ",
        "<fmiModelDescription xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" \
         xsi:noNamespaceSchemaLocation=\"fmi2ModelDescription.xsd\" ",
    );
    assert_eq!(schema_findings(&xml), vec![]);
    let other = xml.replace("xsi:noNamespace", "other:noNamespace");
    single_saying(
        &other,
        &["has no attribute 'other:noNamespaceSchemaLocation'"],
    );
}

#[test]
fn fmi3_interface_elements_allow_further_attributes_but_type_their_own() {
    let xml = fmi3("", FMI3_VAR, "");
    let extra = xml.replace(
        "<CoSimulation modelIdentifier=\"M\"/>",
        "<CoSimulation modelIdentifier=\"M\" vendorFlag=\"x\"/>",
    );
    assert_eq!(schema_findings(&extra), vec![]);
    let bad = xml.replace(
        "<CoSimulation modelIdentifier=\"M\"/>",
        "<CoSimulation modelIdentifier=\"M\" hasEventMode=\"yes\"/>",
    );
    assert!(single(&bad).message.ends_with("is not an xs:boolean"));
}

#[test]
fn fmi3_variables_take_their_children_in_order() {
    let ok = r#"<String name="s" valueReference="2"><Dimension start="2"/><Start value="a"/><Start value="b"/><Alias name="t"/></String>"#;
    assert_eq!(schema_findings(&fmi3("", ok, "")), vec![]);
    let swapped =
        r#"<String name="s" valueReference="2"><Start value="a"/><Dimension start="2"/></String>"#;
    assert!(single(&fmi3("", swapped, ""))
        .message
        .contains("<Dimension> is out of the schema's order"));
    // an enumeration names its type (fmi3MandatorilyTypedArrayableVariable)
    let untyped = r#"<Enumeration name="e" valueReference="3"/>"#;
    assert!(single(&fmi3("", untyped, ""))
        .message
        .ends_with("'declaredType'"));
    let clock =
        r#"<Clock name="c" valueReference="4" causality="input" intervalVariability="sometimes"/>"#;
    assert!(single(&fmi3("", clock, ""))
        .message
        .contains("is not one of constant, fixed, tunable"));
}

#[test]
fn fmi3_start_values_are_lists_of_their_type() {
    let ok = r#"<UInt8 name="u" valueReference="2" start="0 255"><Dimension start="2"/></UInt8>"#;
    assert_eq!(schema_findings(&fmi3("", ok, "")), vec![]);
    let f = single(&fmi3("", &ok.replace("255", "256"), ""));
    assert!(f
        .message
        .contains("has the item \"256\", which is outside the range of xs:unsignedByte"));
}

#[test]
fn the_fmi3_version_pattern_and_the_fmi2_fixed_version_are_checked() {
    for (v, valid) in [
        ("3.0", true),
        ("3.0.2", true),
        ("3.1-beta.3", true),
        ("3.01", false),
        ("3.", false),
        ("3.0-", false),
    ] {
        let xml =
            fmi3("", FMI3_VAR, "").replace("fmiVersion=\"3.0\"", &format!("fmiVersion=\"{v}\""));
        assert_eq!(schema_findings(&xml).is_empty(), valid, "{v}");
    }
    let f = single(&fmi2("", FMI2_VAR).replace("fmiVersion=\"2.0\"", "fmiVersion=\"2.0.4\""));
    assert!(f.message.contains("differs from the fixed value \"2.0\""));
}

#[test]
fn a_structured_name_outside_the_grammar_is_a_naming_finding() {
    let xml = fmi2("", &FMI2_VAR.replace("name=\"x\"", "name=\"a..b[1\"")).replace(
        "guid=\"{1}\"",
        "guid=\"{1}\" variableNamingConvention=\"structured\"",
    );
    let f = check_description_xml(&xml);
    assert_eq!(f.len(), 1, "{f:#?}");
    assert_eq!(f[0].check, "naming-convention");
    assert_eq!(f[0].location, "modelDescription.xml:6 (variable 'a..b[1')");
    assert!(f[0].clause.starts_with("FMI 2.0.4 §2.2.9"));
    // FMI 3.0: aliases are names too
    let alias = r#"<Float64 name="y" valueReference="1"><Alias name="1y"/></Float64>"#;
    let xml = fmi3("", alias, "").replace(
        "modelName=",
        "variableNamingConvention=\"structured\" modelName=",
    );
    let f = check_description_xml(&xml);
    assert_eq!(f.len(), 1, "{f:#?}");
    assert!(f[0]
        .message
        .starts_with("\"1y\" is not a name of the structured naming convention"));
}

#[test]
fn lexical_spaces_follow_xml_schema_datatypes() {
    let valid = |ty: &Ty, v: &str| problem(ty, v).is_none();
    for v in ["1", "-1.5e-3", ".5", "1.", "INF", "-INF", "NaN", " 2 "] {
        assert!(valid(&Ty::Double, v), "{v}");
    }
    for v in ["", "inf", "+INF", "1,5", "0x10", "e5", "."] {
        assert!(!valid(&Ty::Double, v), "{v}");
    }
    let int = super::model::INT;
    assert!(valid(&int, "2147483647") && valid(&int, "-2147483648") && valid(&int, "+007"));
    assert!(!valid(&int, "2147483648") && !valid(&int, "1.0") && !valid(&int, ""));
    assert!(valid(&super::model::UINT, "-0") && !valid(&super::model::UINT, "-1"));
    for v in [
        "2016-02-29T00:00:00Z",
        "2016-05-12T10:20:30.123+01:00",
        "2016-05-12T24:00:00",
    ] {
        assert!(valid(&Ty::DateTime, v), "{v}");
    }
    for v in [
        "2015-02-29T00:00:00",
        "2016-05-12 10:20:30",
        "2016-05-12T10:20",
        "0000-01-01T00:00:00",
        "2016-05-12T10:20:30+15:00",
    ] {
        assert!(!valid(&Ty::DateTime, v), "{v}");
    }
    assert!(valid(&Ty::HexBinary, "0aFF") && !valid(&Ty::HexBinary, "0a1"));
    assert!(valid(&Ty::Boolean, "1") && !valid(&Ty::Boolean, "True"));
}

/// Every element reachable from a root, each once.
fn reachable(root: &'static Elem) -> Vec<&'static Elem> {
    fn visit(e: &'static Elem, out: &mut Vec<&'static Elem>) {
        if out.iter().any(|x| std::ptr::eq(*x, e)) {
            return;
        }
        out.push(e);
        let mut todo: Vec<&Term> = e.particle().map(|p| vec![&p.term]).unwrap_or_default();
        while let Some(t) = todo.pop() {
            match t {
                Term::Elem(c) => visit(c, out),
                Term::Seq(ps) | Term::Choice(ps) => todo.extend(ps.iter().map(|p| &p.term)),
                Term::Any => {}
            }
        }
    }
    let mut out = Vec::new();
    visit(root, &mut out);
    out
}

#[test]
fn the_tables_declare_each_attribute_once_and_every_element_the_brief_lists() {
    for (schema, count) in [(&fmi2::SCHEMA, 36), (&fmi3::SCHEMA, 57)] {
        let elems = reachable(schema.root);
        assert_eq!(elems.len(), count);
        for e in &elems {
            let names: Vec<&str> = e
                .attrs
                .iter()
                .flat_map(|g| g.iter())
                .map(|a| a.name)
                .collect();
            for (i, n) in names.iter().enumerate() {
                assert!(!names[..i].contains(n), "<{}> declares '{n}' twice", e.name);
            }
            // every content model can be compiled and started
            if let Some(p) = e.particle() {
                assert!(!Automaton::new(p).start().is_empty());
            }
            assert!(!matches!(e.content, Content::AnyType) || e.any_attribute);
        }
    }
}

#[test]
fn a_description_broken_throughout_gets_a_bounded_number_of_findings() {
    let vars: String = (0..150)
        .map(|i| format!("<ScalarVariable name=\"x{i}\" valueReference=\"{i}\" odd=\"1\"><Real/></ScalarVariable>\n"))
        .collect();
    let f = schema_findings(&fmi2("", &vars));
    assert_eq!(f.len(), super::MAX_FINDINGS + 1);
    assert_eq!(
        f[0].message,
        "element <ScalarVariable> has no attribute 'odd'"
    );
    assert_eq!(
        f[super::MAX_FINDINGS].message,
        "50 further departures from the schema are not listed"
    );
}
