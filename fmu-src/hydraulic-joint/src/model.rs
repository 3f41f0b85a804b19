//! The FMI model: parameters from the variable table, consistent initialization at rest,
//! stepping with the 40 Hz controller samples hit exactly, outputs.

use crate::controller::{controller_update, U_MAX};
use crate::plant::*;
use crate::vars::{V, VARIABLES};
use fmu_core::{Model, ModelError, Values, ValuesMut, Variable};
use ode::{Integrator, SampleClock};
use serde::{Deserialize, Serialize};

/// The HydraulicJoint model state (serialized whole for fmi2GetFMUstate).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct HydraulicJoint {
    pub(crate) params: Option<(Params, Derived)>,
    pub(crate) y: Vec<f64>,
    pub(crate) integrator: Option<Integrator>,
    /// Voltages held at the valves [V].
    pub(crate) u_held: [f64; 2],
    /// External torque of the previous step (a change resets the step size history).
    pub(crate) tau_held: f64,
    /// Index of the next controller sample `t0 + k/f`.
    pub(crate) next_sample: u64,
    /// Oil supplied and returned since initialization [m3 at 0 gauge]: the sums of the ODE
    /// states `VSUP`, `VRET` over the integration calls (they restart at 0 in each call so
    /// their relative tolerance applies to the increment, not to the growing total).
    pub(crate) oil: [f64; 2],
    pub(crate) t0: f64,
}

impl HydraulicJoint {
    /// Integrator work counters (None before initialization).
    pub fn solver_stats(&self) -> Option<&ode::Stats> {
        self.integrator.as_ref().map(|i| i.stats())
    }

    /// Valve voltages when no controller sample is due: the inputs (open loop) or the held
    /// controller output.
    pub(crate) fn open_loop_commands(vars: &[f64]) -> [f64; 2] {
        let v = Values(vars);
        [
            v.real(V::U_LEFT).clamp(-U_MAX, U_MAX),
            v.real(V::U_RIGHT).clamp(-U_MAX, U_MAX),
        ]
    }

    /// Write every output from the current state and held commands.
    fn write_outputs(&mut self, vars: &mut [f64]) {
        self.write_outputs_with(vars, self.u_held, self.tau_held);
    }

    /// Write every output from the current state with valve commands `u` and torque `tau`.
    pub(crate) fn write_outputs_with(&self, vars: &mut [f64], u: [f64; 2], tau: f64) {
        let Some((p, d)) = &self.params else { return };
        let plant = Plant {
            p,
            d,
            u,
            tau_ext: tau,
        };
        let y = &self.y;
        let l = plant.piston(0, y);
        let r = plant.piston(1, y);
        let set = |vars: &mut [f64], v: V, x: f64| ValuesMut(vars).set(v, x);
        set(vars, V::THETA, y[TH]);
        set(vars, V::V_SUPPLIED, self.oil[0]);
        set(vars, V::V_RETURNED, self.oil[1]);
        set(vars, V::V_STORED, l.stored + r.stored);
        set(vars, V::OMEGA, y[OM]);
        for (i, a) in [l, r].iter().enumerate() {
            let b = piston(i);
            let (vx, vv, vp1, vp2, vf, vt, vu, vq) = if i == 0 {
                (
                    V::X_LEFT,
                    V::V_LEFT,
                    V::P1_LEFT,
                    V::P2_LEFT,
                    V::F_LEFT,
                    V::T_LEFT,
                    V::U_VALVE_LEFT,
                    V::Q_LEFT,
                )
            } else {
                (
                    V::X_RIGHT,
                    V::V_RIGHT,
                    V::P1_RIGHT,
                    V::P2_RIGHT,
                    V::F_RIGHT,
                    V::T_RIGHT,
                    V::U_VALVE_RIGHT,
                    V::Q_RIGHT,
                )
            };
            set(vars, vx, y[b]);
            set(vars, vv, y[b + 1]);
            set(vars, vp1, y[b + 2]);
            set(vars, vp2, y[b + 3]);
            set(vars, vf, a.force);
            set(vars, vt, a.t_joint);
            set(vars, vu, u[i]);
            set(vars, vq, a.q_supply);
        }
    }

    /// Integrate the plant from `t0` to `t1` with the held commands.
    fn advance(&mut self, t0: f64, t1: f64) -> Result<(), ModelError> {
        if t1 <= t0 {
            return Ok(());
        }
        let (Some((p, d)), Some(integ)) = (&self.params, &mut self.integrator) else {
            return Err(ModelError::NotInitialized);
        };
        let plant = Plant {
            p,
            d,
            u: self.u_held,
            tau_ext: self.tau_held,
        };
        self.y[VSUP] = 0.0;
        self.y[VRET] = 0.0;
        integ
            .integrate(&plant, t0, t1, &mut self.y)
            .map_err(|e| ModelError::solver(t0, t1, e))?;
        self.oil[0] += self.y[VSUP];
        self.oil[1] += self.y[VRET];
        if self.y.iter().any(|v| !v.is_finite()) {
            return Err(ModelError::solver(
                t0,
                t1,
                ode::OdeError::NonFinite { t: t1 },
            ));
        }
        Ok(())
    }

    /// Mean piston offset from the rest position `(x_L + x_R)/2 - x0` [m], the co-contraction
    /// loop's measurement (piston potentiometers).
    pub(crate) fn mean_piston_offset(&self) -> f64 {
        match &self.params {
            Some((_, d)) => 0.5 * (self.y[piston(0)] + self.y[piston(1)]) - d.x0,
            None => 0.0,
        }
    }

    /// Set new held commands; forget the step-size history if they changed (discontinuity).
    fn hold(&mut self, u: [f64; 2], tau: f64) {
        if u != self.u_held || tau != self.tau_held {
            self.u_held = u;
            self.tau_held = tau;
            if let Some(integ) = &mut self.integrator {
                integ.reset_step_size();
            }
        }
    }
}

impl Model for HydraulicJoint {
    const NAME: &'static str = "HydraulicJoint";
    const DESCRIPTION: &'static str = "NEUROexos agonist/antagonist hydraulic shoulder joint: two \
        CHL cylinders with D1FP spool valves, series springs, Bowden cables, pulley and link, \
        with the paper's 40 Hz position controller";
    const DEFAULT_STOP_TIME: f64 = 2.0;
    const EXPERIMENT_TOLERANCE: &'static [usize] = &[V::RTOL as usize, V::ATOL as usize];

    fn variables() -> &'static [Variable] {
        VARIABLES
    }

    fn documentation_html() -> String {
        crate::docs::html()
    }

    fn model_exchange() -> Option<fmu_core::MeVTable<Self>> {
        Some(fmu_core::MeVTable::of())
    }

    fn new() -> Self {
        HydraulicJoint {
            params: None,
            y: Vec::new(),
            integrator: None,
            u_held: [0.0; 2],
            tau_held: 0.0,
            next_sample: 0,
            oil: [0.0; 2],
            t0: 0.0,
        }
    }

    fn initialize(&mut self, vars: &mut [f64], start_time: f64) -> Result<(), ModelError> {
        let p = Params::read(vars);
        let d = p.derive()?;
        let u = if p.internal_controller {
            let (l, r) =
                controller_update(Values(vars).real(V::THETA_REF), 0.0, 0.0, &p.controller());
            [l, r]
        } else {
            Self::open_loop_commands(vars)
        };
        self.y = p.rest_state(&d, u);
        self.integrator = Some(Integrator::new(p.rtol, p.atol_vector(&d)));
        self.u_held = u;
        self.tau_held = Values(vars).real(V::TAU_EXT);
        self.next_sample = 0;
        self.oil = [0.0; 2];
        self.t0 = start_time;
        self.params = Some((p, d));
        self.write_outputs(vars);
        Ok(())
    }

    /// The tunable parameters (load mass, controller gains) act from the next step; the state
    /// and the held valve commands are kept, the step-size history restarts.
    fn tune(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let p = Params::read(vars);
        let d = p.derive()?;
        self.params = Some((p, d));
        if let Some(integ) = &mut self.integrator {
            integ.reset_step_size();
        }
        Ok(())
    }

    fn do_step(&mut self, vars: &mut [f64], t: f64, h: f64) -> Result<(), ModelError> {
        let Some((p, _)) = &self.params else {
            return Err(ModelError::NotInitialized);
        };
        let internal = p.internal_controller;
        let ctrl = p.controller();
        let inputs = Values(vars);
        let tau = inputs.real(V::TAU_EXT);
        let theta_ref = inputs.real(V::THETA_REF);
        let t_end = t + h;
        if !(h.is_finite() && h >= 0.0 && t.is_finite() && t_end.is_finite()) {
            return Err(ModelError::Step {
                t,
                h,
                reason: "time and step size must be finite, h >= 0".into(),
            });
        }
        if !internal {
            self.hold(Self::open_loop_commands(vars), tau);
            self.advance(t, t_end)?;
        } else {
            let Some(clock) = SampleClock::new(self.t0, 1.0 / ctrl.rate) else {
                return Err(ModelError::parameter(
                    "controller_rate",
                    format!("{} Hz gives no sample period", ctrl.rate),
                ));
            };
            if h * ctrl.rate > 1e6 {
                return Err(ModelError::Step {
                    t,
                    h,
                    reason: format!(
                        "spans more than 1e6 samples of the {} Hz controller; use smaller steps",
                        ctrl.rate
                    ),
                });
            }
            // samples due at (or before, within rounding) the start of the step: one update at
            // t uses the state there, however many sample instants lie at or before t
            let mut u = self.u_held;
            if clock.is_due(self.next_sample, t) {
                let (l, r) =
                    controller_update(theta_ref, self.y[TH], self.mean_piston_offset(), &ctrl);
                u = [l, r];
                self.next_sample = clock.after_due(self.next_sample, t);
            }
            self.hold(u, tau);
            let mut tc = t;
            loop {
                let (tk, sample) = clock.stop_before(self.next_sample, t_end);
                self.advance(tc, tk)?;
                if !sample {
                    break;
                }
                let (l, r) =
                    controller_update(theta_ref, self.y[TH], self.mean_piston_offset(), &ctrl);
                self.hold([l, r], tau);
                self.next_sample += 1;
                tc = tk;
            }
        }
        self.write_outputs(vars);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::HydraulicJoint;
    use crate::physics::free_piston_slopes;
    use crate::plant::{Params, Plant};
    use crate::vars::{V, VARIABLES};
    use fmu_core::Model;

    fn defaults() -> Vec<f64> {
        VARIABLES.iter().map(|v| v.start).collect()
    }

    #[test]
    fn controller_slopes_are_the_closed_form_fig6_slopes() {
        let p = Params::read(&defaults());
        let (ke, kr) = free_piston_slopes(
            p.piston_area,
            p.annulus_area,
            p.supply_pressure,
            0.0,
            &p.orifice_coefficients(),
        );
        assert!((p.controller_slope_extend / ke - 1.0).abs() < 2e-3, "{ke}");
        assert!((p.controller_slope_retract / kr - 1.0).abs() < 2e-3, "{kr}");
    }

    #[test]
    fn rest_is_an_exact_equilibrium() {
        let p = Params::read(&defaults());
        let d = p.derive().unwrap();
        let y = p.rest_state(&d, [0.0; 2]);
        let plant = Plant {
            p: &p,
            d: &d,
            u: [0.0; 2],
            tau_ext: 0.0,
        };
        let mut dy = vec![0.0; d.dim];
        plant.eval(&y, &mut dy);
        for (i, v) in dy.iter().enumerate() {
            assert!(v.abs() < 1e-9, "component {i}: {v}");
        }
    }

    #[test]
    fn serialized_state_continues_bit_identically() {
        let mut vars = defaults();
        let mut m = HydraulicJoint::new();
        m.initialize(&mut vars, 0.0).unwrap();
        let mut t = 0.0;
        for k in 0..300 {
            vars[V::THETA_REF as usize] = 0.5 * (k as f64 * 1e-3).min(0.2);
            m.do_step(&mut vars, t, 1e-3).unwrap();
            t += 1e-3;
        }
        let bytes = bincode::serialize(&m).unwrap();
        let mut copy: HydraulicJoint = bincode::deserialize(&bytes).unwrap();
        let mut vars2 = vars.clone();
        for _ in 0..200 {
            m.do_step(&mut vars, t, 1e-3).unwrap();
            copy.do_step(&mut vars2, t, 1e-3).unwrap();
            t += 1e-3;
        }
        assert_eq!(vars, vars2);
        assert!(vars[V::THETA as usize] > 0.05);
    }

    #[test]
    fn ill_posed_parameters_are_named() {
        for (v, x, name) in [
            (V::ANNULUS_AREA, 3e-4, "annulus_area"),
            (V::RETURN_PRESSURE, 2e7, "return_pressure"),
        ] {
            let mut vars = defaults();
            vars[v as usize] = x;
            let err = HydraulicJoint::new()
                .initialize(&mut vars, 0.0)
                .unwrap_err();
            assert!(err.names().contains(&name), "{err}");
        }
        let mut vars = defaults();
        vars[V::SUPPLY_PRESSURE as usize] = 1e6;
        vars[V::SPRING_PRETENSION as usize] = 1000.0;
        let err = HydraulicJoint::new()
            .initialize(&mut vars, 0.0)
            .unwrap_err();
        assert!(err.names().contains(&"spring_pretension"), "{err}");
    }

    #[test]
    fn oil_balance_closes_to_the_solver_tolerance() {
        // V_supplied - V_returned = V_stored - V_stored(0) (docs, 'Oil balance'), open loop
        // with leakage and air: the residual is solver error, far below rtol * throughput
        let mut vars = defaults();
        vars[V::INTERNAL_CONTROLLER as usize] = 0.0;
        vars[V::INTERNAL_LEAKAGE_ENABLED as usize] = 1.0;
        vars[V::ENTRAINED_AIR_ENABLED as usize] = 1.0;
        let mut m = HydraulicJoint::new();
        m.initialize(&mut vars, 0.0).unwrap();
        let s0 = vars[V::V_STORED as usize];
        for k in 0..1500 {
            let t = k as f64 * 1e-3;
            vars[V::U_LEFT as usize] = if (k / 300) % 2 == 0 { 6.0 } else { -7.0 };
            vars[V::U_RIGHT as usize] = if (k / 200) % 2 == 0 { -5.0 } else { 8.0 };
            m.do_step(&mut vars, t, 1e-3).unwrap();
        }
        let (vs, vr) = (vars[V::V_SUPPLIED as usize], vars[V::V_RETURNED as usize]);
        let res = vs - vr - (vars[V::V_STORED as usize] - s0);
        assert!(vs + vr > 3.0 * s0, "{vs} {vr} {s0}");
        assert!(res.abs() < 1e-6 * (vs + vr), "{res} {vs} {vr}");
    }

    #[test]
    fn samples_hit_exactly_whatever_the_communication_step() {
        // a sample at 1/40 s must see the state there: 7 ms steps vs 1 ms steps agree closely
        let run = |h: f64, n: usize| {
            let mut vars = defaults();
            vars[V::THETA_REF as usize] = 0.2;
            let mut m = HydraulicJoint::new();
            m.initialize(&mut vars, 0.0).unwrap();
            for k in 0..n {
                m.do_step(&mut vars, k as f64 * h, h).unwrap();
            }
            vars[V::THETA as usize]
        };
        let a = run(1e-3, 280);
        let b = run(7e-3, 40);
        assert!((a - b).abs() < 1e-6 * a.abs().max(1e-3), "{a} {b}");
    }
}
