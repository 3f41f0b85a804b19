//! High-level simulation: start values by name, input series, fixed communication step.

use crate::error::{HostError, Result, Status};
use crate::fmi3::{Fmu3, Instance3, Request3};
use crate::fmu::Fmu;
use crate::instance::Instance;
use crate::kind::Interface;
use crate::md::{Causality, ModelDescription, ScalarVariable, VarKind, Variability};
use crate::me::isclose;
use crate::run::{
    fmu_tolerance, me_settings, step_through, with_input_events, CoSimulationStep, InputAxis,
    InputPlanOf, InputPoint, InputValues, Inputs, Outputs,
};

/// Columns of text: (variable name, one value per row).
pub type TextColumns = Vec<(String, Vec<String>)>;

/// A value for a variable before initialization (`--set NAME=VALUE`).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// For Real variables (Integer variables accept integral values).
    Real(f64),
    /// For Boolean variables.
    Boolean(bool),
    /// For String variables.
    Text(String),
}

impl Value {
    /// Parses `text` for the scalar variable `v`: `true`/`false` (or 1/0) for Booleans, a
    /// finite number within the variable's min/max otherwise.
    pub fn parse_for(v: &crate::view::Variable, text: &str) -> Result<Value> {
        let t = text.trim();
        let kind = v.scalar_kind().ok_or_else(|| {
            HostError::Request(format!("'{}' is not a scalar model variable", v.name))
        })?;
        match kind {
            VarKind::Boolean => match t {
                "true" | "1" => Ok(Value::Boolean(true)),
                "false" | "0" => Ok(Value::Boolean(false)),
                _ => Err(HostError::Request(format!(
                    "'{}' is Boolean: expected true or false, got '{text}'",
                    v.name
                ))),
            },
            VarKind::Real | VarKind::Integer | VarKind::Enumeration => {
                let x: f64 = t.parse().map_err(|_| {
                    HostError::Request(format!("'{}': '{text}' is not a number", v.name))
                })?;
                if !x.is_finite() {
                    return Err(HostError::Request(format!(
                        "'{}': value must be finite, got '{text}'",
                        v.name
                    )));
                }
                within_range(&v.name, (x, &x), (v.min, v.max))?;
                Ok(Value::Real(x))
            }
            VarKind::String => Ok(Value::Text(text.to_string())),
        }
    }
}

/// Refuses the value `x` (written as `shown`) of variable `name` outside `[min, max]`.
pub(crate) fn within_range(
    name: &str,
    (x, shown): (f64, &dyn std::fmt::Display),
    (min, max): (Option<f64>, Option<f64>),
) -> Result<()> {
    if matches!(min, Some(lo) if x < lo) || matches!(max, Some(hi) if x > hi) {
        return Err(HostError::Request(format!(
            "'{}' = {shown} is outside its range [{}, {}]",
            crate::error::shown(name, 60),
            min.unwrap_or(f64::NEG_INFINITY),
            max.unwrap_or(f64::INFINITY)
        )));
    }
    Ok(())
}

/// Input time series: `time` strictly increasing, each column as long as `time`.
///
/// At each communication point `t`, continuous Real inputs are interpolated linearly; discrete
/// inputs (Integer, Boolean, Enumeration, String, and Real with `variability="discrete"`) are
/// held at the row with the largest time `<= t` (zero-order hold, a row time within 1e-9
/// relative of `t` counting as reached). Before the first row and after the last the end
/// values are held. This is how FMPy applies inputs to a Co-Simulation FMU.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InputSeries {
    /// Sample times.
    pub time: Vec<f64>,
    /// (input name, samples); Booleans as 0/1.
    pub columns: Vec<(String, Vec<f64>)>,
    /// (String input name, samples).
    pub text: TextColumns,
}

/// What to simulate.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationRequest {
    /// Start time (fmi2SetupExperiment).
    pub start_time: f64,
    /// Stop time; the last communication point is exactly this.
    pub stop_time: f64,
    /// Communication step; the last step is shortened if it does not divide the interval.
    pub step: f64,
    /// Values set after instantiation, before initialization (parameters and inputs).
    pub start_values: Vec<(String, Value)>,
    /// Inputs driven over time (override the start values of those inputs).
    pub inputs: InputSeries,
    /// Variables to record; empty means every output.
    pub outputs: Vec<String>,
    /// Relative tolerance (None: the DefaultExperiment's): Co-Simulation passes it to
    /// fmi2SetupExperiment (neither: not defined); Model Exchange integrates with it (neither:
    /// 1e-5) and passes only a given one (see `run::fmu_tolerance`), as FMPy does.
    pub tolerance: Option<f64>,
    /// Model Exchange: also record before and after each event (two rows at its time), as
    /// FMPy's `record_events`. Co-Simulation records the communication points only.
    pub record_events: bool,
}

impl SimulationRequest {
    /// A request from `start` to `stop` with step `step`, no inputs, every output.
    pub fn new(start_time: f64, stop_time: f64, step: f64) -> Self {
        SimulationRequest {
            start_time,
            stop_time,
            step,
            start_values: Vec::new(),
            inputs: InputSeries::default(),
            outputs: Vec::new(),
            tolerance: None,
            record_events: false,
        }
    }
}

/// Recorded trajectories: `columns[j][k]` is variable `names[j]` at `time[k]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimulationResult {
    /// Communication points, the start included.
    pub time: Vec<f64>,
    /// Recorded variable names.
    pub names: Vec<String>,
    /// One trajectory per name (Booleans as 0/1).
    pub columns: Vec<Vec<f64>>,
    /// Recorded String variables: (name, one value per time).
    pub text: TextColumns,
    /// When the FMU ended the run itself (fmi2DoStep returned fmi2Discard and
    /// fmi2GetBooleanStatus(fmi2Terminated) was true): the last recorded time, its
    /// fmi2LastSuccessfulTime.
    pub ended_by_fmu: Option<f64>,
}

/// What a recorder holds at the end of a run: the numeric variables' names, their columns, and
/// the text columns, each in the order asked for.
pub(crate) type Recorded = (Vec<String>, Vec<Vec<f64>>, TextColumns);

impl SimulationResult {
    /// The result of a run that recorded `recorded` at the times `time` (every interface and
    /// FMI version records this way).
    pub(crate) fn of_rows(time: Vec<f64>, recorded: Recorded, ended_by_fmu: Option<f64>) -> Self {
        let (names, columns, text) = recorded;
        SimulationResult {
            time,
            names,
            columns,
            text,
            ended_by_fmu,
        }
    }

    /// Values of the String variable `name`.
    pub fn text_column(&self, name: &str) -> Option<&[String]> {
        self.text
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, c)| c.as_slice())
    }

    /// Trajectory of `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }
}

/// Communication points from `start` to `stop`: `t_k = start + k*h` computed from the integer
/// k (no accumulated rounding), the last one exactly `stop`.
pub fn communication_points(start: f64, stop: f64, h: f64) -> Result<Vec<f64>> {
    if !(start.is_finite() && stop.is_finite() && h.is_finite()) {
        return Err(HostError::Request(
            "start, stop and step must be finite".into(),
        ));
    }
    if h <= 0.0 {
        return Err(HostError::Request(format!("step must be > 0, got {h}")));
    }
    if stop < start {
        return Err(HostError::Request(format!(
            "stop time {stop} is before start time {start}"
        )));
    }
    let ratio = (stop - start) / h;
    if ratio > 1e8 {
        return Err(HostError::Request(format!(
            "{ratio:.0} steps: step too small for the interval"
        )));
    }
    let n_round = ratio.round();
    let n = if (ratio - n_round).abs() <= 1e-9 * n_round.max(1.0) {
        n_round as usize
    } else {
        ratio.ceil() as usize
    };
    let mut t: Vec<f64> = (0..=n).map(|k| start + k as f64 * h).collect();
    if let Some(last) = t.last_mut() {
        *last = stop;
    }
    Ok(t)
}

/// Linear interpolation of `(xs, ys)` at `x`, holding the end values; `cursor` speeds up
/// monotone queries (start it at 0).
///
/// For `xs[i] < x <= xs[i+1]`: `w0 = (xs[i+1] - x) / (xs[i+1] - xs[i])`,
/// `y = w0 ys[i] + (1 - w0) ys[i+1]`: the formula of FMPy's `Input.interpolate`, so inputs
/// reach the FMU bit-identical to an FMPy run on the same table.
pub fn interpolate(xs: &[f64], ys: &[f64], x: f64, cursor: &mut usize) -> f64 {
    let n = xs.len();
    if n == 0 {
        return f64::NAN;
    }
    if x <= xs[0] {
        return ys[0];
    }
    if x > xs[n - 1] {
        return ys[n - 1];
    }
    // Find i with xs[i] < x <= xs[i + 1].
    if *cursor >= n - 1 || xs[*cursor] >= x {
        *cursor = 0;
    }
    while xs[*cursor + 1] < x {
        *cursor += 1;
    }
    let (i, j) = (*cursor, *cursor + 1);
    let w0 = (xs[j] - x) / (xs[j] - xs[i]);
    let w1 = 1.0 - w0;
    w0 * ys[i] + w1 * ys[j]
}

/// The value of the column `ys` at `x` once a jump at `x` has been passed (`after`): the last
/// row at `x` (`row`, from [`hold_index`]) where two rows hold that time; else [`interpolate`].
pub(crate) fn interpolate_at(
    (xs, ys): (&[f64], &[f64]),
    x: f64,
    (row, after): (usize, bool),
    cursor: &mut usize,
) -> f64 {
    if after && row > 0 && xs[row - 1] == xs[row] && isclose(xs[row], x) {
        ys[row]
    } else {
        interpolate(xs, ys, x, cursor)
    }
}

/// Index of the row held at `x` (zero-order hold): the largest `i` with `xs[i] <= x`, a row
/// within 1e-9 relative of `x` counting as reached (FMPy's `isclose`); 0 before the first row.
/// `cursor` speeds up monotone queries (start it at 0).
pub fn hold_index(xs: &[f64], x: f64, cursor: &mut usize) -> usize {
    let reached = |r: f64| r < x || isclose(r, x);
    if *cursor >= xs.len() || !reached(xs[*cursor]) {
        *cursor = 0;
    }
    while *cursor + 1 < xs.len() && reached(xs[*cursor + 1]) {
        *cursor += 1;
    }
    *cursor
}

/// Variable lookup split by type for one get/set call per type.
#[derive(Clone, Debug, Default)]
struct ByType {
    real: Vec<(usize, u32)>,
    integer: Vec<(usize, u32)>,
    boolean: Vec<(usize, u32)>,
    string: Vec<(usize, u32)>,
}

fn lookup<'m>(md: &'m ModelDescription, name: &str) -> Result<&'m ScalarVariable> {
    md.variable(name)
        .ok_or_else(|| HostError::UnknownVariable(name.to_string()))
}

/// One FMI version's part of a run: what [`Simulator`] and [`simulate_then`] need of an FMU.
pub trait Simulated {
    /// The version's instance.
    type Instance<'a>
    where
        Self: 'a;
    /// The version's request.
    type Request;
    /// A fresh instance named `host`.
    fn instantiate_host(&self) -> Result<Self::Instance<'_>>;
    /// The version's reset (fmi2Reset, fmi3Reset), its log then dropped.
    fn reset(inst: &mut Self::Instance<'_>) -> Result<()>;
    /// Drops the log of earlier calls.
    fn forget_log(inst: &mut Self::Instance<'_>);
    /// One run of `req` on `inst`.
    fn run_on(inst: &mut Self::Instance<'_>, req: &Self::Request) -> Result<SimulationResult>;
}

/// [`Simulated`] for each version: its FMU, instance and request types and its run. The
/// versions' instances spell `reset` and `take_log` alike, so only the types differ.
macro_rules! simulated {
    ($($fmu:ty => $inst:ident, $req:ty, $run:path;)*) => {$(
        impl Simulated for $fmu {
            type Instance<'a> = $inst<'a>;
            type Request = $req;
            fn instantiate_host(&self) -> Result<$inst<'_>> {
                self.instantiate("host")
            }
            fn reset(inst: &mut $inst<'_>) -> Result<()> {
                inst.reset().map(drop)
            }
            fn forget_log(inst: &mut $inst<'_>) {
                let _ = inst.take_log();
            }
            fn run_on(inst: &mut $inst<'_>, req: &$req) -> Result<SimulationResult> {
                $run(inst, req)
            }
        }
    )*};
}

simulated! {
    Fmu => Instance, SimulationRequest, run_on;
    Fmu3 => Instance3, Request3, crate::fmi3::simulate::run_on;
}

/// Reusable simulation driver: one instance, reset between runs (fmi2Reset, fmi3Reset), so
/// repeated simulations (calibration) do not pay for instantiation. If a reset fails, the
/// instance is freed and a new one made.
pub struct Simulator<'a, F: Simulated = Fmu> {
    fmu: &'a F,
    instance: ReusedInstance<F::Instance<'a>>,
}

impl<'a, F: Simulated> Simulator<'a, F> {
    /// Instantiates the FMU once.
    pub fn new(fmu: &'a F) -> Result<Self> {
        Ok(Simulator {
            fmu,
            instance: ReusedInstance::new(fmu.instantiate_host()?),
        })
    }

    /// The instance (for direct calls between runs); None only after a failed re-instantiation.
    pub fn instance(&mut self) -> Option<&mut F::Instance<'a>> {
        self.instance.get()
    }

    /// Runs one simulation. After any run the instance is reset before the next.
    pub fn run(&mut self, req: &F::Request) -> Result<SimulationResult> {
        let fmu = self.fmu;
        let inst = self.instance.ready(F::reset, || fmu.instantiate_host())?;
        F::forget_log(inst);
        F::run_on(inst, req)
    }
}

/// An instance reused across runs: reset before every run but the first, and made again when a
/// reset fails (a failed reset leaves it unusable). The FMI 2.0 and FMI 3.0 simulators keep
/// theirs in one; each brings its own reset and instantiate calls.
pub(crate) struct ReusedInstance<I> {
    instance: Option<I>,
    used: bool,
}

impl<I> ReusedInstance<I> {
    /// A fresh instance, not reset before its first run.
    pub(crate) fn new(instance: I) -> Self {
        ReusedInstance {
            instance: Some(instance),
            used: false,
        }
    }

    /// The instance; None only after a failed re-instantiation.
    pub(crate) fn get(&mut self) -> Option<&mut I> {
        self.instance.as_mut()
    }

    /// The instance, ready for a run: after an earlier run, `reset`; when that fails, freed
    /// and made again with `instantiate`, reporting the reset's error if that fails too.
    pub(crate) fn ready<S>(
        &mut self,
        reset: impl FnOnce(&mut I) -> Result<S>,
        instantiate: impl FnOnce() -> Result<I>,
    ) -> Result<&mut I> {
        let ran_before = self.used;
        self.used = true;
        if ran_before {
            let reset = match self.instance.as_mut() {
                Some(inst) => reset(inst).map(|_| ()),
                None => Err(no_instance()),
            };
            if let Err(e) = reset {
                self.instance = None;
                self.instance = Some(instantiate().map_err(|_| e)?);
            }
        }
        self.instance.as_mut().ok_or_else(no_instance)
    }
}

/// A simulator whose instance was lost: its reset and a new instantiation both failed before.
fn no_instance() -> HostError {
    HostError::Request("no instance".into())
}

/// Simulates `req` on a fresh instance of `fmu`.
pub fn simulate<F: Simulated>(fmu: &F, req: &F::Request) -> Result<SimulationResult> {
    simulate_then(fmu, req, |res| res)
}

/// [`simulate`], handing the result to `keep` before the instance is freed: what `keep` saves
/// (the output file) survives an FMU that crashes in fmi2FreeInstance or fmi3FreeInstance.
pub fn simulate_then<F: Simulated, R>(
    fmu: &F,
    req: &F::Request,
    keep: impl FnOnce(SimulationResult) -> R,
) -> Result<R> {
    let mut inst = fmu.instantiate_host()?;
    let kept = keep(F::run_on(&mut inst, req)?);
    drop(inst);
    Ok(kept)
}

/// One run on `inst`, Co-Simulation or Model Exchange as it was instantiated: everything
/// resolved before the FMU is touched, then start values and inputs, initialization, and
/// [`step_through`] or [`crate::me::fmi2::integrate`].
fn run_on(inst: &mut Instance<'_>, req: &SimulationRequest) -> Result<SimulationResult> {
    let md = inst.fmu().model_description();
    let model_exchange = inst.fmu().interface() == Interface::ModelExchange;
    let times = communication_points(req.start_time, req.stop_time, req.step)?;
    let starts = StartValues::resolve(md, &req.start_values)?;
    let mut inputs = InputPlan::new(md, &req.inputs)?;
    let variable_step = md
        .co_simulation
        .as_ref()
        .is_some_and(|c| c.can_handle_variable_communication_step_size);
    let times = match model_exchange || !variable_step {
        true => times,
        false => with_input_events(&times, &inputs),
    };
    let out_names: Vec<String> = if req.outputs.is_empty() {
        md.recorded_by_default()
    } else {
        req.outputs.clone()
    };
    if !model_exchange {
        check_recorded_values(times.len(), out_names.len())?;
    }
    let mut rec = Recorder::new(md, out_names, times.len())?;
    let default_tolerance = md.default_experiment.as_ref().and_then(|d| d.tolerance);
    let settings = model_exchange
        .then(|| {
            me_settings(
                (req.start_time, req.stop_time, req.step),
                req.tolerance,
                default_tolerance,
                req.record_events,
            )
        })
        .transpose()?;
    let tolerance = fmu_tolerance(model_exchange, req.tolerance, default_tolerance);

    starts.apply(inst)?;
    inputs.apply(inst, req.start_time)?;
    inst.setup_experiment(tolerance, req.start_time, Some(req.stop_time))?;
    inst.enter_initialization_mode()?;
    inst.exit_initialization_mode()?;
    let (time, ended_by_fmu) = match settings {
        Some(settings) => crate::me::fmi2::integrate(inst, &settings, &mut inputs, &mut rec)?,
        None => step_through(inst, &times, &mut inputs, &mut rec)?,
    };
    let _ = inst.terminate();
    Ok(SimulationResult::of_rows(time, rec.finish(), ended_by_fmu))
}

/// Refuses a Co-Simulation run that would record more than [`MAX_RECORDED_VALUES`].
fn check_recorded_values(points: usize, outputs: usize) -> Result<()> {
    let values = points.saturating_mul(outputs.max(1));
    if values > MAX_RECORDED_VALUES {
        return Err(HostError::Request(format!(
            "{points} communication points x {outputs} outputs would record {values} values \
             (limit {MAX_RECORDED_VALUES}, {} MB): use a larger step or fewer outputs",
            (MAX_RECORDED_VALUES * 8) >> 20
        )));
    }
    Ok(())
}

/// fmi2DoStep from `t` by `h`. FMI 2.0.4 section 4.2.3: after fmi2Discard, fmi2Terminated true
/// means the FMU ended the simulation; its results are valid up to fmi2LastSuccessfulTime.
impl CoSimulationStep for Instance<'_> {
    fn co_simulation_step(&mut self, t: f64, h: f64) -> Result<Option<f64>> {
        match self.do_step(t, h, true) {
            Ok(_) => Ok(None),
            Err(e) if e.status() == Some(Status::Discard) && self.terminated().unwrap_or(false) => {
                self.last_successful_time().map(Some)
            }
            Err(e) => Err(e),
        }
    }
}

/// Most values one run records (8 bytes each): a step far too small for the interval, or an FMU
/// with very many outputs, ends in a message rather than in exhausted memory.
pub const MAX_RECORDED_VALUES: usize = 1 << 27;

/// Start values grouped by type, checked against the model description.
#[derive(Default)]
pub(crate) struct StartValues {
    reals: (Vec<u32>, Vec<f64>),
    ints: (Vec<u32>, Vec<i32>),
    bools: (Vec<u32>, Vec<bool>),
    strings: (Vec<u32>, Vec<String>),
}

impl StartValues {
    pub(crate) fn resolve(md: &ModelDescription, values: &[(String, Value)]) -> Result<Self> {
        let mut s = StartValues::default();
        for (name, value) in values {
            let v = lookup(md, name)?;
            if v.causality == Causality::Independent
                || v.causality == Causality::CalculatedParameter
            {
                return Err(HostError::Request(format!(
                    "'{name}' is {:?}: cannot be set",
                    v.causality
                )));
            }
            let vr = v.value_reference;
            match (v.kind, value) {
                (VarKind::Real, Value::Real(x)) => push(&mut s.reals, vr, *x),
                (VarKind::Integer | VarKind::Enumeration, Value::Real(x))
                    if x.fract() == 0.0 && x.abs() < 2.1e9 =>
                {
                    push(&mut s.ints, vr, *x as i32)
                }
                (VarKind::Boolean, Value::Boolean(b)) => push(&mut s.bools, vr, *b),
                (VarKind::String, Value::Text(t)) => push(&mut s.strings, vr, t.clone()),
                (kind, value) => {
                    return Err(HostError::Request(format!(
                        "'{name}' is {kind:?}: cannot take the value {value:?}"
                    )))
                }
            }
        }
        Ok(s)
    }

    pub(crate) fn apply(&self, inst: &mut Instance<'_>) -> Result<()> {
        if !self.reals.0.is_empty() {
            inst.set_real(&self.reals.0, &self.reals.1)?;
        }
        if !self.ints.0.is_empty() {
            inst.set_integer(&self.ints.0, &self.ints.1)?;
        }
        if !self.bools.0.is_empty() {
            inst.set_boolean(&self.bools.0, &self.bools.1)?;
        }
        if !self.strings.0.is_empty() {
            let refs: Vec<&str> = self.strings.1.iter().map(String::as_str).collect();
            inst.set_string(&self.strings.0, &refs)?;
        }
        Ok(())
    }
}

fn push<T>(to: &mut (Vec<u32>, Vec<T>), vr: u32, x: T) {
    to.0.push(vr);
    to.1.push(x);
}

/// How an input column reaches the FMU.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Apply {
    /// Continuous Real: linear interpolation.
    Interpolate,
    /// Discrete Real, Integer, Enumeration, Boolean: zero-order hold.
    Hold,
}

/// The inputs of a run: value references by type, one set call per type per point.
pub(crate) type InputPlan<'r> = InputPlanOf<'r, Inputs2<'r>>;

/// The FMI 2.0 inputs of a run: their columns of the series, by type.
pub(crate) struct Inputs2<'r> {
    series: &'r InputSeries,
    /// (vr, column, how) of Real inputs, set together.
    reals: Vec<(u32, usize, Apply)>,
    ints: Vec<(u32, usize)>,
    bools: Vec<(u32, usize)>,
    /// (vr, text column) of String inputs.
    strings: Vec<(u32, usize)>,
    real_vrs: Vec<u32>,
    real_buf: Vec<f64>,
}

/// Whether a held (discrete) input of `plan` changes its value at row `k` of `series`.
fn held_changes(plan: &Inputs2<'_>, series: &InputSeries, k: usize) -> bool {
    let changed = |v: &[f64]| k < v.len() && v[k] != v[k - 1];
    let held = plan
        .reals
        .iter()
        .filter(|r| r.2 == Apply::Hold)
        .map(|r| r.1);
    let mut held = held.chain(plan.ints.iter().chain(&plan.bools).map(|r| r.1));
    let text_changed = |&(_, col): &(u32, usize)| {
        let v = &series.text[col].1;
        k < v.len() && v[k] != v[k - 1]
    };
    held.any(|col| changed(&series.columns[col].1)) || plan.strings.iter().any(text_changed)
}

impl<'r> InputPlan<'r> {
    pub(crate) fn new(md: &ModelDescription, series: &'r InputSeries) -> Result<Self> {
        let mut plan = Inputs2 {
            series,
            reals: Vec::new(),
            ints: Vec::new(),
            bools: Vec::new(),
            strings: Vec::new(),
            real_vrs: Vec::new(),
            real_buf: Vec::new(),
        };
        let names = series.columns.iter().map(|(n, c)| (n, c.len()));
        let text_names = series.text.iter().map(|(n, c)| (n, c.len()));
        for (col, (name, len)) in names.chain(text_names).enumerate() {
            let v = match md.input_of(name) {
                Some(v) => v,
                None => {
                    lookup(md, name)?;
                    return Err(HostError::Request(format!(
                        "'{name}' is not an input of the FMU"
                    )));
                }
            };
            if len != series.time.len() {
                return Err(HostError::Request(format!(
                    "input '{name}' has {len} samples for {} times",
                    series.time.len()
                )));
            }
            let vr = v.value_reference;
            let text_col = col.checked_sub(series.columns.len());
            match (v.kind, text_col) {
                (VarKind::String, Some(j)) => plan.strings.push((vr, j)),
                (VarKind::String, None) | (_, Some(_)) => {
                    return Err(HostError::Request(format!(
                        "input '{name}': text values for a {:?} variable or numbers for a String",
                        v.kind
                    )))
                }
                (VarKind::Real, None) if v.variability == Variability::Continuous => {
                    plan.reals.push((vr, col, Apply::Interpolate))
                }
                (VarKind::Real, None) => plan.reals.push((vr, col, Apply::Hold)),
                (VarKind::Boolean, None) => plan.bools.push((vr, col)),
                (VarKind::Integer | VarKind::Enumeration, None) => plan.ints.push((vr, col)),
            }
        }
        if !(series.columns.is_empty() && series.text.is_empty()) && series.time.is_empty() {
            return Err(HostError::Request("input series has no samples".into()));
        }
        plan.real_vrs = plan.reals.iter().map(|r| r.0).collect();
        plan.real_buf = vec![0.0; plan.reals.len()];
        let axis = InputAxis::new(&series.time, |k| held_changes(&plan, series, k));
        Ok(InputPlanOf { axis, values: plan })
    }
}

impl InputValues<Instance<'_>> for Inputs2<'_> {
    /// Sets the continuous Real inputs (`continuous`) and the discrete ones (`discrete`) to
    /// their values at `at`: Model Exchange sets the discrete inputs in Event Mode only.
    fn set_at(&mut self, inst: &mut Instance<'_>, at: &mut InputPoint<'_>) -> Result<()> {
        let (s, row) = (self.series, at.row);
        let (continuous, discrete) = (at.continuous, at.discrete);
        for (x, &(_, col, how)) in self.real_buf.iter_mut().zip(&self.reals) {
            *x = match how {
                Apply::Interpolate => at.interpolate(&s.columns[col].1),
                Apply::Hold => s.columns[col].1[row],
            };
        }
        if continuous && discrete {
            if !self.reals.is_empty() {
                inst.set_real(&self.real_vrs, &self.real_buf)?;
            }
        } else {
            let want = if continuous {
                Apply::Interpolate
            } else {
                Apply::Hold
            };
            for (x, &(vr, _, how)) in self.real_buf.iter().zip(&self.reals) {
                if how == want {
                    inst.set_real(&[vr], &[*x])?;
                }
            }
        }
        if !discrete {
            return Ok(());
        }
        for &(vr, col) in &self.ints {
            inst.set_integer(&[vr], &[held_integer(s.columns[col].1[row])])?;
        }
        for &(vr, col) in &self.bools {
            inst.set_boolean(&[vr], &[s.columns[col].1[row] >= 0.5])?;
        }
        for &(vr, col) in &self.strings {
            inst.set_string(&[vr], &[s.text[col].1[row].as_str()])?;
        }
        Ok(())
    }
}

/// An Integer input's value from a numeric cell: rounded, clamped to the i32 range.
fn held_integer(x: f64) -> i32 {
    x.round().clamp(i32::MIN as f64, i32::MAX as f64) as i32
}

/// Outputs read after each step, by type.
pub(crate) struct Recorder {
    names: Vec<String>,
    by_type: ByType,
    vrs: [Vec<u32>; 4],
    columns: Vec<Vec<f64>>,
    text: Vec<Vec<String>>,
    rbuf: Vec<f64>,
    ibuf: Vec<i32>,
    bbuf: Vec<bool>,
}

impl Recorder {
    pub(crate) fn new(md: &ModelDescription, names: Vec<String>, capacity: usize) -> Result<Self> {
        let mut by_type = ByType::default();
        for (j, name) in names.iter().enumerate() {
            let v = lookup(md, name)?;
            let to = match v.kind {
                VarKind::Real => &mut by_type.real,
                VarKind::Integer | VarKind::Enumeration => &mut by_type.integer,
                VarKind::Boolean => &mut by_type.boolean,
                VarKind::String => &mut by_type.string,
            };
            to.push((j, v.value_reference));
        }
        let vrs_of = |v: &[(usize, u32)]| v.iter().map(|&(_, vr)| vr).collect::<Vec<u32>>();
        let vrs = [
            vrs_of(&by_type.real),
            vrs_of(&by_type.integer),
            vrs_of(&by_type.boolean),
            vrs_of(&by_type.string),
        ];
        Ok(Recorder {
            columns: names.iter().map(|_| Vec::with_capacity(capacity)).collect(),
            text: names.iter().map(|_| Vec::new()).collect(),
            rbuf: vec![0.0; vrs[0].len()],
            ibuf: vec![0; vrs[1].len()],
            bbuf: vec![false; vrs[2].len()],
            names,
            by_type,
            vrs,
        })
    }

    /// (numeric names, their columns, String columns), each in the order asked for.
    pub(crate) fn finish(self) -> Recorded {
        let is_text: Vec<bool> = (0..self.names.len())
            .map(|j| self.by_type.string.iter().any(|&(k, _)| k == j))
            .collect();
        let (mut names, mut columns, mut text) = (Vec::new(), Vec::new(), Vec::new());
        for (((name, col), txt), is_text) in self
            .names
            .into_iter()
            .zip(self.columns)
            .zip(self.text)
            .zip(is_text)
        {
            if is_text {
                text.push((name, txt));
            } else {
                names.push(name);
                columns.push(col);
            }
        }
        (names, columns, text)
    }
}

impl Outputs<Instance<'_>> for Recorder {
    /// Number of recorded variables.
    fn width(&self) -> usize {
        self.names.len()
    }

    fn record(&mut self, inst: &mut Instance<'_>) -> Result<()> {
        let t = &self.by_type;
        if !self.vrs[0].is_empty() {
            inst.get_real(&self.vrs[0], &mut self.rbuf)?;
            for (&(j, _), &x) in t.real.iter().zip(&self.rbuf) {
                self.columns[j].push(x);
            }
        }
        if !self.vrs[1].is_empty() {
            inst.get_integer(&self.vrs[1], &mut self.ibuf)?;
            for (&(j, _), &x) in t.integer.iter().zip(&self.ibuf) {
                self.columns[j].push(x as f64);
            }
        }
        if !self.vrs[2].is_empty() {
            inst.get_boolean(&self.vrs[2], &mut self.bbuf)?;
            for (&(j, _), &x) in t.boolean.iter().zip(&self.bbuf) {
                self.columns[j].push(if x { 1.0 } else { 0.0 });
            }
        }
        if !self.vrs[3].is_empty() {
            let values = inst.get_string(&self.vrs[3])?;
            for (&(j, _), x) in t.string.iter().zip(values) {
                self.text[j].push(x);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{communication_points, hold_index, interpolate};

    #[test]
    fn communication_points_hit_stop_exactly_without_drift() {
        let t = communication_points(0.0, 1.0, 0.1).unwrap();
        assert_eq!(t.len(), 11);
        assert_eq!(t[3], 3.0 * 0.1);
        assert_eq!(*t.last().unwrap(), 1.0);
        let t = communication_points(0.0, 1.05, 0.1).unwrap();
        assert_eq!(t.len(), 12);
        assert_eq!(t[10], 1.0);
        assert_eq!(t[11], 1.05);
        let t = communication_points(2.0, 2.0, 0.1).unwrap();
        assert_eq!(t, vec![2.0]);
        assert!(communication_points(0.0, 1.0, 0.0).is_err());
        assert!(communication_points(0.0, 1.0, -0.1).is_err());
        assert!(communication_points(1.0, 0.0, 0.1).is_err());
        assert!(communication_points(0.0, f64::NAN, 0.1).is_err());
    }

    #[test]
    fn discrete_inputs_hold_the_last_row_reached() {
        let xs = [0.0, 0.1, 0.2, 0.30000000000000004];
        let mut c = 0;
        assert_eq!(hold_index(&xs, -1.0, &mut c), 0);
        assert_eq!(hold_index(&xs, 0.05, &mut c), 0);
        // a communication point computed as 3 * 0.1 reaches the row written as 0.3 and back
        assert_eq!(hold_index(&xs, 0.1, &mut c), 1);
        assert_eq!(hold_index(&xs, 0.3, &mut c), 3);
        assert_eq!(hold_index(&xs, 0.2 - 1e-6, &mut c), 1);
        assert_eq!(hold_index(&xs, 0.2 - 1e-12, &mut c), 2); // within 1e-9 relative
        assert_eq!(hold_index(&xs, 9.0, &mut c), 3);
        assert_eq!(hold_index(&xs, 0.15, &mut c), 1);
    }

    #[test]
    fn interpolation_is_linear_and_holds_the_ends() {
        let xs = [0.0, 1.0, 3.0];
        let ys = [0.0, 10.0, 30.0];
        let mut c = 0;
        assert_eq!(interpolate(&xs, &ys, -1.0, &mut c), 0.0);
        assert_eq!(interpolate(&xs, &ys, 0.5, &mut c), 5.0);
        assert_eq!(interpolate(&xs, &ys, 2.0, &mut c), 20.0);
        assert_eq!(interpolate(&xs, &ys, 3.0, &mut c), 30.0);
        assert_eq!(interpolate(&xs, &ys, 9.0, &mut c), 30.0);
        // going back in time resets the cursor
        assert_eq!(interpolate(&xs, &ys, 0.25, &mut c), 2.5);
    }
}
