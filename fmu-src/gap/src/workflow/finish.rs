//! The end of a run: the chosen model refitted on the whole trace, its outputs as the data see
//! them, and the errors before and after per output.

use super::diagnose::errors;
use super::fit::FINAL_LIMITS;
use super::offsets::offset_estimates;
use super::{
    ensure_jacobian, fit_state, fit_state_holding, Ctx, Data, Estimate, FitOut, GapError, Limits,
    ModelState, OutputErrors, OutputTrace,
};
use crate::lm;
use crate::policy::{WANDERED_LINEAR, WANDERED_LOG};
use crate::sim::GridModel;
use std::collections::BTreeMap;

/// The final fit. The held-out end has done its work (choosing which effects to name); the
/// chosen model's parameters are then estimated from all the data, as after any model
/// selection: a model with several friction parameters can fit the training part to the noise
/// with values the held-out end contradicts. Its intervals come from this fit's Jacobian; it is
/// kept only if it lowers the whole trace's sum of squares (a failed fit keeps the
/// training-part one, `cur` with its whole-trace residual `cur_full_r`). Returns the fit and the
/// samples it used.
///
/// A flat valley lets base parameters wander while effects are added (a spring stiffening to
/// stand in for a compliance). When a base parameter ended far from where the calibration
/// started it (`st0`, beyond [`WANDERED_LOG`] or [`WANDERED_LINEAR`]), the final fit also starts
/// from there (the effects' parameters as fitted), and, as that start can still slide back along
/// the valley while the effects' parameters stay where the wandering left them, once more with
/// the wandered parameters held at their starts while the others are fitted, then released. The
/// three run in parallel and the lowest sum is kept.
pub(super) fn final_fit<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: FitOut,
    cur_full_r: &[f64],
    st0: &ModelState,
) -> (FitOut, usize) {
    let (n, n_train) = (ctx.n, ctx.n_train);
    if n_train >= n {
        return (cur, n_train);
    }
    ctx.stage("final fit on the whole trace".to_string());
    let moved = wandered(&cur, st0);
    let restart = (!moved.is_empty())
        .then(|| cur.state.with_base(st0))
        .flatten();
    let limits = FINAL_LIMITS.without_final_jacobian();
    let (a, (b, c)) = rayon::join(
        || fit_state(ctx, &cur.state, None, &[], n, limits).ok(),
        || {
            rayon::join(
                || fit_state(ctx, restart.as_ref()?, None, &[], n, limits).ok(),
                || held_restart(ctx, restart.as_ref()?, &moved, n, limits),
            )
        },
    );
    let best = [
        (a, None),
        (b, Some("the calibration's start")),
        (c, Some("the wandered parameters held at their starts")),
    ]
    .into_iter()
    .filter_map(|(f, how)| f.map(|f| (f, how)))
    .min_by(|x, y| x.0.fit.sse.total_cmp(&y.0.fit.sse));
    if let Some((f, Some(how))) = &best {
        ctx.stage(format!(
            "final fit: restarted from {how}, sum {:.1}",
            f.fit.sse
        ));
    }
    match best {
        Some((mut f, _)) if f.fit.sse < lm::sse(cur_full_r) => {
            ensure_jacobian(ctx, &mut f, n);
            (f, n)
        }
        _ => (cur, n_train),
    }
}

/// The final fit started again from `values` (every parameter of `fin`, a point the profile
/// search found clearly below `fin`'s sum), kept if it ends below `fin`'s sum, with its Jacobian.
pub(super) fn refit_from_lower<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: &FitOut,
    values: Vec<f64>,
    n_fin: usize,
) -> Option<FitOut> {
    let limits = FINAL_LIMITS.without_final_jacobian();
    let mut lower = fit_state(
        ctx,
        &fin.state.with_values(values),
        None,
        &[],
        n_fin,
        limits,
    )
    .ok()?;
    ctx.stage(format!(
        "final fit: the profile search found a lower valley, refitted from there: sum {:.1} against {:.1}",
        lower.fit.sse, fin.fit.sse
    ));
    (lower.fit.sse < fin.fit.sse).then(|| {
        ensure_jacobian(ctx, &mut lower, n_fin);
        lower
    })
}

/// The fit from `restart` with the parameters `held` (indices into its parameters, at its
/// values) kept there while the others are fitted, then every parameter fitted from there.
fn held_restart<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    restart: &ModelState,
    held: &[usize],
    n: usize,
    limits: Limits,
) -> Option<FitOut> {
    let keep: Vec<usize> = (0..restart.idx.len())
        .filter(|j| !held.contains(j))
        .collect();
    let others = ModelState {
        named: restart.named.clone(),
        idx: keep.iter().map(|&j| restart.idx[j]).collect(),
        val: keep.iter().map(|&j| restart.val[j]).collect(),
    };
    let hold: Vec<(usize, f64)> = held
        .iter()
        .map(|&j| (restart.idx[j], restart.val[j]))
        .collect();
    let first = fit_state_holding(ctx, &others, None, &[], &hold, n, limits).ok()?;
    let mut val = restart.val.clone();
    for (k, &j) in keep.iter().enumerate() {
        val[j] = first.state.val[k];
    }
    fit_state(ctx, &restart.with_values(val), None, &[], n, limits).ok()
}

/// The base parameters (positions in `cur`'s parameters, which list `st0`'s first) that ended
/// far from their start in `st0`.
fn wandered(cur: &FitOut, st0: &ModelState) -> Vec<usize> {
    st0.idx
        .iter()
        .zip(&st0.val)
        .filter_map(|(i, &v0)| {
            let j = cur.state.idx.iter().position(|k| k == i)?;
            let b = &cur.bounds[j];
            let limit = match b.coord {
                lm::Coord::Log => WANDERED_LOG,
                lm::Coord::Linear(_) => WANDERED_LINEAR,
            };
            ((b.to_z(cur.state.val[j]) - b.to_z(v0)).abs() > limit).then_some(j)
        })
        .collect()
}

/// Estimated output offsets by output name.
pub(super) type Offsets = BTreeMap<String, Estimate>;

/// The final model's measured outputs over the whole trace with their estimated offsets added
/// (the model as the data see it), and the offsets with their intervals (`offsets`).
pub(super) fn final_outputs<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: &FitOut,
    n_fin: usize,
    data_names: &[String],
) -> Result<(Vec<Vec<f64>>, Offsets), GapError> {
    let y = ctx
        .measured_outputs(&ctx.settings(&fin.state, None, &[]), ctx.n)
        .map_err(GapError::Simulation)?;
    let offsets = offset_estimates(ctx, fin, n_fin, &y, data_names);
    Ok((ctx.with_offsets(y, n_fin), offsets))
}

/// Errors per output of the model as given, the base fit and the final model (`models`, in
/// that order, measured outputs in the data's order), and the traces for the plots.
pub(super) fn output_errors<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    data: &Data,
    models: [&[Vec<f64>]; 3],
) -> (BTreeMap<String, OutputErrors>, Vec<OutputTrace>) {
    let [nominal, base_fit, final_y] = models;
    let mut outputs = BTreeMap::new();
    let mut traces = Vec::new();
    for (k, (name, y)) in data.outputs.iter().enumerate() {
        let (rb, mb) = errors(y, &nominal[k]);
        let (ra, ma) = errors(y, &final_y[k]);
        let (rf, mf) = errors(y, &base_fit[k]);
        outputs.insert(
            name.clone(),
            OutputErrors {
                rmse_before: rb,
                max_before: mb,
                rmse_after: ra,
                max_after: ma,
                rmse_base_fit: rf,
                max_base_fit: mf,
                noise_sigma: ctx.sigma[k],
                noise_ar1: ctx.rho[k],
                noise_white: ctx.sigma[k],
                unexplained_rms: 0.0,
                mean_after: final_y[k].iter().zip(y).map(|(m, d)| m - d).sum::<f64>()
                    / y.len().max(1) as f64,
            },
        );
        traces.push(OutputTrace {
            name: name.clone(),
            measured: y.clone(),
            nominal: nominal[k].clone(),
            base_fit: base_fit[k].clone(),
            final_fit: final_y[k].clone(),
        });
    }
    (outputs, traces)
}
