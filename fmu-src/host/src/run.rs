//! One simulation run of either FMI version, written once against the interfaces its binding
//! implements (as rust-fmi's `fmi-sim` is generic over its version traits):
//!
//! - [`CoSimulationStep`]: the instance's communication step ([`crate::Instance`] with fmi2DoStep,
//!   [`crate::fmi3::Instance3`] with fmi3DoStep);
//! - [`Inputs`]: the run's input plan, setting the inputs at a time on the instance;
//! - [`Outputs`]: the run's recorder, reading the outputs of the instance into columns;
//! - [`ModelExchangeOf`]: a Model Exchange binding ([`ModelExchange`]) with the instance it drives.
//!
//! [`step_through`] is the Co-Simulation loop and [`integrate`] the Model Exchange one.

use crate::error::{HostError, Result};
use crate::me::{self, isclose, Ending, Environment, ModelExchange, Settings};
use crate::simulate::{hold_index, interpolate_at, MAX_RECORDED_VALUES};

/// The Co-Simulation step of an instance.
pub trait CoSimulationStep {
    /// One step from `t` by `h`: the FMU's last successful time when it ended the simulation,
    /// None when the step completed.
    fn co_simulation_step(&mut self, t: f64, h: f64) -> Result<Option<f64>>;
}

/// The inputs of a run, set on an instance `I`.
pub(crate) trait Inputs<I> {
    /// Sets the continuous (interpolated) inputs (`continuous`) and the held ones (`discrete`)
    /// to their values at `t`: Model Exchange sets the discrete inputs in Event Mode only.
    fn apply_some(&mut self, inst: &mut I, t: f64, continuous: bool, discrete: bool) -> Result<()>;

    /// The first input event after `t` (infinite: none).
    fn next_event(&self, t: f64) -> f64;

    /// Sets every input to its value at `t`.
    fn apply(&mut self, inst: &mut I, t: f64) -> Result<()> {
        self.apply_some(inst, t, true, true)
    }

    /// From now on the inputs at `t` take their values after a jump at `t` (two rows at one
    /// time: the second), as FMPy's `Input.apply(after_event=True)` after an event and at each
    /// communication point; before, the value at `t` is the one before the jump.
    fn pass_jump(&mut self, t: f64);

    /// Sets every input to its value just after `t`.
    fn apply_after(&mut self, inst: &mut I, t: f64) -> Result<()> {
        self.pass_jump(t);
        self.apply(inst, t)
    }
}

/// Where a run stands on its inputs' time axis: the row times, the input events and the
/// cursors that speed up monotone lookups.
pub(crate) struct InputAxis<'r> {
    time: &'r [f64],
    /// The input events in time order, found once (Model Exchange asks for the next one at every
    /// integration segment): a repeated row time, or a row at which a held input changes
    /// (FMPy's `Input.findEvents`).
    events: Vec<f64>,
    /// The time of the last jump passed ([`Inputs::pass_jump`]); -inf: none.
    jump_passed: f64,
    interp_cursor: usize,
    hold_cursor: usize,
}

/// A time on the input axis as the inputs are set there: the row held at `t`, whether a jump
/// at `t` has been passed (the second of two rows at one time then holds) and which inputs are
/// set (Model Exchange sets the discrete ones in Event Mode only).
pub(crate) struct InputPoint<'x> {
    axis: &'x InputAxis<'x>,
    pub t: f64,
    pub row: usize,
    after: bool,
    /// Set the continuous (interpolated) inputs.
    pub continuous: bool,
    /// Set the held inputs.
    pub discrete: bool,
    /// The interpolation cursor after the lookups: all columns share one time axis, so one
    /// cursor serves them all.
    next: usize,
}

impl InputPoint<'_> {
    /// Column `ys` here: linear between rows, the row's own value just after a jump.
    pub(crate) fn interpolate(&mut self, ys: &[f64]) -> f64 {
        self.next = self.axis.interp_cursor;
        let at = (self.row, self.after);
        interpolate_at((self.axis.time, ys), self.t, at, &mut self.next)
    }
}

impl<'r> InputAxis<'r> {
    /// The axis of row times `time`; `held_changes(k)`: whether a held input's value at row `k`
    /// differs from its value at row `k - 1`.
    pub(crate) fn new(time: &'r [f64], held_changes: impl Fn(usize) -> bool) -> Self {
        InputAxis {
            time,
            events: input_events(time, held_changes),
            jump_passed: f64::NEG_INFINITY,
            interp_cursor: 0,
            hold_cursor: 0,
        }
    }
}

/// The inputs of one FMI version, set on an instance `I`.
pub(crate) trait InputValues<I> {
    /// Sets the inputs `at` asks for to their values there.
    fn set_at(&mut self, inst: &mut I, at: &mut InputPoint<'_>) -> Result<()>;
}

/// A run's input plan: the time axis and the inputs of one version.
pub(crate) struct InputPlanOf<'r, V> {
    pub(crate) axis: InputAxis<'r>,
    pub(crate) values: V,
}

impl<I, V: InputValues<I>> Inputs<I> for InputPlanOf<'_, V> {
    fn next_event(&self, t: f64) -> f64 {
        first_event_after(&self.axis.events, t)
    }

    fn pass_jump(&mut self, t: f64) {
        self.axis.jump_passed = t;
    }

    fn apply_some(&mut self, inst: &mut I, t: f64, continuous: bool, discrete: bool) -> Result<()> {
        if self.axis.time.is_empty() {
            return Ok(());
        }
        let row = hold_index(self.axis.time, t, &mut self.axis.hold_cursor);
        let after = isclose(self.axis.jump_passed, t);
        let next = self.axis.interp_cursor;
        let axis = &self.axis;
        let mut at = InputPoint {
            axis,
            t,
            row,
            after,
            continuous,
            discrete,
            next,
        };
        let result = self.values.set_at(inst, &mut at);
        self.axis.interp_cursor = at.next;
        result
    }
}

/// The row times at which an input event happens, ascending and each once: a repeated row
/// time, or a row at which a held input changes (FMPy's `Input.findEvents`).
fn input_events(time: &[f64], held_changes: impl Fn(usize) -> bool) -> Vec<f64> {
    let mut events: Vec<f64> = (1..time.len())
        .filter(|&k| time[k - 1] == time[k] || held_changes(k))
        .map(|k| time[k])
        .collect();
    events.sort_by(f64::total_cmp);
    events.dedup();
    events
}

/// The first of the ascending event times `events` after `t`, not within 1e-9 relative of it
/// (an event at `t` itself has been handled); infinite: none.
fn first_event_after(events: &[f64], t: f64) -> f64 {
    let from = events.partition_point(|&e| e <= t);
    events[from..]
        .iter()
        .copied()
        .find(|&e| !isclose(e, t))
        .unwrap_or(f64::INFINITY)
}

/// The recorder of a run, reading an instance `I`.
pub(crate) trait Outputs<I> {
    /// Values recorded per row.
    fn width(&self) -> usize;
    /// Appends the outputs' current values as a row.
    fn record(&mut self, inst: &mut I) -> Result<()>;
    /// Reads what the active clocks `clocks` clock (in Event Mode).
    fn clocks_active(&mut self, _inst: &mut I, _clocks: &[u32]) -> Result<()> {
        Ok(())
    }
}

/// A Model Exchange binding with the instance it drives (for the inputs and the recorder).
pub(crate) trait ModelExchangeOf: ModelExchange {
    /// The instance type of the version.
    type Instance;
    /// The instance.
    fn instance(&mut self) -> &mut Self::Instance;
}

/// The communication points `times` with the input events between them added: FMPy's
/// `simulate_fmu` ends a Co-Simulation step at an input event (a jump, a held input changing)
/// when the FMU can handle a variable communication step size, and records a row there.
pub(crate) fn with_input_events<I>(times: &[f64], inputs: &impl Inputs<I>) -> Vec<f64> {
    let mut points = Vec::with_capacity(times.len());
    for w in times.windows(2) {
        points.push(w[0]);
        let mut t = w[0];
        loop {
            let event = inputs.next_event(t);
            if event >= w[1] || crate::me::isclose(event, w[1]) {
                break;
            }
            points.push(event);
            t = event;
        }
    }
    points.extend(times.last());
    points
}

/// Steps a Co-Simulation instance through the communication points `times`, recording at each:
/// the inputs are set at every point before its step (those at the start are set before
/// initialization). An FMU that ends the simulation keeps the rows up to its last successful
/// time. Returns the recorded times and, when the FMU ended the simulation, the last of them.
pub(crate) fn step_through<I: CoSimulationStep>(
    inst: &mut I,
    times: &[f64],
    inputs: &mut impl Inputs<I>,
    outputs: &mut impl Outputs<I>,
) -> Result<(Vec<f64>, Option<f64>)> {
    let mut time = Vec::with_capacity(times.len());
    outputs.record(inst)?;
    time.push(times[0]);
    for k in 0..times.len().saturating_sub(1) {
        let (t, t1) = (times[k], times[k + 1]);
        if k > 0 {
            inputs.apply_after(inst, t)?;
        }
        if let Some(last) = inst.co_simulation_step(t, t1 - t)? {
            if last > t && last.is_finite() {
                outputs.record(inst)?;
                time.push(last.min(t1));
            }
            let ended_at = *time.last().unwrap_or(&t);
            return Ok((time, Some(ended_at)));
        }
        outputs.record(inst)?;
        time.push(t1);
    }
    Ok((time, None))
}

/// The tolerance handed to the FMU (fmi2SetupExperiment, fmi3EnterInitializationMode; None:
/// `toleranceDefined = false`), as FMPy's `simulate_fmu` hands it: Co-Simulation gets the
/// requested tolerance, else the DefaultExperiment's `default_tolerance`, else none (the FMU
/// then integrates with its own). Model Exchange gets the requested tolerance only: FMPy passes
/// none there, the importer's integrator being the one the tolerance governs ([`me_settings`]);
/// a tolerance the user asks for is still handed over, since FMI 2.0.4 section 3.2.1 defines
/// `toleranceDefined = true` as "the model is called with a numerical integration scheme where
/// the step size is controlled by using tolerance", which the host's integrator then is.
pub(crate) fn fmu_tolerance(
    model_exchange: bool,
    tolerance: Option<f64>,
    default_tolerance: Option<f64>,
) -> Option<f64> {
    if model_exchange {
        tolerance
    } else {
        tolerance.or(default_tolerance)
    }
}

/// The Model Exchange settings of a run: its grid, and as relative tolerance `tolerance`, else
/// the DefaultExperiment's `default_tolerance`, else 1e-5: FMPy's `simulateME` integrates with
/// CVode at exactly these (its `relative_tolerance`, defaulting to the DefaultExperiment's, and
/// 1e-5 when that is absent), so a run without `--tolerance` meets the error FMPy's does.
pub(crate) fn me_settings(
    (start, stop, interval): (f64, f64, f64),
    tolerance: Option<f64>,
    default_tolerance: Option<f64>,
    record_events: bool,
) -> Result<Settings> {
    let rtol = tolerance.or(default_tolerance).unwrap_or(1e-5);
    if !(rtol > 0.0 && rtol.is_finite()) {
        return Err(HostError::Request(format!(
            "Model Exchange: the tolerance must be > 0, got {rtol}"
        )));
    }
    Ok(Settings {
        start,
        stop,
        interval,
        rtol,
        record_events,
    })
}

/// Integrates `fmu` (initialized, in Event Mode) with [`me::run`], setting `inputs` and
/// recording `outputs`: the recorded times and, when the FMU ended the run, its time.
pub(crate) fn integrate<M: ModelExchangeOf>(
    fmu: &mut M,
    settings: &Settings,
    inputs: &mut impl Inputs<M::Instance>,
    outputs: &mut impl Outputs<M::Instance>,
) -> Result<(Vec<f64>, Option<f64>)> {
    let mut env = Recording {
        inputs,
        outputs,
        time: Vec::new(),
    };
    let ending = me::run(fmu, &mut env, settings)?;
    Ok((
        env.time,
        match ending {
            Ending::Stop => None,
            Ending::Terminated(t) => Some(t),
        },
    ))
}

/// The inputs and the recorder of a Model Exchange run, with the times recorded.
struct Recording<'p, P, R> {
    inputs: &'p mut P,
    outputs: &'p mut R,
    time: Vec<f64>,
}

impl<M, P, R> Environment<M> for Recording<'_, P, R>
where
    M: ModelExchangeOf,
    P: Inputs<M::Instance>,
    R: Outputs<M::Instance>,
{
    fn apply_continuous_inputs(&mut self, fmu: &mut M, t: f64) -> Result<()> {
        self.inputs.apply_some(fmu.instance(), t, true, false)
    }

    fn apply_inputs_after_event(&mut self, fmu: &mut M, t: f64) -> Result<()> {
        self.inputs.apply_after(fmu.instance(), t)
    }

    fn next_input_event(&self, t: f64) -> f64 {
        self.inputs.next_event(t)
    }

    fn record(&mut self, fmu: &mut M, t: f64) -> Result<()> {
        if self.time.len() >= MAX_RECORDED_VALUES / self.outputs.width().max(1) {
            return Err(HostError::Request(format!(
                "Model Exchange: more than {} rows recorded (events at a rate the output \
                 cannot hold)",
                self.time.len()
            )));
        }
        self.outputs.record(fmu.instance())?;
        self.time.push(t);
        Ok(())
    }

    fn clocks_active(&mut self, fmu: &mut M, clocks: &[u32]) -> Result<()> {
        self.outputs.clocks_active(fmu.instance(), clocks)
    }
}
