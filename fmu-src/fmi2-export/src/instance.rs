//! The FMI 2.0 instance as safe Rust: the state machines of Co-Simulation and Model Exchange,
//! variable access with all argument checks, stepping and FMU states (the Model Exchange
//! functions are in [`crate::me_instance`]). The C glue in [`crate::ffi`] only converts pointers.
//!
//! Every operation returns a [`Status`] and queues its messages in [`Instance::log`]; the C glue
//! passes them to the environment's logger. A rejected call (wrong state, bad argument) changes
//! nothing; a failed step leaves the outputs of the last good communication point and moves the
//! instance to [`MachineState::Error`], from which `fmi2Reset` or `fmi2SetFMUstate` recover.

use crate::{Causality, MeVTable, Model, ModelError, VarType, Variability};
use bincode::Options as _;
use serde::{Deserialize, Serialize};

pub use fmi2_types::Status;

/// States of the FMI 2.0 state machines, Co-Simulation (standard section 4.2.4) and Model
/// Exchange (section 3.2.3: `EventMode`, `ContinuousTimeMode`); each is one bit so a function's
/// allowed states are a mask. An instance only ever enters the states of its interface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u32)]
pub enum MachineState {
    Instantiated = 1,
    InitializationMode = 2,
    StepComplete = 4,
    StepFailed = 8,
    StepCanceled = 16,
    Terminated = 32,
    Error = 64,
    EventMode = 128,
    ContinuousTimeMode = 256,
}

impl MachineState {
    /// Whether an instance of `interface` can be in this state.
    pub fn belongs_to(self, interface: Interface) -> bool {
        use MachineState::*;
        match self {
            StepComplete | StepFailed | StepCanceled => interface == Interface::CoSimulation,
            EventMode | ContinuousTimeMode => interface == Interface::ModelExchange,
            Instantiated | InitializationMode | Terminated | Error => true,
        }
    }
}

/// The interface type an instance was created for (`fmuType` of `fmi2Instantiate`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    ModelExchange,
    CoSimulation,
}

/// Allowed-state masks, one per group of functions (standard tables of sections 3.2.3 and
/// 4.2.4); a mask shared by both interfaces lists the states of each.
pub mod allowed {
    use super::MachineState::*;
    const fn m(states: &[super::MachineState]) -> u32 {
        let mut mask = 0;
        let mut i = 0;
        while i < states.len() {
            mask |= states[i] as u32;
            i += 1;
        }
        mask
    }
    /// fmi2SetDebugLogging, fmi2Reset, fmi2FreeInstance, FMU-state functions.
    pub const ANY: u32 = m(&[
        Instantiated,
        InitializationMode,
        StepComplete,
        StepFailed,
        StepCanceled,
        Terminated,
        Error,
        EventMode,
        ContinuousTimeMode,
    ]);
    pub const SETUP: u32 = m(&[Instantiated]);
    pub const ENTER_INIT: u32 = m(&[Instantiated]);
    pub const EXIT_INIT: u32 = m(&[InitializationMode]);
    pub const TERMINATE: u32 = m(&[StepComplete, StepFailed, EventMode, ContinuousTimeMode]);
    pub const GET: u32 = m(&[
        InitializationMode,
        StepComplete,
        StepFailed,
        StepCanceled,
        Terminated,
        Error,
        EventMode,
        ContinuousTimeMode,
    ]);
    /// fmi2SetReal; Integer and Boolean variables are not set in Continuous-Time Mode (checked
    /// per variable: only continuous inputs are).
    pub const SET: u32 = m(&[
        Instantiated,
        InitializationMode,
        StepComplete,
        EventMode,
        ContinuousTimeMode,
    ]);
    pub const DO_STEP: u32 = m(&[StepComplete]);
    pub const STATUS: u32 = m(&[StepComplete, StepFailed, StepCanceled, Terminated]);
    // Model Exchange only (FMI 2.0.4 section 3.2.3).
    pub const ENTER_EVENT_MODE: u32 = m(&[EventMode, ContinuousTimeMode]);
    pub const NEW_DISCRETE_STATES: u32 = m(&[EventMode]);
    pub const ENTER_CONTINUOUS_TIME_MODE: u32 = m(&[EventMode]);
    pub const COMPLETED_INTEGRATOR_STEP: u32 = m(&[ContinuousTimeMode]);
    pub const SET_TIME: u32 = m(&[EventMode, ContinuousTimeMode]);
    pub const SET_CONTINUOUS_STATES: u32 = m(&[ContinuousTimeMode]);
    pub const GET_EVENT_INDICATORS: u32 = m(&[
        InitializationMode,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ]);
    pub const GET_CONTINUOUS_STATES: u32 = GET_EVENT_INDICATORS;
    pub const GET_DERIVATIVES: u32 = m(&[EventMode, ContinuousTimeMode, Terminated, Error]);
    /// fmi2GetDirectionalDerivative: the initial unknowns in Initialization Mode, Model Exchange
    /// at the states, Co-Simulation at the communication point (FMI 2.0.4 sections 3.2.3 and
    /// 4.2.4: also after a failed or canceled step, for debugging).
    pub const DIRECTIONAL_DERIVATIVE: u32 = m(&[
        InitializationMode,
        StepComplete,
        StepFailed,
        StepCanceled,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ]);
    pub const GET_NOMINALS: u32 = m(&[
        Instantiated,
        EventMode,
        ContinuousTimeMode,
        Terminated,
        Error,
    ]);
}

/// The log categories declared in `LogCategories`, in this order.
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

/// Everything needed to continue a simulation bit-identically: `fmi2GetFMUstate` copies it,
/// `fmi2SerializeFMUstate` writes it with bincode behind a header naming the model and GUID.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Snapshot<M: Model> {
    state: MachineState,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    tolerance: Option<f64>,
    vars: Vec<f64>,
    model: M,
}

/// Format of serialized FMU states: a new layout gets a new number.
const SERIAL_MAGIC: &[u8; 8] = b"AFMUST03";

/// Fixed-width little-endian encoding: f64 values are written bit for bit.
fn bincode_options() -> impl bincode::Options {
    use bincode::Options;
    bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_little_endian()
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

/// One FMU instance.
pub struct Instance<M: Model> {
    pub name: String,
    pub state: MachineState,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    /// The relative tolerance of `fmi2SetupExperiment`, when the importer defined a usable one.
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
    /// the derivatives of `fmi2GetDerivatives` before they are checked.
    pub(crate) me_scratch: Vec<f64>,
    /// Model Exchange: the state Jacobian of the current point, cleared at every change.
    pub(crate) jacobian: crate::me_instance::JacobianCache,
    /// Outputs of the last good communication point, restored when a step fails.
    last_good: Vec<f64>,
    /// In initialization mode: outputs must be recomputed before they are read.
    init_outputs_stale: bool,
    /// Enabled flags of [`LOG_CATEGORIES`].
    log_enabled: [bool; 4],
    pub log: Vec<LogEntry>,
    guid: String,
}

fn start_values<M: Model>() -> Vec<f64> {
    M::variables()
        .iter()
        .map(|v| if v.has_start() { v.start } else { 0.0 })
        .collect()
}

impl<M: Model> Instance<M> {
    /// `fmi2Instantiate` (Co-Simulation) after the C arguments are checked.
    pub fn new(name: &str, guid: String, logging_on: bool) -> Self {
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
        }
    }

    /// `fmi2Instantiate` with `fmuType` `interface`; `None` for Model Exchange when the model
    /// does not provide it.
    pub fn with_interface(
        name: &str,
        guid: String,
        logging_on: bool,
        interface: Interface,
    ) -> Option<Self> {
        let mut instance = Self::new(name, guid, logging_on);
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
            MachineState::StepComplete | MachineState::EventMode | MachineState::ContinuousTimeMode
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

    /// Check the current state against `mask`; log an illegal call sequence otherwise.
    pub fn check_state(&mut self, func: &str, mask: u32) -> Result<(), Status> {
        if self.state as u32 & mask != 0 {
            Ok(())
        } else {
            let state = self.state;
            Err(self.error(
                func,
                format!("illegal call sequence: not allowed in state {state:?}"),
            ))
        }
    }

    /// [`Instance::check_state`] for a function of Co-Simulation only: a Model Exchange
    /// instance refuses it in every state.
    pub fn check_cs_state(&mut self, func: &str, mask: u32) -> Result<(), Status> {
        if self.interface == Interface::ModelExchange {
            return Err(self.error(
                func,
                "a Co-Simulation function called on a Model Exchange instance",
            ));
        }
        self.check_state(func, mask)
    }

    /// `fmi2SetDebugLogging`.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Status {
        const F: &str = "fmi2SetDebugLogging";
        if let Err(s) = self.check_state(F, allowed::ANY) {
            return s;
        }
        let mut indices = Vec::with_capacity(categories.len());
        for c in categories {
            match LOG_CATEGORIES.iter().position(|(name, _)| name == c) {
                Some(i) => indices.push(i),
                None => return self.error(F, format!("unknown log category '{c}'")),
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

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        start: f64,
        stop: Option<f64>,
        tolerance: Option<f64>,
    ) -> Status {
        const F: &str = "fmi2SetupExperiment";
        if let Err(s) = self.check_state(F, allowed::SETUP) {
            return s;
        }
        if !start.is_finite() {
            return self.error(F, format!("startTime {start} is not finite"));
        }
        if let Some(stop) = stop {
            if !stop.is_finite() || stop < start {
                return self.error(
                    F,
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
                    format!("{F}: tolerance {t} is not a positive number; ignored"),
                );
                Status::Warning
            }
            t => {
                self.tolerance = t;
                Status::Ok
            }
        }
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Status {
        if let Err(s) = self.check_state("fmi2EnterInitializationMode", allowed::ENTER_INIT) {
            return s;
        }
        self.state = MachineState::InitializationMode;
        self.init_outputs_stale = true;
        Status::Ok
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
    fn initialize_model(&mut self, func: &str) -> Result<(), Status> {
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

    /// `fmi2ExitInitializationMode`: parameters out of range or ill-posed are refused here with a
    /// message naming them; the instance stays in initialization mode so they can be corrected.
    pub fn exit_initialization_mode(&mut self) -> Status {
        const F: &str = "fmi2ExitInitializationMode";
        if let Err(s) = self.check_state(F, allowed::EXIT_INIT) {
            return s;
        }
        if let Err(s) = self.initialize_model(F) {
            return s;
        }
        self.time = self.start_time;
        self.last_good.copy_from_slice(&self.vars);
        // Model Exchange continues in Event Mode (FMI 2.0.4 section 3.2.3), where the importer
        // asks fmi2NewDiscreteStates for the discrete state at the start time.
        self.state = match self.interface {
            Interface::CoSimulation => {
                self.write_derivatives();
                self.last_good.copy_from_slice(&self.vars);
                MachineState::StepComplete
            }
            Interface::ModelExchange => {
                self.me_outputs_stale = true;
                MachineState::EventMode
            }
        };
        self.event(format!("initialized at t = {}", self.time));
        Status::Ok
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Status {
        if let Err(s) = self.check_state("fmi2Terminate", allowed::TERMINATE) {
            return s;
        }
        self.state = MachineState::Terminated;
        Status::Ok
    }

    /// `fmi2Reset`: back to the state right after instantiation, start values restored.
    pub fn reset(&mut self) -> Status {
        if let Err(s) = self.check_state("fmi2Reset", allowed::ANY) {
            return s;
        }
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

    /// Shared part of the getters: state, references, fresh outputs in initialization mode.
    pub(crate) fn prepare_get(
        &mut self,
        func: &str,
        vrs: &[u32],
        ty: VarType,
    ) -> Result<Vec<usize>, Status> {
        self.check_state(func, allowed::GET)?;
        let indices = self.check_refs(func, vrs, ty)?;
        if self.state == MachineState::InitializationMode && self.init_outputs_stale {
            self.initialize_model(func)?;
        }
        self.refresh_me_outputs();
        Ok(indices)
    }

    /// `fmi2GetReal` (also `fmi2GetInteger`/`fmi2GetBoolean` through `ty`): fills `out`.
    pub fn get_values(&mut self, func: &str, ty: VarType, vrs: &[u32], out: &mut [f64]) -> Status {
        let indices = match self.prepare_get(func, vrs, ty) {
            Ok(indices) => indices,
            Err(s) => return s,
        };
        for (o, &i) in out.iter_mut().zip(&indices) {
            *o = self.vars[i];
        }
        Status::Ok
    }

    /// `fmi2SetReal` (also Integer/Boolean through `ty`). All-or-nothing: every reference and value
    /// is checked before any is written.
    pub fn set_values(&mut self, func: &str, ty: VarType, vrs: &[u32], values: &[f64]) -> Status {
        if let Err(s) = self.check_state(func, allowed::SET) {
            return s;
        }
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
            // Continuous-Time Mode: continuous inputs only (FMI 2.0.4 section 3.2.3).
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

    /// `fmi2DoStep`.
    pub fn do_step(&mut self, current: f64, h: f64) -> Status {
        const F: &str = "fmi2DoStep";
        if let Err(s) = self.check_cs_state(F, allowed::DO_STEP) {
            return s;
        }
        if !(h.is_finite() && h > 0.0) {
            return self.error(
                F,
                format!("communicationStepSize {h:?} must be finite and > 0"),
            );
        }
        let tolerance = 1e-9 * self.time.abs().max(1.0);
        if !current.is_finite() || (current - self.time).abs() > tolerance {
            return self.error(
                F,
                format!(
                    "currentCommunicationPoint {current:?} is not the current time {:?}",
                    self.time
                ),
            );
        }
        // The end of the step must be a finite time after the current one: a step lost in the
        // rounding of a large time (t + h == t) would report fmi2OK without advancing, and a
        // model's sample clock could never reach it.
        let end = current + h;
        if !(end.is_finite() && end > current) {
            return self.error(
                F,
                format!(
                    "communicationStepSize {h:?} does not advance time at t = {current:?} \
                     (t + h = {end:?})"
                ),
            );
        }
        if let Some(stop) = self.stop_time {
            if end > stop + 1e-9 * stop.abs().max(1.0) {
                return self.error(
                    F,
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
                        F,
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
                    F,
                    format!("step from t = {current:?} with h = {h:?} failed: {msg}"),
                )
            }
        }
    }

    /// `fmi2GetFMUstate`.
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

    /// `fmi2SetFMUstate`: refuses (nothing changed) a state saved by an instance of the other
    /// interface type in a state this one cannot be in.
    pub fn restore(&mut self, s: &Snapshot<M>) -> Status {
        if !s.state.belongs_to(self.interface) {
            let (state, interface) = (s.state, self.interface);
            return self.error(
                "fmi2SetFMUstate",
                format!("the FMU state was saved in {state:?}, which a {interface:?} instance cannot be in"),
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

    /// Bytes of `fmi2SerializeFMUstate`: the format magic, the GUID (length-prefixed), the
    /// payload length, the bincode snapshot, and a checksum of everything before it.
    pub fn serialize(&self, s: &Snapshot<M>) -> Result<Vec<u8>, StateError> {
        let mut out = Vec::with_capacity(256);
        out.extend_from_slice(SERIAL_MAGIC);
        let guid = self.guid.as_bytes();
        out.extend_from_slice(&(guid.len() as u32).to_le_bytes());
        out.extend_from_slice(guid);
        let payload = bincode_options()
            .serialize(s)
            .map_err(|e| StateError::Encode(e.to_string()))?;
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&payload);
        let sum = checksum(&out);
        out.extend_from_slice(&sum);
        Ok(out)
    }

    /// Inverse of [`Instance::serialize`]: refuses bytes of another format or model, a length
    /// that does not match, and any change the checksum detects, before decoding anything.
    pub fn deserialize(&self, bytes: &[u8]) -> Result<Snapshot<M>, StateError> {
        if !bytes.starts_with(SERIAL_MAGIC) {
            return Err(StateError::BadHeader);
        }
        let (body, sum) = bytes
            .split_last_chunk::<CHECKSUM_LEN>()
            .filter(|(body, _)| body.len() >= SERIAL_MAGIC.len())
            .ok_or(StateError::Truncated(bytes.len()))?;
        let rest = &body[SERIAL_MAGIC.len()..];
        if checksum(body) != *sum {
            return Err(StateError::Checksum);
        }
        let (n, rest) = rest
            .split_first_chunk::<4>()
            .ok_or(StateError::Truncated(bytes.len()))?;
        let (guid, rest) = rest
            .split_at_checked(u32::from_le_bytes(*n) as usize)
            .ok_or(StateError::Truncated(bytes.len()))?;
        if guid != self.guid.as_bytes() {
            return Err(StateError::OtherModel);
        }
        let (len, payload) = rest
            .split_first_chunk::<8>()
            .ok_or(StateError::Truncated(bytes.len()))?;
        if u64::from_le_bytes(*len) != payload.len() as u64 {
            return Err(StateError::Truncated(bytes.len()));
        }
        let s: Snapshot<M> = bincode_options()
            .with_limit(payload.len() as u64)
            .deserialize(payload)
            .map_err(|e| StateError::Decode(e.to_string()))?;
        if s.vars.len() != M::variables().len() {
            return Err(StateError::Decode(format!(
                "{} variables, the model has {}",
                s.vars.len(),
                M::variables().len()
            )));
        }
        Ok(s)
    }
}

/// Length of the checksum closing a serialized FMU state.
const CHECKSUM_LEN: usize = 8;

/// The first 8 bytes of SHA-256 (already linked for the GUID): any change of a serialized state
/// (a flipped bit, a truncated or spliced buffer) is refused before decoding, rather than
/// decoded into a state that is valid bincode but not the one saved.
fn checksum(bytes: &[u8]) -> [u8; CHECKSUM_LEN] {
    use sha2::{Digest, Sha256};
    let d = Sha256::digest(bytes);
    let mut out = [0; CHECKSUM_LEN];
    out.copy_from_slice(&d[..CHECKSUM_LEN]);
    out
}

/// Why a serialized FMU state was refused (or could not be written).
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("not a serialized FMU state of this FMU (bad header)")]
    BadHeader,
    #[error("serialized FMU state is truncated or its length field is wrong ({0} bytes)")]
    Truncated(usize),
    #[error("serialized FMU state is damaged (checksum mismatch)")]
    Checksum,
    #[error("serialized FMU state belongs to another model (GUID differs)")]
    OtherModel,
    #[error("serialized FMU state cannot be decoded: {0}")]
    Decode(String),
    #[error("FMU state cannot be serialized: {0}")]
    Encode(String),
}
