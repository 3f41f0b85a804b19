//! The version-neutral exporter: what a model is and what an FMU instance does, for FMI 2.0 and
//! FMI 3.0 alike (the C layers `fmi2-export` and `fmi3-export` only convert pointers and name
//! each call).
//!
//! A model implements [`Model`] (pure Rust, no C pointers), and [`ModelExchange`] for Model
//! Exchange, and declares its variables once with [`declare_variables!`]. The [`Instance`] runs
//! the one state machine ([`machine`]) over it: experiment, initialization, variable access,
//! steps, FMU states ([`snapshot`]), Model Exchange ([`me_instance`]) and derivatives
//! ([`directional`]). From the same table [`model_description`] writes `modelDescription.xml`
//! and [`documentation`] the HTML page of either version. This crate knows no physics.

pub mod directional;
pub mod glue;
pub mod html;
mod initial_derivatives;
pub mod instance;
pub mod machine;
pub mod me;
pub mod me_instance;
pub mod snapshot;
pub mod units;
mod values;
pub mod variables;
pub mod xml;
pub mod xml3;

pub use directional::Knowns;
pub use instance::{Experiment, Instance, Status};
pub use machine::{Call, Checked, Interface, MachineState, StateNames};
pub use me::{MeVTable, ModelExchange};
pub use me_instance::EventInfo;
pub use snapshot::{Snapshot, StateError};
pub use variables::{Causality, Initial, Values, ValuesMut, VarId, VarType, Variability, Variable};

/// The FMI version of an archive: what its description, documentation and binary follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Version {
    Fmi2,
    Fmi3,
}

/// A Co-Simulation model. The layer owns the values of all variables (`vars`, in table order:
/// `V::X as usize`, Booleans as 0.0/1.0) and the FMI state machine; the model owns its physical state.
pub trait Model: Clone + Send + serde::Serialize + serde::de::DeserializeOwned + 'static {
    /// `modelName` and `modelIdentifier`.
    const NAME: &'static str;
    /// One-line description for the model description.
    const DESCRIPTION: &'static str;
    /// `DefaultExperiment` stop time [s].
    const DEFAULT_STOP_TIME: f64 = 10.0;
    /// `DefaultExperiment` step size [s].
    const DEFAULT_STEP_SIZE: f64 = 1e-3;
    /// `DefaultExperiment` tolerance.
    const DEFAULT_TOLERANCE: f64 = 1e-6;
    /// `version` of the model description: the workspace version.
    const VERSION: &'static str = env!("CARGO_PKG_VERSION");
    /// `author`.
    const AUTHOR: &'static str = "the actuator-fmu developers";
    /// `copyright`.
    const COPYRIGHT: &'static str = "Copyright (c) 2026 the actuator-fmu developers";
    /// `license`: the licence of the FMU; the licences of the crates compiled into its binaries
    /// are in `documentation/licenses/`.
    const LICENSE: &'static str = "MIT (see documentation/licenses/)";

    /// Positions in the table (`V::X as usize`) of the Real parameters that take the relative
    /// tolerance an importer passes (`fmi2SetupExperiment`, `fmi3EnterInitializationMode`;
    /// clamped into their range) when it defines one and the parameter is still at its start
    /// value: a solver's tolerances. A value set by the user wins; without a
    /// tolerance from the importer the parameters keep their values.
    const EXPERIMENT_TOLERANCE: &'static [usize] = &[];

    /// Every variable once, each with its declared value reference.
    fn variables() -> &'static [Variable];
    /// HTML fragment for `documentation/index.html`: equations, sources, derivations, choices.
    fn documentation_html() -> String;
    /// The state before initialization.
    fn new() -> Self;
    /// Validate parameters (min/max are already checked by the layer), build the consistent initial
    /// state and write every output into `vars`. Idempotent. `Err` names the offending parameter.
    fn initialize(&mut self, vars: &mut [f64], start_time: f64) -> Result<(), ModelError>;
    /// Advance from `t` to `t + h` with inputs as in `vars`; write every output into `vars`.
    fn do_step(&mut self, vars: &mut [f64], t: f64, h: f64) -> Result<(), ModelError>;
    /// Apply tunable parameters changed in Step mode: `vars` holds the new values (already
    /// inside their ranges); they act from the next step. `Err` (nothing changed) refuses them.
    /// A model that declares tunable variables implements it.
    fn tune(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let _ = vars;
        Err(ModelError::parameters(
            &[],
            "this model applies no parameter change after initialization",
        ))
    }

    /// The Model Exchange interface: `Some(MeVTable::of::<Self>())` for a model that implements
    /// [`ModelExchange`] (the FMU then offers `<ModelExchange>` beside `<CoSimulation>`), `None`
    /// (the default) for a Co-Simulation-only model.
    fn model_exchange() -> Option<MeVTable<Self>> {
        None
    }
}

/// Why a model cannot initialize or complete a step. The FMI layer logs it under the FMI
/// function's name and returns its error status; the message is built here, once, from the
/// fields.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// Parameter values the physics cannot use, each name a variable of the table.
    #[error("{}: {reason}", quote_names(names))]
    Parameters {
        names: Vec<&'static str>,
        reason: String,
    },
    /// A communication step the model cannot take as asked.
    #[error("communication step at t = {t} s with h = {h} s: {reason}")]
    Step { t: f64, h: f64, reason: String },
    /// The integrator failed inside `[t0, t1]`.
    #[error("integration from t = {t0} s to {t1} s failed: {source}")]
    Solver {
        t0: f64,
        t1: f64,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// `do_step` before `initialize` (the FMI state machine prevents it; kept for direct users).
    #[error("do_step before initialize")]
    NotInitialized,
}

/// `parameter 'a'` or `parameters 'a', 'b'`.
fn quote_names(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
    let noun = if names.len() == 1 {
        "parameter"
    } else {
        "parameters"
    };
    format!("{noun} {}", quoted.join(", "))
}

impl ModelError {
    /// One parameter the physics cannot use.
    pub fn parameter(name: &'static str, reason: impl Into<String>) -> Self {
        ModelError::Parameters {
            names: vec![name],
            reason: reason.into(),
        }
    }

    /// A combination of parameters the physics cannot use.
    pub fn parameters(names: &[&'static str], reason: impl Into<String>) -> Self {
        ModelError::Parameters {
            names: names.to_vec(),
            reason: reason.into(),
        }
    }

    /// The variables this error names (empty unless it is about parameters).
    pub fn names(&self) -> &[&'static str] {
        match self {
            ModelError::Parameters { names, .. } => names,
            _ => &[],
        }
    }

    /// The integrator failed inside `[t0, t1]`.
    pub fn solver(t0: f64, t1: f64, e: impl std::error::Error + Send + Sync + 'static) -> Self {
        ModelError::Solver {
            t0,
            t1,
            source: Box::new(e),
        }
    }
}

/// The `modelDescription.xml` of `M` in `version`.
pub fn model_description<M: Model>(version: Version) -> String {
    match version {
        Version::Fmi2 => xml::model_description::<M>(),
        Version::Fmi3 => xml3::model_description::<M>(),
    }
}

/// The `documentation/index.html` of `M` in `version`.
pub fn documentation<M: Model>(version: Version) -> String {
    match version {
        Version::Fmi2 => html::documentation::<M>(),
        Version::Fmi3 => html::documentation_fmi3::<M>(),
    }
}

/// Problems in the variable table of `M`, one sentence each (empty when consistent): FMI names,
/// units, ranges, causality/variability/initial, the candidate-effect convention, the Model
/// Exchange declarations, and value references clear of those the FMI 3.0 description adds.
pub fn table_problems<M: Model>() -> Vec<String> {
    let vars = M::variables();
    let mut problems = xml::check_table(vars);
    if let Some(me) = M::model_exchange() {
        problems.extend(me.check(vars));
        problems.extend(me::nominal_problems(&me, &M::new(), vars));
    }
    for v in vars {
        if v.name == "time" || v.value_reference >= xml3::TIME_VALUE_REFERENCE {
            problems.push(format!(
                "'{}': value reference {} or name clashes with the FMI 3.0 variables 'time' and \
                 the event indicators (from {})",
                v.name,
                v.value_reference,
                xml3::TIME_VALUE_REFERENCE
            ));
        }
    }
    problems
}

/// Entry point of the `describe` binary: writes `modelDescription.xml` and
/// `documentation/index.html` of `M` in `version` into the directory given as the only argument
/// (default `.`).
pub fn describe_main<M: Model>(version: Version) {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".to_string());
    let dir = std::path::Path::new(&dir);
    let result = (|| -> std::io::Result<()> {
        std::fs::create_dir_all(dir.join("documentation"))?;
        std::fs::write(
            dir.join("modelDescription.xml"),
            model_description::<M>(version),
        )?;
        std::fs::write(
            dir.join("documentation").join("index.html"),
            documentation::<M>(version),
        )?;
        Ok(())
    })();
    if let Err(e) = result {
        let what = match version {
            Version::Fmi2 => "describe",
            Version::Fmi3 => "describe (FMI 3.0)",
        };
        eprintln!("{what} {}: cannot write to {}: {e}", M::NAME, dir.display());
        std::process::exit(2);
    }
}
