//! The host's `modelDescription.xml` parsers and the validator's description checks
//! (`host::ModelDescription::parse`, `validate::check_model_description`; FMI 3.0:
//! `host::fmi3::ModelDescription3::parse`, array shapes; the one view of both, `host::ModelView`): any text
//! gives a description or an error, never a panic, a hang or an allocation beyond the bounds.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(md) = host::ModelDescription::parse(text, "fuzz.xml") {
        let findings = validate::check_model_description(&md);
        for f in &findings {
            let _ = format!("{f:?}");
        }
        let _ = md.output_names();
        let _ = md.input_names();
        let _ = host::ModelView::from(&md).effect_problems();
        for v in &md.model_variables {
            let _ = md.effective_unit(v);
            let _ = v.effective_initial();
        }
    }
    if let Ok(md) = host::fmi3::ModelDescription3::parse(text, "fuzz.xml") {
        for v in &md.variables {
            let _ = md.shape(v);
            let _ = v.effective_initial();
        }
        let _ = host::ModelView::from(&md).effect_problems();
        let _ = host::fmi3::unsupported(&md);
    }
});
