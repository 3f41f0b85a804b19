//! Every threshold of the gap workflow and of `design`, each with the rule it states.
//!
//! The workflow's modules read their decisions from here; a number that only evaluates a formula
//! (a midpoint's 0.5, a guard against division by zero) stays where the formula is. How each
//! value was settled on the evaluation records is told in `examples/README.md` and in git.

// --- Statistical levels.

/// z value of a two-sided 95 % interval: every reported interval is a 95 % one.
pub const Z95: f64 = 1.959_963_984_540_054;
/// One-sided 95 % standard normal quantile: "reliably visible" means named in 95 of 100 records.
pub const Z95_ONE_SIDED: f64 = 1.644_853_626_951_472_2;

// --- Naming an effect (defaults of `Config`).

/// ΔBIC an effect needs to be named: "very strong" evidence on the Kass & Raftery scale.
pub const MIN_DELTA_BIC: f64 = 10.0;
/// Share of the trace held out at its end to check that a named effect generalises.
pub const HOLDOUT: f64 = 0.3;
/// Largest share that may be held out: the fit needs most of the record.
pub const MAX_HOLDOUT: f64 = 0.9;
/// Fewest samples a record may have: the noise and whiteness statistics need that many.
pub const MIN_SAMPLES: usize = 20;
/// Largest share of a record's rows that may be left out for a missing sample: a few dropped
/// samples are bridged by the inputs' interpolation; beyond it the fit would rest on inputs
/// nobody measured.
pub const MAX_LEFT_OUT_SHARE: f64 = 0.1;
/// Fewest training samples a fit uses, whatever the holdout.
pub const MIN_TRAIN_SAMPLES: f64 = 10.0;
/// Effects named at most (rounds of screening and refitting).
pub const ROUNDS: usize = 2;
/// Screened candidates refitted at most per round.
pub const MAX_REFIT: usize = 5;

// --- Noise and the diagnosis of a residual.

/// A residual within this multiple of its noise level (RMS) is at the noise level.
pub const NOISE_RMS_RATIO: f64 = 1.2;
/// Ljung–Box p-value above which a residual counts as white.
pub const WHITE_P: f64 = 0.01;
/// Lags of the Ljung–Box whiteness test.
pub const LJUNG_BOX_LAGS: usize = 20;
/// Time windows over which a residual's RMS is located in the diagnosis.
pub const DIAGNOSIS_WINDOWS: usize = 10;
/// Longest input lag searched for a cross-correlation with the residual, in samples.
pub const MAX_XCORR_LAG: usize = 200;
/// Quantile bins of each variable in the operating-region diagnosis.
pub const REGION_BINS: usize = 8;
/// Noise level floor, as a share of an output's range: a noiseless output gets a finite weight.
pub const MIN_NOISE_SHARE_OF_RANGE: f64 = 1e-4;
/// Smallest ρ taken as correlated noise: below it the level changes by under 13 %.
pub const MIN_RHO: f64 = 0.3;
/// Largest ρ used: nearer 1 the noise is a drift the record cannot tell from a model error.
pub const MAX_RHO: f64 = 0.99;
/// ρ above which the report says that the statistics rest on few effective samples.
pub const LOW_INFORMATION_RHO: f64 = 0.95;
/// Fewest residual samples from which an AR(1) coefficient is estimated.
pub const MIN_AR1_SAMPLES: usize = 20;
/// Differences beyond this many robust standard deviations are clipped (a switch or a jump).
pub const AR1_CLIP: f64 = 5.0;
/// ρ must exceed this many standard errors of the white-noise autocorrelation to count.
pub const AR1_SIGNIFICANCE: f64 = 4.0;
/// Two estimates of ρ agree within this many `1/√N` (three spreads of `2/√N`).
pub const AR1_AGREEMENT: f64 = 6.0;
/// A residual is noise-like within this multiple of its correlated noise's marginal level.
pub const NOISE_LIKE_RMS: f64 = 1.5;

// --- Calibration of the base model.

/// Iterations and relative stopping tolerance of a base calibration.
pub const CALIBRATION_ITERATIONS: usize = 20;
pub const CALIBRATION_REL_TOL: f64 = 1e-4;
/// Horizons of the growing-horizon calibration before the whole training part (fractions).
pub const CALIBRATION_HORIZONS: [f64; 2] = [0.25, 0.5];
/// Fewest samples a horizon of the growing-horizon calibration holds.
pub const MIN_HORIZON_SAMPLES: usize = 20;
/// Growing horizons go on only if the first is fitted within this chi-square per sample and
/// output (√2 × the noise level): their premise is a model that reproduces the trace's start.
pub const HORIZON_ANCHOR_MAX_CHI2: f64 = 2.0;

// --- The record's start.

/// Samples at the start of the record that are compared with the model's initial state.
pub const START_SAMPLES: usize = 3;
/// Standard score beyond which the record does not begin in the model's state.
pub const START_MAX_Z: f64 = 10.0;
/// A start miss must also exceed this share of the misfit over the rest of the trace (RMS):
/// the affine account of a static mismatch leaves a curvature that grows with the mismatch.
pub const START_REST_SHARE: f64 = 0.1;
/// A candidate's fit begins in the record's state when it cuts the base fit's start miss by
/// this factor (or to within [`START_MAX_Z`]).
pub const START_MISS_REDUCTION: f64 = 3.0;

// --- Screening and refitting candidates.

/// Points of the start scan along each effect's range (fractions, in fitting coordinates).
pub const SCAN_FRACTIONS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// Step of an effect parameter's sensitivity in the screening, in fitting coordinates (5 % of
/// a log parameter): the screening linearises each effect over this secant.
pub const SENSITIVITY_STEP: f64 = 0.05;
/// The best-scored candidates are promising whatever their share of the best score.
pub const ALWAYS_REFIT: usize = 2;
/// Candidates refitted per round after the first (more only where the linearised ΔBIC reaches
/// the threshold).
pub const LATER_ROUND_REFITS: usize = 2;
/// A candidate beyond those is promising only if it scores this fraction of the best score.
pub const REFIT_SCORE_FRACTION: f64 = 1.0 / 3.0;
/// An output missing by more than this many noise levels is far from the data: the
/// linearised ranking is then close to chance, so every candidate is refitted if none is named.
pub const FAR_FROM_NOISE: f64 = 10.0;
/// Iterations and relative stopping tolerance of a candidate's refit.
pub const REFIT_ITERATIONS: usize = 15;
pub const REFIT_REL_TOL: f64 = 5e-4;
/// Iterations and relative stopping tolerance of each profile fit of a profile restart.
pub const PROFILE_ITERATIONS: usize = 4;
pub const PROFILE_REL_TOL: f64 = 1e-3;
/// Iterations and relative stopping tolerance of the base re-check before naming.
pub const BASE_RECHECK_ITERATIONS: usize = 12;
pub const BASE_RECHECK_REL_TOL: f64 = 1e-4;

// --- Fits (Levenberg–Marquardt).

/// Absolute stopping floor of every fit (chi-square): a fit gaining more per step goes on.
pub const LM_ABS_TOL: f64 = 1.0;
/// How many times the Gauss–Newton predicted decrease a fit may still gain per iteration left
/// before it is futile: along a curved valley each step gains about that much again.
pub const FUTILITY_FACTOR: f64 = 2.0;
/// Forward-difference step of every Jacobian, in fitting coordinates (0.1 % of a log parameter).
pub const FD_STEP: f64 = 1e-3;
/// Accepted steps with Broyden-updated Jacobians between finite-difference ones.
pub const BROYDEN_STEPS: usize = 3;
/// Iterations before a fit may be called futile.
pub const FUTILITY_MIN_ITERATIONS: usize = 3;
/// Iterations and relative stopping tolerance of the final fit, whose values are reported.
pub const FINAL_ITERATIONS: usize = 20;
pub const FINAL_REL_TOL: f64 = 1e-5;
/// A reported fit is converged when the Gauss–Newton step predicts a smaller decrease
/// (chi-square): the step left is then within 0.07 of a 95 % half-width in every parameter.
pub const CONVERGED_DECREASE: f64 = 0.02;
/// Iterations and relative stopping tolerance of the polish of a named candidate's refit: the
/// next round compares against it, so it goes as far as the final fit's thresholds.
pub const POLISH_ITERATIONS: usize = 60;
pub const POLISH_REL_TOL: f64 = 1e-5;
/// A base parameter that ended this far from its calibration start (`ln 3`, in log
/// coordinates) has wandered: the final fit is also tried from its start.
pub const WANDERED_LOG: f64 = 1.0986;
/// The same for a parameter fitted linearly: twice its start's magnitude.
pub const WANDERED_LINEAR: f64 = 2.0;

// --- Intervals.

/// Relative eigenvalue below which a direction of the normal matrix is undetermined.
pub const EIG_REL_TOL: f64 = 1e-8;
/// A parameter with a larger squared component in the undetermined eigenspace is not estimable.
pub const NULL_COMPONENT_TOL: f64 = 1e-4;
/// Most an interval end is moved out along its profile, in multiples of the linearised one.
pub const MAX_END_WIDENING: f64 = 4.0;
/// Probes of each interval end along the sum of squares.
pub const END_PROBES: usize = 4;
/// An end moved out by more than this factor is bent (less is the interpolation's own play).
pub const BENT: f64 = 1.05;
/// Held fits of the profile search per end.
pub const MAX_HELD_FITS: usize = 4;
/// Factor by which each held fit of the profile search moves the end out.
pub const HELD_FIT_GROWTH: f64 = 4.0;
/// Iterations and relative stopping tolerance of each held fit of the profile search.
pub const HELD_FIT_ITERATIONS: usize = 5;
pub const HELD_FIT_REL_TOL: f64 = 1e-4;
/// A held fit this far below the fit's sum (chi-square) shows the fit is not the minimum.
pub const LOWER_BY: f64 = 1.0;

// --- A rough sum of squares.

/// Sign patterns probed for the roughness at each scale.
pub const ROUGHNESS_PATTERNS: usize = 4;
/// Roughness below which the usual `1.96 σ` stands: a widening under 5 % of it.
pub const NEGLIGIBLE_ROUGHNESS: f64 = 0.5 * (0.05 * Z95) * (0.05 * Z95);
/// A secant's change must reach this multiple of the roughness (a jump at most a fifth of it).
pub const SECANT_TARGET: f64 = 25.0;
/// On a rough sum a point must lie this many spreads of two smoothed sums below the fit.
pub const LOWER_SPREADS: f64 = 2.0;
/// Steps towards the smooth part's minimum, in order, as (Marquardt damping, share of the
/// step): full, shorter for a bent valley, then damped for a flat one.
pub const RECENTRE_TRIALS: [(f64, f64); 4] = [(0.0, 1.0), (0.0, 0.5), (0.0, 0.25), (1e-2, 1.0)];
/// Most Gauss–Newton steps taken on the smooth part.
pub const RECENTRE_STEPS: usize = 6;
/// The smooth part's minimum is reached when the predicted decrease is below this
/// (chi-square): the step left is within 0.2 standard errors.
pub const RECENTRE_CONVERGED: f64 = 0.05;
/// Mirrored pairs averaged for the smooth part while the jumps stay within `1.96 σ`.
pub const SMOOTHING_PAIRS: usize = 8;
/// Roughness up to which [`SMOOTHING_PAIRS`] are averaged.
pub const MILD_ROUGHNESS: f64 = 0.5 * Z95 * Z95;
/// Mirrored pairs averaged beyond [`MILD_ROUGHNESS`]: 64 points keep the smooth part's minimum
/// within a tenth of the widened half-width `(1.96 + √(2F)) σ` at any roughness `F`.
pub const ROUGH_SMOOTHING_PAIRS: usize = 32;
/// Spread of the smoothing points in standard errors: each flips its own decisions, the
/// curvature over them stays negligible.
pub const SMOOTHING_SPREAD: f64 = 0.25;
/// Largest spread of the smoothing points in fitting coordinates (10 % of a log parameter).
pub const MAX_SMOOTHING_STEP: f64 = 0.1;

// --- What the final model still misses.

/// An output whose final RMSE exceeds this many noise levels disagrees with the data.
pub const DISAGREEMENT_RATIO: f64 = 1.5;
/// An output is "far from the data" after the final fit beyond this many noise levels.
pub const FAR_FROM_DATA: f64 = 3.0;
/// Equal time windows over which a disagreement is located.
pub const DISAGREEMENT_WINDOWS: usize = 10;
/// Share of the residual's mean square a shape must explain to be suggested.
pub const MIN_EXPLAINED: f64 = 0.5;
/// A richer shape must explain this much more of the mean square than an offset.
pub const SHAPE_OVER_OFFSET: f64 = 0.1;
/// An output moves where its rate exceeds this share of its largest rate (dead-zone shape).
pub const MOVING_SHARE: f64 = 0.05;
/// A remaining error is mostly an offset when the mean's square is this share of the MSE.
pub const OFFSET_SHARE: f64 = 0.5;

// --- Experiment design.

/// Margin over the naming threshold an experiment aims for: the prediction is linear and the
/// refit is not; beyond it a larger prediction drives the rig away from its calibration.
pub const ENOUGH: f64 = 100.0;
/// Effects with at most this many parameters are evaluated at the weakest corner of their box.
pub const MAX_CORNER_PARAMS: usize = 5;
/// Halvings of the bisection that shrinks an experiment's amplitude.
pub const SHRINK_STEPS: usize = 7;
/// Periods of the proposed input signals, as fractions of the experiment's duration.
pub const PERIODS: [f64; 2] = [0.125, 1.0 / 3.0];
/// Share of the duration the input rests at its start value before the experiment begins.
pub const REST: f64 = 0.05;

// --- Effects inert where their refit would start.

/// A setting that changes the outputs by less than this chi-square (the weighted sum of squares
/// of the change over the training part) is inert: the data cannot tell it from the effect off,
/// and the sum of squares is flat in the effect's parameters there (a saturation above the
/// signal's peak, a dead zone of zero width), so a local refit started there stays there.
pub const INERT_CHI2: f64 = 1.0;
/// Values tried along each parameter's range when the scan's best setting is inert: a factor
/// under 1.6 between neighbours on a range of two decades, so a level acting between two of
/// them starts its refit within its basin.
pub const RANGE_SEARCH_POINTS: usize = 12;
/// Where the search of a range that begins at 0 starts, as a share of its upper end: a level
/// or width acts from above 0, and on a scale no linear grid of the range resolves.
pub const RANGE_SEARCH_FLOOR: f64 = 1e-3;

// --- What an explanation must explain.

/// Share of the way from the current model's misfit to the data's white noise level (in log
/// sum of squares, `Σ_k ln(RSS_k / RSS'_k) / Σ_k ln(RSS_k / (N w_k²))`, `w_k` the white level of
/// output k's second differences) that the first effect must cover to be named as the
/// explanation when the base model is far from the data (an output beyond [`FAR_FROM_NOISE`]). On a model
/// that far from its data the ΔBIC threshold is passed by any effect that bends a little of
/// a large misfit away (a delay or a position-dependent friction in place of a missing Coulomb
/// friction): ΔBIC says the effect helps, not that it is what is missing. An effect that covers
/// under a tenth of the way leaves the disagreement standing and is not named.
pub const MIN_EXPLAINED_SHARE: f64 = 0.1;
