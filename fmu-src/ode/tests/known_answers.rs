//! Accuracy against closed forms and independent reference values
//! (`tests/data/reference.json`, written by `scripts/reference.py`; sources inside that file).
// Test references use the platform libm: an implementation independent of the `libm` crate
// the FMU code uses (workspace clippy.toml).
#![allow(clippy::disallowed_methods)]

mod problems;

use ode::{Integrator, Method, OdeSystem};
use problems::*;

fn reference(key: &str) -> (Vec<f64>, Option<Vec<f64>>) {
    let text = include_str!("data/reference.json");
    let v: serde_json::Value = serde_json::from_str(text).expect("reference.json parses");
    let entry = &v[key];
    let get = |k: &str| -> Option<Vec<f64>> {
        entry[k]
            .as_array()
            .map(|a| a.iter().map(|x| x.as_f64().unwrap()).collect())
    };
    (get("scipy").expect("scipy value"), get("published"))
}

const METHODS: [Method; 2] = [Method::Rodas5P, Method::Rodas4];

fn solve<S: OdeSystem>(
    sys: &S,
    m: Method,
    rtol: f64,
    atol: Vec<f64>,
    t1: f64,
    y: &mut [f64],
) -> Integrator {
    let mut ig = Integrator::new(rtol, atol).with_method(m);
    ig.integrate(sys, 0.0, t1, y).expect("integration succeeds");
    ig
}

#[test]
fn dahlquist_matches_exp_for_k_up_to_1e6() {
    for m in METHODS {
        for &k in &[1.0, 1e2, 1e4, 1e6] {
            for &t1 in &[1e-6, 1e-3, 1.0, 10.0] {
                let mut y = [1.0];
                let ig = solve(&Dahlquist { k }, m, 1e-8, vec![1e-12], t1, &mut y);
                let exact = (-k * t1).exp();
                let err = (y[0] - exact).abs();
                assert!(
                    err <= 1e-7 * exact + 1e-11,
                    "{m:?} k={k} t={t1}: y={} exact={exact} err={err:e}",
                    y[0]
                );
                // L-stability: in the stiff regime (k t >> 1) the step count must not scale
                // with k t (an explicit method would need ~k t / 3 steps).
                if k * t1 >= 1e4 {
                    assert!(
                        ig.stats().steps < 500,
                        "{m:?} k={k} t={t1}: {:?}",
                        ig.stats()
                    );
                }
            }
        }
    }
}

#[test]
fn dahlquist_error_decreases_with_tolerance() {
    // Tolerance proportionality: tightening rtol by 1e3 must reduce the error substantially.
    for m in METHODS {
        let mut errs = vec![];
        for &rtol in &[1e-4, 1e-7, 1e-10] {
            let mut y = [1.0];
            solve(&Dahlquist { k: 3.0 }, m, rtol, vec![rtol], 2.0, &mut y);
            errs.push((y[0] - (-6.0f64).exp()).abs());
        }
        assert!(
            errs[1] < errs[0] / 20.0 && errs[2] < errs[1] / 20.0,
            "{m:?}: {errs:?}"
        );
    }
}

#[test]
fn forced_problem_exercises_time_derivative_terms() {
    for m in METHODS {
        for &k in &[1.0, 1e3, 1e6] {
            for analytic in [true, false] {
                let sys = Forced { k, analytic };
                let mut y = [0.0];
                solve(&sys, m, 1e-9, vec![1e-12], 5.0, &mut y);
                let exact = sys.exact(0.0, 5.0);
                assert!(
                    (y[0] - exact).abs() < 1e-7,
                    "{m:?} k={k} analytic={analytic}: {} vs {exact}",
                    y[0]
                );
            }
        }
    }
}

#[test]
fn van_der_pol_scaled_matches_ivp_test_set() {
    let (scipy, published) = reference("vdp_scaled_eps1e-6_t2");
    let published = published.unwrap();
    // The independent SciPy value agrees with the published one (sanity of the data file).
    assert!((scipy[0] - published[0]).abs() < 1e-8 && (scipy[1] - published[1]).abs() < 1e-6);
    for m in METHODS {
        for (rtol, tol) in [(1e-6, 2e-4), (1e-9, 2e-7)] {
            let mut y = [2.0, 0.0];
            let ig = solve(
                &VanDerPolScaled { eps: 1e-6 },
                m,
                rtol,
                vec![rtol; 2],
                2.0,
                &mut y,
            );
            let e0 = (y[0] - published[0]).abs() / published[0].abs();
            let e1 = (y[1] - published[1]).abs() / published[1].abs();
            assert!(
                e0 < tol && e1 < tol,
                "{m:?} rtol={rtol}: {y:?} vs {published:?} ({e0:e}, {e1:e}); {:?}",
                ig.stats()
            );
        }
    }
}

#[test]
fn van_der_pol_mu_1000_matches_reference() {
    let (scipy, published) = reference("vdp_mu1000_t2000");
    let published = published.unwrap();
    assert!(
        (scipy[0] - published[0]).abs() < 1e-8,
        "{scipy:?} vs {published:?}"
    );
    for m in METHODS {
        for analytic in [true, false] {
            let mut y = [2.0, 0.0];
            let sys = VanDerPol {
                mu: 1000.0,
                analytic,
            };
            let ig = solve(&sys, m, 1e-8, vec![1e-8, 1e-8], 2000.0, &mut y);
            let e0 = (y[0] - published[0]).abs() / published[0].abs();
            let e1 = (y[1] - published[1]).abs() / published[1].abs();
            assert!(
                e0 < 2e-6 && e1 < 2e-6,
                "{m:?} analytic={analytic}: {y:?} ({e0:e}, {e1:e})"
            );
            assert!(ig.stats().steps < 5_000, "{m:?}: {:?}", ig.stats());
            assert_eq!(ig.stats().fd_jacobians > 0, !analytic);
        }
    }
}

#[test]
fn robertson_matches_reference_at_40_and_1e11() {
    let (r40, _) = reference("robertson_t40");
    let (r11, published) = reference("robertson_t1e+11");
    let published = published.unwrap();
    for i in 0..3 {
        assert!(
            (r11[i] - published[i]).abs() <= 1e-6 * published[i].abs(),
            "scipy {r11:?} vs {published:?}"
        );
    }
    for m in METHODS {
        for analytic in [true, false] {
            let sys = Robertson { analytic };
            let atol = vec![1e-12, 1e-16, 1e-12];
            let mut y = [1.0, 0.0, 0.0];
            let mut ig = Integrator::new(1e-8, atol).with_method(m);
            ig.integrate(&sys, 0.0, 40.0, &mut y).unwrap();
            for i in 0..3 {
                assert!(
                    (y[i] - r40[i]).abs() <= 1e-6 * r40[i].abs(),
                    "{m:?} analytic={analytic} t=40: {y:?} vs {r40:?}"
                );
            }
            ig.integrate(&sys, 40.0, 1e11, &mut y).unwrap();
            for i in 0..3 {
                assert!(
                    (y[i] - published[i]).abs() <= 1e-5 * published[i].abs(),
                    "{m:?} analytic={analytic} t=1e11: {y:?} vs {published:?}"
                );
            }
            assert!(ig.stats().steps < 2_000, "{m:?}: {:?}", ig.stats());
            // One call over the whole span (initial steps ~1e-6 while t1 = 1e11).
            let mut y = [1.0, 0.0, 0.0];
            let mut ig = Integrator::new(1e-8, vec![1e-12, 1e-16, 1e-12]).with_method(m);
            ig.integrate(&sys, 0.0, 1e11, &mut y).unwrap();
            for i in 0..3 {
                assert!(
                    (y[i] - published[i]).abs() <= 1e-5 * published[i].abs(),
                    "{m:?} analytic={analytic} one call: {y:?} vs {published:?}"
                );
            }
        }
    }
}

#[test]
fn hydraulic_and_dc_motor_match_scipy() {
    let (hyd_ref, _) = reference("hydraulic_sine_f2_t0.5");
    let (dc_ref, _) = reference("dcmotor_sine_t0.5");
    for m in METHODS {
        let atol: Vec<f64> = HYD_NOMINAL.iter().map(|s| 1e-9 * s).collect();
        let mut y = HYD_Y0;
        solve(
            &Hydraulic {
                square: false,
                freq: 2.0,
            },
            m,
            1e-9,
            atol,
            0.5,
            &mut y,
        );
        let e = scaled_err(&y, &hyd_ref, &HYD_NOMINAL);
        assert!(e < 1e-6, "{m:?} hydraulic: {y:?} vs {hyd_ref:?} ({e:e})");

        let atol: Vec<f64> = DC_NOMINAL.iter().map(|s| 1e-9 * s).collect();
        let mut y = [0.0; 3];
        let sys = DcMotor {
            amp: 12.0,
            freq: 5.0,
            held: None,
            analytic: true,
        };
        solve(&sys, m, 1e-9, atol, 0.5, &mut y);
        let e = scaled_err(&y, &dc_ref, &DC_NOMINAL);
        assert!(e < 1e-6, "{m:?} dc motor: {y:?} vs {dc_ref:?} ({e:e})");
    }
}

/// A stiff decay `y0' = -k y0`
/// driving a forced state `y1' = -y1 + y0`, and two quadratures `q0' = y0^2`, `q1' = y0 y1` that
/// nothing depends on. Closed forms (y0(0) = 1, y1(0) = 0, k != 1):
/// `y0 = e^{-kt}`, `y1 = (e^{-t} - e^{-kt}) / (k - 1)`,
/// `q0 = (1 - e^{-2kt}) / (2k)`, `q1 = int_0^t y0 y1 = [ (1 - e^{-(k+1)t})/(k+1) - q0 ] / (k - 1)`.
struct WithQuadratures {
    k: f64,
    declared: usize,
}

impl OdeSystem for WithQuadratures {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, _t: f64, y: &[f64], f: &mut [f64]) {
        f[0] = -self.k * y[0];
        f[1] = -y[1] + y[0];
        f[2] = y[0] * y[0];
        f[3] = y[0] * y[1];
    }
    fn autonomous(&self) -> bool {
        true
    }
    fn quadratures(&self) -> usize {
        self.declared
    }
}

#[test]
fn quadrature_states_are_solved_by_substitution_exactly() {
    let k = 200.0;
    let t1 = 2.0;
    let e = |a: f64| (-a * t1).exp();
    let q0 = (1.0 - e(2.0 * k)) / (2.0 * k);
    let exact = [
        e(k),
        (e(1.0) - e(k)) / (k - 1.0),
        q0,
        ((1.0 - e(k + 1.0)) / (k + 1.0) - q0) / (k - 1.0),
    ];
    for m in METHODS {
        let mut results = Vec::new();
        for declared in [0, 2] {
            let mut y = [1.0, 0.0, 0.0, 0.0];
            let ig = solve(
                &WithQuadratures { k, declared },
                m,
                1e-8,
                vec![1e-10; 4],
                t1,
                &mut y,
            );
            for i in 0..4 {
                assert!(
                    (y[i] - exact[i]).abs() < 1e-7 * exact[i].abs().max(1e-3),
                    "{m:?} declared {declared}: y[{i}] = {} vs exact {}",
                    y[i],
                    exact[i]
                );
            }
            results.push((y, ig.stats().steps, ig.stats().rejected));
        }
        // W is block lower-triangular, so substitution solves the same linear systems: the same
        // steps are taken and the states agree to rounding (different elimination order).
        assert_eq!(results[0].1, results[1].1, "{m:?}: step counts differ");
        assert_eq!(results[0].2, results[1].2, "{m:?}: rejection counts differ");
        for i in 0..4 {
            let (a, b) = (results[0].0[i], results[1].0[i]);
            assert!(
                (a - b).abs() <= 1e-10 * a.abs().max(1e-6),
                "{m:?}: y[{i}] {a} vs {b}"
            );
        }
    }
}
