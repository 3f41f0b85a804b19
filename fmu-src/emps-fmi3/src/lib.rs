//! The FMI 3.0 binary of the EMPS model: the model crate with its `fmi2` feature off (no `fmi2*`
//! symbol) behind `fmi3-export`.

fmi3_export::export_fmi3!(emps::Emps);
