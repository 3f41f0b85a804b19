//! `Integrator::integrate_observed`: an observer that never stops changes nothing; one that stops
//! ends the call at the end of the accepted step where it said so.
// Closed-form references use the platform libm, independent of the `libm` crate the solver
// uses (workspace clippy.toml).
#![allow(clippy::disallowed_methods)]

use ode::{Integrator, OdeSystem};

/// Harmonic oscillator `x'' = -x` from (1, 0): `x = cos t`, `v = -sin t`.
struct Oscillator;

impl OdeSystem for Oscillator {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        dydt[0] = y[1];
        dydt[1] = -y[0];
    }
}

#[test]
fn an_observer_that_never_stops_gives_the_steps_and_values_of_integrate() {
    let mut a = Integrator::new(1e-8, vec![1e-10; 2]);
    let mut b = a.clone();
    let (mut ya, mut yb) = ([1.0, 0.0], [1.0, 0.0]);
    let mut seen = Vec::new();
    for k in 0..5 {
        let (t0, t1) = (k as f64, k as f64 + 1.0);
        a.integrate(&Oscillator, t0, t1, &mut ya).unwrap();
        let reached = b
            .integrate_observed(&Oscillator, t0, t1, &mut yb, |t, _| {
                seen.push(t);
                false
            })
            .unwrap();
        assert_eq!(reached, t1);
        assert_eq!(ya.map(f64::to_bits), yb.map(f64::to_bits));
    }
    assert_eq!(a.stats(), b.stats());
    assert_eq!(seen.len() as u64, b.stats().steps);
    assert!(seen.windows(2).all(|w| w[0] < w[1]) && *seen.last().unwrap() == 5.0);
}

#[test]
fn an_observer_stops_the_call_at_the_step_where_it_says_so() {
    let mut ode = Integrator::new(1e-8, vec![1e-10; 2]);
    let mut y = [1.0, 0.0];
    let mut before = (0.0, 1.0);
    let reached = ode
        .integrate_observed(&Oscillator, 0.0, 10.0, &mut y, |t, y| {
            if y[0] > 0.0 {
                before = (t, y[0]);
            }
            y[0] <= 0.0
        })
        .unwrap();
    // the first accepted step past x = 0 (t = pi/2), the step before it still short of it
    assert!(reached > std::f64::consts::FRAC_PI_2 && before.0 < std::f64::consts::FRAC_PI_2);
    assert!(reached < 10.0 && y[0] <= 0.0 && before.1 > 0.0);
    assert!(
        (y[0] - reached.cos()).abs() < 1e-7,
        "{} vs {}",
        y[0],
        reached.cos()
    );
    // the next call continues from there
    let reached2 = ode
        .integrate_observed(&Oscillator, reached, 10.0, &mut y, |_, _| false)
        .unwrap();
    assert_eq!(reached2, 10.0);
    assert!(
        (y[0] - 10f64.cos()).abs() < 1e-6,
        "{} vs {}",
        y[0],
        10f64.cos()
    );
}
