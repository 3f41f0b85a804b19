//! The gap workflow: find where a model (an FMI 2.0 co-simulation FMU following the
//! effect convention) and a measurement disagree, name the missing effect, add it, and show the
//! gap shrink.
//!
//! The method is written against the [`GridModel`] trait so it can be tested on synthetic models
//! (`synthetic.rs`); [`fmu::FmuSimulator`] adapts an FMU opened by the `host` crate to it, and the
//! CLI's `gap` subcommand wires CSV, FMU, workflow and report together.
//!
//! Steps ([`workflow::run`]):
//! 1. Noise level per output from the data's second differences (robust MAD), the weights
//!    `1/σ_k`. The last 30 % of the trace is held out. Where the calibrated base residual shows
//!    correlated (AR(1)) noise, the level becomes the marginal one, the base model is calibrated
//!    again with it, and the start test and the whiteness test carry the correlation
//!    ([`workflow`]'s `noise` module).
//! 2. Calibration of the base parameters (`[calibrate]` tag or `--fit`) by a bounded
//!    Levenberg–Marquardt ([`lm`]) with a parallel finite-difference Jacobian and Broyden updates;
//!    bounds by an active set (a parameter whose step would leave its range is held at the bound
//!    and the step re-solved for the others), stopping only when a step gains less than both a
//!    fraction of the sum and one unit of chi-square. The calibration runs directly over the
//!    training part and, where the model reproduces its first quarter to within √2 × the noise,
//!    over growing horizons (the first quarter, half, then all, each fit starting from the
//!    previous one's values), keeping the lower sum: for a trajectory whose phase is sensitive to
//!    the parameters (a loop near its stability limit) a long horizon's cost has many local
//!    minima that a short one does not.
//!    A base fit that misses the record's first samples by more than 10 standard scores means
//!    the record does not begin in the model's initial state: the base model is calibrated
//!    again with the parameters tagged `[initial]` (the state the model begins in), if the FMU
//!    has any. A miss beyond a constant offset, beyond what the misfit elsewhere predicts at the
//!    start's measured values and beyond a tenth of that misfit, that remains lets an effect be
//!    named only if its fit begins in the record's state, and if none does (counted under the
//!    noise model of the final residual), the run stops with what to do ([`workflow`]'s
//!    `start` module).
//! 3. Diagnosis of the residual: RMS/noise per output and per time window, Ljung–Box whiteness,
//!    cross-correlation with the inputs, and the operating region (quantile bins of every input
//!    and model output, η²) that organises it best.
//! 4. Start scan of every candidate (its parameters at their start values and at 0, ¼, ½, ¾ and 1
//!    of their ranges, scored after the linearised readjustment of the base parameters, and also
//!    simulated with the base parameters as given: a strong effect the base fit could not
//!    imitate leaves the fitted base values, and their linearisation, far off), then
//!    screening by a score-type regression of the residual on the base Jacobian plus the effect's
//!    switch-on change and parameter sensitivities at that start (linearised ΔBIC). The same
//!    scan gives each candidate's visibility: at every scanned setting, the chi-square of the
//!    change it makes to the outputs that the base Jacobian cannot absorb. Below the naming
//!    threshold everywhere in range, the data cannot reveal the effect, and the verdict says so.
//! 5. Refit of the most promising candidates (rayon; round 1 the best five unless the residuals
//!    look like noise) from their scanned starts with base and effect parameters; ranking by
//!    BIC with per-output noise variances and an effective sample size from the residual
//!    autocorrelation (Bartlett-weighted), so correlated noise is not taken as evidence. A refit
//!    that falls short of the evidence, although the scan says the data could show the effect
//!    and it predicts the held-out end no worse (within √(2 N_h) of chi-square), is restarted
//!    from its profile: the base parameters fitted with the effect held at each revealing scanned
//!    setting, the best refitted in full (the base fit may have bent a base parameter to imitate
//!    the effect, a stiffer spring for a growing string radius, and a local descent from there
//!    lowers the effect instead of unbending it). The best refit is restarted so too when it
//!    reaches the threshold: where a refit along such a valley stops turns on the last bits of
//!    the data, and the named estimate must not. Before
//!    naming, the base model is refitted from the best candidate's base values, so a gain the base
//!    model reaches alone is not credited to the effect; when that re-check improves the base fit
//!    by ΔBIC ≥ 10 and no candidate still reaches the threshold against it, the round is done
//!    once more from the better base (the refits started from a worse one).
//!    An effect is named only if ΔBIC ≥ 10, the 95 % interval of its contribution's scale excludes
//!    0, and it lowers the error on the held-out part. If what remains is not yet noise and a
//!    round follows, its fit is polished and the loop repeats (`rounds`); otherwise the final fit
//!    does the polishing. In a later round whose residuals are not white noise, when the two
//!    refitted candidates reach nothing, the others are refitted too (a named friction can
//!    mimic most of a strand hysteresis, and the linearisation about it misjudges the rest).
//!    Once the residuals are noise, the candidates left are screened against the final model
//!    (a last round): their visibility there is what the data show beyond the named effects.
//! 6. Final fit: the chosen model (base plus named effects) is refitted on the whole trace; its
//!    parameters and intervals are the reported ones, its errors the "after" column. The 95 %
//!    intervals are linearised (from secants, widened by the jumps' spread, when the sum of
//!    squares is rough), then each end is checked against the sum itself along the first-order
//!    path of its profile and, where the valley is flat or bends or a parameter sits on a bound,
//!    by fits with the parameter held at the end; every interval also holds each point such a held fit reached below the 95 %
//!    level (`workflow`'s `rough` and `ends` modules). A held fit that lands clearly below the
//!    fit's sum (by a chi-square unit; on a rough sum, below on its smooth part as well, by
//!    twice the spread of two smoothed sums) shows the fit stopped in a valley that is not the
//!    lowest: the final fit starts again from there, once, and its intervals are made anew.
//! 7. Report ([`report`]: `report.json`, `report.md`) and plots ([`plots`]). Outputs the final
//!    model still misses by more than 1.5 × their noise level (or 1.2 × with a residual that is
//!    not white) are a disagreement no candidate explains: the report says where (outputs, time
//!    windows) and which simple shape the residual fits against the simulated output (offset,
//!    gain, lag, dead zone), and the verdict never calls such residuals noise
//!    ([`workflow`]'s `disagreement` module).
//!
//! For a candidate the data cannot reveal at its weakest setting, or whose refit was inconclusive
//! (0 < ΔBIC < 10), [`design`] proposes an experiment (an input signal
//! within the inputs' ranges) under which it would show at the weakest setting of its range.

pub mod design;
pub mod fmu;
pub mod lm;
pub mod plots;
pub mod report;
pub mod sim;
pub mod spec;
pub mod stats;
pub mod workflow;

pub use sim::GridModel;
pub use spec::{EffectSpec, ParamKind, ParamSpec};
pub use workflow::{run, Config, Data, GapError, GapResult};

#[cfg(test)]
mod synthetic;
