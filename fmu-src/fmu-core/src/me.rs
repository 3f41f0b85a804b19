//! The Model Exchange side of a model: what the FMI 2.0 ME functions (standard chapter 3) need
//! besides [`Model`]. The importer integrates the continuous states with its own solver; the model
//! supplies their derivatives, its outputs at any (t, x), and its sampled controllers as time
//! events. The model's Co-Simulation code (`Model::do_step`) is untouched by this trait.

use crate::{Model, ModelError};

/// A model that an importer's solver can integrate (FMI 2.0 Model Exchange).
///
/// State and derivative variables are ordinary variables of the table: each state is a
/// continuous Real (an output where the model has one, else a local) and its derivative a
/// continuous Real local named `der(<state>)`. Their positions in the table (`V::X as usize`,
/// the index into `vars`) are listed by [`ModelExchange::state_variables`] in the order of the
/// state vector `x`.
///
/// Call sequence the layer guarantees (FMI 2.0.4 section 3.2.3): [`Model::initialize`] at
/// `fmi2ExitInitializationMode` (it builds the initial state and writes every output, exactly as
/// in Co-Simulation), then repeatedly: `set_states`/input changes, [`derivatives`],
/// [`me_outputs`]; at a time event [`event_update`] (repeated until it reports no change, as in
/// event iteration), after which [`next_time_event`] is asked.
///
/// [`derivatives`]: ModelExchange::derivatives
/// [`me_outputs`]: ModelExchange::me_outputs
/// [`event_update`]: ModelExchange::event_update
/// [`next_time_event`]: ModelExchange::next_time_event
pub trait ModelExchange: Model {
    /// Number of continuous states: fixed for the model (the largest over all effect settings);
    /// a state an effect does not use keeps its value and has derivative 0.
    const STATES: usize;
    /// Number of event indicators (state events). Smooth models have none.
    const EVENT_INDICATORS: usize = 0;

    /// `(state, derivative)` as positions in the table (`V::X as usize`) per state, in the
    /// order of `x`. Length [`ModelExchange::STATES`].
    fn state_variables() -> &'static [(usize, usize)];

    /// Inputs an output depends on directly in Model Exchange (an input set in Continuous-Time
    /// Mode changes the output at once), as `(output, inputs)` positions in the table; the
    /// model description lists them with the states in the output's `dependencies`. Default:
    /// none (outputs depend on the states only).
    fn output_feedthrough() -> &'static [(usize, &'static [usize])] {
        &[]
    }

    /// Per state, in the order of `x`: the states and inputs (positions in the table) its
    /// derivative depends on, under any parameter setting; the model description lists them as
    /// the `dependencies` of `<Derivatives>`. `None` (default): every state and input.
    fn derivative_dependencies() -> Option<&'static [&'static [usize]]> {
        None
    }

    /// Per unknown of the FMI 3.0 `<ModelStructure>` (an output or a state derivative, as
    /// `(unknown, parameters)` positions in the table): the parameters (any type, Booleans
    /// included) its value depends on in Event and Continuous-Time Mode and at a communication
    /// point, under any setting of the other parameters. FMI 3.0.2 section 2.4.8 counts the
    /// parameters among the knowns of `<Output>` and `<ContinuousStateDerivative>`, and a known
    /// left out has a partial derivative that is identically zero; an unknown not named here
    /// depends on no parameter. `None` (default): every unknown on every parameter. (FMI 2.0.4
    /// has no parameters among these knowns; its description does not use this.)
    fn parameter_dependencies() -> Option<&'static [(usize, &'static [usize])]> {
        None
    }

    /// Take every parameter from `vars` (already inside their ranges) into the model as
    /// initialization would, keeping the continuous states and the discrete (controller)
    /// state: the model whose derivatives and outputs the directional derivatives with respect
    /// to a parameter differentiate (called on a copy, never on the instance's model). `Err`
    /// when the values are ill-posed. Default: no parameter derivatives.
    fn set_parameters(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let _ = vars;
        Err(ModelError::parameters(
            &[],
            "this model provides no derivatives with respect to parameters",
        ))
    }

    /// The continuous state vector `x` (length `STATES`) from the model's state.
    fn states(&self, x: &mut [f64]);

    /// Set the continuous states from `x` (length `STATES`); the discrete (controller) state is
    /// untouched.
    fn set_states(&mut self, x: &[f64]);

    /// Nominal magnitudes of the states (the importer's absolute tolerance scale). Default 1.
    fn nominals(&self, n: &mut [f64]) {
        n.fill(1.0);
    }

    /// `dx/dt` at time `t` for the current states, inputs read from `vars`, discrete
    /// (controller) state from `self`. Must not change anything.
    fn derivatives(&self, vars: &[f64], t: f64, dx: &mut [f64]) -> Result<(), ModelError>;

    /// Write every output, every state and derivative variable and every other computed
    /// variable into `vars`, from the states, the inputs in `vars` and the discrete state.
    fn me_outputs(&self, vars: &mut [f64], t: f64);

    /// Time of the next time event (the next controller tick) after the last event update,
    /// `None` when there is none.
    fn next_time_event(&self) -> Option<f64> {
        None
    }

    /// Event mode at time `t` (a time event reached, a state event, or an input changed in
    /// event mode): update the discrete state (e.g. the sampled controller's tick at `t` if it
    /// is due) and the discrete outputs in `vars`. Returns whether any discrete value changed
    /// (the layer then calls it again until it returns `false`, event iteration).
    fn event_update(&mut self, vars: &mut [f64], t: f64) -> Result<bool, ModelError> {
        let _ = (vars, t);
        Ok(false)
    }

    /// Whether [`ModelExchange::state_jacobian`] is implemented: the FMU then declares
    /// `providesDirectionalDerivative="true"` for Model Exchange.
    const PROVIDES_JACOBIAN: bool = false;

    /// The Jacobian of the derivatives with respect to the states at the current states, inputs
    /// from `vars`: `jac[i * STATES + j] = d(dx_i)/d(x_j)` (row-major, `STATES x STATES`).
    /// Called only when [`ModelExchange::PROVIDES_JACOBIAN`]; must not change anything.
    fn state_jacobian(&self, vars: &[f64], t: f64, jac: &mut [f64]) -> Result<(), ModelError> {
        let _ = (vars, t, jac);
        Err(ModelError::parameters(
            &[],
            "this model provides no Jacobian",
        ))
    }

    /// Event indicators `z` (length `EVENT_INDICATORS`): a sign change is a state event.
    fn event_indicators(&self, vars: &[f64], t: f64, z: &mut [f64]) {
        let _ = (vars, t, z);
    }
}

/// [`ModelExchange::derivatives`] (and [`ModelExchange::state_jacobian`]) as a function pointer.
pub type DerivativesFn<M> = fn(&M, &[f64], f64, &mut [f64]) -> Result<(), ModelError>;

/// The [`ModelExchange`] functions of a model as plain function pointers, so that the generic
/// layer (bound on [`Model`] only) can run Model Exchange for the models that provide it. A model
/// implementing [`ModelExchange`] returns `Some(MeVTable::of::<Self>())` from
/// [`Model::model_exchange`].
pub struct MeVTable<M> {
    /// [`ModelExchange::STATES`].
    pub states: usize,
    /// [`ModelExchange::EVENT_INDICATORS`].
    pub event_indicators: usize,
    /// [`ModelExchange::state_variables`].
    pub state_variables: &'static [(usize, usize)],
    /// [`ModelExchange::output_feedthrough`].
    pub output_feedthrough: &'static [(usize, &'static [usize])],
    /// [`ModelExchange::derivative_dependencies`].
    pub derivative_dependencies: Option<&'static [&'static [usize]]>,
    /// [`ModelExchange::parameter_dependencies`].
    pub parameter_dependencies: Option<&'static [(usize, &'static [usize])]>,
    pub set_parameters: fn(&mut M, &[f64]) -> Result<(), ModelError>,
    pub get_states: fn(&M, &mut [f64]),
    pub set_states: fn(&mut M, &[f64]),
    pub nominals: fn(&M, &mut [f64]),
    pub derivatives: DerivativesFn<M>,
    pub outputs: fn(&M, &mut [f64], f64),
    pub next_time_event: fn(&M) -> Option<f64>,
    pub event_update: fn(&mut M, &mut [f64], f64) -> Result<bool, ModelError>,
    pub indicators: fn(&M, &[f64], f64, &mut [f64]),
    /// [`ModelExchange::PROVIDES_JACOBIAN`].
    pub provides_jacobian: bool,
    pub state_jacobian: DerivativesFn<M>,
}

impl<M> Clone for MeVTable<M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M> Copy for MeVTable<M> {}

impl<M: ModelExchange> MeVTable<M> {
    /// The table of `M`'s [`ModelExchange`] implementation.
    pub fn of() -> Self {
        MeVTable {
            states: M::STATES,
            event_indicators: M::EVENT_INDICATORS,
            state_variables: M::state_variables(),
            output_feedthrough: M::output_feedthrough(),
            derivative_dependencies: M::derivative_dependencies(),
            parameter_dependencies: M::parameter_dependencies(),
            set_parameters: M::set_parameters,
            get_states: M::states,
            set_states: M::set_states,
            nominals: M::nominals,
            derivatives: M::derivatives,
            outputs: M::me_outputs,
            next_time_event: M::next_time_event,
            event_update: M::event_update,
            indicators: M::event_indicators,
            provides_jacobian: M::PROVIDES_JACOBIAN,
            state_jacobian: M::state_jacobian,
        }
    }
}

/// Problems of the states' declared `nominal`s (empty when consistent): each state variable
/// declares one, equal to what `me.nominals` returns for it on `model`, so that an importer
/// reading the description (FMI 2.0.4 section 2.2.7, `nominal`) and one calling
/// fmi2GetNominalsOfContinuousStates / fmi3GetNominalsOfContinuousStates (FMPy's CVode:
/// `atol_i = rtol * nominal_i`) scale each state alike.
pub fn nominal_problems<M>(me: &MeVTable<M>, model: &M, vars: &[crate::Variable]) -> Vec<String> {
    let mut n = vec![0.0; me.states];
    (me.nominals)(model, &mut n);
    let mut problems = Vec::new();
    for (&(x, _), &nominal) in me.state_variables.iter().zip(&n) {
        let Some(v) = vars.get(x) else { continue };
        match v.nominal {
            Some(d) if d.to_bits() == nominal.to_bits() && d > 0.0 => {}
            declared => problems.push(format!(
                "state '{}': declared nominal {declared:?}, the model's nominal is {nominal}",
                v.name
            )),
        }
    }
    problems
}

impl<M> MeVTable<M> {
    /// Problems of the declared state and derivative variables (empty when consistent): the
    /// count, each a continuous Real of the table, each derivative a local.
    pub fn check(&self, vars: &[crate::Variable]) -> Vec<String> {
        use crate::{Causality, VarType, Variability};
        let mut problems = Vec::new();
        if self.state_variables.len() != self.states {
            problems.push(format!(
                "{} state variables declared for {} states",
                self.state_variables.len(),
                self.states
            ));
        }
        for &(x, dx) in self.state_variables {
            for vr in [x, dx] {
                match vars.get(vr) {
                    None => {
                        problems.push(format!("state/derivative position {vr} not in the table"))
                    }
                    Some(v)
                        if v.vtype != VarType::Real || v.variability != Variability::Continuous =>
                    {
                        problems.push(format!("'{}' is not a continuous Real", v.name))
                    }
                    Some(_) => {}
                }
            }
            if let (Some(s), Some(d)) = (vars.get(x), vars.get(dx)) {
                if d.causality != Causality::Local || d.name != format!("der({})", s.name) {
                    problems.push(format!(
                        "derivative of '{}' must be the local 'der({})', not '{}'",
                        s.name, s.name, d.name
                    ));
                }
            }
        }
        if let Some(deps) = self.derivative_dependencies {
            if deps.len() != self.states {
                problems.push(format!(
                    "derivative dependencies for {} states, the model has {}",
                    deps.len(),
                    self.states
                ));
            }
            for &i in deps.iter().flat_map(|d| d.iter()) {
                let is_state = self.state_variables.iter().any(|&(x, _)| x == i);
                let is_input = vars.get(i).map(|v| v.causality) == Some(Causality::Input);
                if !(is_state || is_input) {
                    problems.push(format!(
                        "derivative dependency: position {i} is neither a state nor an input"
                    ));
                }
            }
        }
        for &(u, parameters) in self.parameter_dependencies.unwrap_or(&[]) {
            let is_derivative = self.state_variables.iter().any(|&(_, d)| d == u);
            if !(is_derivative || vars.get(u).map(|v| v.causality) == Some(Causality::Output)) {
                problems.push(format!(
                    "parameter dependencies: position {u} is neither an output nor a derivative"
                ));
            }
            for &p in parameters {
                if vars.get(p).map(|v| v.causality) != Some(Causality::Parameter) {
                    problems.push(format!(
                        "parameter dependencies: position {p} is not a parameter"
                    ));
                }
            }
        }
        for &(o, inputs) in self.output_feedthrough {
            if vars.get(o).map(|v| v.causality) != Some(Causality::Output) {
                problems.push(format!("feedthrough: position {o} is not an output"));
            }
            for &i in inputs {
                if vars.get(i).map(|v| v.causality) != Some(Causality::Input) {
                    problems.push(format!("feedthrough: position {i} is not an input"));
                }
            }
        }
        problems
    }
}

/// The positions of `groups` in one array, in order (repeats kept: the model description lists
/// each value reference once), so that [`ModelExchange::parameter_dependencies`] can be written
/// from named groups of parameters (see [`parameter_groups!`](crate::parameter_groups)). `N` is
/// the groups' total length; another `N` fails to compile.
pub const fn join<const N: usize>(groups: &[&[usize]]) -> [usize; N] {
    let mut out = [0; N];
    let (mut k, mut g) = (0, 0);
    while g < groups.len() {
        let mut i = 0;
        while i < groups[g].len() {
            out[k] = groups[g][i];
            k += 1;
            i += 1;
        }
        g += 1;
    }
    assert!(k == N, "join: N is not the groups' total length");
    out
}

/// `parameter_groups!(A, B, ...)`: the positions of the constant arrays (or slices) `A`, `B`,
/// ... in one `&'static [usize]` ([`join`]), in a constant context.
#[macro_export]
macro_rules! parameter_groups {
    ($($group:expr),+ $(,)?) => {{
        const N: usize = 0 $(+ $group.len())+;
        const JOINED: [usize; N] = $crate::me::join::<N>(&[$(&$group),+]);
        &JOINED
    }};
}

/// A disagreement between a model's declared parameter dependencies
/// ([`ModelExchange::parameter_dependencies`]) and its equations, found by
/// [`parameter_dependency_problems`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DependencyProblem {
    /// The output or derivative `unknown` moved when `parameter` alone moved, and does not name
    /// it.
    Undeclared {
        unknown: &'static str,
        parameter: &'static str,
    },
    /// `unknown` names the effect parameter `parameter` without the effect's switch
    /// `<effect>.enabled` (the parameter acts only through the switch).
    SwitchMissing {
        unknown: &'static str,
        parameter: &'static str,
    },
    /// The model refused the moved value of `parameter` ([`ModelExchange::set_parameters`]).
    Refused { parameter: &'static str },
}

/// The declared parameter dependencies of a model checked against its equations, so that the
/// groups they are written from need no counting by hand: from `model`, initialized from `vars`
/// at a state where the parameters act (effects on, moving), each Real and Integer parameter in
/// turn is moved on a copy ([`ModelExchange::set_parameters`]; a Real by a relative 1e-6 inside
/// its range, an Integer by one), and every state derivative and output
/// ([`ModelExchange::me_outputs`] at `t`) whose bits change must name it. Also every effect
/// parameter named must come with its effect's switch. Booleans are not moved: a switch changes
/// which states exist, which `set_parameters` (directional derivatives) never meets. A
/// dependency the state does not exercise goes unseen; a declared one that does not act is
/// allowed (declarations may be conservative).
pub fn parameter_dependency_problems<M: ModelExchange + Clone>(
    model: &M,
    vars: &[f64],
    t: f64,
) -> Vec<DependencyProblem> {
    use crate::Causality;
    let table = M::variables();
    let declared = M::parameter_dependencies().unwrap_or(&[]);
    let named = |u: usize| {
        declared
            .iter()
            .find(|(k, _)| *k == u)
            .map_or(&[][..], |(_, p)| *p)
    };
    let mut unknowns: Vec<usize> = M::state_variables().iter().map(|&(_, d)| d).collect();
    unknowns.extend((0..table.len()).filter(|&i| table[i].causality == Causality::Output));
    let evaluate = |m: &M, vars: &[f64]| {
        let mut v = vars.to_vec();
        m.me_outputs(&mut v, t);
        unknowns.iter().map(|&u| v[u].to_bits()).collect::<Vec<_>>()
    };
    let base = evaluate(model, vars);
    let mut problems = switch_problems(table, declared);
    let movable = |v: &crate::Variable| {
        v.causality == Causality::Parameter && v.vtype != crate::VarType::Boolean
    };
    for p in (0..table.len()).filter(|&p| movable(&table[p])) {
        let parameter = table[p].name;
        let mut moved = vars.to_vec();
        moved[p] = moved_value(&table[p], vars[p]);
        let mut copy = model.clone();
        if copy.set_parameters(&moved).is_err() {
            problems.push(DependencyProblem::Refused { parameter });
            continue;
        }
        let now = evaluate(&copy, &moved);
        for (k, &u) in unknowns.iter().enumerate() {
            if now[k] != base[k] && !named(u).contains(&p) {
                let unknown = table[u].name;
                problems.push(DependencyProblem::Undeclared { unknown, parameter });
            }
        }
    }
    problems
}

/// Every effect parameter named in `declared` without its effect's switch.
fn switch_problems(
    table: &[crate::Variable],
    declared: &[(usize, &[usize])],
) -> Vec<DependencyProblem> {
    let mut problems = Vec::new();
    for &(u, parameters) in declared {
        for &p in parameters {
            let Some(effect) = table[p].effect() else {
                continue;
            };
            let switch = format!("{effect}.enabled");
            if !parameters.iter().any(|&q| table[q].name == switch) {
                problems.push(DependencyProblem::SwitchMissing {
                    unknown: table[u].name,
                    parameter: table[p].name,
                });
            }
        }
    }
    problems
}

/// `x` moved a little inside the variable's range: an Integer by one, a Real by a relative 1e-6
/// (by 1e-6 of its range, or 1e-6, from 0).
fn moved_value(v: &crate::Variable, x: f64) -> f64 {
    let step = match v.vtype {
        crate::VarType::Integer => 1.0,
        _ if x != 0.0 => 1e-6 * x.abs(),
        _ => match (v.min, v.max) {
            (Some(lo), Some(hi)) if hi > lo => 1e-6 * (hi - lo),
            _ => 1e-6,
        },
    };
    if v.max.is_some_and(|hi| x + step > hi) {
        x - step
    } else {
        x + step
    }
}
