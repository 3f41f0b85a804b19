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
//! tolerance far below the noise moved the reported values by half their intervals. The
//! smooth part's residuals near a point are the mean over mirrored points around it
//! ([`lm::smoothed_residuals`]; 16 points, 64 on a sum whose jumps outgrow the statistical
//! half-width), which averages their jumps, and Gauss–Newton steps on them end where two runs
//! that stopped at different jumps agree.
//!
//! Rough or smooth, each interval's ends are then checked against the sum of squares itself
//! ([`lm::interval_ends`]): along the first-order path of the parameter's profile, an end where
//! the sum rises less than the quadratic model says (a flatter or bending valley, or a fit that
//! stopped short of the minimum) moves out to where it rises by as much. A 95 % interval is thus
//! never narrower than its likelihood-ratio end along that path. The ends are then checked
//! against the profile itself where the valley is flat, bent or constrained by a bound
//! ([`super::ends`]: fits with the parameter held at the end). A held fit that ends below the
//! fit shows that the fit stopped in a valley that is not the lowest, and the final fit is made
//! again from there; on a rough sum only when the point lies below on the smooth part as well
//! ([`clearly_lower`]).

use super::ends::{profile_ends, ProfileEnds};
use super::evidence::{covariance, row_weights};
use super::{Ctx, FitOut, FitProblem, Z95};
use crate::lm::{self, LmOptions};
use crate::policy::{
    LOWER_BY, LOWER_SPREADS, MAX_SMOOTHING_STEP, MILD_ROUGHNESS, NEGLIGIBLE_ROUGHNESS,
    RECENTRE_CONVERGED, RECENTRE_STEPS, RECENTRE_TRIALS, ROUGHNESS_PATTERNS, ROUGH_SMOOTHING_PAIRS,
    SECANT_TARGET, SMOOTHING_PAIRS, SMOOTHING_SPREAD,
};
use crate::sim::GridModel;
use nalgebra::{DMatrix, DVector};

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
        ROUGHNESS_PATTERNS,
    )
}

/// The secant Jacobian at `z` (residuals `r0` there) for roughness `f0`: slopes over steps
/// whose change reaches [`SECANT_TARGET`] times it.
fn secants<S: GridModel + ?Sized>(
    problem: &FitProblem<'_, '_, S>,
    bounds: &[lm::Bounded],
    (z, r0): (&[f64], &[f64]),
    w: &[f64],
    f0: f64,
) -> DMatrix<f64> {
    let h = LmOptions::default().fd_step;
    lm::secant_jacobian(problem, bounds, z, r0, w, h, SECANT_TARGET * f0)
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
    let (jac, z, roughness) = if f0 <= NEGLIGIBLE_ROUGHNESS {
        (fin.fit.jac.clone(), Z95, None)
    } else {
        let at = (fin.fit.z.as_slice(), fin.fit.residuals.as_slice());
        let jac = secant.unwrap_or_else(|| secants(&problem, &fin.bounds, at, &w, f0));
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
    let lower = lower.and_then(|(rise, values)| match roughness {
        None => Some(values),
        Some(f) => {
            let smoothing = (&jac, scale, n_fin);
            clearly_lower(ctx, &problem, fin, smoothing, (rise, values), f)
        }
    });
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

/// `point` (its raw rise above the fit `fin`'s sum, negative, and every parameter's value),
/// where a held fit of the profile search ended, if it lies below the fit on the smooth part of
/// a sum of roughness `f`. Its raw sum can gain by where the jumps fall alone; the widened
/// intervals' own rule for that, `t² − 1.96²` (15.3 chi-square units on that record), let a
/// point 10 units below stand unexplored, and the fit then ended in one valley or the other of
/// a spring stiffness / string compliance trade-off as a change of the FMU's tolerance decided.
/// The smoothed sums ([`lm::smoothed_residuals`], spreads `smoothing`: the secant Jacobian,
/// the output scale and the sample count; `n` points, [`smoothing_pairs`]) carry about `F / n`
/// of each point's jumps, which moves a sum by its cross term with the residuals, `2 √(F / n)`
/// at one standard deviation, and their difference by `√2` times that; the point counts when it
/// lies [`LOWER_SPREADS`] such spreads (at least [`LOWER_BY`], the rule of a smooth sum) below.
fn clearly_lower<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    problem: &FitProblem<'_, '_, S>,
    fin: &FitOut,
    (jac, scale, n_fin): (&DMatrix<f64>, &[f64], usize),
    (rise, values): (f64, Vec<f64>),
    f: f64,
) -> Option<Vec<f64>> {
    let h = smoothing_steps(jac, scale, n_fin);
    let len = fin.fit.residuals.len();
    let pairs = smoothing_pairs(f);
    let low = Smooth::at(
        problem,
        &fin.bounds,
        lm::to_z(&fin.bounds, &values),
        (&h, pairs),
        len,
    )?;
    let here = Smooth::at(problem, &fin.bounds, fin.fit.z.clone(), (&h, pairs), len)?;
    let points = (2 * pairs) as f64;
    let spread = std::f64::consts::SQRT_2 * 2.0 * (f / points).sqrt();
    let margin = (LOWER_SPREADS * spread).max(LOWER_BY);
    let drop = here.ssq - low.ssq;
    ctx.stage(format!(
        "profile search: a held fit ended {:.1} below the fit; on the smooth part {drop:.1} (needed {margin:.1})",
        -rise
    ));
    (drop > margin).then_some(values)
}

/// Mirrored pairs averaged for the smooth part of a sum of roughness `f`.
fn smoothing_pairs(f: f64) -> usize {
    if f > MILD_ROUGHNESS {
        ROUGH_SMOOTHING_PAIRS
    } else {
        SMOOTHING_PAIRS
    }
}

/// The smooth part of a rough sum near one point: its residuals there and their sum.
struct Smooth {
    z: Vec<f64>,
    r: DVector<f64>,
    ssq: f64,
}

impl Smooth {
    fn at<S: GridModel + ?Sized>(
        problem: &FitProblem<'_, '_, S>,
        bounds: &[lm::Bounded],
        z: Vec<f64>,
        (h, pairs): (&[f64], usize),
        len: usize,
    ) -> Option<Self> {
        let r = lm::smoothed_residuals(problem, bounds, &z, h, pairs, len)?;
        let r = DVector::from_vec(r);
        let ssq = r.norm_squared();
        Some(Self { z, r, ssq })
    }

    /// The point `fraction` of the way to the minimum of the model `r + J (z' − z)` inside the
    /// bounds with Marquardt damping `lambda`, and the decrease the model predicts there.
    fn step(
        &self,
        jac: &DMatrix<f64>,
        bounds: &[lm::Bounded],
        (lambda, fraction): (f64, f64),
    ) -> Option<(Vec<f64>, f64)> {
        let a = jac.transpose() * jac;
        let g = jac.transpose() * &self.r;
        let full = lm::damped_step(&a, &g, bounds, &self.z, lambda)?;
        let zn: Vec<f64> = full
            .iter()
            .zip(&self.z)
            .map(|(f, z)| z + fraction * (f - z))
            .collect();
        let dz = DVector::from_iterator(zn.len(), zn.iter().zip(&self.z).map(|(a, b)| a - b));
        let predicted = self.ssq - (&self.r + jac * dz).norm_squared();
        Some((zn, predicted))
    }
}

/// The final fit `fin` moved to the minimum of the smooth part of a rough sum of squares. On a
/// rough sum the fit stops at whichever local minimum a jump makes, anywhere the smooth part
/// lies within about a jump of its own minimum, so a change of the record or of the FMU's
/// tolerance far below the noise moved the reported values by half their intervals; and one
/// Gauss–Newton step from there carries the jumps of the point it starts from. Here the
/// residuals of the smooth part are the mean over mirrored points a quarter of a standard error
/// around ([`lm::smoothed_residuals`]), its slopes the secants over steps well above the jumps
/// ([`lm::secant_jacobian`]), and Gauss–Newton steps on that model ([`RECENTRE_TRIALS`], each
/// taken when the smooth part's sum falls) go on until it predicts less than
/// [`RECENTRE_CONVERGED`] to gain, or for [`RECENTRE_STEPS`]; the rougher the sum, the more
/// points its smooth part averages ([`smoothing_pairs`]). A smooth sum and a fit no step moved
/// leave `fin` as it is, returned with what was measured there ([`Measured`]; `None` once
/// moved).
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
    let len = fin.fit.residuals.len();
    let w = row_weights(scale, n_fin, len);
    let f0 = tiny_step_roughness(&problem, &fin, &w);
    if f0 <= NEGLIGIBLE_ROUGHNESS {
        ctx.stage(format!(
            "final fit: roughness {f0:.3} over a tiny step; left where it stopped"
        ));
        return (fin, Some(Measured { f0, secant: None }));
    }
    let at = (fin.fit.z.as_slice(), fin.fit.residuals.as_slice());
    let jac0 = secants(&problem, &fin.bounds, at, &w, f0);
    let h = smoothing_steps(&jac0, scale, n_fin);
    let smoothing = (h.as_slice(), smoothing_pairs(f0));
    let descent = Smooth::at(&problem, &fin.bounds, fin.fit.z.clone(), smoothing, len)
        .map(|start| {
            descend(
                &problem,
                &fin.bounds,
                (start, jac0.clone()),
                smoothing,
                &w,
                f0,
            )
        })
        .filter(|&(_, _, steps)| steps > 0)
        .and_then(|(here, jac, steps)| {
            let r = lm::residuals_at(&problem, &fin.bounds, &here, len)?;
            Some((here, jac, steps, r))
        });
    let Some((here, jac, steps, r)) = descent else {
        ctx.stage(format!(
            "final fit: roughness {f0:.3}; no step lowered the smooth part's sum"
        ));
        let secant = Some(jac0);
        return (fin, Some(Measured { f0, secant }));
    };
    let sse = lm::sse(&r);
    ctx.stage(format!(
        "final fit: moved to the smooth part's minimum in {steps} step(s) (roughness {f0:.3}), sum {sse:.1} against {:.1}",
        fin.fit.sse
    ));
    let p = lm::to_p(&fin.bounds, &here);
    let mut state = fin.state.clone();
    state.val = p.clone();
    let moved = FitOut {
        state,
        fit: lm::LmFit {
            p,
            z: here,
            residuals: r,
            sse,
            jac,
            jac_fresh: true,
            ..fin.fit
        },
        bounds: fin.bounds,
    };
    (moved, None)
}

/// Gauss–Newton steps on the smooth part from `start` (its point and secant Jacobian), each
/// the first of [`RECENTRE_TRIALS`] that lowers the smooth part's sum, until the model predicts
/// less than [`RECENTRE_CONVERGED`] to gain or after [`RECENTRE_STEPS`]; the secants are taken
/// again at each new point; each smooth part is the mean over `smoothing` (spreads and mirrored
/// pairs, [`Smooth::at`]). Returns the last point, its Jacobian and the steps taken.
fn descend<S: GridModel + ?Sized>(
    problem: &FitProblem<'_, '_, S>,
    bounds: &[lm::Bounded],
    start: (Smooth, DMatrix<f64>),
    smoothing: (&[f64], usize),
    w: &[f64],
    f0: f64,
) -> (Vec<f64>, DMatrix<f64>, usize) {
    let (mut here, mut jac) = start;
    let len = here.r.len();
    for steps in 0..RECENTRE_STEPS {
        let next = RECENTRE_TRIALS.iter().find_map(|&trial| {
            let (zn, predicted) = here.step(&jac, bounds, trial)?;
            if trial == RECENTRE_TRIALS[0] && predicted < RECENTRE_CONVERGED {
                return Some(None);
            }
            let there = Smooth::at(problem, bounds, zn, smoothing, len)?;
            (there.ssq < here.ssq).then_some(Some(there))
        });
        let Some(Some(there)) = next else {
            return (here.z, jac, steps);
        };
        here = there;
        jac = secants(problem, bounds, (&here.z, here.r.as_slice()), w, f0);
    }
    (here.z, jac, RECENTRE_STEPS)
}

/// The spread of [`lm::smoothed_residuals`]'s points per coordinate: [`SMOOTHING_SPREAD`]
/// standard errors from the secant Jacobian `jac`, at least the finite-difference step (where
/// decisions already flip) and at most [`MAX_SMOOTHING_STEP`].
fn smoothing_steps(jac: &DMatrix<f64>, scale: &[f64], n_fin: usize) -> Vec<f64> {
    let h0 = LmOptions::default().fd_step;
    let m = jac.ncols();
    match covariance(jac, scale, n_fin) {
        Some(c) => (0..m)
            .map(|j| (SMOOTHING_SPREAD * c[(j, j)].max(0.0).sqrt()).clamp(h0, MAX_SMOOTHING_STEP))
            .collect(),
        None => vec![10.0 * h0; m],
    }
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
    let f1 = lm::roughness(
        problem,
        &fin.bounds,
        &fin.fit.z,
        r0,
        w,
        &sd,
        ROUGHNESS_PATTERNS,
    );
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

#[cfg(test)]
mod tests {
    use super::{smoothing_pairs, MILD_ROUGHNESS};
    use crate::workflow::Z95;

    #[test]
    fn the_smooth_minimum_is_placed_within_a_tenth_of_the_widened_half_width_at_every_roughness() {
        // √(F / n) standard errors against 0.1 (1.96 + √(2F)), for F from the negligible to
        // far beyond any record's.
        let mut f = 1e-3;
        while f < 1e6 {
            let n = (2 * smoothing_pairs(f)) as f64;
            let placed = (f / n).sqrt();
            let tenth = 0.1 * (Z95 + (2.0 * f).sqrt());
            assert!(
                placed <= tenth,
                "F = {f}: {placed} > {tenth} with {n} points"
            );
            f *= 1.1;
        }
        // The 16 points of a mild sum would not do beyond it.
        let f = 4.0 * MILD_ROUGHNESS;
        assert!((f / 16.0).sqrt() > 0.1 * (Z95 + (2.0 * f).sqrt()));
    }
}
