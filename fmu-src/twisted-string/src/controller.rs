//! Cascade controller of Fig. 11 / Table 5 (ESCON current and speed PI, sbRIO position P with the
//! +-2 deg hysteresis band of eq. 20-21).
//!
//! Modelling choice (documented in the FMU documentation): the ESCON runs its current loop at
//! 53.6 kHz and its speed loop at 5.36 kHz, two decades above the mechanical bandwidth; both are
//! modelled as continuous PI controllers (their integrators are ODE states), with clamping
//! anti-windup. The position loop runs on the sbRIO and is sampled at `controller_position_period`
//! (default 1 ms) from the 4x-decoded encoder angle; its output (the speed set point) is held
//! between samples.

use serde::{Deserialize, Serialize};

/// Proportional-integral law in the ideal form `u = K (e + z / Ti)` with integrator state
/// `z = int e dt`, saturated to `[-u_max, u_max]`. Returns `(u_sat, u_unsat)`.
#[inline]
pub fn pi_output(k: f64, ti: f64, e: f64, z: f64, u_max: f64) -> (f64, f64) {
    let u = k * (e + z / ti);
    (u.clamp(-u_max, u_max), u)
}

/// Width of the fade-out of integration beyond the output limit, relative to the limit.
pub const CLAMP_FADE: f64 = 0.01;

/// Integrator rate with conditional-integration (clamping) anti-windup: `dz/dt = e (1 - s)`, where
/// `s` = 0 unless the unsaturated output `u` exceeds the limit and `e` drives it further out
/// (`e u > 0`); then `s` rises linearly from 0 at `|u| = u_max` to 1 at `|u| = (1 + 0.01) u_max`
/// (Astrom & Hagglund, "Advanced PID control", sec. 3.5, conditional integration; the linear fade
/// keeps the right-hand side continuous for the error-controlled solver).
#[inline]
pub fn pi_integrator_rate(e: f64, u: f64, u_max: f64) -> f64 {
    if e * u <= 0.0 {
        return e;
    }
    let s = ((u.abs() - u_max) / (CLAMP_FADE * u_max)).clamp(0.0, 1.0);
    e * (1.0 - s)
}

/// Position P controller of the sbRIO with the hysteresis band of eq. 20-21.
/// While `SP - band < PV < SP + band` the loop is satisfied and commands zero speed (the ESCON
/// speed loop holds the motor); outside it commands `K_pos (SP - PV)` clamped to the speed limit.
/// So the motor stops at the first sample inside the band: the steady-state error is below `band`
/// and depends on the approach direction (the hysteresis). Returns the speed set point [rad/s].
#[inline]
pub fn position_loop(sp: f64, pv: f64, k_pos: f64, band: f64, omega_max: f64) -> f64 {
    let e = sp - pv;
    if e > -band && e < band {
        0.0
    } else {
        (k_pos * e).clamp(-omega_max, omega_max)
    }
}

/// Discrete state of the sampled position loop.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct PositionLoop {
    /// Index of the next sample instant not yet processed (an integer counter: the instants
    /// are `ode::SampleClock::time(k) = t0 + k Ts`, never accumulated).
    pub next_sample: u64,
    /// Speed set point held since the last sample [rad/s].
    pub omega_ref: f64,
}

#[cfg(test)]
mod tests {
    use super::{pi_integrator_rate, pi_output, position_loop};

    #[test]
    fn pi_saturates_and_tracks() {
        let (u, uu) = pi_output(2.0, 0.5, 1.0, 0.25, 10.0);
        assert_eq!(u, 3.0);
        assert_eq!(uu, 3.0);
        let (u, uu) = pi_output(2.0, 0.5, 10.0, 0.0, 3.0);
        assert_eq!(u, 3.0);
        assert_eq!(uu, 20.0);
        // unsaturated: plain integral of e
        assert_eq!(pi_integrator_rate(1.5, 2.9, 3.0), 1.5);
        // saturated and pushing further: stopped
        assert_eq!(pi_integrator_rate(10.0, 20.0, 3.0), 0.0);
        // saturated but the error pulls back: integrates
        assert_eq!(pi_integrator_rate(-1.0, 20.0, 3.0), -1.0);
        // halfway through the fade
        assert!((pi_integrator_rate(2.0, 3.015, 3.0) - 1.0).abs() < 1e-12);
        // continuous at e = 0
        assert_eq!(pi_integrator_rate(0.0, 20.0, 3.0), 0.0);
    }

    #[test]
    fn position_band_and_limit() {
        let band = 2f64.to_radians();
        assert_eq!(
            position_loop(10.0, 10.0 - 0.9 * band, 8.75, band, 837.0),
            0.0
        );
        assert_eq!(
            position_loop(10.0, 10.0 + 0.9 * band, 8.75, band, 837.0),
            0.0
        );
        let w = position_loop(10.0, 10.0 - 1.5 * band, 8.75, band, 837.0);
        assert!((w - 8.75 * 1.5 * band).abs() < 1e-12);
        assert_eq!(position_loop(2011.0, 0.0, 8.75, band, 837.0), 837.0);
        assert_eq!(position_loop(-2011.0, 0.0, 8.75, band, 837.0), -837.0);
    }
}
