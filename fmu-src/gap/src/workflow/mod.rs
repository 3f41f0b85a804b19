//! The gap workflow: calibrate, locate, screen, refit, name, repeat, report.
//!
//! Notation: `K` measured outputs, `N` samples, weighted residual `r = (y_model − y_meas) / σ_k`
//! stacked output by output (row `k N + i`). `σ_k` is the noise level of output `k` estimated from
//! the data (`stats::noise_sigma`), the marginal level of correlated noise (`noise`). Fits use the
//! first `(1 − holdout)` of the trace; the last part is held out to check that a named effect
//! generalises. Every threshold is in [`crate::policy`]; the verdicts are typed (`verdict`) and
//! put into words by [`crate::report`].
//!
//! Model comparison uses the profile likelihood with one unknown noise variance per output and an
//! effective sample size per output that accounts for residual autocorrelation:
//! `BIC = Σ_k N_eff,k ln(RSS_k / N) + p ln(Σ_k N_eff,k)`, `N_eff,k = N (1 − ρ_k)/(1 + ρ_k)` with `ρ_k`
//! the lag-1 autocorrelation of the larger model's residual (Schwarz 1978; AR(1) variance
//! inflation). Parameter covariances use the Jacobian with the same per-output scaling:
//! rows of output `k` are multiplied by `(σ_k / s_k) √(N_eff,k / N)` where `s_k` is the residual RMS,
//! so `Cov(z) = (J̃ᵀ J̃)⁻¹` and 95 % Wald intervals follow by the delta method.

use crate::policy::{HOLDOUT, MAX_HOLDOUT, MAX_REFIT, MIN_DELTA_BIC, MIN_TRAIN_SAMPLES, ROUNDS};
use crate::sim::{Counted, GridModel, SimError};
use diagnose::diagnose;
use evidence::{bound_warnings, estimates, far_from_data_warning, offset_warnings, row_scale};
use finish::{final_fit, final_outputs, output_errors, refit_from_lower};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rough::{interval_basis, recentre, roughness_note, IntervalBasis};
use rounds::{run_rounds, RoundInputs, Rounds};
use setup::{setup, Setup};
use start::{calibrate_to_start, initial_state_note, start_error, still_misses_start, Calibrated};
use std::collections::BTreeMap;
use std::time::Instant;

mod calibrate;
mod diagnose;
mod disagreement;
mod ends;
mod evidence;
mod explain;
mod finish;
mod fit;
mod inert;
pub(crate) mod noise;
mod offsets;
mod refit;
mod result;
mod rough;
mod rounds;
mod screen;
mod setup;
mod start;
mod verdict;

pub use crate::report::visibility_scale;
pub use calibrate::{Calibration, CalibrationFit};
pub use disagreement::{Disagreement, OutputDisagreement, Shape};
pub(crate) use evidence::regress;
pub use result::{
    reliably_visible, Candidate, Diagnosis, Estimate, GapResult, OutputDiagnosis, OutputErrors,
    OutputTrace, Timing, Traces, VisibilityPoint,
};
pub use verdict::{
    CandidateVerdict, ClosestShortfall, LeftOpen, Reach, ScreenedHint, Shortfall, Unrevealable,
    Verdict,
};

use fit::{
    ensure_jacobian, find_param, fit_state, fit_state_holding, Ctx, FitOut, FitProblem, Limits,
    ModelState,
};

pub use crate::policy::{DISAGREEMENT_RATIO, Z95};

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
    /// Samples of the training part, when the data are several records joined with their
    /// training parts first ([`crate::records`]); `None`: the first `1 − holdout` of the trace.
    pub train_samples: Option<usize>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            fit: None,
            effects: None,
            rounds: ROUNDS,
            fixed: Vec::new(),
            holdout: HOLDOUT,
            max_refit: MAX_REFIT,
            min_delta_bic: MIN_DELTA_BIC,
            progress: false,
            calibration_horizons: true,
            profile_restart: true,
            trace: false,
            offsets: Vec::new(),
            train_samples: None,
        }
    }
}

/// Errors of the workflow.
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    /// The request, the data and the model do not fit together.
    #[error(transparent)]
    Input(#[from] InputError),
    #[error("simulation failed: {0}")]
    Simulation(#[from] SimError),
}

/// What in the request, the data or the model keeps the workflow from running, with the
/// variable it concerns.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("the data need at least two rows")]
    NoSampleInterval,
    /// More rows miss a sample than [`crate::policy::MAX_LEFT_OUT_SHARE`] allows.
    #[error(
        "{rows} of {of} rows miss a sample (an empty or NaN cell; most in column '{column}': \
         {in_column}): more than {:.0} % of a record cannot be left out",
        crate::policy::MAX_LEFT_OUT_SHARE * 100.0
    )]
    TooManyMissing {
        rows: usize,
        of: usize,
        column: String,
        in_column: usize,
    },
    /// Records fitted together must measure the same outputs.
    #[error("records fitted together must have the same output columns: the first has [{}], another [{}]", .first.join(", "), .other.join(", "))]
    RecordOutputs {
        first: Vec<String>,
        other: Vec<String>,
    },
    #[error("need at least {need} samples, got {got}")]
    TooFewSamples { got: usize, need: usize },
    #[error("the data hold no output column to compare with")]
    NoOutputColumn,
    #[error("the model has no output named '{0}'")]
    NoOutput(String),
    #[error("column '{column}' has {values} values for {times} times")]
    ColumnLength {
        column: String,
        values: usize,
        times: usize,
    },
    #[error("--offset {output}: not a measured output (the data's outputs: {})", .measured.join(", "))]
    OffsetNotMeasured {
        output: String,
        measured: Vec<String>,
    },
    #[error("the model has no parameter named '{0}'")]
    NoParameter(String),
    #[error("the model has no effect named '{0}'")]
    NoEffect(String),
    #[error("'{0}' is not a Real parameter and cannot be fitted")]
    NotReal(String),
    #[error(
        "nothing to do: no parameter to calibrate (none tagged [calibrate] at the start of its \
         description, no --fit) and no candidate effect (no Boolean parameter '<effect>.enabled' \
         with ranged Real parameters '<effect>.<name>'){}",
        parenthesised(.departures)
    )]
    NothingToDo {
        /// The FMU's departures from the candidate-effect convention.
        departures: Vec<String>,
    },
    #[error("the experiment has {got} samples: a design needs at least {need}")]
    ShortExperiment { got: usize, need: usize },
    #[error("no measured output to design for")]
    NothingToDesignFor,
    #[error("the measured outputs must match the outputs and the time grid")]
    MeasuredNoiseShape,
    #[error("a noise model from measured outputs needs the inputs that made them")]
    MeasuredNoiseWithoutInputs,
    #[error("the noise level of every measured output must be positive and finite")]
    NoiseLevel,
    #[error("input '{input}': range [{lo}, {hi}] is not a finite interval")]
    InputRange { input: String, lo: f64, hi: f64 },
    #[error("the model has no candidate effect '{effect}' (candidates: {})", .candidates.join(", "))]
    NoCandidateNamed {
        effect: String,
        candidates: Vec<String>,
    },
    #[error("the model has no candidate effect (no Boolean parameter '<effect>.enabled')")]
    NoCandidate,
    /// No input changes a measured output: each with why it is held.
    #[error("no input can be designed: {}", .held.iter().map(|(n, why)| format!("{n}: {why}")).collect::<Vec<_>>().join("; "))]
    NoDesignableInput { held: Vec<(String, String)> },
    /// The record begins away from the model's initial state and no candidate explains it;
    /// `advice` says what to do.
    #[error(
        "{miss}, and no candidate effect explains it. {advice} No effect is named from such a \
         record: it would only imitate the start."
    )]
    StartNotExplained { miss: StartMissed, advice: String },
}

/// How the calibrated base model misses the record's start: at output `output`, over the first
/// `samples` samples (to time `until_s`), by `start_ratio` noise levels on average against
/// `trace_ratio` over the whole trace.
#[derive(Clone, Debug, thiserror::Error)]
#[error(
    "the record does not begin where the model begins: over its first {samples} samples (to \
     t = {until_s} s) the calibrated base model misses '{output}' by {start_ratio:.1}× its noise \
     level on average, against {trace_ratio:.1}× over the whole trace, so this is no constant \
     offset"
)]
pub struct StartMissed {
    pub output: String,
    pub samples: usize,
    pub until_s: f64,
    pub start_ratio: f64,
    pub trace_ratio: f64,
}

/// `" (a; b)"`, or nothing for an empty list.
fn parenthesised(items: &[String]) -> String {
    if items.is_empty() {
        String::new()
    } else {
        format!(" ({})", items.join("; "))
    }
}

/// Run the workflow on `data` with the simulator `sim`.
pub fn run<S: GridModel + ?Sized>(
    sim: &S,
    data: &Data,
    cfg: &Config,
) -> Result<GapResult, GapError> {
    let t_start = Instant::now();
    let setup = setup(sim, data, cfg)?;
    let model = ModelFacts {
        names: setup.names.clone(),
        initial_idx: setup.initial_idx.clone(),
        convention_warnings: setup.convention_warnings.clone(),
    };
    let (ctx, st0) = context(sim, data, cfg, setup, t_start);
    let t_est = Instant::now();
    // The model as given.
    ctx.stage("simulating the model as given".to_string());
    let nominal = measured_part(&ctx, &simulate_all(&ctx, &st0)?);
    // 1. Calibrate the base model, with the record's initial state and noise model.
    let (ctx, base) = calibrate_base_model(ctx, st0, &model.initial_idx)?;
    let base_values = base
        .fit
        .state
        .idx
        .iter()
        .zip(&base.fit.state.val)
        .map(|(&i, &v)| (ctx.params[i].name.clone(), v))
        .collect();
    // 2. Locate the disagreement.
    let diagnosis0 = diagnose(&ctx, data, &base.all, &model.names);
    let revealing = revealing_variable(&diagnosis0, data, &model.names, &base.all, ctx.n);
    // 3./4. Screen, refit, name; repeat.
    let inputs = RoundInputs {
        cfg,
        st0: &base.st0,
        start_miss: base.start_miss.as_ref(),
    };
    let rounds = run_rounds(
        &ctx,
        &inputs,
        base.fit,
        base.residual,
        diagnosis0,
        data,
        &model.names,
    )?;
    let start_warning = start_warning(&ctx, &base.start_miss, &rounds, &model, data, cfg)?;
    // 5. Final fit on the whole trace and the errors before/after.
    let before = [nominal.as_slice(), base.outputs.as_slice()];
    let cur = (rounds.cur, rounds.cur_full_r.as_slice());
    let mut ending = finish(&ctx, data, &base.st0, cur, before)?;
    noise::refine_after_final_fit(&mut ending.outputs, &ending.trace_outputs);
    ctx.pb.finish_and_clear();
    let est_s = t_est.elapsed().as_secs_f64();
    // 6. What the final model still misses, and the warnings.
    let initial_note = base
        .initial_estimated
        .map(|m| initial_state_note(&ctx, &m, &model.initial_idx));
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
        verdict: rounds.verdict.unwrap_or_else(|| Verdict::Named {
            effects: rounds.named.clone(),
        }),
        disagreement,
        named: rounds.named,
        unexplained: rounds.unexplained,
        warnings,
        convention_warnings: model.convention_warnings,
        candidates: rounds.candidates,
        redone_rounds: rounds.redone,
        calibration: base.calibration,
        base_values,
        parameters,
        offsets,
        outputs,
        fixed: cfg.fixed.iter().cloned().collect(),
        diagnosis: rounds.diagnosis,
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

/// What the run keeps from the setup about the model: its output names, the initial-state
/// parameters it exposes, and its departures from the candidate-effect convention.
struct ModelFacts {
    names: Vec<String>,
    initial_idx: Vec<usize>,
    convention_warnings: Vec<String>,
}

/// The calibrated base model: its start state and fit, every model output at the fit, the
/// measured outputs as the data see them (offsets added) and the whole-trace weighted residual,
/// how it was calibrated, and the record's start miss.
struct Base {
    st0: ModelState,
    fit: FitOut,
    all: Vec<Vec<f64>>,
    outputs: Vec<Vec<f64>>,
    residual: Vec<f64>,
    calibration: Calibration,
    start_miss: Option<start::StartMiss>,
    initial_estimated: Option<start::StartMiss>,
}

/// Step 1: the base model calibrated on the training part; for a record that does not begin in
/// the model's initial state, again with the initial state the FMU exposes (`start`); for
/// correlated noise, again with its marginal level (`noise`).
fn calibrate_base_model<'a, S: GridModel + ?Sized>(
    ctx: Ctx<'a, S>,
    st0: ModelState,
    initial_idx: &[usize],
) -> Result<(Ctx<'a, S>, Base), GapError> {
    let (ctx, calibrated) = calibrate_with_noise_model(ctx, st0, initial_idx)?;
    let Calibrated {
        st0,
        fit,
        calibration,
        all,
        miss,
        initial_estimated,
        ..
    } = calibrated;
    let outputs = measured_part(&ctx, &all);
    let residual = ctx.residual(&outputs, ctx.n);
    let outputs = ctx.with_offsets(outputs, ctx.n_train);
    let base = Base {
        st0,
        fit,
        all,
        outputs,
        residual,
        calibration,
        start_miss: miss,
        initial_estimated,
    };
    Ok((ctx, base))
}

/// The warning (or, with candidate rounds, the error) for a record whose start the final model
/// still misses as the base fit did.
fn start_warning<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    start_miss: &Option<start::StartMiss>,
    rounds: &Rounds,
    model: &ModelFacts,
    data: &Data,
    cfg: &Config,
) -> Result<Option<String>, GapError> {
    match start_miss {
        Some(miss) if still_misses_start(ctx, miss, &rounds.cur_full_r) => Ok(Some(start_error(
            ctx,
            miss,
            &model.initial_idx,
            &data.time,
            cfg.rounds,
        )?)),
        _ => Ok(None),
    }
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
    cfg.holdout.clamp(0.0, MAX_HOLDOUT)
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
    let n_train = cfg.train_samples.map_or_else(
        || {
            ((n as f64) * (1.0 - holdout))
                .round()
                .clamp(MIN_TRAIN_SAMPLES, n as f64) as usize
        },
        |t| t.clamp(1, n),
    );
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
