//! The equations of the EMPS axis as pure functions, each with its source. Units are SI on the
//! load side (positions in m, forces in N), as the benchmark writes them.

use ode::math::tanh;

/// Friction coefficients of one direction of motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Friction {
    /// Viscous coefficient Fv [N.s/m].
    pub viscous: f64,
    /// Coulomb force Fc [N].
    pub coulomb: f64,
}

/// Smooth sign `tanh(v / v_s)`: the Coulomb term `Fc sign(v)` of description eq. 1 made
/// continuous, so that an error-controlled solver integrates through a velocity reversal. It
/// differs from `sign(v)` by less than 1e-3 for `|v| > 3.8 v_s`.
#[inline]
pub fn smooth_sign(v: f64, v_s: f64) -> f64 {
    tanh(v / v_s)
}

/// Friction force `Fv v + Fc sgn(v)` with the coefficients of the direction of `v`
/// (description eq. 1; per direction, eq. 12: `Fv+ 0+(v) + Fc+ sign(0+(v)) + Fv- 0-(v) + ...`),
/// times the factor of the position along the screw.
#[inline]
pub fn friction_force(
    v: f64,
    positive: Friction,
    negative: Friction,
    v_s: f64,
    factor: f64,
) -> f64 {
    let f = if v >= 0.0 { positive } else { negative };
    factor * (f.viscous * v + f.coulomb * smooth_sign(v, v_s))
}

/// `d/dv` of [`friction_force`] (without the position factor):
/// `Fv + Fc (1 - tanh^2(v / v_s)) / v_s` with the coefficients of the direction of `v`.
#[inline]
pub fn friction_slope(v: f64, positive: Friction, negative: Friction, v_s: f64) -> f64 {
    let f = if v >= 0.0 { positive } else { negative };
    let th = smooth_sign(v, v_s);
    f.viscous + f.coulomb * (1.0 - th * th) / v_s
}

/// Partial derivatives `(dF/d delta, dF/d rate)` of [`coupling_force`]: `(k, c)` in contact,
/// `(0, 0)` across the play.
#[inline]
pub fn coupling_slopes(delta: f64, k: f64, c: f64, play: f64) -> (f64, f64) {
    if play > 0.0 && dead_zone(delta, play) == 0.0 {
        (0.0, 0.0)
    } else {
        (k, c)
    }
}

/// Factor of the friction at position `q`: `1 + c (q - q_mid) / q_half` (friction varying
/// linearly along the screw; 1 without the effect).
#[inline]
pub fn position_factor(q: f64, change: Option<f64>, q_mid: f64, q_half: f64) -> f64 {
    change.map_or(1.0, |c| 1.0 + c * (q - q_mid) / q_half)
}

/// Dead zone of the play: the spring deflection `delta - b/2 sign(delta)` outside `|delta| <= b/2`,
/// 0 inside (`b` = total play; `b = 0` gives `delta`).
#[inline]
pub fn dead_zone(delta: f64, play: f64) -> f64 {
    let half = 0.5 * play;
    if delta > half {
        delta - half
    } else if delta < -half {
        delta + half
    } else {
        0.0
    }
}

/// Force of the screw on the load in the two-mass model: `k dz(delta) + c delta'` while in
/// contact (`|delta| > b/2`), 0 across the play. `delta = q - q_load`.
#[inline]
pub fn coupling_force(delta: f64, rate: f64, k: f64, c: f64, play: f64) -> f64 {
    let d = dead_zone(delta, play);
    if d == 0.0 && play > 0.0 {
        0.0
    } else {
        k * d + c * rate
    }
}

/// Damping coefficient `c = 2 zeta sqrt(k m_r)` of a spring between masses `m1` and `m2`
/// (reduced mass `m_r = m1 m2 / (m1 + m2)`): damping ratio `zeta` of the two-mass mode.
#[inline]
pub fn mode_damping(zeta: f64, k: f64, m1: f64, m2: f64) -> f64 {
    2.0 * zeta * (k * m1 * m2 / (m1 + m2)).sqrt()
}

/// The logged controller's velocity: `qfm(k) = (qm(k) + qm(k-1)) / 2`,
/// `v(k) = (qfm(k) - qfm(k-1)) / Ts = (qm(k) - qm(k-2)) / (2 Ts)` (description sec. 2.2).
#[inline]
pub fn controller_velocity(qm: f64, qm_2: f64, ts: f64) -> f64 {
    (qm - qm_2) / (2.0 * ts)
}

/// Cascade law `nu = kv (kp (qg - qm) - v)` [V] (description eq. 6: P position loop around a
/// P velocity loop), plus the pulse voltage, saturated at `+-u_max` (Simulation_EMPS.m: 10 V).
#[inline]
pub fn controller_voltage(
    qg: f64,
    qm: f64,
    v: f64,
    kp: f64,
    kv: f64,
    pulse_v: f64,
    u_max: f64,
) -> f64 {
    (kv * (kp * (qg - qm) - v) + pulse_v).clamp(-u_max, u_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn friction_per_direction_and_position() {
        let pos = Friction {
            viscous: 166.7,
            coulomb: 20.14,
        };
        let neg = Friction {
            viscous: 240.4,
            coulomb: 20.63,
        };
        let f = friction_force(0.1, pos, neg, 1e-6, 1.0);
        assert!((f - (16.67 + 20.14)).abs() < 1e-9);
        let f = friction_force(-0.1, pos, neg, 1e-6, 1.0);
        assert!((f + 24.04 + 20.63).abs() < 1e-9);
        assert_eq!(friction_force(0.0, pos, neg, 1e-4, 1.0), 0.0);
        assert!((position_factor(0.25, Some(0.1), 0.125, 0.125) - 1.1).abs() < 1e-12);
        assert_eq!(position_factor(0.25, None, 0.125, 0.125), 1.0);
    }

    #[test]
    fn play_and_coupling() {
        assert_eq!(dead_zone(5e-6, 20e-6), 0.0);
        assert!((dead_zone(15e-6, 20e-6) - 5e-6).abs() < 1e-18);
        assert!((dead_zone(-15e-6, 20e-6) + 5e-6).abs() < 1e-18);
        assert_eq!(coupling_force(5e-6, 1.0, 1e7, 100.0, 20e-6), 0.0);
        assert!((coupling_force(1e-6, 0.01, 1e7, 100.0, 0.0) - 11.0).abs() < 1e-9);
    }

    #[test]
    fn controller_matches_the_logged_law() {
        // DATA_EMPS.mat samples 2 and 0: qm = 2.185e-5, qm(k-2) = 7.45e-6, qg = 1.3646232e-4,
        // logged vir = 2.722679781 V (the law reproduces the file to 3.7 mV RMS, 6 mV here)
        let v = controller_velocity(2.185e-5, 7.45e-6, 1e-3);
        assert!((v - 0.0072).abs() < 1e-12);
        let u = controller_voltage(1.364_623_2e-4, 2.185e-5, v, 160.18, 243.45, 0.0, 10.0);
        assert!((u - 2.722_679_781).abs() < 1e-2, "{u}");
        assert_eq!(
            controller_voltage(1.0, 0.0, 0.0, 160.18, 243.45, 0.0, 10.0),
            10.0
        );
    }
}
