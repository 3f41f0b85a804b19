//! What a run finds: candidates with their verdicts and visibility, estimates, diagnoses,
//! errors per output, timing, and the traces kept for the plots.

use super::calibrate::Calibration;
use super::disagreement::Disagreement;
use super::verdict::{CandidateVerdict, Reach, Verdict};
use crate::policy::Z95_ONE_SIDED;
use crate::stats;
use serde::Serialize;
use std::collections::BTreeMap;

/// Value with a 95 % interval.
#[derive(Clone, Debug, Serialize)]
pub struct Estimate {
    pub value: f64,
    pub ci_low: f64,
    pub ci_high: f64,
    pub unit: String,
    pub start: f64,
    /// "min" or "max" when the fitted value lies on that bound of the parameter's range (the fit
    /// wanted to go further), else None.
    pub at_bound: Option<String>,
}

/// One candidate effect in one round.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    pub effect: String,
    /// BIC(current model) − BIC(current model + effect) after the nonlinear refit; for a candidate
    /// that was only screened, the linearised estimate with the autocorrelation correction.
    pub delta_bic: f64,
    /// Screening statistic (ranks the candidates): linearised ΔBIC of regressing the residual on
    /// the base Jacobian plus the effect's sensitivities, every sample counted as independent.
    pub score: f64,
    pub refit: bool,
    /// Fitted effect parameters (refitted candidates only).
    pub parameters: BTreeMap<String, Estimate>,
    /// Scale `a` of the effect's contribution `y_off + a (y_on − y_off)` with its interval
    /// (fitted value 1 by construction); the interval must exclude 0 to name the effect.
    pub magnitude: Option<Estimate>,
    /// Weighted sum of squares on the held-out part: current model and with this effect.
    pub holdout_sse_without: Option<f64>,
    pub holdout_sse_with: Option<f64>,
    pub named: bool,
    /// Why it was or was not named (`report` puts it into words as `verdict`).
    #[serde(rename = "decision")]
    pub verdict: CandidateVerdict,
    /// Largest drop of the weighted sum of squares (chi-square) the effect could bring anywhere
    /// in its scanned range once the base parameters readjust (linearised; see `visibility`).
    pub visibility: Option<f64>,
    /// The drop naming needs: `min ΔBIC + (effect parameters) ln N`. A candidate whose
    /// visibility stays below it cannot be revealed by these data, whatever its true size.
    pub visibility_needed: f64,
    /// Detection limit: the weakest scanned setting of the effect's parameters whose visibility
    /// reaches `visibility_needed` (None: no scanned setting does). A true effect weaker than
    /// this is likely to go unnamed in these data.
    pub detectable_from: Option<BTreeMap<String, f64>>,
    /// The scanned settings in range order with their visibility.
    pub visibility_scan: Vec<VisibilityPoint>,
    /// The refit was restarted from the best point of the effect's profile (see
    /// `profile_restart`), which fitted better.
    pub profiled: bool,
    /// Not named, with some evidence short of the threshold (0 < ΔBIC < min ΔBIC, refitted or
    /// linearised): the data neither show the effect nor rule it out at that strength.
    pub inconclusive: bool,
    /// Share of the way from the current model's misfit to the data's white noise level that
    /// its refit covers (log sum of squares; see `policy::MIN_EXPLAINED_SHARE`); None when not
    /// refitted or when the current model is already at that level.
    pub explained_share: Option<f64>,
}

/// Whether an effect of visibility `v` (the chi-square drop it brings, linearised) is named
/// with 95 % probability when naming needs a drop of `needed`. On noisy data the drop a refit
/// reaches along the effect's direction is `(√v + Z)²` with `Z` standard normal (noncentral
/// chi-square, one degree of freedom); its 5 % quantile `(√v − 1.645)²` must reach `needed`,
/// i.e. `√v ≥ √needed + 1.645`. For `needed` 17.9 that is `v` ≥ 34.5: a visibility just at
/// what naming needs is named only half the time.
pub fn reliably_visible(v: f64, needed: f64) -> bool {
    v.max(0.0).sqrt() >= needed.max(0.0).sqrt() + Z95_ONE_SIDED
}

/// One scanned setting of a candidate's parameters.
#[derive(Clone, Debug, Serialize)]
pub struct VisibilityPoint {
    pub parameters: BTreeMap<String, f64>,
    /// Mean position of the values in their ranges (0 = min, 1 = max, in the fitting coordinate).
    pub fraction: f64,
    /// Chi-square of the change the setting makes that the base parameters cannot absorb.
    pub visibility: Option<f64>,
}

impl Candidate {
    /// Its visibility and what naming it needs (an unknown visibility as 0).
    pub fn reach(&self) -> Reach {
        Reach {
            visibility: self.visibility.unwrap_or(0.0),
            needed: self.visibility_needed,
        }
    }

    /// Whether the data can reveal this effect at all (unknown: assumed they can).
    pub fn detectable(&self) -> bool {
        self.visibility.is_none_or(|v| v >= self.visibility_needed)
    }

    /// Whether the data would reveal this effect even at the weakest setting of its range (the
    /// least visible scanned setting: a spool's lag is weakest at the top of its frequency
    /// range, not at the min of its parameters) with 95 % probability ([`reliably_visible`]);
    /// without a scan, as [`Candidate::detectable`].
    pub fn detectable_at_weakest(&self) -> bool {
        let weakest = self
            .visibility_scan
            .iter()
            .filter_map(|p| p.visibility)
            .min_by(f64::total_cmp);
        match weakest {
            Some(v) => reliably_visible(v, self.visibility_needed),
            None => self.detectable(),
        }
    }

    /// Not named, and the data show it only from a setting above the weakest of its range, or
    /// its refit was inconclusive: a weaker instance may be present unseen, or this one
    /// (`actuator-fmu design` proposes an experiment that would reveal it at its weakest).
    pub fn may_hide(&self) -> bool {
        !self.named && (!self.detectable_at_weakest() || self.inconclusive)
    }
}

impl Candidate {
    /// A candidate that was screened (linearised ΔBIC `delta_bic`) but not refitted.
    pub(super) fn screened_only(effect: &str, delta_bic: f64, score: f64) -> Self {
        Candidate {
            effect: effect.to_string(),
            delta_bic,
            score,
            refit: false,
            parameters: BTreeMap::new(),
            magnitude: None,
            holdout_sse_without: None,
            holdout_sse_with: None,
            named: false,
            verdict: CandidateVerdict::ScreenedOnly,
            visibility: None,
            visibility_needed: 0.0,
            detectable_from: None,
            visibility_scan: Vec::new(),
            profiled: false,
            inconclusive: false,
            explained_share: None,
        }
    }

    /// Marks a screened-only candidate whose linearised ΔBIC is positive yet below the naming
    /// threshold: its chi-square drop exceeds its parameters' BIC penalty (for one parameter,
    /// p ≈ 0.003 under no effect), a hint the data neither confirm nor rule out. Residuals at the
    /// noise level are not refitted, so this is how such a hint reaches the report, with the
    /// experiment that would settle it.
    pub(super) fn hinted(mut self, min_delta_bic: f64) -> Self {
        self.inconclusive = !self.refit && self.delta_bic > 0.0 && self.delta_bic < min_delta_bic;
        self
    }
}

/// Where the model and the measurement disagree, per output.
#[derive(Clone, Debug, Serialize)]
pub struct OutputDiagnosis {
    pub output: String,
    pub noise_sigma: f64,
    /// Residual RMS / noise level.
    pub rmse_over_noise: f64,
    /// Window [t0, t1] with the largest RMS residual and its RMS / noise level.
    pub worst_window: (f64, f64, f64),
    pub window_rmse_over_noise: Vec<f64>,
    pub ljung_box_p: f64,
    pub lag1_autocorr: f64,
    /// Input with the largest cross-correlation: (name, lag in samples, correlation).
    pub input_xcorr: Option<(String, usize, f64)>,
    /// Variable whose operating region best explains the residual: (name, η²).
    pub region_variable: Option<(String, f64)>,
    pub region_bins: Vec<stats::RegionBin>,
    pub text: String,
}

/// Diagnosis of one round.
#[derive(Clone, Debug, Serialize)]
pub struct Diagnosis {
    pub consistent_with_noise: bool,
    pub outputs: Vec<OutputDiagnosis>,
    pub text: String,
}

/// Errors per measured output.
#[derive(Clone, Debug, Serialize)]
pub struct OutputErrors {
    /// Model as given (start values, `--set` applied, effects off).
    pub rmse_before: f64,
    pub max_before: f64,
    /// Model after the final fit with the named effects.
    pub rmse_after: f64,
    pub max_after: f64,
    /// Base model (effects off) after calibration.
    pub rmse_base_fit: f64,
    pub max_base_fit: f64,
    /// Noise level (marginal standard deviation) and the noise's AR(1) coefficient (0: white).
    pub noise_sigma: f64,
    pub noise_ar1: f64,
    /// The white noise level no model explains: the measured output's second-difference level
    /// (robust MAD). Where `noise_sigma` is far above it, the correlated part may be noise or
    /// a model error that these statistics cannot tell apart.
    pub noise_white: f64,
    /// What the final model leaves beyond that white noise: `√max(0, RMSE_after² −
    /// noise_white²)`, the unexplained misfit if the correlated part is not noise.
    pub unexplained_rms: f64,
    /// Mean of (model − measured) after the final fit: a constant offset, such as a sensor zero
    /// error, shows here.
    pub mean_after: f64,
}

/// Timing split.
#[derive(Clone, Debug, Serialize)]
pub struct Timing {
    pub total_s: f64,
    /// Wall time during which at least one simulation was running.
    pub simulate_s: f64,
    /// Wall time of the estimation not spent simulating (linear algebra, statistics).
    pub fit_s: f64,
    pub simulations: usize,
    pub threads: usize,
}

/// Everything the report needs.
#[derive(Clone, Debug, Serialize)]
pub struct GapResult {
    pub named: Vec<String>,
    pub unexplained: Option<String>,
    /// What the rounds concluded (`report::verdict_text` puts it into words with the
    /// disagreement).
    pub verdict: Verdict,
    /// Outputs the final model still misses by more than `DISAGREEMENT_RATIO` × their noise
    /// level: where, and the simple shapes fitted to the residual.
    pub disagreement: Option<Disagreement>,
    /// Things the user should know about the fit (parameters on bounds).
    pub warnings: Vec<String>,
    /// Departures of the FMU from the candidate-effect convention, each naming its variable
    /// (a variable the convention cannot use is ignored by the workflow; this says why).
    pub convention_warnings: Vec<String>,
    pub candidates: Vec<Vec<Candidate>>,
    /// Rounds done twice because their base re-check found a better base: (round, 1-based;
    /// ΔBIC by which the base fit improved). `candidates` holds the second pass.
    pub redone_rounds: Vec<(usize, f64)>,
    /// How the base model was calibrated (direct or over growing horizons).
    pub calibration: Calibration,
    /// The calibrated base model's parameter values (initial state included when estimated).
    pub base_values: BTreeMap<String, f64>,
    pub parameters: BTreeMap<String, Estimate>,
    /// Estimated offsets (measured − model, in the output's SI unit) of the outputs given by
    /// `Config::offsets`.
    pub offsets: BTreeMap<String, Estimate>,
    pub outputs: BTreeMap<String, OutputErrors>,
    pub fixed: BTreeMap<String, f64>,
    pub diagnosis: Vec<Diagnosis>,
    pub timing: Timing,
    pub holdout_fraction: f64,
    pub samples: usize,
    pub train_samples: usize,
    #[serde(skip)]
    pub traces: Traces,
}

/// One measured output and the three models' versions of it, on the data's time grid.
#[derive(Clone, Debug, Default)]
pub struct OutputTrace {
    pub name: String,
    pub measured: Vec<f64>,
    /// The model as given (before calibration).
    pub nominal: Vec<f64>,
    /// The calibrated base model (no effect named).
    pub base_fit: Vec<f64>,
    /// The final model (base plus the named effects, refitted on the whole trace).
    pub final_fit: Vec<f64>,
}

/// Time series kept for the plots.
#[derive(Clone, Debug, Default)]
pub struct Traces {
    pub time: Vec<f64>,
    pub outputs: Vec<OutputTrace>,
    /// (output index, variable name, variable values at the base fit)
    pub revealing: Option<(usize, String, Vec<f64>)>,
}
