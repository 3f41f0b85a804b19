//! Pure physics of the twisted-string actuator (SI units throughout).
//!
//! Paper: D. Urukalo, M. D. Jovanovic, A. Rodic, "Modeling, Development and Control of Linear
//! Twisted-String Actuator" (seed `001_97c94864f93437ff.txt`), equations (9)-(21), Tables 2-5.
//! Angles: `theta_m` is the motor shaft angle, `theta_t = theta_m / N` the twist angle of the
//! string bundle (gearhead output). Tables 2-4 (eq. 7, 10, 17) use the MOTOR angle in rad
//! (0-2011 rad = 0-6000 deg of twist x 19.2); eq. 9 and 13-16 use `theta r` with the TWIST angle
//! and the physical bundle radius (equivalently motor angle x radius / N).

use std::f64::consts::PI;

/// Standard gravity [m/s2]; the paper's loads are `F = m g` (so a load of F newtons is `load_mass = F / 9.81`).
pub const GRAVITY: f64 = 9.81;

/// Smooth positive part `max(x, 0) ~ (x + sqrt(x^2 + w^2)) / 2` and its derivative.
/// Regularises string slack / dead-zone edges so an error-controlled solver keeps its step size;
/// the error against the exact max is at most `w / 2` (at `x = 0`) and `w^2 / (4|x|)` away from it.
#[inline]
pub fn smooth_pos(x: f64, w: f64) -> (f64, f64) {
    let s = (x * x + w * w).sqrt();
    (0.5 * (x + s), 0.5 * (1.0 + x / s))
}

/// Inverse of [`smooth_pos`] for `y > 0`: the `x` with `smooth_pos(x, w) = y`,
/// `x = y - w^2 / (4 y)` (closed form, used to start exactly in equilibrium).
#[inline]
pub fn smooth_pos_inverse(y: f64, w: f64) -> f64 {
    y - w * w / (4.0 * y)
}

/// Torque of the gearhead flanks on the output (`gear_backlash`) and its partial derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlankTorque {
    /// Torque on the output [N.m] (positive: toward positive twist).
    pub tau: f64,
    /// d tau / d delta [N.m/rad].
    pub d_delta: f64,
    /// d tau / d delta_rate [N.m.s/rad].
    pub d_rate: f64,
    /// Elastic part `k (pos(pen+) - pos(pen-))` [N.m]; its primitive is [`flank_energy`].
    pub elastic: f64,
    /// d elastic / d delta [N.m/rad].
    pub d_elastic: f64,
}

/// Mesh of the gearhead output with backlash of total width `b` (documentation, section 7).
/// `delta = theta_m / N - theta_t` is the position of the output in the gap (output side); the
/// motor-side flank touches at `delta = +b/2` (driving toward positive twist) or at
/// `delta = -b/2`. Each flank pushes with a Kelvin-Voigt mesh that acts only in contact and
/// cannot pull: `tau+ = pos(k pos(pen) + d pos'(pen) pen_rate, w_tau)` with the penetration
/// `pen = delta - b/2` and `pen_rate = delta_rate` ([`smooth_pos`] of width `w_pen` inside, so
/// the damper acts only once the teeth touch; the outer `pos` of width `w_tau` because a flank
/// cannot pull while the teeth separate, the tension artefact of the plain Kelvin-Voigt contact
/// that Hunt and Crossley (1975) pointed out). The other flank is the mirror image:
/// `tau = tau+(delta, rate) - tau+(-delta, -rate)`. Inside the gap both outer terms are
/// `w_tau/2 + O(k w_pen^2 / |pen|)` and cancel to that order.
#[inline]
pub fn flank_torque(delta: f64, delta_rate: f64, b: f64, mesh: &Mesh) -> FlankTorque {
    let mut out = FlankTorque {
        tau: 0.0,
        d_delta: 0.0,
        d_rate: 0.0,
        elastic: 0.0,
        d_elastic: 0.0,
    };
    for sgn in [1.0, -1.0] {
        let pen = sgn * delta - 0.5 * b;
        let rate = sgn * delta_rate;
        let (r, dr) = smooth_pos(pen, mesh.w_pen);
        let ddr = smooth_pos_second(pen, mesh.w_pen);
        let (t, dt) = smooth_pos(mesh.k * r + mesh.d * dr * rate, mesh.w_tau);
        // tau = sgn t(pen(delta)): the two signs of d/d delta cancel, likewise for the rate
        out.tau += sgn * t;
        out.d_delta += dt * (mesh.k * dr + mesh.d * ddr * rate);
        out.d_rate += dt * mesh.d * dr;
        out.elastic += sgn * mesh.k * r;
        out.d_elastic += mesh.k * dr;
    }
    out
}

/// Elastic energy of the flanks, `k (Phi(delta - b/2) + Phi(-delta - b/2))` with the primitive
/// [`smooth_pos_primitive`] of the smoothed penetration: its derivative in `delta` is
/// [`FlankTorque::elastic`].
#[inline]
pub fn flank_energy(delta: f64, b: f64, mesh: &Mesh) -> f64 {
    mesh.k
        * (smooth_pos_primitive(delta - 0.5 * b, mesh.w_pen)
            + smooth_pos_primitive(-delta - 0.5 * b, mesh.w_pen))
}

/// Contact law of the gear mesh at the output (see [`flank_torque`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mesh {
    /// Stiffness of the meshing teeth at the output [N.m/rad].
    pub k: f64,
    /// Damping while in contact [N.m.s/rad].
    pub d: f64,
    /// Smoothing width of the penetration [rad].
    pub w_pen: f64,
    /// Smoothing width of "a flank only pushes" [N.m].
    pub w_tau: f64,
}

/// Second derivative of [`smooth_pos`]: `w^2 / (2 (x^2 + w^2)^(3/2))`.
#[inline]
pub fn smooth_pos_second(x: f64, w: f64) -> f64 {
    let q = x * x + w * w;
    0.5 * w * w / (q * q.sqrt())
}

/// Effective helix radius of a bundle of four round strings of diameter `d` packed in a square:
/// centres at `d / sqrt(2)` from the axis plus the string radius, `r = (1/sqrt(2) + 1/2) d`.
/// For d = 1 mm: 1.2071 mm; the least-squares fit of eq. 9-10 (Table 3) to the Table 2 regression
/// gives 1.2060 mm and to the measured contractions of sec. 6 1.2127 mm (the default, see the
/// documentation, section 2).
pub fn bundle_radius(d: f64) -> f64 {
    (std::f64::consts::FRAC_1_SQRT_2 + 0.5) * d
}

/// Sign of `x` for the derivatives of `|x|`, with the right-hand value 1 at 0 (also at -0): the
/// paper twists forward from zero, so at zero twist the forward derivative applies.
#[inline]
pub fn sign_fwd(x: f64) -> f64 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Bundle radius growing with the amount of twist (`radius_growth`):
/// `r = r0 (1 + g |theta_t| / (2 pi))`, `g` the relative growth per turn (ref. [13] of the paper:
/// the radius varies with twist). `|theta_t|`: twisting either way packs the bundle alike.
/// Returns the "twist arc" `a = theta_t r(theta_t)` and `da/dtheta_t = r0 (1 + 2 g |theta_t| / (2 pi))`
/// (continuous through 0; `d2a/dtheta_t2 = 2 r0 g sign(theta_t) / (2 pi)`, forward value at 0).
#[inline]
pub fn twist_arc(theta_t: f64, r0: f64, growth_per_turn: f64) -> (f64, f64) {
    let k = growth_per_turn / (2.0 * PI);
    let r = r0 * (1.0 + k * theta_t.abs());
    (theta_t * r, r + theta_t.abs() * r0 * k)
}

/// Length of a helix strand of axial length `p` and twist arc `a = theta r` (Pythagoras, Fig. 12):
/// `L = sqrt(p^2 + a^2)`; eq. 9 read backward.
#[inline]
pub fn strand_length(p: f64, a: f64) -> f64 {
    (p * p + a * a).sqrt()
}

/// Eq. 9: axial length of a helix of strand length `l` and twist arc `a`: `p = sqrt(l^2 - a^2)`
/// (0 at and beyond full twist).
#[inline]
pub fn helix_position(l: f64, a: f64) -> f64 {
    (l * l - a * a).max(0.0).sqrt()
}

/// Eq. 10 without its load term: unloaded strand length `L0 + a1 |theta_M| + a2 theta_M^2`
/// (theta_M = motor-referred twist angle in rad, Table 3, where theta_M >= 0) and its derivative
/// w.r.t. theta_M. `|theta_M|`: the strands lengthen with the amount of twist whichever the
/// direction (the paper only twists one way; the linear term read as odd would shorten strings
/// twisted backward). The load term `a3 F_L` of eq. 10 is the bundle's axial compliance, see
/// [`string_tension`].
#[inline]
pub fn free_length(theta_motor: f64, l0: f64, a1: f64, a2: f64) -> (f64, f64) {
    (
        l0 + a1 * theta_motor.abs() + a2 * theta_motor * theta_motor,
        a1 * sign_fwd(theta_motor) + 2.0 * a2 * theta_motor,
    )
}

/// Total strand tension of the bundle (sum over the n strings) from the strand stretch `s` and its
/// rate: `T = pos(s / c + d s_dot)` (Kelvin-Voigt, smooth positive part of width `w` [N] because a
/// string cannot push). `c` is the axial compliance [m/N]: `a3` of eq. 10 (Table 3) with
/// `string_compliance`, else `1 / string_stiffness` (nearly inextensible). Returns `(T, dT/dx)`
/// where `x = s / c + d s_dot`.
#[inline]
pub fn string_tension(s: f64, s_dot: f64, c: f64, d: f64, w: f64) -> (f64, f64) {
    smooth_pos(s / c + d * s_dot, w)
}

/// `string_compliance` (eq. 9-10 as the paper fits them): the elongation is `a3 F_L`, proportional
/// to the axial LOAD, not to the strand tension. With `x = pos(s / a3 + d s_dot)` the load is
/// `F_L = x p / q` and the strand tension `T = x L / q` (so `F_L = T p / L`, eq. 12/19), where
/// `q = sqrt(p^2 + p_eps^2)` regularises p: for p >> p_eps (all of the paper's range, p > 5 cm with
/// p_eps = 1 mm: relative effect < 2e-4) `F_L = x` exactly as eq. 10, while at p -> 0 the load
/// force fades out like the strand model's, so a stalled motor cannot pull the load through the
/// motor and T stays finite. Returns `(T, F_L)`.
#[inline]
pub fn load_form_forces(x: f64, p: f64, l: f64, p_eps: f64) -> (f64, f64) {
    let q = (p * p + p_eps * p_eps).sqrt();
    (x * l / q, x * p / q)
}

/// Axial stiffness `dF_L/dp` at fixed twist of the `string_compliance` law
/// `F_L = (s / a3) p / q` (s = L - L_free, dL/dp = p/L, q = sqrt(p^2 + p_eps^2)):
/// `k = (p/L)(p/q) / a3 + (s / a3) p_eps^2 / q^3` (falls with twist as cos(alpha) / a3).
#[inline]
pub fn axial_stiffness_load_form(s: f64, p: f64, l: f64, a3: f64, p_eps: f64) -> f64 {
    let q = (p * p + p_eps * p_eps).sqrt();
    (p / l) * (p / q) / a3 + s / a3 * p_eps * p_eps / (q * q * q)
}

/// Eq. 12/19: axial force on the load `F_L = T cos(alpha) = T p / L` (T = n F_i).
#[inline]
pub fn axial_force(t: f64, p: f64, l: f64) -> f64 {
    t * p / l
}

/// Eq. 14-15: tangential force `F_tau = T sin(alpha) = T a / L` (= F_L theta r / p).
#[inline]
pub fn tangential_force(t: f64, a: f64, l: f64) -> f64 {
    t * a / l
}

/// Eq. 13-14: torque of the strings on the twisting shaft `tau_L = F_tau r = F_L theta r^2 / p`,
/// written `T a a' / L` (a = theta r, a' = da/dtheta; equals eq. 13 for a constant radius and
/// stays finite at full twist where p -> 0).
#[inline]
pub fn twist_torque(t: f64, a: f64, da: f64, l: f64) -> f64 {
    t * a * da / l
}

/// Eq. 19: helix slope `alpha = acos(F_L / (n F_i)) = atan2(theta r, p)`.
#[inline]
pub fn helix_slope(p: f64, a: f64) -> f64 {
    ode::math::atan2(a, p)
}

/// Eq. 13 read as a transmission: `dp/dtheta_t` at constant tension. From `p^2 + a^2 = L^2` with
/// `L = L_free(theta) + c T`: `dp/dtheta_t = (L dL_free/dtheta_t - a a') / p` (= -theta r^2 / p
/// for the inextensible helix). `p` is floored at `p_min` to stay finite at full twist.
#[inline]
pub fn transmission_ratio(
    p: f64,
    l: f64,
    a: f64,
    da: f64,
    dlfree_dtheta_t: f64,
    p_min: f64,
) -> f64 {
    (l * dlfree_dtheta_t - a * da) / p.max(p_min)
}

/// Axial stiffness of the bundle at the load, `k = dF_L/dp` at fixed twist, from `F_L = T p / L`
/// and `T = (L - L_free) / c`: `k = (p/L)^2 / c + T a^2 / L^3` (cos^2(alpha)/c falls with twist:
/// Fig. 19's decreasing stiffness).
#[inline]
pub fn axial_stiffness(t: f64, p: f64, a: f64, l: f64, c: f64) -> f64 {
    let cos = p / l;
    cos * cos / c + t * a * a / (l * l * l)
}

/// Armature: `L di/dt = u - R i - k_e omega` (DC motor, e.g. N. Mohan [22] ch. 7). Returns di/dt.
#[inline]
pub fn armature_current_rate(u: f64, i: f64, omega: f64, r: f64, l: f64, ke: f64) -> f64 {
    (u - r * i - ke * omega) / l
}

/// Electromagnetic torque `tau_m = k_t i`.
#[inline]
pub fn motor_torque(kt: f64, i: f64) -> f64 {
    kt * i
}

/// Gearhead efficiency applied in the direction of the power flow: the torque needed at the motor
/// for an output torque `tau_out` at output speed `omega_out` is `tau_out / (N eta)` when the motor
/// drives the load (P = tau_out omega_out > 0) and `tau_out eta / N` when the load drives the
/// motor. The switch is blended with `tanh(P / p_w)` (p_w [W] small) to keep the RHS smooth.
/// Returns the factor `f` with `tau_in = f tau_out / N`, and df/dP.
#[inline]
pub fn gear_efficiency_factor(power_out: f64, eta: f64, p_w: f64) -> (f64, f64) {
    let mean = 0.5 * (1.0 / eta + eta);
    let half = 0.5 * (1.0 / eta - eta);
    let th = ode::math::tanh(power_out / p_w);
    (mean + half * th, half * (1.0 - th * th) / p_w)
}

/// Encoder read 4x: `4 cpt` quadrature counts per revolution; the measured angle is
/// `floor(theta 4 cpt / (2 pi)) 2 pi / (4 cpt)` (1000 CPT -> 0.09 deg resolution).
#[inline]
pub fn encoder_quantize(theta: f64, cpt: f64) -> f64 {
    let per_count = 2.0 * PI / (4.0 * cpt);
    (theta / per_count).floor() * per_count
}

/// Return spring between the motor bracket and the moving bracket, pushing the load away from the
/// motor (toward the untwisted length, Fig. 7 part 6): `F_s = F_0 + k (L0 - p)`.
#[inline]
pub fn spring_force(p: f64, l0: f64, k: f64, preload: f64) -> f64 {
    preload + k * (l0 - p)
}

/// Linear guides (4 guides, linear bearings): plain viscous friction `F = c v` (the paper gives no friction model for them).
#[inline]
pub fn guide_friction(v: f64, c: f64) -> f64 {
    c * v
}

/// Motor-shaft friction (`motor_friction`): `tau = tau_c tanh(omega / omega_s) + b omega`,
/// Coulomb smoothed over `omega_s` [rad/s], viscous `b`. Returns (tau, dtau/domega).
#[inline]
pub fn motor_friction(omega: f64, coulomb: f64, viscous: f64, omega_s: f64) -> (f64, f64) {
    let th = ode::math::tanh(omega / omega_s);
    (
        coulomb * th + viscous * omega,
        coulomb * (1.0 - th * th) / omega_s + viscous,
    )
}

/// Inter-strand friction (`twist_hysteresis`): a torque opposing the twist rate proportional to the
/// strand tension, `tau_h = mu T a' tanh(omega_t / omega_h)` (a' = effective radius): twisting needs
/// more and untwisting less torque under one load, so the paths differ. Returns
/// (tau_h, dtau_h/dT, dtau_h/domega_t) for fixed a'.
#[inline]
pub fn strand_friction(t: f64, da: f64, omega_t: f64, mu: f64, omega_h: f64) -> (f64, f64, f64) {
    let th = ode::math::tanh(omega_t / omega_h);
    (
        mu * t * da * th,
        mu * da * th,
        mu * t * da * (1.0 - th * th) / omega_h,
    )
}

/// Load on the guides (vertical, p grows downward): `m dv/dt = m g + F_ext + F_s - F_L - c v`.
/// Returns dv/dt.
#[inline]
pub fn load_acceleration(mass: f64, f_ext: f64, f_spring: f64, f_axial: f64, f_fric: f64) -> f64 {
    (mass * GRAVITY + f_ext + f_spring - f_axial - f_fric) / mass
}

/// Primitive of the smooth positive part, `Phi(x) = int_0^x pos(z) dz
/// = (x^2 + x sqrt(x^2 + w^2) + w^2 asinh(x / w)) / 4` (dPhi/dx = pos(x)). The elastic energy of a
/// spring whose force is `pos(s / c)` is `c Phi(s / c)` (zero at s = 0, slightly negative when slack).
#[inline]
pub fn smooth_pos_primitive(x: f64, w: f64) -> f64 {
    0.25 * (x * x + x * (x * x + w * w).sqrt() + w * w * ode::math::asinh(x / w))
}

/// Kinetic energy `J omega^2 / 2` (rotor) or `m v^2 / 2` (load), and magnetic energy `L i^2 / 2`.
#[inline]
pub fn quadratic_energy(k: f64, x: f64) -> f64 {
    0.5 * k * x * x
}

/// Potential energy of the load above the untwisted length (p grows downward, gravity pulls toward
/// +p) plus that of the return spring `F_s = F_0 + k (L0 - p)` (`-dV/dp = m g + F_s`):
/// `V = (m g + F_0)(L0 - p) + k (L0 - p)^2 / 2`.
#[inline]
pub fn load_potential(mass: f64, p: f64, l0: f64, k: f64, preload: f64) -> f64 {
    let d = l0 - p;
    (mass * GRAVITY + preload) * d + 0.5 * k * d * d
}

#[cfg(test)]
mod tests {
    use super::{
        armature_current_rate, axial_force, axial_stiffness, axial_stiffness_load_form,
        bundle_radius, encoder_quantize, flank_energy, flank_torque, free_length,
        gear_efficiency_factor, guide_friction, helix_position, helix_slope, load_acceleration,
        load_form_forces, load_potential, motor_friction, motor_torque, quadratic_energy, sign_fwd,
        smooth_pos, smooth_pos_inverse, smooth_pos_primitive, spring_force, strand_friction,
        strand_length, tangential_force, transmission_ratio, twist_arc, twist_torque, Mesh,
        GRAVITY,
    };
    use std::f64::consts::PI;

    #[test]
    fn smooth_pos_limits_and_inverse() {
        let w = 1e-3;
        assert!((smooth_pos(1.0, w).0 - 1.0).abs() < 1e-6);
        assert!(smooth_pos(-1.0, w).0 < 1e-6 && smooth_pos(-1.0, w).0 > 0.0);
        assert!((smooth_pos(0.0, w).0 - 0.5e-3).abs() < 1e-15);
        for y in [1e-2, 1.0, 37.5, 1e4] {
            let x = smooth_pos_inverse(y, w);
            assert!((smooth_pos(x, w).0 - y).abs() < 1e-12 * y.max(1.0));
        }
        // derivative by central difference
        let x = 3e-4;
        let fd = (smooth_pos(x + 1e-9, w).0 - smooth_pos(x - 1e-9, w).0) / 2e-9;
        assert!((fd - smooth_pos(x, w).1).abs() < 1e-6);
    }

    #[test]
    fn flank_torque_contact_gap_and_derivatives() {
        let b = 1f64.to_radians();
        let m = Mesh {
            k: 1000.0,
            d: 0.0775,
            w_pen: 1e-6,
            w_tau: 1e-5,
        };
        let h = 0.5 * b;
        // in the gap: no torque but the tails of the smoothing, k w^2/(4 |pen|) elastic and
        // d |v| w^2/(4 pen^2) damping of the nearer flank (0.7 uN.m at 0.05 deg from the flank
        // approaching at 40 rad/s)
        for (x, v) in [
            (0.0, 0.0),
            (0.5 * h, 40.0),
            (-0.9 * h, -40.0),
            (0.95 * h, 40.0),
        ] {
            let f = flank_torque(x, v, b, &m);
            let pen = h - f64::abs(x);
            let w2 = m.w_pen * m.w_pen;
            let tail = m.k * w2 / (4.0 * pen) + m.d * f64::abs(v) * w2 / (4.0 * pen * pen);
            assert!(
                f.tau.abs() <= tail && tail < 1e-4,
                "{x} {v}: {} > {tail}",
                f.tau
            );
        }
        // held in contact on either flank: k * penetration (+ damping while pressing)
        let f = flank_torque(h + 1e-3, 0.0, b, &m);
        assert!((f.tau - 1.0).abs() < 1e-5 && (f.elastic - 1.0).abs() < 1e-5);
        let f = flank_torque(-h - 1e-3, -2.0, b, &m);
        assert!((f.tau + 1.0 + 2.0 * m.d).abs() < 1e-5, "{}", f.tau);
        // separating fast: the flank does not pull (beyond the w_tau/2 that the smoothing of the
        // far flank leaves when one flank touches)
        let f = flank_torque(h + 1e-4, -10.0, b, &m);
        assert!(f.tau.abs() <= 0.5 * m.w_tau + 1e-7, "{}", f.tau);
        // derivatives against central differences, elastic part against the energy
        for (x, v) in [
            (h + 2e-6, 0.3),
            (h - 1e-6, 2.0),
            (-h - 3e-4, 1.0),
            (0.1 * h, 5.0),
        ] {
            let f = flank_torque(x, v, b, &m);
            let e = 1e-10;
            let fd_x =
                (flank_torque(x + e, v, b, &m).tau - flank_torque(x - e, v, b, &m).tau) / (2.0 * e);
            let fd_v = (flank_torque(x, v + 1e-6, b, &m).tau
                - flank_torque(x, v - 1e-6, b, &m).tau)
                / 2e-6;
            assert!(
                (fd_x - f.d_delta).abs() < 1e-4 * f.d_delta.abs().max(1.0),
                "{x}: {fd_x} vs {}",
                f.d_delta
            );
            assert!(
                (fd_v - f.d_rate).abs() < 1e-6 * f.d_rate.abs().max(1.0),
                "{x}"
            );
            // (a wider step: the far flank's primitive cancels to ~1e-20 J)
            let fd_e = (flank_energy(x + 1e-8, b, &m) - flank_energy(x - 1e-8, b, &m)) / 2e-8;
            assert!(
                (fd_e - f.elastic).abs() < 1e-5 * f.elastic.abs().max(1e-3),
                "{x}: {fd_e} vs {}",
                f.elastic
            );
            let fd_el = (flank_torque(x + e, v, b, &m).elastic
                - flank_torque(x - e, v, b, &m).elastic)
                / (2.0 * e);
            assert!((fd_el - f.d_elastic).abs() < 1e-4 * f.d_elastic.abs().max(1.0));
        }
    }

    #[test]
    fn bundle_radius_of_four_1mm_strings() {
        assert!((bundle_radius(1e-3) - 1.207_106_781e-3).abs() < 1e-12);
    }

    #[test]
    fn helix_pythagoras_roundtrip() {
        // eq. 9: L = 0.0897, a = 0.05 -> p = sqrt(L^2 - a^2)
        let p = helix_position(0.0897, 0.05);
        assert!((p - (0.0897f64.powi(2) - 0.0025).sqrt()).abs() < 1e-15);
        assert!((strand_length(p, 0.05) - 0.0897).abs() < 1e-15);
        assert_eq!(helix_position(0.05, 0.06), 0.0);
    }

    #[test]
    fn twisting_backward_mirrors_twisting_forward() {
        for th in [0.3, 5.0, 40.0] {
            let (a, da) = twist_arc(th, 1.2e-3, 0.01);
            let (am, dam) = twist_arc(-th, 1.2e-3, 0.01);
            assert_eq!(am, -a);
            assert_eq!(dam, da);
            let (l, dl) = free_length(19.2 * th, 0.0897, 8.1153e-06, 8.4427e-09);
            let (lm, dlm) = free_length(-19.2 * th, 0.0897, 8.1153e-06, 8.4427e-09);
            assert_eq!(lm, l);
            assert_eq!(dlm, -dl);
            assert!(l > 0.0897, "twist either way lengthens the strands");
        }
        // at zero twist the forward derivative (the paper twists forward)
        assert_eq!(free_length(0.0, 0.0897, 1e-5, 1e-8), (0.0897, 1e-5));
        assert_eq!(sign_fwd(-0.0), 1.0);
        assert_eq!(sign_fwd(-1e-300), -1.0);
    }

    #[test]
    fn twist_arc_growth() {
        let (a, da) = twist_arc(10.0, 1e-3, 0.0);
        assert!((a - 1e-2).abs() < 1e-15 && (da - 1e-3).abs() < 1e-15);
        let (a, da) = twist_arc(2.0 * PI, 1e-3, 0.01);
        assert!((a - 2.0 * PI * 1.01e-3).abs() < 1e-15);
        assert!((da - (1.01e-3 + 1e-3 * 0.01)).abs() < 1e-15);
    }

    #[test]
    fn eq13_torque_matches_paper_form() {
        // tau_L = F_L theta r^2 / p (eq. 13) from the strand-tension form T a a' / L.
        let (theta, r, p) = (50.0, 1.2e-3, 0.07);
        let a = theta * r;
        let l = strand_length(p, a);
        let t = 120.0;
        let fl = axial_force(t, p, l);
        let tau = twist_torque(t, a, r, l);
        assert!((tau - fl * theta * r * r / p).abs() < 1e-12);
        // eq. 12: T = sqrt(F_L^2 + F_tau^2)
        let ft = tangential_force(t, a, l);
        assert!((fl.hypot(ft) - t).abs() < 1e-12);
        // eq. 19: alpha = acos(F_L / T)
        assert!((helix_slope(p, a) - (fl / t).acos()).abs() < 1e-12);
        // eq. 14: tau = F_tau r
        assert!((tau - ft * r).abs() < 1e-15);
    }

    #[test]
    fn transmission_is_derivative_of_helix() {
        let (r, l0) = (1.2e-3, 0.0897);
        let p_of = |th: f64| helix_position(l0, th * r);
        let th = 40.0;
        let fd = (p_of(th + 1e-6) - p_of(th - 1e-6)) / 2e-6;
        let p = p_of(th);
        let tr = transmission_ratio(p, l0, th * r, r, 0.0, 1e-6);
        assert!((tr - fd).abs() < 1e-8 * fd.abs());
        assert!(tr < 0.0);
    }

    #[test]
    fn stiffness_is_derivative_and_falls_with_twist() {
        let (r, l0, c) = (1.2e-3, 0.0897, 1.6914e-5);
        // F_L(p) = ((L(p) - l0)/c) p / L(p) at fixed theta; numerical dF/dp vs closed form.
        let f = |p: f64, a: f64| {
            let l = strand_length(p, a);
            (l - l0) / c * p / l
        };
        let mut last = f64::INFINITY;
        for th in [0.0, 20.0, 40.0, 60.0] {
            let a = th * r;
            // choose p with ~100 N tension
            let l = l0 + 100.0 * c;
            let p = helix_position(l, a);
            let fd = (f(p + 1e-8, a) - f(p - 1e-8, a)) / 2e-8;
            let k = axial_stiffness(100.0, p, a, l, c);
            assert!((k - fd).abs() < 1e-5 * k, "th {th}: {k} vs {fd}");
            assert!(k < last);
            last = k;
        }
    }

    #[test]
    fn free_length_table3() {
        let (l, dl) = free_length(2011.0, 0.0897, 8.1153e-06, 8.4427e-09);
        assert!((l - (0.0897 + 8.1153e-06 * 2011.0 + 8.4427e-09 * 2011.0 * 2011.0)).abs() < 1e-15);
        assert!((dl - (8.1153e-06 + 2.0 * 8.4427e-09 * 2011.0)).abs() < 1e-18);
    }

    #[test]
    fn armature_steady_state() {
        // at steady state u = R i + k_e omega
        let (r, l, ke) = (2.32, 0.238e-3, 0.0234);
        assert!(armature_current_rate(2.32 + 0.0234 * 100.0, 1.0, 100.0, r, l, ke).abs() < 1e-9);
        assert!((armature_current_rate(1.0, 0.0, 0.0, r, l, ke) - 1.0 / l).abs() < 1e-9);
        assert_eq!(motor_torque(0.0234, 2.0), 0.0468);
    }

    #[test]
    fn gear_efficiency_direction() {
        let (f, _) = gear_efficiency_factor(10.0, 0.81, 1e-3);
        assert!((f - 1.0 / 0.81).abs() < 1e-9);
        let (f, _) = gear_efficiency_factor(-10.0, 0.81, 1e-3);
        assert!((f - 0.81).abs() < 1e-9);
        let p = 2e-4;
        let fd = (gear_efficiency_factor(p + 1e-9, 0.81, 1e-3).0
            - gear_efficiency_factor(p - 1e-9, 0.81, 1e-3).0)
            / 2e-9;
        assert!((fd - gear_efficiency_factor(p, 0.81, 1e-3).1).abs() < 1e-4);
    }

    #[test]
    fn encoder_resolution() {
        let q = 2.0 * PI / 4000.0;
        assert_eq!(encoder_quantize(0.0, 1000.0), 0.0);
        assert_eq!(encoder_quantize(0.5 * q, 1000.0), 0.0);
        assert!((encoder_quantize(10.7 * q, 1000.0) - 10.0 * q).abs() < 1e-15);
        assert!((encoder_quantize(-0.5 * q, 1000.0) + q).abs() < 1e-15);
        // 0.09 deg per count
        assert!((q.to_degrees() - 0.09).abs() < 1e-12);
    }

    #[test]
    fn spring_guide_and_load() {
        assert_eq!(spring_force(0.0897, 0.0897, 100.0, 5.0), 5.0);
        assert!((spring_force(0.0597, 0.0897, 100.0, 5.0) - 8.0).abs() < 1e-12);
        assert_eq!(guide_friction(0.01, 20.0), 0.2);
        // equilibrium: string carries weight + spring
        let m = 23.0 / GRAVITY;
        assert!(load_acceleration(m, 0.0, 5.0, 28.0, 0.0).abs() < 1e-12);
    }

    #[test]
    fn friction_laws() {
        let (t, _) = motor_friction(100.0, 1e-3, 2e-6, 1.0);
        assert!((t - (1e-3 + 2e-4)).abs() < 1e-9);
        let (t0, d0) = motor_friction(0.0, 1e-3, 2e-6, 1.0);
        assert_eq!(t0, 0.0);
        assert!((d0 - (1e-3 + 2e-6)).abs() < 1e-12);
        let (h, dh_dt, _) = strand_friction(100.0, 1.2e-3, 10.0, 0.1, 0.05);
        assert!((h - 0.1 * 100.0 * 1.2e-3).abs() < 1e-9);
        assert!((dh_dt - 0.1 * 1.2e-3).abs() < 1e-9);
        let (hn, _, _) = strand_friction(100.0, 1.2e-3, -10.0, 0.1, 0.05);
        assert!((hn + h).abs() < 1e-15);
    }

    #[test]
    fn load_form_reproduces_eq10_and_is_finite_at_p0() {
        // p >> p_eps: F_L = x and T = x L / p (eq. 12: T = F_L / cos(alpha))
        let (t, fl) = load_form_forces(100.0, 0.065, 0.14, 1e-3);
        assert!((fl - 100.0).abs() < 0.02);
        assert!((t - 100.0 * 0.14 / 0.065).abs() < 0.1);
        assert!((fl / t - 0.065 / 0.14).abs() < 1e-12);
        let (t0, fl0) = load_form_forces(100.0, 0.0, 0.12, 1e-3);
        assert_eq!(fl0, 0.0);
        assert!(t0.is_finite());
        // stiffness = numerical derivative of F_L(p) = ((L(p) - Lf)/a3) p/q
        let (a, lf, a3, pe) = (0.1, 0.13, 1.6914e-5, 1e-3);
        let f = |p: f64| {
            let l = strand_length(p, a);
            load_form_forces((l - lf) / a3, p, l, pe).1
        };
        let p = 0.08;
        let l = strand_length(p, a);
        let fd = (f(p + 1e-8) - f(p - 1e-8)) / 2e-8;
        let k = axial_stiffness_load_form(l - lf, p, l, a3, pe);
        assert!((k - fd).abs() < 1e-5 * k, "{k} vs {fd}");
    }
    #[test]
    fn energy_functions_are_potentials() {
        let w = 0.01;
        for x in [-3.0f64, -0.02, 0.0, 0.004, 1.0, 250.0] {
            let h = 1e-6 * (1.0f64).max(x.abs());
            let fd = (smooth_pos_primitive(x + h, w) - smooth_pos_primitive(x - h, w)) / (2.0 * h);
            assert!(
                (fd - smooth_pos(x, w).0).abs() < 1e-7 * (1.0 + x.abs()),
                "{x}"
            );
        }
        assert_eq!(smooth_pos_primitive(0.0, w), 0.0);
        // far from the kink: x^2/2 (taut), about 0 (slack)
        assert!((smooth_pos_primitive(100.0, w) - 5000.0).abs() < 1e-3);
        assert!(smooth_pos_primitive(-100.0, w).abs() < 1e-3);
        let (m, l0, k, f0) = (2.0, 0.09, 100.0, 5.0);
        let p = 0.07;
        let fd = -(load_potential(m, p + 1e-7, l0, k, f0) - load_potential(m, p - 1e-7, l0, k, f0))
            / 2e-7;
        assert!((fd - (m * GRAVITY + spring_force(p, l0, k, f0))).abs() < 1e-6);
        assert_eq!(quadratic_energy(2.0, 3.0), 9.0);
    }
}
