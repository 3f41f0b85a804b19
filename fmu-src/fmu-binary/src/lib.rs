//! The FMU binary of one model in one FMI version, chosen by cargo features: one model
//! (`hydraulic-joint`, `twisted-string`, `emps`, `test-oscillator`) and one version (`fmi2`: the 44
//! `fmi2*` functions of `fmi2-export`; `fmi3`: the 75 `fmi3*` functions of `fmi3-export`), e.g.
//! `cargo build --release -p fmu-binary --features hydraulic-joint,fmi3`. The model crates know
//! no FMI version; this crate is where a model meets one. Without features it exports nothing
//! (so that workspace-wide builds and tests pass), and `describe` says what is missing.

/// How many model features this build enables: one binary exports one model.
const MODELS_CHOSEN: usize = cfg!(feature = "hydraulic-joint") as usize
    + cfg!(feature = "twisted-string") as usize
    + cfg!(feature = "test-oscillator") as usize
    + cfg!(feature = "emps") as usize;
// With no feature the count is 0 and the comparison always holds: that build is the empty one.
#[allow(clippy::absurd_extreme_comparisons)]
const _: () = assert!(
    MODELS_CHOSEN <= 1,
    "fmu-binary: enable exactly one model feature (one binary exports one model)"
);

#[cfg(all(feature = "fmi2", feature = "fmi3"))]
compile_error!("fmu-binary: enable exactly one of the features fmi2 and fmi3");

/// The model this binary exports.
#[cfg(feature = "hydraulic-joint")]
pub type Exported = hydraulic_joint::HydraulicJoint;
/// The model this binary exports.
#[cfg(feature = "twisted-string")]
pub type Exported = twisted_string::TwistedString;
/// The model this binary exports.
#[cfg(feature = "test-oscillator")]
pub type Exported = test_oscillator::Oscillator;
/// The model this binary exports.
#[cfg(feature = "emps")]
pub type Exported = emps::Emps;

/// The FMI version this binary exports.
#[cfg(feature = "fmi2")]
pub const VERSION: Option<fmu_core::Version> = Some(fmu_core::Version::Fmi2);
/// The FMI version this binary exports.
#[cfg(feature = "fmi3")]
pub const VERSION: Option<fmu_core::Version> = Some(fmu_core::Version::Fmi3);
/// The FMI version this binary exports: none chosen.
#[cfg(not(any(feature = "fmi2", feature = "fmi3")))]
pub const VERSION: Option<fmu_core::Version> = None;

#[cfg(all(feature = "fmi2", feature = "model"))]
fmi2_export::export_model!(Exported);

#[cfg(all(feature = "fmi3", feature = "model"))]
fmi3_export::export_fmi3!(Exported);

/// Write the description and documentation of the chosen model in the chosen version
/// ([`fmu_core::describe_main`]); exits with status 2 when a feature is missing.
pub fn describe() {
    #[cfg(feature = "model")]
    if let Some(version) = VERSION {
        return fmu_core::describe_main::<Exported>(version);
    }
    eprintln!("describe: build fmu-binary with one model feature and one of fmi2, fmi3");
    std::process::exit(2);
}
