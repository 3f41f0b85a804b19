//! The clocks of an FMI 3.0 run in Model Exchange and in Co-Simulation with Event Mode (FMI
//! 3.0.2 section 2.2.8, Clocks; table "Overview of Clock types").
//!
//! "In Model Exchange and Co-Simulation, when input Clocks tick, the importer will activate the
//! input Clocks using fmi3SetClock" (section 2.2.8.2), and fmi3EnterEventMode is called when "an
//! input Clock needs to be set" (sections 3.2.1, 4.2). The run drives the time-based input
//! clocks:
//!
//! - `constant`: interval and shift from `intervalDecimal` and `shiftDecimal` (0 when absent);
//!   without `intervalDecimal`, fmi3GetIntervalDecimal and fmi3GetShiftDecimal in
//!   Initialization Mode (the calls the table of clock types allows there);
//! - `fixed`, `tunable` with `intervalDecimal`: fmi3SetIntervalDecimal with it in
//!   Initialization Mode ("One of these functions must be called for all fixed periodic Clocks
//!   and tunable periodic Clocks", section 2.3.3); without it, fmi3GetIntervalDecimal and
//!   fmi3GetShiftDecimal there ("the importer must use fmi3GetInterval and fmi3GetShift");
//! - `changing`, `countdown` (aperiodic): the first interval `T_interval,0 >= 0` from
//!   fmi3GetIntervalDecimal in Initialization Mode, `t_0 = t_start + T_interval,0`; then
//!   fmi3GetIntervalDecimal after the event iteration of every Event Mode where a `changing`
//!   clock ticked ("if and only if this Clock ticked") and of every Event Mode for a `countdown`
//!   clock ("in every Event Mode"; section 2.3.5: "these functions should be called after
//!   fmi3UpdateDiscreteStates"). Its qualifier says what the interval means: `Changed`, the next
//!   tick is at `t_event + interval` ("The new Clock interval is relative to the time of the
//!   current Event Mode"); `Unchanged`, the tick announced before stands; `NotYetKnown`, no tick
//!   is scheduled yet.
//!
//! A periodic clock ticks at `t_0 = t_start + T_shift`, `t_i = t_(i-1) + T_interval`
//! (section 2.2.8.2, Periodic Clock), computed as `t_0 + i T_interval` so that no rounding
//! accumulates. Ticks are time events: the run enters Event Mode there and sets the clocks due
//! before the event iteration; the FMU deactivates them in fmi3UpdateDiscreteStates ("Any Clock
//! active during fmi3UpdateDiscreteStates must be deactivated by the FMU itself", section 2.3.5).
//! An aperiodic clock whose next interval is 0 ticks again in the same Event Mode (section
//! 2.3.5 allows aperiodic clocks more than one fmi3UpdateDiscreteStates per Event Mode).
//!
//! Output and local clocks are activated by the FMU; "the importer must call fmi3GetClock in
//! Event Mode" (section 2.2.8.2, triggered output and local Clocks): the run inquires them before
//! each fmi3UpdateDiscreteStates of an event iteration, while the clocks that activated them are
//! still active, and once after it, and reads the variables of the active ones.
//!
//! Triggered input clocks tick when the importer decides (section 2.2.8.2: "For triggered input
//! clocks, the timing is determined by the importer"); a `simulate` run has no source of
//! triggers, so they stay inactive. [`refusal`] refuses a clock of no kind the standard defines.

use crate::error::{HostError, Result};
use crate::ffi::function_table;
use crate::fmi3::ffi::{Bool3, RawStatus3};
use crate::fmi3::instance::Instance3;
use crate::fmi3::md::INTERVAL_VARIABILITIES;
use crate::fmi3::md::{Causality3, ModelDescription3};
use crate::fmi3::value::Type3;
use crate::watch::{self, Call};
use std::ffi::{c_int, c_void};

type I = *mut c_void;

/// `fmi3IntervalQualifier` (FMI 3.0.2 section 2.2.8.4): `fmi3IntervalNotYetKnown`.
const NOT_YET_KNOWN: c_int = 0;
/// `fmi3IntervalUnchanged`
const UNCHANGED: c_int = 1;
/// `fmi3IntervalChanged`
const CHANGED: c_int = 2;

function_table! {
    /// The clock functions a run calls (FMI 3.0.2 section 2.2.8.4); a binary exports all of them
    /// or none (section 2.5: "The FMU must implement all API functions declared in
    /// fmi3Functions.h").
    pub struct ClockFunctions3 {
        set_clock: required "fmi3SetClock"
            unsafe extern "C" fn(I, *const u32, usize, *const Bool3) -> RawStatus3,
        get_clock: required "fmi3GetClock"
            unsafe extern "C" fn(I, *const u32, usize, *mut Bool3) -> RawStatus3,
        // `(instance, vrs, n, intervals, qualifiers)`; `fmi3IntervalQualifier` is a C enum.
        get_interval_decimal: required "fmi3GetIntervalDecimal"
            unsafe extern "C" fn(I, *const u32, usize, *mut f64, *mut c_int) -> RawStatus3,
        get_shift_decimal: required "fmi3GetShiftDecimal"
            unsafe extern "C" fn(I, *const u32, usize, *mut f64) -> RawStatus3,
        set_interval_decimal: required "fmi3SetIntervalDecimal"
            unsafe extern "C" fn(I, *const u32, usize, *const f64) -> RawStatus3,
    }
    given {}
}

/// Why a run cannot drive the clocks of `md`: a Clock whose `intervalVariability` is none of
/// the kinds of FMI 3.0.2 section 2.4.7.6 (or not `triggered` for an output or local clock,
/// section 2.2.8.2: "The attribute intervalVariability must be triggered for output Clocks");
/// None when it can.
pub fn refusal(md: &ModelDescription3) -> Option<String> {
    for v in md.variables.iter().filter(|v| v.ty == Type3::Clock) {
        let kind = v.interval_variability.as_deref().unwrap_or("");
        let known = match v.causality {
            Causality3::Input => INTERVAL_VARIABILITIES.contains(&kind),
            Causality3::Output | Causality3::Local => kind == "triggered",
            _ => false,
        };
        if !known {
            return Some(format!(
                "FMI 3.0 clock '{}' ({} with intervalVariability \"{kind}\") is of no kind \
                 the standard defines (FMI 3.0.2 section 2.2.8.2, table \"Overview of Clock \
                 types\"): the run cannot tell when it ticks",
                v.name, v.causality
            ));
        }
    }
    None
}

/// One periodic input clock: it ticks at `t0 + k * interval`, `k` = 0, 1, ...
#[derive(Clone, Debug, PartialEq)]
struct Periodic {
    vr: u32,
    t0: f64,
    interval: f64,
    /// Ticks done.
    k: u64,
}

impl Periodic {
    fn next(&self) -> f64 {
        self.t0 + self.k as f64 * self.interval
    }
}

/// One aperiodic input clock and its next tick (None: not known yet).
#[derive(Clone, Debug, PartialEq)]
struct Aperiodic {
    vr: u32,
    /// `countdown` (asked in every Event Mode), else `changing` (asked when it ticked).
    countdown: bool,
    next: Option<f64>,
}

/// One triggered input clock and the times the data tick it, ascending.
#[derive(Clone, Debug, PartialEq)]
struct Triggered {
    vr: u32,
    ticks: Vec<f64>,
    /// Ticks done.
    k: usize,
}

/// The time-based input clocks of a run and their next ticks, and the output and local clocks
/// the run inquires.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClockSchedule {
    clocks: Vec<Periodic>,
    aperiodic: Vec<Aperiodic>,
    triggered: Vec<Triggered>,
    /// Output and local clocks: fmi3GetClock in Event Mode.
    inquired: Vec<u32>,
}

impl ClockSchedule {
    /// The clocks of the instance's description, their intervals and shifts settled in
    /// Initialization Mode (where `inst` must be) for a run from `start`.
    pub fn initialize(inst: &mut Instance3<'_>, start: f64) -> Result<Self> {
        let md = inst.fmu().model_description();
        let clocks: Vec<_> = md
            .variables
            .iter()
            .filter(|v| v.ty == Type3::Clock)
            .collect();
        if clocks.is_empty() {
            return Ok(ClockSchedule::default());
        }
        let f = clock_functions(inst)?;
        let mut s = ClockSchedule::default();
        for v in clocks {
            let vr = v.value_reference;
            let kind = v.interval_variability.as_deref().unwrap_or("");
            match (v.causality, kind) {
                (Causality3::Output | Causality3::Local, _) => s.inquired.push(vr),
                (Causality3::Input, "constant" | "fixed" | "tunable") => {
                    let given = (v.interval_decimal, v.shift_decimal, kind != "constant");
                    s.clocks.push(periodic(inst, &f, vr, given, start)?);
                }
                (Causality3::Input, "changing" | "countdown") => {
                    let (interval, q) = interval_of(inst, &f, vr, start)?;
                    // no earlier answer in Initialization Mode: Unchanged is taken as known
                    let next = (q != NOT_YET_KNOWN).then_some(start + interval);
                    let countdown = kind == "countdown";
                    s.aperiodic.push(Aperiodic {
                        vr,
                        countdown,
                        next,
                    });
                }
                _ => {}
            }
        }
        Ok(s)
    }

    /// Adds the triggered input clocks `(vr, tick times)` the data tick, their ticks from `start`
    /// on.
    pub fn trigger(&mut self, ticks: &[(u32, Vec<f64>)], start: f64) {
        for (vr, times) in ticks {
            let ticks = times.iter().copied().filter(|&t| t >= start).collect();
            self.triggered.push(Triggered {
                vr: *vr,
                ticks,
                k: 0,
            });
        }
    }

    /// Whether the run inquires output or local clocks.
    pub fn inquires(&self) -> bool {
        !self.inquired.is_empty()
    }

    /// The earliest next tick, if any clock ticks.
    pub fn next_tick(&self) -> Option<f64> {
        let periodic = self.clocks.iter().map(Periodic::next);
        let aperiodic = self.aperiodic.iter().filter_map(|c| c.next);
        let triggered = self
            .triggered
            .iter()
            .filter_map(|c| c.ticks.get(c.k).copied());
        periodic.chain(aperiodic).chain(triggered).reduce(f64::min)
    }

    /// The clocks whose tick is due at `t` (within `isclose` of it, or passed), each advanced
    /// to its next tick (an aperiodic one to none until the FMU tells it).
    pub fn due(&mut self, t: f64) -> Vec<u32> {
        let reached = |tk: f64| tk <= t || super::isclose(tk, t);
        let mut due = Vec::new();
        for c in &mut self.clocks {
            if reached(c.next()) {
                due.push(c.vr);
                while reached(c.next()) {
                    c.k += 1;
                }
            }
        }
        for c in &mut self.aperiodic {
            if c.next.is_some_and(reached) {
                due.push(c.vr);
                c.next = None;
            }
        }
        for c in &mut self.triggered {
            if c.ticks.get(c.k).is_some_and(|&tk| reached(tk)) {
                due.push(c.vr);
                while c.ticks.get(c.k).is_some_and(|&tk| reached(tk)) {
                    c.k += 1;
                }
            }
        }
        due
    }

    /// fmi3SetClock(active) for `vrs` (in Event Mode).
    pub fn activate(inst: &mut Instance3<'_>, vrs: &[u32], t: f64) -> Result<()> {
        let f = clock_functions(inst)?;
        let on = vec![1 as Bool3; vrs.len()];
        let _w = watch::enter3(Call::Set, Some(t));
        // SAFETY: `on` has one value per value reference.
        let raw = unsafe { (f.set_clock)(inst.instance, vrs.as_ptr(), vrs.len(), on.as_ptr()) };
        inst.check("fmi3SetClock", raw).map(drop)
    }

    /// The output and local clocks active now (fmi3GetClock, in Event Mode).
    pub fn inquire(&self, inst: &mut Instance3<'_>, t: f64) -> Result<Vec<u32>> {
        if self.inquired.is_empty() {
            return Ok(Vec::new());
        }
        let f = clock_functions(inst)?;
        let mut on = vec![0 as Bool3; self.inquired.len()];
        let _w = watch::enter3(Call::Get, Some(t));
        let (vrs, n) = (self.inquired.as_ptr(), self.inquired.len());
        // SAFETY: `on` has one value per value reference.
        let raw = unsafe { (f.get_clock)(inst.instance, vrs, n, on.as_mut_ptr()) };
        inst.check("fmi3GetClock", raw)?;
        Ok(self
            .inquired
            .iter()
            .zip(on)
            .filter(|(_, a)| *a != 0)
            .map(|(vr, _)| *vr)
            .collect())
    }

    /// After the event iteration at `t` in which the input clocks `ticked` ticked: the next
    /// intervals of the aperiodic clocks the table of clock types asks for (a `changing` clock
    /// that ticked, every `countdown` clock).
    pub fn after_event(&mut self, inst: &mut Instance3<'_>, t: f64, ticked: &[u32]) -> Result<()> {
        let asked: Vec<usize> = (0..self.aperiodic.len())
            .filter(|&i| self.aperiodic[i].countdown || ticked.contains(&self.aperiodic[i].vr))
            .collect();
        if asked.is_empty() {
            return Ok(());
        }
        let f = clock_functions(inst)?;
        for i in asked {
            let c = &mut self.aperiodic[i];
            let (interval, q) = interval_of(inst, &f, c.vr, t)?;
            match q {
                CHANGED => c.next = Some(t + interval),
                // a changing clock must announce its next tick now; without it, none follows
                _ if !c.countdown => c.next = None,
                _ => {}
            }
        }
        Ok(())
    }
}

/// A periodic clock from `(intervalDecimal, shiftDecimal, settable)` of its description, set
/// or asked in Initialization Mode.
fn periodic(
    inst: &mut Instance3<'_>,
    f: &ClockFunctions3,
    vr: u32,
    (interval, shift, settable): (Option<f64>, Option<f64>, bool),
    start: f64,
) -> Result<Periodic> {
    let (interval, shift) = match interval {
        Some(t) => {
            if settable {
                let _w = watch::enter3(Call::Other, Some(start));
                // SAFETY: one value reference, one interval.
                let raw = unsafe { (f.set_interval_decimal)(inst.instance, &vr, 1, &t) };
                inst.check("fmi3SetIntervalDecimal", raw)?;
            }
            (t, shift.unwrap_or(0.0))
        }
        None => {
            let (interval, _) = interval_of(inst, f, vr, start)?;
            let mut shift = 0.0;
            let _w = watch::enter3(Call::Other, Some(start));
            // SAFETY: one value reference, one shift.
            let raw = unsafe { (f.get_shift_decimal)(inst.instance, &vr, 1, &mut shift) };
            inst.check("fmi3GetShiftDecimal", raw)?;
            (interval, shift)
        }
    };
    if !(interval > 0.0 && interval.is_finite() && shift.is_finite()) {
        return Err(HostError::Request(format!(
            "clock (value reference {vr}): interval {interval} and shift {shift}; FMI 3.0.2 \
             section 2.2.8.2 asks for an interval > 0"
        )));
    }
    Ok(Periodic {
        vr,
        t0: start + shift,
        interval,
        k: 0,
    })
}

fn clock_functions(inst: &Instance3<'_>) -> Result<ClockFunctions3> {
    inst.fmu.functions.clocks.ok_or_else(|| {
        HostError::Request(
            "the FMU declares clocks but its binary does not export fmi3SetClock, fmi3GetClock, \
             fmi3GetIntervalDecimal, fmi3GetShiftDecimal and fmi3SetIntervalDecimal"
                .into(),
        )
    })
}

/// fmi3GetIntervalDecimal of clock `vr` at `t`: the interval and its qualifier, the interval
/// checked when it is news (`T_interval >= 0`, FMI 3.0.2 section 2.2.8.2, aperiodic clocks).
fn interval_of(
    inst: &mut Instance3<'_>,
    f: &ClockFunctions3,
    vr: u32,
    t: f64,
) -> Result<(f64, c_int)> {
    let (mut interval, mut qualifier) = (0.0, NOT_YET_KNOWN);
    let _w = watch::enter3(Call::Other, Some(t));
    // SAFETY: one value reference, one interval, one qualifier.
    let raw =
        unsafe { (f.get_interval_decimal)(inst.instance, &vr, 1, &mut interval, &mut qualifier) };
    inst.check("fmi3GetIntervalDecimal", raw)?;
    let news = qualifier != NOT_YET_KNOWN;
    if !matches!(qualifier, NOT_YET_KNOWN | UNCHANGED | CHANGED)
        || news && !(interval >= 0.0 && interval.is_finite())
    {
        return Err(HostError::Request(format!(
            "fmi3GetIntervalDecimal at t = {t}: clock (value reference {vr}) has interval \
             {interval} with qualifier {qualifier}; FMI 3.0.2 section 2.2.8.2 asks for an \
             interval >= 0 and a qualifier of fmi3IntervalQualifier"
        )));
    }
    Ok((interval, qualifier))
}

#[cfg(test)]
mod tests {
    use super::{refusal, Aperiodic, ClockSchedule, Periodic};
    use crate::fmi3::md::ModelDescription3;

    fn with_clock(causality: &str, kind: &str) -> ModelDescription3 {
        let xml = format!(
            "<fmiModelDescription fmiVersion=\"3.0\" instantiationToken=\"t\">\
             <ModelExchange modelIdentifier=\"M\"/><ModelVariables>\
             <Clock name=\"k\" valueReference=\"1\" causality=\"{causality}\" \
             intervalVariability=\"{kind}\"/></ModelVariables></fmiModelDescription>"
        );
        ModelDescription3::parse(&xml, "").expect("a valid description")
    }

    #[test]
    fn every_clock_kind_of_the_table_runs_and_no_other() {
        // the intervalVariability of every input clock of FMI 3.0.2 table "Overview of Clock types"
        for kind in "constant fixed tunable changing countdown triggered".split(' ') {
            assert_eq!(refusal(&with_clock("input", kind)), None, "{kind}");
        }
        assert_eq!(refusal(&with_clock("output", "triggered")), None);
        assert_eq!(refusal(&with_clock("local", "triggered")), None);
        let why = refusal(&with_clock("output", "constant")).expect("refused");
        assert!(
            why.contains("clock 'k'") && why.contains("section 2.2.8.2"),
            "{why}"
        );
    }

    #[test]
    fn ticks_come_from_the_start_and_shift_without_accumulated_rounding() {
        let mut s = ClockSchedule {
            clocks: vec![
                Periodic {
                    vr: 1,
                    t0: 0.1,
                    interval: 0.1,
                    k: 0,
                },
                Periodic {
                    vr: 2,
                    t0: 0.0,
                    interval: 0.25,
                    k: 0,
                },
            ],
            ..ClockSchedule::default()
        };
        assert_eq!(s.next_tick(), Some(0.0));
        assert_eq!(s.due(0.0), vec![2]);
        assert_eq!(s.next_tick(), Some(0.1));
        assert!(s.due(0.05).is_empty());
        for k in 1..1000 {
            let t = 0.1 * k as f64;
            let due = s.due(t + 1e-12);
            assert!(due.contains(&1), "tick {k} at {t}");
        }
        // 0.1 * 1000 is the 1000th tick, computed as t0 + 999 * 0.1, not summed
        assert!((s.clocks[0].next() - 100.0).abs() < 1e-12);
    }

    #[test]
    fn an_aperiodic_clock_ticks_once_and_waits_for_its_next_interval() {
        let mut s = ClockSchedule {
            aperiodic: vec![Aperiodic {
                vr: 7,
                countdown: true,
                next: Some(0.3),
            }],
            ..ClockSchedule::default()
        };
        assert_eq!(s.next_tick(), Some(0.3));
        assert!(s.due(0.2).is_empty());
        assert_eq!(s.due(0.3), vec![7]);
        assert_eq!(s.next_tick(), None);
        assert!(s.due(0.4).is_empty());
    }

    #[test]
    fn a_triggered_clock_ticks_at_the_times_of_its_data_from_the_start_on() {
        let mut s = ClockSchedule::default();
        s.trigger(&[(4, vec![-1.0, 0.3, 0.3, 0.55])], 0.0);
        assert_eq!(s.next_tick(), Some(0.3));
        assert!(s.due(0.2).is_empty());
        // two rows ticking at one time are one tick
        assert_eq!(s.due(0.3 - 1e-17), vec![4]);
        assert_eq!(s.next_tick(), Some(0.55));
        assert_eq!(s.due(0.6), vec![4]);
        assert_eq!(s.next_tick(), None);
    }
}
