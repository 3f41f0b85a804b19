//! State vector, parameters and the `OdeSystem` of the twisted-string actuator.
//!
//! States `y`: 0 armature current i [A], 1 motor angle theta_m [rad], 2 motor speed omega_m
//! [rad/s], 3 load position p [m] (twisted length, grows downward), 4 load velocity v = dp/dt
//! [m/s], 5 current-PI integrator z_i = int(i_ref - i) dt [A.s], 6 speed-PI integrator
//! z_w = int(omega_ref - omega_m) dt [rad].

use crate::controller::{pi_integrator_rate, pi_output};
use crate::physics::*;
use serde::{Deserialize, Serialize};

/// Number of states.
pub const DIM: usize = 7;
/// Nominal magnitude of each state: the absolute tolerance of state k is `atol * NOMINAL[k]`.
pub const NOMINAL: [f64; DIM] = [1.0, 1.0, 10.0, 0.01, 0.01, 1e-3, 1.0];
/// Smoothing width of the slack regularisation of the strand tension [N].
pub const TENSION_WIDTH: f64 = 1e-2;
/// Smoothing width of the backlash dead-zone edges [rad of twist].
pub const BACKLASH_WIDTH: f64 = 1e-4;
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
}

/// Every parameter in SI units (read from the variable table at initialization).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Params {
    pub internal_controller: bool,
    pub load_mass: f64,
    pub string_length: f64,
    pub string_radius: f64,
    pub string_count: f64,
    pub string_stiffness: f64,
    pub string_damping: f64,
    pub spring_stiffness: f64,
    pub spring_preload: f64,
    pub guide_damping: f64,
    pub motor_resistance: f64,
    pub motor_inductance: f64,
    pub torque_constant: f64,
    pub back_emf_constant: f64,
    pub rotor_inertia: f64,
    pub gear_ratio: f64,
    pub gear_efficiency: f64,
    pub encoder_cpt: f64,
    pub supply_voltage: f64,
    pub current_limit: f64,
    pub speed_limit: f64,
    pub current_p: f64,
    pub current_ti: f64,
    pub speed_p: f64,
    pub speed_ti: f64,
    pub position_p: f64,
    pub position_band: f64,
    pub position_period: f64,
    pub rtol: f64,
    pub atol: f64,
    /// `string_compliance`: (a1 [m/rad], a2 [m/rad2], a3 [m/N]) of eq. 10 (motor angle).
    pub compliance: Option<(f64, f64, f64)>,
    /// `twist_hysteresis`: inter-strand friction coefficient.
    pub hysteresis: Option<f64>,
    /// `motor_friction`: (Coulomb [N.m], viscous [N.m.s/rad]).
    pub motor_friction: Option<(f64, f64)>,
    /// `gear_backlash`: total backlash at the output [rad].
    pub backlash: Option<f64>,
    /// `radius_growth`: relative radius growth per turn of twist.
    pub radius_growth: Option<f64>,
}

impl Params {
    /// Axial compliance of the bundle [m/N]: a3 (Table 3) or 1/string_stiffness.
    pub fn compliance_c(&self) -> f64 {
        match self.compliance {
            Some((_, _, a3)) => a3,
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
}

/// Every intermediate quantity of the right-hand side (outputs are taken from here).
#[derive(Clone, Copy, Debug, Default)]
pub struct Aux {
    pub theta_t: f64,
    pub dtheta_t: f64,
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
    pub dy: [f64; DIM],
}

/// The ODE system: parameters and the inputs held over the current interval.
pub struct Plant<'a> {
    pub par: &'a Params,
    pub inp: Inputs,
}

impl Plant<'_> {
    /// Evaluate the model equations at state `y` (see the documentation for each line's source).
    pub fn eval(&self, y: &[f64]) -> Aux {
        let q = self.par;
        let (i, th_m, om, p, v, zi, zw) = (y[0], y[1], y[2], y[3], y[4], y[5], y[6]);
        let n = q.gear_ratio;
        // gearhead output = twist angle (with optional backlash dead zone)
        let (theta_t, dtheta_t) = twist_angle(th_m, n, q.backlash.map(|b| (b, BACKLASH_WIDTH)));
        let omega_t = dtheta_t * om;
        // helix geometry (eq. 9), optional radius growth
        let (a, da) = twist_arc(theta_t, q.string_radius, q.radius_growth.unwrap_or(0.0));
        let l = strand_length(p, a);
        // unloaded strand length (eq. 10 twist terms, motor-referred angle N theta_t)
        let (lfree, dlfree) = match q.compliance {
            Some((a1, a2, _)) => {
                let (lf, d) = free_length(n * theta_t, q.string_length, a1, a2);
                (lf, d * n)
            }
            None => (q.string_length, 0.0),
        };
        let c = q.compliance_c();
        let s = l - lfree;
        let s_dot = (p * v + a * da * omega_t) / l - dlfree * omega_t;
        let (x, _) = string_tension(s, s_dot, c, q.string_damping, TENSION_WIDTH);
        let (tension, f_axial) = match q.compliance {
            Some(_) => load_form_forces(x, p, l, P_EPS),
            None => (x, axial_force(x, p, l)),
        };
        let f_tangential = tangential_force(tension, a, l);
        let mut tau_out = twist_torque(tension, a, da, l);
        if let Some(mu) = q.hysteresis {
            tau_out += strand_friction(tension, da, omega_t, mu, HYSTERESIS_SPEED_WIDTH).0;
        }
        // gearhead: reflect to the motor with the efficiency in the direction of power flow
        let (f_eta, _) =
            gear_efficiency_factor(tau_out * omega_t, q.gear_efficiency, EFFICIENCY_POWER_WIDTH);
        let tau_in = f_eta * dtheta_t * tau_out;
        let tau_fric = match q.motor_friction {
            Some((tc, b)) => motor_friction(om, tc, b, FRICTION_SPEED_WIDTH).0,
            None => 0.0,
        };
        // cascade controller (continuous current and speed PI) or open-loop voltage
        let (u, i_ref, dzi, dzw) = if q.internal_controller {
            let e_w = self.inp.omega_ref - om;
            let (i_ref, i_ref_u) = pi_output(q.speed_p, q.speed_ti, e_w, zw, q.current_limit);
            let e_i = i_ref - i;
            let (u, u_u) = pi_output(q.current_p, q.current_ti, e_i, zi, q.supply_voltage);
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
        let dv = load_acceleration(
            q.load_mass,
            self.inp.f_load,
            f_s,
            f_axial,
            guide_friction(v, q.guide_damping),
        );
        Aux {
            theta_t,
            dtheta_t,
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
            dy: [di, om, dom, v, dv, dzi, dzw],
        }
    }
}

impl ode::OdeSystem for Plant<'_> {
    fn dim(&self) -> usize {
        DIM
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        dydt.copy_from_slice(&self.eval(y).dy);
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Consistent initial state at rest, untwisted (issue 10): theta_m = omega = i = 0, controller
/// integrators 0, and the load hanging in equilibrium `F_L(p0) = m g + F_ext + F_s(p0)`. With
/// x = (p0 - L0)/c the load force is `pos(x) phi(p0)` (phi = 1 for the strand law, p/q for the
/// `string_compliance` law at zero twist); Newton on the monotone
/// `g(x) = pos(x) phi(L0 + c x) + k_s c x - (m g + F_ext + F_0)`. Returns p0.
pub fn rest_position(q: &Params, f_load: f64) -> Result<f64, String> {
    let c = q.compliance_c();
    let b = q.load_mass * GRAVITY + f_load + q.spring_preload;
    let ksc = q.spring_stiffness * c;
    let phi = |p: f64| -> (f64, f64) {
        if q.compliance.is_some() {
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
        return Err(format!(
            "load_mass/spring_preload/F_load: no equilibrium at rest (p0 = {p0})"
        ));
    }
    Ok(p0)
}

#[cfg(test)]
mod tests {
    use super::*;

    pub fn defaults() -> Params {
        Params {
            internal_controller: false,
            load_mass: 23.0 / GRAVITY,
            string_length: 0.0897,
            string_radius: bundle_radius(1e-3),
            string_count: 4.0,
            string_stiffness: 1e6,
            string_damping: 2000.0,
            spring_stiffness: 100.0,
            spring_preload: 5.0,
            guide_damping: 20.0,
            motor_resistance: 2.32,
            motor_inductance: 0.238e-3,
            torque_constant: 0.0234,
            back_emf_constant: 0.0234,
            rotor_inertia: 1.14e-6,
            gear_ratio: 19.2,
            gear_efficiency: 0.81,
            encoder_cpt: 1000.0,
            supply_voltage: 24.0,
            current_limit: 3.0,
            speed_limit: 837.758,
            current_p: 0.165,
            current_ti: 69e-6,
            speed_p: 9.196e-3,
            speed_ti: 0.042,
            position_p: 8.75,
            position_band: 2f64.to_radians(),
            position_period: 1e-3,
            rtol: 1e-6,
            atol: 1e-6,
            ..Default::default()
        }
    }

    #[test]
    fn rest_is_equilibrium() {
        for compl in [None, Some((8.1153e-06, 8.4427e-09, 1.6914e-5))] {
            let mut q = defaults();
            q.compliance = compl;
            let p0 = rest_position(&q, 0.0).unwrap();
            let plant = Plant {
                par: &q,
                inp: Inputs::default(),
            };
            let y = [0.0, 0.0, 0.0, p0, 0.0, 0.0, 0.0];
            let aux = plant.eval(&y);
            for (k, d) in aux.dy.iter().enumerate() {
                assert!(d.abs() < 1e-9, "state {k}: {d}");
            }
            assert!((aux.f_axial - (23.0 + 5.0 + 100.0 * (0.0897 - p0))).abs() < 1e-9);
        }
    }

    #[test]
    fn stall_torque_finite_beyond_full_twist() {
        // theta_t r > L0: strands stretched, tension large but finite
        let q = defaults();
        let plant = Plant {
            par: &q,
            inp: Inputs::default(),
        };
        let th_m = 1.05 * q.string_length / q.string_radius * q.gear_ratio;
        let y = [0.0, th_m, 0.0, 1e-3, 0.0, 0.0, 0.0];
        let aux = plant.eval(&y);
        assert!(aux.tension > 1e3 && aux.tension.is_finite());
        assert!(aux.dy.iter().all(|d| d.is_finite()));
    }
}
