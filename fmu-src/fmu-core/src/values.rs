//! Variable access of [`Instance`]: value references and types checked against the table,
//! values checked against causality, variability, state and range, tunable parameters handed
//! to the model. All-or-nothing: a refused call changes nothing.

use crate::instance::Instance;
use crate::machine::{Checked, Interface, MachineState};
use crate::{Causality, Model, Status, VarType, Variability};

impl<M: Model> Instance<M> {
    /// Check a list of value references against the table and the expected type; returns the
    /// position in the table (storage index) of each.
    fn check_refs(&mut self, func: &str, vrs: &[u32], ty: VarType) -> Result<Vec<usize>, Status> {
        let vars = M::variables();
        let mut indices = Vec::with_capacity(vrs.len());
        for &vr in vrs {
            let Some(i) = crate::variables::index_of(vars, vr) else {
                return Err(self.error(func, format!("unknown value reference {vr}")));
            };
            let v = &vars[i];
            if v.vtype != ty {
                return Err(self.error(
                    func,
                    format!(
                        "value reference {vr} ('{}') is {:?}, not {ty:?}",
                        v.name, v.vtype
                    ),
                ));
            }
            indices.push(i);
        }
        Ok(indices)
    }

    /// Fresh values before they are read: the model initialized from the current values in
    /// initialization mode, the outputs recomputed in Model Exchange.
    pub(crate) fn refresh_values(&mut self, func: &str) -> Result<(), Status> {
        if self.state == MachineState::InitializationMode && self.init_outputs_stale {
            self.initialize_model(func)?;
        }
        self.refresh_me_outputs();
        Ok(())
    }

    /// Shared part of the getters: state, references, fresh values.
    fn prepare_get(
        &mut self,
        call: Checked,
        vrs: &[u32],
        ty: VarType,
    ) -> Result<Vec<usize>, Status> {
        let indices = self.check_refs(call.name, vrs, ty)?;
        self.refresh_values(call.name)?;
        Ok(indices)
    }

    /// The values of `vrs`, all of type `ty` (Booleans 0.0/1.0), into `out`.
    pub fn get_values(
        &mut self,
        call: Checked,
        ty: VarType,
        vrs: &[u32],
        out: &mut [f64],
    ) -> Status {
        let indices = match self.prepare_get(call, vrs, ty) {
            Ok(indices) => indices,
            Err(s) => return s,
        };
        for (o, &i) in out.iter_mut().zip(&indices) {
            *o = self.vars[i];
        }
        Status::Ok
    }

    /// Set `vrs`, all of type `ty`. All-or-nothing: every reference and value is checked before
    /// any is written.
    pub fn set_values(
        &mut self,
        call: Checked,
        ty: VarType,
        vrs: &[u32],
        values: &[f64],
    ) -> Status {
        self.write_values(call.name, ty, vrs, values)
    }

    /// The body of [`Instance::set_values`] after the state check.
    pub(crate) fn write_values(
        &mut self,
        func: &str,
        ty: VarType,
        vrs: &[u32],
        values: &[f64],
    ) -> Status {
        let indices = match self.check_refs(func, vrs, ty) {
            Ok(indices) => indices,
            Err(s) => return s,
        };
        let table = M::variables();
        let initialized = self.running();
        let continuous_time = self.state == MachineState::ContinuousTimeMode;
        let mut status = Status::Ok;
        for ((&vr, &i), &x) in vrs.iter().zip(&indices).zip(values) {
            let v = &table[i];
            let settable = if initialized {
                v.settable_after_init()
            } else {
                v.settable_before_init()
            };
            // Continuous-Time Mode: continuous inputs only (FMI 2.0.4 section 3.2.3, FMI 3.0.2
            // section 3.2.1).
            let settable = settable
                && !(continuous_time
                    && (v.causality != Causality::Input
                        || v.variability != Variability::Continuous));
            if !settable {
                let why = match (v.causality, v.variability) {
                    (Causality::Parameter, Variability::Fixed) => {
                        "is a fixed parameter and cannot be set after initialization"
                    }
                    (Causality::Output, _) => "is an output and cannot be set",
                    (Causality::CalculatedParameter, _) => {
                        "is a calculated parameter and cannot be set"
                    }
                    _ => "cannot be set in this state",
                };
                return self.error(func, format!("'{}' (value reference {vr}) {why}", v.name));
            }
            if !x.is_finite() {
                return self.error(
                    func,
                    format!(
                        "'{}' (value reference {vr}): value {x} is not finite",
                        v.name
                    ),
                );
            }
            if v.causality == Causality::Input {
                let out_of_range = v.min.is_some_and(|m| x < m) || v.max.is_some_and(|m| x > m);
                if out_of_range {
                    self.push_log(
                        Status::Warning,
                        "logStatusWarning",
                        format!(
                            "{func}: input '{}' = {x} is outside its range [{}, {}]",
                            v.name,
                            v.min.unwrap_or(f64::NEG_INFINITY),
                            v.max.unwrap_or(f64::INFINITY)
                        ),
                    );
                    status = Status::Warning;
                }
            }
        }
        let value = |x: f64| {
            if ty == VarType::Boolean {
                (x != 0.0) as i32 as f64
            } else {
                x
            }
        };
        let tuned = initialized
            && indices
                .iter()
                .any(|&i| table[i].causality == Causality::Parameter);
        if tuned {
            if let Err(s) = self.tune(func, &indices, values, value) {
                return s;
            }
        }
        for (&i, &x) in indices.iter().zip(values) {
            self.vars[i] = value(x);
        }
        self.jacobian.clear();
        if initialized {
            self.me_outputs_stale = self.interface == Interface::ModelExchange;
        } else {
            self.init_outputs_stale = true;
        }
        status
    }

    /// Tunable parameters set in Step mode: each inside its range, then the model accepts the
    /// new values (from the next step) or refuses them with nothing changed.
    fn tune(
        &mut self,
        func: &str,
        indices: &[usize],
        values: &[f64],
        value: impl Fn(f64) -> f64,
    ) -> Result<(), Status> {
        let table = M::variables();
        let mut candidate = self.vars.clone();
        for (&i, &x) in indices.iter().zip(values) {
            let v = &table[i];
            if v.min.is_some_and(|m| x < m) || v.max.is_some_and(|m| x > m) {
                let (lo, hi) = (
                    v.min.unwrap_or(f64::NEG_INFINITY),
                    v.max.unwrap_or(f64::INFINITY),
                );
                let m = format!("'{}' = {x} is outside its range [{lo}, {hi}]", v.name);
                return Err(self.error(func, m));
            }
            candidate[i] = value(x);
        }
        match self.model.tune(&candidate) {
            Ok(()) => {
                self.event(format!("tunable parameters changed at t = {}", self.time));
                Ok(())
            }
            Err(e) => Err(self.error(func, e)),
        }
    }
}
