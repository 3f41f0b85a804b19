use super::{
    interval_ends, jacobian, levenberg_marquardt, refresh_jacobian, roughness, secant_jacobian,
    smoothed_residuals, to_p, Bounded, Coord, LmOptions, Problem,
};
use crate::policy::MAX_END_WIDENING;
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
    let fit = levenberg_marquardt(&pr, &b, &[1.0, 0.5, 0.0], LmOptions::default(), &|| {}).unwrap();
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
    let slope =
        t.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>() / t.iter().map(|a| a * a).sum::<f64>();
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
