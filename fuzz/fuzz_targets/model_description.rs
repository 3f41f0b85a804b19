//! The host's `modelDescription.xml` parser and the validator's description checks
//! (`host::ModelDescription::parse`, `host::validate::check_model_description`): any text gives
//! a description or an error, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(md) = host::ModelDescription::parse(text, "fuzz.xml") {
        let findings = host::validate::check_model_description(&md);
        for f in &findings {
            let _ = format!("{f:?}");
        }
        let _ = md.output_names();
        let _ = md.input_names();
        for v in &md.model_variables {
            let _ = md.effective_unit(v);
            let _ = v.effective_initial();
        }
    }
});
