//! The paper's 40 Hz position controller (section IV, Fig. 7, eq. 23-26) as a pure discrete
//! update evaluated at the sample instants `t0 + k/f`.

use crate::physics::dead_band_inverse;
use serde::{Deserialize, Serialize};

/// Blend width [V] of the valve dead band edges (see [`crate::physics::dead_band`]); the
/// controller's inverse curve uses the same width so its compensation is exact.
pub const DEAD_BAND_BLEND: f64 = 0.02;
/// Saturation of the valve command [V] (D1FP command range +-10 V).
pub const U_MAX: f64 = 10.0;

/// What the controller knows: its rate, gain and the measured Fig. 6 curve it inverts.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct ControllerParams {
    /// Sample rate `f` [1/s] (40 Hz in the paper).
    pub rate: f64,
    /// Gain `K` [1] of eq. (25)-(26), applied to the desired speed (see [`piston_voltage`]).
    pub gain: f64,
    /// Pulley radius `R` [m].
    pub radius: f64,
    /// Fig. 6 slope above the positive dead band edge [m s^-1 V^-1] (extending).
    pub slope_extend: f64,
    /// Fig. 6 slope below the negative dead band edge [m s^-1 V^-1] (retracting).
    pub slope_retract: f64,
    /// Dead band edges of Fig. 6 [V].
    pub deadband_low: f64,
    pub deadband_high: f64,
    /// Co-contraction gain `K_c` [1] on the mean piston offset (see [`controller_update`]).
    pub cocontraction: f64,
}

/// Desired piston speed, paper eq. (23): `xdot = e f R` [m/s] with `e = theta_d - theta` [rad].
pub fn desired_piston_speed(e: f64, rate: f64, radius: f64) -> f64 {
    e * rate * radius
}

/// Paper eq. (25)-(26), `V = K f(xdot)`, read as `V = f(K xdot)`: the inverse of the Fig. 6
/// voltage-velocity curve (slope per side plus the dead-band jump) applied to the desired speed
/// scaled by `K`, saturated to +-10 V. Scaling the speed rather than the voltage keeps the
/// dead-band compensation exact for any `K` (a `K < 1` on the voltage would push small commands
/// back into the dead band and stall the joint with a standing error).
pub fn piston_voltage(xdot: f64, c: &ControllerParams) -> f64 {
    let v = c.gain * xdot;
    let y = if v >= 0.0 {
        v / c.slope_extend
    } else {
        v / c.slope_retract
    };
    dead_band_inverse(y, c.deadband_low, c.deadband_high, DEAD_BAND_BLEND).clamp(-U_MAX, U_MAX)
}

/// One controller sample: returns the held valve voltages `(u_left, u_right)` [V]. The left
/// piston's pull (extension) makes `theta` grow, so the differential speeds are
/// `xdot_L = e f R`, `xdot_R = -xdot_L` (eq. 23-24, section IV). The sum of the two spring
/// elongations, `2 e0 + 2 m` with the mean piston offset `m = (x_L + x_R)/2 - x0` [m] read from
/// the piston potentiometers (section II), does not depend on `theta`: the pretension is held
/// only while `m = 0`. Equal and opposite *commanded* speeds keep `m` constant only if both
/// valves deliver them; under load the pulling piston extends slower and the pulled one retracts
/// faster than the unloaded Fig. 6 curve promises, `m` drifts negative and the cables go slack.
/// So both pistons also get the common speed `-K_c f m` (the co-contraction loop, corrected at
/// the rate of eq. 23); `K_c = 0` is eq. 23-24 alone.
pub fn controller_update(
    theta_ref: f64,
    theta: f64,
    mean_offset: f64,
    c: &ControllerParams,
) -> (f64, f64) {
    let xdot = desired_piston_speed(theta_ref - theta, c.rate, c.radius);
    let common = -c.cocontraction * c.rate * mean_offset;
    (
        piston_voltage(xdot + common, c),
        piston_voltage(-xdot + common, c),
    )
}

#[cfg(test)]
mod tests {
    use super::{controller_update, ControllerParams, DEAD_BAND_BLEND};
    use crate::physics::dead_band;

    fn params() -> ControllerParams {
        ControllerParams {
            rate: 40.0,
            gain: 0.25,
            radius: 0.03,
            slope_extend: 0.05,
            slope_retract: 0.036,
            deadband_low: -1.8,
            deadband_high: 1.5,
            cocontraction: 1.0,
        }
    }

    #[test]
    fn zero_error_gives_zero_voltage() {
        assert_eq!(controller_update(0.3, 0.3, 0.0, &params()), (0.0, 0.0));
    }

    #[test]
    fn positive_error_extends_left_and_retracts_right_at_equal_speeds() {
        let c = params();
        let (ul, ur) = controller_update(0.1, 0.0, 0.0, &c);
        assert!(ul > c.deadband_high && ur < c.deadband_low);
        // through the (measured) Fig. 6 curve both give the same speed magnitude K e f R
        let want = c.gain * 0.1 * 40.0 * 0.03;
        let vl = c.slope_extend * dead_band(ul, -1.8, 1.5, DEAD_BAND_BLEND);
        let vr = c.slope_retract * dead_band(ur, -1.8, 1.5, DEAD_BAND_BLEND);
        assert!((vl - want).abs() < 1e-12 && (vr + want).abs() < 1e-12);
    }

    #[test]
    fn saturates_at_ten_volts() {
        let (ul, ur) = controller_update(10.0, 0.0, 0.0, &params());
        assert_eq!((ul, ur), (10.0, -10.0));
    }

    #[test]
    fn a_mean_piston_offset_moves_both_pistons_back_at_the_same_speed() {
        // pistons 2 mm retracted on average, no joint error: both extend at K K_c f 2 mm
        let c = params();
        let (ul, ur) = controller_update(0.0, 0.0, -2e-3, &c);
        let want = c.gain * c.cocontraction * 40.0 * 2e-3;
        let vl = c.slope_extend * dead_band(ul, -1.8, 1.5, DEAD_BAND_BLEND);
        let vr = c.slope_extend * dead_band(ur, -1.8, 1.5, DEAD_BAND_BLEND);
        assert!(
            (vl - want).abs() < 1e-12 && (vr - want).abs() < 1e-12,
            "{vl} {vr}"
        );
    }
}
