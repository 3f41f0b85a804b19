//! The start of the record: an FMU begins in the state its parameters give (at rest, for most
//! models), and a record that begins mid-motion makes every later comparison wrong: the fit
//! bends base parameters, and a candidate effect may imitate the mismatch (a current limit
//! holding back a motor that the record shows already turning).
//!
//! Where the FMU exposes its initial state (Real parameters tagged `[initial]`, see
//! `effects`) and the base fit misses the record's start, the base model is
//! calibrated again with those parameters, so that it begins where the record does
//! ([`calibrate_to_start`]; a record from rest is fitted without them). Either way, the base
//! fit's start is then checked ([`start_disagreement`]). A model may miss the start for a good
//! reason: an effect that moves the state it rests in (a leak shifting the pressures at rest,
//! friction holding a loaded string). So while the start disagrees, a candidate is named only
//! if its fit begins in the record's state ([`reproduces_start`]), and a run whose model still
//! misses the start after the rounds stops with a message saying what to do ([`start_error`]).
//!
//! The test ([`start_misses`], [`concentrated_at_start`]): at the first samples, model and record
//! begin from their initial states and neither has had time to show a missing effect's dynamics; a
//! record that began mid-motion is missed there by the whole difference of states. Per output, the
//! mean weighted residual over the first [`START_SAMPLES`] samples, and the same less the mean over
//! the whole trace (so that a constant output offset, such as a sensor zero error, which is
//! reported as such, does not count): the smaller of the two, as a standard score under the noise
//! (× √m for white noise; for correlated noise divided by the standard deviation of a mean of m
//! AR(1) samples, [`noise::mean_variance_factor`]), must exceed [`START_MAX_Z`] = 10 standard
//! deviations, beyond noise and beyond what a parameter error leaves in the first samples. A third
//! miss is counted too, the start mean less what the misfit over the rest of the trace predicts at
//! the start's measured values ([`affine_prediction`], a line in the measured output): a
//! disagreement that runs through the whole record as a function of the measured output (a sensor
//! gain error, a fixed length set wrong) misses the start by what it misses the same values by
//! elsewhere, and is reported as a disagreement that remains, never as a record begun elsewhere;
//! and the miss must exceed [`START_REST_SHARE`] of the misfit over the rest of the trace as
//! well, which the line only approximates. A record begun in motion is missed at the start where
//! it is met with the same measured values later at the rest's misfit. Whether to estimate the
//! initial state an FMU exposes is decided on the start mean alone ([`StartMiss::z_raw`]): an
//! angle the record begins at stays as a constant offset over the whole trace. (The standard
//! scores measured on records from rest and begun in motion are in `examples/README.md`.)
//!
//! Dropping a settling window instead would not do: an angle (any integrated state) keeps the
//! difference it began with for ever, and the fit bends to it over the whole trace.

use super::calibrate::calibrate_base;
use super::noise;
use super::{Calibration, Ctx, FitOut, GapError, InputError, ModelState, StartMissed};
use crate::policy::{START_MAX_Z, START_MISS_REDUCTION, START_REST_SHARE, START_SAMPLES};
use crate::sim::GridModel;
use crate::spec::ParamSpec;
use crate::stats;

/// Most names listed in the message (it stays one bounded line).
const MAX_NAMES: usize = 5;

/// How the base fit misses the first samples of one output ([`start_misses`]).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct StartMiss {
    /// Index of the output among the measured ones.
    pub(super) output: usize,
    /// Mean weighted residual over the first samples and over the whole trace (noise levels).
    pub(super) start_mean: f64,
    pub(super) trace_mean: f64,
    /// Standard score of the start miss beyond the trace's constant offset and beyond what the
    /// misfit elsewhere predicts at the start's measured values (the smallest of the start
    /// mean and its differences from the trace mean and from that prediction, × √m for white
    /// noise).
    pub(super) z: f64,
    /// Standard score of the start miss itself (start mean × √m).
    pub(super) z_raw: f64,
    /// `z` in units of the spread of the model's misfit over the rest of the trace where that
    /// exceeds the noise level: a model that still misses an effect by 20 noise levels up and
    /// down says nothing particular about the start by missing it by 8.
    pub(super) z_rel: f64,
    /// Root mean square of the weighted residual over the rest of the trace (noise levels).
    pub(super) rest_rms: f64,
    /// The start miss `z` counts, in noise levels (`|z|` × the standard deviation of the
    /// start's mean).
    pub(super) excess: f64,
}

/// How the model misses the first `m` samples of each output (`r`: weighted residual stacked
/// by output, `k` outputs of `n` samples each, `rho`: each output's noise AR(1) coefficient,
/// `meas`: the measured outputs, empty where not at hand); empty for a trace too short to tell.
fn start_misses(
    r: &[f64],
    k: usize,
    n: usize,
    m: usize,
    rho: &[f64],
    meas: &[Vec<f64>],
) -> Vec<StartMiss> {
    let m = m.min(n / 4);
    if m == 0 {
        return Vec::new();
    }
    (0..k)
        .map(|j| {
            let rj = &r[j * n..(j + 1) * n];
            let start_mean = rj[..m].iter().sum::<f64>() / m as f64;
            let trace_mean = rj.iter().sum::<f64>() / n as f64;
            // The spread of the model's misfit over the rest of the trace (a constant miss, an
            // offset, does not widen it), for `z_rel`.
            let rest = &rj[m..];
            let rest_mean = rest.iter().sum::<f64>() / rest.len().max(1) as f64;
            let spread = (rest
                .iter()
                .map(|x| crate::stats::sq(x - rest_mean))
                .sum::<f64>()
                / rest.len().max(1) as f64)
                .sqrt();
            // What the misfit over the rest of the trace predicts for the start, where it
            // follows the measured output (a sensor gain error, a fixed length set wrong).
            let follows = meas
                .get(j)
                .filter(|y| y.len() >= n)
                .map_or(trace_mean, |y| affine_prediction(rest, &y[m..n], &y[..m]));
            // The smallest of the three misses: a start that agrees, one that only shares the
            // trace's offset, or one its misfit elsewhere predicts, is no start miss.
            // Standard deviation of a mean of m noise samples: 1/√m for white noise.
            let sd_mean = (noise::mean_variance_factor(rho.get(j).copied().unwrap_or(0.0), m)
                / m as f64)
                .sqrt();
            let excess = start_mean
                .abs()
                .min((start_mean - trace_mean).abs())
                .min((start_mean - follows).abs());
            let z = start_mean.signum() * excess / sd_mean;
            StartMiss {
                output: j,
                start_mean,
                trace_mean,
                z,
                z_raw: start_mean / sd_mean,
                z_rel: z / spread.max(1.0),
                rest_rms: stats::rms(rest),
                excess,
            }
        })
        .collect()
}

/// The mean over the start of the least-squares line `a + b y` through the misfit `rest` at the
/// measured values `y_rest`, at the start's measured values `y_start`: a misfit that is a
/// linear function of the measured output (a gain and a zero error of the sensor, and to first
/// order any static mismatch of that output) predicts the start's; a record begun in another
/// state does not (the model misses it there, where elsewhere the same measured values are
/// met with the misfit of the rest). The plain mean of `rest` where `y_rest` does not vary.
fn affine_prediction(rest: &[f64], y_rest: &[f64], y_start: &[f64]) -> f64 {
    let len = rest.len().max(1) as f64;
    let r_mean = rest.iter().sum::<f64>() / len;
    let y_mean = y_rest.iter().sum::<f64>() / len;
    let (sxy, sxx) = rest
        .iter()
        .zip(y_rest)
        .fold((0.0, 0.0), |(sxy, sxx), (r, y)| {
            (
                sxy + (y - y_mean) * (r - r_mean),
                sxx + stats::sq(y - y_mean),
            )
        });
    if sxx <= 0.0 || y_start.is_empty() {
        return r_mean;
    }
    let y0 = y_start.iter().sum::<f64>() / y_start.len() as f64;
    r_mean + sxy / sxx * (y0 - y_mean)
}

/// The base calibration as the rest of the workflow starts from it ([`calibrate_to_start`]).
pub(super) struct Calibrated {
    /// The parameters fitted, at their values as given (with the initial-state parameters when
    /// they were estimated).
    pub(super) st0: ModelState,
    pub(super) fit: FitOut,
    pub(super) calibration: Calibration,
    /// Every model output of the fit over the whole trace.
    pub(super) all: Vec<Vec<f64>>,
    /// The fit's start miss beyond [`START_MAX_Z`] (None: it begins in the record's state).
    pub(super) miss: Option<StartMiss>,
    /// The same counting a constant offset too ([`StartMiss::z_raw`]): for an FMU that exposes
    /// its initial state, an angle the record begins at looks like an offset the whole trace
    /// keeps, and its initial-state parameter is the first explanation to try.
    pub(super) raw_miss: Option<StartMiss>,
    /// The start miss of the fit without the initial state, when that made the workflow
    /// estimate it.
    pub(super) initial_estimated: Option<StartMiss>,
}

/// Calibrates the base model from `st0` and checks its start; when the record does not begin
/// in the model's initial state and the FMU exposes initial-state parameters (`initial`),
/// calibrates again from the values as given with them added, so that the model begins where
/// the record does. A record from rest is fitted without them: the extra freedom is given
/// only where the record needs it.
pub(super) fn calibrate_to_start<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st0: ModelState,
    initial: &[usize],
) -> Result<Calibrated, GapError> {
    let first = calibrate_and_check(ctx, st0)?;
    let Some(miss) = first.raw_miss.clone().filter(|_| !initial.is_empty()) else {
        return Ok(first);
    };
    let mut st0 = first.st0;
    st0.idx.extend_from_slice(initial);
    st0.val.extend(initial.iter().map(|&i| ctx.params[i].start));
    ctx.stage(format!(
        "the record does not begin in the model's initial state (z = {:.1}): calibrating again \
         with the initial state",
        miss.z_raw
    ));
    let mut again = calibrate_and_check(ctx, st0)?;
    again.initial_estimated = Some(miss);
    Ok(again)
}

fn calibrate_and_check<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st0: ModelState,
) -> Result<Calibrated, GapError> {
    ctx.pb
        .set_message(format!("calibrating {} base parameter(s)", st0.idx.len()));
    let (fit, calibration) = calibrate_base(ctx, &st0).map_err(GapError::Simulation)?;
    ctx.stage(format!(
        "base fit: chi-square {:.1} directly; growing horizons (samples, chi-square) {:?}; kept {}",
        calibration.direct_chi2,
        calibration.horizons,
        calibration.chosen.label()
    ));
    let all = ctx
        .sim
        .simulate(&ctx.settings(&fit.state, None, &[]), ctx.n)
        .map_err(GapError::Simulation)?;
    let y: Vec<Vec<f64>> = ctx
        .out_idx
        .iter()
        .map(|&k| all[k][..ctx.n].to_vec())
        .collect();
    let r = ctx.residual(&y, ctx.n);
    let miss = start_disagreement(ctx, &r);
    let raw_miss = start_misses(
        &r,
        ctx.out_idx.len(),
        ctx.n,
        START_SAMPLES,
        &ctx.rho,
        &ctx.meas,
    )
    .into_iter()
    .max_by(|a, b| a.z_raw.abs().total_cmp(&b.z_raw.abs()))
    .filter(|m| m.z_raw.abs() > START_MAX_Z);
    Ok(Calibrated {
        st0,
        fit,
        calibration,
        all,
        miss,
        raw_miss,
        initial_estimated: None,
    })
}

/// The line the report gives when the initial state was estimated ([`calibrate_to_start`]).
pub(super) fn initial_state_note<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    miss: &StartMiss,
    initial: &[usize],
) -> String {
    let output = &ctx.sim.inner.output_names()[ctx.out_idx[miss.output]];
    format!(
        "The record does not begin at rest: calibrated from rest, the model missed '{output}' \
         over the first samples by {:.1}× its noise level. The initial state the FMU exposes \
         ({}) was estimated with the base parameters; see their values and intervals.",
        miss.start_mean.abs(),
        names(&ctx.params, initial)
    )
}

/// The base fit's miss of the record's start when it exceeds [`START_MAX_Z`] (None: the record
/// begins in the model's state); `r`: the base fit's weighted residual over the whole trace.
pub(super) fn start_disagreement<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    r: &[f64],
) -> Option<StartMiss> {
    let misses = start_misses(
        r,
        ctx.out_idx.len(),
        ctx.n,
        START_SAMPLES,
        &ctx.rho,
        &ctx.meas,
    );
    let worst = misses
        .iter()
        .max_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))?;
    ctx.stage(format!(
        "start of the record: the base fit misses output {} by {:.1} noise levels over the \
         first samples (trace mean {:.1}, rest RMS {:.1}), z = {:.1}, z_rel = {:.1}",
        worst.output, worst.start_mean, worst.trace_mean, worst.rest_rms, worst.z, worst.z_rel
    ));
    concentrated_at_start(misses)
}

/// The output whose start miss is concentrated at the start, the most ([`StartMiss::z`]) if
/// several are: beyond [`START_MAX_Z`] under the noise after the trace's offset and what the
/// misfit elsewhere predicts at the start ([`affine_prediction`]) are taken off, and beyond
/// [`START_REST_SHARE`] of the misfit over the rest of the trace. A record begun elsewhere is missed
/// at its first samples by the difference of states; a disagreement that runs through the
/// whole trace as a function of the measured output (a sensor gain error, a fixed parameter set
/// wrong) is missed at the start by what it is missed by elsewhere at the same measured values,
/// and says nothing about where the record begins: it is left to the rounds and to the report
/// of the disagreement that remains.
fn concentrated_at_start(misses: Vec<StartMiss>) -> Option<StartMiss> {
    misses
        .into_iter()
        .filter(|m| m.z.abs() > START_MAX_Z && m.excess > START_REST_SHARE * m.rest_rms)
        .max_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))
}

/// Whether a model whose weighted residual is `r` begins in the record's state where the base
/// fit did not (`base`): its start miss is within [`START_MAX_Z`] or a third of the base
/// fit's. With `relative`, the miss is counted against the model's misfit over the rest of the
/// trace ([`StartMiss::z_rel`]): a candidate while another effect is still missing, which the
/// next round may add. The final model is held to the noise level, except where it misses the
/// rest of the trace by more than the start (`rest_rms` above the start's mean miss): a model
/// that the named effects leave far from the data everywhere (41 noise levels on average,
/// against 6 at the start, when a wrong effect was named first) begins nearer the record than
/// it goes on, which is no sign of a record begun in motion. An effect that moves the state
/// the model rests in (a leak shifting the pressures at rest) explains such a start; an effect
/// named while the start stays unexplained would only imitate it.
pub(super) fn reproduces_start<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    base: &StartMiss,
    r: &[f64],
    relative: bool,
) -> bool {
    begins_alike(
        &start_misses(
            r,
            ctx.out_idx.len(),
            ctx.n,
            START_SAMPLES,
            &ctx.rho,
            &ctx.meas,
        ),
        base.z,
        relative,
    )
}

/// Whether the final model, whose weighted residual over the whole trace is `r`, still misses
/// the record's start that the base fit missed (`base`), under the noise model estimated again
/// from that residual. The base fit's residual holds the missing effect's misfit, under which
/// the noise's correlation cannot be seen ([`noise::noise_fit`] takes such an output's noise
/// as white, at its second-difference level); where the final model leaves noise, the noise is
/// seen, and a start miss counted against the fast part of correlated noise may be none. As
/// [`noise::refine_after_final_fit`] does for the report; the outputs whose correlation was
/// estimated from the base fit keep their model. Where [`noise::noise_fit`] still sees white
/// noise, [`noise::spike_robust_fit`] is asked too: a misfit that switches with the output
/// (a current at a motor's starts and stops) hides the correlation from the differences'
/// autocorrelation, not from their scales.
pub(super) fn still_misses_start<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    base: &StartMiss,
    r: &[f64],
) -> bool {
    let (k, n) = (ctx.out_idx.len(), ctx.n);
    let mut r = r.to_vec();
    let mut rho: Vec<f64> = (0..k)
        .map(|j| ctx.rho.get(j).copied().unwrap_or(0.0))
        .collect();
    let mut level = vec![1.0; k];
    // The noise is fitted where the model was fitted: over the held-out end a training fit
    // also carries its extrapolation error, which raises the RMS the noise test compares with
    // the marginal level.
    let fitted = ctx.n_train.clamp(1, n);
    for j in 0..k {
        let Some(block) = r.get_mut(j * n..(j + 1) * n).filter(|_| rho[j] == 0.0) else {
            continue;
        };
        let fit = match noise::noise_fit(&block[..fitted]) {
            f if f.rho == 0.0 => noise::spike_robust_fit(&block[..fitted]),
            f => f,
        };
        if fit.rho > 0.0 {
            block.iter_mut().for_each(|x| *x /= fit.level);
            rho[j] = fit.rho;
            level[j] = fit.level;
        }
    }
    let m = START_SAMPLES.min(n / 4);
    let sd = |rho: f64| (noise::mean_variance_factor(rho, m.max(1)) / m.max(1) as f64).sqrt();
    let j = base.output;
    let old_rho = ctx.rho.get(j).copied().unwrap_or(0.0);
    let base_z = base.z * sd(old_rho) / (level[j] * sd(rho[j]));
    if base_z.abs() <= START_MAX_Z {
        ctx.stage(format!(
            "start of the record: under the noise model of the final residual the base fit's \
             start miss is z = {base_z:.1}, within the noise"
        ));
        return false;
    }
    !begins_alike(
        &start_misses(&r, k, n, START_SAMPLES, &rho, &ctx.meas),
        base_z,
        false,
    )
}

/// [`reproduces_start`] on the start misses of every output (`base_z`: the base fit's).
fn begins_alike(misses: &[StartMiss], base_z: f64, relative: bool) -> bool {
    misses.iter().all(|m| {
        let z = if relative { m.z_rel } else { m.z };
        z.abs() <= START_MAX_Z.max(base_z.abs() / START_MISS_REDUCTION)
            || (!relative && m.start_mean.abs() < m.rest_rms)
    })
}

/// What stops a run whose record does not begin where the model begins and no candidate
/// explains it (`miss`: the base fit's start miss; `initial`: the initial-state parameters that
/// were estimated; `time`: the record's sample times). With no candidate round (`rounds` 0)
/// nothing can be named, so the same text is a warning of the calibration instead (`Ok`); so it
/// is too when the initial state was estimated and the rest of the record is missed far beyond
/// the noise as well (a model far from the record is reported, not refused).
pub(super) fn start_error<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    miss: &StartMiss,
    initial: &[usize],
    time: &[f64],
    rounds: usize,
) -> Result<String, GapError> {
    let output = &ctx.sim.inner.output_names()[ctx.out_idx[miss.output]];
    let m = START_SAMPLES.min(ctx.n / 4);
    let t_end = time.get(m.saturating_sub(1)).copied().unwrap_or(0.0);
    let what = StartMissed {
        output: output.clone(),
        samples: m,
        until_s: t_end,
        start_ratio: miss.start_mean.abs(),
        trace_ratio: miss.trace_mean.abs(),
    };
    let mut advice = what_to_do(&ctx.params, initial);
    if miss.rest_rms > START_MAX_Z {
        // The rest of the record is missed far beyond the noise too: the start may be where a
        // disagreement that is everywhere shows most, not a record begun elsewhere.
        advice += &format!(
            " The model also misses '{output}' by {:.1}× its noise level (RMS) over the rest of \
             the record: a sensor gain or zero error, a fixed parameter set wrong (--set) or a \
             mechanism that is not among the candidates can do that and make the start look \
             wrong; check those too.",
            miss.rest_rms
        );
    }
    if rounds == 0 {
        return Ok(format!("{what}; the calibration bends to it. {advice}"));
    }
    if !initial.is_empty() && miss.rest_rms > START_MAX_Z {
        // The initial state the FMU exposes was estimated and the model misses the whole
        // record far beyond the noise: what the user asked for is a diagnosis of that model,
        // so the run reports the disagreement (no effect is named that does not reproduce the
        // start) instead of refusing the record.
        return Ok(format!(
            "{what}, and no candidate effect explains it: the model is far from the whole \
             record, a disagreement no candidate explains. {advice}"
        ));
    }
    Err(InputError::StartNotExplained { miss: what, advice }.into())
}

/// The advice of [`start_error`]: with no initial-state parameter estimated, how to give the
/// model the record's initial state; with some, that another state begins elsewhere.
fn what_to_do(params: &[ParamSpec], initial: &[usize]) -> String {
    if initial.is_empty() {
        return "The FMU has no parameter tagged [initial] through which gap could estimate \
                its initial state: start the record where the system is at rest (or in the \
                state the model begins in), set the initial state with --set if the FMU has \
                parameters for it, or tag such parameters [initial] (README, conventions for \
                foreign FMUs)."
            .into();
    }
    format!(
        "This remains with the initial state the FMU exposes estimated ({}): a state it does \
         not expose begins elsewhere, or the record begins outside those parameters' ranges. \
         Start the record where the system is at rest, or give the FMU parameters tagged \
         [initial] for every state.",
        names(params, initial)
    )
}

/// The names of `idx`, at most [`MAX_NAMES`], comma-separated.
fn names(params: &[ParamSpec], idx: &[usize]) -> String {
    let mut v: Vec<&str> = idx.iter().map(|&i| params[i].name.as_str()).collect();
    if v.len() > MAX_NAMES {
        v.truncate(MAX_NAMES);
        v.push("…");
    }
    v.join(", ")
}

#[cfg(test)]
mod tests {
    use super::{
        begins_alike, concentrated_at_start, start_misses, what_to_do, StartMiss, START_MAX_Z,
        START_SAMPLES,
    };
    use crate::ParamSpec;

    /// The output whose first `m` samples the model misses most beyond a constant offset
    /// ([`StartMiss::z`]).
    fn start_miss(r: &[f64], k: usize, n: usize, m: usize, rho: &[f64]) -> Option<StartMiss> {
        start_misses(r, k, n, m, rho, &[])
            .into_iter()
            .max_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))
    }

    /// Pseudo-random standard normal samples (deterministic; Box–Muller on an LCG).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        let mut u = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| (-2.0 * libm::log(u())).sqrt() * libm::cos(std::f64::consts::TAU * u()))
            .collect()
    }

    #[test]
    fn a_model_far_off_everywhere_is_not_taken_for_a_record_begun_in_motion() {
        let n = 600;
        // Output 0 of a final model: nearer the record at the start (8 noise levels off), then
        // 41 levels below it on average, swinging by 20.
        let mut far = noise(n, 3);
        for (i, x) in far.iter_mut().enumerate() {
            *x += if i < START_SAMPLES {
                8.0
            } else {
                -41.0 + 20.0 * libm::sin(i as f64 / 15.0)
            };
        }
        let misses = start_misses(&far, 1, n, START_SAMPLES, &[], &[]);
        assert!(misses[0].z.abs() > START_MAX_Z, "{:?}", misses[0]);
        assert!(begins_alike(&misses, 11.0, false));
        // A model at the noise level elsewhere that misses the start by 30: begun in motion.
        let mut moving = noise(n, 4);
        for x in moving.iter_mut().take(START_SAMPLES) {
            *x += 30.0;
        }
        let misses = start_misses(&moving, 1, n, START_SAMPLES, &[], &[]);
        assert!(!begins_alike(&misses, 11.0, false), "{:?}", misses[0]);
        assert!(!begins_alike(&misses, 11.0, true), "{:?}", misses[0]);
    }

    #[test]
    fn a_decaying_start_transient_is_found_a_constant_offset_is_not() {
        let n = 600;
        // Output 0: white noise. Output 1: a speed the record began with, decaying over
        // 10 samples from 25 noise levels. Output 2: an angle read 30 noise levels high
        // throughout (a sensor zero error).
        let mut r = noise(3 * n, 7);
        for i in 0..n {
            r[n + i] += 25.0 * libm::exp(-(i as f64) / 10.0);
            r[2 * n + i] += 30.0;
        }
        let m = start_miss(&r, 3, n, START_SAMPLES, &[]).unwrap();
        assert_eq!(m.output, 1);
        assert!(m.z > START_MAX_Z, "{m:?}");
        // Without the transient nothing stands out: the offset is no start miss.
        let mut r2 = noise(3 * n, 7);
        for x in &mut r2[2 * n..] {
            *x += 30.0;
        }
        let m2 = start_miss(&r2, 3, n, START_SAMPLES, &[]).unwrap();
        assert!(m2.z.abs() < 4.0, "{m2:?}");
        // Counted with its offset, the angle misses the start: for an FMU that exposes its
        // initial state, the initial angle is tried first.
        let raw = &start_misses(&r2, 3, n, START_SAMPLES, &[], &[])[2];
        assert!(raw.z_raw > START_MAX_Z, "{raw:?}");
    }

    #[test]
    fn a_disagreement_that_follows_the_measured_output_is_no_start_miss() {
        let n = 750;
        // A sensor read 6 % low on an output that begins at its largest value, 5,000 noise
        // levels, and moves by a fifth of it: the misfit is 6 % of the measured value, 300 noise
        // levels at the start and 240-300 over the rest (as 'p' of TwistedString); noise of
        // level 1 on top.
        let measured: Vec<f64> = (0..n)
            .map(|i| 5000.0 - 1000.0 * (1.0 - libm::cos(i as f64 / 40.0)) / 2.0)
            .collect();
        let mut gain = noise(n, 11);
        for (x, y) in gain.iter_mut().zip(&measured) {
            *x += 0.06 * y;
        }
        let meas = vec![measured];
        // Beyond the noise at the start, counted against the trace's offset only ...
        let offset_only = start_misses(&gain, 1, n, START_SAMPLES, &[], &[]);
        assert!(offset_only[0].z.abs() > START_MAX_Z, "{:?}", offset_only[0]);
        // ... but what the misfit over the rest predicts at the measured start: no start miss,
        // under white noise or the workflow's AR(1) model alike.
        for rho in [0.0, 0.9] {
            let misses = start_misses(&gain, 1, n, START_SAMPLES, &[rho], &meas);
            assert!(misses[0].z.abs() < 5.0, "{:?}", misses[0]);
            assert_eq!(concentrated_at_start(misses), None);
        }
        // A second output begun in motion: a speed measured swinging between -40 and 40, met
        // at its start value 40 again and again, that the model misses only at the start (by 40
        // noise levels, decaying over 8 samples). Its misfit elsewhere does not predict the
        // start: that output is the start miss.
        let mut two = gain.clone();
        two.extend(
            noise(n, 12)
                .iter()
                .enumerate()
                .map(|(i, x)| x + 40.0 * libm::exp(-(i as f64) / 8.0)),
        );
        let mut meas2 = meas.clone();
        meas2.push((0..n).map(|i| 40.0 * libm::cos(i as f64 / 30.0)).collect());
        let m = concentrated_at_start(start_misses(&two, 2, n, START_SAMPLES, &[], &meas2));
        assert_eq!(m.map(|m| m.output), Some(1));
    }

    #[test]
    fn a_start_miss_small_against_the_misfit_everywhere_is_not_concentrated() {
        let n = 750;
        // An output missed by 3,800 noise levels over the whole trace, swinging by 200 with
        // the measured output, and at the start by 15 more than that line predicts (the line's
        // curvature, as with TwistedString's string length set wrong): far beyond the noise,
        // a tiny share of the misfit, no start miss.
        let measured: Vec<f64> = (0..n).map(|i| libm::sin(i as f64 / 40.0)).collect();
        let mut r = noise(n, 13);
        for (i, (x, y)) in r.iter_mut().zip(&measured).enumerate() {
            *x += 3800.0 + 200.0 * y + if i < START_SAMPLES { 15.0 } else { 0.0 };
        }
        let meas = vec![measured];
        let misses = start_misses(&r, 1, n, START_SAMPLES, &[], &meas);
        assert!(misses[0].z.abs() > START_MAX_Z, "{:?}", misses[0]);
        assert_eq!(concentrated_at_start(misses), None);
        // The same 15 beyond the line where the model meets the rest at the noise level: the
        // record begins elsewhere.
        let mut near = noise(n, 13);
        for x in near.iter_mut().take(START_SAMPLES) {
            *x += 15.0;
        }
        let misses = start_misses(&near, 1, n, START_SAMPLES, &[], &meas);
        assert!(concentrated_at_start(misses).is_some());
    }

    #[test]
    fn white_noise_stays_far_below_the_threshold() {
        let n = 400;
        let worst = (0..200)
            .map(|seed| {
                start_miss(&noise(2 * n, seed), 2, n, START_SAMPLES, &[])
                    .unwrap()
                    .z
                    .abs()
            })
            .fold(0.0, f64::max);
        assert!(worst < 5.0, "{worst}");
    }

    #[test]
    fn the_advice_names_the_estimated_initial_state_or_says_how_to_give_one() {
        let p = vec![
            ParamSpec::real(
                "speed_start",
                0.0,
                Some(-1.0),
                Some(1.0),
                "rad/s",
                "[initial]",
            ),
            ParamSpec::real(
                "angle_start",
                0.0,
                Some(-1.0),
                Some(1.0),
                "rad",
                "[initial]",
            ),
        ];
        let none = what_to_do(&p, &[]);
        assert!(none.contains("no parameter tagged [initial]"), "{none}");
        assert!(none.contains("--set"), "{none}");
        let some = what_to_do(&p, &[0, 1]);
        assert!(some.contains("(speed_start, angle_start)"), "{some}");
    }
}
