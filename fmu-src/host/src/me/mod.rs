//! Model Exchange: the host integrates the FMU's continuous states with the `ode` crate's
//! Rosenbrock integrator and handles its events (FMI 2.0.4 section 3.2.3, the pseudo-code of
//! `fmi2ModelExchange`; FMPy's `simulateME` records the same rows).
//!
//! The loop is written against [`ModelExchange`], the few calls it needs, so that a binding of
//! another FMI version plugs in; [`fmi2`] binds it to an FMI 2.0 [`crate::Instance`].
//!
//! - **Time events**: each integration segment ends exactly at the FMU's `nextEventTime`, at a
//!   change of a discrete input (an input event) or at the next output point.
//! - **State events**: after every accepted step the event indicators are compared with those at
//!   the step's start; a change of domain (`z > 0` against `z <= 0`, FMI 2.0.4 section 3.1; an
//!   indicator exactly 0 after an event takes its domain from its next nonzero value, as CVode
//!   does) is located by re-integration: the Illinois variant of regula falsi on the indicator
//!   that changed first, each trial point reached by integrating from the bracket's left end with
//!   the same tolerances, until the bracket is narrower than [`ROOT_TIME_TOLERANCE`] relative to
//!   the time. The event is handled at the bracket's right end, where the indicator has changed.
//!   Re-integration (rather than the step's interpolant) gives every trial point the solver's
//!   full error control and needs no change to the integrator's steps.
//! - **Step events**: `completedIntegratorStep` after every accepted step (unless the FMU
//!   declares it not needed); `enterEventMode` ends the segment there.
//! - **Clocks** (FMI 3.0, [`clocks`]): the ticks of time-based input clocks are time events; at
//!   one the clocks due are set active in Event Mode before the event iteration; output and
//!   local clocks are inquired during it; aperiodic clocks' next intervals asked after it.
//! - **Event iteration**: `newDiscreteStates` until no new discrete states are needed; a
//!   terminate request ends the run (its rows up to then are kept).
//! - **Jacobian**: from `fmi2GetDirectionalDerivative` when the FMU provides directional
//!   derivatives (one seed per group of states whose columns do not overlap by the declared
//!   dependencies, [`ColumnGroups`]; one per state without them), otherwise forward
//!   differences by the integrator.
//! - **Recording**: at the start, every output point, and (with `record_events`) before and after
//!   every event at the same time, as FMPy's `simulate_fmu(record_events=True)` does.

pub mod clocks;
pub mod fmi2;
pub mod fmi3;

use crate::error::{HostError, Result, Status};
use crate::watch::{self, Call};
use nalgebra::DMatrix;
use ode::{Integrator, OdeSystem};
use std::cell::RefCell;

/// Width of the located bracket of a state event, relative to `max(1, |t|)`.
pub const ROOT_TIME_TOLERANCE: f64 = 1e-12;
/// Most trial points one state event's location takes.
const MAX_ROOT_ITERATIONS: usize = 200;
/// Most event iterations (`newDiscreteStates` calls) at one time before the FMU is taken to
/// loop without end.
const MAX_EVENT_ITERATIONS: usize = 10_000;
/// Most events at one time instant in a row (an event that re-triggers itself).
pub(crate) const MAX_EVENTS_AT_ONE_TIME: usize = 1_000;

/// The events at one time so far, so that an event that triggers itself again ends the run
/// with an error rather than looping (both interfaces' event loops count with it).
#[derive(Clone, Copy, Debug)]
pub(crate) struct EventsAtOneTime {
    time: f64,
    count: usize,
}

impl EventsAtOneTime {
    /// None counted yet, at `t`.
    pub(crate) fn new(t: f64) -> Self {
        EventsAtOneTime { time: t, count: 0 }
    }

    /// Counts an event at `t`; more than [`MAX_EVENTS_AT_ONE_TIME`] there is an error naming
    /// the `interface`'s run.
    pub(crate) fn count(&mut self, t: f64, interface: &str) -> Result<()> {
        *self = if self.time == t {
            EventsAtOneTime {
                time: t,
                count: self.count + 1,
            }
        } else {
            EventsAtOneTime { time: t, count: 1 }
        };
        if self.count > MAX_EVENTS_AT_ONE_TIME {
            return Err(HostError::Request(format!(
                "{interface}: more than {MAX_EVENTS_AT_ONE_TIME} events at t = {t} \
                 (an event that triggers itself again)"
            )));
        }
        Ok(())
    }
}

/// What `newDiscreteStates` reports (`fmi2EventInfo`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventInfo {
    /// Another event iteration is needed.
    pub new_discrete_states_needed: bool,
    /// The FMU asks to end the simulation.
    pub terminate_simulation: bool,
    /// The nominals of the continuous states changed.
    pub nominals_changed: bool,
    /// The values of the continuous states changed.
    pub values_changed: bool,
    /// The next time event, if any.
    pub next_event_time: Option<f64>,
}

/// A vector of the continuous states' size handed to an FMU: its pointer and length.
pub(crate) trait StateSlice {
    /// `*const f64` for a vector the FMU reads, `*mut f64` for one it fills.
    type Ptr;
    /// The pointer to the first element and the number of elements.
    fn raw(self) -> (Self::Ptr, usize);
}

impl StateSlice for &[f64] {
    type Ptr = *const f64;
    fn raw(self) -> (*const f64, usize) {
        (self.as_ptr(), self.len())
    }
}

impl StateSlice for &mut [f64] {
    type Ptr = *mut f64;
    fn raw(self) -> (*mut f64, usize) {
        (self.as_mut_ptr(), self.len())
    }
}

/// The result of a derivative evaluation as the integrator takes it: `Ok(false)` where the FMU
/// answered Discard, which asks the integrator for a smaller step (FMI 2.0.4 section 3.2.2,
/// FMI 3.0.2 section 3.2.1).
pub(crate) fn derivatives_taken(result: Result<Status>) -> Result<bool> {
    match result {
        Ok(_) => Ok(true),
        Err(e) if e.status() == Some(Status::Discard) => Ok(false),
        Err(e) => Err(e),
    }
}

/// What `completedIntegratorStep` reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepOutcome {
    /// The FMU asks for an event now (a step event).
    pub enter_event_mode: bool,
    /// The FMU asks to end the simulation.
    pub terminate_simulation: bool,
}

/// What a binding knows of its FMU once bound, the same at every call.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bound {
    /// Number of continuous states.
    pub states: usize,
    /// Number of event indicators.
    pub indicators: usize,
    /// Whether `completedIntegratorStep` must be called.
    pub needs_step: bool,
    /// Per derivative, in the order of the state vector: the states (positions) it depends on
    /// as `<ModelStructure>` declares them, `None` when it declares no dependencies (it may then
    /// depend on every state).
    pub dependencies: Vec<Option<Vec<usize>>>,
}

/// The calls of a Model Exchange FMU the integration loop makes, whatever the FMI version.
/// Each marks itself in [`crate::watch`] with the call and time.
pub trait ModelExchange {
    /// What the binding knows of its FMU once bound.
    fn bound(&self) -> &Bound;
    /// Number of continuous states.
    fn states(&self) -> usize {
        self.bound().states
    }
    /// Number of event indicators.
    fn indicators(&self) -> usize {
        self.bound().indicators
    }
    /// `setTime`
    fn set_time(&mut self, t: f64) -> Result<()>;
    /// `setContinuousStates`
    fn set_states(&mut self, x: &[f64]) -> Result<()>;
    /// `getContinuousStates`
    fn get_states(&mut self, x: &mut [f64]) -> Result<()>;
    /// `getDerivatives`; `Ok(false)` when the FMU discards the point (fmi2Discard: the
    /// integrator retries with a smaller step).
    fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<bool>;
    /// `getEventIndicators`
    fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<()>;
    /// `getNominalsOfContinuousStates`
    fn get_nominals(&mut self, x: &mut [f64]) -> Result<()>;
    /// `enterEventMode`
    fn enter_event_mode(&mut self) -> Result<()>;
    /// `newDiscreteStates` (FMI 3.0: `updateDiscreteStates`)
    fn new_discrete_states(&mut self) -> Result<EventInfo>;
    /// `enterContinuousTimeMode`
    fn enter_continuous_time_mode(&mut self) -> Result<()>;
    /// `completedIntegratorStep`
    fn completed_integrator_step(&mut self) -> Result<StepOutcome>;
    /// Whether `completedIntegratorStep` must be called.
    fn needs_completed_integrator_step(&self) -> bool {
        self.bound().needs_step
    }
    /// Whether [`Self::state_derivative_seed`] is available.
    fn provides_directional_derivative(&self) -> bool;
    /// The directional derivative of the derivatives with respect to the states with the seed
    /// 1 on each state of `columns` (positions in the state vector) and 0 on the others: the
    /// sum of these columns of the Jacobian.
    fn state_derivative_seed(&mut self, columns: &[usize], out: &mut [f64]) -> Result<()>;
    /// Column `j` of the Jacobian of the derivatives with respect to the states (a directional
    /// derivative with the unit seed `e_j`).
    fn state_derivative_column(&mut self, j: usize, out: &mut [f64]) -> Result<()> {
        self.state_derivative_seed(&[j], out)
    }
    /// In Event Mode at `t`: activates the input clocks that tick now (FMI 3.0 fmi3SetClock)
    /// and returns their value references. Default: none (FMI 2.0 has no clocks).
    fn activate_clocks(&mut self, _t: f64) -> Result<Vec<u32>> {
        Ok(Vec::new())
    }
    /// In Event Mode at `t`: the output and local clocks active now (FMI 3.0 fmi3GetClock).
    /// Default: none.
    fn inquire_clocks(&mut self, _t: f64) -> Result<Vec<u32>> {
        Ok(Vec::new())
    }
    /// After the event iteration at `t` in which the input clocks `ticked` ticked: asks the
    /// FMU for the next intervals of its aperiodic clocks (FMI 3.0 fmi3GetIntervalDecimal).
    /// Default: nothing to ask.
    fn clocks_after_event(&mut self, _t: f64, _ticked: &[u32]) -> Result<()> {
        Ok(())
    }
    /// The next tick of an input clock, if any. Default: none.
    fn next_clock_tick(&self) -> Option<f64> {
        None
    }
    /// The declared dependencies of the derivatives on the states ([`Bound::dependencies`]).
    fn state_dependencies(&self) -> &[Option<Vec<usize>>] {
        &self.bound().dependencies
    }
}

/// The columns of the state Jacobian asked for together: columns whose nonzero rows (by the
/// declared dependencies) do not overlap are summed into one directional derivative and each
/// read back from its own rows (Curtis, Powell and Reid, "On the estimation of sparse Jacobian
/// matrices", IMA J. Appl. Math. 13, 1974; greedy grouping in column order). Without declared
/// dependencies every column is its own group (one call per state).
///
/// The values are the single columns' bit for bit: a row of a group's sum holds one column's
/// entry plus exact zeros of the others (the FMU declares a dependency wherever its Jacobian
/// can be nonzero, FMI 2.0.4 section 2.2.8, FMI 3.0.2 section 2.4.8).
#[derive(Clone, Debug, PartialEq)]
struct ColumnGroups {
    /// The columns of each group, each in ascending order.
    groups: Vec<Vec<usize>>,
    /// Per column, the rows where it may be nonzero (`None`: every row).
    rows: Vec<Option<Vec<usize>>>,
}

impl ColumnGroups {
    /// The groups of an `n`-state Jacobian whose row `i` depends on the columns
    /// `dependencies[i]` (`None`: on every column).
    fn new(n: usize, dependencies: &[Option<Vec<usize>>]) -> Self {
        // without a list per row nothing is known: every column may be nonzero everywhere
        let known = dependencies.len() == n;
        let mut rows: Vec<Option<Vec<usize>>> = vec![known.then(Vec::new); n];
        for (i, deps) in dependencies.iter().enumerate().filter(|_| known) {
            match deps {
                Some(deps) if deps.iter().all(|&j| j < n) => {
                    for &j in deps {
                        if let Some(r) = rows[j].as_mut().filter(|r| r.last() != Some(&i)) {
                            r.push(i);
                        }
                    }
                }
                // a row that may depend on every column: every column may be nonzero there
                _ => rows.iter_mut().for_each(|r| *r = None),
            }
        }
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut taken: Vec<Vec<bool>> = Vec::new();
        for (j, r) in rows.iter().enumerate() {
            let Some(r) = r else {
                groups.push(vec![j]);
                taken.push(vec![true; n]);
                continue;
            };
            match taken.iter().position(|t| r.iter().all(|&i| !t[i])) {
                Some(g) => {
                    groups[g].push(j);
                    r.iter().for_each(|&i| taken[g][i] = true);
                }
                None => {
                    let mut t = vec![false; n];
                    r.iter().for_each(|&i| t[i] = true);
                    groups.push(vec![j]);
                    taken.push(t);
                }
            }
        }
        ColumnGroups { groups, rows }
    }
}

/// What the run does besides calling the FMU: inputs and recording.
pub trait Environment<M> {
    /// Sets the continuous inputs at `t` (allowed in Continuous-Time Mode).
    fn apply_continuous_inputs(&mut self, fmu: &mut M, t: f64) -> Result<()>;
    /// Sets every input to its value just after `t`, a jump there taken (in Event Mode).
    fn apply_inputs_after_event(&mut self, fmu: &mut M, t: f64) -> Result<()>;
    /// The first time after `t` at which a discrete input changes (infinite: none).
    fn next_input_event(&self, t: f64) -> f64;
    /// Records the outputs at `t`.
    fn record(&mut self, fmu: &mut M, t: f64) -> Result<()>;
    /// While the clocks `clocks` are active (Event Mode, before an update of the event
    /// iteration): the variables they clock can be read now only (FMI 3.0.2 section 2.2.8.3).
    fn clocks_active(&mut self, _fmu: &mut M, _clocks: &[u32]) -> Result<()> {
        Ok(())
    }
}

/// The grid and tolerance of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Start time (the FMU is initialized there).
    pub start: f64,
    /// Stop time.
    pub stop: f64,
    /// Output interval: rows at `start + k * interval`.
    pub interval: f64,
    /// Relative tolerance; the absolute one is it times each state's nominal.
    pub rtol: f64,
    /// Also record before and after each event.
    pub record_events: bool,
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ending {
    /// At the stop time.
    Stop,
    /// The FMU asked to terminate at this time.
    Terminated(f64),
}

/// `math.isclose` with its default relative tolerance 1e-9, as FMPy compares times.
pub(crate) fn isclose(a: f64, b: f64) -> bool {
    a == b || (a.is_finite() && b.is_finite() && (a - b).abs() <= 1e-9 * a.abs().max(b.abs()))
}

/// Runs the loop from the Event Mode the FMU is in after initialization to the stop time.
pub fn run<M: ModelExchange, E: Environment<M>>(
    fmu: &mut M,
    env: &mut E,
    s: &Settings,
) -> Result<Ending> {
    let _integration = watch::enter(Call::HostIntegration, Some(s.start));
    let mut time = s.start;
    let info = event_mode(fmu, env, time)?;
    if info.terminate_simulation {
        env.record(fmu, time)?;
        return Ok(Ending::Terminated(time));
    }
    let mut next_event_time = info.next_event_time;
    fmu.enter_continuous_time_mode()?;
    let n = fmu.states();
    let mut x = vec![0.0; n];
    fmu.get_states(&mut x)?;
    let jacobian = fmu
        .provides_directional_derivative()
        .then(|| ColumnGroups::new(n, fmu.state_dependencies()));
    let mut integrator = Integrator::new(s.rtol, absolute_tolerances(fmu, s.rtol)?);
    // CVode's limit in FMPy's ME run: no step beyond a fiftieth of the interval.
    integrator.set_max_step((s.stop - s.start) / 50.0);
    let mut n_steps: u64 = 0;
    let mut next_regular = time;
    let mut events_here = EventsAtOneTime::new(time);
    loop {
        if s.record_events || isclose(time, next_regular) {
            env.record(fmu, time)?;
        }
        if time > s.stop || isclose(time, s.stop) {
            return Ok(Ending::Stop);
        }
        next_regular = s.start + (n_steps + 1) as f64 * s.interval;
        let mut target = next_regular;
        let input_event_time = env.next_input_event(time);
        if target > input_event_time && !isclose(target, input_event_time) {
            target = input_event_time;
        }
        if let Some(te) = next_event_time {
            if target > te && !isclose(target, te) {
                target = te;
            }
        }
        if target > s.stop && !isclose(target, s.stop) {
            target = s.stop;
        }
        let seg = integrate_segment(
            (fmu, env),
            &mut integrator,
            jacobian.as_ref(),
            (time, target),
            &mut x,
        )?;
        time = seg.time;
        fmu.set_time(time)?;
        env.apply_continuous_inputs(fmu, time)?;
        if isclose(time, next_regular) {
            n_steps += 1;
        }
        if seg.terminate {
            return Ok(Ending::Terminated(time));
        }
        let reached = seg.time == target;
        let input_event = reached && isclose(target, input_event_time);
        let time_event = reached && next_event_time.is_some_and(|te| isclose(target, te));
        if !(input_event || time_event || seg.state_event || seg.step_event) {
            continue;
        }
        events_here.count(time, "Model Exchange")?;
        if s.record_events {
            env.record(fmu, time)?;
        }
        fmu.enter_event_mode()?;
        if input_event {
            env.apply_inputs_after_event(fmu, time)?;
        }
        let info = event_mode(fmu, env, time)?;
        if info.terminate_simulation {
            return Ok(Ending::Terminated(time));
        }
        next_event_time = info.next_event_time;
        fmu.enter_continuous_time_mode()?;
        if info.values_changed {
            fmu.get_states(&mut x)?;
        }
        if info.nominals_changed {
            integrator.set_tolerances(s.rtol, absolute_tolerances(fmu, s.rtol)?);
        }
        // The right-hand side may jump at an event: the step size starts anew.
        integrator.reset_step_size();
    }
}

/// The Event Mode at `t` once entered: the input clocks due set active, the event iteration,
/// the next intervals of aperiodic clocks; again while an aperiodic clock ticks at `t` once more
/// (its next interval 0, FMI 3.0.2 section 2.3.5). The next time event is the FMU's or the next
/// clock tick, whichever comes first (section 2.3.5: time events are announced "through the
/// arguments of fmi3GetShift and fmi3GetInterval" too).
fn event_mode<M: ModelExchange, E: Environment<M>>(
    fmu: &mut M,
    env: &mut E,
    t: f64,
) -> Result<EventInfo> {
    let (mut values_changed, mut nominals_changed) = (false, false);
    let mut ticked = fmu.activate_clocks(t)?;
    for _ in 0..MAX_EVENTS_AT_ONE_TIME {
        let info = event_iteration(fmu, env, t, &ticked)?;
        values_changed |= info.values_changed;
        nominals_changed |= info.nominals_changed;
        let merged = EventInfo {
            values_changed,
            nominals_changed,
            ..info
        };
        if info.terminate_simulation {
            return Ok(merged);
        }
        fmu.clocks_after_event(t, &ticked)?;
        ticked = fmu.activate_clocks(t)?;
        if ticked.is_empty() {
            let next = [info.next_event_time, fmu.next_clock_tick()];
            return Ok(EventInfo {
                next_event_time: next.into_iter().flatten().reduce(f64::min),
                ..merged
            });
        }
    }
    Err(HostError::Request(format!(
        "Model Exchange: clocks ticked more than {MAX_EVENTS_AT_ONE_TIME} times at t = {t} \
         (an aperiodic clock whose next interval stays 0)"
    )))
}

/// Before each `newDiscreteStates` of an event iteration, and once after it: lets the
/// environment read what the active clocks clock, the input clocks `ticked` (active until the
/// first call deactivates them) and the output and local clocks active then (FMI 3.0
/// fmi3GetClock; FMI 3.0.2 section 2.2.8.3: clocked variables "can be queried only when their
/// Clock is active").
fn read_clocked<M: ModelExchange, E: Environment<M>>(
    fmu: &mut M,
    env: &mut E,
    t: f64,
    ticked: &[u32],
) -> Result<()> {
    let mut active = fmu.inquire_clocks(t)?;
    active.extend_from_slice(ticked);
    if active.is_empty() {
        return Ok(());
    }
    env.clocks_active(fmu, &active)
}

/// `newDiscreteStates` until no further iteration is needed or the FMU asks to terminate, the
/// clocked variables read before each call ([`read_clocked`]).
/// The states' values and nominals changed when any call of the iteration says so (FMI 2.0.4
/// section 3.2.4's pseudocode: `valuesOfContinuousStatesChanged = valuesOfContinuousStatesChanged
/// or eventInfo.valuesOfContinuousStatesChanged`, the same for the nominals): an FMU may
/// re-initialize a state in the first call and report no change in the last.
fn event_iteration<M: ModelExchange, E: Environment<M>>(
    fmu: &mut M,
    env: &mut E,
    t: f64,
    ticked: &[u32],
) -> Result<EventInfo> {
    let (mut values_changed, mut nominals_changed) = (false, false);
    let mut ticked = ticked;
    for _ in 0..MAX_EVENT_ITERATIONS {
        read_clocked(fmu, env, t, ticked)?;
        ticked = &[];
        let info = fmu.new_discrete_states()?;
        values_changed |= info.values_changed;
        nominals_changed |= info.nominals_changed;
        if !info.new_discrete_states_needed || info.terminate_simulation {
            read_clocked(fmu, env, t, &[])?;
            return Ok(EventInfo {
                values_changed,
                nominals_changed,
                ..info
            });
        }
    }
    Err(HostError::Request(format!(
        "Model Exchange: the event iteration did not converge in {MAX_EVENT_ITERATIONS} \
         calls of newDiscreteStates"
    )))
}

/// `rtol * |nominal_i|` for each state (CVode's choice in FMPy), nominals that are not positive
/// and finite taken as 1.
fn absolute_tolerances<M: ModelExchange>(fmu: &mut M, rtol: f64) -> Result<Vec<f64>> {
    let mut nominal = vec![1.0; fmu.states()];
    if !nominal.is_empty() {
        fmu.get_nominals(&mut nominal)?;
    }
    Ok(nominal
        .into_iter()
        .map(|v| {
            let v = v.abs();
            rtol * if v > 0.0 && v.is_finite() { v } else { 1.0 }
        })
        .collect())
}

/// Where an integration segment ended.
struct Segment {
    time: f64,
    state_event: bool,
    step_event: bool,
    terminate: bool,
}

/// The FMU and its environment as an [`OdeSystem`]: the right-hand side sets time, continuous
/// inputs and states and gets the derivatives. The first error is kept (the FMU is not called
/// again) and NaN returned, which stops the integrator.
struct System<'m, M, E> {
    inner: RefCell<(&'m mut M, &'m mut E)>,
    error: RefCell<Option<HostError>>,
    n: usize,
    /// The columns asked for together when the FMU provides directional derivatives.
    directional: Option<&'m ColumnGroups>,
    /// The point the FMU was last set to through this system (time bits, states), `None` before
    /// the first: a call at the same time does not set time and inputs again, one at the same
    /// states not the states (the integrator asks the Jacobian at the point of its last
    /// right-hand side, and several stages of a step at one time). Only this system calls the
    /// FMU while it integrates, and none of the calls it makes changes time, inputs or states.
    at: RefCell<(Option<u64>, Vec<f64>)>,
}

impl<M: ModelExchange, E: Environment<M>> System<'_, M, E> {
    fn failed(&self) -> bool {
        self.error.borrow().is_some()
    }

    fn keep(&self, e: HostError) {
        self.error.borrow_mut().get_or_insert(e);
    }

    /// Sets `(t, y)` and the continuous inputs at `t`, each unless the FMU is there already.
    fn set_point(&self, t: f64, y: &[f64]) -> Result<()> {
        let mut guard = self.inner.borrow_mut();
        let (fmu, env) = &mut *guard;
        let mut at = self.at.borrow_mut();
        let (time, states) = &mut *at;
        if *time != Some(t.to_bits()) {
            // forgotten first: a failed call leaves the FMU's point unknown
            *time = None;
            fmu.set_time(t)?;
            env.apply_continuous_inputs(fmu, t)?;
            *time = Some(t.to_bits());
        }
        let same = states.len() == y.len()
            && states
                .iter()
                .zip(y)
                .all(|(a, b)| a.to_bits() == b.to_bits());
        if !same {
            states.clear();
            fmu.set_states(y)?;
            states.extend_from_slice(y);
        }
        Ok(())
    }

    fn derivatives(&self, t: f64, y: &[f64], dydt: &mut [f64]) -> Result<bool> {
        self.set_point(t, y)?;
        self.inner.borrow_mut().0.get_derivatives(dydt)
    }

    fn indicators(&self, t: f64, y: &[f64], z: &mut [f64]) -> Result<()> {
        self.set_point(t, y)?;
        self.inner.borrow_mut().0.get_event_indicators(z)
    }
}

impl<M: ModelExchange, E: Environment<M>> OdeSystem for System<'_, M, E> {
    fn dim(&self) -> usize {
        self.n
    }

    fn rhs(&self, t: f64, y: &[f64], dydt: &mut [f64]) {
        if !self.failed() {
            match self.derivatives(t, y, dydt) {
                Ok(true) => return,
                Ok(false) => {}
                Err(e) => self.keep(e),
            }
        }
        dydt.iter_mut().for_each(|v| *v = f64::NAN);
    }

    fn jacobian(&self, t: f64, y: &[f64], jac: &mut DMatrix<f64>) -> bool {
        let Some(plan) = self.directional.filter(|_| !self.failed()) else {
            return false;
        };
        if self.n == 0 {
            return true;
        }
        let n = self.n;
        let columns = (|| -> Result<()> {
            self.set_point(t, y)?;
            let mut guard = self.inner.borrow_mut();
            // DMatrix is column-major: column j is the contiguous slice [j n, (j + 1) n).
            let jac = jac.as_mut_slice();
            for group in &plan.groups {
                if let [j] = group[..] {
                    guard
                        .0
                        .state_derivative_seed(group, &mut jac[j * n..(j + 1) * n])?;
                    continue;
                }
                let (first, rest) = (group[0], &group[1..]);
                let (sum, _) = jac[first * n..].split_at_mut(n);
                guard.0.state_derivative_seed(group, sum)?;
                for &j in rest {
                    let (head, tail) = jac.split_at_mut(j * n);
                    let (sum, column) = (&head[first * n..(first + 1) * n], &mut tail[..n]);
                    column.fill(0.0);
                    for &i in plan.rows[j].iter().flatten() {
                        column[i] = sum[i];
                    }
                }
                // the first column keeps its own rows of the sum
                let keep = plan.rows[first].as_deref().unwrap_or(&[]);
                let column = &mut jac[first * n..(first + 1) * n];
                let mut k = 0;
                for (i, v) in column.iter_mut().enumerate() {
                    if keep.get(k) == Some(&i) {
                        k += 1;
                    } else {
                        *v = 0.0;
                    }
                }
            }
            Ok(())
        })();
        match columns {
            Ok(()) => true,
            Err(e) => {
                self.keep(e);
                jac.fill(f64::NAN);
                true
            }
        }
    }
}

/// Domain of each event indicator: `Some(z > 0)`, or None for an indicator exactly 0 (after an
/// event) until it leaves 0.
fn domains(z: &[f64], before: &[Option<bool>]) -> Vec<Option<bool>> {
    z.iter()
        .zip(before)
        .map(|(&v, &b)| {
            if v == 0.0 {
                b.filter(|p| !p)
            } else {
                Some(v > 0.0)
            }
        })
        .collect()
}

/// Indices whose domain changed from `before` to the values `z`.
fn crossed(before: &[Option<bool>], z: &[f64]) -> Vec<usize> {
    before
        .iter()
        .zip(z)
        .enumerate()
        .filter_map(|(i, (b, &v))| match b {
            Some(p) if (v > 0.0) != *p => Some(i),
            _ => None,
        })
        .collect()
}

/// The last accepted point before a state event, and the first after it.
struct Bracket {
    ta: f64,
    ya: Vec<f64>,
    za: Vec<f64>,
    tb: f64,
    yb: Vec<f64>,
    zb: Vec<f64>,
}

/// Integrates from `t0` towards `t1`, checking the event indicators and calling
/// `completedIntegratorStep` after every accepted step; a state event is located.
fn integrate_segment<M: ModelExchange, E: Environment<M>>(
    (fmu, env): (&mut M, &mut E),
    integrator: &mut Integrator,
    directional: Option<&ColumnGroups>,
    (t0, t1): (f64, f64),
    x: &mut [f64],
) -> Result<Segment> {
    let nz = fmu.indicators();
    let needs_step = fmu.needs_completed_integrator_step();
    let n = x.len();
    let sys = System {
        inner: RefCell::new((fmu, env)),
        error: RefCell::new(None),
        n,
        directional,
        at: RefCell::new((None, Vec::with_capacity(n))),
    };
    let mut z = vec![0.0; nz];
    if nz > 0 {
        sys.indicators(t0, x, &mut z)?;
    }
    let mut domain = domains(&z, &vec![None; nz]);
    let (mut ta, mut ya, mut za) = (t0, x.to_vec(), z.clone());
    let mut bracket = None;
    let mut step = StepOutcome::default();
    let mut observe = |t: f64, y: &[f64]| {
        if sys.failed() {
            return true;
        }
        let checked = (|| -> Result<bool> {
            if nz > 0 {
                sys.indicators(t, y, &mut z)?;
                if !crossed(&domain, &z).is_empty() {
                    bracket = Some(Bracket {
                        ta,
                        ya: ya.clone(),
                        za: za.clone(),
                        tb: t,
                        yb: y.to_vec(),
                        zb: z.clone(),
                    });
                    return Ok(true);
                }
                domain = domains(&z, &domain);
            }
            if needs_step {
                sys.set_point(t, y)?;
                step = sys.inner.borrow_mut().0.completed_integrator_step()?;
                if step.enter_event_mode || step.terminate_simulation {
                    return Ok(true);
                }
            }
            (ta, za) = (t, z.clone());
            ya.copy_from_slice(y);
            Ok(false)
        })();
        checked.unwrap_or_else(|e| {
            sys.keep(e);
            true
        })
    };
    let observed = if n == 0 {
        // Without continuous states the integrator takes no step, yet the event indicators move
        // with time (FMI 2.0.4 section 3.1: a state event is a change of an indicator's domain
        // between two points of the integration): the segment's end is observed once.
        observe(t1, x);
        Ok(t1)
    } else {
        integrator.integrate_observed(&sys, t0, t1, x, observe)
    };
    if let Some(e) = sys.error.borrow_mut().take() {
        return Err(e);
    }
    let mut reached = observed.map_err(|e| ode_error(e, t0))?;
    let mut state_event = false;
    if let Some(b) = bracket {
        let (t, y) = locate(&sys, integrator, &domain, b)?;
        reached = t;
        x.copy_from_slice(&y);
        state_event = true;
        sys.set_point(t, &y)?;
        if needs_step {
            step = sys.inner.borrow_mut().0.completed_integrator_step()?;
        }
    } else {
        sys.set_point(reached, x)?;
    }
    Ok(Segment {
        time: reached,
        state_event,
        step_event: step.enter_event_mode,
        terminate: step.terminate_simulation,
    })
}

fn ode_error(e: ode::OdeError, t0: f64) -> HostError {
    HostError::Request(format!(
        "Model Exchange integration from t = {t0} failed: {e}"
    ))
}

/// Locates the first change of domain in `b` (Illinois regula falsi on the indicator whose
/// linear estimate comes first, every trial point integrated from the bracket's left end).
/// Returns the bracket's right end once it is narrow enough: the indicator has changed there.
fn locate<M: ModelExchange, E: Environment<M>>(
    sys: &System<'_, M, E>,
    integrator: &Integrator,
    domain: &[Option<bool>],
    mut b: Bracket,
) -> Result<(f64, Vec<f64>)> {
    let mut z = vec![0.0; b.za.len()];
    // Illinois: the retained end's value is halved when the same end is kept twice in a row.
    let (mut wa, mut wb) = (1.0, 1.0);
    let mut last_kept = 0i8;
    for _ in 0..MAX_ROOT_ITERATIONS {
        let width = b.tb - b.ta;
        if width <= ROOT_TIME_TOLERANCE * b.tb.abs().max(1.0) {
            break;
        }
        let i = first_crossing(domain, &b);
        let (fa, fb) = (wa * b.za[i], wb * b.zb[i]);
        let mut t = if fa != fb {
            b.ta - fa * width / (fb - fa)
        } else {
            f64::NAN
        };
        if !(t > b.ta && t < b.tb) {
            t = b.ta + 0.5 * width;
            if !(t > b.ta && t < b.tb) {
                break;
            }
        }
        let mut y = b.ya.clone();
        let mut trial = integrator.clone();
        trial
            .integrate(sys, b.ta, t, &mut y)
            .map_err(|e| ode_error(e, b.ta))?;
        if let Some(e) = sys.error.borrow_mut().take() {
            return Err(e);
        }
        sys.indicators(t, &y, &mut z)?;
        if crossed(domain, &z).is_empty() {
            (b.ta, b.ya, b.za) = (t, y, z.clone());
            wa = 1.0;
            wb = if last_kept == 1 { wb * 0.5 } else { 1.0 };
            last_kept = 1;
        } else {
            (b.tb, b.yb, b.zb) = (t, y, z.clone());
            wb = 1.0;
            wa = if last_kept == -1 { wa * 0.5 } else { 1.0 };
            last_kept = -1;
        }
    }
    Ok((b.tb, b.yb))
}

/// The changed indicator whose linear interpolation over the bracket crosses first.
fn first_crossing(domain: &[Option<bool>], b: &Bracket) -> usize {
    let mut best = (f64::INFINITY, 0);
    for i in crossed(domain, &b.zb) {
        let (za, zb) = (b.za[i], b.zb[i]);
        let s = if za != zb { za / (za - zb) } else { 0.0 };
        if s < best.0 {
            best = (s, i);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::{crossed, domains, isclose, ColumnGroups};

    #[test]
    fn an_indicator_leaving_zero_after_an_event_is_no_crossing() {
        let d = domains(&[0.0, 1.0, -1.0], &[None, None, None]);
        assert_eq!(d, vec![None, Some(true), Some(false)]);
        // 0 -> positive: adopted, not crossed; positive -> 0 and negative -> positive: crossed
        assert!(crossed(&d, &[0.5, 1.0, -1.0]).is_empty());
        assert_eq!(crossed(&d, &[0.5, 0.0, 2.0]), vec![1, 2]);
        // negative -> 0 stays in the domain z <= 0
        assert!(crossed(&d, &[0.0, 1.0, 0.0]).is_empty());
        assert_eq!(domains(&[0.0, 0.0, 0.0], &d), vec![None, None, Some(false)]);
    }

    #[test]
    fn columns_without_common_rows_are_asked_together() {
        // rows: 0 <- {0, 1}, 1 <- {1}, 2 <- {2}, 3 <- {} ; columns: 0 -> {0}, 1 -> {0, 1},
        // 2 -> {2}, 3 -> {}
        let deps = [Some(vec![0, 1]), Some(vec![1]), Some(vec![2]), Some(vec![])];
        let g = ColumnGroups::new(4, &deps);
        assert_eq!(g.groups, vec![vec![0, 2, 3], vec![1]]);
        assert_eq!(
            g.rows,
            vec![Some(vec![0]), Some(vec![0, 1]), Some(vec![2]), Some(vec![])]
        );
        // a row without declared dependencies, or no lists at all: one column per call
        let dense = ColumnGroups::new(3, &[Some(vec![0]), None, Some(vec![2])]);
        assert_eq!(dense.groups, vec![vec![0], vec![1], vec![2]]);
        assert!(dense.rows.iter().all(Option::is_none));
        assert_eq!(ColumnGroups::new(2, &[]).groups, vec![vec![0], vec![1]]);
        // a dependency outside the state vector is not trusted either
        assert_eq!(
            ColumnGroups::new(2, &[Some(vec![5]), Some(vec![])]).groups,
            vec![vec![0], vec![1]]
        );
    }

    #[test]
    fn isclose_is_relative() {
        assert!(isclose(1.0, 1.0 + 1e-12));
        assert!(!isclose(1.0, 1.0 + 1e-6));
        assert!(isclose(0.0, 0.0));
        assert!(!isclose(1.0, f64::INFINITY));
    }
}
