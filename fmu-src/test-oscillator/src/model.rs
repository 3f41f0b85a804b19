//! The FMI model: parameters copied at initialization, RK4 sub-steps (Co-Simulation), the
//! right-hand side `(x, v)' = (v, (F - c v - k x) / m)` (Model Exchange), outputs.

use crate::vars::{Params, V, VARIABLES};
use fmu_core::{MeVTable, Model, ModelError, ModelExchange, Values, ValuesMut, Variable};
use serde::{Deserialize, Serialize};

/// The physical state; parameters copied at initialization.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Oscillator {
    x: f64,
    v: f64,
    p: Params,
}

impl Oscillator {
    fn accel(&self, x: f64, v: f64, f: f64) -> f64 {
        (f - self.p.damping * v - self.p.stiffness * x) / self.p.mass
    }

    fn outputs(&self, vars: &mut [f64]) {
        let mut out = ValuesMut(vars);
        out.set(V::X, self.x);
        out.set(V::V, self.v);
        out.set(
            V::ENERGY,
            0.5 * self.p.mass * self.v * self.v + 0.5 * self.p.stiffness * self.x * self.x,
        );
    }
}

impl Model for Oscillator {
    const NAME: &'static str = "Oscillator";
    const DESCRIPTION: &'static str = "Damped spring-mass oscillator (test model of the FMI layer)";
    const DEFAULT_STOP_TIME: f64 = 2.0;

    fn variables() -> &'static [Variable] {
        VARIABLES
    }

    fn documentation_html() -> String {
        crate::docs::html()
    }

    fn new() -> Self {
        Oscillator::default()
    }

    fn initialize(&mut self, vars: &mut [f64], _start_time: f64) -> Result<(), ModelError> {
        let p = Params::read(vars);
        *self = Oscillator { x: p.x0, v: 0.0, p };
        if self.p.stiffness == 0.0 && self.p.damping == 0.0 && !self.p.locked {
            return Err(ModelError::parameters(
                &["stiffness", "damping"],
                "both 0: the motion is undamped and unbounded under a constant force",
            ));
        }
        self.outputs(vars);
        Ok(())
    }

    fn model_exchange() -> Option<MeVTable<Self>> {
        Some(MeVTable::of())
    }

    fn do_step(&mut self, vars: &mut [f64], t: f64, h: f64) -> Result<(), ModelError> {
        if t + h >= self.p.fail_at {
            return Err(ModelError::Step {
                t,
                h,
                reason: format!("deliberate failure: fail_at = {} reached", self.p.fail_at),
            });
        }
        if !self.p.locked {
            let f = Values(vars).real(V::FORCE);
            let n = (h / self.p.max_substep).ceil().max(1.0) as usize;
            let dt = h / n as f64;
            for _ in 0..n {
                let (x, v) = (self.x, self.v);
                let (k1x, k1v) = (v, self.accel(x, v, f));
                let (k2x, k2v) = (
                    v + 0.5 * dt * k1v,
                    self.accel(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v, f),
                );
                let (k3x, k3v) = (
                    v + 0.5 * dt * k2v,
                    self.accel(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v, f),
                );
                let (k4x, k4v) = (v + dt * k3v, self.accel(x + dt * k3x, v + dt * k3v, f));
                self.x += dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                self.v += dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            }
        }
        self.outputs(vars);
        Ok(())
    }
}

/// Model Exchange: states `(x, v)`; a locked mass has derivative 0; `fail_at` fails the
/// derivative evaluation from that time on (the error path of `fmi2GetDerivatives`).
impl ModelExchange for Oscillator {
    const STATES: usize = 2;

    fn state_variables() -> &'static [(usize, usize)] {
        const S: [(usize, usize); 2] = [
            (V::X as usize, V::DER_X as usize),
            (V::V as usize, V::DER_V as usize),
        ];
        &S
    }

    /// `der(v) = (F - c v - k x) / m`, `energy = m v^2 / 2 + k x^2 / 2`, both 0-rate when
    /// locked; `fail_at` makes the evaluation fail (no value depends on it).
    fn parameter_dependencies() -> Option<&'static [(usize, &'static [usize])]> {
        const DER_V: &[usize] = &[
            V::MASS as usize,
            V::STIFFNESS as usize,
            V::DAMPING as usize,
            V::LOCKED as usize,
        ];
        const ENERGY: &[usize] = &[V::MASS as usize, V::STIFFNESS as usize];
        const DEPS: &[(usize, &[usize])] = &[
            (V::DER_X as usize, &[V::LOCKED as usize]),
            (V::DER_V as usize, DER_V),
            (V::ENERGY as usize, ENERGY),
        ];
        Some(DEPS)
    }

    /// The parameters as `initialize` reads them; position and velocity kept.
    fn set_parameters(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let (x, v) = (self.x, self.v);
        self.initialize(&mut vars.to_vec(), 0.0)?;
        (self.x, self.v) = (x, v);
        Ok(())
    }

    fn states(&self, x: &mut [f64]) {
        x.copy_from_slice(&[self.x, self.v]);
    }

    fn set_states(&mut self, x: &[f64]) {
        (self.x, self.v) = (x[0], x[1]);
    }

    fn nominals(&self, n: &mut [f64]) {
        n.fill(1e-2);
    }

    fn derivatives(&self, vars: &[f64], t: f64, dx: &mut [f64]) -> Result<(), ModelError> {
        if t >= self.p.fail_at {
            return Err(ModelError::Step {
                t,
                h: 0.0,
                reason: format!("deliberate failure: fail_at = {} reached", self.p.fail_at),
            });
        }
        if self.p.locked {
            dx.fill(0.0);
        } else {
            let f = Values(vars).real(V::FORCE);
            dx.copy_from_slice(&[self.v, self.accel(self.x, self.v, f)]);
        }
        Ok(())
    }

    const PROVIDES_JACOBIAN: bool = true;

    /// `d(x, v)'/d(x, v) = [[0, 1], [-k/m, -c/m]]` (0 when locked).
    fn state_jacobian(&self, _vars: &[f64], _t: f64, jac: &mut [f64]) -> Result<(), ModelError> {
        if self.p.locked {
            jac.fill(0.0);
        } else {
            jac.copy_from_slice(&[
                0.0,
                1.0,
                -self.p.stiffness / self.p.mass,
                -self.p.damping / self.p.mass,
            ]);
        }
        Ok(())
    }

    fn me_outputs(&self, vars: &mut [f64], t: f64) {
        self.outputs(vars);
        let mut dx = [0.0; 2];
        if self.derivatives(vars, t, &mut dx).is_ok() {
            let mut out = ValuesMut(vars);
            out.set(V::DER_X, dx[0]);
            out.set(V::DER_V, dx[1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Oscillator;
    use crate::vars::{V, VARIABLES};
    use fmu_core::Model;

    #[test]
    fn free_oscillation_matches_closed_form() {
        let mut m = Oscillator::new();
        let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
        m.initialize(&mut vars, 0.0).unwrap();
        for i in 0..1000 {
            m.do_step(&mut vars, i as f64 * 1e-3, 1e-3).unwrap();
        }
        // Underdamped closed form: x = x0 e^{-zeta wn t} (cos wd t + zeta wn / wd sin wd t).
        let (k, c, mass, x0, t) = (100.0f64, 0.5, 1.0, 0.01, 1.0);
        let wn = (k / mass).sqrt();
        let zeta = c / (2.0 * (k * mass).sqrt());
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let exact =
            x0 * (-zeta * wn * t).exp() * ((wd * t).cos() + zeta * wn / wd * (wd * t).sin());
        assert!(
            (vars[V::X as usize] - exact).abs() < 1e-9,
            "{} vs {exact}",
            vars[V::X as usize]
        );
    }

    /// The declared parameter dependencies name every parameter that moves an output or a
    /// derivative, mid-oscillation.
    #[test]
    fn declared_parameter_dependencies_cover_the_equations() {
        let mut m = Oscillator::new();
        let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
        vars[V::FORCE as usize] = 2.0;
        m.initialize(&mut vars, 0.0).unwrap();
        for i in 0..100 {
            m.do_step(&mut vars, i as f64 * 1e-3, 1e-3).unwrap();
        }
        let problems = fmu_core::me::parameter_dependency_problems(&m, &vars, 0.1);
        assert!(problems.is_empty(), "{problems:#?}");
    }
}
