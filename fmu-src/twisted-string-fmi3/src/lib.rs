//! The FMI 3.0 Co-Simulation binary of TwistedString: the same model code as the FMI 2.0 FMU (the
//! `twisted-string` crate, linked without its `fmi2` feature so this library exports the 75
//! `fmi3*` functions only), under the generic layer of `fmi3-export`.

fmi3_export::export_fmi3!(twisted_string::TwistedString);
