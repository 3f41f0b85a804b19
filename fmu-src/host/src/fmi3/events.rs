//! Co-Simulation with Event Mode (`eventModeUsed = true`), which a run uses for an FMU with
//! clocks (FMI 3.0.2 section 2.3.1: "For FMUs that have clocks, eventModeUsed = fmi3True is
//! required"; section 4.2).
//!
//! After fmi3ExitInitializationMode the FMU is in Event Mode (section 2.3.3). In every Event
//! Mode the run sets the input clocks due active (fmi3SetClock), calls fmi3UpdateDiscreteStates
//! until no discrete state needs an update, reading the variables of the active clocks before
//! each call (output and local clocks inquired with fmi3GetClock), asks the aperiodic clocks'
//! next intervals (see [`crate::me::clocks`]) and returns to Step Mode with fmi3EnterStepMode.
//!
//! A communication step ends at the next output point, the next clock tick, the FMU's
//! `nextEventTime` or the next input event (a held input changing), whichever comes first
//! (section 4.2.1, fmi3EnterEventMode: the importer enters Event Mode when "time has reached
//! nextEventTime", "the importer plans discrete changes to inputs" or "an input Clock needs to
//! be set"); the held inputs are set in that Event Mode, the interpolated ones before each step.
//! After a step the run enters Event Mode there and when fmi3DoStep returned
//! `eventHandlingNeeded`, at the time reached: `lastSuccessfulTime` after an early return,
//! which the run allows when the FMU declares `mightReturnEarlyFromDoStep`, the step's end
//! otherwise. Rows are recorded at the output points, after the events there.

use super::ffi::{update_discrete_states, DiscreteUpdate3};
use super::instance::Instance3;
use super::simulate::{InputPlan3, Recorder3};
use crate::error::{HostError, Result};
use crate::me::clocks::ClockSchedule;
use crate::me::{isclose, EventsAtOneTime, MAX_EVENTS_AT_ONE_TIME};
use crate::run::{Inputs, Outputs};
use crate::watch::{self, Call};

/// Most fmi3UpdateDiscreteStates calls of one event iteration.
const MAX_EVENT_ITERATIONS: usize = 10_000;

impl Instance3<'_> {
    fn events(&self) -> Result<crate::fmi3::ffi::Events3> {
        self.fmu.functions.events.ok_or_else(|| {
            HostError::Request(
                "the FMU binary does not export fmi3EnterEventMode and fmi3UpdateDiscreteStates"
                    .into(),
            )
        })
    }

    /// fmi3EnterEventMode (from Step Mode).
    fn enter_event_mode(&mut self, t: f64) -> Result<()> {
        let f = self.events()?.enter_event_mode;
        let _w = watch::enter3(Call::EnterEventMode, Some(t));
        // SAFETY: live instance.
        let raw = unsafe { f(self.instance) };
        self.check("fmi3EnterEventMode", raw).map(drop)
    }

    /// fmi3EnterStepMode (from Event Mode).
    fn enter_step_mode(&mut self, t: f64) -> Result<()> {
        let f = self.events()?.enter_step_mode.ok_or_else(|| {
            HostError::Request("the FMU binary does not export fmi3EnterStepMode".into())
        })?;
        let _w = watch::enter3(Call::Other, Some(t));
        // SAFETY: live instance.
        let raw = unsafe { f(self.instance) };
        self.check("fmi3EnterStepMode", raw).map(drop)
    }

    /// fmi3UpdateDiscreteStates.
    fn update_discrete_states(&mut self, t: f64) -> Result<DiscreteUpdate3> {
        let f = self.events()?.update_discrete_states;
        let (raw, update) = update_discrete_states(f, self.instance, t);
        self.check("fmi3UpdateDiscreteStates", raw)?;
        Ok(update)
    }
}

/// The clocks and the recorder a run's Event Modes work with.
struct EventContext<'r> {
    clocks: ClockSchedule,
    rec: &'r mut Recorder3,
}

impl EventContext<'_> {
    /// One Event Mode at `t` (entered): clocks due set, event iteration, next intervals; again
    /// while an aperiodic clock ticks at `t` once more. Returns the last update, its next event
    /// time the FMU's or the next clock tick, whichever comes first.
    fn event_mode(&mut self, inst: &mut Instance3<'_>, t: f64) -> Result<DiscreteUpdate3> {
        let mut ticked = self.activate_due(inst, t)?;
        for _ in 0..MAX_EVENTS_AT_ONE_TIME {
            let update = self.iterate(inst, t, &ticked)?;
            if update.terminate {
                return Ok(update);
            }
            self.clocks.after_event(inst, t, &ticked)?;
            ticked = self.activate_due(inst, t)?;
            if ticked.is_empty() {
                let next = [update.next_event_time, self.clocks.next_tick()];
                return Ok(DiscreteUpdate3 {
                    next_event_time: next.into_iter().flatten().reduce(f64::min),
                    ..update
                });
            }
        }
        Err(HostError::Request(format!(
            "Co-Simulation: clocks ticked more than {MAX_EVENTS_AT_ONE_TIME} times at t = {t} \
             (an aperiodic clock whose next interval stays 0)"
        )))
    }

    /// Enters Event Mode at `t` for the events there; the inputs after their jump at `t` when
    /// it is an input event (`inputs`), then [`Self::event_mode`].
    fn events_at(
        &mut self,
        inst: &mut Instance3<'_>,
        t: f64,
        inputs: Option<&mut InputPlan3<'_>>,
    ) -> Result<DiscreteUpdate3> {
        inst.enter_event_mode(t)?;
        if let Some(inputs) = inputs {
            inputs.apply_after(inst, t)?;
        }
        self.event_mode(inst, t)
    }

    fn activate_due(&mut self, inst: &mut Instance3<'_>, t: f64) -> Result<Vec<u32>> {
        let due = self.clocks.due(t);
        if !due.is_empty() {
            ClockSchedule::activate(inst, &due, t)?;
        }
        Ok(due)
    }

    /// fmi3UpdateDiscreteStates until no discrete state needs an update, the clocked variables
    /// read before each call and after the last (FMI 3.0.2 section 2.2.8.3: they "can be
    /// queried only when their Clock is active"; section 2.3.5: the FMU deactivates its clocks
    /// in fmi3UpdateDiscreteStates).
    fn iterate(
        &mut self,
        inst: &mut Instance3<'_>,
        t: f64,
        ticked: &[u32],
    ) -> Result<DiscreteUpdate3> {
        let mut ticked = ticked;
        for _ in 0..MAX_EVENT_ITERATIONS {
            self.read_clocked(inst, t, ticked)?;
            ticked = &[];
            let update = inst.update_discrete_states(t)?;
            if !update.needed || update.terminate {
                self.read_clocked(inst, t, &[])?;
                return Ok(update);
            }
        }
        Err(HostError::Request(format!(
            "Co-Simulation: the event iteration at t = {t} did not converge in \
             {MAX_EVENT_ITERATIONS} calls of fmi3UpdateDiscreteStates"
        )))
    }

    fn read_clocked(&mut self, inst: &mut Instance3<'_>, t: f64, ticked: &[u32]) -> Result<()> {
        let mut active = self.clocks.inquire(inst, t)?;
        active.extend_from_slice(ticked);
        if active.is_empty() {
            return Ok(());
        }
        self.rec.clocks_active(inst, &active)
    }
}

/// Steps in a row that returned early without advancing.
struct Stalls(usize);

impl Stalls {
    /// Counts a step from `from` that reached `to`; more than [`MAX_EVENTS_AT_ONE_TIME`] in a
    /// row without advancing is an error (an FMU that keeps returning early where it is).
    fn count(&mut self, from: f64, to: f64) -> Result<()> {
        self.0 = if to == from { self.0 + 1 } else { 0 };
        if self.0 > MAX_EVENTS_AT_ONE_TIME {
            return Err(HostError::Request(format!(
                "Co-Simulation: fmi3DoStep returned early at t = {to} more than \
                 {MAX_EVENTS_AT_ONE_TIME} times without advancing"
            )));
        }
        Ok(())
    }
}

/// The end of the step from `time`: the next output point `next_regular`, else the first of
/// the events the run knows of (`known`: the FMU's next event time, a clock tick, an input
/// event) after `time` and before it.
fn step_end(time: f64, next_regular: f64, known: [Option<f64>; 3]) -> f64 {
    let mut target = next_regular;
    for te in known.into_iter().flatten() {
        if te < target && !isclose(te, target) && te > time {
            target = te;
        }
    }
    target
}

/// Steps `inst` (initialized with Event Mode, in Event Mode) through the output points `times`
/// with the clocks of `clocks`, recording at each as the step reaches it (before the events
/// there): the recorded times and, when the FMU ended the run, the last of them.
pub(crate) fn run(
    inst: &mut Instance3<'_>,
    times: &[f64],
    inputs: &mut InputPlan3<'_>,
    rec: &mut Recorder3,
    clocks: ClockSchedule,
) -> Result<(Vec<f64>, Option<f64>)> {
    let mut ctx = EventContext { clocks, rec };
    let mut rows = Vec::with_capacity(times.len());
    let start = times[0];
    let mut update = ctx.event_mode(inst, start)?;
    ctx.rec.record(inst)?;
    rows.push(start);
    if update.terminate {
        return Ok((rows, Some(start)));
    }
    inst.enter_step_mode(start)?;
    let early_allowed = inst.fmu().early_return_allowed();
    let (mut time, mut k) = (start, 0);
    let mut events_here = EventsAtOneTime::new(start);
    let mut stalls = Stalls(0);
    while k + 1 < times.len() {
        let next_regular = times[k + 1];
        let input_event = inputs.next_event(time);
        let known = [
            update.next_event_time,
            ctx.clocks.next_tick(),
            Some(input_event),
        ];
        let target = step_end(time, next_regular, known);
        if time > start {
            // held inputs change at input events only, in Event Mode
            inputs.apply_some(inst, time, true, false)?;
        }
        let out = inst.do_step(time, target - time, true)?;
        let last = out.last_successful_time;
        if out.terminate {
            if last > time && last.is_finite() {
                ctx.rec.record(inst)?;
                rows.push(last.min(target));
            }
            let ended = *rows.last().unwrap_or(&time);
            return Ok((rows, Some(ended)));
        }
        let early = early_allowed && out.early_return && last >= time && last < target;
        let reached = if early { last } else { target };
        stalls.count(time, reached)?;
        time = reached;
        // An output point is recorded as the step reached it, before the events there are
        // handled, as FMPy's simulate_fmu records (after fmi3DoStep, before
        // fmi3EnterEventMode): a clock ticking at an output point shows in the next row.
        let regular = isclose(time, next_regular);
        if regular {
            ctx.rec.record(inst)?;
            rows.push(next_regular);
            k += 1;
        }
        let reached = |te: Option<f64>| te.is_some_and(|te| te <= time || isclose(te, time));
        let at_input_event = reached(Some(input_event));
        if out.event_handling_needed
            || at_input_event
            || reached(update.next_event_time)
            || reached(ctx.clocks.next_tick())
        {
            events_here.count(time, "Co-Simulation")?;
            update = ctx.events_at(inst, time, at_input_event.then_some(&mut *inputs))?;
            if update.terminate {
                if !regular {
                    ctx.rec.record(inst)?;
                    rows.push(time);
                }
                return Ok((rows, Some(time)));
            }
            inst.enter_step_mode(time)?;
        }
    }
    Ok((rows, None))
}
