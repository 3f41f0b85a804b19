//! Intervals when the fit's sum of squares is rough: a model with a quantised or switched signal
//! in a loop (an encoder read in counts, a relay, a controller deciding on thresholds) changes
//! its outputs by a jump when a tiny parameter change flips one of its decisions. A
//! finite-difference Jacobian over a step of 1e-3 then measures those jumps instead of the
//! slope: the intervals come out far too narrow and miss the truth.
//!
//! At the final fit the roughness `F` (chi-square of one such jump, [`lm::roughness`]) is
//! measured over a step of 1e-3. When it matters, the Jacobian is rebuilt from secants over
//! steps whose change is well above it ([`lm::secant_jacobian`]), the roughness is measured again
//! with each parameter moved by its standard error (the scale of the intervals, where more
//! decisions flip), the larger of the two is `F`, and the 95 % half-width is widened from `1.96 σ` to
//! `(1.96 + √(2F)) σ`: the fit can only place the minimum of the smooth part to within where that
//! part rises by about the spread of the jumps (`2F`, two independent jumps), a distance
//! `√(2F) σ` in its own metric, which adds to the statistical `1.96 σ` (triangle inequality).
//!
//! Before that, the estimate itself is moved to the smooth part's minimum ([`recentre`]): on a
//! rough sum the fit stops at whichever local minimum a jump makes, anywhere the smooth part
//! lies within about a jump of its own minimum, so a change of the record or of the FMU's
//! tolerance far below the noise moved the reported values by half their intervals.
//!
//! Rough or smooth, each interval's ends are then checked against the sum of squares itself
//! ([`lm::interval_ends`]): along the first-order path of the parameter's profile, an end where
//! the sum rises less than the quadratic model says (a flatter or bending valley, or a fit that
//! stopped short of the minimum) moves out to where it rises by as much. A 95 % interval is thus
//! never narrower than its likelihood-ratio end along that path. The ends are then checked
//! against the profile itself where the valley is flat, bent or constrained by a bound
//! ([`super::ends`]: fits with the parameter held at the end).

use super::ends::{profile_ends, ProfileEnds};
use super::evidence::{covariance, row_weights};
use super::{Ctx, FitOut, FitProblem, Z95};
use crate::lm::{self, LmOptions};
use crate::sim::GridModel;
use nalgebra::{DMatrix, DVector};

/// Sign patterns probed for the roughness at each scale (two simulations each).
const PATTERNS: usize = 4;

/// Roughness below which the fit's own Jacobian and the usual `1.96 σ` stand: `√(2F)` below
/// 5 % of 1.96, a widening no reader would notice.
const NEGLIGIBLE: f64 = 0.5 * (0.05 * Z95) * (0.05 * Z95);

/// A secant's change must reach this multiple of the roughness, so that a jump is at most about
/// a fifth of the column's norm.
const SECANT_TARGET: f64 = 25.0;

/// The final fit's Jacobian and half-width multipliers for its intervals.
pub(super) struct IntervalBasis {
    pub fit: lm::LmFit,
    /// Per fitted parameter, the (lower, upper) multipliers of its standard error once the ends
    /// are checked against the sum of squares ([`lm::interval_ends`]; each at least `z`).
    pub ends: Vec<(f64, f64)>,
    /// The measured roughness (chi-square of one jump), when it mattered.
    pub roughness: Option<f64>,
    /// Every parameter's value at a point the profile search found clearly below the fit's sum
    /// ([`ProfileEnds`]): the fit stopped in a valley that is not the lowest.
    pub lower: Option<Vec<f64>>,
}

/// What [`recentre`] measured at a final fit it left where it stopped: the roughness over a
/// tiny step and, if it went on to compute it, the secant Jacobian. [`interval_basis`] at the
/// same point takes them instead of simulating them again.
pub(super) struct Measured {
    f0: f64,
    secant: Option<DMatrix<f64>>,
}

/// The roughness at the final fit over a step of the fit's finite-difference size.
fn tiny_step_roughness<S: GridModel + ?Sized>(
    problem: &FitProblem<'_, '_, S>,
    fin: &FitOut,
    w: &[f64],
) -> f64 {
    let h = LmOptions::default().fd_step;
    let m = fin.state.idx.len();
    let r0 = &fin.fit.residuals;
    lm::roughness(
        problem,
        &fin.bounds,
        &fin.fit.z,
        r0,
        w,
        &vec![h; m],
        PATTERNS,
    )
}

/// The secant Jacobian at the final fit for roughness `f0`: slopes over steps whose change
/// reaches [`SECANT_TARGET`] times it.
fn secants<S: GridModel + ?Sized>(
    problem: &FitProblem<'_, '_, S>,
    fin: &FitOut,
    w: &[f64],
    f0: f64,
) -> DMatrix<f64> {
    let h = LmOptions::default().fd_step;
    let (z, r0) = (&fin.fit.z, &fin.fit.residuals);
    lm::secant_jacobian(problem, &fin.bounds, z, r0, w, h, SECANT_TARGET * f0)
}

/// Measure the roughness at the final fit `fin` (over its `n_fin` samples, rows weighted by
/// `scale` per output; `measured`: what [`recentre`] already measured at this point) and, when
/// it matters, the Jacobian and multiplier that account for it.
pub(super) fn interval_basis<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: &FitOut,
    n_fin: usize,
    scale: &[f64],
    measured: Option<Measured>,
) -> IntervalBasis {
    let m = fin.state.idx.len();
    if m == 0 {
        return IntervalBasis {
            fit: fin.fit.clone(),
            ends: Vec::new(),
            roughness: None,
            lower: None,
        };
    }
    let problem = FitProblem::of(ctx, fin, n_fin);
    let r0 = &fin.fit.residuals;
    let w = row_weights(scale, n_fin, r0.len());
    let Measured { f0, secant } = measured.unwrap_or_else(|| Measured {
        f0: tiny_step_roughness(&problem, fin, &w),
        secant: None,
    });
    let (jac, z, roughness) = if f0 <= NEGLIGIBLE {
        (fin.fit.jac.clone(), Z95, None)
    } else {
        let jac = secant.unwrap_or_else(|| secants(&problem, fin, &w, f0));
        rough_jacobian(&problem, fin, n_fin, scale, &w, f0, jac)
    };
    let ends = match covariance(&jac, scale, n_fin) {
        Some(cov) => {
            let ends = lm::interval_ends(&problem, &fin.bounds, &fin.fit.z, r0, &w, &cov, z);
            profile_ends(ctx, fin, n_fin, &problem, &w, &cov, z, ends)
        }
        None => ProfileEnds {
            ends: vec![(z, z); m],
            lower: None,
        },
    };
    let ProfileEnds { ends, lower } = ends;
    IntervalBasis {
        fit: lm::LmFit {
            jac,
            ..fin.fit.clone()
        },
        ends,
        roughness,
        lower,
    }
}

/// Largest roughness at which the estimate is moved to the smooth part's minimum: jumps whose
/// spread `√(2F)` stays within the statistical `1.96 σ`. Beyond it the sum is more jumps than
/// slope, the secants' quadratic model no longer says where its minimum lies (on a trace with
/// `F` = 21 the step went down a flat valley and the profile ends from there missed the truth),
/// and the widened intervals are all the report can offer.
const RECENTRE_MAX: f64 = 0.5 * Z95 * Z95;

/// Marquardt dampings tried, in order, for the step to the smooth part's minimum: the
/// undamped Gauss–Newton step, then one shortened along poorly determined directions (a flat
/// valley's, where the undamped step overshoots to a bound).
const RECENTRE_DAMPING: [f64; 2] = [0.0, 1e-2];

/// The final fit `fin` moved to the minimum of the smooth part of a rough sum of squares:
/// from where the fit stopped, one Gauss–Newton step with the secant Jacobian (slopes over
/// steps well above the jumps, [`lm::secant_jacobian`]), i.e. the minimum of the quadratic
/// model of the smooth part. The step removes the smooth part's remaining slope, which is what
/// differs between two runs that stopped at different jumps; what remains is the jumps' own
/// projection on the slopes. The step is taken when the sum at the new point is within the
/// jumps' spread (`2F`) of the fit's: the point is then as good a fit as the jumps allow. A
/// step that fails that test, a smooth sum and one rougher than [`RECENTRE_MAX`] leave `fin`
/// as it is, returned with what was measured there ([`Measured`]; `None` once moved).
pub(super) fn recentre<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: FitOut,
    n_fin: usize,
    scale: &[f64],
) -> (FitOut, Option<Measured>) {
    if fin.state.idx.is_empty() {
        return (fin, None);
    }
    let problem = FitProblem::of(ctx, &fin, n_fin);
    let r0 = &fin.fit.residuals;
    let w = row_weights(scale, n_fin, r0.len());
    let f0 = tiny_step_roughness(&problem, &fin, &w);
    if f0 <= NEGLIGIBLE || f0 > RECENTRE_MAX {
        return (fin, Some(Measured { f0, secant: None }));
    }
    let jac = secants(&problem, &fin, &w, f0);
    let a = jac.transpose() * &jac;
    let g = jac.transpose() * DVector::from_column_slice(r0);
    for lambda in RECENTRE_DAMPING {
        let Some(z) = lm::damped_step(&a, &g, &fin.bounds, &fin.fit.z, lambda) else {
            continue;
        };
        let Some(r) = lm::residuals_at(&problem, &fin.bounds, &z, r0.len()) else {
            continue;
        };
        let sse = lm::sse(&r);
        if sse <= fin.fit.sse + 2.0 * f0 {
            ctx.stage(format!(
                "final fit: moved to the smooth part's minimum (roughness {f0:.3}), sum {sse:.1} against {:.1}",
                fin.fit.sse
            ));
            let p = lm::to_p(&fin.bounds, &z);
            let mut state = fin.state.clone();
            state.val = p.clone();
            let moved = FitOut {
                state,
                fit: lm::LmFit {
                    p,
                    z,
                    residuals: r,
                    sse,
                    jac,
                    jac_fresh: true,
                    ..fin.fit
                },
                bounds: fin.bounds,
            };
            return (moved, None);
        }
    }
    let secant = Some(jac);
    (fin, Some(Measured { f0, secant }))
}

/// On a rough sum of squares (roughness `f0` over a tiny step, secant Jacobian `jac`): the
/// Jacobian, the widened multiplier and the roughness `F` that sets it.
fn rough_jacobian<S: GridModel + ?Sized>(
    problem: &FitProblem<'_, '_, S>,
    fin: &FitOut,
    n_fin: usize,
    scale: &[f64],
    w: &[f64],
    f0: f64,
    jac: DMatrix<f64>,
) -> (DMatrix<f64>, f64, Option<f64>) {
    let (m, r0) = (fin.state.idx.len(), &fin.fit.residuals);
    // The same at the scale of the intervals: each coordinate moved by its standard error. A
    // jump there (and the curvature over that step) is what the quadratic model behind the
    // interval misses; a tiny step may flip no decision at all.
    let sd: Vec<f64> = covariance(&jac, scale, n_fin)
        .map(|c| (0..m).map(|j| c[(j, j)].max(0.0).sqrt()).collect())
        .unwrap_or_else(|| vec![f64::INFINITY; m]);
    let f1 = lm::roughness(problem, &fin.bounds, &fin.fit.z, r0, w, &sd, PATTERNS);
    let f = f0.max(f1);
    (jac, Z95 + (2.0 * f).sqrt(), Some(f))
}

/// The warning that tells the user the intervals account for a rough sum of squares.
pub(super) fn roughness_note(f: f64) -> String {
    format!(
        "The fit's sum of squares is rough: a change of the parameters (by 0.1 %, or by their standard errors) alters it by about {f:.3} (chi-square) that no slope explains, as a quantised or switched signal in the model does (an encoder read in counts, a threshold). The intervals use slopes over steps well above that and are widened to ±{:.2} standard errors instead of ±1.96",
        Z95 + (2.0 * f).sqrt()
    )
}
