//! The escaping rules of the formats, from their specifications: GitHub's workflow commands
//! (percent-encoding of `%`, CR, LF, and in properties `:` and `,`), XML 1.0 character data
//! and attribute values; the sections the SARIF `helpUri` points at.

use super::clauses::help_uri;
use super::description_line;
use super::github::{data, property};
use super::junit::esc;

#[test]
fn workflow_command_values_are_percent_encoded() {
    assert_eq!(data("50% done\r\nnext: a, b"), "50%25 done%0D%0Anext: a, b");
    assert_eq!(property("dist/a,b:c%.fmu\n"), "dist/a%2Cb%3Ac%25.fmu%0A");
}

#[test]
fn xml_text_escapes_markup_and_replaces_characters_xml_forbids() {
    assert_eq!(
        esc("a<b & \"c\" 'd'>"),
        "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&gt;"
    );
    assert_eq!(esc("line\nnext\ttab"), "line&#10;next&#9;tab");
    assert_eq!(esc("nul\u{0}bell\u{7}"), "nul\u{FFFD}bell\u{FFFD}");
}

#[test]
fn help_uri_points_at_the_cited_section_or_its_document() {
    let v3 = help_uri("FMI 3.0.2 §2.4.7: ModelVariables");
    assert_eq!(
        v3.as_deref(),
        Some("https://fmi-standard.org/docs/3.0.2/#ModelVariables")
    );
    // §2.4.7.5 has no anchor of its own: the enclosing section's
    let nested = help_uri("FMI 3.0.2 §2.4.7.5, start");
    assert_eq!(nested, v3);
    let v2 = help_uri("FMI 2.0.4 §2.2.7: ScalarVariable");
    assert_eq!(
        v2.as_deref(),
        Some("https://fmi-standard.org/docs/2.0.4/#_definition_of_model_variables_modelvariables")
    );
    // a section whose source gives an explicit anchor keeps it (2_1_common_api.adoc of the
    // v2.0.4 tag: `[#GetSetCompleteFMUState]` above "Getting and Setting the Complete FMU State")
    assert_eq!(
        help_uri("FMI 2.0.4 §2.1.8: canGetAndSetFMUstate declared").as_deref(),
        Some("https://fmi-standard.org/docs/2.0.4/#GetSetCompleteFMUState")
    );
    assert_eq!(
        help_uri("FMI 2.0.4 §5: literature").as_deref(),
        Some("https://fmi-standard.org/docs/2.0.4/")
    );
    assert_eq!(
        help_uri("actuator-fmu candidate-effect convention (README)"),
        None
    );
}

#[test]
fn the_description_line_is_read_from_the_location() {
    assert_eq!(
        description_line("modelDescription.xml:19 (variable 'mu')"),
        Some(19)
    );
    assert_eq!(
        description_line("modelDescription.xml:<CoSimulation>"),
        None
    );
    assert_eq!(description_line("probe fmi3-normal-run"), None);
}
