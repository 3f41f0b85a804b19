//! The continuous plant: parameters, state vector, right-hand side and outputs.
//!
//! State `y` (SI): `[theta, omega, x_L, v_L, p1_L, p2_L, x_R, v_R, p1_R, p2_R]` and, with
//! `valve_dynamics` on, the spools `[xv_L, vv_L, xv_R, vv_R]` (positions in volts of command).

use crate::controller::{ControllerParams, DEAD_BAND_BLEND};
use crate::physics::*;
use serde::{Deserialize, Serialize};

pub const TH: usize = 0;
pub const OM: usize = 1;
/// First index of piston `i` (0 = left, 1 = right): `x, v, p1, p2`.
pub const fn piston(i: usize) -> usize {
    2 + 4 * i
}
/// First index of spool `i`: `xv, vv`.
pub const fn spool(i: usize) -> usize {
    10 + 2 * i
}

/// Laminar transition pressure drop of the orifices [Pa] (0.1 bar).
pub const P_TRANSITION: f64 = 1e4;
/// Blend width of the cable slack [m] (10 um).
pub const SLACK_BLEND: f64 = 1e-5;
/// End-stop contact stiffness [N/m], damping [N s/m] and blend width [m].
pub const STOP_STIFFNESS: f64 = 1e8;
pub const STOP_DAMPING: f64 = 5e3;
pub const STOP_BLEND: f64 = 1e-5;
/// Stiction regularisation speed of the seal friction [m/s].
pub const SEAL_V_EPS: f64 = 1e-4;
/// Direction regularisation speed of the capstan friction [m/s].
pub const CAPSTAN_V_EPS: f64 = 1e-3;
/// Atmospheric pressure [Pa] (gauge -> absolute for the entrained air).
pub const P_ATM: f64 = 101_325.0;

/// Every parameter of the model, read from the variable table at initialization.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Params {
    pub internal_controller: bool,
    pub cables_attached: bool,
    pub valve_use_mean: bool,
    pub load_mass: f64,
    pub load_radius: f64,
    pub link_inertia: f64,
    pub link_damping: f64,
    pub pulley_radius: f64,
    pub piston_area: f64,
    pub annulus_area: f64,
    pub stroke: f64,
    pub dead_volume_cap: f64,
    pub dead_volume_rod: f64,
    pub piston_mass: f64,
    pub piston_damping: f64,
    pub bulk_modulus: f64,
    pub supply_pressure: f64,
    pub return_pressure: f64,
    pub c: [f64; 4],
    pub valve_flow_scale: f64,
    pub valve_deadband_low: f64,
    pub valve_deadband_high: f64,
    pub spring_stiffness: f64,
    pub spring_pretension: f64,
    pub ctrl: ControllerParams,
    pub rtol: f64,
    pub atol: f64,
    pub seal_friction: Option<SealFriction>,
    pub valve_overlap: Option<f64>,
    pub internal_leakage: Option<f64>,
    pub cable_friction: Option<CableFriction>,
    pub entrained_air: Option<EntrainedAir>,
    pub valve_dynamics: Option<ValveDynamics>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct SealFriction {
    pub coulomb: f64,
    pub breakaway_excess: f64,
    pub stribeck_velocity: f64,
    pub viscous: f64,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct CableFriction {
    pub mu: f64,
    pub wrap_angle: f64,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct EntrainedAir {
    pub fraction: f64,
    pub polytropic_index: f64,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct ValveDynamics {
    pub natural_frequency: f64,
    pub damping_ratio: f64,
}

/// Quantities derived once at initialization.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Derived {
    /// Effective orifice coefficients (Table I times scale, or their mean).
    pub c_eff: [f64; 4],
    /// Total link inertia `I = link_inertia + load_mass load_radius^2` [kg m2].
    pub inertia: f64,
    /// Piston position at rest (mid-stroke) [m].
    pub x0: f64,
    /// Spring elongation at rest giving the pretension [m].
    pub e0: f64,
    /// Dead band edges including the valve overlap [V].
    pub db_low: f64,
    pub db_high: f64,
    pub dim: usize,
}

impl Params {
    /// Check combinations the per-variable bounds cannot express and derive the constants.
    /// `Err` names the offending parameter.
    pub fn derive(&self) -> Result<Derived, String> {
        if self.annulus_area >= self.piston_area {
            return Err(format!(
                "annulus_area ({}) must be smaller than piston_area ({}) for a single-rod cylinder",
                self.annulus_area, self.piston_area
            ));
        }
        if self.return_pressure >= self.supply_pressure {
            return Err(format!(
                "return_pressure ({}) must be below supply_pressure ({})",
                self.return_pressure, self.supply_pressure
            ));
        }
        let c_eff = if self.valve_use_mean {
            [0.25 * self.c.iter().sum::<f64>() * self.valve_flow_scale; 4]
        } else {
            self.c.map(|c| c * self.valve_flow_scale)
        };
        let t0 = self.spring_pretension;
        let k = self.spring_stiffness;
        let e0 = if t0 >= 0.5 * k * SLACK_BLEND {
            t0 / k + 0.5 * SLACK_BLEND
        } else {
            (2.0 * SLACK_BLEND * t0 / k).sqrt()
        };
        let (db_low, db_high) = match self.valve_overlap {
            Some(w) => (self.valve_deadband_low - w, self.valve_deadband_high + w),
            None => (self.valve_deadband_low, self.valve_deadband_high),
        };
        let d = Derived {
            c_eff,
            inertia: self.link_inertia + self.load_mass * self.load_radius * self.load_radius,
            x0: 0.5 * self.stroke,
            e0,
            db_low,
            db_high,
            dim: if self.valve_dynamics.is_some() {
                14
            } else {
                10
            },
        };
        let (p1, p2) = self.rest_pressures();
        if self.cables_attached && (p1 > self.supply_pressure || p2 > self.supply_pressure) {
            return Err(format!(
                "spring_pretension ({t0} N) cannot be held at rest with supply_pressure {} Pa \
                 (chamber pressure {:.4e} Pa needed)",
                self.supply_pressure,
                p1.max(p2)
            ));
        }
        Ok(d)
    }

    /// Chamber pressures at rest `(p1, p2)` [Pa]: valve closed (inside its dead band), piston
    /// force balancing the cable pretension `P1 A1 - P2 A2 = T0` (eq. 6 at rest). Without
    /// leakage the trapped pressures are not unique; we take the rod side at the valve's null
    /// pressure `P2 = (Ps + Pr)/2` (a zero-lapped valve's matched edges at null). With
    /// `internal_leakage` on, the only rest state has `P1 = P2 = T0/(A1 - A2)`.
    pub fn rest_pressures(&self) -> (f64, f64) {
        let t0 = if self.cables_attached {
            self.spring_pretension
        } else {
            0.0
        };
        if self.internal_leakage.is_some() {
            let p = t0 / (self.piston_area - self.annulus_area);
            (p, p)
        } else {
            let p2 = 0.5 * (self.supply_pressure + self.return_pressure);
            ((t0 + p2 * self.annulus_area) / self.piston_area, p2)
        }
    }

    /// Controller parameters.
    pub fn controller(&self) -> ControllerParams {
        self.ctrl
    }

    /// Initial state at rest (theta = 0, pistons mid-stroke, spools at the given commands).
    pub fn rest_state(&self, d: &Derived, u: [f64; 2]) -> Vec<f64> {
        let mut y = vec![0.0; d.dim];
        let (p1, p2) = self.rest_pressures();
        for i in 0..2 {
            let b = piston(i);
            y[b] = d.x0;
            y[b + 2] = p1;
            y[b + 3] = p2;
        }
        if d.dim == 14 {
            y[spool(0)] = u[0];
            y[spool(1)] = u[1];
        }
        y
    }

    /// Absolute tolerance per state: `atol * nominal_i` with nominal scales theta 0.01 rad,
    /// omega 0.01 rad/s, x 1 mm, v 1 mm/s, pressures 1e5 Pa, spool 0.01 V and 10 V/s: the
    /// resolution at which the outputs are compared (speeds near zero during stiction need a
    /// tight absolute tolerance).
    pub fn atol_vector(&self, dim: usize) -> Vec<f64> {
        let nominal = [
            0.01, 0.01, 1e-3, 1e-3, 1e5, 1e5, 1e-3, 1e-3, 1e5, 1e5, 0.01, 10.0, 0.01, 10.0,
        ];
        nominal[..dim].iter().map(|n| n * self.atol).collect()
    }
}

/// Everything computed from a state, for the right-hand side and for the outputs.
#[derive(Clone, Copy, Debug, Default)]
pub struct PistonAux {
    pub u_eff: f64,
    pub q1: f64,
    pub q2: f64,
    pub q_supply: f64,
    pub force: f64,
    pub t_spring: f64,
    pub t_joint: f64,
    pub dp1: f64,
    pub dp2: f64,
    pub accel: f64,
}

/// The plant as an ODE system with the valve commands and external torque held constant.
pub struct Plant<'a> {
    pub p: &'a Params,
    pub d: &'a Derived,
    /// Voltages at the valves [V] (command, before spool dynamics and dead band).
    pub u: [f64; 2],
    pub tau_ext: f64,
}

impl Plant<'_> {
    /// Piston `i` (0 left, 1 right): flows, forces and derivatives.
    pub fn piston(&self, i: usize, y: &[f64]) -> PistonAux {
        let (p, d) = (self.p, self.d);
        let b = piston(i);
        let (x, v, p1, p2) = (y[b], y[b + 1], y[b + 2], y[b + 3]);
        let (theta, omega) = (y[TH], y[OM]);
        let xv = if d.dim == 14 { y[spool(i)] } else { self.u[i] };
        // valve: dead band (+ overlap) then orifices, eq. (13)-(16)
        let u_eff = dead_band(xv, d.db_low, d.db_high, DEAD_BAND_BLEND);
        let (mut q1, mut q2, q_supply) = valve_flows(
            u_eff,
            p1,
            p2,
            p.supply_pressure,
            p.return_pressure,
            &d.c_eff,
            P_TRANSITION,
        );
        if let Some(c_ip) = p.internal_leakage {
            let ql = leakage_flow(c_ip, p1, p2);
            q1 -= ql;
            q2 += ql;
        }
        // chambers, eq. (7)-(12)
        let (v1, v2) = chamber_volumes(
            x,
            p.stroke,
            p.piston_area,
            p.annulus_area,
            p.dead_volume_cap,
            p.dead_volume_rod,
        );
        let (beta1, beta2) = match p.entrained_air {
            Some(a) => (
                effective_bulk_modulus(p.bulk_modulus, p1, a.fraction, P_ATM, a.polytropic_index),
                effective_bulk_modulus(p.bulk_modulus, p2, a.fraction, P_ATM, a.polytropic_index),
            ),
            None => (p.bulk_modulus, p.bulk_modulus),
        };
        let dp1 = pressure_rate(beta1, v1, p.piston_area * v, q1);
        let dp2 = pressure_rate(beta2, v2, -p.annulus_area * v, q2);
        // cable through the series spring: the left pull makes theta grow
        let sgn = if i == 0 { -1.0 } else { 1.0 };
        let (t_spring, t_joint) = if p.cables_attached {
            let e = d.e0 + (x - d.x0) + sgn * p.pulley_radius * theta;
            let ts = cable_tension(e, p.spring_stiffness, SLACK_BLEND);
            let tj = match p.cable_friction {
                Some(cf) => capstan_joint_tension(
                    ts,
                    cf.mu * cf.wrap_angle,
                    -sgn * p.pulley_radius * omega,
                    CAPSTAN_V_EPS,
                ),
                None => ts,
            };
            (ts, tj)
        } else {
            (0.0, 0.0)
        };
        // piston, eq. (6)
        let force = piston_force(p1, p2, p.piston_area, p.annulus_area);
        let mut g = p.piston_damping * v;
        if let Some(sf) = p.seal_friction {
            g += seal_friction(
                v,
                sf.coulomb,
                sf.breakaway_excess,
                sf.stribeck_velocity,
                sf.viscous,
                SEAL_V_EPS,
            );
        }
        let f_stop = end_stop_force(x, v, p.stroke, STOP_STIFFNESS, STOP_DAMPING, STOP_BLEND);
        let accel = (force - t_spring - g + f_stop) / p.piston_mass;
        PistonAux {
            u_eff,
            q1,
            q2,
            q_supply,
            force,
            t_spring,
            t_joint,
            dp1,
            dp2,
            accel,
        }
    }

    /// Link angular acceleration, paper eq. (1) with the cable tensions at the joint and the
    /// external torque: `I theta'' = (T_L - T_R) R - b theta' + tau_ext`.
    pub fn link_accel(&self, omega: f64, t_left: f64, t_right: f64) -> f64 {
        ((t_left - t_right) * self.p.pulley_radius - self.p.link_damping * omega + self.tau_ext)
            / self.d.inertia
    }

    /// The full right-hand side.
    pub fn eval(&self, y: &[f64], dydt: &mut [f64]) {
        let l = self.piston(0, y);
        let r = self.piston(1, y);
        dydt[TH] = y[OM];
        dydt[OM] = self.link_accel(y[OM], l.t_joint, r.t_joint);
        for (i, a) in [l, r].iter().enumerate() {
            let b = piston(i);
            dydt[b] = y[b + 1];
            dydt[b + 1] = a.accel;
            dydt[b + 2] = a.dp1;
            dydt[b + 3] = a.dp2;
        }
        if let Some(vd) = self.p.valve_dynamics {
            for i in 0..2 {
                let s = spool(i);
                dydt[s] = y[s + 1];
                dydt[s + 1] = spool_accel(
                    y[s],
                    y[s + 1],
                    self.u[i],
                    vd.natural_frequency,
                    vd.damping_ratio,
                );
            }
        }
    }
}

impl ode::OdeSystem for Plant<'_> {
    fn dim(&self) -> usize {
        self.d.dim
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        self.eval(y, dydt);
    }
}
