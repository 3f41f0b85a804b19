//! The gap workflow: calibrate, locate, screen, refit, name, repeat, report.
//!
//! Notation: `K` measured outputs, `N` samples, weighted residual `r = (y_model − y_meas) / σ_k`
//! stacked output by output (row `k N + i`). `σ_k` is the noise level of output `k` estimated from
//! the data (`stats::noise_sigma`), the marginal level of correlated noise (`noise`). Fits use the first `(1 − holdout)` of the trace; the last part
//! is held out to check that a named effect generalises.
//!
//! Model comparison uses the profile likelihood with one unknown noise variance per output and an
//! effective sample size per output that accounts for residual autocorrelation:
//! `BIC = Σ_k N_eff,k ln(RSS_k / N) + p ln(Σ_k N_eff,k)`, `N_eff,k = N (1 − ρ_k)/(1 + ρ_k)` with `ρ_k`
//! the lag-1 autocorrelation of the larger model's residual (Schwarz 1978; AR(1) variance
//! inflation). Parameter covariances use the Jacobian with the same per-output scaling:
//! rows of output `k` are multiplied by `(σ_k / s_k) √(N_eff,k / N)` where `s_k` is the residual RMS,
//! so `Cov(z) = (J̃ᵀ J̃)⁻¹` and 95 % Wald intervals follow by the delta method.

use crate::lm::{Bounded, LmOptions, Problem};
use crate::sim::{Counted, GridModel, SimError};
use crate::spec::{EffectSpec, ParamSpec};
use crate::{lm, stats};
use diagnose::diagnose;
use evidence::{bound_warnings, estimates, far_from_data_warning, offset_warnings, row_scale};
use finish::{final_fit, final_outputs, output_errors, refit_from_lower};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rough::{interval_basis, recentre, roughness_note, IntervalBasis};
use rounds::{run_rounds, RoundInputs, Rounds};
use screen::LM_ABS_TOL;
use serde::Serialize;
use setup::{setup, Setup};
use start::{calibrate_to_start, initial_state_note, start_error, still_misses_start, Calibrated};
use std::collections::BTreeMap;
use std::time::Instant;

mod calibrate;
mod diagnose;
mod disagreement;
mod ends;
mod evidence;
mod finish;
pub(crate) mod noise;
mod offsets;
mod refit;
mod rough;
mod rounds;
mod screen;
mod setup;
mod start;
mod verdict;

pub use calibrate::{Calibration, CalibrationFit};
pub use disagreement::{Disagreement, OutputDisagreement, Shape, DISAGREEMENT_RATIO};
pub(crate) use evidence::regress;
pub use verdict::visibility_scale;

/// z value of a two-sided 95 % interval.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Measured data on one time grid (SI units).
#[derive(Clone, Debug, Default)]
pub struct Data {
    pub time: Vec<f64>,
    pub inputs: Vec<(String, Vec<f64>)>,
    pub outputs: Vec<(String, Vec<f64>)>,
}

/// Options of the workflow.
#[derive(Clone, Debug)]
pub struct Config {
    /// Base parameters to calibrate (names); `None` = those tagged `[calibrate]`.
    pub fit: Option<Vec<String>>,
    /// Candidate effects to consider (names); `None` = every effect of the model.
    pub effects: Option<Vec<String>>,
    /// Maximum number of effects to add.
    pub rounds: usize,
    /// Known settings applied to every simulation and never fitted (`--set`).
    pub fixed: Vec<(String, f64)>,
    /// Fraction of the trace held out at its end.
    pub holdout: f64,
    /// How many screened candidates are refitted per round.
    pub max_refit: usize,
    /// Minimum BIC improvement to name an effect.
    pub min_delta_bic: f64,
    /// Show progress on stderr.
    pub progress: bool,
    /// Calibrate the base model over growing horizons as well as directly (`false`: the direct
    /// fit only, for before/after measurements of the continuation).
    pub calibration_horizons: bool,
    /// Restart a refit short of the naming threshold, and the best refit, from the profile of
    /// its effect's valley (`false`: off, for before/after measurements).
    pub profile_restart: bool,
    /// Print a line per stage on stderr with the elapsed time and simulation count, and every
    /// Levenberg-Marquardt iteration (for profiling).
    pub trace: bool,
    /// Measured outputs whose constant offset (a sensor zero error: measured − model) is
    /// estimated with the parameters (`--offset`).
    pub offsets: Vec<String>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            fit: None,
            effects: None,
            rounds: 2,
            fixed: Vec::new(),
            holdout: 0.3,
            max_refit: 5,
            min_delta_bic: 10.0,
            progress: false,
            calibration_horizons: true,
            profile_restart: true,
            trace: false,
            offsets: Vec::new(),
        }
    }
}

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
    /// Why it was or was not named.
    pub verdict: String,
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

/// One-sided 95 % standard normal quantile.
const Z95_ONE_SIDED: f64 = 1.644_853_626_951_472_2;

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
    fn screened_only(effect: &str, delta_bic: f64, score: f64) -> Self {
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
            verdict: "screened only (linearised ΔBIC)".into(),
            visibility: None,
            visibility_needed: 0.0,
            detectable_from: None,
            visibility_scan: Vec::new(),
            profiled: false,
            inconclusive: false,
        }
    }

    /// Marks a screened-only candidate whose linearised ΔBIC is positive yet below the naming
    /// threshold: its chi-square drop exceeds its parameters' BIC penalty (for one parameter,
    /// p ≈ 0.003 under no effect), a hint the data neither confirm nor rule out. Residuals at the
    /// noise level are not refitted, so this is how such a hint reaches the report, with the
    /// experiment that would settle it.
    fn hinted(mut self, min_delta_bic: f64) -> Self {
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
    pub verdict: String,
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

/// Errors of the workflow.
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    #[error("{0}")]
    Usage(String),
    #[error("simulation failed: {0}")]
    Simulation(#[from] SimError),
}

/// A model configuration: parameter values that are set for a simulation.
#[derive(Clone, Debug)]
struct ModelState {
    /// Named effects (indices into the effect list).
    named: Vec<usize>,
    /// Fitted parameter indices and their current values.
    idx: Vec<usize>,
    val: Vec<f64>,
}

impl ModelState {
    /// The same named effects and fitted parameters with other values (same order as `idx`).
    fn with_values(&self, val: Vec<f64>) -> ModelState {
        debug_assert_eq!(val.len(), self.idx.len());
        ModelState {
            named: self.named.clone(),
            idx: self.idx.clone(),
            val,
        }
    }

    /// The same with its base parameters (those of `st0`) at `st0`'s values, when it lists them
    /// first.
    fn with_base(&self, st0: &ModelState) -> Option<ModelState> {
        let k = st0.idx.len();
        (self.idx.len() >= k && self.idx[..k] == st0.idx[..]).then(|| {
            let mut v = self.val.clone();
            v[..k].copy_from_slice(&st0.val);
            self.with_values(v)
        })
    }
}

struct Ctx<'a, S: GridModel + ?Sized> {
    sim: Counted<'a, S>,
    params: Vec<ParamSpec>,
    effects: Vec<EffectSpec>,
    fixed: Vec<(usize, f64)>,
    out_idx: Vec<usize>,
    meas: Vec<Vec<f64>>,
    /// Per measured output: the noise level (marginal standard deviation) and the AR(1)
    /// coefficient of the noise (0: white), see `noise`.
    sigma: Vec<f64>,
    rho: Vec<f64>,
    /// Per measured output: its offset is estimated (`Config::offsets`).
    offset: Vec<bool>,
    n: usize,
    n_train: usize,
    /// ΔBIC an effect needs to be named (`Config::min_delta_bic`).
    min_delta_bic: f64,
    /// `Config::calibration_horizons`, `Config::profile_restart`, `Config::trace`.
    calibration_horizons: bool,
    profile_restart: bool,
    trace: bool,
    pb: ProgressBar,
    t0: Instant,
}

impl<S: GridModel + ?Sized> Ctx<'_, S> {
    /// Progress message; with `Config::trace` also a line on stderr with the elapsed time and
    /// the simulation count (for profiling).
    fn stage(&self, msg: String) {
        if self.trace {
            eprintln!(
                "[gap {:7.2} s, {:4} sims, {:7.2} s simulating] {msg}",
                self.t0.elapsed().as_secs_f64(),
                self.sim.count(),
                self.sim.busy_s()
            );
        }
        self.pb.set_message(msg);
    }

    fn settings(
        &self,
        st: &ModelState,
        extra_on: Option<usize>,
        extra: &[(usize, f64)],
    ) -> Vec<(usize, f64)> {
        let mut s = self.fixed.clone();
        for &e in st.named.iter().chain(extra_on.iter()) {
            s.push((self.effects[e].enabled, 1.0));
        }
        s.extend(st.idx.iter().copied().zip(st.val.iter().copied()));
        s.extend_from_slice(extra);
        s
    }

    /// The chi-square drop naming effect `e` needs on the training part: `min ΔBIC + (effect
    /// parameters) ln N_eff`, N_eff the effective samples of all outputs under the noise model
    /// (its visibility, counted in effective samples too, is measured against this).
    fn visibility_needed(&self, e: usize) -> f64 {
        let n_eff: f64 = self
            .sample_weights()
            .iter()
            .map(|w| w * self.n_train as f64)
            .sum();
        self.min_delta_bic + self.effects[e].params.len() as f64 * libm::log(n_eff.max(1.0))
    }

    /// Effective samples per sample of each measured output's noise: `(1 − ρ)/(1 + ρ)` for its
    /// AR(1) coefficient ρ (the variance of a mean of AR(1) noise over many samples), 1 for
    /// white noise.
    fn sample_weights(&self) -> Vec<f64> {
        self.rho.iter().map(|r| (1.0 - r) / (1.0 + r)).collect()
    }

    /// Simulate and return the measured outputs only, first `n` samples.
    fn measured_outputs(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        self.sim.measured(set, n, &self.out_idx)
    }

    /// Weighted residual stacked by output over samples `0..n`; an output whose offset is
    /// estimated has it removed as estimated over the fitted samples (`0..min(n, n_train)`:
    /// over the training part when a training fit is carried to the whole trace).
    fn residual(&self, y: &[Vec<f64>], n: usize) -> Vec<f64> {
        self.residual_est(y, n, n.min(self.n_train))
    }

    /// [`Ctx::residual`] with the offsets estimated over samples `0..n_est`.
    ///
    /// An offset enters linearly: with `r_i = (y_i − m_i) / σ` the least-squares offset is the
    /// mean of `r` over the fitted samples, so it is eliminated in closed form (variable
    /// projection, Golub & Pereyra 1973) and the fits, their Jacobians and the ΔBIC see the
    /// residual with its mean removed.
    fn residual_est(&self, y: &[Vec<f64>], n: usize, n_est: usize) -> Vec<f64> {
        let mut r = Vec::with_capacity(n * y.len());
        for (k, yk) in y.iter().enumerate() {
            r.extend((0..n).map(|i| (yk[i] - self.meas[k][i]) / self.sigma[k]));
        }
        self.remove_offsets(&mut r, n, n_est);
        r
    }

    /// Subtract from each offset output's block of `v` (stacked by output, `n` per output) its
    /// mean over the first `n_est` samples.
    fn remove_offsets(&self, v: &mut [f64], n: usize, n_est: usize) {
        let n_est = n_est.clamp(1, n.max(1));
        for (k, _) in self.offset.iter().enumerate().filter(|(_, on)| **on) {
            let Some(block) = v.get_mut(k * n..(k + 1) * n) else {
                continue;
            };
            let mean = block[..n_est].iter().sum::<f64>() / n_est as f64;
            block.iter_mut().for_each(|x| *x -= mean);
        }
    }

    /// The offset of output `k` (measured − model, physical units) for model outputs `y_k`,
    /// estimated over samples `0..n_est`; 0 for an output whose offset is not estimated.
    fn offset_of(&self, k: usize, y_k: &[f64], n_est: usize) -> f64 {
        if !self.offset[k] {
            return 0.0;
        }
        let n_est = n_est.clamp(1, y_k.len().max(1));
        (0..n_est).map(|i| self.meas[k][i] - y_k[i]).sum::<f64>() / n_est as f64
    }

    /// The model's measured outputs `y` as the data see them: each with its offset, estimated
    /// over samples `0..n_est`, added.
    fn with_offsets(&self, y: Vec<Vec<f64>>, n_est: usize) -> Vec<Vec<f64>> {
        y.into_iter()
            .enumerate()
            .map(|(k, yk)| {
                let b = self.offset_of(k, &yk, n_est);
                yk.into_iter().map(|v| v + b).collect()
            })
            .collect()
    }
}

struct FitProblem<'c, 'a, S: GridModel + ?Sized> {
    ctx: &'c Ctx<'a, S>,
    /// Settings that stay constant in this fit.
    base: Vec<(usize, f64)>,
    idx: Vec<usize>,
    n: usize,
}

impl<'c, 'a, S: GridModel + ?Sized> FitProblem<'c, 'a, S> {
    /// The problem a fit of `f`'s parameters over `n` samples solves: its effects on, nothing
    /// held.
    fn of(ctx: &'c Ctx<'a, S>, f: &FitOut, n: usize) -> Self {
        let effects_on = ModelState {
            named: f.state.named.clone(),
            idx: Vec::new(),
            val: Vec::new(),
        };
        FitProblem {
            ctx,
            base: ctx.settings(&effects_on, None, &[]),
            idx: f.state.idx.clone(),
            n,
        }
    }
}

impl<S: GridModel + ?Sized> Problem for FitProblem<'_, '_, S> {
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
        let mut set = self.base.clone();
        set.extend(self.idx.iter().copied().zip(p.iter().copied()));
        let y = self.ctx.measured_outputs(&set, self.n)?;
        // Offsets estimated over the samples this fit uses (the whole trace in the final fit).
        Ok(self.ctx.residual_est(&y, self.n, self.n))
    }
}

fn bounds_of(params: &[ParamSpec], idx: &[usize]) -> Vec<Bounded> {
    idx.iter()
        .map(|&i| Bounded::new(params[i].start, params[i].min, params[i].max))
        .collect()
}

fn find_param(params: &[ParamSpec], name: &str) -> Result<usize, GapError> {
    params
        .iter()
        .position(|p| p.name == name)
        .ok_or_else(|| GapError::Usage(format!("the model has no parameter named '{name}'")))
}

struct FitOut {
    state: ModelState,
    fit: lm::LmFit,
    bounds: Vec<Bounded>,
}

/// How far one fit may go: iterations, the relative stopping tolerance, and the sum of squares
/// below which it must be able to come to be worth continuing (`lm::LmOptions::futile_above`).
#[derive(Clone, Copy, Debug)]
struct Limits {
    max_iter: usize,
    rel_tol: f64,
    futile_above: Option<f64>,
    /// `lm::LmOptions::final_jacobian`.
    final_jacobian: bool,
    /// `lm::LmOptions::converged_below`.
    converged_below: Option<f64>,
}

impl Limits {
    const fn new(max_iter: usize, rel_tol: f64) -> Self {
        Limits {
            max_iter,
            rel_tol,
            futile_above: None,
            final_jacobian: true,
            converged_below: None,
        }
    }

    /// The same limits, stopping only where the remaining Gauss–Newton step predicts a decrease
    /// below `decrease` (`lm::LmOptions::converged_below`).
    const fn converged_below(self, decrease: f64) -> Self {
        Limits {
            converged_below: Some(decrease),
            ..self
        }
    }

    /// The same limits for a fit whose Jacobian is not read, or made later by
    /// [`ensure_jacobian`] only if the fit is kept.
    const fn without_final_jacobian(self) -> Self {
        Limits {
            final_jacobian: false,
            ..self
        }
    }

    /// The same limits, giving up once the sum of squares cannot come below `target`.
    fn futile_above(self, target: f64) -> Self {
        Limits {
            futile_above: Some(target),
            ..self
        }
    }
}

fn fit_state<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st: &ModelState,
    extra_on: Option<usize>,
    extra: &[(usize, f64)],
    n: usize,
    limits: Limits,
) -> Result<FitOut, SimError> {
    fit_state_holding(ctx, st, extra_on, extra, &[], n, limits)
}

/// [`fit_state`] with the settings `held` applied and kept constant (a profile fit: the base
/// parameters fitted with an effect's parameters held at given values).
fn fit_state_holding<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st: &ModelState,
    extra_on: Option<usize>,
    extra: &[(usize, f64)],
    held: &[(usize, f64)],
    n: usize,
    limits: Limits,
) -> Result<FitOut, SimError> {
    let mut idx = st.idx.clone();
    let mut p0 = st.val.clone();
    for &(i, v) in extra {
        idx.push(i);
        p0.push(v);
    }
    let empty = ModelState {
        named: st.named.clone(),
        idx: Vec::new(),
        val: Vec::new(),
    };
    let problem = FitProblem {
        ctx,
        base: ctx.settings(&empty, extra_on, held),
        idx: idx.clone(),
        n,
    };
    let bounds = bounds_of(&ctx.params, &idx);
    let opts = LmOptions {
        max_iter: limits.max_iter,
        rel_tol: limits.rel_tol,
        abs_tol: LM_ABS_TOL,
        trace: ctx.trace,
        futile_above: limits.futile_above,
        converged_below: limits.converged_below,
        final_jacobian: limits.final_jacobian,
        ..Default::default()
    };
    let fit = lm::levenberg_marquardt(&problem, &bounds, &p0, opts, &|| ctx.pb.tick())?;
    let mut named = st.named.clone();
    if let Some(e) = extra_on {
        named.push(e);
    }
    Ok(FitOut {
        state: ModelState {
            named,
            idx,
            val: fit.p.clone(),
        },
        fit,
        bounds,
    })
}

/// The finite-difference Jacobian at the optimum of `f` (a fit of `fit_state` over `n`
/// samples, effects in `f.state.named` on, nothing held) if it ended without one: the values
/// the fit would have ended with.
fn ensure_jacobian<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, f: &mut FitOut, n: usize) {
    if f.fit.jac_fresh {
        return;
    }
    let problem = FitProblem::of(ctx, f, n);
    lm::refresh_jacobian(
        &problem,
        &f.bounds,
        &mut f.fit,
        LmOptions::default().fd_step,
    );
}

/// Run the workflow on `data` with the simulator `sim`.
pub fn run<S: GridModel + ?Sized>(
    sim: &S,
    data: &Data,
    cfg: &Config,
) -> Result<GapResult, GapError> {
    let t_start = Instant::now();
    let setup = setup(sim, data, cfg)?;
    let names = setup.names.clone();
    let initial_idx = setup.initial_idx.clone();
    let convention_warnings = setup.convention_warnings.clone();
    let (ctx, st0) = context(sim, data, cfg, setup, t_start);
    let t_est = Instant::now();

    // --- The model as given.
    ctx.stage("simulating the model as given".to_string());
    let nominal = measured_part(&ctx, &simulate_all(&ctx, &st0)?);

    // --- 1. Calibrate the base model on the training part; for a record that does not begin
    // in the model's initial state, again with the initial state the FMU exposes (`start`);
    // for correlated noise, again with its marginal level (`noise`).
    let (ctx, calibrated) = calibrate_with_noise_model(ctx, st0, &initial_idx)?;
    let Calibrated {
        st0,
        fit: base,
        calibration,
        all: base_all,
        miss: start_miss0,
        initial_estimated,
        ..
    } = calibrated;
    let base_fit = measured_part(&ctx, &base_all);
    let cur_full_r = ctx.residual(&base_fit, ctx.n);
    let base_fit = ctx.with_offsets(base_fit, ctx.n_train);

    // --- 2. Locate the disagreement.
    let diagnosis0 = diagnose(&ctx, data, &base_all, &names);
    let revealing = revealing_variable(&diagnosis0, data, &names, &base_all, ctx.n);

    // --- 3./4. Screen, refit, name; repeat.
    let inputs = RoundInputs {
        cfg,
        st0: &st0,
        start_miss: start_miss0.as_ref(),
    };
    let Rounds {
        cur,
        cur_full_r,
        named,
        candidates,
        diagnosis,
        redone,
        verdict,
        unexplained,
    } = run_rounds(&ctx, &inputs, base, cur_full_r, diagnosis0, data, &names)?;
    let start_warning = match &start_miss0 {
        Some(miss) if still_misses_start(&ctx, miss, &cur_full_r) => Some(start_error(
            &ctx,
            miss,
            &initial_idx,
            &data.time,
            cfg.rounds,
        )?),
        _ => None,
    };

    // --- 5. Final fit on the whole trace and the errors before/after.
    let mut ending = finish(&ctx, data, &st0, (cur, &cur_full_r), [&nominal, &base_fit])?;
    noise::refine_after_final_fit(&mut ending.outputs, &ending.trace_outputs);
    ctx.pb.finish_and_clear();
    let est_s = t_est.elapsed().as_secs_f64();
    let initial_note = initial_estimated.map(|m| initial_state_note(&ctx, &m, &initial_idx));
    let disagreement =
        disagreement::disagreement(&data.time, &ending.trace_outputs, &ending.outputs);
    let mut warnings = run_warnings(&ctx, &ending, initial_note, start_warning);
    warnings.extend(disagreement.as_ref().map(|d| d.text.clone()));
    let timing = timing(&ctx, t_start, est_s);
    let Ending {
        parameters,
        offsets,
        outputs,
        trace_outputs,
        ..
    } = ending;
    Ok(GapResult {
        verdict: verdict_text(verdict, &named, disagreement.as_ref()),
        disagreement,
        named,
        unexplained,
        warnings,
        convention_warnings,
        candidates,
        redone_rounds: redone,
        calibration,
        parameters,
        offsets,
        outputs,
        fixed: cfg.fixed.iter().cloned().collect(),
        diagnosis,
        timing,
        holdout_fraction: ctx_holdout(cfg),
        samples: ctx.n,
        train_samples: ctx.n_train,
        traces: Traces {
            time: data.time.clone(),
            outputs: trace_outputs,
            revealing,
        },
    })
}

/// The report's warnings, in the order a reader meets them: parameters on a bound, offsets,
/// the initial state estimated, a start the final model does not reproduce, a final model
/// still far from the data, a rough sum of squares.
fn run_warnings<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    ending: &Ending,
    initial_note: Option<String>,
    start_warning: Option<String>,
) -> Vec<String> {
    let mut warnings = bound_warnings(&ending.parameters, &ctx.params);
    warnings.extend(offset_warnings(&ending.outputs));
    warnings.extend(initial_note);
    warnings.extend(start_warning);
    warnings.extend(noise::correlated_noise_note(&ending.outputs));
    warnings.extend(far_from_data_warning(&ending.outputs));
    warnings.extend(ending.roughness.map(roughness_note));
    warnings
}

/// Wall time of the run, split into simulating and the rest of the estimation (`est_s`).
fn timing<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, t_start: Instant, est_s: f64) -> Timing {
    Timing {
        total_s: t_start.elapsed().as_secs_f64(),
        simulate_s: ctx.sim.busy_s(),
        fit_s: (est_s - ctx.sim.busy_s()).max(0.0),
        simulations: ctx.sim.count(),
        threads: rayon::current_num_threads(),
    }
}

/// The base calibration ([`calibrate_to_start`]), then the noise model from its residual
/// (`noise`): where an output's noise is correlated, its level becomes the marginal one, its
/// AR(1) coefficient is carried by the statistics, and the base model is calibrated again
/// with those weights. White noise everywhere leaves the first calibration as it is.
fn calibrate_with_noise_model<'a, S: GridModel + ?Sized>(
    ctx: Ctx<'a, S>,
    st0: ModelState,
    initial_idx: &[usize],
) -> Result<(Ctx<'a, S>, Calibrated), GapError> {
    let first = calibrate_to_start(&ctx, st0.clone(), initial_idx)?;
    let r = ctx.residual(&measured_part(&ctx, &first.all), ctx.n);
    let n = ctx.n;
    let fits: Vec<noise::NoiseFit> = (0..ctx.out_idx.len())
        .map(|k| noise::noise_fit(&r[k * n..(k + 1) * n]))
        .collect();
    if fits.iter().all(|f| f.rho == 0.0) {
        return Ok((ctx, first));
    }
    let rho = fits.iter().map(|f| f.rho).collect();
    let sigma = ctx
        .sigma
        .iter()
        .zip(&fits)
        .map(|(s, f)| s * f.level)
        .collect();
    let ctx = Ctx { sigma, rho, ..ctx };
    ctx.stage("calibrating again with the correlated noise's level".to_string());
    let again = calibrate_to_start(&ctx, st0, initial_idx)?;
    Ok((ctx, again))
}

/// The fraction of the trace held out at its end (`Config::holdout`, kept within 0..0.9).
fn ctx_holdout(cfg: &Config) -> f64 {
    cfg.holdout.clamp(0.0, 0.9)
}

/// The noise level of each measured output, estimated from the data (`stats::noise_sigma`), kept
/// above 1e-4 of its range so that a noiseless output does not get an infinite weight.
fn noise_levels(meas: &[Vec<f64>]) -> Vec<f64> {
    meas.iter().map(|y| noise::difference_level(y)).collect()
}

/// A spinner on stderr when `Config::progress`, else a hidden bar.
fn progress_bar(cfg: &Config) -> ProgressBar {
    if !cfg.progress {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    pb.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
            .unwrap_or(ProgressStyle::default_spinner()),
    );
    pb
}

/// The workflow's context from the resolved setup, and the model as given (base parameters at
/// their values as given, no effect named).
fn context<'a, S: GridModel + ?Sized>(
    sim: &'a S,
    data: &Data,
    cfg: &Config,
    setup: Setup,
    t0: Instant,
) -> (Ctx<'a, S>, ModelState) {
    let Setup {
        params,
        n,
        out_idx,
        fixed,
        effects,
        fit_idx,
        fit_start,
        offset,
        ..
    } = setup;
    let meas: Vec<Vec<f64>> = data.outputs.iter().map(|(_, v)| v.clone()).collect();
    let sigma = noise_levels(&meas);
    let holdout = ctx_holdout(cfg);
    let n_train = ((n as f64) * (1.0 - holdout)).round().clamp(10.0, n as f64) as usize;
    let ctx = Ctx {
        sim: Counted::new(sim),
        params,
        effects,
        fixed,
        out_idx,
        rho: vec![0.0; meas.len()],
        meas,
        sigma,
        offset,
        n,
        n_train,
        min_delta_bic: cfg.min_delta_bic,
        calibration_horizons: cfg.calibration_horizons,
        profile_restart: cfg.profile_restart,
        trace: cfg.trace,
        pb: progress_bar(cfg),
        t0,
    };
    let st0 = ModelState {
        named: Vec::new(),
        idx: fit_idx,
        val: fit_start,
    };
    (ctx, st0)
}

/// Every model output of `st` over the whole trace.
fn simulate_all<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st: &ModelState,
) -> Result<Vec<Vec<f64>>, GapError> {
    ctx.sim
        .simulate(&ctx.settings(st, None, &[]), ctx.n)
        .map_err(GapError::Simulation)
}

/// The model outputs that are measured, in the data's order, over the whole trace.
fn measured_part<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, all: &[Vec<f64>]) -> Vec<Vec<f64>> {
    ctx.out_idx
        .iter()
        .map(|&k| all[k][..ctx.n].to_vec())
        .collect()
}

/// For the plots: the output the base fit misses most (largest RMSE over noise) with the
/// variable (an input or a model output) that organises its residual best, and that variable's
/// values (at the base fit for a model output).
fn revealing_variable(
    diagnosis: &Diagnosis,
    data: &Data,
    names: &[String],
    base_all: &[Vec<f64>],
    n: usize,
) -> Option<(usize, String, Vec<f64>)> {
    let (k, d) = diagnosis.outputs.iter().enumerate().max_by(|a, b| {
        a.1.rmse_over_noise
            .partial_cmp(&b.1.rmse_over_noise)
            .unwrap_or(std::cmp::Ordering::Equal)
    })?;
    let (name, _) = d.region_variable.as_ref()?;
    let v = data
        .inputs
        .iter()
        .find(|(s, _)| s == name)
        .map(|(_, v)| v[..n].to_vec())
        .or_else(|| {
            names
                .iter()
                .position(|s| s == name)
                .map(|j| base_all[j][..n].to_vec())
        })?;
    Some((k, name.clone(), v))
}

/// The verdict line: the rounds' own when they gave one, else what was named. While the final
/// model still disagrees with the data, it never says that nothing is missing or that the
/// residuals are noise: it says that a disagreement remains that no candidate explains.
fn verdict_text(verdict: String, named: &[String], disagreement: Option<&Disagreement>) -> String {
    let verdict = if !verdict.is_empty() {
        verdict
    } else if named.is_empty() {
        "no missing effect found".to_string()
    } else {
        format!("named {}", named.join(", "))
    };
    let Some(d) = disagreement else {
        return verdict;
    };
    let remains = disagreement::verdict_words(d);
    if verdict.contains("consistent with noise") {
        remains
    } else if let Some(rest) = verdict.strip_prefix("no missing effect found") {
        format!("{remains}{rest}")
    } else {
        format!("{verdict}; {remains}")
    }
}

/// What the final fit makes of the rounds' model.
struct Ending {
    parameters: BTreeMap<String, Estimate>,
    offsets: BTreeMap<String, Estimate>,
    outputs: BTreeMap<String, OutputErrors>,
    trace_outputs: Vec<OutputTrace>,
    roughness: Option<f64>,
}

/// The final fit `fin` moved to its smooth part's minimum where its sum is rough
/// ([`recentre`]), with the per-output scale of its intervals and their basis
/// ([`interval_basis`]), both made from its residuals before that move.
fn settle<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: FitOut,
    n_fin: usize,
) -> (FitOut, Vec<f64>, IntervalBasis) {
    let scale = row_scale(&fin.fit.residuals, ctx.out_idx.len());
    let (fin, measured) = recentre(ctx, fin, n_fin, &scale);
    let basis = interval_basis(ctx, &fin, n_fin, &scale, measured);
    (fin, scale, basis)
}

/// The final fit on the whole trace (`final_fit`) of the rounds' model (`cur`: its fit and
/// whole-trace residual), its parameters with their intervals, and the errors per output of the
/// model as given, the base fit and the final model (`before` holds the first two).
fn finish<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    data: &Data,
    st0: &ModelState,
    cur: (FitOut, &[f64]),
    before: [&[Vec<f64>]; 2],
) -> Result<Ending, GapError> {
    let (fin, n_fin) = final_fit(ctx, cur.0, cur.1, st0);
    let (fin, scale, mut basis) = settle(ctx, fin, n_fin);
    // A held fit of the profile search that found a clearly lower sum: the fit stopped in a
    // valley that is not the lowest; refitted from that point once, its intervals made anew.
    let lower = basis
        .lower
        .take()
        .and_then(|v| refit_from_lower(ctx, &fin, v, n_fin));
    let (fin, scale, basis) = match lower {
        Some(lower) => settle(ctx, lower, n_fin),
        None => (fin, scale, basis),
    };
    let data_names: Vec<String> = data.outputs.iter().map(|(s, _)| s.clone()).collect();
    let (final_y, offsets) = final_outputs(ctx, &fin, n_fin, &data_names)?;
    let parameters = estimates(
        &ctx.params,
        &fin.state.idx,
        &basis.fit,
        &fin.bounds,
        &scale,
        n_fin,
        &basis.ends,
    );
    let [nominal, base_fit] = before;
    let (outputs, trace_outputs) = output_errors(ctx, data, [nominal, base_fit, &final_y]);
    Ok(Ending {
        parameters,
        offsets,
        outputs,
        trace_outputs,
        roughness: basis.roughness,
    })
}
