//! Model Exchange: the importer integrates the states `(qm, v_motor, load_position,
//! load_velocity)`; the controller's samples and its delayed force changes are time events. The
//! equations are those of Co-Simulation ([`crate::plant`], [`crate::controller`]); without two
//! masses the load's states keep their start values (derivative 0).

use crate::model::{read_params, validate, Emps};
use crate::plant::{ix, Plant, NOMINAL};
use crate::vars::V;
use fmu_core::{ModelError, ModelExchange, ValuesMut};

/// `(state, derivative)` positions in the table, in the order of `x`.
const STATE_VARIABLES: [(usize, usize); 4] = [
    (V::QM as usize, V::DER_QM as usize),
    (V::V_MOTOR as usize, V::DER_V_MOTOR as usize),
    (V::LOAD_POSITION as usize, V::DER_LOAD_POSITION as usize),
    (V::LOAD_VELOCITY as usize, V::DER_LOAD_VELOCITY as usize),
];

impl Emps {
    /// `dy/dt` under the force acting now; positions absolute (no offset).
    pub(crate) fn rates(&self, vars: &[f64]) -> [f64; 4] {
        let mut dy = [0.0; 4];
        let plant = Plant {
            par: &self.par,
            force: self.force(vars),
            q_offset: 0.0,
        };
        let n = self.par.dim();
        plant.derivatives(&self.y[..n], &mut dy[..n]);
        dy
    }

    /// The state variables and their derivatives (written in both interfaces).
    pub(crate) fn write_state_variables(&self, vars: &mut [f64]) {
        let dy = self.rates(vars);
        let mut out = ValuesMut(vars);
        out.set(V::LOAD_POSITION, self.y[ix::Q_LOAD]);
        out.set(V::LOAD_VELOCITY, self.y[ix::V_LOAD]);
        out.set(V::DER_QM, dy[ix::Q]);
        out.set(V::DER_V_MOTOR, dy[ix::V]);
        out.set(V::DER_LOAD_POSITION, dy[ix::Q_LOAD]);
        out.set(V::DER_LOAD_VELOCITY, dy[ix::V_LOAD]);
    }
}

impl ModelExchange for Emps {
    const STATES: usize = 4;

    fn state_variables() -> &'static [(usize, usize)] {
        &STATE_VARIABLES
    }

    /// In open loop the applied force is the input `force_measured`.
    fn output_feedthrough() -> &'static [(usize, &'static [usize])] {
        const F: [(usize, &[usize]); 1] = [(V::FORCE as usize, &[V::FORCE_MEASURED as usize])];
        &F
    }

    /// Every parameter as initialization reads it; states and controller kept.
    fn set_parameters(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let par = read_params(vars);
        validate(&par)?;
        self.par = par;
        Ok(())
    }

    fn states(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.y);
    }

    fn set_states(&mut self, x: &[f64]) {
        self.y.copy_from_slice(x);
    }

    fn nominals(&self, n: &mut [f64]) {
        n.copy_from_slice(&NOMINAL);
    }

    fn derivatives(&self, vars: &[f64], t: f64, dx: &mut [f64]) -> Result<(), ModelError> {
        dx.copy_from_slice(&self.rates(vars));
        if dx.iter().all(|d| d.is_finite()) {
            Ok(())
        } else {
            Err(ModelError::Step {
                t,
                h: 0.0,
                reason: "non-finite derivative".into(),
            })
        }
    }

    fn me_outputs(&self, vars: &mut [f64], _t: f64) {
        self.write_outputs(vars);
    }

    /// The next sample or delayed force change.
    fn next_time_event(&self) -> Option<f64> {
        let clock = ode::SampleClock::new(self.t0, self.par.period)?;
        let sample = clock.time(self.ctrl.next_sample);
        Some(self.ctrl.next_release().map_or(sample, |r| r.min(sample)))
    }

    /// Every sample and delayed force change due at `t`, as `do_step` takes them.
    fn event_update(&mut self, vars: &mut [f64], t: f64) -> Result<bool, ModelError> {
        let clock = self.sample_clock()?;
        let before = self.ctrl.clone();
        while clock.is_due(self.ctrl.next_sample, t) {
            self.take_sample(vars, clock);
        }
        self.ctrl.release_due(t, clock.tolerance());
        let changed = before != self.ctrl;
        if changed {
            self.write_outputs(vars);
        }
        Ok(changed)
    }

    const PROVIDES_JACOBIAN: bool = true;

    /// The plant's analytic Jacobian ([`Plant::jacobian`]).
    fn state_jacobian(&self, vars: &[f64], _t: f64, jac: &mut [f64]) -> Result<(), ModelError> {
        let plant = Plant {
            par: &self.par,
            force: self.force(vars),
            q_offset: 0.0,
        };
        let mut j = [0.0; 16];
        plant.jacobian(&self.y, &mut j);
        jac.copy_from_slice(&j);
        Ok(())
    }
}
