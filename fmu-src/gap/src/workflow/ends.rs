//! Interval ends checked against the profile of the sum of squares.
//!
//! The 95 % interval of a parameter is the set of values whose profile (the weighted sum of
//! squares minimised over the other parameters with this one held) lies within `t²` of the
//! minimum (Venzon & Moolgavkar 1988; Bates & Watts 1988, 6.1). The linearised interval and its
//! check along the first-order path ([`lm::interval_ends`]) stand for that only where the valley
//! is nearly quadratic. Where it is flat and bent (a stiffness traded against a damping and a
//! load, on a sum of squares made rough by encoder counts), a linearised interval can miss the
//! truth by many of its half-widths.
//!
//! Check: the sum with only this parameter moved to the end (the others at their fitted values)
//! bounds the profile there from above. Where even that stays below `t²`, the end is provably
//! too close; where the valley is flat, a fit of the others with this
//! parameter held at the end decides. A close end moves out (fourfold per step, up to the
//! bound), each point a fit of the others with this parameter held (started from the previous
//! point's values, following the valley), until the profile reaches `t²` (the end interpolated
//! in the squared distance) or the parameter's bound.

use super::{fit_state_holding, Ctx, FitOut, FitProblem, Limits, ModelState};
use crate::lm;
use crate::policy::{
    BENT, HELD_FIT_GROWTH, HELD_FIT_ITERATIONS, HELD_FIT_REL_TOL, LOWER_BY, MAX_HELD_FITS,
};
use crate::sim::GridModel;
use nalgebra::DMatrix;
use rayon::iter::{IndexedParallelIterator, IntoParallelRefIterator, ParallelIterator};
use std::sync::Mutex;

/// The ends `ends` (multipliers of each parameter's standard error in its fitting coordinate,
/// from `cov`), each moved out where the profile shows it too close; `w` weighs the residual
/// rows as in `cov`. Every end is at least its given value.
///
/// First every end is probed along its parameter's axis. Where the valley is flat (some end's
/// probe, short of the parameter's bound, stays below `t²`), it also bends in ways the
/// linearisation does not see (one parameter's profile following two others across their
/// ranges), and every end is then checked by a fit of the others with its parameter held there.
/// So is every end when a parameter sits on one of its bounds ([`at_a_bound`]): there the
/// first-order path can rise far more than the profile. An end the first-order path already
/// moved out ([`lm::interval_ends`] found the sum rising less than quadratically along it: a
/// bending valley) is checked by a held fit too, whatever its axis probe shows: the other
/// parameters readjusting along the valley can keep the profile low far beyond it. So is an end
/// whose first-order path leaves another parameter's bounds ([`clamped`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn profile_ends<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    fin: &FitOut,
    n_fin: usize,
    problem: &FitProblem<'_, '_, S>,
    w: &[f64],
    cov: &DMatrix<f64>,
    t: f64,
    ends: Vec<(f64, f64)>,
) -> ProfileEnds {
    let m = ends.len();
    let c0 = lm::weighted_sse(&fin.fit.residuals, w);
    let z = &fin.fit.z;
    // Per end: parameter, direction, multiplier, standard error, multiplier at the bound.
    let sides: Vec<(usize, f64, f64, f64, f64)> = (0..m)
        .flat_map(|j| [(j, -1.0, ends[j].0), (j, 1.0, ends[j].1)])
        .map(|(j, sign, k)| {
            let sd = cov[(j, j)].sqrt();
            let (lo, hi) = fin.bounds[j].z_bounds();
            let k_bound = ((if sign < 0.0 { lo } else { hi }) - z[j]).abs() / sd;
            (j, sign, k, sd, k_bound)
        })
        .collect();
    let at = |j: usize, sign: f64, sd: f64, k: f64| {
        let (lo, hi) = fin.bounds[j].z_bounds();
        (z[j] + sign * k * sd).clamp(lo, hi)
    };
    // The sum's rise with only parameter j moved to the end (an upper bound of its profile).
    let axis: Vec<Option<f64>> = sides
        .par_iter()
        .map(|&(j, sign, k, sd, _)| {
            if !(sd.is_finite() && sd > 0.0) || at(j, sign, sd, k) == z[j] {
                return None;
            }
            let mut zz = z.clone();
            zz[j] = at(j, sign, sd, k);
            lm::residuals_at(problem, &fin.bounds, &zz, fin.fit.residuals.len())
                .map(|r| lm::weighted_sse(&r, w) - c0)
        })
        .collect();
    let thorough = at_a_bound(&fin.bounds, z)
        || shows_flat_valley(sides.iter().zip(&axis).map(|(s, &r)| (s.2, s.4, r)), t);
    // Points a held fit reached below t² (in z): witnesses for every parameter's interval.
    let witnesses = Mutex::new(Vec::new());
    // The held fit's point lowest below the minimum (rise, every parameter's value).
    let lowest: Mutex<Option<(f64, Vec<f64>)>> = Mutex::new(None);
    // The profile's rise with parameter j held at multiplier k, the others fitted from `from`.
    let held = |j: usize, sign: f64, sd: f64, k: f64, from: &[f64]| -> Option<(f64, Vec<f64>)> {
        let st = ModelState {
            named: fin.state.named.clone(),
            idx: (0..m)
                .filter(|&i| i != j)
                .map(|i| fin.state.idx[i])
                .collect(),
            val: from.to_vec(),
        };
        let held = [(fin.state.idx[j], fin.bounds[j].to_p(at(j, sign, sd, k)))];
        let limits = Limits::new(HELD_FIT_ITERATIONS, HELD_FIT_REL_TOL).without_final_jacobian();
        let f = fit_state_holding(ctx, &st, None, &[], &held, n_fin, limits).ok()?;
        let rise = lm::weighted_sse(&f.fit.residuals, w) - c0;
        // Every parameter's value at this point, the held one included.
        let mut val = f.state.val.clone();
        val.insert(j, held[0].1);
        if rise < t * t {
            let mut zw = lm::to_z(&fin.bounds, &val);
            zw[j] = at(j, sign, sd, k);
            witnesses.lock().unwrap_or_else(|e| e.into_inner()).push(zw);
        }
        let mut low = lowest.lock().unwrap_or_else(|e| e.into_inner());
        if rise < low.as_ref().map_or(0.0, |l| l.0) {
            *low = Some((rise, val));
        }
        Some((rise, f.state.val))
    };
    let moved: Vec<f64> = sides
        .par_iter()
        .zip(&axis)
        .map(|(&(j, sign, k, sd, k_bound), &rise)| {
            let Some(rise) = rise else {
                return k;
            };
            let mut others: Vec<f64> = (0..m)
                .filter(|&i| i != j)
                .map(|i| fin.state.val[i])
                .collect();
            let mut last = (k, rise);
            if rise >= t * t {
                if !thorough && !bent(k, t) && !clamped(&fin.bounds, z, cov, j, sign * k) {
                    return k;
                }
                match held(j, sign, sd, k, &others) {
                    Some((r, v)) if r < t * t => {
                        last = (k, r);
                        others = v;
                    }
                    _ => return k,
                }
            }
            move_out(last, k, k_bound, t, others, |k2, from| {
                held(j, sign, sd, k2, from)
            })
        })
        .collect();
    ctx.stage(format!(
        "interval ends against the profile (95 % level {:.1}): axis rises {:?}; {}; multipliers \
         {:?} -> {:?}",
        t * t,
        axis.iter()
            .map(|r| r.map(|r| (r * 10.0).round() / 10.0))
            .collect::<Vec<_>>(),
        if thorough {
            "flat valley or a parameter on a bound, every end checked by a held fit"
        } else {
            "no flat end"
        },
        sides
            .iter()
            .map(|s| (s.2 * 100.0).round() / 100.0)
            .collect::<Vec<_>>(),
        moved
            .iter()
            .map(|k| (k * 100.0).round() / 100.0)
            .collect::<Vec<_>>(),
    ));
    let witnesses = witnesses.into_inner().unwrap_or_else(|e| e.into_inner());
    let moved: Vec<(f64, f64)> = moved.chunks(2).map(|c| (c[0], c[1])).collect();
    let lower = lowest.into_inner().unwrap_or_else(|e| e.into_inner());
    ProfileEnds {
        ends: spanning(moved, &witnesses, z, cov),
        lower: lower.filter(|(rise, _)| *rise < -LOWER_BY),
    }
}

/// What the profile search found: the ends, and a point whose sum lies below the fit's (by
/// more than [`LOWER_BY`]), when a held fit reached one.
pub(super) struct ProfileEnds {
    /// Per parameter, the (lower, upper) multipliers of its standard error.
    pub ends: Vec<(f64, f64)>,
    /// That point's rise above the fit's sum (negative) and every parameter's value there (in
    /// the fit's order). On a rough sum the caller confirms it on the smooth part
    /// ([`super::rough`]): a point can gain by where the jumps fall alone.
    pub lower: Option<(f64, Vec<f64>)>,
}

/// The ends `ends` (multipliers of each parameter's standard error from `cov`, about `z`) moved
/// out to hold every witness: a point whose sum rises less than `t²` above the minimum. Such a
/// point bounds from above the profile of each parameter at its own coordinate, so each of its
/// coordinates lies inside that parameter's profile interval: a held fit that followed a curved
/// valley (the return spring's, taking the string compliance and radius with it) shows how far
/// the other parameters reach along it, where their own first-order paths climb its walls.
fn spanning(
    mut ends: Vec<(f64, f64)>,
    witnesses: &[Vec<f64>],
    z: &[f64],
    cov: &DMatrix<f64>,
) -> Vec<(f64, f64)> {
    for (j, end) in ends.iter_mut().enumerate() {
        let sd = cov[(j, j)].sqrt();
        if !(sd.is_finite() && sd > 0.0) {
            continue;
        }
        for zw in witnesses {
            let d = (zw[j] - z[j]) / sd;
            if d < 0.0 {
                end.0 = end.0.max(-d);
            } else {
                end.1 = end.1.max(d);
            }
        }
    }
    ends
}

/// Whether the axis probes (multiplier, multiplier at the bound, rise) show a flat valley: a
/// probe at its full distance that rises less than `t²`. A probe stopped at the parameter's
/// bound, closer than `k` standard errors, rises less than `t²` in a quadratic valley too, and
/// is no evidence.
fn shows_flat_valley(probes: impl IntoIterator<Item = (f64, f64, Option<f64>)>, t: f64) -> bool {
    probes
        .into_iter()
        .any(|(k, k_bound, rise)| k < k_bound && rise.is_some_and(|r| r < t * t))
}

/// Whether some parameter sits on one of its bounds at `z`: the minimum is then a constrained
/// one, where the quadratic model of the sum, and the covariance from it, do not describe the
/// profile (Self & Liang 1987, likelihood ratios on the boundary of the parameter space).
fn at_a_bound(b: &[lm::Bounded], z: &[f64]) -> bool {
    b.iter().zip(z).any(|(b, &zi)| {
        let (lo, hi) = b.z_bounds();
        zi <= lo || zi >= hi
    })
}

/// Whether an end's multiplier `k` was moved out from `t` by the first-order path's check
/// (by more than [`BENT`]): the sum rose less than quadratically along it.
fn bent(k: f64, t: f64) -> bool {
    k > BENT * t
}

/// Whether the first-order path of parameter `j`'s profile, `z + s · cov[:, j] / σ_j` out to
/// `s` standard errors, leaves another parameter's bounds: [`lm::interval_ends`] clamps it there,
/// so its rise is no longer the profile's.
fn clamped(b: &[lm::Bounded], z: &[f64], cov: &DMatrix<f64>, j: usize, s: f64) -> bool {
    let sd = cov[(j, j)].sqrt();
    (0..z.len()).filter(|&i| i != j).any(|i| {
        let (lo, hi) = b[i].z_bounds();
        let zi = z[i] + s * cov[(i, j)] / sd;
        zi < lo || zi > hi
    })
}

/// The profile search of one end: from `last` (multiplier, rise below `t²`), the end moves out
/// by [`HELD_FIT_GROWTH`] per step up to `k_bound`, each step's rise from `held(k, from)` (a fit of the
/// others started at `from`, returning its rise and values), until the rise reaches `t²`; the end
/// is then interpolated linearly in k² between the last two steps (exact for a quadratic
/// profile). Returns the multiplier, at least `k`; a failed fit keeps the last one reached.
fn move_out(
    mut last: (f64, f64),
    k: f64,
    k_bound: f64,
    t: f64,
    mut others: Vec<f64>,
    held: impl Fn(f64, &[f64]) -> Option<(f64, Vec<f64>)>,
) -> f64 {
    for _ in 0..MAX_HELD_FITS {
        if last.0 >= k_bound {
            return k_bound.max(k);
        }
        let k2 = (HELD_FIT_GROWTH * last.0).min(k_bound);
        let Some((rise2, v)) = held(k2, &others) else {
            return last.0;
        };
        if rise2 >= t * t {
            let (k1, r1) = last;
            let k_sq = k1 * k1 + (t * t - r1) * (k2 * k2 - k1 * k1) / (rise2 - r1);
            return k_sq.max(0.0).sqrt().clamp(k1, k2);
        }
        others = v;
        last = (k2, rise2);
    }
    last.0
}

#[cfg(test)]
mod tests {
    use super::{at_a_bound, bent, clamped, move_out, shows_flat_valley, spanning};
    use crate::lm::Bounded;
    use nalgebra::DMatrix;

    #[test]
    fn only_a_probe_short_of_the_bound_shows_a_flat_valley() {
        let t: f64 = 1.96;
        // Rising less than t² over the full distance: flat.
        assert!(shows_flat_valley([(t, 10.0, Some(3.0))], t));
        // The same rise at the bound (0.5 standard errors away): what a quadratic valley gives.
        assert!(!shows_flat_valley([(t, 0.5, Some(0.25))], t));
        // Rises at or above t², or no probe: not flat.
        assert!(!shows_flat_valley(
            [(t, 10.0, Some(t * t)), (t, 10.0, None)],
            t
        ));
    }

    #[test]
    fn only_an_end_moved_out_by_more_than_the_interpolations_play_is_bent() {
        let t: f64 = 1.96;
        assert!(!bent(t, t));
        assert!(!bent(1.04 * t, t));
        assert!(bent(1.06 * t, t));
    }

    #[test]
    fn a_path_is_clamped_only_where_another_parameter_leaves_its_bounds() {
        // Parameter 0 free; parameter 1 at z = 0.5 within [0, 10] (linear, start 0.5), falling
        // by 0.2 per standard error of parameter 0 along its path.
        let b = [
            Bounded::new(1.0, None, None),
            Bounded::new(0.5, Some(0.0), Some(10.0)),
        ];
        let z = [b[0].to_z(1.0), b[1].to_z(0.5)];
        let d1 = b[1].dp_dz(z[1]);
        let cov = DMatrix::from_row_slice(2, 2, &[1.0, -0.2 / d1, -0.2 / d1, 1.0]);
        assert!(!clamped(&b, &z, &cov, 0, 2.0));
        assert!(clamped(&b, &z, &cov, 0, 3.0));
        assert!(!clamped(&b, &z, &cov, 0, -3.0));
    }

    #[test]
    fn a_parameter_exactly_on_a_bound_is_at_a_bound() {
        let b = [
            Bounded::new(1.0, Some(0.0), Some(10.0)),
            Bounded::new(1.0, None, None),
        ];
        let z = |p0: f64| [b[0].to_z(p0), b[1].to_z(1.0)];
        assert!(at_a_bound(&b, &z(0.0)));
        assert!(at_a_bound(&b, &z(10.0)));
        assert!(!at_a_bound(&b, &z(1e-9)));
        assert!(!at_a_bound(&b, &z(5.0)));
    }

    #[test]
    fn every_end_moves_out_to_hold_the_witnesses_and_none_moves_in() {
        // Two parameters at z = (1, 2), standard errors 0.5 and 2.
        let cov = DMatrix::from_row_slice(2, 2, &[0.25, 0.0, 0.0, 4.0]);
        let ends = vec![(1.96, 1.96), (3.0, 1.96)];
        // A witness 3 standard errors below the first and 1.5 above the second, another 4
        // above the first.
        let witnesses = vec![vec![-0.5, 5.0], vec![3.0, 2.0]];
        let spanned = spanning(ends, &witnesses, &[1.0, 2.0], &cov);
        assert_eq!(spanned, vec![(3.0, 4.0), (3.0, 1.96)]);
        // A parameter without a finite standard error keeps its ends.
        let cov = DMatrix::from_row_slice(1, 1, &[f64::NAN]);
        assert_eq!(
            spanning(vec![(1.96, 1.96)], &[vec![9.0]], &[0.0], &cov),
            vec![(1.96, 1.96)]
        );
    }

    #[test]
    fn a_quadratic_profile_ends_where_it_reaches_the_level() {
        // Profile rise (k / 5)² (a standard error five times the linearised one): the end at
        // t = 1.96 is 9.8, reached exactly by the interpolation in k².
        let held = |k: f64, _: &[f64]| Some((crate::stats::sq(k / 5.0), Vec::new()));
        let k = move_out(
            (1.96, crate::stats::sq(1.96f64 / 5.0)),
            1.96,
            1e9,
            1.96,
            Vec::new(),
            held,
        );
        assert!((k - 9.8).abs() < 1e-9, "{k}");
    }

    #[test]
    fn a_flat_profile_ends_at_the_bound_and_a_failed_fit_keeps_the_last_end() {
        let flat = |_: f64, _: &[f64]| Some((0.5, Vec::new()));
        assert_eq!(
            move_out((2.0, 0.5), 2.0, 30.0, 1.96, Vec::new(), flat),
            30.0
        );
        // Beyond the steps allowed: the last step reached (2 × 4⁴).
        assert_eq!(
            move_out((2.0, 0.5), 2.0, 1e9, 1.96, Vec::new(), flat),
            512.0
        );
        let failing = |k: f64, _: &[f64]| (k < 10.0).then(|| (0.5, Vec::new()));
        assert_eq!(
            move_out((2.0, 0.5), 2.0, 1e9, 1.96, Vec::new(), failing),
            8.0
        );
    }

    #[test]
    fn each_step_starts_from_the_previous_steps_values() {
        let seen = std::sync::Mutex::new(Vec::new());
        let held = |k: f64, from: &[f64]| {
            seen.lock().unwrap().push(from.to_vec());
            Some((crate::stats::sq(k / 20.0), vec![k]))
        };
        move_out((2.0, 0.01), 2.0, 1e9, 1.96, vec![-1.0], held);
        assert_eq!(
            *seen.lock().unwrap(),
            vec![vec![-1.0], vec![8.0], vec![32.0]]
        );
    }
}
