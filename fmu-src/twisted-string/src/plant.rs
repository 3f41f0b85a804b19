//! State vector, parameters and the `OdeSystem` of the twisted-string actuator.
//!
//! States `y`: 0 armature current i [A], 1 motor angle theta_m [rad], 2 motor speed omega_m
//! [rad/s], 3 load position p [m] (twisted length, grows downward), 4 load velocity v = dp/dt
//! [m/s], 5 current-PI integrator z_i = int(i_ref - i) dt [A.s], 6 speed-PI integrator
//! z_w = int(omega_ref - omega_m) dt [rad]; energy integrals (for the energy balance, see the
//! documentation section "Energy balance"): 7 E_electrical = int u i dt [J], 8 E_loss = int of
//! the dissipated powers [J], 9 E_kinematic = int of the non-conservative exchange of the
//! `string_compliance` law [J]. The energy states feed nothing back (quadratures). With
//! `gear_backlash` two more: 10 delta = theta_m / N - theta_t, the position of the gearhead output
//! in the gap [rad], and 11 omega_t, the output speed [rad/s] (documentation, section 7); the
//! solver then integrates 12 states, otherwise the first 10.

use crate::controller::{pi_integrator_rate, pi_output};
use crate::physics::*;
use fmu_core::ModelError;
use serde::{Deserialize, Serialize};

/// Largest number of states (with `gear_backlash`).
pub const DIM: usize = 12;
/// Number of states without `gear_backlash`: physical, controller and energy states.
pub const DIM_BASE: usize = 10;
/// Number of physical and controller states without `gear_backlash` (then followed by the
/// energy quadratures).
pub const DIM_DYN: usize = 7;
/// Nominal magnitude of each state: the absolute tolerance of state k is `atol * NOMINAL[k]`
/// (energies 1 J; gear_backlash: delta 1e-2 rad, about the gap, omega_t 1 rad/s).
pub const NOMINAL: [f64; DIM] = [
    1.0, 1.0, 10.0, 0.01, 0.01, 1e-3, 1.0, 1.0, 1.0, 1.0, 1e-2, 1.0,
];
/// Smoothing width of the slack regularisation of the strand tension [N].
pub const TENSION_WIDTH: f64 = 1e-2;
/// Inertia of the gearhead output with `gear_backlash` [kg.m2]: output planet carrier with its
/// planets, output shaft and string clamp (documentation, section 7; estimate).
pub const GEAR_OUTPUT_INERTIA: f64 = 1.5e-6;
/// Contact law of the gear flanks at the output with `gear_backlash` (documentation, section 7):
/// stiffness 1000 N.m/rad, damping `2 sqrt(k J_out)` (critical for the output on a held motor),
/// smoothing widths 1e-6 rad (penetration) and 1e-5 N.m (push only).
pub const MESH: Mesh = Mesh {
    k: 1000.0,
    d: 0.077_459_666_924_148_34,
    w_pen: 1e-6,
    w_tau: 1e-5,
};
/// Power scale of the gearhead efficiency direction switch [W].
pub const EFFICIENCY_POWER_WIDTH: f64 = 0.1;
/// Speed scale of the Coulomb motor friction [rad/s] (motor shaft).
pub const FRICTION_SPEED_WIDTH: f64 = 1.0;
/// Speed scale of the inter-strand friction [rad/s] (twist).
pub const HYSTERESIS_SPEED_WIDTH: f64 = 0.05;
/// Regularisation length of p in the `string_compliance` load law [m].
pub const P_EPS: f64 = 1e-3;
/// Floor of p in the transmission-ratio output [m].
pub const P_MIN_OUTPUT: f64 = 1e-4;

/// Index names of the state vector.
pub mod ix {
    pub const I: usize = 0;
    pub const THETA: usize = 1;
    pub const OMEGA: usize = 2;
    pub const P: usize = 3;
    pub const V: usize = 4;
    pub const ZI: usize = 5;
    pub const ZW: usize = 6;
    pub const E_EL: usize = 7;
    pub const E_LOSS: usize = 8;
    pub const E_KIN: usize = 9;
    /// gear_backlash: position of the output in the gap, theta_m / N - theta_t [rad].
    pub const DELTA: usize = 10;
    /// gear_backlash: output (twist) speed [rad/s].
    pub const OMEGA_T: usize = 11;
}

/// Number of states the solver integrates for these parameters: 12 with `gear_backlash`
/// (its two states follow the energy integrals), 10 otherwise.
pub fn state_dim(q: &Params) -> usize {
    if q.gear_backlash.is_some() {
        DIM
    } else {
        DIM_BASE
    }
}

/// Every parameter in SI units (generated from the variable table, [`crate::vars`]).
pub use crate::vars::{
    GearBacklash, MotorFriction, Params, RadiusGrowth, StringCompliance, TwistHysteresis,
};

impl Params {
    /// Axial compliance of the bundle [m/N]: a3 (Table 3) or 1/string_stiffness.
    pub fn compliance_c(&self) -> f64 {
        match self.string_compliance {
            Some(StringCompliance { a3, .. }) => a3,
            None => 1.0 / self.string_stiffness,
        }
    }
}

/// Inputs held over a communication step plus the sampled speed set point.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Inputs {
    pub theta_ref: f64,
    pub voltage: f64,
    pub f_load: f64,
    pub omega_ref: f64,
    /// The motor angle is `theta_offset + y[1]`: the model integrates the angle relative to its
    /// value at the start of each interval, so that its error control is absolute (atol * 1 rad)
    /// instead of relative to thousands of radians (documentation, section 8).
    pub theta_offset: f64,
}

/// Every intermediate quantity of the right-hand side (outputs are taken from here).
#[derive(Clone, Copy, Debug, Default)]
pub struct Aux {
    pub theta_t: f64,
    pub omega_t: f64,
    pub a: f64,
    pub da: f64,
    pub l: f64,
    pub dlfree: f64,
    pub stretch: f64,
    pub tension: f64,
    pub f_axial: f64,
    pub f_tangential: f64,
    pub tau_out: f64,
    pub tau_in: f64,
    pub u: f64,
    pub i_ref: f64,
    /// Electrical input power `u i` [W].
    pub p_el: f64,
    /// Dissipated power (copper, conversion mismatch, gearhead, motor friction, strand
    /// friction, guides, string damping, gear-flank damping) [W].
    pub p_loss: f64,
    /// Non-conservative exchange power of the `string_compliance` law [W] (0 without it).
    pub p_kin: f64,
    pub dy: [f64; DIM],
}

/// The ODE system: parameters and the inputs held over the current interval.
pub struct Plant<'a> {
    pub par: &'a Params,
    pub inp: Inputs,
}

impl Plant<'_> {
    /// The physical states (current, absolute motor angle, motor speed, position, load speed,
    /// current-loop and speed-loop integrators) from the solver vector `y`.
    fn unpack(&self, y: &[f64]) -> (f64, f64, f64, f64, f64, f64, f64) {
        (
            y[0],
            self.inp.theta_offset + y[1],
            y[2],
            y[3],
            y[4],
            y[5],
            y[6],
        )
    }

    /// Evaluate the model equations at state `y` (see the documentation for each line's source).
    pub fn eval(&self, y: &[f64]) -> Aux {
        let q = self.par;
        let (i, th_m, om, p, v, zi, zw) = self.unpack(y);
        let n = q.gear_ratio;
        let q_p = (p * p + P_EPS * P_EPS).sqrt();
        // gearhead output = twist angle: rigid theta_m / N, or with backlash the output's own
        // angle theta_m / N - delta and speed omega_t (states)
        let dtheta_t = 1.0 / n;
        let (theta_t, omega_t) = match q.gear_backlash {
            None => (th_m / n, dtheta_t * om),
            Some(_) => (th_m / n - y[ix::DELTA], y[ix::OMEGA_T]),
        };
        // helix geometry (eq. 9), optional radius growth
        let (a, da) = twist_arc(
            theta_t,
            q.string_radius,
            q.radius_growth.map_or(0.0, |g| g.per_turn),
        );
        let l = strand_length(p, a);
        // unloaded strand length (eq. 10 twist terms, motor-referred angle N theta_t)
        let (lfree, dlfree) = match q.string_compliance {
            Some(StringCompliance { a1, a2, .. }) => {
                let (lf, d) = free_length(n * theta_t, q.string_length, a1, a2);
                (lf, d * n)
            }
            None => (q.string_length, 0.0),
        };
        let c = q.compliance_c();
        let s = l - lfree;
        let s_dot = (p * v + a * da * omega_t) / l - dlfree * omega_t;
        let (x, _) = string_tension(s, s_dot, c, q.string_damping, TENSION_WIDTH);
        let (tension, f_axial) = match q.string_compliance {
            Some(_) => load_form_forces(x, p, l, P_EPS),
            None => (x, axial_force(x, p, l)),
        };
        let f_tangential = tangential_force(tension, a, l);
        let tau_l = twist_torque(tension, a, da, l);
        let tau_h = match q.twist_hysteresis {
            Some(TwistHysteresis {
                friction_coefficient: mu,
            }) => strand_friction(tension, da, omega_t, mu, HYSTERESIS_SPEED_WIDTH).0,
            None => 0.0,
        };
        let tau_out = tau_l + tau_h;
        // torque through the gear and the speed of its output as the motor side sees it: the
        // strings' torque at the twist rate (rigid), or the flank torque at omega_m / N (backlash)
        let mesh = flanks(q, y, om);
        let (tau_gear, omega_gear) = match mesh {
            None => (tau_out, omega_t),
            Some((f, _)) => (f.tau, dtheta_t * om),
        };
        // gearhead: reflect to the motor with the efficiency in the direction of power flow
        let (f_eta, _) = gear_efficiency_factor(
            tau_gear * omega_gear,
            q.gear_efficiency,
            EFFICIENCY_POWER_WIDTH,
        );
        let tau_in = f_eta * dtheta_t * tau_gear;
        let tau_fric = match q.motor_friction {
            Some(MotorFriction {
                coulomb: tc,
                viscous: b,
            }) => motor_friction(om, tc, b, FRICTION_SPEED_WIDTH).0,
            None => 0.0,
        };
        // cascade controller (continuous current and speed PI) or open-loop voltage
        let (u, i_ref, dzi, dzw) = if q.internal_controller {
            let e_w = self.inp.omega_ref - om;
            let (i_ref, i_ref_u) = pi_output(
                q.controller_speed_p,
                q.controller_speed_ti,
                e_w,
                zw,
                q.current_limit,
            );
            let e_i = i_ref - i;
            let (u, u_u) = pi_output(
                q.controller_current_p,
                q.controller_current_ti,
                e_i,
                zi,
                q.supply_voltage,
            );
            (
                u,
                i_ref,
                pi_integrator_rate(e_i, u_u, q.supply_voltage),
                pi_integrator_rate(e_w, i_ref_u, q.current_limit),
            )
        } else {
            (self.inp.voltage, 0.0, 0.0, 0.0)
        };
        let di = armature_current_rate(
            u,
            i,
            om,
            q.motor_resistance,
            q.motor_inductance,
            q.back_emf_constant,
        );
        let dom = (motor_torque(q.torque_constant, i) - tau_in - tau_fric) / q.rotor_inertia;
        let f_s = spring_force(p, q.string_length, q.spring_stiffness, q.spring_preload);
        let f_guide = guide_friction(v, q.guide_damping);
        let dv = load_acceleration(q.load_mass, self.inp.f_load, f_s, f_axial, f_guide);
        // power balance (documentation, "Energy balance"): elastic part of the string law
        let t_el = smooth_pos(s / c, TENSION_WIDTH).0;
        let p_el = u * i;
        let mut p_loss = q.motor_resistance * i * i
            + (q.back_emf_constant - q.torque_constant) * i * om
            + (f_eta - 1.0) * tau_gear * omega_gear
            + tau_fric * om
            + tau_h * omega_t
            + f_guide * v
            + (x - t_el) * s_dot;
        // backlash: the output and the damping of the flanks
        let (d_delta, d_omega_t) = match mesh {
            Some((f, rate)) => {
                p_loss += (f.tau - f.elastic) * rate;
                (rate, (f.tau - tau_out) / GEAR_OUTPUT_INERTIA)
            }
            None => (0.0, 0.0),
        };
        let p_kin = match q.string_compliance {
            Some(_) => x * ((l / q_p) * (s_dot + dlfree * omega_t) - s_dot),
            None => 0.0,
        };
        Aux {
            theta_t,
            omega_t,
            a,
            da,
            l,
            dlfree,
            stretch: s,
            tension,
            f_axial,
            f_tangential,
            tau_out,
            tau_in,
            u,
            i_ref,
            p_el,
            p_loss,
            p_kin,
            dy: [
                di, om, dom, v, dv, dzi, dzw, p_el, p_loss, p_kin, d_delta, d_omega_t,
            ],
        }
    }
}

/// With `gear_backlash`: the torque of the gear flanks on the output and the rate of the output's
/// position in the gap, `d delta/dt = omega_m / N - omega_t` (documentation, section 7.1).
fn flanks(q: &Params, y: &[f64], omega_m: f64) -> Option<(FlankTorque, f64)> {
    q.gear_backlash.map(|GearBacklash { angle: b }| {
        let rate = (1.0 / q.gear_ratio) * omega_m - y[ix::OMEGA_T];
        (flank_torque(y[ix::DELTA], rate, b, &MESH), rate)
    })
}

impl ode::OdeSystem for Plant<'_> {
    fn dim(&self) -> usize {
        state_dim(self.par)
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        let n = dydt.len();
        dydt.copy_from_slice(&self.eval(y).dy[..n]);
    }
    fn autonomous(&self) -> bool {
        true
    }
    /// The energy integrals 7..9 feed nothing back; they are trailing only without
    /// `gear_backlash` (whose states follow them), so only then are they declared.
    fn quadratures(&self) -> usize {
        if self.par.gear_backlash.is_some() {
            0
        } else {
            DIM_BASE - DIM_DYN
        }
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut nalgebra::DMatrix<f64>) -> bool {
        let n = y.len();
        let j = self.jacobian_rows(y);
        for (r, row) in j.iter().take(n).enumerate() {
            for (c, v) in row.iter().take(n).enumerate() {
                jac[(r, c)] = *v;
            }
        }
        true
    }
}

/// Gradient of a scalar with respect to the states.
type Grad = [f64; DIM];

#[inline]
fn unit(k: usize) -> Grad {
    let mut g = [0.0; DIM];
    g[k] = 1.0;
    g
}

/// `a * x + b * y` componentwise.
#[inline]
fn lin(a: f64, x: &Grad, b: f64, y: &Grad) -> Grad {
    let mut g = [0.0; DIM];
    for k in 0..DIM {
        g[k] = a * x[k] + b * y[k];
    }
    g
}

#[inline]
fn scale(a: f64, x: &Grad) -> Grad {
    lin(a, x, 0.0, x)
}

/// Derivative of the clamping anti-windup integrator rate `e (1 - s)` (see
/// [`crate::controller::pi_integrator_rate`]) from the gradients of `e` and of the unsaturated
/// output `u`.
fn clamp_rate_grad(e: f64, u: f64, u_max: f64, de: &Grad, du: &Grad) -> Grad {
    if e * u <= 0.0 {
        return *de;
    }
    let width = crate::controller::CLAMP_FADE * u_max;
    let raw = (u.abs() - u_max) / width;
    let s = raw.clamp(0.0, 1.0);
    if raw > 0.0 && raw < 1.0 {
        lin(1.0 - s, de, -e * u.signum() / width, du)
    } else {
        scale(1.0 - s, de)
    }
}

impl Plant<'_> {
    /// Analytic Jacobian d(rhs)/dy (rows = equations), the chain rule through [`Plant::eval`]
    /// (tested against central differences).
    pub fn jacobian_rows(&self, y: &[f64]) -> [Grad; DIM] {
        let q = self.par;
        let (i, th_m, om, p, v, zi, zw) = self.unpack(y);
        let n = q.gear_ratio;
        let (e_i, e_th, e_om, e_p, e_v, e_zi, e_zw) = (
            unit(0),
            unit(1),
            unit(2),
            unit(3),
            unit(4),
            unit(5),
            unit(6),
        );
        let (e_delta, e_omt) = (unit(ix::DELTA), unit(ix::OMEGA_T));
        let zero = [0.0; DIM];
        // gearhead output (twist) angle and speed with their gradients, g = 1/N
        let g = 1.0 / n;
        let (theta_t, d_th_t, omega_t, d_omega_t) = match q.gear_backlash {
            None => (th_m / n, scale(g, &e_th), g * om, scale(g, &e_om)),
            Some(_) => (
                th_m / n - y[ix::DELTA],
                lin(g, &e_th, -1.0, &e_delta),
                y[ix::OMEGA_T],
                e_omt,
            ),
        };
        // arc a = theta_t r(theta_t), a' and a''
        let k = q.radius_growth.map_or(0.0, |g| g.per_turn) / (2.0 * std::f64::consts::PI);
        let r0 = q.string_radius;
        let (a, da) = twist_arc(theta_t, r0, q.radius_growth.map_or(0.0, |g| g.per_turn));
        let dda = 2.0 * r0 * k * sign_fwd(theta_t);
        let d_a = scale(da, &d_th_t);
        let d_da = scale(dda, &d_th_t);
        let l = strand_length(p, a);
        let d_l = lin(p / l, &e_p, a / l, &d_a);
        let (lf_p, lf_pp) = match q.string_compliance {
            Some(StringCompliance { a1, a2, .. }) => {
                let (_, d) = free_length(n * theta_t, q.string_length, a1, a2);
                (d * n, 2.0 * a2 * n * n)
            }
            None => (0.0, 0.0),
        };
        let lfree = match q.string_compliance {
            Some(StringCompliance { a1, a2, .. }) => {
                free_length(n * theta_t, q.string_length, a1, a2).0
            }
            None => q.string_length,
        };
        let d_lf = scale(lf_p, &d_th_t);
        let d_lf_p = scale(lf_pp, &d_th_t);
        let c = q.compliance_c();
        let s = l - lfree;
        let d_s = lin(1.0, &d_l, -1.0, &d_lf);
        let qn = p * v + a * da * omega_t;
        let mut d_qn = lin(v, &e_p, p, &e_v);
        for kk in 0..DIM {
            d_qn[kk] += (d_a[kk] * da + a * d_da[kk]) * omega_t + a * da * d_omega_t[kk];
        }
        let s_dot = qn / l - lf_p * omega_t;
        let mut d_sdot = [0.0; DIM];
        for kk in 0..DIM {
            d_sdot[kk] =
                d_qn[kk] / l - qn / (l * l) * d_l[kk] - d_lf_p[kk] * omega_t - lf_p * d_omega_t[kk];
        }
        let (xt, dxt) = string_tension(s, s_dot, c, q.string_damping, TENSION_WIDTH);
        let d_x = lin(dxt / c, &d_s, dxt * q.string_damping, &d_sdot);
        let (tension, _f_axial, d_t, d_fl) = match q.string_compliance {
            Some(_) => {
                let qp = (p * p + P_EPS * P_EPS).sqrt();
                let d_q = scale(p / qp, &e_p);
                let t = xt * l / qp;
                let fl = xt * p / qp;
                let mut dt = [0.0; DIM];
                let mut dfl = [0.0; DIM];
                for kk in 0..DIM {
                    dt[kk] = d_x[kk] * l / qp + xt * d_l[kk] / qp - xt * l / (qp * qp) * d_q[kk];
                    dfl[kk] = d_x[kk] * p / qp + xt * e_p[kk] / qp - xt * p / (qp * qp) * d_q[kk];
                }
                (t, fl, dt, dfl)
            }
            None => {
                let fl = xt * p / l;
                let mut dfl = [0.0; DIM];
                for kk in 0..DIM {
                    dfl[kk] = d_x[kk] * p / l + xt * (e_p[kk] / l - p / (l * l) * d_l[kk]);
                }
                (xt, fl, d_x, dfl)
            }
        };
        // twist torque tau_L = T a a' / L
        let tau_l = tension * a * da / l;
        let mut d_tau = [0.0; DIM];
        for kk in 0..DIM {
            d_tau[kk] = d_t[kk] * a * da / l + tension * (d_a[kk] * da + a * d_da[kk]) / l
                - tau_l / l * d_l[kk];
        }
        let mut tau_out = tau_l;
        let mut tau_h = 0.0;
        let mut d_tau_h = zero;
        if let Some(TwistHysteresis {
            friction_coefficient: mu,
        }) = q.twist_hysteresis
        {
            let th = ode::math::tanh(omega_t / HYSTERESIS_SPEED_WIDTH);
            tau_h = mu * tension * da * th;
            tau_out += tau_h;
            for kk in 0..DIM {
                d_tau_h[kk] = mu
                    * (d_t[kk] * da * th
                        + tension * d_da[kk] * th
                        + tension * da * (1.0 - th * th) / HYSTERESIS_SPEED_WIDTH * d_omega_t[kk]);
                d_tau[kk] += d_tau_h[kk];
            }
        }
        // torque through the gear and its output speed on the motor side (see Plant::eval)
        let mesh = flanks(q, y, om).map(|(f, rate)| (f, rate, lin(g, &e_om, -1.0, &e_omt)));
        let (tau_g, d_tau_g, omega_g, d_omega_g) = match mesh {
            None => (tau_out, d_tau, omega_t, d_omega_t),
            Some((f, _, d_rate)) => (
                f.tau,
                lin(f.d_delta, &e_delta, f.d_rate, &d_rate),
                g * om,
                scale(g, &e_om),
            ),
        };
        let power = tau_g * omega_g;
        let d_power = lin(omega_g, &d_tau_g, tau_g, &d_omega_g);
        let (f_eta, df_dp) =
            gear_efficiency_factor(power, q.gear_efficiency, EFFICIENCY_POWER_WIDTH);
        let mut d_tau_in = [0.0; DIM];
        for kk in 0..DIM {
            d_tau_in[kk] = df_dp * d_power[kk] * g * tau_g + f_eta * g * d_tau_g[kk];
        }
        let (fric, d_fric) = match q.motor_friction {
            Some(MotorFriction {
                coulomb: tc,
                viscous: b,
            }) => {
                let (f, df) = motor_friction(om, tc, b, FRICTION_SPEED_WIDTH);
                (f, scale(df, &e_om))
            }
            None => (0.0, zero),
        };
        // controller
        let (u, d_u, d_dzi, d_dzw) = if q.internal_controller {
            let e_w = self.inp.omega_ref - om;
            let d_ew = scale(-1.0, &e_om);
            let (kp_w, ti_w) = (q.controller_speed_p, q.controller_speed_ti);
            let iref_u = kp_w * (e_w + zw / ti_w);
            let d_iref_u = lin(kp_w, &d_ew, kp_w / ti_w, &e_zw);
            let d_iref = if iref_u.abs() < q.current_limit {
                d_iref_u
            } else {
                zero
            };
            let iref = iref_u.clamp(-q.current_limit, q.current_limit);
            let ei = iref - i;
            let d_ei = lin(1.0, &d_iref, -1.0, &e_i);
            let (kp_i, ti_i) = (q.controller_current_p, q.controller_current_ti);
            let u_u = kp_i * (ei + zi / ti_i);
            let d_uu = lin(kp_i, &d_ei, kp_i / ti_i, &e_zi);
            let d_u = if u_u.abs() < q.supply_voltage {
                d_uu
            } else {
                zero
            };
            (
                u_u.clamp(-q.supply_voltage, q.supply_voltage),
                d_u,
                clamp_rate_grad(ei, u_u, q.supply_voltage, &d_ei, &d_uu),
                clamp_rate_grad(e_w, iref_u, q.current_limit, &d_ew, &d_iref_u),
            )
        } else {
            (self.inp.voltage, zero, zero, zero)
        };
        let mut jr = [[0.0; DIM]; DIM];
        for kk in 0..DIM {
            jr[ix::I][kk] =
                (d_u[kk] - q.motor_resistance * e_i[kk] - q.back_emf_constant * e_om[kk])
                    / q.motor_inductance;
            jr[ix::OMEGA][kk] =
                (q.torque_constant * e_i[kk] - d_tau_in[kk] - d_fric[kk]) / q.rotor_inertia;
            jr[ix::V][kk] = (-q.spring_stiffness * e_p[kk] - d_fl[kk] - q.guide_damping * e_v[kk])
                / q.load_mass;
        }
        jr[ix::THETA] = e_om;
        jr[ix::P] = e_v;
        jr[ix::ZI] = d_dzi;
        jr[ix::ZW] = d_dzw;
        if let Some((_, _, d_rate)) = mesh {
            // output in the gap: d delta/dt = omega_m / N - omega_t,
            // J_out d omega_t/dt = tau_gear - tau_out; flank damping power (tau - elastic) rate
            jr[ix::DELTA] = d_rate;
            jr[ix::OMEGA_T] = lin(
                1.0 / GEAR_OUTPUT_INERTIA,
                &d_tau_g,
                -1.0 / GEAR_OUTPUT_INERTIA,
                &d_tau,
            );
        }
        // energy quadratures: gradients of the powers of Plant::eval
        let (r, kdiff) = (q.motor_resistance, q.back_emf_constant - q.torque_constant);
        let (t_el, dt_el) = smooth_pos(s / c, TENSION_WIDTH);
        let d_tel = scale(dt_el / c, &d_s);
        let gear = f_eta - 1.0;
        for kk in 0..DIM {
            jr[ix::E_EL][kk] = d_u[kk] * i + u * e_i[kk];
            jr[ix::E_LOSS][kk] = 2.0 * r * i * e_i[kk]
                + kdiff * (om * e_i[kk] + i * e_om[kk])
                + (df_dp * power + gear) * d_power[kk]
                + d_fric[kk] * om
                + fric * e_om[kk]
                + d_tau_h[kk] * omega_t
                + tau_h * d_omega_t[kk]
                + 2.0 * q.guide_damping * v * e_v[kk]
                + (d_x[kk] - d_tel[kk]) * s_dot
                + (xt - t_el) * d_sdot[kk];
        }
        if let Some((f, rate, d_rate)) = mesh {
            let d_el = scale(f.d_elastic, &e_delta);
            for kk in 0..DIM {
                jr[ix::E_LOSS][kk] +=
                    (d_tau_g[kk] - d_el[kk]) * rate + (f.tau - f.elastic) * d_rate[kk];
            }
        }
        if q.string_compliance.is_some() {
            let qp = (p * p + P_EPS * P_EPS).sqrt();
            let lfd = lf_p * omega_t;
            let bracket = (l / qp) * (s_dot + lfd) - s_dot;
            for kk in 0..DIM {
                let d_ratio = d_l[kk] / qp - l / (qp * qp) * (p / qp) * e_p[kk];
                let d_lfd = d_lf_p[kk] * omega_t + lf_p * d_omega_t[kk];
                let d_bracket =
                    d_ratio * (s_dot + lfd) + (l / qp) * (d_sdot[kk] + d_lfd) - d_sdot[kk];
                jr[ix::E_KIN][kk] = d_x[kk] * bracket + xt * d_bracket;
            }
        }
        jr
    }
}

/// Stored energy [J] (documentation, "Energy balance"): magnetic `L i^2/2`, rotor `J omega^2/2`,
/// load `m v^2/2`, gravity and return spring [`load_potential`] (zero at p = L0), the elastic
/// energy of the string law `c Phi(s/c)` ([`smooth_pos_primitive`], s = L - L_free, c = a3 or
/// 1/string_stiffness), and with `gear_backlash` the output's `J_out omega_t^2/2` and the flanks'
/// [`flank_energy`]. Along any solution `d/dt E_stored = u i + F_load v - P_loss - P_kin`.
pub fn stored_energy(q: &Params, y: &[f64]) -> f64 {
    let gear = match q.gear_backlash {
        Some(GearBacklash { angle: b }) => {
            quadratic_energy(GEAR_OUTPUT_INERTIA, y[ix::OMEGA_T])
                + flank_energy(y[ix::DELTA], b, &MESH)
        }
        None => 0.0,
    };
    strings_and_motor_energy(q, y) + gear
}

/// [`stored_energy`] without the gearhead output's terms.
fn strings_and_motor_energy(q: &Params, y: &[f64]) -> f64 {
    let aux = Plant {
        par: q,
        inp: Inputs::default(),
    }
    .eval(y);
    let c = q.compliance_c();
    quadratic_energy(q.motor_inductance, y[ix::I])
        + quadratic_energy(q.rotor_inertia, y[ix::OMEGA])
        + quadratic_energy(q.load_mass, y[ix::V])
        + load_potential(
            q.load_mass,
            y[ix::P],
            q.string_length,
            q.spring_stiffness,
            q.spring_preload,
        )
        + c * smooth_pos_primitive(aux.stretch / c, TENSION_WIDTH)
}

/// Consistent initial state at rest, untwisted (a simulation starts there unless told otherwise): theta_m = omega = i = 0, controller
/// integrators 0, and the load hanging in equilibrium `F_L(p0) = m g + F_ext + F_s(p0)`. With
/// x = (p0 - L0)/c the load force is `pos(x) phi(p0)` (phi = 1 for the strand law, p/q for the
/// `string_compliance` law at zero twist); Newton on the monotone
/// `g(x) = pos(x) phi(L0 + c x) + k_s c x - (m g + F_ext + F_0)`. Returns p0.
pub fn rest_position(q: &Params, f_load: f64) -> Result<f64, ModelError> {
    let c = q.compliance_c();
    let b = q.load_mass * GRAVITY + f_load + q.spring_preload;
    let ksc = q.spring_stiffness * c;
    let phi = |p: f64| -> (f64, f64) {
        if q.string_compliance.is_some() {
            let r = (p * p + P_EPS * P_EPS).sqrt();
            (p / r, P_EPS * P_EPS / (r * r * r))
        } else {
            (1.0, 0.0)
        }
    };
    let mut x = b.max(TENSION_WIDTH);
    for _ in 0..200 {
        let (t, dt) = smooth_pos(x, TENSION_WIDTH);
        let (f, df) = phi(q.string_length + c * x);
        let g = t * f + ksc * x - b;
        let step = g / (dt * f + t * df * c + ksc);
        x -= step;
        if step.abs() <= 1e-14 * x.abs().max(1.0) {
            break;
        }
    }
    let p0 = q.string_length + c * x;
    if !(p0.is_finite() && p0 > 0.0) {
        return Err(ModelError::parameters(
            &["load_mass", "spring_preload", "F_load"],
            format!("no equilibrium at rest (p0 = {p0})"),
        ));
    }
    Ok(p0)
}

/// `q` with every effect on at its table default, the gear backlash at `backlash` [rad].
#[cfg(test)]
pub(crate) fn with_every_effect(q: &Params, backlash: f64) -> Params {
    use crate::vars::VARIABLES;
    let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
    for (i, v) in VARIABLES.iter().enumerate() {
        if v.name.ends_with(".enabled") {
            vars[i] = 1.0;
        }
    }
    let on = Params::read(&vars);
    Params {
        string_compliance: on.string_compliance,
        twist_hysteresis: on.twist_hysteresis,
        motor_friction: on.motor_friction,
        gear_backlash: Some(GearBacklash { angle: backlash }),
        radius_growth: on.radius_growth,
        ..q.clone()
    }
}

#[cfg(test)]
mod tests;
