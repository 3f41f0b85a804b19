//! FMI 3.0: model description, binding and Co-Simulation runs.
//!
//! - [`md`]: the typed FMI 3.0 `modelDescription.xml` and its parser.
//! - [`value`]: the FMI 3.0 types and typed value buffers with their text form.

pub mod md;
pub mod value;

pub use md::{Causality3, ModelDescription3, Variable3};
pub use value::{Type3, Values};
