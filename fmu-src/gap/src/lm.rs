//! Bounded Levenberg–Marquardt on a transformed parameter vector with a forward-difference
//! Jacobian whose columns are evaluated in parallel (rayon): one simulation per parameter; between
//! finite-difference Jacobians, Broyden rank-one updates save simulations.
//!
//! Each physical parameter `p` is mapped to an unbounded-looking coordinate `z`: `z = ln p` when
//! the parameter is positive and its range spans at least a decade (multiplicative uncertainty),
//! else `z = p / s` with `s` its typical size. Bounds are enforced by clamping `z` after each step
//! (a projected LM step); the damping is Marquardt's `λ diag(JᵀJ)` (Marquardt 1963), so the
//! choice of `s` only sets the finite-difference step.
//!
//! Why our own instead of the `levenberg-marquardt` crate: that crate has no bounds (the
//! parameters here have hardware ranges the fit must respect), evaluates its Jacobian through one
//! user callback (here every column is a whole FMU simulation, run in parallel), and has no
//! Broyden updates between Jacobians (which save a simulation per parameter per iteration).

use crate::sim::SimError;
use crate::stats::sq;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Coordinate map of one parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Coord {
    /// z = ln p
    Log,
    /// z = p / scale
    Linear(f64),
}

/// A parameter with its bounds and coordinate map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounded {
    pub lo: f64,
    pub hi: f64,
    pub coord: Coord,
}

impl Bounded {
    /// Choose the coordinate for a parameter from its start value and optional bounds.
    pub fn new(start: f64, min: Option<f64>, max: Option<f64>) -> Self {
        let lo = min.unwrap_or(f64::NEG_INFINITY);
        let hi = max.unwrap_or(f64::INFINITY);
        let log = lo > 0.0 && (hi / lo >= 10.0 || hi.is_infinite());
        let coord = if log {
            Coord::Log
        } else {
            let span = if lo.is_finite() && hi.is_finite() {
                hi - lo
            } else {
                0.0
            };
            let s = start.abs().max(1e-3 * span);
            Coord::Linear(if s > 0.0 { s } else { 1.0 })
        };
        Bounded { lo, hi, coord }
    }

    /// Physical value to coordinate.
    pub fn to_z(&self, p: f64) -> f64 {
        let p = p.clamp(self.lo, self.hi);
        match self.coord {
            Coord::Log => libm::log(p),
            Coord::Linear(s) => p / s,
        }
    }

    /// Coordinate to physical value (clamped into the bounds).
    pub fn to_p(&self, z: f64) -> f64 {
        let p = match self.coord {
            Coord::Log => libm::exp(z),
            Coord::Linear(s) => z * s,
        };
        p.clamp(self.lo, self.hi)
    }

    /// dp/dz at z (for the delta method).
    pub fn dp_dz(&self, z: f64) -> f64 {
        match self.coord {
            Coord::Log => libm::exp(z),
            Coord::Linear(s) => s,
        }
    }

    pub fn z_bounds(&self) -> (f64, f64) {
        match self.coord {
            Coord::Log => (libm::log(self.lo), libm::log(self.hi)),
            Coord::Linear(s) => (self.lo / s, self.hi / s),
        }
    }
}

/// A least-squares problem: weighted residuals (model − data) / σ for physical parameters.
pub trait Problem: Sync {
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError>;
}

/// Options of the fit.
#[derive(Clone, Copy, Debug)]
pub struct LmOptions {
    pub max_iter: usize,
    /// Stop when an accepted step made with a finite-difference Jacobian lowers the sum of
    /// squares by less than this fraction of it and by less than `abs_tol`.
    pub rel_tol: f64,
    /// Absolute floor of the stopping test (in units of the sum of squares; for residuals
    /// weighted by their noise level, 1 is one unit of chi-square, a tenth of the ΔBIC the gap
    /// workflow asks for): a fit crawling along a narrow valley by more than this per step goes on.
    pub abs_tol: f64,
    /// Forward-difference step in z.
    pub fd_step: f64,
    /// Accepted steps with Broyden-updated Jacobians between finite-difference ones.
    pub broyden_steps: usize,
    /// Print every iteration on stderr (for profiling).
    pub trace: bool,
    /// End with a finite-difference Jacobian at the optimum (else [`LmFit::jac`] may be a
    /// Broyden update; [`refresh_jacobian`] makes it one later, with the same values). A fit
    /// whose Jacobian nobody reads (a profile point, or one of rival fits until the winner is
    /// known) skips its `m` simulations.
    pub final_jacobian: bool,
    /// Give up once the fit cannot come down to this sum of squares within its iterations:
    /// from the third iteration on, when even `FUTILITY_FACTOR` times the decrease the undamped
    /// Gauss–Newton step predicts, gained in every iteration left, would leave the sum above it
    /// (a refit that cannot reach the evidence needed need not crawl on). `None`: never.
    pub futile_above: Option<f64>,
    /// Stop only at a point where the undamped Gauss–Newton step of a finite-difference
    /// Jacobian predicts a decrease of the sum below this ([`free_gauss_newton_decrease`]),
    /// when the steps' gains alone would stop the fit (`None`: the gains alone decide). With
    /// residuals weighted by their noise level the predicted decrease is the squared length of
    /// the remaining step in standard errors, which bounds every parameter's remaining move:
    /// `|Δz_j| ≤ √decrease · σ_j`. Small steps along a flat valley can each gain less than
    /// `abs_tol` while the minimum is still a whole interval away.
    pub converged_below: Option<f64>,
}

/// How many times the Gauss–Newton predicted decrease a fit may still gain per iteration left
/// before it is called futile. The quadratic model's decrease is what one step can gain near a
/// minimum; along a curved valley each step gains about that much again, and far from the
/// minimum a step can gain more; twice it leaves room for that.
pub const FUTILITY_FACTOR: f64 = 2.0;

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iter: 25,
            rel_tol: 1e-4,
            abs_tol: 0.0,
            fd_step: 1e-3,
            broyden_steps: 3,
            trace: false,
            final_jacobian: true,
            futile_above: None,
            converged_below: None,
        }
    }
}

/// Result of a fit. `jac` is the finite-difference d(residual)/dz at the optimum when
/// `jac_fresh` (always, unless `LmOptions::final_jacobian` was false).
#[derive(Clone, Debug)]
pub struct LmFit {
    pub p: Vec<f64>,
    pub z: Vec<f64>,
    pub residuals: Vec<f64>,
    pub sse: f64,
    pub jac: DMatrix<f64>,
    pub jac_fresh: bool,
    pub iterations: usize,
    pub evaluations: usize,
    /// The fit stopped because it could not reach `LmOptions::futile_above`.
    pub futile: bool,
}

/// Decrease of the sum of squares the undamped Gauss–Newton step predicts from the Jacobian
/// `jac` and residual `r`: `gᵀ (JᵀJ)⁻¹ g` with `g = Jᵀ r` (a pseudo-inverse for a singular
/// `JᵀJ`).
pub fn gauss_newton_decrease(jac: &DMatrix<f64>, r: &[f64]) -> f64 {
    let g = jac.transpose() * DVector::from_column_slice(r);
    let a = jac.transpose() * jac;
    let eps = 1e-12 * a.diagonal().amax().max(1e-300);
    match a.pseudo_inverse(eps) {
        Ok(inv) => g.dot(&(inv * &g)).max(0.0),
        Err(_) => f64::INFINITY,
    }
}

/// [`gauss_newton_decrease`] over the parameters free to move: a parameter at a bound whose
/// descent direction (`-g_j`, `g = Jᵀ r`) points out of its range is held there, as the
/// projected step holds it.
pub fn free_gauss_newton_decrease(jac: &DMatrix<f64>, r: &[f64], b: &[Bounded], z: &[f64]) -> f64 {
    let g = jac.transpose() * DVector::from_column_slice(r);
    let free: Vec<usize> = (0..z.len())
        .filter(|&j| {
            let (lo, hi) = b[j].z_bounds();
            !((z[j] <= lo && g[j] > 0.0) || (z[j] >= hi && g[j] < 0.0))
        })
        .collect();
    if free.is_empty() {
        return 0.0;
    }
    gauss_newton_decrease(&jac.select_columns(free.iter()), r)
}

/// Sum of squares of a residual vector.
pub fn sse(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Physical values of the coordinates `z`.
pub fn to_p(b: &[Bounded], z: &[f64]) -> Vec<f64> {
    b.iter().zip(z).map(|(b, &z)| b.to_p(z)).collect()
}

/// Coordinates of the physical values `p` (each clamped into its bounds first).
pub fn to_z(b: &[Bounded], p: &[f64]) -> Vec<f64> {
    b.iter().zip(p).map(|(b, &p)| b.to_z(p)).collect()
}

/// The residuals at the coordinates `z` when they are usable: the simulation ran and gave `len`
/// finite values (None otherwise).
pub fn residuals_at<P: Problem>(
    problem: &P,
    b: &[Bounded],
    z: &[f64],
    len: usize,
) -> Option<Vec<f64>> {
    problem
        .residuals(&to_p(b, z))
        .ok()
        .filter(|r| r.len() == len && r.iter().all(|v| v.is_finite()))
}

/// Sum of squares of the residuals `r` weighted row by row by `w`: `Σ (w_i r_i)²`.
pub fn weighted_sse(r: &[f64], w: &[f64]) -> f64 {
    r.iter().zip(w).map(|(r, w)| sq(w * r)).sum()
}

/// Forward-difference Jacobian d r / d z, columns in parallel. A step that would leave the bounds
/// or whose simulation fails is taken backwards; a column that fails both ways is zero.
pub fn jacobian<P: Problem>(
    problem: &P,
    b: &[Bounded],
    z: &[f64],
    r0: &[f64],
    h: f64,
) -> DMatrix<f64> {
    let n = r0.len();
    let cols: Vec<Vec<f64>> = (0..z.len())
        .into_par_iter()
        .map(|j| {
            let (zlo, zhi) = b[j].z_bounds();
            let dirs = if z[j] + h <= zhi { [h, -h] } else { [-h, h] };
            for d in dirs {
                let zj = z[j] + d;
                if zj < zlo || zj > zhi {
                    continue;
                }
                let mut zz = z.to_vec();
                zz[j] = zj;
                if let Some(r) = residuals_at(problem, b, &zz, n) {
                    return r.iter().zip(r0).map(|(a, c)| (a - c) / d).collect();
                }
            }
            vec![0.0; n]
        })
        .collect();
    DMatrix::from_fn(n, z.len(), |i, j| cols[j][i])
}

/// Make `fit.jac` the finite-difference Jacobian at its optimum if it is not already (a fit
/// run without `LmOptions::final_jacobian`): the same values that fit would have ended with
/// (`fd_step` as in its options).
pub fn refresh_jacobian<P: Problem>(problem: &P, b: &[Bounded], fit: &mut LmFit, fd_step: f64) {
    if fit.jac_fresh {
        return;
    }
    fit.evaluations += fit.z.len();
    fit.jac = jacobian(problem, b, &fit.z, &fit.residuals, fd_step);
    fit.jac_fresh = true;
}

/// Most an interval end is moved out by [`interval_ends`], in multiples of the linearised one.
pub const MAX_END_WIDENING: f64 = 4.0;

/// Probes of each interval end along the sum of squares.
const END_PROBES: usize = 4;

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

/// An evaluated trial point of the fit: its residuals and sum of squares, None when they are
/// not usable ([`residuals_at`]).
type Trial = Option<(Vec<f64>, f64)>;

fn trial<P: Problem>(problem: &P, b: &[Bounded], zn: &[f64], len: usize) -> Trial {
    residuals_at(problem, b, zn, len).map(|rn| {
        let sn = sse(&rn);
        (rn, sn)
    })
}

/// The damped Gauss–Newton point from `z` with damping `lambda` (normal matrix `a`, gradient
/// `g`), inside the bounds. Active set: a parameter at a bound whose step would leave the range
/// is held there and the step re-solved for the others, until no further one would leave (a
/// projected Newton step; clamping the full step instead rarely lowers the sum, and the
/// gradient sign alone would also hold a parameter that the coupled step moves inward, as along
/// the valley of two compensating parameters). `None` when the damped matrix is not positive
/// definite.
pub fn damped_step(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    b: &[Bounded],
    z: &[f64],
    lambda: f64,
) -> Option<Vec<f64>> {
    let m = z.len();
    let mut held = vec![false; m];
    let delta = loop {
        let mut mm = a.clone();
        let mut gg = g.clone();
        for k in 0..m {
            mm[(k, k)] += lambda * a[(k, k)].max(1e-12) + 1e-12;
        }
        for k in (0..m).filter(|&k| held[k]) {
            #[allow(clippy::needless_range_loop)]
            for j in 0..m {
                mm[(k, j)] = 0.0;
                mm[(j, k)] = 0.0;
            }
            mm[(k, k)] = 1.0;
            gg[k] = 0.0;
        }
        let ch = mm.cholesky()?;
        let d = ch.solve(&(-&gg));
        let mut more = false;
        for k in 0..m {
            let (lo, hi) = b[k].z_bounds();
            if !held[k] && ((z[k] <= lo && d[k] < 0.0) || (z[k] >= hi && d[k] > 0.0)) {
                held[k] = true;
                more = true;
            }
        }
        if !more {
            break d;
        }
    };
    Some(
        (0..m)
            .map(|k| {
                let (lo, hi) = b[k].z_bounds();
                (z[k] + delta[k]).clamp(lo, hi)
            })
            .collect(),
    )
}

/// Minimise Σ r² over the bounded parameters starting at `p0`. `tick` is called once per
/// iteration (progress reporting).
pub fn levenberg_marquardt<P: Problem>(
    problem: &P,
    b: &[Bounded],
    p0: &[f64],
    opts: LmOptions,
    tick: &(dyn Fn() + Sync),
) -> Result<LmFit, SimError> {
    let m = p0.len();
    let mut z = to_z(b, p0);
    let mut r = problem.residuals(&to_p(b, &z))?;
    if r.iter().any(|v| !v.is_finite()) {
        return Err(SimError::NonFiniteStart);
    }
    let mut s = sse(&r);
    let mut evaluations = 1;
    let mut jac = if m > 0 {
        evaluations += m;
        jacobian(problem, b, &z, &r, opts.fd_step)
    } else {
        DMatrix::zeros(r.len(), 0)
    };
    let trace = opts.trace;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    // `fresh`: `jac` is a finite-difference Jacobian at `z` (else a Broyden update of one).
    let mut fresh = true;
    let mut since_fd = 0;
    let mut futile = false;
    while m > 0 && iterations < opts.max_iter {
        iterations += 1;
        tick();
        let a = jac.transpose() * &jac;
        let g = jac.transpose() * DVector::from_column_slice(&r);
        let mut accepted = None;
        let tries = if fresh { 12 } else { 3 };
        // A trial evaluated ahead (see below): its damping, point and result.
        let mut ahead: Option<(f64, Vec<f64>, Trial)> = None;
        for attempt in 0..tries {
            let Some(zn) = damped_step(&a, &g, b, &z, lambda) else {
                lambda *= 10.0;
                continue;
            };
            if zn == z {
                break;
            }
            evaluations += 1;
            let result = match ahead.take() {
                Some((l, za, t)) if l == lambda && za == zn => t,
                _ => {
                    // While this trial runs, the one a rejection would try next (damping ×4)
                    // runs on an idle thread, if there is one: the sequence of trials, and so
                    // the fit, is the same as one at a time. It is skipped once this trial is
                    // accepted before it starts.
                    let next = (attempt + 1 < tries && lambda * 4.0 <= 1e12)
                        .then(|| damped_step(&a, &g, b, &z, lambda * 4.0))
                        .flatten()
                        .filter(|zb| *zb != z);
                    let done = AtomicBool::new(false);
                    let (t, tb) = rayon::join(
                        || {
                            let t = trial(problem, b, &zn, r.len());
                            if t.as_ref().is_some_and(|(_, sn)| *sn < s) {
                                done.store(true, Ordering::SeqCst);
                            }
                            t
                        },
                        || {
                            let zb = next.as_ref()?;
                            (!done.load(Ordering::SeqCst)).then(|| trial(problem, b, zb, r.len()))
                        },
                    );
                    if let (Some(zb), Some(tb)) = (next, tb) {
                        ahead = Some((lambda * 4.0, zb, tb));
                    }
                    t
                }
            };
            match result {
                Some((rn, sn)) => {
                    if sn < s {
                        lambda = (lambda / 3.0).max(1e-9);
                        accepted = Some((zn, rn, sn));
                        break;
                    }
                    lambda *= 4.0;
                }
                None => lambda *= 10.0,
            }
            if lambda > 1e12 {
                break;
            }
        }
        let Some((zn, rn, sn)) = accepted else {
            if fresh {
                break;
            }
            // The updated Jacobian led nowhere: take a finite-difference one and retry.
            evaluations += m;
            jac = jacobian(problem, b, &z, &r, opts.fd_step);
            fresh = true;
            since_fd = 0;
            continue;
        };
        let rel = (s - sn) / s.max(1e-300);
        if trace {
            eprintln!(
                "[lm] iteration {iterations}: sum {s:.1} -> {sn:.1}, p = {:?}",
                to_p(b, &zn)
            );
        }
        // Broyden's rank-one update J += (Δr − J Δz) Δzᵀ / (Δzᵀ Δz) (Broyden 1965).
        let dz = DVector::from_iterator(m, zn.iter().zip(&z).map(|(a, b)| a - b));
        let dr = DVector::from_iterator(r.len(), rn.iter().zip(&r).map(|(a, b)| a - b));
        let den = dz.dot(&dz);
        if den > 0.0 {
            let u = (dr - &jac * &dz) / den;
            jac += u * dz.transpose();
        }
        let was_fresh = fresh;
        fresh = false;
        since_fd += 1;
        z = zn;
        r = rn;
        let s_prev = s;
        s = sn;
        if rel < opts.rel_tol && s_prev - s < opts.abs_tol {
            if was_fresh {
                let Some(target) = opts.converged_below else {
                    break;
                };
                // The gains say stop; the step still predicted from here decides.
                evaluations += m;
                jac = jacobian(problem, b, &z, &r, opts.fd_step);
                fresh = true;
                since_fd = 0;
                if free_gauss_newton_decrease(&jac, &r, b, &z) < target {
                    break;
                }
                continue;
            }
            // A small gain with an updated Jacobian may be the update's fault: refresh it.
            since_fd = opts.broyden_steps;
        }
        if since_fd >= opts.broyden_steps {
            evaluations += m;
            jac = jacobian(problem, b, &z, &r, opts.fd_step);
            fresh = true;
            since_fd = 0;
        }
        if let Some(target) = opts.futile_above {
            let left = opts.max_iter.saturating_sub(iterations) as f64;
            let reach = FUTILITY_FACTOR * left * gauss_newton_decrease(&jac, &r);
            if iterations >= 3 && s - reach > target {
                futile = true;
                break;
            }
        }
    }
    let mut fit = LmFit {
        p: to_p(b, &z),
        z,
        residuals: r,
        sse: s,
        jac,
        jac_fresh: fresh,
        iterations,
        evaluations,
        futile,
    };
    if opts.final_jacobian {
        // Intervals and screening need the Jacobian at the optimum.
        refresh_jacobian(problem, b, &mut fit, opts.fd_step);
    }
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::{
        interval_ends, jacobian, levenberg_marquardt, refresh_jacobian, roughness, secant_jacobian,
        smoothed_residuals, to_p, Bounded, Coord, LmOptions, Problem, MAX_END_WIDENING,
    };
    use crate::sim::SimError;
    use crate::stats::sq;
    use nalgebra::DMatrix;

    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
    }
    impl Problem for Decay {
        fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
            Ok(self
                .t
                .iter()
                .zip(&self.y)
                .map(|(t, y)| p[0] * libm::exp(-p[1] * t) + p[2] - y)
                .collect())
        }
    }

    /// Bounds of the decay's amplitude (linear), rate (logarithmic) and offset (linear).
    fn decay_bounds() -> [Bounded; 3] {
        [
            Bounded::new(1.0, Some(0.0), Some(10.0)),
            Bounded::new(0.2, Some(0.01), Some(100.0)),
            Bounded::new(0.0, Some(-5.0), Some(5.0)),
        ]
    }

    #[test]
    fn fits_an_exponential_decay_from_a_poor_start() {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
        let y = t.iter().map(|t| 2.5 * libm::exp(-1.3 * t) + 0.4).collect();
        let pr = Decay { t, y };
        let b = decay_bounds();
        assert_eq!(b[1].coord, Coord::Log);
        let fit = levenberg_marquardt(
            &pr,
            &b,
            &[1.0, 0.2, 0.0],
            LmOptions {
                rel_tol: 1e-12,
                ..Default::default()
            },
            &|| {},
        )
        .unwrap();
        assert!((fit.p[0] - 2.5).abs() < 1e-4, "{:?}", fit.p);
        assert!((fit.p[1] - 1.3).abs() < 1e-4, "{:?}", fit.p);
        assert!((fit.p[2] - 0.4).abs() < 1e-4, "{:?}", fit.p);
    }

    /// A fit ended without its Jacobian and refreshed later is the fit that ended with it: the
    /// same point, the same Jacobian, the same count of evaluations. The data are noisy so that
    /// the fit stops on an updated (Broyden) Jacobian, the case in which the two differ.
    #[test]
    fn a_jacobian_made_later_is_the_one_the_fit_would_have_ended_with() {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
        let y = t
            .iter()
            .enumerate()
            .map(|(i, t)| 2.5 * libm::exp(-1.3 * t) + 0.4 + 0.01 * ((i * 7919) % 13) as f64)
            .collect();
        let pr = Decay { t, y };
        let b = decay_bounds();
        let fit = |final_jacobian| {
            let opts = LmOptions {
                max_iter: 6,
                final_jacobian,
                ..Default::default()
            };
            levenberg_marquardt(&pr, &b, &[1.0, 0.2, 0.0], opts, &|| {}).unwrap()
        };
        let (with, mut later) = (fit(true), fit(false));
        assert!(
            with.jac_fresh && !later.jac_fresh,
            "the fit ended on a fresh Jacobian"
        );
        assert_ne!(with.jac, later.jac);
        refresh_jacobian(&pr, &b, &mut later, LmOptions::default().fd_step);
        assert!(later.jac_fresh);
        assert_eq!((&with.z, &with.jac), (&later.z, &later.jac));
        assert_eq!(with.evaluations, later.evaluations);
    }

    #[test]
    fn respects_bounds() {
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.1).collect();
        let y = t.iter().map(|t| 8.0 * libm::exp(-0.5 * t)).collect();
        let pr = Decay { t, y };
        let b = [
            Bounded::new(1.0, Some(0.0), Some(5.0)),
            Bounded::new(0.5, Some(0.01), Some(100.0)),
            Bounded::new(0.0, Some(-5.0), Some(5.0)),
        ];
        let fit =
            levenberg_marquardt(&pr, &b, &[1.0, 0.5, 0.0], LmOptions::default(), &|| {}).unwrap();
        assert!(fit.p[0] <= 5.0 && fit.p[0] > 4.9, "{:?}", fit.p);
    }

    /// A fit asked to come below a sum it cannot reach (the exponential decay with noise-free
    /// data reaches 0; with a constant offset of the data it cannot go below the offset's sum)
    /// gives up after three iterations and says so; one whose target is reachable runs on to
    /// its optimum.
    #[test]
    fn gives_up_on_an_unreachable_sum_and_only_then() {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
        // Data = decay + a step the model cannot follow: the best sum is about 200 * 0.25.
        let y: Vec<f64> = t
            .iter()
            .map(|t| 2.5 * libm::exp(-1.3 * t) + 0.4 + if *t > 5.0 { 0.5 } else { 0.0 })
            .collect();
        let pr = Decay { t, y };
        let b = decay_bounds();
        let opts = LmOptions {
            rel_tol: 1e-12,
            max_iter: 50,
            ..Default::default()
        };
        let free = levenberg_marquardt(&pr, &b, &[1.0, 0.2, 0.0], opts, &|| {}).unwrap();
        assert!(!free.futile);
        let futile = levenberg_marquardt(
            &pr,
            &b,
            &[1.0, 0.2, 0.0],
            LmOptions {
                futile_above: Some(0.5 * free.sse),
                ..opts
            },
            &|| {},
        )
        .unwrap();
        assert!(
            futile.futile && futile.iterations < free.iterations,
            "{futile:?}"
        );
        let reachable = levenberg_marquardt(
            &pr,
            &b,
            &[1.0, 0.2, 0.0],
            LmOptions {
                futile_above: Some(1.01 * free.sse),
                ..opts
            },
            &|| {},
        )
        .unwrap();
        assert!(!reachable.futile, "{reachable:?}");
        assert!((reachable.sse - free.sse).abs() < 1e-6 * free.sse);
    }

    struct Line {
        t: Vec<f64>,
        y: Vec<f64>,
    }
    impl Problem for Line {
        fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
            Ok(self
                .t
                .iter()
                .zip(&self.y)
                .map(|(t, y)| p[0] + p[1] * t - y)
                .collect())
        }
    }

    /// Data on the line `-1 + 2 t` fitted with the intercept bounded to `[0, 10]`: the
    /// constrained least-squares optimum (closed form) is intercept 0 and slope
    /// `sum(t y) / sum(t^2)`. The intercept reaches its bound in the first steps and the slope
    /// must keep moving there (the active set); the clamped step alone stalls the fit.
    #[test]
    fn parameter_held_at_its_bound_while_the_others_converge() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| -1.0 + 2.0 * t).collect();
        let slope = t.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>()
            / t.iter().map(|a| a * a).sum::<f64>();
        let pr = Line { t, y };
        let b = [
            Bounded::new(1.0, Some(0.0), Some(10.0)),
            Bounded::new(0.5, None, None),
        ];
        let fit = levenberg_marquardt(
            &pr,
            &b,
            &[1.0, 0.5],
            LmOptions {
                rel_tol: 1e-10,
                ..Default::default()
            },
            &|| {},
        )
        .unwrap();
        assert_eq!(fit.p[0], 0.0, "{:?}", fit.p);
        assert!(
            (fit.p[1] - slope).abs() < 1e-6 * slope,
            "{:?} vs slope {slope}",
            fit.p
        );
    }

    /// A line `a t + b` whose outputs pass through a quantiser of step `q` before they are
    /// compared (as a loop closed on an encoder count): rough in `a` and `b` at scales below `q`.
    struct Stairs {
        t: Vec<f64>,
        y: Vec<f64>,
        q: f64,
    }
    impl Problem for Stairs {
        fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
            Ok(self
                .t
                .iter()
                .zip(&self.y)
                .map(|(t, y)| {
                    let v = p[0] * t + p[1];
                    (if self.q > 0.0 {
                        (v / self.q).floor() * self.q
                    } else {
                        v
                    }) - y
                })
                .collect())
        }
    }

    fn stairs(q: f64) -> (Stairs, Vec<Bounded>, Vec<f64>, Vec<f64>) {
        // 2/203 per sample: the samples sit at spread positions within a quantiser step.
        let t: Vec<f64> = (0..200).map(|i| i as f64 / 203.0).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * t + 1.0).collect();
        let b = vec![
            Bounded::new(2.0, Some(0.1), Some(20.0)),
            Bounded::new(1.0, Some(0.1), Some(10.0)),
        ];
        let z: Vec<f64> = b.iter().zip([2.0, 1.0]).map(|(b, p)| b.to_z(p)).collect();
        let pr = Stairs { t, y, q };
        let r0 = pr.residuals(&to_p(&b, &z)).unwrap();
        (pr, b, z, r0)
    }

    #[test]
    fn a_smooth_sum_of_squares_has_no_roughness_and_its_secants_are_its_slopes() {
        let (pr, b, z, r0) = stairs(0.0);
        let w = vec![1.0; r0.len()];
        // What is left is the curvature of exp over the step (ln coordinates): about 1e-10.
        assert!(roughness(&pr, &b, &z, &r0, &w, &[1e-3; 2], 3) < 1e-8);
        let fd = jacobian(&pr, &b, &z, &r0, 1e-3);
        let sec = secant_jacobian(&pr, &b, &z, &r0, &w, 1e-3, 1.0);
        // Linear in p, ln-coordinates: the secant over a longer step differs from the slope by
        // the curvature of exp only; both are within a few per cent of the analytic column.
        for i in 0..r0.len() {
            let exact0 = 2.0 * pr.t[i];
            assert!((fd[(i, 0)] - exact0).abs() <= 2e-3 * exact0.abs() + 1e-12);
            assert!((sec[(i, 0)] - exact0).abs() <= 0.1 * exact0.abs() + 1e-12);
        }
    }

    #[test]
    fn a_quantised_sum_of_squares_is_measured_rough_and_secants_see_the_slope_not_the_jumps() {
        let q = 0.01;
        let (pr, b, z, r0) = stairs(q);
        let w = vec![1.0 / q; r0.len()];
        let f = roughness(&pr, &b, &z, &r0, &w, &[1e-3; 2], 3);
        // A 0.1 % change of the line moves it by up to 0.003 = 0.3 q: a share of the samples
        // flips by one step q (chi-square 1 each in units of q; 39 measured).
        assert!(f > 10.0 && f < 200.0, "roughness {f}");
        let fd = jacobian(&pr, &b, &z, &r0, 1e-3);
        let sec = secant_jacobian(&pr, &b, &z, &r0, &w, 1e-3, 25.0 * f);
        // Column of b (z = ln b, slope b = 1 per unit z): the finite difference sees jumps of q
        // over a step of 1e-3, three times the slope; the secant is within a quarter of it.
        let norm = |m: &DMatrix<f64>| m.column(1).norm() / (r0.len() as f64).sqrt();
        assert!(norm(&fd) > 2.0, "finite difference {}", norm(&fd));
        assert!((norm(&sec) - 1.0).abs() < 0.25, "secant {}", norm(&sec));
    }

    #[test]
    fn smoothed_residuals_keep_a_smooth_line_and_average_a_quantisers_jumps() {
        let h = [0.0237, 0.0237];
        let (pr, b, z, r0) = stairs(0.0);
        let smooth = smoothed_residuals(&pr, &b, &z, &h, 8, r0.len()).unwrap();
        // Linear in p on ln coordinates: the mirrored pairs cancel the slope; what is left is
        // the curvature of exp over h, h²/2 of the slope.
        for i in 0..r0.len() {
            let slopes = 2.0 * pr.t[i] + 1.0;
            assert!((smooth[i] - r0[i]).abs() <= h[0] * h[0] * slopes, "row {i}");
        }
        // Quantised by q: each point's residual is the line's (0 at the truth) plus the
        // quantiser's error in [−q, 0), mean −q/2. Steps of 2.4 % move the line by 2.4 q and more,
        // so each of the 16 points carries its own error and their mean's spread about −q/2 is
        // about a quarter of one point's.
        let q = 0.01;
        let (pr, b, z, r0) = stairs(q);
        let smooth = smoothed_residuals(&pr, &b, &z, &h, 8, r0.len()).unwrap();
        let spread = |r: &[f64]| r.iter().map(|v| sq(v + 0.5 * q)).sum::<f64>().sqrt();
        assert!(
            spread(&smooth) < 0.4 * spread(&r0),
            "{} against {}",
            spread(&smooth),
            spread(&r0)
        );
    }

    /// One residual `a f(p − c)` in a linear coordinate (z = p).
    struct Valley {
        a: f64,
        c: f64,
        f: fn(f64) -> f64,
    }
    impl Problem for Valley {
        fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
            Ok(vec![self.a * (self.f)(p[0] - self.c)])
        }
    }

    fn ends(v: &Valley, t: f64) -> (f64, f64) {
        let b = [Bounded {
            lo: -100.0,
            hi: 100.0,
            coord: Coord::Linear(1.0),
        }];
        let r0 = v.residuals(&[0.0]).unwrap();
        // Covariance of the quadratic model at p = 0: 1 / (a f'(0))² with f'(0) = 1.
        let cov = DMatrix::from_element(1, 1, 1.0 / (v.a * v.a));
        interval_ends(v, &b, &[0.0], &r0, &[1.0], &cov, t)[0]
    }

    #[test]
    fn interval_ends_of_a_quadratic_sum_stay_and_of_a_flattening_one_move_out() {
        // Quadratic: the rise at t standard errors is t²; nothing moves.
        let (lo, hi) = ends(
            &Valley {
                a: 2.0,
                c: 0.0,
                f: |x| x,
            },
            Z,
        );
        assert!(
            (lo - Z).abs() < 1e-12 && (hi - Z).abs() < 1e-12,
            "{lo} {hi}"
        );
        // 4 tanh²(p) rises to 3.84 at p = atanh(0.98) = 2.298, 4.60 standard errors (σ = 0.5);
        // the linearised end 1.96 σ rises only to 2.27.
        let exact = libm::atanh(0.98_f64) / 0.5;
        let (lo, hi) = ends(
            &Valley {
                a: 2.0,
                c: 0.0,
                f: libm::tanh,
            },
            Z,
        );
        for k in [lo, hi] {
            assert!(
                k > 0.85 * exact && k <= MAX_END_WIDENING * Z,
                "{k} against {exact}"
            );
        }
    }

    #[test]
    fn an_interval_end_beyond_a_lower_point_moves_out_on_that_side_only() {
        // The fit stopped at p = 0 short of the minimum at 0.3 (σ = 0.5): upwards the sum first
        // falls, downwards it rises faster than t².
        let (lo, hi) = ends(
            &Valley {
                a: 2.0,
                c: 0.3,
                f: |x| x,
            },
            Z,
        );
        assert_eq!(lo, Z);
        // Exact upper end: 4 (p − 0.3)² − 0.36 = 3.84 at p = 1.325, 2.65 standard errors.
        assert!(hi > 2.6 && hi < 2.8, "{hi}");
    }

    const Z: f64 = 1.96;
}
