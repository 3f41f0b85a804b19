//! An FMU instance as safe Rust, for both FMI versions: the state machine of Co-Simulation and
//! Model Exchange ([`crate::machine`]), the experiment, initialization, stepping and FMU states
//! (variable access is in [`crate::values`], the Model Exchange functions in
//! [`crate::me_instance`]). The C layers only convert pointers and name each call ([`Call`]).
//!
//! Every operation returns a [`Status`] and queues its messages in [`Instance::log`], each
//! prefixed with the name of the C function called; the C layer passes them to the
//! environment's logger. A rejected call (wrong state, bad argument) changes nothing; a failed
//! step leaves the outputs of the last good communication point and moves the instance to
//! [`MachineState::Error`], from which a reset or an FMU-state restore recovers.

use crate::machine::{Call, Checked, Interface, MachineState, StateNames};
use crate::snapshot::Snapshot;
use crate::{Causality, MeVTable, Model, ModelError, VarType};

pub use fmi_types::Status;

/// The log categories declared in `LogCategories` of both versions' descriptions, in this
/// order (the descriptions carry these words as they are).
pub const LOG_CATEGORIES: [(&str, &str); 4] = [
    (
        "logStatusError",
        "Errors: why a call returned fmi2Error (always logged)",
    ),
    ("logStatusWarning", "Warnings"),
    ("logEvents", "Initialization, steps, resets, FMU states"),
    ("logAll", "Everything, including every call"),
];

/// A message waiting to be passed to the logger.
#[derive(Clone, Debug, PartialEq)]
pub struct LogEntry {
    pub status: Status,
    pub category: &'static str,
    pub message: String,
}

/// The importer's tolerance into the model's tolerance parameters
/// ([`Model::EXPERIMENT_TOLERANCE`]) that are still at their start values, clamped into their
/// ranges; `fmi2GetReal` then shows the tolerance in use.
fn experiment_tolerance<M: Model>(vars: &mut [f64], tolerance: f64) {
    for &i in M::EXPERIMENT_TOLERANCE {
        let v = &M::variables()[i];
        if vars[i] == v.start {
            let lo = v.min.unwrap_or(f64::MIN_POSITIVE);
            let hi = v.max.unwrap_or(f64::MAX);
            vars[i] = tolerance.clamp(lo, hi);
        }
    }
}

/// The experiment an importer sets up: start time, stop time and relative tolerance when
/// defined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Experiment {
    pub start: f64,
    pub stop: Option<f64>,
    pub tolerance: Option<f64>,
}

/// One FMU instance.
pub struct Instance<M: Model> {
    pub name: String,
    pub state: MachineState,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    /// The importer's relative tolerance, when it defined a usable one.
    pub tolerance: Option<f64>,
    /// Values of all variables, in table order (Booleans 0.0/1.0).
    pub vars: Vec<f64>,
    pub model: M,
    /// Model Exchange or Co-Simulation, fixed at instantiation.
    pub interface: Interface,
    /// The model's Model Exchange functions, when it has them.
    pub(crate) me: Option<MeVTable<M>>,
    /// Model Exchange: time, states or inputs changed since the outputs were last computed.
    pub(crate) me_outputs_stale: bool,
    /// Scratch for the states and derivatives written after each Co-Simulation step, and for
    /// the derivatives an importer asks for before they are checked.
    pub(crate) me_scratch: Vec<f64>,
    /// Model Exchange: the state Jacobian of the current point, cleared at every change.
    pub(crate) jacobian: crate::directional::JacobianCache,
    /// Outputs of the last good communication point, restored when a step fails.
    pub(crate) last_good: Vec<f64>,
    /// In initialization mode: outputs must be recomputed before they are read.
    pub(crate) init_outputs_stale: bool,
    /// Enabled flags of [`LOG_CATEGORIES`].
    log_enabled: [bool; 4],
    pub log: Vec<LogEntry>,
    pub(crate) guid: String,
    /// How the layer that created the instance names its states.
    names: StateNames,
}

fn start_values<M: Model>() -> Vec<f64> {
    M::variables()
        .iter()
        .map(|v| if v.has_start() { v.start } else { 0.0 })
        .collect()
}

impl<M: Model> Instance<M> {
    /// A Co-Simulation instance, after the layer checked the C arguments of its instantiation;
    /// its messages name the states as `names` does.
    pub fn new(name: &str, guid: String, logging_on: bool, names: StateNames) -> Self {
        let vars = start_values::<M>();
        Instance {
            interface: Interface::CoSimulation,
            me: M::model_exchange(),
            me_outputs_stale: false,
            me_scratch: vec![0.0; 2 * M::model_exchange().map_or(0, |me| me.states)],
            jacobian: Default::default(),
            name: name.to_string(),
            state: MachineState::Instantiated,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
            last_good: vars.clone(),
            vars,
            model: M::new(),
            init_outputs_stale: true,
            log_enabled: [true, true, logging_on, logging_on],
            log: Vec::new(),
            guid,
            names,
        }
    }

    /// An instance of `interface`; `None` for Model Exchange when the model does not provide it.
    pub fn with_interface(
        name: &str,
        guid: String,
        logging_on: bool,
        interface: Interface,
        names: StateNames,
    ) -> Option<Self> {
        let mut instance = Self::new(name, guid, logging_on, names);
        if interface == Interface::ModelExchange && instance.me.is_none() {
            return None;
        }
        instance.interface = interface;
        Some(instance)
    }

    /// Whether the instance is initialized and running (Step mode, Event or Continuous-Time Mode).
    pub fn running(&self) -> bool {
        matches!(
            self.state,
            MachineState::StepMode | MachineState::EventMode | MachineState::ContinuousTimeMode
        )
    }

    /// Queue a message; filtered by the enabled categories when the logger is called.
    pub fn push_log(&mut self, status: Status, category: &'static str, message: String) {
        self.log.push(LogEntry {
            status,
            category,
            message,
        });
    }

    /// Whether a message of `category` reaches the logger. Errors always do.
    pub fn category_enabled(&self, category: &str) -> bool {
        match LOG_CATEGORIES.iter().position(|(c, _)| *c == category) {
            Some(0) => true,
            Some(i) => self.log_enabled[i],
            None => false,
        }
    }

    /// Log an error and return [`Status::Error`].
    pub fn error(&mut self, func: &str, message: impl std::fmt::Display) -> Status {
        self.push_log(
            Status::Error,
            "logStatusError",
            format!("{func}: {message}"),
        );
        Status::Error
    }

    pub(crate) fn event(&mut self, message: String) {
        if self.log_enabled[2] {
            self.push_log(Status::Ok, "logEvents", message);
        }
    }

    /// The name of `state` in the messages of the layer that created the instance.
    pub fn state_name(&self, state: MachineState) -> &'static str {
        (self.names.name)(state)
    }

    /// Check `call` against the instance, once per call: a function of the other interface is
    /// refused in every state, then the current state must be one the call allows. Logs why
    /// otherwise.
    pub fn check_state(&mut self, call: Call) -> Result<Checked, Status> {
        let why = match call.only {
            Some(Interface::CoSimulation) if self.interface == Interface::ModelExchange => {
                "a Co-Simulation function called on a Model Exchange instance"
            }
            Some(Interface::ModelExchange) if self.interface == Interface::CoSimulation => {
                "a Model Exchange function called on a Co-Simulation instance"
            }
            _ => "",
        };
        if !why.is_empty() {
            return Err(self.error(call.name, why));
        }
        if self.state as u32 & call.allowed != 0 {
            Ok(Checked::of(call))
        } else {
            let (article, state) = (self.names.article, self.state_name(self.state));
            Err(self.error(
                call.name,
                format!("illegal call sequence: not allowed in {article}{state}"),
            ))
        }
    }

    /// Check `call` ([`Instance::check_state`]), then run `op` with the proof: the usual shape of
    /// a call that needs no argument checked before its state.
    pub fn call(&mut self, call: Call, op: impl FnOnce(&mut Self, Checked) -> Status) -> Status {
        match self.check_state(call) {
            Ok(checked) => op(self, checked),
            Err(s) => s,
        }
    }

    /// Set which log categories reach the logger (all when `categories` is empty).
    pub fn set_debug_logging(&mut self, call: Checked, on: bool, categories: &[&str]) -> Status {
        let func = call.name;
        let mut indices = Vec::with_capacity(categories.len());
        for c in categories {
            match LOG_CATEGORIES.iter().position(|(name, _)| name == c) {
                Some(i) => indices.push(i),
                None => return self.error(func, format!("unknown log category '{c}'")),
            }
        }
        if indices.is_empty() {
            self.log_enabled = [true, on, on, on];
        } else {
            for i in indices {
                self.log_enabled[i] = on;
            }
            self.log_enabled[0] = true;
        }
        Status::Ok
    }

    /// The experiment of [`Instance::setup_experiment`], then Initialization Mode: one call
    /// that does both. The worse of the two statuses is returned.
    pub fn enter_initialization_mode_with(
        &mut self,
        call: Checked,
        experiment: Experiment,
    ) -> Status {
        let setup = self.setup_experiment(call, experiment);
        if setup != Status::Error {
            self.enter_initialization();
        }
        setup
    }

    /// Set up the experiment: start and stop time, the importer's relative tolerance (which
    /// goes to the model's tolerance parameters at initialization).
    pub fn setup_experiment(
        &mut self,
        call: Checked,
        Experiment {
            start,
            stop,
            tolerance,
        }: Experiment,
    ) -> Status {
        let func = call.name;
        if !start.is_finite() {
            return self.error(func, format!("startTime {start} is not finite"));
        }
        if let Some(stop) = stop {
            if !stop.is_finite() || stop < start {
                return self.error(
                    func,
                    format!("stopTime {stop} is not finite or before startTime {start}"),
                );
            }
        }
        self.start_time = start;
        self.time = start;
        self.stop_time = stop;
        self.event(format!(
            "experiment set up: start {start}, stop {stop:?}, tolerance {tolerance:?}"
        ));
        self.tolerance = None;
        match tolerance {
            Some(t) if !(t > 0.0 && t.is_finite()) => {
                self.push_log(
                    Status::Warning,
                    "logStatusWarning",
                    format!("{func}: tolerance {t} is not a positive number; ignored"),
                );
                Status::Warning
            }
            t => {
                self.tolerance = t;
                Status::Ok
            }
        }
    }

    /// Enter Initialization Mode.
    pub fn enter_initialization_mode(&mut self, _call: Checked) -> Status {
        self.enter_initialization();
        Status::Ok
    }

    fn enter_initialization(&mut self) {
        self.state = MachineState::InitializationMode;
        self.init_outputs_stale = true;
    }

    /// Check every Real parameter against its bounds, every value for finiteness.
    fn check_parameters(&mut self, func: &str) -> Result<(), Status> {
        for (i, v) in M::variables().iter().enumerate() {
            let x = self.vars[i];
            if !x.is_finite() {
                return Err(self.error(func, format!("'{}' = {x} is not finite", v.name)));
            }
            if v.causality == Causality::Parameter && v.vtype != VarType::Boolean {
                let below = v.min.is_some_and(|m| x < m);
                let above = v.max.is_some_and(|m| x > m);
                if below || above {
                    return Err(self.error(
                        func,
                        format!(
                            "parameter '{}' = {x} is outside its range [{}, {}]",
                            v.name,
                            v.min.unwrap_or(f64::NEG_INFINITY),
                            v.max.unwrap_or(f64::INFINITY)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The model initialized from `vars` (the importer's values), with the variables it
    /// writes: every output and, for a model with Model Exchange, each state and state
    /// derivative at the start time (the initial unknowns of FMI 2.0.4 section 2.2.8). Changes
    /// nothing.
    pub(crate) fn initialized(&self, mut vars: Vec<f64>) -> Result<(M, Vec<f64>), ModelError> {
        if let Some(t) = self.tolerance {
            experiment_tolerance::<M>(&mut vars, t);
        }
        let mut model = M::new();
        model.initialize(&mut vars, self.start_time)?;
        if let Some(me) = self.me {
            let mut x = vec![0.0; me.states];
            let mut dx = vec![0.0; me.states];
            (me.get_states)(&model, &mut x);
            let ok = (me.derivatives)(&model, &vars, self.start_time, &mut dx).is_ok();
            for (k, &(s, d)) in me.state_variables.iter().enumerate() {
                vars[s] = x[k];
                if ok {
                    vars[d] = dx[k];
                }
            }
        }
        Ok((model, vars))
    }

    /// Run the model's initialization; on failure nothing but the log changes.
    pub(crate) fn initialize_model(&mut self, func: &str) -> Result<(), Status> {
        self.check_parameters(func)?;
        match self.initialized(self.vars.clone()) {
            Ok((model, vars)) => {
                self.vars = vars;
                self.model = model;
                self.jacobian.clear();
                self.init_outputs_stale = false;
                Ok(())
            }
            Err(msg) => Err(self.error(func, msg)),
        }
    }

    /// Exit Initialization Mode: parameters out of range or ill-posed are refused here with a
    /// message naming them; the instance stays in initialization mode so they can be corrected.
    pub fn exit_initialization_mode(&mut self, call: Checked) -> Status {
        if let Err(s) = self.initialize_model(call.name) {
            return s;
        }
        self.time = self.start_time;
        self.last_good.copy_from_slice(&self.vars);
        // Model Exchange continues in Event Mode (FMI 2.0.4 section 3.2.3, FMI 3.0.2 section
        // 3.2), where the importer asks for the discrete state at the start time.
        self.state = match self.interface {
            Interface::CoSimulation => {
                self.write_derivatives();
                self.last_good.copy_from_slice(&self.vars);
                MachineState::StepMode
            }
            Interface::ModelExchange => {
                self.me_outputs_stale = true;
                MachineState::EventMode
            }
        };
        self.event(format!("initialized at t = {}", self.time));
        Status::Ok
    }

    /// Terminate.
    pub fn terminate(&mut self, _call: Checked) -> Status {
        self.state = MachineState::Terminated;
        Status::Ok
    }

    /// Reset: back to the state right after instantiation, start values restored.
    pub fn reset(&mut self, _call: Checked) -> Status {
        self.vars = start_values::<M>();
        self.last_good.copy_from_slice(&self.vars);
        self.model = M::new();
        self.jacobian.clear();
        self.time = 0.0;
        self.start_time = 0.0;
        self.stop_time = None;
        self.tolerance = None;
        self.init_outputs_stale = true;
        self.me_outputs_stale = false;
        self.state = MachineState::Instantiated;
        self.event("reset".to_string());
        Status::Ok
    }

    /// A Co-Simulation step from `current` (the instance's time) to `current + h`.
    pub fn do_step(&mut self, call: Checked, current: f64, h: f64) -> Status {
        let func = call.name;
        if !(h.is_finite() && h > 0.0) {
            return self.error(
                func,
                format!("communicationStepSize {h:?} must be finite and > 0"),
            );
        }
        let tolerance = 1e-9 * self.time.abs().max(1.0);
        if !current.is_finite() || (current - self.time).abs() > tolerance {
            return self.error(
                func,
                format!(
                    "currentCommunicationPoint {current:?} is not the current time {:?}",
                    self.time
                ),
            );
        }
        // The end of the step must be a finite time after the current one: a step lost in the
        // rounding of a large time (t + h == t) would report OK without advancing, and a
        // model's sample clock could never reach it.
        let end = current + h;
        if !(end.is_finite() && end > current) {
            return self.error(
                func,
                format!(
                    "communicationStepSize {h:?} does not advance time at t = {current:?} \
                     (t + h = {end:?})"
                ),
            );
        }
        if let Some(stop) = self.stop_time {
            if end > stop + 1e-9 * stop.abs().max(1.0) {
                return self.error(
                    func,
                    format!("step to {end:?} goes beyond the stopTime {stop:?}"),
                );
            }
        }
        self.jacobian.clear();
        match self.model.do_step(&mut self.vars, current, h) {
            Ok(()) => {
                if let Some((i, v)) = M::variables()
                    .iter()
                    .enumerate()
                    .find(|(i, _)| !self.vars[*i].is_finite())
                {
                    let value = self.vars[i];
                    self.vars.copy_from_slice(&self.last_good);
                    self.state = MachineState::Error;
                    return self.error(
                        func,
                        format!("'{}' became {value} at t = {current:?} + {h:?}", v.name),
                    );
                }
                self.time = current + h;
                self.write_derivatives();
                self.last_good.copy_from_slice(&self.vars);
                if self.log_enabled[3] {
                    self.push_log(Status::Ok, "logAll", format!("step to t = {}", self.time));
                }
                Status::Ok
            }
            Err(msg) => {
                self.vars.copy_from_slice(&self.last_good);
                self.state = MachineState::Error;
                self.error(
                    func,
                    format!("step from t = {current:?} with h = {h:?} failed: {msg}"),
                )
            }
        }
    }

    /// The FMU state (a copy of everything needed to continue bit-identically).
    pub fn snapshot(&self) -> Snapshot<M> {
        Snapshot {
            state: self.state,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            tolerance: self.tolerance,
            vars: self.vars.clone(),
            model: self.model.clone(),
        }
    }

    /// Restore an FMU state: refuses (nothing changed) a state saved by an instance of the
    /// other interface type in a state this one cannot be in.
    pub fn restore(&mut self, call: Checked, s: &Snapshot<M>) -> Status {
        if !s.state.belongs_to(self.interface) {
            let (state, interface) = (self.state_name(s.state), self.interface);
            return self.error(
                call.name,
                format!("the FMU state was saved in {state}, which a {interface:?} instance cannot be in"),
            );
        }
        self.state = s.state;
        self.time = s.time;
        self.start_time = s.start_time;
        self.stop_time = s.stop_time;
        self.tolerance = s.tolerance;
        self.vars.copy_from_slice(&s.vars);
        self.last_good.copy_from_slice(&s.vars);
        self.model = s.model.clone();
        self.jacobian.clear();
        self.init_outputs_stale = true;
        self.me_outputs_stale = self.interface == Interface::ModelExchange;
        self.event(format!("FMU state restored at t = {}", s.time));
        Status::Ok
    }
}
