//! The FMI 3.0 C layer over `fmu-core`: Co-Simulation and (for a model with `ModelExchange`)
//! Model Exchange.
//!
//! [`export_fmi3!`] emits all 75 `fmi3*` functions for a model type; each converts pointers
//! (the FMI 3.0 C types are `fmi_types::c3`) and calls the version-neutral
//! [`fmu_core::Instance`] with its [`calls`] entry (its name and the states FMI 3.0 allows it
//! in). This layer adds what only FMI 3.0 has: `time` as the independent variable and the
//! event indicators as variables in the getters. Everything else (state machine, variables,
//! steps, FMU states, descriptions) is `fmu-core`'s.

pub mod calls;
mod export;
pub mod ffi;
pub mod me;
pub mod states;

pub use fmi_types;
pub use fmu_core;

#[cfg(test)]
mod tests {
    use fmu_core::{documentation, Version};
    use test_oscillator::Oscillator;

    #[test]
    fn the_documentation_names_fmi3_not_fmi2_as_its_interface() {
        let html = documentation::<Oscillator>(Version::Fmi3);
        assert!(html.contains(
            "<p>FMI 3.0 Model Exchange (2 continuous states, 0 event indicators) and Co-Simulation"
        ));
        assert!(!html.contains(", GUID <code>"));
        assert_eq!(html.matches("<h1>").count(), 1);
    }
}
