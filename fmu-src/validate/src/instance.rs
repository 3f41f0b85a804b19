//! The FMI 2.0 and FMI 3.0 FMUs and instances as the probes drive them, so that a probe is
//! written once over both: [`ProbedFmu`] opens instances and reads the default experiment,
//! [`Probed`] makes the calls of the probes' sequences, [`FmuStates`] saves and restores states.
//! The two versions differ here only in which host calls they make.

use host::fmi3::{Fmu3, Instance3};
use host::me::fmi2::Fmi2Me;
use host::me::fmi3::Fmi3Me;
use host::me::ModelExchange;
use host::{Fmu, FmuStateHandle, FmuStateHandle3, HostError, Instance};

/// The default experiment as the probes use it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Experiment {
    /// `startTime` (0 when not given).
    pub start: f64,
    /// `stopTime`, if given.
    pub stop: Option<f64>,
    /// `stepSize`, if given.
    pub step_size: Option<f64>,
}

impl Experiment {
    fn new(start: Option<f64>, stop: Option<f64>, step_size: Option<f64>) -> Experiment {
        Experiment {
            start: start.unwrap_or(0.0),
            stop,
            step_size,
        }
    }
}

/// An opened FMU of either version, as the probes instantiate it.
pub(crate) trait ProbedFmu {
    /// Its instance.
    type Instance<'f>: Probed
    where
        Self: 'f;
    /// A fresh instance named `probe`.
    fn instantiate(&self) -> Result<Self::Instance<'_>, HostError>;
    /// The default experiment of its description.
    fn experiment(&self) -> Experiment;
    /// Whether the Model Exchange interface declares `canGetAndSetFMUstate` and
    /// `canSerializeFMUstate`.
    fn model_exchange_states(&self) -> (bool, bool);
}

/// The calls the probes' sequences make on an instance of either version.
pub(crate) trait Probed: FmuStates {
    /// The instance bound as Model Exchange.
    type Me<'i>: ModelExchange
    where
        Self: 'i;
    /// Enters and leaves Initialization Mode at `t0` (FMI 2.0: after `fmi2SetupExperiment`): a
    /// Model Exchange instance is then in Event Mode.
    fn initialize(&mut self, t0: f64) -> Result<(), HostError>;
    /// The instance bound as Model Exchange.
    fn model_exchange(&mut self) -> Result<Self::Me<'_>, HostError>;
    /// `terminate`.
    fn end(&mut self) -> Result<(), HostError>;
}

/// How one FMI version's messages name the FMU state calls.
pub(crate) struct StateCallNames {
    /// The call that saves a state (`fmi2GetFMUstate`).
    pub get: &'static str,
    /// The call that restores one (`fmi2SetFMUstate`).
    pub set: &'static str,
    /// Serialize, deserialize and set, as one phrase.
    pub copy: &'static str,
}

/// The FMU state calls of one FMI version's instance, as the restored-state checks use them.
pub(crate) trait FmuStates {
    /// A saved FMU state.
    type State;
    /// The names of the calls in this version's spelling.
    const NAMES: StateCallNames;
    /// Saves the instance's state.
    fn get_state(&mut self) -> Result<Self::State, HostError>;
    /// Restores `state`.
    fn set_state(&mut self, state: &Self::State) -> Result<(), HostError>;
    /// Serializes `state` and deserializes the bytes into a new state.
    fn serialized_copy(&mut self, state: &Self::State) -> Result<Self::State, HostError>;
    /// Frees `state` (a failure changes no verdict: the check is made).
    fn free_state(&mut self, state: Self::State);
}

/// [`FmuStates`] of an instance type whose host API names the calls alike in both versions.
macro_rules! fmu_states {
    ($instance:ty, $state:ty, $names:expr) => {
        impl FmuStates for $instance {
            type State = $state;
            const NAMES: StateCallNames = $names;

            fn get_state(&mut self) -> Result<$state, HostError> {
                self.get_fmu_state()
            }

            fn set_state(&mut self, state: &$state) -> Result<(), HostError> {
                self.set_fmu_state(state).map(drop)
            }

            fn serialized_copy(&mut self, state: &$state) -> Result<$state, HostError> {
                let bytes = self.serialize_fmu_state(state)?;
                self.deserialize_fmu_state(&bytes)
            }

            fn free_state(&mut self, state: $state) {
                let _ = self.free_fmu_state(state);
            }
        }
    };
}

fmu_states!(
    Instance<'_>,
    FmuStateHandle,
    StateCallNames {
        get: "fmi2GetFMUstate",
        set: "fmi2SetFMUstate",
        copy: "fmi2SerializeFMUstate, fmi2DeSerializeFMUstate and fmi2SetFMUstate",
    }
);

fmu_states!(
    Instance3<'_>,
    FmuStateHandle3,
    StateCallNames {
        get: "fmi3GetFMUState",
        set: "fmi3SetFMUState",
        copy: "fmi3SerializeFMUState, fmi3DeserializeFMUState and fmi3SetFMUState",
    }
);

/// [`ProbedFmu`] of an FMU type with instances of type `$instance`, whose Model Exchange
/// state capabilities `$states` reads from its description.
macro_rules! probed_fmu {
    ($fmu:ident, $instance:ident, $states:expr) => {
        impl ProbedFmu for $fmu {
            type Instance<'f> = $instance<'f>;

            fn instantiate(&self) -> Result<$instance<'_>, HostError> {
                $fmu::instantiate(self, "probe")
            }

            fn experiment(&self) -> Experiment {
                let de = self.model_description().default_experiment.clone();
                let de = de.unwrap_or_default();
                Experiment::new(de.start_time, de.stop_time, de.step_size)
            }

            fn model_exchange_states(&self) -> (bool, bool) {
                let states: fn(&Self) -> (bool, bool) = $states;
                states(self)
            }
        }
    };
}

probed_fmu!(Fmu, Instance, |fmu| {
    let me = fmu.model_description().model_exchange.as_ref();
    (
        me.is_some_and(|m| m.can_get_and_set_fmu_state),
        me.is_some_and(|m| m.can_serialize_fmu_state),
    )
});

probed_fmu!(Fmu3, Instance3, |fmu| {
    (
        declares(fmu, true, "canGetAndSetFMUState"),
        declares(fmu, true, "canSerializeFMUState"),
    )
});

/// Whether the description of `fmu` declares the capability `flag` for Model Exchange
/// (`model_exchange`) or Co-Simulation.
pub(crate) fn declares(fmu: &Fmu3, model_exchange: bool, flag: &str) -> bool {
    let md = fmu.model_description();
    let element = if model_exchange {
        md.model_exchange.as_ref()
    } else {
        md.co_simulation.as_ref()
    };
    element.is_some_and(|e| e.flag(flag))
}

/// [`Probed`] of an instance type, bound as Model Exchange by `$me`, initialized by
/// `$initialize` (the one call sequence the versions spell differently).
macro_rules! probed {
    ($instance:ident, $me:ident, $initialize:expr) => {
        impl<'a> Probed for $instance<'a> {
            type Me<'i>
                = $me<'i, 'a>
            where
                Self: 'i;

            fn initialize(&mut self, t0: f64) -> Result<(), HostError> {
                let initialize: fn(&mut Self, f64) -> Result<(), HostError> = $initialize;
                initialize(self, t0)
            }

            fn model_exchange(&mut self) -> Result<$me<'_, 'a>, HostError> {
                $me::new(self)
            }

            fn end(&mut self) -> Result<(), HostError> {
                self.terminate().map(drop)
            }
        }
    };
}

probed!(Instance, Fmi2Me, |inst, t0| {
    inst.setup_experiment(None, t0, None)?;
    inst.enter_initialization_mode()?;
    inst.exit_initialization_mode()?;
    Ok(())
});

probed!(Instance3, Fmi3Me, |inst, t0| {
    inst.enter_initialization_mode(None, t0, None)?;
    inst.exit_initialization_mode()?;
    Ok(())
});
