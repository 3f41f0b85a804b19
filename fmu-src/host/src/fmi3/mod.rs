//! FMI 3.0: model description, binding and Co-Simulation runs.
//!
//! - [`md`]: the typed FMI 3.0 `modelDescription.xml` and its parser.
//! - [`value`]: the FMI 3.0 types and typed value buffers with their text form.
//! - [`ffi`]: the C types and the function table of a binary.
//! - [`Fmu3`] / [`Instance3`]: an opened FMU (binary of this platform tuple loaded) and one
//!   Co-Simulation instance with typed get/set of every type, arrays included.
//! - [`simulate3`] / [`Simulator3`]: a whole run from start values and input columns; `events`:
//!   Co-Simulation with Event Mode, which drives the FMU's clocks.

pub(crate) mod events;
pub mod ffi;
pub(crate) mod instance;
pub mod md;
pub(crate) mod simulate;
pub mod value;

pub use crate::simulate::{simulate as simulate3, simulate_then as simulate3_then};
pub use instance::{
    clocks_in_co_simulation, unsupported, ClocksInCs, Fmu3, Instance3, StepOutcome, PLATFORM_TUPLE,
};
pub use md::{Causality3, ModelDescription3, Variable3};
pub use simulate::{element_index, Inputs3, Request3, Simulator3};
pub use value::{Type3, ValueError, Values};
