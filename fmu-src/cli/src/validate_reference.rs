//! The `--reference` options of `validate`: which references, the tube's size; the check itself
//! is `validate::reference`.

use crate::common::CliError;
use std::path::{Path, PathBuf};
use validate::reference::{check_reference, Request, Tolerances};
use validate::Finding;

/// `--reference[=FILE]`, `--reference-inputs FILE` and the tube's tolerances.
#[derive(clap::Args)]
pub struct ReferenceArgs {
    /// Simulate the FMU's FMI-LS-REF experiments (Stimuli and References of each
    /// <Experiment>, or a <Related role="result"> CSV: the DefaultExperiment without inputs)
    /// and compare every reference column naming a variable; with `=FILE`, the reference CSV
    /// FILE instead (time first), run over its span.
    #[arg(long, value_name = "FILE", num_args = 0..=1, require_equals = true)]
    pub reference: Option<Option<PathBuf>>,
    /// Stimuli CSV for `--reference=FILE` (time first, columns named as inputs).
    #[arg(long, value_name = "FILE", requires = "reference")]
    pub reference_inputs: Option<PathBuf>,
    /// Tube half height relative to each reference signal's range (max - min).
    #[arg(long, value_name = "REL", default_value_t = Tolerances::default().rel)]
    pub reference_rtol: f64,
    /// Tube half height added, in each signal's unit.
    #[arg(long, value_name = "ABS", default_value_t = Tolerances::default().abs)]
    pub reference_atol: f64,
    /// Tube half width relative to the reference's time span.
    #[arg(long, value_name = "REL", default_value_t = Tolerances::default().time)]
    pub reference_ttol: f64,
}

impl ReferenceArgs {
    /// The reference results of the FMU at `path` (nothing without `--reference`).
    pub fn check(&self, path: &Path) -> Result<Vec<Finding>, CliError> {
        let Some(file) = &self.reference else {
            return Ok(Vec::new());
        };
        let tolerances = Tolerances {
            rel: self.reference_rtol,
            abs: self.reference_atol,
            time: self.reference_ttol,
        };
        for (name, x) in [
            ("--reference-rtol", tolerances.rel),
            ("--reference-atol", tolerances.abs),
            ("--reference-ttol", tolerances.time),
        ] {
            if !(x >= 0.0 && x.is_finite()) {
                return Err(CliError::input(format!(
                    "{name} must be a number >= 0, got {x}"
                )));
            }
        }
        let req = Request {
            file: file.clone(),
            inputs: self.reference_inputs.clone(),
            tolerances,
        };
        check_reference(path, &req).map_err(CliError::input)
    }
}
