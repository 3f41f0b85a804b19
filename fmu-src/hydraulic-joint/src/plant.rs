//! The continuous plant: parameters, state vector, right-hand side and outputs.
//!
//! State `y` (SI): `[theta, omega, x_L, v_L, p1_L, p2_L, x_R, v_R, p1_R, p2_R, Vs, Vr]` and,
//! with `valve_dynamics` on, the spools `[xv_L, vv_L, xv_R, vv_R]` (positions in volts of
//! command), and with `seal_friction` on the remembered piston speeds `[vm_L, vm_R]` (frictional
//! memory). `Vs`, `Vr` are the oil-balance integrals (supplied and returned oil as volume at
//! 0 gauge) over the current integration call; the model accumulates them.

use crate::controller::{ControllerParams, DEAD_BAND_BLEND};
use crate::physics::*;
use fmu_core::ModelError;
use serde::{Deserialize, Serialize};

pub const TH: usize = 0;
pub const OM: usize = 1;
/// First index of piston `i` (0 = left, 1 = right): `x, v, p1, p2`.
pub const fn piston(i: usize) -> usize {
    2 + 4 * i
}
/// Oil supplied by both valves since the start of the integration call [m3 at 0 gauge].
pub const VSUP: usize = 10;
/// Oil returned to tank by both valves since the start of the integration call [m3 at 0 gauge].
pub const VRET: usize = 11;
/// First index of spool `i`: `xv, vv`.
pub const fn spool(i: usize) -> usize {
    12 + 2 * i
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

/// Every parameter of the model (generated from the variable table, [`crate::vars`]).
pub use crate::vars::{
    CableFriction, EntrainedAir, InternalLeakage, Params, SealFriction, ValveDynamics, ValveOverlap,
};

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
    /// Specific volume of the air-oil mixture at 0 gauge (1 without entrained air).
    pub v_ref: f64,
    /// Spool states present (`valve_dynamics`).
    pub spool: bool,
    /// Index of the first frictional-memory state (`seal_friction`), one per piston.
    pub mem: Option<usize>,
    pub dim: usize,
}

impl Params {
    /// Check combinations the per-variable bounds cannot express and derive the constants.
    /// `Err` names the offending parameter.
    pub fn derive(&self) -> Result<Derived, ModelError> {
        if self.annulus_area >= self.piston_area {
            return Err(ModelError::parameters(
                &["annulus_area", "piston_area"],
                format!(
                    "annulus_area ({}) must be smaller than piston_area ({}) for a single-rod \
                     cylinder",
                    self.annulus_area, self.piston_area
                ),
            ));
        }
        if self.return_pressure >= self.supply_pressure {
            return Err(ModelError::parameters(
                &["return_pressure", "supply_pressure"],
                format!(
                    "return_pressure ({}) must be below supply_pressure ({})",
                    self.return_pressure, self.supply_pressure
                ),
            ));
        }
        let c = self.orifice_coefficients();
        let c_eff = if self.valve_use_mean {
            [0.25 * c.iter().sum::<f64>() * self.valve_flow_scale; 4]
        } else {
            c.map(|c| c * self.valve_flow_scale)
        };
        let t0 = self.spring_pretension;
        let k = self.spring_stiffness;
        let e0 = if t0 >= 0.5 * k * SLACK_BLEND {
            t0 / k + 0.5 * SLACK_BLEND
        } else {
            (2.0 * SLACK_BLEND * t0 / k).sqrt()
        };
        let (db_low, db_high) = match self.valve_overlap {
            Some(ValveOverlap { width: w }) => {
                (self.valve_deadband_low - w, self.valve_deadband_high + w)
            }
            None => (self.valve_deadband_low, self.valve_deadband_high),
        };
        let spool_states = if self.valve_dynamics.is_some() { 4 } else { 0 };
        let d = Derived {
            c_eff,
            inertia: self.link_inertia + self.load_mass * self.load_radius * self.load_radius,
            x0: 0.5 * self.stroke,
            e0,
            db_low,
            db_high,
            v_ref: match self.entrained_air {
                Some(a) => mixture_volume(
                    0.0,
                    self.bulk_modulus,
                    a.fraction,
                    P_ATM,
                    a.polytropic_index,
                )[0],
                None => 1.0,
            },
            spool: self.valve_dynamics.is_some(),
            mem: self.seal_friction.map(|_| spool(0) + spool_states),
            dim: spool(0) + spool_states + if self.seal_friction.is_some() { 2 } else { 0 },
        };
        let (p1, p2) = self.rest_pressures();
        if self.cables_attached && (p1 > self.supply_pressure || p2 > self.supply_pressure) {
            return Err(ModelError::parameters(
                &["spring_pretension", "supply_pressure"],
                format!(
                    "spring_pretension ({t0} N) cannot be held at rest with supply_pressure {} \
                     Pa (chamber pressure {:.4e} Pa needed)",
                    self.supply_pressure,
                    p1.max(p2)
                ),
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

    /// The Table I orifice coefficients `[c1, c2, c3, c4]`, eq. (13)-(16).
    pub fn orifice_coefficients(&self) -> [f64; 4] {
        [self.c1, self.c2, self.c3, self.c4]
    }

    /// What the controller knows: its own parameters and the pulley radius.
    pub fn controller(&self) -> ControllerParams {
        ControllerParams {
            rate: self.controller_rate,
            gain: self.controller_gain,
            radius: self.pulley_radius,
            slope_extend: self.controller_slope_extend,
            slope_retract: self.controller_slope_retract,
            deadband_low: self.controller_deadband_low,
            deadband_high: self.controller_deadband_high,
            cocontraction: self.controller_cocontraction,
        }
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
        if d.spool {
            y[spool(0)] = u[0];
            y[spool(1)] = u[1];
        }
        y
    }

    /// Absolute tolerance per state: `atol * nominal_i` with nominal scales theta 0.01 rad,
    /// omega 0.01 rad/s, x 1 mm, piston speed 1 cm/s, pressures 1e5 Pa, oil integrals 1e-8 m3
    /// (the oil moved in 1 ms at 0.6 L/min), spool 0.01 V and 10 V/s, remembered speed 1 cm/s:
    /// at the default `atol` 1e-6 these are 1e5 times finer than the 1e-3-of-range resolution at
    /// which outputs are compared. (A piston-speed scale of 1 mm/s, needed by the memoryless
    /// stiction model, cost up to 18 % more steps for no gain in accuracy.)
    pub fn atol_vector(&self, d: &Derived) -> Vec<f64> {
        let mut nominal = NOMINAL_BASE.to_vec();
        if d.spool {
            nominal.extend_from_slice(&NOMINAL_SPOOL);
        }
        if d.mem.is_some() {
            nominal.extend_from_slice(&NOMINAL_MEMORY);
        }
        debug_assert_eq!(nominal.len(), d.dim);
        nominal.iter().map(|n| n * self.atol).collect()
    }
}

/// Nominal scales of the base states `theta .. Vr` (see [`Params::atol_vector`]).
pub const NOMINAL_BASE: [f64; 12] = [
    0.01, 0.01, 1e-3, 1e-2, 1e5, 1e5, 1e-3, 1e-2, 1e5, 1e5, 1e-8, 1e-8,
];
/// Nominal scales of the spool states `xv_L, vv_L, xv_R, vv_R`.
pub const NOMINAL_SPOOL: [f64; 4] = [0.01, 10.0, 0.01, 10.0];
/// Nominal scales of the remembered piston speeds `vm_L, vm_R`.
pub const NOMINAL_MEMORY: [f64; 2] = [1e-2, 1e-2];

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
    /// Oil drawn from the supply and returned to tank, as volume at 0 gauge per second
    /// (`r(P_fed) Q_supply`, `r(P_drained) Q_tank`) [m3/s].
    pub oil_in: f64,
    pub oil_out: f64,
    /// Oil in the two chambers as volume at 0 gauge, `V1 r(P1) + V2 r(P2)` [m3].
    pub stored: f64,
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
        let xv = if d.spool { y[spool(i)] } else { self.u[i] };
        // valve: dead band (+ overlap) then orifices, eq. (13)-(16)
        let u_eff = dead_band(xv, d.db_low, d.db_high, DEAD_BAND_BLEND);
        let (q1v, q2v, q_supply) = valve_flows(
            u_eff,
            p1,
            p2,
            p.supply_pressure,
            p.return_pressure,
            &d.c_eff,
            P_TRANSITION,
        );
        let q_tank = q_supply - q1v - q2v;
        let (o1, o2) = self.oil(p1, p2);
        let (r_fed, r_drained) = if u_eff >= 0.0 {
            (o1.r, o2.r)
        } else {
            (o2.r, o1.r)
        };
        let (mut q1, mut q2) = (q1v, q2v);
        if let Some(InternalLeakage { coefficient: c_ip }) = p.internal_leakage {
            // mass-conserving: leaves chamber 1 as Q_leak, enters chamber 2 as Q_leak r1/r2
            let ql = leakage_flow(c_ip, p1, p2);
            q1 -= ql;
            q2 += ql * (o1.r / o2.r);
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
        let dp1 = pressure_rate(o1.beta, v1, p.piston_area * v, q1);
        let dp2 = pressure_rate(o2.beta, v2, -p.annulus_area * v, q2);
        // cable through the series spring: the left pull makes theta grow
        let sgn = if i == 0 { -1.0 } else { 1.0 };
        let (t_spring, t_joint) = if p.cables_attached {
            let e = d.e0 + (x - d.x0) + sgn * p.pulley_radius * theta;
            let ts = cable_tension(e, p.spring_stiffness, SLACK_BLEND);
            let tj = match p.cable_friction {
                Some(cf) => capstan_joint_tension(
                    ts,
                    cf.mu * p.bowden_wrap_angle,
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
        if let (Some(sf), Some(m)) = (p.seal_friction, d.mem) {
            g += seal_friction(
                v,
                y[m + i],
                sf.coulomb,
                sf.breakaway_excess,
                sf.stribeck_velocity,
                sf.viscous,
                SEAL_V_EPS,
            )
            .0;
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
            oil_in: r_fed * q_supply,
            oil_out: r_drained * q_tank,
            stored: v1 * o1.r + v2 * o2.r,
        }
    }

    /// Compressibility of the oil in both chambers (bulk modulus, slope, density ratio).
    pub fn oil(&self, p1: f64, p2: f64) -> (OilState, OilState) {
        let p = self.p;
        match p.entrained_air {
            Some(a) => {
                let f = |pg: f64| {
                    air_oil_state(
                        pg,
                        p.bulk_modulus,
                        a.fraction,
                        P_ATM,
                        a.polytropic_index,
                        self.d.v_ref,
                    )
                };
                (f(p1), f(p2))
            }
            None => (oil_state(p1, p.bulk_modulus), oil_state(p2, p.bulk_modulus)),
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
        dydt[VSUP] = l.oil_in + r.oil_in;
        dydt[VRET] = l.oil_out + r.oil_out;
        if let (Some(sf), Some(m)) = (self.p.seal_friction, self.d.mem) {
            for i in 0..2 {
                dydt[m + i] = friction_memory_rate(y[piston(i) + 1], y[m + i], sf.memory_time);
            }
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

/// Partial derivatives of one piston's rows and its contribution to the link row.
#[derive(Clone, Copy, Debug, Default)]
struct PistonJac {
    /// d(accel)/d(theta, x, v, p1, p2, v_m)
    a_th: f64,
    a_vm: f64,
    a_x: f64,
    a_v: f64,
    a_p1: f64,
    a_p2: f64,
    /// d(dp1)/d(x, v, p1, p2, xv) and d(dp2)/d(...)
    p1_x: f64,
    p1_v: f64,
    p1_p1: f64,
    p1_p2: f64,
    p1_xv: f64,
    p2_x: f64,
    p2_v: f64,
    p2_p1: f64,
    p2_p2: f64,
    p2_xv: f64,
    /// d(T_joint)/d(theta, omega, x)
    t_th: f64,
    t_om: f64,
    t_x: f64,
    /// d(oil_in)/d(p1, p2, xv) and d(oil_out)/d(p1, p2, xv)
    s_p1: f64,
    s_p2: f64,
    s_xv: f64,
    r_p1: f64,
    r_p2: f64,
    r_xv: f64,
}

impl Plant<'_> {
    /// Analytic partial derivatives of piston `i` (chain rule through the laws of
    /// [`crate::physics`]; the slopes of the smooth scalar laws for bulk modulus, seal friction,
    /// end stops and capstan by central differences).
    fn piston_jac(&self, i: usize, y: &[f64]) -> PistonJac {
        let (p, d) = (self.p, self.d);
        let b = piston(i);
        let (x, v, p1, p2) = (y[b], y[b + 1], y[b + 2], y[b + 3]);
        let (theta, omega) = (y[TH], y[OM]);
        let xv = if d.spool { y[spool(i)] } else { self.u[i] };
        let u_eff = dead_band(xv, d.db_low, d.db_high, DEAD_BAND_BLEND);
        let du = dead_band_slope(xv, d.db_low, d.db_high, DEAD_BAND_BLEND);
        let (ps, pr, c) = (p.supply_pressure, p.return_pressure, &d.c_eff);
        let (q1, q2, q_supply) = valve_flows(u_eff, p1, p2, ps, pr, c, P_TRANSITION);
        let q_tank = q_supply - q1 - q2;
        let (o1, o2) = self.oil(p1, p2);
        let (beta1, beta2, dbeta1, dbeta2) = (o1.beta, o2.beta, o1.dbeta, o2.dbeta);
        // flow partials: (dq1/dp1, dq1/dp2, dq2/dp1, dq2/dp2, dq1/du, dq2/du)
        let (mut q1p1, mut q1p2, mut q2p1, mut q2p2, q1u, q2u);
        if u_eff >= 0.0 {
            q1p1 = -c[0] * u_eff * signed_sqrt_reg_slope(ps - p1, P_TRANSITION);
            q2p2 = -c[2] * u_eff * signed_sqrt_reg_slope(p2 - pr, P_TRANSITION);
            q1u = c[0] * signed_sqrt_reg(ps - p1, P_TRANSITION);
            q2u = -c[2] * signed_sqrt_reg(p2 - pr, P_TRANSITION);
        } else {
            let a = -u_eff;
            q2p2 = -c[1] * a * signed_sqrt_reg_slope(ps - p2, P_TRANSITION);
            q1p1 = -c[3] * a * signed_sqrt_reg_slope(p1 - pr, P_TRANSITION);
            q2u = -c[1] * signed_sqrt_reg(ps - p2, P_TRANSITION);
            q1u = c[3] * signed_sqrt_reg(p1 - pr, P_TRANSITION);
        }
        // oil balance rates r(P_fed) Q_supply, r(P_drained) Q_tank with dr/dP = r/beta
        let (s_p1, s_p2, s_xv, r_p1, r_p2, r_xv) = if u_eff >= 0.0 {
            // fed: chamber 1 (Q_supply = q1), drained: chamber 2 (Q_tank = -q2)
            (
                o1.r * (q_supply / beta1 + q1p1),
                0.0,
                o1.r * q1u * du,
                0.0,
                o2.r * (q_tank / beta2 - q2p2),
                -o2.r * q2u * du,
            )
        } else {
            // fed: chamber 2 (Q_supply = q2), drained: chamber 1 (Q_tank = -q1)
            (
                0.0,
                o2.r * (q_supply / beta2 + q2p2),
                o2.r * q2u * du,
                o1.r * (q_tank / beta1 - q1p1),
                0.0,
                -o1.r * q1u * du,
            )
        };
        q1p2 = 0.0;
        q2p1 = 0.0;
        let (mut q1, mut q2) = (q1, q2);
        if let Some(InternalLeakage { coefficient: c_ip }) = p.internal_leakage {
            let ql = leakage_flow(c_ip, p1, p2);
            let ratio = o1.r / o2.r;
            q1 -= ql;
            q2 += ql * ratio;
            q1p1 -= c_ip;
            q1p2 += c_ip;
            // d(ql r1/r2)/dp1 = (c + ql/beta1) r1/r2, d/dp2 = -(c + ql/beta2) r1/r2
            q2p1 += (c_ip + ql / beta1) * ratio;
            q2p2 -= (c_ip + ql / beta2) * ratio;
        }
        let (a1, a2) = (p.piston_area, p.annulus_area);
        let (v1, v2) = chamber_volumes(x, p.stroke, a1, a2, p.dead_volume_cap, p.dead_volume_rod);
        let r1 = q1 - a1 * v;
        let r2 = q2 + a2 * v;
        let mut j = PistonJac {
            p1_p1: dbeta1 / v1 * r1 + beta1 / v1 * q1p1,
            p1_p2: beta1 / v1 * q1p2,
            p1_x: -beta1 * r1 * a1 / (v1 * v1),
            p1_v: -beta1 * a1 / v1,
            p1_xv: beta1 / v1 * q1u * du,
            p2_p2: dbeta2 / v2 * r2 + beta2 / v2 * q2p2,
            p2_p1: beta2 / v2 * q2p1,
            p2_x: beta2 * r2 * a2 / (v2 * v2),
            p2_v: beta2 * a2 / v2,
            p2_xv: beta2 / v2 * q2u * du,
            a_p1: a1 / p.piston_mass,
            a_p2: -a2 / p.piston_mass,
            s_p1,
            s_p2,
            s_xv,
            r_p1,
            r_p2,
            r_xv,
            ..Default::default()
        };
        // cable
        let sgn = if i == 0 { -1.0 } else { 1.0 };
        let rr = p.pulley_radius;
        let mut ts_e = 0.0;
        if p.cables_attached {
            let e = d.e0 + (x - d.x0) + sgn * rr * theta;
            let ts = cable_tension(e, p.spring_stiffness, SLACK_BLEND);
            ts_e = p.spring_stiffness * smooth_pos_slope(e, SLACK_BLEND);
            let (gain, t_om) = match p.cable_friction {
                Some(cf) => {
                    let mp = cf.mu * p.bowden_wrap_angle;
                    let vs = -sgn * rr * omega;
                    let g = |v: f64| capstan_joint_tension(1.0, mp, v, CAPSTAN_V_EPS);
                    (
                        g(vs),
                        ts * central_slope(g, vs, CAPSTAN_V_EPS) * (-sgn * rr),
                    )
                }
                None => (1.0, 0.0),
            };
            j.t_x = gain * ts_e;
            j.t_th = gain * ts_e * sgn * rr;
            j.t_om = t_om;
        }
        // piston accel
        let mut g_v = p.piston_damping;
        if let (Some(sf), Some(mi)) = (p.seal_friction, d.mem) {
            let (_, dv, dvm) = seal_friction(
                v,
                y[mi + i],
                sf.coulomb,
                sf.breakaway_excess,
                sf.stribeck_velocity,
                sf.viscous,
                SEAL_V_EPS,
            );
            g_v += dv;
            j.a_vm = -dvm / p.piston_mass;
        }
        let (mut stop_x, mut stop_v) = (0.0, 0.0);
        if x < 0.0 || x > p.stroke {
            let fx =
                |xx: f64| end_stop_force(xx, v, p.stroke, STOP_STIFFNESS, STOP_DAMPING, STOP_BLEND);
            let fv =
                |vv: f64| end_stop_force(x, vv, p.stroke, STOP_STIFFNESS, STOP_DAMPING, STOP_BLEND);
            stop_x = central_slope(fx, x, 1e-3 * STOP_BLEND);
            stop_v = central_slope(fv, v, 1e-3);
        }
        let m = p.piston_mass;
        j.a_x = (-ts_e + stop_x) / m;
        j.a_th = -ts_e * sgn * rr / m;
        j.a_v = (-g_v + stop_v) / m;
        j
    }
}

impl ode::OdeSystem for Plant<'_> {
    fn dim(&self) -> usize {
        self.d.dim
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        self.eval(y, dydt);
    }
    fn autonomous(&self) -> bool {
        true
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut nalgebra::DMatrix<f64>) -> bool {
        jac.fill(0.0);
        let r = self.p.pulley_radius;
        let inv_i = 1.0 / self.d.inertia;
        jac[(TH, OM)] = 1.0;
        jac[(OM, OM)] = -self.p.link_damping * inv_i;
        for i in 0..2 {
            let j = self.piston_jac(i, y);
            let b = piston(i);
            // link row: +T_L R - T_R R
            let s = if i == 0 { r * inv_i } else { -r * inv_i };
            jac[(OM, TH)] += s * j.t_th;
            jac[(OM, OM)] += s * j.t_om;
            jac[(OM, b)] += s * j.t_x;
            jac[(b, b + 1)] = 1.0;
            jac[(b + 1, TH)] = j.a_th;
            jac[(b + 1, b)] = j.a_x;
            jac[(b + 1, b + 1)] = j.a_v;
            jac[(b + 1, b + 2)] = j.a_p1;
            jac[(b + 1, b + 3)] = j.a_p2;
            jac[(b + 2, b)] = j.p1_x;
            jac[(b + 2, b + 1)] = j.p1_v;
            jac[(b + 2, b + 2)] = j.p1_p1;
            jac[(b + 2, b + 3)] = j.p1_p2;
            jac[(b + 3, b)] = j.p2_x;
            jac[(b + 3, b + 1)] = j.p2_v;
            jac[(b + 3, b + 2)] = j.p2_p1;
            jac[(b + 3, b + 3)] = j.p2_p2;
            jac[(VSUP, b + 2)] = j.s_p1;
            jac[(VSUP, b + 3)] = j.s_p2;
            jac[(VRET, b + 2)] = j.r_p1;
            jac[(VRET, b + 3)] = j.r_p2;
            if let (Some(sf), Some(m)) = (self.p.seal_friction, self.d.mem) {
                jac[(b + 1, m + i)] = j.a_vm;
                jac[(m + i, b + 1)] = 1.0 / sf.memory_time;
                jac[(m + i, m + i)] = -1.0 / sf.memory_time;
            }
            if let Some(vd) = self.p.valve_dynamics {
                let sp = spool(i);
                jac[(b + 2, sp)] = j.p1_xv;
                jac[(b + 3, sp)] = j.p2_xv;
                jac[(VSUP, sp)] = j.s_xv;
                jac[(VRET, sp)] = j.r_xv;
                let w = vd.natural_frequency;
                jac[(sp, sp + 1)] = 1.0;
                jac[(sp + 1, sp)] = -w * w;
                jac[(sp + 1, sp + 1)] = -2.0 * vd.damping_ratio * w;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::{
        CableFriction, EntrainedAir, InternalLeakage, Params, Plant, SealFriction, ValveDynamics,
        ValveOverlap,
    };
    use crate::vars::VARIABLES;
    use ode::OdeSystem;

    /// The analytic Jacobian against central differences of the right-hand side, at a moving
    /// state with every effect on (and with all off).
    #[test]
    fn analytic_jacobian_matches_differences() {
        for effects in [false, true] {
            let vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
            let mut p = Params::read(&vars);
            if effects {
                p.seal_friction = Some(SealFriction {
                    coulomb: 40.0,
                    breakaway_excess: 30.0,
                    stribeck_velocity: 0.01,
                    viscous: 300.0,
                    memory_time: 5e-3,
                });
                p.internal_leakage = Some(InternalLeakage { coefficient: 5e-13 });
                p.cable_friction = Some(CableFriction { mu: 0.1 });
                p.entrained_air = Some(EntrainedAir {
                    fraction: 0.02,
                    polytropic_index: 1.2,
                });
                p.valve_dynamics = Some(ValveDynamics {
                    natural_frequency: 1300.0,
                    damping_ratio: 0.7,
                });
                p.valve_overlap = Some(ValveOverlap { width: 0.3 });
            }
            let d = p.derive().unwrap();
            for (u, yy) in [
                (
                    [3.0, -3.5],
                    [0.1, 0.4, 0.055, 0.02, 6e6, 2e6, 0.045, -0.015, 1e6, 7e6],
                ),
                (
                    [-2.5, 2.2],
                    [-0.2, -0.3, 0.04, -0.01, 1e6, 8e6, 0.06, 0.012, 5e6, 1e6],
                ),
            ] {
                let mut y: Vec<f64> = yy.to_vec();
                y.extend_from_slice(&[3e-6, 1e-6]);
                if d.spool {
                    y.extend_from_slice(&[u[0] * 0.9, 50.0, u[1] * 0.8, -40.0]);
                }
                if d.mem.is_some() {
                    y.extend_from_slice(&[0.012, -0.004]);
                }
                let plant = Plant {
                    p: &p,
                    d: &d,
                    u,
                    tau_ext: 0.5,
                };
                let n = d.dim;
                let mut jac = nalgebra::DMatrix::zeros(n, n);
                assert!(plant.jacobian(0.0, &y, &mut jac));
                let nominal = [
                    1.0, 1.0, 0.01, 0.1, 1e6, 1e6, 0.01, 0.1, 1e6, 1e6, 1e-6, 1e-6, 1.0, 10.0, 1.0,
                    10.0, 0.01, 0.01,
                ];
                let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
                for j in 0..n {
                    let h = 1e-7 * nominal[j];
                    let mut yp = y.clone();
                    yp[j] += h;
                    let mut ym = y.clone();
                    ym[j] -= h;
                    plant.rhs(0.0, &yp, &mut fp);
                    plant.rhs(0.0, &ym, &mut fm);
                    for i in 0..n {
                        let fd = (fp[i] - fm[i]) / (2.0 * h);
                        let scale = jac[(i, j)].abs().max(fd.abs()).max(1e-6);
                        assert!(
                            (jac[(i, j)] - fd).abs() <= 1e-4 * scale,
                            "effects {effects} d f{i}/d y{j}: analytic {} fd {fd}",
                            jac[(i, j)]
                        );
                    }
                }
            }
        }
    }
}
