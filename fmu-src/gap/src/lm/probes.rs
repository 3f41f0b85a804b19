//! Checks of a fit against the sum of squares itself: interval ends along the profile's
//! first-order path, the roughness of the sum (random ±1 patterns), smoothed residuals and
//! secant Jacobians for a rough sum.

use super::{residuals_at, to_p, weighted_sse, Bounded, Problem};
use crate::policy::{END_PROBES, MAX_END_WIDENING};
use crate::stats::sq;
use nalgebra::DMatrix;
use rayon::prelude::*;

/// The ends of the linearised intervals checked against the weighted sum of squares itself.
///
/// At a minimum `z` with covariance `cov` (in `z`, rows weighted by `w`), moving coordinate `j`
/// by `t` standard errors along `d_j = cov[:, j] / σ_j` (the others readjusting by their
/// regression on it, the first-order path of its profile) raises the sum by `t²` if the sum is
/// quadratic. Where it rises less (a flatter or bending valley, or a lower point: the fit stopped
/// short of the minimum), the end moves out to where the rise reaches `t²`, extrapolating the
/// measured rise (quadratically, or along the secant of the last two probes; at most doubling per
/// probe, at most [`MAX_END_WIDENING`] `t`).
/// Returns per coordinate the (lower, upper) multipliers of `σ_j`, each at least `t`: an interval
/// is only ever widened. A coordinate without a finite standard error keeps `t`; a failed
/// simulation ends that probe with the multiplier reached.
pub fn interval_ends<P: Problem>(
    problem: &P,
    b: &[Bounded],
    z: &[f64],
    r0: &[f64],
    w: &[f64],
    cov: &DMatrix<f64>,
    t: f64,
) -> Vec<(f64, f64)> {
    let m = z.len();
    let c0 = weighted_sse(r0, w);
    let side = |j: usize, sign: f64| -> f64 {
        let sd = cov[(j, j)].sqrt();
        if !(sd.is_finite() && sd > 0.0) || (0..m).any(|i| !cov[(i, j)].is_finite()) {
            return t;
        }
        let mut k = t;
        let mut last: Option<(f64, f64)> = None;
        for _ in 0..END_PROBES {
            let zz: Vec<f64> = (0..m)
                .map(|i| {
                    let (lo, hi) = b[i].z_bounds();
                    (z[i] + sign * k * cov[(i, j)] / sd).clamp(lo, hi)
                })
                .collect();
            let Some(r) = residuals_at(problem, b, &zz, r0.len()) else {
                break;
            };
            let rise = weighted_sse(&r, w) - c0;
            if rise >= t * t {
                // Past the end: back to where the rise crosses t², interpolated linearly in k²
                // from the last probe short of it (exact for a quadratic rise).
                if let Some((k1, r1)) = last {
                    let k2 = k1 * k1 + (t * t - r1) * (k * k - k1 * k1) / (rise - r1);
                    k = k2.sqrt().clamp(k1, k);
                }
                break;
            }
            if k >= MAX_END_WIDENING * t {
                break;
            }
            // Quadratic extrapolation from the start, or the secant through the last two probes
            // where it reaches further (a valley that keeps flattening), at most doubling.
            let quadratic = if rise > 0.0 {
                k * (t * t / rise).sqrt()
            } else {
                2.0 * k
            };
            let secant = last
                .filter(|&(k1, r1)| rise > r1 && k > k1)
                .map_or(0.0, |(k1, r1)| k + (t * t - rise) * (k - k1) / (rise - r1));
            last = Some((k, rise));
            k = quadratic.max(secant).min(2.0 * k).min(MAX_END_WIDENING * t);
        }
        k
    };
    (0..2 * m)
        .into_par_iter()
        .map(|q| side(q / 2, if q % 2 == 0 { -1.0 } else { 1.0 }))
        .collect::<Vec<f64>>()
        .chunks(2)
        .map(|c| (c[0], c[1]))
        .collect()
}

/// Roughness of the weighted sum of squares at `z`: the chi-square of the part of a move's
/// change that no slope explains. For `patterns` deterministic sign patterns `u` (coordinate `j`
/// moves by ±`h[j]`; one whose move would leave its bounds stays), the second difference
/// `d = r(z+u) + r(z−u) − 2 r(z)` cancels the linear part; what is left is the curvature over
/// the step (negligible for a tiny one) and the jumps a model with a quantised or switched signal
/// makes when a change flips one of its decisions, independent between the two sides, so
/// `‖W d‖²/2` estimates the chi-square of one such jump. `w` weighs each residual row. Returns the
/// mean over the patterns (0 for a smooth model, up to its solver's noise); a failed simulation
/// leaves its pattern out. Moré & Wild (2011), "Estimating computational noise", use the same
/// difference table for the noise of a simulation.
pub fn roughness<P: Problem>(
    problem: &P,
    b: &[Bounded],
    z: &[f64],
    r0: &[f64],
    w: &[f64],
    h: &[f64],
    patterns: usize,
) -> f64 {
    let vals: Vec<f64> = (0..patterns)
        .into_par_iter()
        .filter_map(|k| {
            let zp = mirrored(b, z, h, (k, 1.0), |_, _| 1.0);
            let zm = mirrored(b, z, h, (k, -1.0), |_, _| 1.0);
            let rp = problem.residuals(&to_p(b, &zp)).ok()?;
            let rm = problem.residuals(&to_p(b, &zm)).ok()?;
            if rp.len() != r0.len() || rm.len() != r0.len() {
                return None;
            }
            let c: f64 = (0..r0.len())
                .map(|i| sq(w[i] * (rp[i] + rm[i] - 2.0 * r0[i])))
                .sum();
            c.is_finite().then_some(0.5 * c)
        })
        .collect();
    if vals.is_empty() {
        0.0
    } else {
        vals.iter().sum::<f64>() / vals.len() as f64
    }
}

/// Sign `±1` of coordinate `j` in pattern `k`, from a fixed integer hash: the same on every
/// machine.
fn rademacher(k: usize, j: usize) -> f64 {
    let x = (k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (j as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    if (x >> 29) & 1 == 0 {
        1.0
    } else {
        -1.0
    }
}

/// A fraction in `[1/2, 1)` for coordinate `j` of pattern `k`, from another fixed integer
/// hash: with two coordinates there are only two sign patterns up to mirroring, so points
/// that must differ also differ in their magnitudes.
fn magnitude(k: usize, j: usize) -> f64 {
    let x = (k as u64 + 1).wrapping_mul(0xD6E8_FEB8_6659_FD93)
        ^ (j as u64 + 1).wrapping_mul(0x94D0_49BB_1331_11EB);
    0.5 + 0.5 * ((x >> 11) as f64 / (1u64 << 53) as f64)
}

/// The point `z + sign·u` of pattern `k`: coordinate `j` moves by `h[j]` times `scaled(k, j)`
/// with a sign from [`rademacher`] (times `sign`, ±1); one whose move would leave its bounds
/// either way stays, so `sign` ±1 give a mirrored pair.
fn mirrored(
    b: &[Bounded],
    z: &[f64],
    h: &[f64],
    (k, sign): (usize, f64),
    scaled: fn(usize, usize) -> f64,
) -> Vec<f64> {
    let mut point = z.to_vec();
    for j in 0..z.len() {
        let (lo, hi) = b[j].z_bounds();
        let d = h[j] * scaled(k, j);
        if d.is_finite() && z[j] - d >= lo && z[j] + d <= hi {
            point[j] += sign * d * rademacher(k, j);
        }
    }
    point
}

/// The residuals of a rough objective's smooth part at `z`: the mean of the residuals at the
/// `2·pairs` points `z ± u_k` of [`mirrored`]'s patterns (coordinate `j` moved by between
/// `h[j]/2` and `h[j]`, [`magnitude`]). The pairs cancel the linear part exactly and leave the
/// curvature over `h`, while a model with a quantised or switched signal carries, at each
/// point, the jumps of the decisions that step flipped: independent between points, so the mean carries `1/√(2·pairs)` of them
/// where the residuals at `z` alone carry all of their own (the centred simplex gradient's
/// averaging, Kelley 1999, "Iterative methods for optimization", §6.2). `None` when any point
/// fails to simulate.
pub fn smoothed_residuals<P: Problem>(
    problem: &P,
    b: &[Bounded],
    z: &[f64],
    h: &[f64],
    pairs: usize,
    len: usize,
) -> Option<Vec<f64>> {
    let points: Vec<Option<Vec<f64>>> = (0..2 * pairs)
        .into_par_iter()
        .map(|i| {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            residuals_at(
                problem,
                b,
                &mirrored(b, z, h, (i / 2, sign), magnitude),
                len,
            )
        })
        .collect();
    let mut mean = vec![0.0; len];
    for r in points {
        for (m, v) in mean.iter_mut().zip(r?) {
            *m += v;
        }
    }
    let count = (2 * pairs) as f64;
    mean.iter_mut().for_each(|m| *m /= count);
    Some(mean)
}

/// Jacobian of a rough objective (see [`roughness`]): each column is the secant over the
/// smallest step `h0·4^k` whose weighted change `‖W (r(z + h e_j) − r(z))‖²` reaches `target`
/// (a multiple of the roughness, so that a flipped decision is a small part of the column), at
/// most a quarter of the coordinate's span or 2 (a factor e² on a log coordinate). A step that
/// would leave the bounds is taken backwards. A parameter whose change never reaches `target`
/// keeps the secant of the longest step: a small column, so a wide interval.
pub fn secant_jacobian<P: Problem>(
    problem: &P,
    b: &[Bounded],
    z: &[f64],
    r0: &[f64],
    w: &[f64],
    h0: f64,
    target: f64,
) -> DMatrix<f64> {
    let n = r0.len();
    let cols: Vec<Vec<f64>> = (0..z.len())
        .into_par_iter()
        .map(|j| {
            let (lo, hi) = b[j].z_bounds();
            let span = hi - lo;
            let h_max = if span.is_finite() {
                (0.25 * span).min(2.0)
            } else {
                2.0
            };
            let mut h = (4.0 * h0).min(h_max);
            let mut best = vec![0.0; n];
            loop {
                let d = if z[j] + h <= hi { h } else { -h };
                let mut zz = z.to_vec();
                zz[j] = (z[j] + d).clamp(lo, hi);
                let step = zz[j] - z[j];
                if let Some(r) = residuals_at(problem, b, &zz, n).filter(|_| step != 0.0) {
                    let c: f64 = (0..n).map(|i| sq(w[i] * (r[i] - r0[i]))).sum();
                    best = r.iter().zip(r0).map(|(a, c0)| (a - c0) / step).collect();
                    if c >= target {
                        break;
                    }
                }
                if h >= h_max {
                    break;
                }
                h = (4.0 * h).min(h_max);
            }
            best
        })
        .collect();
    DMatrix::from_fn(n, z.len(), |i, j| cols[j][i])
}
