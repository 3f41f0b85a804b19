//! Refit of the promising candidates, their assessment, and the profile restart of a refit
//! stuck short of the naming threshold.

use super::evidence::{covariance, delta_bic, estimates, holdout_sse, row_scale};
use super::screen::CandidateStart;
use super::verdict::CandidateVerdict;
use super::{
    ensure_jacobian, find_param, fit_state, fit_state_holding, Candidate, Ctx, Estimate, FitOut,
    Limits, ModelState, VisibilityPoint, Z95,
};
use crate::policy::{
    NOISE_RMS_RATIO, PROFILE_ITERATIONS, PROFILE_REL_TOL, REFIT_ITERATIONS, REFIT_REL_TOL,
};
use crate::sim::{GridModel, SimError};
use crate::{lm, stats};
use nalgebra::DMatrix;
use rayon::iter::{IntoParallelIterator, ParallelIterator};
use std::collections::BTreeMap;

/// Refit the current model plus effect `e` on the training part; compute its ΔBIC, parameter and
/// magnitude intervals and held-out error. Returns the candidate, its fit and its full-trace
/// weighted residual.
pub(super) fn refit<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: &FitOut,
    e: usize,
    score: f64,
    cur_full_r: &[f64],
    alt_start: Option<&ModelState>,
    start: &CandidateStart,
) -> Result<(Candidate, FitOut, Vec<f64>), SimError> {
    let n = ctx.n_train;
    let k = ctx.out_idx.len();
    let eff = &ctx.effects[e];
    // From the current fit, and (for the most promising candidate of the first round) also from
    // the base parameters as given: the base fit may have bent them to mimic the effect, and
    // undoing that can trap the refit in a local minimum. The lower sum of squares wins.
    // The second start is tried only when the first leaves some output's residual above 1.2×
    // its noise level.
    let from = cur.state.with_values(start.base.clone());
    let start = start.effect.as_slice();
    let limits = refit_limits(ctx, cur, e).without_final_jacobian();
    let first = fit_state(ctx, &from, Some(e), start, n, limits);
    let at_noise = |f: &FitOut| {
        (0..k).all(|j| stats::rms(&f.fit.residuals[j * n..(j + 1) * n]) <= NOISE_RMS_RATIO)
    };
    let retry_from = match (&first, alt_start) {
        (Ok(f), Some(st)) if !at_noise(f) => Some(st),
        (Err(_), Some(st)) => Some(st),
        _ => None,
    };
    let second = retry_from.map(|st| fit_state(ctx, st, Some(e), start, n, limits));
    let mut failure = None;
    let best = std::iter::once(first)
        .chain(second)
        .filter_map(|r| r.map_err(|e| failure = failure.take().or(Some(e))).ok())
        .min_by(|a, b| {
            a.fit
                .sse
                .partial_cmp(&b.fit.sse)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    let mut f = best.ok_or_else(|| SimError::Refit {
        effect: eff.name.clone(),
        cause: Box::new(failure.unwrap_or(SimError::NonFiniteStart)),
    })?;
    ensure_jacobian(ctx, &mut f, n);
    ctx.stage(format!(
        "refit {}: {} iterations, {} simulations",
        eff.name, f.fit.iterations, f.fit.evaluations
    ));
    assess(ctx, cur, e, score, cur_full_r, f)
}

/// Limits of a candidate refit: `REFIT_ITERATIONS`, and given up once it cannot reach the
/// evidence naming needs. Naming needs `Σ_k N_eff,k ln(RSS_k / RSS'_k) ≥ min ΔBIC + p ln N`
/// (`visibility_needed`). With `N_eff,k ≤ N` and `ln(a / b) ≤ (a − b) / b`, the left side is at
/// most `D / ℓ`, `D` the drop of the sum of squares and `ℓ` a lower bound of the per-sample sums
/// `RSS'_k / N` after the refit. `ℓ` is taken as half the smaller of 1 (the noise level, which
/// with σ estimated from the data a fit cannot undercut by much) and the current smallest
/// `RSS_k / N`; a refit that cannot come below the current sum less `visibility_needed · ℓ`
/// cannot be named, whatever its other checks.
fn refit_limits<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, cur: &FitOut, e: usize) -> Limits {
    let n = ctx.n_train;
    let r = &cur.fit.residuals;
    let level = (0..ctx.out_idx.len())
        .map(|j| lm::sse(&r[j * n..(j + 1) * n]) / n as f64)
        .fold(1.0, f64::min);
    let drop = ctx.visibility_needed(e) * 0.5 * level;
    Limits::new(REFIT_ITERATIONS, REFIT_REL_TOL).futile_above(cur.fit.sse - drop)
}

/// The candidate record of effect `e` fitted as `f` (with the current fit `cur`): its ΔBIC,
/// parameter and magnitude intervals and held-out error. Returns it with the fit and the fit's
/// full-trace weighted residual.
pub(super) fn assess<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: &FitOut,
    e: usize,
    score: f64,
    cur_full_r: &[f64],
    f: FitOut,
) -> Result<(Candidate, FitOut, Vec<f64>), SimError> {
    let n = ctx.n_train;
    let k = ctx.out_idx.len();
    let eff = &ctx.effects[e];
    let dbic = delta_bic(&cur.fit.residuals, &f.fit.residuals, k, eff.params.len());
    let scale = row_scale(&f.fit.residuals, k);
    let all_est = estimates(
        &ctx.params,
        &f.state.idx,
        &f.fit,
        &f.bounds,
        &scale,
        n,
        &vec![(Z95, Z95); f.state.idx.len()],
    );
    let parameters: BTreeMap<String, Estimate> = eff
        .params
        .iter()
        .filter_map(|&i| {
            all_est
                .get(&ctx.params[i].name)
                .map(|v| (ctx.params[i].name.clone(), v.clone()))
        })
        .collect();
    // Magnitude: y(a) = y_off + a (y_on − y_off), a = 1 at the fit; interval with the base
    // parameters free.
    let mut off_state = f.state.clone();
    off_state.named.retain(|&x| x != e);
    off_state.idx.truncate(cur.state.idx.len());
    off_state.val.truncate(cur.state.idx.len());
    let y_off = ctx.measured_outputs(&ctx.settings(&off_state, None, &[]), n)?;
    let r_on = &f.fit.residuals;
    let r_off = ctx.residual(&y_off, n);
    let d: Vec<f64> = r_on.iter().zip(&r_off).map(|(a, b)| a - b).collect();
    let pb = cur.state.idx.len();
    let x = DMatrix::from_fn(
        n * k,
        pb + 1,
        |i, j| if j < pb { f.fit.jac[(i, j)] } else { d[i] },
    );
    let magnitude = covariance(&x, &scale, n).map(|c| {
        let sd = c[(pb, pb)].max(0.0).sqrt();
        Estimate {
            value: 1.0,
            ci_low: 1.0 - Z95 * sd,
            ci_high: 1.0 + Z95 * sd,
            unit: "1".into(),
            start: 0.0,
            at_bound: None,
        }
    });
    // Held-out part.
    let full = ctx.measured_outputs(&ctx.settings(&f.state, None, &[]), ctx.n)?;
    let r_full = ctx.residual(&full, ctx.n);
    let hw = holdout_sse(&r_full, k, ctx.n, ctx.n_train);
    let hwo = hw.and(holdout_sse(cur_full_r, k, ctx.n, ctx.n_train));
    Ok((
        Candidate {
            effect: eff.name.clone(),
            delta_bic: dbic,
            score,
            refit: true,
            parameters,
            magnitude,
            holdout_sse_without: hwo,
            holdout_sse_with: hw,
            named: false,
            verdict: CandidateVerdict::Unchecked,
            visibility: None,
            visibility_needed: 0.0,
            detectable_from: None,
            visibility_scan: Vec::new(),
            profiled: false,
            inconclusive: false,
            explained_share: None,
        },
        f,
        r_full,
    ))
}

/// A refit that falls short of the naming evidence although the scan says the data could show
/// the effect may have stopped in a valley's far end: the base fit bent the base parameters to
/// imitate the effect (a stiffer spring for a radius that grows with twist), and from there
/// the local descent lowers the effect instead of unbending them. Profile the valley: at every
/// scanned setting the data can reveal (above the fraction 0 of the range), fit the base
/// parameters with the effect held there (a few iterations, in parallel), starting from their
/// current values and from their values as given (`given`: the base fit may have bent them
/// far); from the best of these, if it beats the refit `f`, refit everything. Returns that fit
/// if its sum of squares is lower than the refit's. Called for refits short of the naming
/// threshold, and for the best refit when it reaches it (see `refit_all`).
/// `Config::profile_restart` false turns it off (for before/after measurements).
pub(super) fn profile_restart<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: &FitOut,
    e: usize,
    f: &FitOut,
    scan: &[VisibilityPoint],
    given: Option<&ModelState>,
) -> Option<FitOut> {
    let n = ctx.n_train;
    let eff = &ctx.effects[e];
    if !ctx.profile_restart || eff.params.is_empty() {
        return None;
    }
    let needed = ctx.visibility_needed(e);
    let points: Vec<Vec<(usize, f64)>> = scan
        .iter()
        .filter(|x| x.fraction > 0.0 && x.visibility.is_some_and(|v| v >= needed))
        .filter_map(|x| {
            x.parameters
                .iter()
                .map(|(name, &v)| find_param(&ctx.params, name).ok().map(|i| (i, v)))
                .collect::<Option<Vec<_>>>()
        })
        .collect();
    if points.is_empty() {
        return None;
    }
    let froms: Vec<&ModelState> = std::iter::once(&cur.state).chain(given).collect();
    let jobs: Vec<(&Vec<(usize, f64)>, &ModelState)> = points
        .iter()
        .flat_map(|pt| froms.iter().map(move |st| (pt, *st)))
        .collect();
    let profiles: Vec<(Vec<(usize, f64)>, FitOut)> = jobs
        .into_par_iter()
        .filter_map(|(pt, st)| {
            fit_state_holding(
                ctx,
                st,
                Some(e),
                &[],
                pt,
                n,
                Limits::new(PROFILE_ITERATIONS, PROFILE_REL_TOL).without_final_jacobian(),
            )
            .ok()
            .map(|p| (pt.clone(), p))
        })
        .collect();
    let (pt, prof) = profiles
        .into_iter()
        .min_by(|a, b| a.1.fit.sse.total_cmp(&b.1.fit.sse))?;
    ctx.stage(format!(
        "profile of {}: best held setting sum {:.1} against the refit's {:.1}",
        eff.name, prof.fit.sse, f.fit.sse
    ));
    if prof.fit.sse >= f.fit.sse {
        return None;
    }
    let from = cur.state.with_values(prof.state.val.clone());
    fit_state(ctx, &from, Some(e), &pt, n, refit_limits(ctx, cur, e))
        .ok()
        .filter(|g| g.fit.sse < f.fit.sse)
}
