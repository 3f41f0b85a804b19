//! The FMI 3.0 Co-Simulation binary of HydraulicJoint: the same model code as the FMI 2.0 FMU (the
//! `hydraulic-joint` crate, linked without its `fmi2` feature so this library exports the 75
//! `fmi3*` functions only), under the generic layer of `fmi3-export`.

fmi3_export::export_fmi3!(hydraulic_joint::HydraulicJoint);
