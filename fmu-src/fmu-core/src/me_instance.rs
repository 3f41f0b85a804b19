//! The Model Exchange functions of [`Instance`] (FMI 2.0.4 section 3.2, FMI 3.0.2 chapter 3):
//! time and states set by the importer's integrator, derivatives, event indicators, and the
//! event mode in which the model's sampled controllers tick (time events). Every call checks
//! the state machine first and changes nothing when it refuses.

use crate::instance::{Instance, Status};
use crate::machine::{Checked, Interface, MachineState};
use crate::{MeVTable, Model};

/// Event iterations of one discrete-state update before the model is declared to chatter.
const MAX_EVENT_ITERATIONS: usize = 100;

/// The outcome of a discrete-state update (`fmi2EventInfo`; the outputs of
/// `fmi3UpdateDiscreteStates`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventInfo {
    pub new_discrete_states_needed: bool,
    pub terminate_simulation: bool,
    pub nominals_of_continuous_states_changed: bool,
    pub values_of_continuous_states_changed: bool,
    pub next_event_time: Option<f64>,
}

impl<M: Model> Instance<M> {
    /// The Model Exchange table, or a logged error when the instance is not a Model Exchange one.
    fn me_table(&mut self, call: Checked) -> Result<MeVTable<M>, Status> {
        let Some(me) = self
            .me
            .filter(|_| self.interface == Interface::ModelExchange)
        else {
            return Err(self.error(
                call.name,
                "a Model Exchange function called on a Co-Simulation instance",
            ));
        };
        Ok(me)
    }

    /// Check that the importer's array length `n` is the number the model has.
    fn check_len(
        &mut self,
        func: &str,
        what: &str,
        n: usize,
        expected: usize,
    ) -> Result<(), Status> {
        if n == expected {
            Ok(())
        } else {
            Err(self.error(func, format!("{what} is {n}, the model has {expected}")))
        }
    }

    /// Model Exchange: recompute outputs, states and derivatives in `vars` when time, states or
    /// inputs changed since the last computation.
    pub(crate) fn refresh_me_outputs(&mut self) {
        if !self.me_outputs_stale || !self.running() {
            return;
        }
        if let Some(me) = self.me {
            (me.outputs)(&self.model, &mut self.vars, self.time);
        }
        self.me_outputs_stale = false;
    }

    /// Co-Simulation of a model with Model Exchange: the state and derivative variables at the
    /// communication point (a state that is an output already holds the same value; the other
    /// outputs are the step's). A model that cannot evaluate the derivatives leaves them
    /// unchanged. Allocation-free after instantiation (scratch of `2 STATES`).
    pub(crate) fn write_derivatives(&mut self) {
        let Some(me) = self.me else { return };
        let mut scratch = std::mem::take(&mut self.me_scratch);
        scratch.resize(2 * me.states, 0.0);
        let (x, dx) = scratch.split_at_mut(me.states);
        (me.get_states)(&self.model, x);
        let ok = (me.derivatives)(&self.model, &self.vars, self.time, dx).is_ok();
        for (k, &(s, d)) in me.state_variables.iter().enumerate() {
            self.vars[s] = x[k];
            if ok {
                self.vars[d] = dx[k];
            }
        }
        self.me_scratch = scratch;
    }

    /// Set the time.
    pub fn set_time(&mut self, call: Checked, t: f64) -> Status {
        let func = call.name;
        if let Err(s) = self.me_table(call) {
            return s;
        }
        if !t.is_finite() {
            return self.error(func, format!("time {t} is not finite"));
        }
        self.time = t;
        self.me_outputs_stale = true;
        self.jacobian.clear();
        Status::Ok
    }

    /// Set the continuous states: all values finite, else nothing changes.
    pub fn set_continuous_states(&mut self, call: Checked, x: &[f64]) -> Status {
        let me = match self.me_table(call) {
            Ok(me) => me,
            Err(s) => return s,
        };
        self.write_states(call.name, &me, x)
    }

    /// The body of [`Instance::set_continuous_states`] after the checks of the state.
    fn write_states(&mut self, func: &str, me: &MeVTable<M>, x: &[f64]) -> Status {
        if let Err(s) = self.check_len(func, "nx", x.len(), me.states) {
            return s;
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            let name = M::variables()[me.state_variables[i].0].name;
            return self.error(func, format!("state '{name}' = {} is not finite", x[i]));
        }
        (me.set_states)(&mut self.model, x);
        self.me_outputs_stale = true;
        self.jacobian.clear();
        Status::Ok
    }

    /// Enter Event Mode.
    pub fn enter_event_mode(&mut self, call: Checked) -> Status {
        if let Err(s) = self.me_table(call) {
            return s;
        }
        self.state = MachineState::EventMode;
        Status::Ok
    }

    /// Enter Continuous-Time Mode.
    pub fn enter_continuous_time_mode(&mut self, call: Checked) -> Status {
        if let Err(s) = self.me_table(call) {
            return s;
        }
        self.state = MachineState::ContinuousTimeMode;
        Status::Ok
    }

    /// The discrete-state update: the model's event update at the current time, iterated until
    /// no discrete value changes (at most [`MAX_EVENT_ITERATIONS`] times); a failure moves the
    /// instance to the error state with the model's values of before the call.
    pub fn new_discrete_states(&mut self, call: Checked, info: &mut EventInfo) -> Status {
        let func = call.name;
        let me = match self.me_table(call) {
            Ok(me) => me,
            Err(s) => return s,
        };
        self.refresh_me_outputs();
        let mut model = self.model.clone();
        let mut vars = self.vars.clone();
        let mut before = vec![0.0; me.states];
        (me.get_states)(&model, &mut before);
        let mut settled = false;
        for _ in 0..MAX_EVENT_ITERATIONS {
            match (me.event_update)(&mut model, &mut vars, self.time) {
                Ok(true) => {}
                Ok(false) => {
                    settled = true;
                    break;
                }
                Err(e) => {
                    self.state = MachineState::Error;
                    return self.error(func, format!("event at t = {}: {e}", self.time));
                }
            }
        }
        if !settled {
            self.state = MachineState::Error;
            let t = self.time;
            return self.error(
                func,
                format!("event at t = {t}: discrete states still change after {MAX_EVENT_ITERATIONS} iterations"),
            );
        }
        let mut after = vec![0.0; me.states];
        (me.get_states)(&model, &mut after);
        self.model = model;
        self.vars = vars;
        self.me_outputs_stale = true;
        self.jacobian.clear();
        let next = (me.next_time_event)(&self.model).filter(|t| t.is_finite());
        *info = EventInfo {
            new_discrete_states_needed: false,
            terminate_simulation: false,
            nominals_of_continuous_states_changed: false,
            values_of_continuous_states_changed: before
                .iter()
                .zip(&after)
                .any(|(a, b)| a.to_bits() != b.to_bits()),
            next_event_time: next,
        };
        if let Some(t) = next {
            self.event(format!(
                "event at t = {}: next time event at {t}",
                self.time
            ));
        }
        Status::Ok
    }

    /// A completed integrator step: no step events, no termination requested; returns
    /// `(enterEventMode, terminateSimulation)`.
    pub fn completed_integrator_step(&mut self, call: Checked) -> (Status, bool, bool) {
        match self.me_table(call) {
            Ok(_) => (Status::Ok, false, false),
            Err(s) => (s, false, false),
        }
    }

    /// The state derivatives: a failure or a value that is not finite is an error of the call
    /// (the instance keeps its state: the importer may retry with other states, e.g. a smaller
    /// step).
    pub fn get_derivatives(&mut self, call: Checked, dx: &mut [f64]) -> Status {
        let func = call.name;
        let me = match self.me_table(call) {
            Ok(me) => me,
            Err(s) => return s,
        };
        if let Err(s) = self.check_len(func, "nx", dx.len(), me.states) {
            return s;
        }
        // Into the instance's scratch first (no allocation per call): `dx` is written only
        // when every value is finite.
        let mut out = std::mem::take(&mut self.me_scratch);
        out.resize(me.states, 0.0);
        let status = match (me.derivatives)(&self.model, &self.vars, self.time, &mut out) {
            Err(e) => self.error(func, format!("at t = {}: {e}", self.time)),
            Ok(()) => match out.iter().position(|v| !v.is_finite()) {
                Some(i) => {
                    let name = M::variables()[me.state_variables[i].1].name;
                    let t = self.time;
                    self.error(
                        func,
                        format!("'{name}' = {} at t = {t} is not finite", out[i]),
                    )
                }
                None => {
                    dx.copy_from_slice(&out);
                    Status::Ok
                }
            },
        };
        self.me_scratch = out;
        status
    }

    /// The event indicators.
    pub fn get_event_indicators(&mut self, call: Checked, z: &mut [f64]) -> Status {
        let func = call.name;
        let me = match self.me_table(call) {
            Ok(me) => me,
            Err(s) => return s,
        };
        if let Err(s) = self.check_len(func, "ni", z.len(), me.event_indicators) {
            return s;
        }
        (me.indicators)(&self.model, &self.vars, self.time, z);
        Status::Ok
    }

    /// The continuous states (in initialization mode: the initial states of the current
    /// parameters and start values).
    pub fn get_continuous_states(&mut self, call: Checked, x: &mut [f64]) -> Status {
        let func = call.name;
        let me = match self.me_table(call) {
            Ok(me) => me,
            Err(s) => return s,
        };
        if let Err(s) = self.check_len(func, "nx", x.len(), me.states) {
            return s;
        }
        if let Err(s) = self.refresh_values(func) {
            return s;
        }
        (me.get_states)(&self.model, x);
        Status::Ok
    }

    /// The nominals of the continuous states: the model's, 1 where one is not a positive finite
    /// number.
    pub fn get_nominals(&mut self, call: Checked, n: &mut [f64]) -> Status {
        let func = call.name;
        let me = match self.me_table(call) {
            Ok(me) => me,
            Err(s) => return s,
        };
        if let Err(s) = self.check_len(func, "nx", n.len(), me.states) {
            return s;
        }
        (me.nominals)(&self.model, n);
        for v in n.iter_mut() {
            if !(v.is_finite() && *v > 0.0) {
                *v = 1.0;
            }
        }
        Status::Ok
    }
}

impl<M: Model> Instance<M> {
    /// The value of event indicator `k` at the instance's current time, states and inputs;
    /// `None` when the model has no such indicator.
    pub fn event_indicator(&self, k: usize) -> Option<f64> {
        let me = self.me?;
        if k >= me.event_indicators {
            return None;
        }
        let mut z = vec![0.0; me.event_indicators];
        (me.indicators)(&self.model, &self.vars, self.time, &mut z);
        Some(z[k])
    }

    /// Real values set in Continuous-Time Mode by value reference, where a continuous-time
    /// state may be set as the states are (FMI 3.0.2 section 3.2.1): continuous inputs as
    /// [`Instance::set_values`] sets them, and states as [`Instance::set_continuous_states`]
    /// would. The states' values are checked (finite) before anything changes; the inputs are
    /// set first (their checks refuse the call as a whole), then the states.
    pub fn set_reals_and_states(&mut self, call: Checked, vrs: &[u32], vals: &[f64]) -> Status {
        let func = call.name;
        let Some(me) = self
            .me
            .filter(|_| self.interface == Interface::ModelExchange)
        else {
            return self.write_values(func, crate::VarType::Real, vrs, vals);
        };
        let table = M::variables();
        let state_of = |vr: u32| {
            me.state_variables
                .iter()
                .position(|&(x, _)| table[x].value_reference == vr)
        };
        let mut updates = Vec::new();
        let (mut input_vrs, mut input_vals) = (Vec::new(), Vec::new());
        for (&vr, &v) in vrs.iter().zip(vals) {
            match state_of(vr) {
                Some(k) if !v.is_finite() => {
                    let name = table[me.state_variables[k].0].name;
                    return self.error(func, format!("state '{name}' = {v} is not finite"));
                }
                Some(k) => updates.push((k, v)),
                None => {
                    input_vrs.push(vr);
                    input_vals.push(v);
                }
            }
        }
        if updates.is_empty() || !input_vrs.is_empty() {
            let s = self.write_values(func, crate::VarType::Real, &input_vrs, &input_vals);
            if s != Status::Ok || updates.is_empty() {
                return s;
            }
        }
        let mut x = vec![0.0; me.states];
        if let Err(s) = self.refresh_values(func) {
            return s;
        }
        (me.get_states)(&self.model, &mut x);
        for (k, v) in updates {
            x[k] = v;
        }
        self.write_states(func, &me, &x)
    }
}
