//! Random FMI 2.0 call sequences on TwistedString (see fmi_common.rs for the checks).
#![no_main]

#[path = "fmi_common.rs"]
mod fmi_common;

libfuzzer_sys::fuzz_target!(|input: fmi_common::Input| {
    fmi_common::run::<twisted_string::TwistedString>(&input);
});
