//! The axis as an ODE: parameters in SI, the state vector and its right-hand side.
//!
//! Rigid (description eq. 1, 3): states `(q, v)`, `M v' = F - friction(q, v) - offset`.
//! Two masses (flexibility or backlash on): states `(q, v, q_load, v_load)`, the motor side
//! `M - m_l` carries the drive force and the friction, the load `m_l` is pulled through the
//! screw-nut coupling: `(M - m_l) v' = F - friction - offset - F_c`, `m_l v_load' = F_c`.

use crate::physics::{
    coupling_force, coupling_slopes, friction_force, friction_slope, mode_damping, position_factor,
    Friction,
};
use serde::{Deserialize, Serialize};

/// State indices.
pub mod ix {
    pub const Q: usize = 0;
    pub const V: usize = 1;
    pub const Q_LOAD: usize = 2;
    pub const V_LOAD: usize = 3;
}

/// Stiffness of the screw-nut contact when backlash is on without flexibility [N/m]: stiff
/// enough to act as a rigid contact (mode above 500 Hz with the default masses).
pub const CONTACT_STIFFNESS: f64 = 1e8;
/// Damping ratio of that contact.
pub const CONTACT_DAMPING_RATIO: f64 = 0.1;
/// Nominal magnitudes of the states for the absolute tolerance: 1 mm, 1 cm/s.
pub const NOMINAL: [f64; 4] = [1e-3, 1e-2, 1e-3, 1e-2];

/// Every parameter in SI, effects as `Option` (None: off).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Params {
    pub internal_controller: bool,
    pub mass: f64,
    pub offset: f64,
    /// Friction of positive velocities (viscous_friction, coulomb_friction.force or 0).
    pub positive: Friction,
    /// Friction of negative velocities (the same as `positive` without asymmetric_friction).
    pub negative: Friction,
    pub q0: f64,
    pub v0: f64,
    pub load_mass: f64,
    pub kp: f64,
    pub kv: f64,
    pub drive_gain: f64,
    pub voltage_limit: f64,
    pub period: f64,
    pub smoothing: f64,
    pub travel_mid: f64,
    pub travel_half: f64,
    pub rtol: f64,
    pub atol: f64,
    /// flexibility: (stiffness, damping ratio).
    pub flexibility: Option<(f64, f64)>,
    /// backlash: total play.
    pub backlash: Option<f64>,
    /// position_friction: relative change at the ends of the travel.
    pub position_change: Option<f64>,
    /// controller_delay: delay of the force after its sample.
    pub delay: Option<f64>,
}

impl Params {
    /// True when the load is a second mass (flexibility or backlash on).
    pub fn two_mass(&self) -> bool {
        self.flexibility.is_some() || self.backlash.is_some()
    }

    /// Number of states: 2 rigid, 4 with two masses.
    pub fn dim(&self) -> usize {
        if self.two_mass() {
            4
        } else {
            2
        }
    }

    /// Stiffness and damping coefficient of the coupling: flexibility's, or the stiff contact.
    pub fn coupling(&self) -> (f64, f64) {
        let (k, zeta) = self
            .flexibility
            .unwrap_or((CONTACT_STIFFNESS, CONTACT_DAMPING_RATIO));
        let m_motor = self.mass - self.load_mass;
        (k, mode_damping(zeta, k, m_motor, self.load_mass))
    }
}

/// The right-hand side under a constant force `force`; positions in `y` are relative to
/// `q_offset` (the integrator controls their error over one interval, not over the travel).
pub struct Plant<'a> {
    pub par: &'a Params,
    pub force: f64,
    pub q_offset: f64,
}

impl Plant<'_> {
    /// Drive force minus friction and offset on the motor side.
    fn net_force(&self, q: f64, v: f64) -> f64 {
        let p = self.par;
        let factor = position_factor(q, p.position_change, p.travel_mid, p.travel_half);
        let friction = friction_force(v, p.positive, p.negative, p.smoothing, factor);
        self.force - friction - p.offset
    }

    /// `dy/dt` at `y`.
    pub fn derivatives(&self, y: &[f64], dy: &mut [f64]) {
        let p = self.par;
        let (q, v) = (y[ix::Q] + self.q_offset, y[ix::V]);
        let net = self.net_force(q, v);
        dy[ix::Q] = v;
        if !p.two_mass() {
            dy[ix::V] = net / p.mass;
            return;
        }
        let (k, c) = p.coupling();
        let play = p.backlash.unwrap_or(0.0);
        let fc = coupling_force(y[ix::Q] - y[ix::Q_LOAD], v - y[ix::V_LOAD], k, c, play);
        dy[ix::V] = (net - fc) / (p.mass - p.load_mass);
        dy[ix::Q_LOAD] = y[ix::V_LOAD];
        dy[ix::V_LOAD] = fc / p.load_mass;
    }
}

impl Plant<'_> {
    /// `(d net / dq, d net / dv)` of the motor side's net force.
    fn net_slopes(&self, q: f64, v: f64) -> (f64, f64) {
        let p = self.par;
        let factor = position_factor(q, p.position_change, p.travel_mid, p.travel_half);
        let dfactor = p.position_change.map_or(0.0, |c| c / p.travel_half);
        let raw = friction_force(v, p.positive, p.negative, p.smoothing, 1.0);
        let slope = friction_slope(v, p.positive, p.negative, p.smoothing);
        (-dfactor * raw, -factor * slope)
    }

    /// The Jacobian `jac[i * 4 + j] = d(dy_i)/d(y_j)` of [`Plant::derivatives`] over the four
    /// states (rows and columns of unused states 0).
    pub fn jacobian(&self, y: &[f64], jac: &mut [f64; 16]) {
        let p = self.par;
        jac.fill(0.0);
        let (dq, dv) = self.net_slopes(y[ix::Q] + self.q_offset, y[ix::V]);
        jac[ix::Q * 4 + ix::V] = 1.0;
        if !p.two_mass() {
            jac[ix::V * 4 + ix::Q] = dq / p.mass;
            jac[ix::V * 4 + ix::V] = dv / p.mass;
            return;
        }
        let (k, c) = p.coupling();
        let (ks, cs) = coupling_slopes(y[ix::Q] - y[ix::Q_LOAD], k, c, p.backlash.unwrap_or(0.0));
        let (mm, ml) = (p.mass - p.load_mass, p.load_mass);
        jac[ix::V * 4..ix::V * 4 + 4].copy_from_slice(&[
            (dq - ks) / mm,
            (dv - cs) / mm,
            ks / mm,
            cs / mm,
        ]);
        jac[ix::Q_LOAD * 4 + ix::V_LOAD] = 1.0;
        jac[ix::V_LOAD * 4..].copy_from_slice(&[ks / ml, cs / ml, -ks / ml, -cs / ml]);
    }
}

impl ode::OdeSystem for Plant<'_> {
    fn dim(&self) -> usize {
        self.par.dim()
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        self.derivatives(y, dydt);
    }
    fn autonomous(&self) -> bool {
        true
    }
    /// The analytic Jacobian ([`Plant::jacobian`]) over the states in use.
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut nalgebra::DMatrix<f64>) -> bool {
        let n = self.par.dim();
        let mut full = [0.0; 16];
        let mut y4 = [0.0; 4];
        y4[..n].copy_from_slice(&y[..n]);
        self.jacobian(&y4, &mut full);
        for i in 0..n {
            for j in 0..n {
                jac[(i, j)] = full[i * 4 + j];
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::{ix, Params, Plant};
    use crate::physics::Friction;

    fn rigid() -> Params {
        let f = Friction {
            viscous: 200.0,
            coulomb: 20.0,
        };
        Params {
            mass: 100.0,
            positive: f,
            negative: f,
            smoothing: 1e-4,
            travel_half: 0.125,
            ..Default::default()
        }
    }

    #[test]
    fn rigid_balance() {
        let p = rigid();
        let plant = Plant {
            par: &p,
            force: 50.0,
            q_offset: 0.0,
        };
        let mut dy = [0.0; 2];
        plant.derivatives(&[0.0, 0.1], &mut dy);
        // 100 kg a = 50 - 200 * 0.1 - 20 = 10
        assert!((dy[ix::V] - 0.1).abs() < 1e-9);
    }

    /// The analytic Jacobian against central differences, every effect on, in and out of the
    /// play and on both sides of a reversal.
    #[test]
    fn jacobian_matches_central_differences() {
        let mut p = rigid();
        p.load_mass = 10.0;
        p.negative = Friction {
            viscous: 240.0,
            coulomb: 21.0,
        };
        p.position_change = Some(0.2);
        p.travel_mid = 0.1;
        for (flex, play) in [
            (None, None),
            (Some((2e7, 0.05)), None),
            (None, Some(2e-5)),
            (Some((2e6, 0.1)), Some(2e-5)),
        ] {
            p.flexibility = flex;
            p.backlash = play;
            let plant = Plant {
                par: &p,
                force: 30.0,
                q_offset: 0.05,
            };
            for y in [
                [0.01, 0.02, 0.0099, 0.021],
                [0.01, -3e-4, 0.01 + 1.5e-5, 0.0],
                [0.0, 1e-5, -2e-6, 0.0],
            ] {
                let n = p.dim();
                let mut jac = [0.0; 16];
                plant.jacobian(&y, &mut jac);
                for j in 0..n {
                    let h = 1e-8 * y[j].abs().max(1e-2);
                    let (mut a, mut b) = (y, y);
                    a[j] += h;
                    b[j] -= h;
                    let (mut fa, mut fb) = ([0.0; 4], [0.0; 4]);
                    plant.derivatives(&a[..n], &mut fa[..n]);
                    plant.derivatives(&b[..n], &mut fb[..n]);
                    for i in 0..n {
                        let fd = (fa[i] - fb[i]) / (2.0 * h);
                        let an = jac[i * 4 + j];
                        assert!(
                            (fd - an).abs() <= 1e-5 * an.abs().max(1.0),
                            "({i},{j}) {an} vs {fd} at {y:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn two_mass_splits_and_couples() {
        let mut p = rigid();
        p.load_mass = 10.0;
        p.flexibility = Some((1e7, 0.0));
        let plant = Plant {
            par: &p,
            force: 20.0,
            q_offset: 0.0,
        };
        let mut dy = [0.0; 4];
        // deflection 1 um: 10 N on the load; motor side 90 kg
        plant.derivatives(&[1e-6, 0.0, 0.0, 0.0], &mut dy);
        assert!((dy[ix::V_LOAD] - 1.0).abs() < 1e-9);
        assert!((dy[ix::V] - (20.0 - 10.0) / 90.0).abs() < 1e-9);
    }
}
