//! A whole FMI 3.0 Co-Simulation run: start values, inputs from text columns, a fixed
//! communication grid, every output recorded.
//!
//! The steps follow the FMI 3.0.2 Co-Simulation state machine without event mode
//! (`eventModeUsed = false`; an FMU with clocks and `hasEventMode` runs with it, see
//! [`super::events`]): instantiate; structural parameters in Configuration Mode; other
//! start values and the inputs at the start time in the Instantiated state;
//! fmi3EnterInitializationMode(tolerance, start, stop); fmi3ExitInitializationMode (to Step
//! Mode); then fmi3DoStep from point to point, inputs set before each step. When fmi3DoStep
//! returns `terminateSimulation`, the rows up to its `lastSuccessfulTime` are kept and the run
//! ends (as FMI 2.0's fmi2Discard with fmi2Terminated).
//!
//! Inputs are applied as FMPy applies them: continuous Float inputs (arrays element by element)
//! interpolated linearly, every other input held at the last row reached.
//!
//! Outputs: scalar Float32/Float64, Int8..UInt32, Boolean and Enumeration as numbers; Int64 and
//! UInt64 (beyond 2^53 a double is inexact), String, Binary (hex) and every array (elements
//! row-major, separated by spaces) as text.

use super::instance::{Fmu3, Instance3};
use super::md::{Causality3, ModelDescription3, Variable3};
use super::value::{Type3, ValueError, Values};
use crate::error::{HostError, Result};
use crate::kind::Interface;
use crate::me::clocks::ClockSchedule;
use crate::run::{
    fmu_tolerance, step_through, with_input_events, CoSimulationStep, InputAxis, InputPlanOf,
    InputPoint, InputValues, Inputs, Outputs,
};
use crate::simulate::{communication_points, within_range, Recorded, SimulationResult, Simulator};
use fmi_types::Variability;

/// Input columns of an FMI 3.0 run: a time axis and text cells (see [`super::value`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Inputs3 {
    /// Sample times, strictly increasing.
    pub time: Vec<f64>,
    /// (column name, one cell per time): a variable's name (an array's elements separated by
    /// spaces) or one element's, `u[2]`, `A[1,3]` (1-based, as FMPy names them).
    pub columns: Vec<(String, Vec<String>)>,
}

/// What to simulate.
#[derive(Clone, Debug, PartialEq)]
pub struct Request3 {
    /// Start time.
    pub start_time: f64,
    /// Stop time; the last communication point is exactly this.
    pub stop_time: f64,
    /// Communication step.
    pub step: f64,
    /// Relative tolerance (None: the DefaultExperiment's), handed to fmi3EnterInitializationMode
    /// and to the Model Exchange integrator as [`crate::SimulationRequest::tolerance`].
    pub tolerance: Option<f64>,
    /// (name, text) set before initialization: parameters, structural parameters, inputs.
    pub start_values: Vec<(String, String)>,
    /// Inputs driven over time.
    pub inputs: Inputs3,
    /// Variables to record; empty means every output.
    pub outputs: Vec<String>,
    /// Model Exchange: also record before and after each event (see
    /// [`crate::SimulationRequest::record_events`]).
    pub record_events: bool,
}

impl Request3 {
    /// A request from `start` to `stop` with step `step`, no inputs, every output.
    pub fn new(start_time: f64, stop_time: f64, step: f64) -> Self {
        Request3 {
            start_time,
            stop_time,
            step,
            tolerance: None,
            start_values: Vec::new(),
            inputs: Inputs3::default(),
            outputs: Vec::new(),
            record_events: false,
        }
    }
}

/// Most values one run records: as for FMI 2.0 runs.
const MAX_RECORDED_VALUES: usize = crate::simulate::MAX_RECORDED_VALUES;

/// Reusable FMI 3.0 simulation driver (fmi3Reset between runs).
pub type Simulator3<'a> = Simulator<'a, Fmu3>;

/// One run on `inst` (see [`crate::Simulated::run_on`]).
pub(crate) fn run_on(inst: &mut Instance3<'_>, req: &Request3) -> Result<SimulationResult> {
    let described = inst.fmu().model_description().with_aliases();
    let md: &ModelDescription3 = &described;
    let times = communication_points(req.start_time, req.stop_time, req.step)?;
    let starts = StartValues3::resolve(md, &req.start_values)?;
    let sizes = |vr: u32| starts.size_of(md, vr);
    let mut inputs = InputPlan3::new(md, &req.inputs, &sizes)?;
    let fmu = inst.fmu();
    let variable_step = fmu.interface() == Interface::CoSimulation
        && !fmu.event_mode_used()
        && md
            .co_simulation
            .as_ref()
            .is_some_and(|c| c.flag("canHandleVariableCommunicationStepSize"));
    let times = match variable_step {
        true => with_input_events(&times, &inputs),
        false => times,
    };
    let names: Vec<String> = if req.outputs.is_empty() {
        md.recorded_by_default()
    } else {
        req.outputs.clone()
    };
    let mut rec = Recorder3::new(md, &names, &sizes, times.len())?;
    if times.len().saturating_mul(rec.width.max(1)) > MAX_RECORDED_VALUES {
        return Err(HostError::Request(format!(
            "{} communication points x {} output values would exceed {MAX_RECORDED_VALUES} \
             values: use a larger step or fewer outputs",
            times.len(),
            rec.width
        )));
    }

    starts.apply(inst)?;
    inputs.apply(inst, req.start_time)?;
    let tolerance = fmu_tolerance(
        inst.fmu().interface() == Interface::ModelExchange,
        req.tolerance,
        md.default_experiment.as_ref().and_then(|d| d.tolerance),
    );
    inst.enter_initialization_mode(tolerance, req.start_time, Some(req.stop_time))?;
    let (me, event_mode) = (
        inst.fmu().interface() == Interface::ModelExchange,
        inst.fmu().event_mode_used(),
    );
    let clocks = if me || event_mode {
        let mut clocks = ClockSchedule::initialize(inst, req.start_time)?;
        clocks.trigger(&inputs.values.triggered, req.start_time);
        clocks
    } else {
        ClockSchedule::default()
    };
    rec.initial_clocked(inst)?;
    inst.exit_initialization_mode()?;
    let (time, ended_by_fmu) = if me {
        crate::me::fmi3::run(inst, req, (&mut inputs, clocks), &mut rec)?
    } else if event_mode {
        super::events::run(inst, &times, &mut inputs, &mut rec, clocks)?
    } else {
        step_through(inst, &times, &mut inputs, &mut rec)?
    };
    let _ = inst.terminate();
    Ok(SimulationResult::of_rows(time, rec.finish(), ended_by_fmu))
}

/// fmi3DoStep from `t` by `h`. FMI 3.0.2 section 4.2.1 (fmi3DoStep): terminateSimulation asks
/// the importer to end the run; the results are valid up to lastSuccessfulTime.
impl CoSimulationStep for Instance3<'_> {
    fn co_simulation_step(&mut self, t: f64, h: f64) -> Result<Option<f64>> {
        let out = self.do_step(t, h, true)?;
        Ok(out.terminate.then_some(out.last_successful_time))
    }
}

fn lookup<'m>(md: &'m ModelDescription3, name: &str) -> Result<&'m Variable3> {
    md.variable(name)
        .ok_or_else(|| HostError::UnknownVariable(name.to_string()))
}

/// The number of elements of `v` (1 for a scalar) given the structural parameters' sizes.
fn element_count(
    md: &ModelDescription3,
    v: &Variable3,
    sizes: &dyn Fn(u32) -> Option<u64>,
) -> Result<(Vec<usize>, usize)> {
    let shape = md
        .shape_with(v, sizes)
        .map_err(|e| HostError::Request(e.to_string()))?;
    let n = shape.iter().product();
    Ok((shape, n))
}

/// Start values checked against the description: structural parameters (set in Configuration
/// Mode) and the rest.
struct StartValues3 {
    structural: Vec<(u32, Values)>,
    other: Vec<(u32, Values)>,
}

impl StartValues3 {
    fn resolve(md: &ModelDescription3, values: &[(String, String)]) -> Result<Self> {
        let mut s = StartValues3 {
            structural: Vec::new(),
            other: Vec::new(),
        };
        for (name, text) in values {
            let v = lookup(md, name)?;
            if !matches!(
                v.causality,
                Causality3::Parameter | Causality3::StructuralParameter | Causality3::Input
            ) || v.variability == Variability::Constant
            {
                return Err(HostError::Request(format!(
                    "'{name}' is {} {}: only parameters, structural parameters and inputs can \
                     be set",
                    v.variability, v.causality
                )));
            }
            if v.ty == Type3::Clock {
                return Err(HostError::Request(format!(
                    "'{name}' is a Clock: the run sets input clocks active at their ticks \
                     (FMI 3.0.2 section 2.2.8.2), a clock takes no start value"
                )));
            }
            let x = Values::parse(v.ty, text)
                .and_then(|x| check_magnitude(&x).map(|_| x))
                .map_err(|e| HostError::Request(format!("'{name}': {e}")))?;
            check_range(v, &x)?;
            let to = if v.causality == Causality3::StructuralParameter {
                &mut s.structural
            } else {
                &mut s.other
            };
            to.push((v.value_reference, x));
        }
        // Sizes of arrays follow the structural parameters set: check the counts now.
        for (vr, x) in &s.other {
            let v = md.by_vr(*vr).expect("resolved above");
            let (_, n) = element_count(md, v, &|r| s.size_of(md, r))?;
            if x.len() != n {
                return Err(HostError::Request(format!(
                    "'{}' has {n} element(s), {} value(s) given",
                    v.name,
                    x.len()
                )));
            }
        }
        Ok(s)
    }

    /// The size a structural parameter gives an array: its value set here, else its start.
    fn size_of(&self, md: &ModelDescription3, vr: u32) -> Option<u64> {
        match self.structural.iter().find(|(r, _)| *r == vr) {
            Some((_, x)) => x.number(0).filter(|n| *n >= 0.0).map(|n| n as u64),
            None => {
                let v = md.by_vr(vr)?;
                let n = v.start.as_ref()?.number(0)?;
                (v.ty.is_integer() && !v.is_array() && n >= 0.0).then_some(n as u64)
            }
        }
    }

    fn apply(&self, inst: &mut Instance3<'_>) -> Result<()> {
        if !self.structural.is_empty() {
            // FMI 3.0.2 section 3.2: structural parameters change in Configuration Mode only.
            inst.enter_configuration_mode()?;
            for (vr, x) in &self.structural {
                inst.set(&[*vr], x)?;
            }
            inst.exit_configuration_mode()?;
        }
        for (vr, x) in &self.other {
            inst.set(&[*vr], x)?;
        }
        Ok(())
    }
}

/// Largest magnitude of a Float input or start value: as for FMI 2.0 data, beyond it squares
/// overflow in the workflows that compare outputs.
const MAX_MAGNITUDE: f64 = 1e100;

/// Refuses NaN, infinities and Float values beyond [`MAX_MAGNITUDE`].
fn check_magnitude(x: &Values) -> Result<(), ValueError> {
    if !matches!(x, Values::Float32(_) | Values::Float64(_)) {
        return Ok(());
    }
    for i in 0..x.len() {
        let n = x.number(i).unwrap_or(0.0);
        if !n.is_finite() || n.abs() > MAX_MAGNITUDE {
            return Err(ValueError::NotFinite {
                text: x.text(i),
                limit: MAX_MAGNITUDE,
            });
        }
    }
    Ok(())
}

/// Refuses a numeric value outside the variable's declared min/max.
fn check_range(v: &Variable3, x: &Values) -> Result<()> {
    for i in 0..x.len() {
        let Some(n) = x.number(i) else { break };
        if n.is_nan() {
            return Err(HostError::Request(format!(
                "'{}': NaN is not a value",
                v.name
            )));
        }
        within_range(&v.name, (n, &x.text(i)), (v.min, v.max))?;
    }
    Ok(())
}

/// How one input reaches the FMU.
enum Samples {
    /// Continuous Float input: `elements[e][row]`, interpolated.
    Interpolated { ty: Type3, elements: Vec<Vec<f64>> },
    /// Any other input: the values of each row, held.
    Held(Vec<Values>),
}

/// The FMI 3.0 inputs of a run: each set with one call per communication point, and the
/// triggered input clocks with the times the data tick them.
pub(crate) struct Inputs3Plan {
    inputs: Vec<(u32, Samples)>,
    pub(crate) triggered: Vec<(u32, Vec<f64>)>,
}

/// The input plan of an FMI 3.0 run.
pub(crate) type InputPlan3<'r> = InputPlanOf<'r, Inputs3Plan>;

impl<'r> InputPlan3<'r> {
    fn new(
        md: &ModelDescription3,
        series: &'r Inputs3,
        sizes: &dyn Fn(u32) -> Option<u64>,
    ) -> Result<Self> {
        let mut used = vec![false; series.columns.len()];
        let mut inputs = Vec::new();
        let mut triggered = Vec::new();
        for v in md.with_causality(Causality3::Input) {
            if v.ty == Type3::Clock {
                if v.interval_variability.as_deref() == Some("triggered") {
                    if let Some(ticks) = clock_ticks(v, series, &mut used)? {
                        triggered.push((v.value_reference, ticks));
                    }
                }
                continue;
            }
            let (shape, n) = element_count(md, v, sizes)?;
            let Some(rows) = input_rows(v, &shape, n, series, &mut used)? else {
                continue;
            };
            let continuous = v.ty.is_float() && v.variability == Variability::Continuous;
            let samples = if continuous {
                let elements = (0..n)
                    .map(|e| {
                        rows.iter()
                            .map(|r| r.number(e).unwrap_or(f64::NAN))
                            .collect()
                    })
                    .collect();
                Samples::Interpolated { ty: v.ty, elements }
            } else {
                Samples::Held(rows)
            };
            inputs.push((v.value_reference, samples));
        }
        if let Some(j) = used.iter().position(|u| !u) {
            let name = &series.columns[j].0;
            let base = name.split('[').next().unwrap_or(name);
            let known = md
                .variable(base)
                .is_some_and(|v| v.causality == Causality3::Output);
            let input_clock =
                |v: &&Variable3| v.ty == Type3::Clock && v.causality == Causality3::Input;
            if let Some(clock) = md.variable(base).filter(input_clock) {
                return Err(HostError::Request(format!(
                    "column '{}': the input clock ticks by its own schedule \
                     (intervalVariability \"{}\"); only a triggered input clock takes its \
                     ticks from the data",
                    crate::error::shown(name, 60),
                    clock.interval_variability.as_deref().unwrap_or("")
                )));
            }
            if !known {
                return Err(HostError::Request(format!(
                    "column '{}' is neither an input nor an output of the FMU (inputs: {})",
                    crate::error::shown(name, 60),
                    names_of(md, Causality3::Input)
                )));
            }
        }
        if !inputs.is_empty() && series.time.is_empty() {
            return Err(HostError::Request("input series has no samples".into()));
        }
        let held_changes = |k: usize| {
            inputs.iter().any(|(_, s)| match s {
                Samples::Held(rows) => rows[k] != rows[k - 1],
                Samples::Interpolated { .. } => false,
            })
        };
        let axis = InputAxis::new(&series.time, held_changes);
        let values = Inputs3Plan { inputs, triggered };
        Ok(InputPlanOf { axis, values })
    }
}

impl InputValues<Instance3<'_>> for Inputs3Plan {
    fn set_at(&mut self, inst: &mut Instance3<'_>, at: &mut InputPoint<'_>) -> Result<()> {
        for (vr, samples) in &self.inputs {
            let interpolated = matches!(samples, Samples::Interpolated { .. });
            if !(interpolated && at.continuous || !interpolated && at.discrete) {
                continue;
            }
            let values = match samples {
                Samples::Interpolated { ty, elements } => {
                    let x: Vec<f64> = elements.iter().map(|ys| at.interpolate(ys)).collect();
                    match ty {
                        Type3::Float32 => Values::Float32(x.iter().map(|&v| v as f32).collect()),
                        _ => Values::Float64(x),
                    }
                }
                Samples::Held(rows) => rows[at.row].clone(),
            };
            inst.set(&[*vr], &values)?;
        }
        Ok(())
    }
}

fn names_of(md: &ModelDescription3, c: Causality3) -> String {
    let n: Vec<&str> = md.with_causality(c).map(|v| v.name.as_str()).collect();
    if n.is_empty() {
        "none".into()
    } else {
        n.join(", ")
    }
}

/// The times at which the data tick the triggered input clock `v`: the rows of its column
/// (Boolean: `true`/`1` a tick) that hold true (FMI 3.0.2 section 2.2.8.2: the importer
/// activates a triggered input clock when it chooses); None without a column.
fn clock_ticks(v: &Variable3, series: &Inputs3, used: &mut [bool]) -> Result<Option<Vec<f64>>> {
    let Some(rows) = input_rows(v, &[], 1, series, used)? else {
        return Ok(None);
    };
    let ticked = |(row, t): (&Values, &f64)| (row.number(0) == Some(1.0)).then_some(*t);
    Ok(Some(
        rows.iter().zip(&series.time).filter_map(ticked).collect(),
    ))
}

/// The rows of input `v` from its own column or from one column per element (`u[1]`, ...);
/// None when the data hold neither.
fn input_rows(
    v: &Variable3,
    shape: &[usize],
    n: usize,
    series: &Inputs3,
    used: &mut [bool],
) -> Result<Option<Vec<Values>>> {
    let parse = |text: &str, what: &str, row: usize| {
        let x = Values::parse(v.ty, text);
        x.and_then(|x| check_magnitude(&x).map(|_| x))
            .map_err(|e| HostError::Request(format!("input '{what}', row {}: {e}", row + 1)))
    };
    if let Some(j) = series.columns.iter().position(|(c, _)| *c == v.name) {
        used[j] = true;
        let cells = &series.columns[j].1;
        check_len(&v.name, cells.len(), series.time.len())?;
        let mut rows = Vec::with_capacity(cells.len());
        for (k, cell) in cells.iter().enumerate() {
            let x = parse(cell, &v.name, k)?;
            if x.len() != n {
                return Err(HostError::Request(format!(
                    "input '{}', row {}: {} value(s) for {n} element(s)",
                    v.name,
                    k + 1,
                    x.len()
                )));
            }
            rows.push(x);
        }
        return Ok(Some(rows));
    }
    if shape.is_empty() || matches!(v.ty, Type3::String | Type3::Binary) && n != 1 {
        return Ok(None);
    }
    let mut element_cols = vec![None; n];
    for (j, (c, _)) in series.columns.iter().enumerate() {
        if let Some(e) = element_index(c, &v.name, shape) {
            element_cols[e] = Some(j);
            used[j] = true;
        }
    }
    if element_cols.iter().all(Option::is_none) {
        return Ok(None);
    }
    if let Some(missing) = element_cols.iter().position(Option::is_none) {
        return Err(HostError::Request(format!(
            "input '{}': the data give some elements but not element {} (columns {}[i,...], \
             1-based, row-major)",
            v.name,
            missing + 1,
            v.name
        )));
    }
    let rows = (0..series.time.len())
        .map(|k| {
            let mut row = Values::zeros(v.ty, 0);
            for j in element_cols.iter().flatten() {
                let (name, cells) = &series.columns[*j];
                check_len(name, cells.len(), series.time.len())?;
                row.extend_from(&parse(&cells[k], name, k)?);
            }
            Ok(row)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Some(rows))
}

fn check_len(name: &str, len: usize, times: usize) -> Result<()> {
    if len == times {
        Ok(())
    } else {
        Err(HostError::Request(format!(
            "input '{name}' has {len} samples for {times} times"
        )))
    }
}

/// The row-major index of the element named `name[i,j,...]` (1-based) of an array `base` of
/// `shape`.
pub fn element_index(column: &str, base: &str, shape: &[usize]) -> Option<usize> {
    let inner = column
        .strip_prefix(base)?
        .strip_prefix('[')?
        .strip_suffix(']')?;
    let idx: Vec<usize> = inner
        .split(',')
        .map(|s| s.trim().parse::<usize>().ok())
        .collect::<Option<_>>()?;
    if idx.len() != shape.len() {
        return None;
    }
    let mut flat = 0;
    for (i, n) in idx.iter().zip(shape) {
        if *i == 0 || i > n {
            return None;
        }
        flat = flat * n + (i - 1);
    }
    Some(flat)
}

/// How a recorded variable is written.
#[derive(Clone, Copy, PartialEq)]
enum Column {
    Number(usize),
    Text(usize),
}

/// Recorded variables of one type: their value references, element counts and columns. A
/// clocked variable is a group of its own: it can be read only while one of its `clocks` is
/// active (FMI 3.0.2 section 2.2.8.3: "Clocked variables ... can be queried only when their
/// Clock is active, except during Initialization Mode"), and its rows hold the value `held`
/// then until the next tick (None before the first: NaN, or empty text).
struct Group {
    ty: Type3,
    vrs: Vec<u32>,
    counts: Vec<usize>,
    cols: Vec<Column>,
    clocks: Vec<u32>,
    held: Option<Values>,
}

/// Outputs read after each step, one get call per type.
pub(crate) struct Recorder3 {
    names: Vec<String>,
    /// One get call per type.
    groups: Vec<Group>,
    numbers: Vec<Vec<f64>>,
    text: Vec<Vec<String>>,
    /// (column kind) of each name in order.
    order: Vec<Column>,
    /// Values recorded per row.
    width: usize,
}

impl Recorder3 {
    fn new(
        md: &ModelDescription3,
        names: &[String],
        sizes: &dyn Fn(u32) -> Option<u64>,
        capacity: usize,
    ) -> Result<Self> {
        let mut rec = Recorder3 {
            names: names.to_vec(),
            groups: Vec::new(),
            numbers: Vec::new(),
            text: Vec::new(),
            order: Vec::new(),
            width: 0,
        };
        for name in names {
            let v = lookup(md, name)?;
            if v.ty == Type3::Clock {
                return Err(HostError::Request(format!(
                    "'{name}' is a Clock: a clock has no value between its ticks to record \
                     (FMI 3.0.2 section 2.2.8.2); record the variables it clocks"
                )));
            }
            let (shape, n) = element_count(md, v, sizes)?;
            let numeric = shape.is_empty()
                && !matches!(
                    v.ty,
                    Type3::Int64 | Type3::UInt64 | Type3::String | Type3::Binary
                );
            let col = if numeric {
                rec.numbers.push(Vec::with_capacity(capacity));
                Column::Number(rec.numbers.len() - 1)
            } else {
                rec.text.push(Vec::with_capacity(capacity));
                Column::Text(rec.text.len() - 1)
            };
            rec.order.push(col);
            rec.width += n;
            let shared = v.clocks.is_empty();
            let g = match rec
                .groups
                .iter()
                .position(|g| shared && g.ty == v.ty && g.clocks.is_empty())
            {
                Some(i) => i,
                None => {
                    rec.groups.push(Group {
                        ty: v.ty,
                        vrs: Vec::new(),
                        counts: Vec::new(),
                        cols: Vec::new(),
                        clocks: v.clocks.clone(),
                        held: None,
                    });
                    rec.groups.len() - 1
                }
            };
            let group = &mut rec.groups[g];
            group.vrs.push(v.value_reference);
            group.counts.push(n);
            group.cols.push(col);
        }
        Ok(rec)
    }

    /// (numeric names, their columns, text columns), each in the order asked for.
    fn finish(self) -> Recorded {
        let mut numbers: Vec<Option<Vec<f64>>> = self.numbers.into_iter().map(Some).collect();
        let mut text: Vec<Option<Vec<String>>> = self.text.into_iter().map(Some).collect();
        let (mut names, mut columns, mut texts) = (Vec::new(), Vec::new(), Vec::new());
        for (name, col) in self.names.into_iter().zip(self.order) {
            match col {
                Column::Number(j) => {
                    names.push(name);
                    columns.push(numbers[j].take().unwrap_or_default());
                }
                Column::Text(j) => texts.push((name, text[j].take().unwrap_or_default())),
            }
        }
        (names, columns, texts)
    }
}

impl Outputs<Instance3<'_>> for Recorder3 {
    /// Values recorded per row.
    fn width(&self) -> usize {
        self.width
    }

    fn record(&mut self, inst: &mut Instance3<'_>) -> Result<()> {
        for g in &self.groups {
            let total = g.counts.iter().sum();
            let values = match (&g.held, g.clocks.is_empty()) {
                (_, true) => inst.get(g.ty, &g.vrs, total)?,
                (Some(held), false) => held.clone(),
                (None, false) => Values::Float64(vec![f64::NAN; total]),
            };
            let mut at = 0;
            for (&n, col) in g.counts.iter().zip(&g.cols) {
                match *col {
                    Column::Number(j) => {
                        self.numbers[j].push(values.number(at).unwrap_or(f64::NAN))
                    }
                    Column::Text(j) => self.text[j].push(values.joined(at..at + n)),
                }
                at += n;
            }
        }
        Ok(())
    }

    /// Reads the variables clocked by one of the active `clocks` and holds their values.
    fn clocks_active(&mut self, inst: &mut Instance3<'_>, clocks: &[u32]) -> Result<()> {
        for g in &mut self.groups {
            if g.clocks.iter().any(|c| clocks.contains(c)) {
                g.held = Some(inst.get(g.ty, &g.vrs, g.counts.iter().sum())?);
            }
        }
        Ok(())
    }
}

impl Recorder3 {
    /// In Initialization Mode: the clocked variables that are `<InitialUnknown>`s, which the
    /// FMU must initialize there (FMI 3.0.2 section 2.2.8.3; the others get their value at
    /// their clock's first tick).
    fn initial_clocked(&mut self, inst: &mut Instance3<'_>) -> Result<()> {
        let md = inst.fmu().model_description();
        let initial: Vec<u32> = md
            .model_structure
            .initial_unknowns
            .iter()
            .map(|u| u.value_reference)
            .collect();
        for g in &mut self.groups {
            if !g.clocks.is_empty() && g.vrs.iter().all(|vr| initial.contains(vr)) {
                g.held = Some(inst.get(g.ty, &g.vrs, g.counts.iter().sum())?);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::element_index;

    #[test]
    fn element_names_map_row_major_and_refuse_what_is_not_an_element() {
        assert_eq!(element_index("u[2]", "u", &[3]), Some(1));
        assert_eq!(element_index("A[2,3]", "A", &[3, 3]), Some(5));
        assert_eq!(element_index("A[1, 1]", "A", &[3, 3]), Some(0));
        assert_eq!(element_index("A[4,1]", "A", &[3, 3]), None);
        assert_eq!(element_index("A[0,1]", "A", &[3, 3]), None);
        assert_eq!(element_index("A[1]", "A", &[3, 3]), None);
        assert_eq!(element_index("AB[1]", "A", &[3]), None);
        assert_eq!(element_index("u", "u", &[3]), None);
    }
}
