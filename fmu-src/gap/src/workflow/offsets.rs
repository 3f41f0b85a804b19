//! Output offsets estimated on request (`Config::offsets`): a constant sensor zero error per
//! measured output, eliminated from every fit in closed form ([`Ctx::residual_est`]) and
//! reported here with its 95 % interval.

use super::evidence::{covariance, row_scale};
use super::{Ctx, Estimate, FitOut, Z95};
use crate::lm::LmOptions;
use crate::sim::GridModel;
use nalgebra::DMatrix;
use rayon::iter::{IntoParallelIterator, ParallelIterator};
use std::collections::BTreeMap;

/// The offset (measured − model) of every output whose offset is estimated, at the final fit
/// `fin` over samples `0..n_fit`, with `y` the model's measured outputs there.
///
/// Interval: the residual with the offset as an explicit coefficient is `r = r_raw + b / σ`, so
/// the offsets' covariance comes from the Jacobian `[J_raw | E]` (`E`: one column per offset,
/// 1 on its output's rows) with the same row scaling as the parameters' ([`covariance`]). The
/// fit's Jacobian `J̃` is that of the residual with its mean removed; `J_raw = J̃ + E C` with `C`
/// the per-output mean of `∂r_raw/∂z`, taken by one forward difference per parameter (the step
/// of the fit's Jacobian). The interval thus carries the uncertainty of the parameters the
/// offset trades against, not only that of a mean.
pub(super) fn offset_estimates<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: &FitOut,
    n_fit: usize,
    y: &[Vec<f64>],
    names: &[String],
) -> BTreeMap<String, Estimate> {
    let ks: Vec<usize> = (0..ctx.out_idx.len()).filter(|&k| ctx.offset[k]).collect();
    if ks.is_empty() {
        return BTreeMap::new();
    }
    let kout = ctx.out_idx.len();
    let n = n_fit;
    let mean = |v: &[f64]| v[..n].iter().sum::<f64>() / n as f64;
    let h = LmOptions::default().fd_step;
    let m = fin.state.idx.len();
    // C[k][j]: mean over output k of ∂r_raw/∂z_j (σ units).
    let cols: Vec<Option<Vec<f64>>> = (0..m)
        .into_par_iter()
        .map(|j| {
            let b = &fin.bounds[j];
            let (_, zhi) = b.z_bounds();
            let d = if fin.fit.z[j] + h <= zhi { h } else { -h };
            let mut val = fin.state.val.clone();
            val[j] = b.to_p(fin.fit.z[j] + d);
            let st = fin.state.with_values(val);
            let yp = ctx
                .measured_outputs(&ctx.settings(&st, None, &[]), n)
                .ok()?;
            Some(
                (0..kout)
                    .map(|k| (mean(&yp[k]) - mean(&y[k])) / (ctx.sigma[k] * d))
                    .collect(),
            )
        })
        .collect();
    let rows = n * kout;
    let x = DMatrix::from_fn(rows, m + ks.len(), |i, c| {
        let k = i / n;
        if c < m {
            fin.fit.jac[(i, c)] + cols[c].as_ref().map_or(0.0, |v| v[k])
        } else {
            f64::from(u8::from(ks[c - m] == k))
        }
    });
    let scale = row_scale(&fin.fit.residuals, kout);
    let cov = covariance(&x, &scale, n);
    ks.iter()
        .enumerate()
        .map(|(c, &k)| {
            let value = ctx.offset_of(k, &y[k], n);
            let sd = cov
                .as_ref()
                .map(|v| v[(m + c, m + c)].max(0.0).sqrt() * ctx.sigma[k])
                .filter(|s| s.is_finite() && cols.iter().all(Option::is_some))
                .unwrap_or(f64::INFINITY);
            (
                names[k].clone(),
                Estimate {
                    value,
                    ci_low: value - Z95 * sd,
                    ci_high: value + Z95 * sd,
                    unit: String::new(),
                    start: 0.0,
                    at_bound: None,
                },
            )
        })
        .collect()
}
