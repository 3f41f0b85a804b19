//! Random FMI 3.0 call sequences on HydraulicJoint (see fmi3_common.rs for the checks): the 75
//! `fmi3*` symbols of `export_fmi3!`, exactly as an FMI 3.0 `fmu-binary` of this model exports them.
#![no_main]

fmi3_export::export_fmi3!(hydraulic_joint::HydraulicJoint);

#[path = "fmi3_common.rs"]
mod fmi3_common;

libfuzzer_sys::fuzz_target!(|input: fmi3_common::Input| {
    fmi3_common::run::<hydraulic_joint::HydraulicJoint>(&input);
});
