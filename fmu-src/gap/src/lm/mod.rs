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

use crate::policy::{BROYDEN_STEPS, FD_STEP, FUTILITY_FACTOR, FUTILITY_MIN_ITERATIONS};
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

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iter: 25,
            rel_tol: 1e-4,
            abs_tol: 0.0,
            fd_step: FD_STEP,
            broyden_steps: BROYDEN_STEPS,
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

mod probes;
pub use probes::{interval_ends, roughness, secant_jacobian, smoothed_residuals};

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
            if iterations >= FUTILITY_MIN_ITERATIONS && s - reach > target {
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
mod tests;
