//! Screening: scan each candidate over its range for a start and its visibility, then rank
//! the candidates by a linearised test ([`screen`]).
//!
//! Screening (score test): regress the current weighted residual on the current Jacobian plus, per
//! candidate, the change the effect makes at its start values and the sensitivities to each of its
//! parameters there; the statistic is the linearised ΔBIC of the augmented regression.

use super::evidence::{delta_bic, delta_bic_naive, row_weights};
use super::{inert, regress, Ctx, FitOut, ModelState, VisibilityPoint};
use crate::lm::{self, Bounded};
use crate::policy::{INERT_CHI2, SCAN_FRACTIONS, SENSITIVITY_STEP};
use crate::sim::GridModel;
use nalgebra::{DMatrix, DVector};
use rayon::iter::{IndexedParallelIterator, IntoParallelRefIterator, ParallelIterator};

/// Start of one candidate's screening and refit: its parameters' values and the base
/// parameters' values (same order as the current fit's).
#[derive(Clone, Debug)]
pub(super) struct CandidateStart {
    pub(super) effect: Vec<(usize, f64)>,
    pub(super) base: Vec<f64>,
    /// Every scanned point, in range order.
    pub(super) scan: Vec<VisibilityPoint>,
    /// Effect setting the screening linearises at (the linearised choice at the current base
    /// values; `effect` may instead come from the scan with the base values as given).
    pub(super) screen_effect: Vec<(usize, f64)>,
}

/// Chi-square of an effect's signal that survives the linearised readjustment of the base
/// parameters: `‖(I − J J⁺) (r_at − r_cur)‖²`, where `r_at − r_cur = (y_at − y_cur)/σ` is the
/// weighted change of the outputs when the effect is switched on at the scanned point and `J` the
/// current fit's Jacobian. This is about the largest drop of the weighted sum of squares the
/// effect could bring at that point; if it stays below the naming threshold
/// (`min ΔBIC + k ln N`) at every scanned magnitude, these data cannot reveal the effect, and
/// not naming it says nothing about whether it is there.
///
/// The rows are stacked by output, and output `k`'s share is counted with `sample_weight[k]`,
/// the effective samples per sample of its noise (`(1 − ρ)/(1 + ρ)` for AR(1) noise of
/// coefficient ρ, 1 for white noise): ΔBIC, which names effects, counts a drop with the
/// residual's effective sample size, so a chi-square counted over correlated samples as if they
/// were independent would promise what the evidence cannot give (19-fold at ρ = 0.9).
pub(super) fn visibility(
    jac: &DMatrix<f64>,
    r_cur: &[f64],
    r_at: &[f64],
    sample_weight: &[f64],
) -> Option<f64> {
    if r_cur.len() != r_at.len() || jac.nrows() != r_at.len() || sample_weight.is_empty() {
        return None;
    }
    let d: Vec<f64> = r_at.iter().zip(r_cur).map(|(a, c)| a - c).collect();
    let (res, _) = regress(jac, &d);
    let n = res.len() / sample_weight.len();
    let w = row_weights(sample_weight, n, res.len());
    let v: f64 = res.iter().zip(&w).map(|(x, w)| w * x * x).sum();
    v.is_finite().then_some(v)
}

/// Start of each candidate's screening and refit. Its parameters are scanned over their start
/// values and [`SCAN_FRACTIONS`] of their ranges, every point scored by the sum of squares left
/// after the linearised readjustment of the base parameters (the residual at the point regressed
/// on the current fit's Jacobian): an effect coupled to a base parameter (radius_growth and
/// string_radius) only pays off once both move, which a score at fixed base parameters misses.
/// At the chosen point the base parameters start from the current fit or from its linearised
/// readjustment, whichever simulates to the lower sum (one more simulation); every point is also
/// simulated with the base parameters as given (`given`), and the refit starts there when one
/// of those simulates lower still. An effect's declared start value can be far too strong or
/// too weak for the data at hand, and a refit started there can end in a local minimum worse
/// than the base model.
pub(super) fn scan_starts<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: &FitOut,
    cand: &[usize],
    given: Option<&ModelState>,
) -> Vec<CandidateStart> {
    let n = ctx.n_train;
    let points = |e: usize| -> Vec<Vec<(usize, f64)>> {
        let ps = &ctx.effects[e].params;
        if ps.is_empty() {
            return vec![Vec::new()];
        }
        let mut pts = vec![ps
            .iter()
            .map(|&i| (i, ctx.params[i].start))
            .collect::<Vec<_>>()];
        for &f in &SCAN_FRACTIONS {
            let pt: Option<Vec<(usize, f64)>> = ps
                .iter()
                .map(|&i| {
                    let q = &ctx.params[i];
                    let b = Bounded::new(q.start, q.min, q.max);
                    let (lo, hi) = b.z_bounds();
                    (lo.is_finite() && hi.is_finite()).then(|| (i, b.to_p(lo + f * (hi - lo))))
                })
                .collect();
            if let Some(pt) = pt {
                if !pts.contains(&pt) {
                    pts.push(pt);
                }
            }
        }
        pts
    };
    let mut jobs: Vec<(usize, Vec<(usize, f64)>)> = cand
        .iter()
        .flat_map(|&e| points(e).into_iter().map(move |p| (e, p)))
        .collect();
    // (sum at fixed base, sum after the linearised readjustment, readjustment in z, visibility,
    // chi-square of the change from the current fit)
    type Scored = (f64, f64, DVector<f64>, Option<f64>, f64);
    let score = |(e, pt): &(usize, Vec<(usize, f64)>)| -> Option<Scored> {
        let set = ctx.settings(&cur.state, Some(*e), pt);
        let r = ctx
            .measured_outputs(&set, n)
            .map(|y| ctx.residual(&y, n))
            .ok()?;
        ctx.pb.tick();
        let fixed = lm::sse(&r);
        let (res, beta) = regress(&cur.fit.jac, &r);
        let lin = lm::sse(&res);
        let vis = visibility(&cur.fit.jac, &cur.fit.residuals, &r, &ctx.sample_weights());
        let change: f64 = r
            .iter()
            .zip(&cur.fit.residuals)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        (fixed.is_finite() && lin.is_finite()).then_some((fixed, lin, -beta, vis, change))
    };
    let mut scored: Vec<Option<Scored>> = jobs.par_iter().map(score).collect();
    // Sum of squares at every point with the base values as given instead of fitted.
    let mut given_sse: Vec<Option<f64>> = jobs
        .par_iter()
        .map(|(e, pt)| {
            let st = given?;
            let v = ctx
                .measured_outputs(&ctx.settings(st, Some(*e), pt), n)
                .map(|y| lm::sse(&ctx.residual(&y, n)))
                .ok();
            ctx.pb.tick();
            v.filter(|v| v.is_finite())
        })
        .collect();
    // Per candidate, the scored point with the lowest readjusted sum.
    let lowest = |jobs: &[(usize, Vec<(usize, f64)>)], scored: &[Option<Scored>]| {
        cand.iter()
            .map(|&e| {
                (0..jobs.len())
                    .filter(|&k| jobs[k].0 == e)
                    .filter_map(|k| scored[k].as_ref().map(|x| (k, x.1)))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .map(|(k, _)| k)
            })
            .collect::<Vec<Option<usize>>>()
    };
    let mut chosen = lowest(&jobs, &scored);
    // A best setting that is inert (the effect changes nothing there) gives its refit no
    // gradient: search that candidate's range more finely, then choose again.
    let extra: Vec<(usize, Vec<(usize, f64)>)> = cand
        .iter()
        .zip(&chosen)
        .filter_map(|(&e, k)| {
            let k = (*k)?;
            let inert = scored[k].as_ref()?.4 < INERT_CHI2;
            inert
                .then(|| inert::search_points(ctx, e, &jobs[k].1))
                .map(|pts| pts.into_iter().map(move |p| (e, p)))
        })
        .flatten()
        .collect();
    if !extra.is_empty() {
        ctx.stage(format!(
            "inert at the scan's best setting: searching {} more settings",
            extra.len()
        ));
        scored.extend(extra.par_iter().map(score).collect::<Vec<_>>());
        given_sse.extend(std::iter::repeat_n(None, extra.len()));
        jobs.extend(extra);
        chosen = lowest(&jobs, &scored);
    }
    // Base start at the chosen point: the current fit or its linearised readjustment.
    chosen
        .par_iter()
        .zip(cand.par_iter())
        .map(|(k, &e)| {
            let mut scan: Vec<VisibilityPoint> = (0..jobs.len())
                .filter(|&j| jobs[j].0 == e)
                .map(|j| {
                    let pt = &jobs[j].1;
                    let frac = pt
                        .iter()
                        .map(|&(i, v)| {
                            let q = &ctx.params[i];
                            let b = Bounded::new(q.start, q.min, q.max);
                            let (lo, hi) = b.z_bounds();
                            (b.to_z(v) - lo) / (hi - lo)
                        })
                        .sum::<f64>()
                        / pt.len().max(1) as f64;
                    VisibilityPoint {
                        parameters: pt
                            .iter()
                            .map(|&(i, v)| (ctx.params[i].name.clone(), v))
                            .collect(),
                        fraction: frac,
                        visibility: scored[j].as_ref().and_then(|x| x.3),
                    }
                })
                .collect();
            scan.sort_by(|a, b| a.fraction.total_cmp(&b.fraction));
            let Some(k) = *k else {
                return CandidateStart {
                    effect: Vec::new(),
                    base: cur.state.val.clone(),
                    scan,
                    screen_effect: Vec::new(),
                };
            };
            let (fixed, _, step, _, _) = scored[k].as_ref().expect("chosen points are scored");
            let pt = jobs[k].1.clone();
            let moved: Vec<f64> = cur
                .bounds
                .iter()
                .zip(&cur.fit.z)
                .enumerate()
                .map(|(j, (b, z))| b.to_p(z + step.get(j).copied().unwrap_or(0.0)))
                .collect();
            let st = cur.state.with_values(moved.clone());
            let moved_sse = ctx
                .measured_outputs(&ctx.settings(&st, Some(e), &pt), n)
                .map(|y| lm::sse(&ctx.residual(&y, n)))
                .unwrap_or(f64::INFINITY);
            ctx.pb.tick();
            let (base, sse) = if moved_sse < *fixed {
                (moved, moved_sse)
            } else {
                (cur.state.val.clone(), *fixed)
            };
            // A strong effect the base fit could not imitate leaves it far off (hydraulic valve
            // overlap of 1 V: the base fit's sum was 2e10, its linearisation useless there);
            // then the effect at a scanned point with the base values as given can simulate
            // far better, and the refit starts there.
            let (effect, base) = match (0..jobs.len())
                .filter(|&j| jobs[j].0 == e)
                .filter_map(|j| given_sse[j].map(|v| (j, v)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
            {
                Some((j, v)) if v < sse => (
                    jobs[j].1.clone(),
                    given.expect("scored with the given base").val.clone(),
                ),
                _ => (pt.clone(), base),
            };
            CandidateStart {
                effect,
                base,
                scan,
                screen_effect: pt,
            }
        })
        .collect()
}

pub(super) fn screen<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: &FitOut,
    cand: &[usize],
    starts: &[CandidateStart],
) -> Vec<(f64, f64)> {
    let n = ctx.n_train;
    let k = ctx.out_idx.len();
    let r0 = &cur.fit.residuals;
    let y_cur: Vec<Vec<f64>> = (0..k)
        .map(|j| {
            (0..n)
                .map(|i| ctx.meas[j][i] + r0[j * n + i] * ctx.sigma[j])
                .collect()
        })
        .collect();
    // Jobs: (candidate, None = switch on at start, Some(p) = perturb parameter p).
    let h = SENSITIVITY_STEP;
    let start_of = |e: usize| -> &[(usize, f64)] {
        cand.iter()
            .position(|&c| c == e)
            .map(|k| starts[k].screen_effect.as_slice())
            .unwrap_or(&[])
    };
    let jobs: Vec<(usize, Option<usize>)> = cand
        .iter()
        .flat_map(|&e| {
            std::iter::once((e, None)).chain(start_of(e).iter().map(move |&(p, _)| (e, Some(p))))
        })
        .collect();
    let sims: Vec<Option<Vec<Vec<f64>>>> = jobs
        .par_iter()
        .map(|&(e, p)| {
            let extra: Vec<(usize, f64)> = match p {
                None => Vec::new(),
                Some(pi) => {
                    let ps = &ctx.params[pi];
                    let at = start_of(e)
                        .iter()
                        .find(|(i, _)| *i == pi)
                        .map_or(ps.start, |x| x.1);
                    let b = Bounded::new(ps.start, ps.min, ps.max);
                    let z = b.to_z(at);
                    let up = b.to_p(z + h);
                    let v = if up != at { up } else { b.to_p(z - h) };
                    vec![(pi, v)]
                }
            };
            // Effect parameters at the scanned start (see `scan_starts`), then the perturbation.
            let mut set = ctx.settings(&cur.state, Some(e), start_of(e));
            set.extend(extra);
            let out = ctx.measured_outputs(&set, n).ok();
            ctx.pb.tick();
            out
        })
        .collect();
    cand.iter()
        .map(|&e| {
            let mut cols: Vec<Vec<f64>> = Vec::new();
            let on_pos = jobs.iter().position(|j| *j == (e, None));
            let Some(y_on) = on_pos.and_then(|i| sims[i].as_ref()) else {
                return (f64::NEG_INFINITY, f64::NEG_INFINITY);
            };
            let mut d0 = Vec::with_capacity(n * k);
            for j in 0..k {
                d0.extend((0..n).map(|i| (y_on[j][i] - y_cur[j][i]) / ctx.sigma[j]));
            }
            cols.push(d0);
            for &(p, _) in start_of(e) {
                let pos = jobs.iter().position(|jb| *jb == (e, Some(p)));
                if let Some(y_p) = pos.and_then(|i| sims[i].as_ref()) {
                    let mut s = Vec::with_capacity(n * k);
                    for j in 0..k {
                        s.extend((0..n).map(|i| (y_p[j][i] - y_on[j][i]) / ctx.sigma[j]));
                    }
                    cols.push(s);
                }
            }
            // A constant change of an output whose offset is estimated is absorbed by it.
            let cols: Vec<Vec<f64>> = cols
                .into_iter()
                .filter(|c| c.iter().any(|v| *v != 0.0))
                .map(|mut c| {
                    ctx.remove_offsets(&mut c, n, n);
                    c
                })
                .filter(|c| c.iter().any(|v| v.abs() > 1e-9))
                .collect();
            if cols.is_empty() {
                return (f64::NEG_INFINITY, f64::NEG_INFINITY);
            }
            let pb = cur.fit.jac.ncols();
            let x = DMatrix::from_fn(n * k, pb + cols.len(), |i, j| {
                if j < pb {
                    cur.fit.jac[(i, j)]
                } else {
                    cols[j - pb][i]
                }
            });
            // r ≈ X β: the residual explained by readjusted base parameters plus the effect.
            let (res, _) = regress(&x, r0);
            let (res0, _) = regress(&cur.fit.jac, r0);
            (
                delta_bic_naive(&res0, &res, k, cols.len()),
                delta_bic(&res0, &res, k, cols.len()),
            )
        })
        .collect()
}

#[cfg(test)]
mod visibility_tests {
    use super::visibility;
    use nalgebra::DMatrix;

    /// Base Jacobian with columns 1 and t on t = 0..1 (an offset and a slope the base can absorb).
    fn base_jac(n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, 2, |i, j| {
            if j == 0 {
                1.0
            } else {
                i as f64 / (n - 1) as f64
            }
        })
    }

    #[test]
    fn a_change_the_base_absorbs_is_invisible() {
        let n = 200;
        let jac = base_jac(n);
        let r_cur: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 13) as f64 / 13.0 - 0.5)
            .collect();
        // The effect shifts and tilts the output by 3σ: all within the span of the base columns.
        let r_at: Vec<f64> = (0..n)
            .map(|i| r_cur[i] + 3.0 - 2.0 * i as f64 / (n - 1) as f64)
            .collect();
        let v = visibility(&jac, &r_cur, &r_at, &[1.0]).unwrap();
        assert!(v < 1e-6, "absorbed change reported visible: {v}");
    }

    #[test]
    fn the_unabsorbable_part_is_counted_in_chi_square() {
        let n = 400;
        let jac = base_jac(n);
        let r_cur = vec![0.0; n];
        // A sine of amplitude 0.5σ over whole periods, plus an absorbable offset; the sine is
        // orthogonal to a constant and nearly so to the slope, so its chi-square is close to
        // n · 0.5² / 2 = 50, minus its small projection on the slope (computed in closed form).
        let w = 2.0 * std::f64::consts::PI * 4.0 / n as f64;
        let s: Vec<f64> = (0..n).map(|i| 0.5 * libm::sin(w * i as f64)).collect();
        let r_at: Vec<f64> = s.iter().map(|x| x + 1.0).collect();
        let t: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let tm = t.iter().sum::<f64>() / n as f64;
        let sm = s.iter().sum::<f64>() / n as f64;
        let sxx: f64 = t.iter().map(|x| crate::stats::sq(x - tm)).sum();
        let sxy: f64 = t.iter().zip(&s).map(|(x, y)| (x - tm) * (y - sm)).sum();
        let syy: f64 = s.iter().map(|y| crate::stats::sq(y - sm)).sum();
        let expected = syy - sxy * sxy / sxx;
        let v = visibility(&jac, &r_cur, &r_at, &[1.0]).unwrap();
        assert!(
            (v - expected).abs() < 1e-6 * expected,
            "visibility {v}, closed form {expected}"
        );
        assert!(v > 40.0 && v < 50.0);
        // The same signal in AR(1) noise of coefficient 0.9 counts (1 − 0.9)/(1 + 0.9) of it.
        let ar = visibility(&jac, &r_cur, &r_at, &[0.1 / 1.9]).unwrap();
        assert!((ar - expected * 0.1 / 1.9).abs() < 1e-6 * expected, "{ar}");
    }

    #[test]
    fn mismatched_lengths_give_none() {
        let jac = base_jac(10);
        assert!(visibility(&jac, &[0.0; 10], &[0.0; 9], &[1.0]).is_none());
        assert!(visibility(&jac, &[0.0; 9], &[0.0; 9], &[1.0]).is_none());
    }
}
