//! Evidence: the statistics a naming rests on (BIC with autocorrelation-corrected sample sizes,
//! held-out sums, parameter covariances and intervals, bound and far-from-data warnings).

use super::{Candidate, Estimate, OutputErrors};
use crate::lm::Bounded;
use crate::policy::{
    DISAGREEMENT_RATIO, EIG_REL_TOL, FAR_FROM_DATA, NULL_COMPONENT_TOL, OFFSET_SHARE,
};
use crate::spec::ParamSpec;
use crate::{lm, stats};
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// Sum of squares of a full-trace stacked residual (k outputs of n samples) over the held-out
/// samples `n_train..n`; None when nothing is held out.
pub(super) fn holdout_sse(r: &[f64], k: usize, n: usize, n_train: usize) -> Option<f64> {
    (n_train < n).then(|| {
        (0..k)
            .map(|j| lm::sse(&r[j * n + n_train..(j + 1) * n]))
            .sum()
    })
}

/// Per-output (RSS, N_eff) of a stacked weighted residual.
pub(super) fn rss_neff(r: &[f64], k: usize) -> Vec<(f64, f64)> {
    let n = r.len() / k.max(1);
    (0..k)
        .map(|j| {
            let rk = &r[j * n..(j + 1) * n];
            (lm::sse(rk).max(1e-300), stats::n_eff_series(rk))
        })
        .collect()
}

/// ΔBIC = BIC(small) − BIC(large) with the large model's effective sample sizes.
pub(super) fn delta_bic(r_small: &[f64], r_large: &[f64], k: usize, extra_params: usize) -> f64 {
    let small = rss_neff(r_small, k);
    let large = rss_neff(r_large, k);
    let ne_total: f64 = large.iter().map(|x| x.1).sum();
    let gain: f64 = small
        .iter()
        .zip(&large)
        .map(|(s, l)| l.1 * libm::log(s.0 / l.0))
        .sum();
    gain - extra_params as f64 * libm::log(ne_total)
}

/// ΔBIC as [`delta_bic`] but with every sample counted as independent (N_eff = N): for ranking
/// candidates in the screening, where the residual is still dominated by the missing effect and
/// its autocorrelation would deflate every candidate alike.
pub(super) fn delta_bic_naive(
    r_small: &[f64],
    r_large: &[f64],
    k: usize,
    extra_params: usize,
) -> f64 {
    let n = (r_small.len() / k.max(1)) as f64;
    let small = rss_neff(r_small, k);
    let large = rss_neff(r_large, k);
    let gain: f64 = small
        .iter()
        .zip(&large)
        .map(|(s, l)| n * libm::log(s.0 / l.0))
        .sum();
    gain - extra_params as f64 * libm::log(n * k as f64)
}

/// Row scaling that turns the weighted Jacobian into one whose (J̃ᵀJ̃)⁻¹ is the parameter
/// covariance: per output, `(1 / s_k) √(N_eff,k / N)` with `s_k` the RMS of the weighted residual.
pub(super) fn row_scale(r: &[f64], k: usize) -> Vec<f64> {
    let n = r.len() / k.max(1);
    (0..k)
        .map(|j| {
            let rk = &r[j * n..(j + 1) * n];
            let s = stats::rms(rk).max(1e-12);
            let ne = stats::n_eff_series(rk);
            (ne / n as f64).sqrt() / s
        })
        .collect()
}

/// Per-row weights of rows stacked by output, `n` per output: output `k`'s `per_output[k]` (the
/// last one's for rows beyond).
pub(super) fn row_weights(per_output: &[f64], n: usize, rows: usize) -> Vec<f64> {
    (0..rows)
        .map(|i| per_output[(i / n.max(1)).min(per_output.len() - 1)])
        .collect()
}

/// Covariance of the columns of `x` with the per-output row scaling, robust to parameters that
/// are not separately identifiable.
///
/// `A = J̃ᵀJ̃` is scaled to unit diagonal, `Â = D⁻¹ A D⁻¹`, and eigen-decomposed,
/// `Â = V Λ Vᵀ`. Directions with `λ_i < EIG_REL_TOL λ_max` are undetermined by the data (e.g. two
/// parameters that enter only as a product). The covariance is the Moore–Penrose pseudo-inverse
/// restricted to the well-determined subspace, `Cov = D⁻¹ V₊ Λ₊⁻¹ V₊ᵀ D⁻¹`. For a parameter whose
/// unit vector `e_j` lies in that subspace (`e_j` is an *estimable function*, Rao 1973 §4a), this is
/// exactly its variance, the same value as the ordinary inverse of the model in which the
/// undetermined combination is held fixed. A parameter with a squared component above
/// `NULL_COMPONENT_TOL` in the undetermined eigenspace (`Σ_{i∉+} V_{ji}² `) is not estimable: its
/// variance is `+∞` (its row and column are NaN), so its interval is unbounded (null in the
/// report) and, for an effect magnitude, never excludes zero. `None` only for an empty or
/// non-finite matrix. (Before this, a single singular pair made `try_inverse` fail and every
/// parameter's interval null.)
pub(super) fn covariance(x: &DMatrix<f64>, scale: &[f64], n: usize) -> Option<DMatrix<f64>> {
    let mut xs = x.clone();
    for (mut xr, w) in xs.row_iter_mut().zip(row_weights(scale, n, x.nrows())) {
        xr *= w;
    }
    let a = xs.transpose() * xs;
    let p = a.nrows();
    if p == 0 || a.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // Scale to unit diagonal (a zero column stays zero and is then undetermined).
    let d: Vec<f64> = (0..p).map(|i| a[(i, i)].max(0.0).sqrt()).collect();
    let an = DMatrix::from_fn(p, p, |i, j| {
        if d[i] > 0.0 && d[j] > 0.0 {
            a[(i, j)] / (d[i] * d[j])
        } else {
            0.0
        }
    });
    let eig = an.symmetric_eigen();
    let lmax = eig.eigenvalues.iter().cloned().fold(0.0_f64, f64::max);
    if lmax <= 0.0 {
        let mut c = DMatrix::from_element(p, p, f64::NAN);
        c.fill_diagonal(f64::INFINITY);
        return Some(c);
    }
    let keep: Vec<bool> = eig
        .eigenvalues
        .iter()
        .map(|&l| l > EIG_REL_TOL * lmax)
        .collect();
    let v = &eig.eigenvectors;
    let estimable: Vec<bool> = (0..p)
        .map(|j| {
            let null: f64 = (0..p)
                .filter(|&i| !keep[i])
                .map(|i| crate::stats::sq(v[(j, i)]))
                .sum();
            d[j] > 0.0 && null <= NULL_COMPONENT_TOL
        })
        .collect();
    Some(DMatrix::from_fn(p, p, |i, j| {
        if !(estimable[i] && estimable[j]) {
            return if i == j { f64::INFINITY } else { f64::NAN };
        }
        let s: f64 = (0..p)
            .filter(|&m| keep[m])
            .map(|m| v[(i, m)] * v[(j, m)] / eig.eigenvalues[m])
            .sum();
        s / (d[i] * d[j])
    }))
}

/// Least-squares fit of `y` on the columns of `x` (column-normalised normal equations with a tiny
/// ridge); returns the residual `y − X β` and β.
pub(crate) fn regress(x: &DMatrix<f64>, y: &[f64]) -> (Vec<f64>, DVector<f64>) {
    let p = x.ncols();
    let yv = DVector::from_column_slice(y);
    if p == 0 {
        return (y.to_vec(), DVector::zeros(0));
    }
    let norms: Vec<f64> = (0..p).map(|j| x.column(j).norm().max(1e-300)).collect();
    let xn = DMatrix::from_fn(x.nrows(), p, |i, j| x[(i, j)] / norms[j]);
    let mut a = xn.transpose() * &xn;
    for j in 0..p {
        a[(j, j)] += 1e-9;
    }
    let b = xn.transpose() * &yv;
    let beta_n = a
        .cholesky()
        .map(|c| c.solve(&b))
        .unwrap_or_else(|| DVector::zeros(p));
    let res = &yv - &xn * &beta_n;
    let beta = DVector::from_fn(p, |j, _| beta_n[j] / norms[j]);
    (res.as_slice().to_vec(), beta)
}

/// Estimates with 95 % intervals: `z ± k·σ` in each parameter's fitting coordinate (σ from the
/// Jacobian of `fit`, `k` from `ends`, see `rough` and `ends`), mapped to its value and held
/// within its declared range (a profile can reach a bound; a parameter fitted in logarithm has
/// an interval that is a factor either way, never a negative end).
pub(super) fn estimates(
    ctx_params: &[ParamSpec],
    idx: &[usize],
    fit: &lm::LmFit,
    bounds: &[Bounded],
    scale: &[f64],
    n: usize,
    ends: &[(f64, f64)],
) -> BTreeMap<String, Estimate> {
    let cov = if idx.is_empty() {
        None
    } else {
        covariance(&fit.jac, scale, n)
    };
    idx.iter()
        .enumerate()
        .map(|(j, &pi)| {
            let v = fit.p[j];
            let sd = cov
                .as_ref()
                .map(|c| c[(j, j)].max(0.0).sqrt())
                .filter(|s| s.is_finite())
                .unwrap_or(f64::INFINITY);
            let (b, z) = (&bounds[j], fit.z[j]);
            (
                ctx_params[pi].name.clone(),
                Estimate {
                    value: v,
                    ci_low: b.to_p(z - ends[j].0 * sd).min(v),
                    ci_high: b.to_p(z + ends[j].1 * sd).max(v),
                    unit: ctx_params[pi].unit.clone(),
                    start: ctx_params[pi].start,
                    at_bound: bound_hit(&ctx_params[pi], v),
                },
            )
        })
        .collect()
}

/// "min" / "max" when `v` lies on that bound of the parameter's range (to 1e-9 of the range).
pub(super) fn bound_hit(q: &ParamSpec, v: f64) -> Option<String> {
    let (lo, hi) = (q.min?, q.max?);
    let tol = 1e-9 * (hi - lo).abs().max(f64::MIN_POSITIVE);
    if (v - lo).abs() <= tol {
        Some("min".into())
    } else if (v - hi).abs() <= tol {
        Some("max".into())
    } else {
        None
    }
}

/// Warnings for the user about the final fit: parameters that ended on a bound of their range.
pub(super) fn bound_warnings(
    parameters: &BTreeMap<String, Estimate>,
    params: &[ParamSpec],
) -> Vec<String> {
    parameters
        .iter()
        .filter_map(|(name, e)| {
            let side = e.at_bound.as_deref()?;
            let q = params.iter().find(|q| &q.name == name)?;
            let bound = if side == "min" { q.min? } else { q.max? };
            Some(format!(
                "{name} ended on its {} bound {bound} {} (start {}): the fit pushes against it. Either the true value lies there or outside the declared range, or the model bends this parameter to stand in for something it lacks (a missing effect the data cannot single out, or a wrong fixed value); treat its interval, and effects judged alongside it, with caution.",
                if side == "min" { "lower" } else { "upper" },
                e.unit,
                e.start
            ))
        })
        .collect()
}

/// Warning when the final model still misses some output by more than [`FAR_FROM_DATA`] times its
/// noise level (None otherwise): whatever was named then explains part of the gap at most.
pub(super) fn far_from_data_warning(outputs: &BTreeMap<String, OutputErrors>) -> Option<String> {
    let mut far: Vec<(&String, f64)> = outputs
        .iter()
        .filter(|(_, o)| o.noise_sigma > 0.0)
        .map(|(n, o)| (n, o.rmse_after / o.noise_sigma))
        .filter(|(_, r)| *r > FAR_FROM_DATA)
        .collect();
    if far.is_empty() {
        return None;
    }
    far.sort_by(|a, b| b.1.total_cmp(&a.1));
    Some(format!(
        "The final model is still far from the data: RMSE {} the noise level. Whatever was named explains part of the gap at most. A missing effect that is not among the candidates, a wrong fixed parameter, or a trajectory too sensitive to the parameters to fit over the whole trace (a loop near its stability limit, oscillating) can leave this; see the residual plots.",
        far.iter()
            .map(|(n, r)| format!("{n} {r:.1}×"))
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// One warning per output whose remaining error after the final fit is mostly a constant offset:
/// `mean² ≥ 0.5 RMSE²` (the offset is at least half the mean square) and `RMSE > 1.5 σ` (the
/// output misses the data by more than noise). A sensor zero error looks like this; the model has
/// no parameter for it, and the workflow does not invent an effect for it.
pub(super) fn offset_warnings(outputs: &BTreeMap<String, OutputErrors>) -> Vec<String> {
    outputs
        .iter()
        .filter(|(_, o)| {
            o.noise_sigma > 0.0
                && o.rmse_after > DISAGREEMENT_RATIO * o.noise_sigma
                && o.mean_after * o.mean_after >= OFFSET_SHARE * o.rmse_after * o.rmse_after
        })
        .map(|(n, o)| {
            format!(
                "{n}: after the fit the model stays off the data by a nearly constant {:+.4e} \
                 (mean of model − data; {:.1}× its noise level, most of its RMSE {:.4e}): a \
                 sensor zero error, an offset the model has no parameter for, or a wrong known \
                 setting (--set). Check the sensor's zero and the settings (or give the FMU an \
                 offset parameter tagged [calibrate]) and run again.",
                o.mean_after,
                o.mean_after.abs() / o.noise_sigma,
                o.rmse_after
            )
        })
        .collect()
}

/// The highest ΔBIC among the refitted candidates of a round (−∞ if none was refitted).
pub(super) fn best_refit_delta_bic(ranked: &[Candidate]) -> f64 {
    ranked
        .iter()
        .filter(|c| c.refit)
        .map(|c| c.delta_bic)
        .fold(f64::NEG_INFINITY, f64::max)
}

#[cfg(test)]
mod covariance_tests {
    use super::covariance;
    use crate::workflow::Z95;
    use nalgebra::DMatrix;

    /// Ordinary inverse of XᵀX (reference for the identifiable case).
    fn plain_inv(x: &DMatrix<f64>) -> DMatrix<f64> {
        (x.transpose() * x).try_inverse().unwrap()
    }

    fn design(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..n).map(|i| i as f64 / n as f64).collect();
        let c1: Vec<f64> = t.iter().map(|t| libm::sin(6.0 * t)).collect();
        let c3: Vec<f64> = t.iter().map(|t| t * t + 0.3 * libm::sin(6.0 * t)).collect();
        let c4: Vec<f64> = t.iter().map(|t| libm::cos(17.0 * t) - 0.2 * t).collect();
        (c1, c3, c4)
    }

    #[test]
    fn full_rank_matches_the_ordinary_inverse() {
        let n = 200;
        let (c1, c3, c4) = design(n);
        let x = DMatrix::from_fn(n, 3, |i, j| [c1[i], c3[i], c4[i]][j]);
        let c = covariance(&x, &[1.0], n).unwrap();
        let r = plain_inv(&x);
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (c[(i, j)] - r[(i, j)]).abs() <= 1e-9 * r[(i, i)].abs().max(r[(j, j)].abs())
                );
            }
        }
    }

    /// Columns 0 and 1 are exactly collinear (a product `mu * phi`: d/dmu = phi f', d/dphi = mu f');
    /// columns 2 and 3 are identifiable and correlated with column 0. The collinear pair must be
    /// unbounded, the other two must get the variance of the model with the pair merged into one
    /// column (`e_j` is estimable, so its variance does not depend on how the pair is split).
    #[test]
    fn collinear_pair_is_unbounded_others_finite() {
        let n = 200;
        let (c1, c3, c4) = design(n);
        let x = DMatrix::from_fn(n, 4, |i, j| [c1[i], -2.5 * c1[i], c3[i], c4[i]][j]);
        // Row scaling by output: two "outputs" of n/2 rows each.
        let scale = [0.7, 1.9];
        let c = covariance(&x, &scale, n / 2).unwrap();
        assert!(c[(0, 0)].is_infinite() && c[(1, 1)].is_infinite());
        // Reference: the merged model [c1, c3, c4] with the same row scaling.
        let xm = DMatrix::from_fn(n, 3, |i, j| {
            let s = scale[i / (n / 2)];
            s * [c1[i], c3[i], c4[i]][j]
        });
        let r = plain_inv(&xm);
        for (j, jr) in [(2, 1), (3, 2)] {
            assert!(c[(j, j)].is_finite() && c[(j, j)] > 0.0);
            let rel = (c[(j, j)] - r[(jr, jr)]).abs() / r[(jr, jr)];
            assert!(
                rel < 1e-8,
                "param {j}: {} vs {} (rel {rel:e})",
                c[(j, j)],
                r[(jr, jr)]
            );
        }
        let rel = (c[(2, 3)] - r[(1, 2)]).abs() / (r[(1, 1)] * r[(2, 2)]).sqrt();
        assert!(rel < 1e-8);
        // The old behaviour (ordinary inverse) fails on this matrix.
        let a = {
            let xs = DMatrix::from_fn(n, 4, |i, j| x[(i, j)] * scale[i / (n / 2)]);
            xs.transpose() * xs
        };
        let cond = a.clone().symmetric_eigen().eigenvalues;
        let (lo, hi) = cond
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(lo < 1e-12 * hi);
    }

    /// A magnitude column that duplicates a base column is unbounded, so the naming rule
    /// "magnitude interval excludes zero" rejects it.
    #[test]
    fn magnitude_collinear_with_base_is_not_bounded() {
        let n = 100;
        let (c1, c3, _) = design(n);
        let x = DMatrix::from_fn(n, 3, |i, j| [c1[i], c3[i], 3.0 * c3[i]][j]);
        let c = covariance(&x, &[1.0], n).unwrap();
        assert!(c[(2, 2)].is_infinite());
        let sd = c[(2, 2)].max(0.0).sqrt();
        assert!(1.0 - Z95 * sd <= 0.0);
        assert!(c[(0, 0)].is_finite());
    }
}

/// Errors of an output whose fit ends at RMSE `rmse` with mean `mean`, noise level `sigma`
/// (before and base fit at 10).
#[cfg(test)]
fn errors_after(rmse: f64, mean: f64, sigma: f64) -> OutputErrors {
    OutputErrors {
        rmse_before: 10.0,
        max_before: 10.0,
        rmse_after: rmse,
        max_after: rmse,
        rmse_base_fit: 10.0,
        max_base_fit: 10.0,
        noise_sigma: sigma,
        noise_ar1: 0.0,
        noise_white: sigma,
        unexplained_rms: 0.0,
        mean_after: mean,
    }
}

#[cfg(test)]
mod offset_tests {
    use super::{errors_after, offset_warnings};
    use crate::workflow::BTreeMap;
    use crate::workflow::OutputErrors;

    fn out(rmse: f64, mean: f64) -> OutputErrors {
        errors_after(rmse, mean, 1.0)
    }

    #[test]
    fn only_an_error_above_noise_that_is_mostly_constant_is_an_offset() {
        let mut outs = BTreeMap::new();
        outs.insert("theta".to_string(), out(5.1, -5.0)); // offset: 96 % of the mean square
        outs.insert("p".to_string(), out(5.0, 2.0)); // large, but mostly not constant
        outs.insert("x".to_string(), out(1.2, 1.1)); // constant, but within noise
        let w = offset_warnings(&outs);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with("theta: ") && w[0].contains("-5.0000e0"),
            "{w:?}"
        );
        assert!(w[0].contains("5.0× its noise level"), "{w:?}");
    }
}

#[cfg(test)]
mod bound_tests {
    use super::{bound_hit, bound_warnings, errors_after, far_from_data_warning};
    use crate::workflow::BTreeMap;
    use crate::workflow::Estimate;
    use crate::ParamSpec;

    fn est(v: f64) -> Estimate {
        Estimate {
            value: v,
            ci_low: v,
            ci_high: v,
            unit: "N/m".into(),
            start: 100.0,
            at_bound: None,
        }
    }

    #[test]
    fn far_from_data_is_warned_about_only_above_three_times_the_noise() {
        let o = |rmse: f64| errors_after(rmse, 0.0, 2.0);
        let mut outs = BTreeMap::new();
        outs.insert("theta".to_string(), o(5.9));
        outs.insert("p".to_string(), o(2.1));
        assert!(far_from_data_warning(&outs).is_none());
        outs.insert("x".to_string(), o(20.8));
        outs.insert("y".to_string(), o(6.4));
        let w = far_from_data_warning(&outs).expect("x and y are far");
        assert!(w.contains("x 10.4×, y 3.2×"), "{w}");
        assert!(!w.contains("theta"), "{w}");
    }

    #[test]
    fn values_on_a_bound_are_flagged_and_warned_about() {
        let q = ParamSpec::real(
            "spring_stiffness",
            100.0,
            Some(0.0),
            Some(5000.0),
            "N/m",
            "",
        );
        assert_eq!(bound_hit(&q, 5000.0).as_deref(), Some("max"));
        assert_eq!(bound_hit(&q, 0.0).as_deref(), Some("min"));
        assert_eq!(bound_hit(&q, 4999.0), None);
        assert_eq!(bound_hit(&q, 1e-3), None);
        let open = ParamSpec::real("free", 1.0, None, Some(2.0), "1", "");
        assert_eq!(
            bound_hit(&open, 2.0),
            None,
            "a half-open range has no box to hit"
        );
        let mut on = est(5000.0);
        on.at_bound = bound_hit(&q, 5000.0);
        let params = vec![q];
        let map: BTreeMap<String, Estimate> = [
            ("spring_stiffness".to_string(), on),
            ("other".to_string(), est(3.0)),
        ]
        .into_iter()
        .collect();
        let w = bound_warnings(&map, &params);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("spring_stiffness ended on its upper bound 5000 N/m (start 100)"));
    }
}
