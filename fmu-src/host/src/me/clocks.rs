//! The input clocks of an FMI 3.0 Model Exchange run (FMI 3.0.2 section 2.2.8, Clocks).
//!
//! "In Model Exchange and Co-Simulation, when input Clocks tick, the importer will activate the
//! input Clocks using fmi3SetClock" (section 2.2.8.2), and fmi3EnterEventMode is called when "an
//! input Clock needs to be set" (section 3.2.1). The run drives the periodic input clocks:
//!
//! - `constant`: interval and shift from `intervalDecimal` and `shiftDecimal` (0 when absent);
//!   without `intervalDecimal`, fmi3GetIntervalDecimal and fmi3GetShiftDecimal in
//!   Initialization Mode (the calls the table of clock types allows there);
//! - `fixed`, `tunable` with `intervalDecimal`: fmi3SetIntervalDecimal with it in
//!   Initialization Mode ("One of these functions must be called for all fixed periodic Clocks
//!   and tunable periodic Clocks", section 2.3.3); without it, fmi3GetIntervalDecimal and
//!   fmi3GetShiftDecimal there ("the importer must use fmi3GetInterval and fmi3GetShift").
//!
//! A periodic clock ticks at `t_0 = t_start + T_shift`, `t_i = t_(i-1) + T_interval`
//! (section 2.2.8.2, Periodic Clock), computed as `t_0 + i T_interval` so that no rounding
//! accumulates. Ticks are time events: the run enters Event Mode there and sets the clocks due
//! before the event iteration; the FMU deactivates them in fmi3UpdateDiscreteStates ("Any Clock
//! active during fmi3UpdateDiscreteStates must be deactivated by the FMU itself", section 2.3.5).
//!
//! Triggered input clocks tick when the importer decides (section 2.2.8.2: "For triggered input
//! clocks, the timing is determined by the importer"); a `simulate` run has no source of
//! triggers, so they stay inactive. The clock kinds the run does not drive are refused by
//! [`refusal`] with the clause that asks the importer for more.

use crate::error::Result;
use crate::fmi3::ffi::{sym, Bool3, RawStatus3};
use crate::fmi3::instance::Instance3;
use crate::fmi3::md::{Causality3, ModelDescription3};
use crate::fmi3::value::Type3;
use crate::watch::{self, Call};
use libloading::Library;
use std::ffi::{c_int, c_void};

type I = *mut c_void;

/// The clock functions a Model Exchange run calls (FMI 3.0.2 section 2.2.8.4).
#[derive(Clone, Copy)]
#[allow(missing_docs)]
pub struct ClockFunctions3 {
    pub set_clock: unsafe extern "C" fn(I, *const u32, usize, *const Bool3) -> RawStatus3,
    /// `(instance, vrs, n, intervals, qualifiers)`; `fmi3IntervalQualifier` is a C enum.
    pub get_interval_decimal:
        unsafe extern "C" fn(I, *const u32, usize, *mut f64, *mut c_int) -> RawStatus3,
    pub get_shift_decimal: unsafe extern "C" fn(I, *const u32, usize, *mut f64) -> RawStatus3,
    pub set_interval_decimal: unsafe extern "C" fn(I, *const u32, usize, *const f64) -> RawStatus3,
}

/// The clock functions, when the binary exports them (FMI 3.0.2 section 2.5: "The FMU must
/// implement all API functions declared in fmi3Functions.h").
///
/// # Safety
/// `lib` must be an FMI 3.0 binary whose exports have the standard signatures.
pub(crate) unsafe fn resolve(lib: &Library) -> Option<ClockFunctions3> {
    Some(ClockFunctions3 {
        set_clock: sym(lib, "fmi3SetClock")?,
        get_interval_decimal: sym(lib, "fmi3GetIntervalDecimal")?,
        get_shift_decimal: sym(lib, "fmi3GetShiftDecimal")?,
        set_interval_decimal: sym(lib, "fmi3SetIntervalDecimal")?,
    })
}

/// Why a Model Exchange run cannot drive the clocks of `md`, citing the clause that asks the
/// importer for what it does not do; None when it can.
pub fn refusal(md: &ModelDescription3) -> Option<String> {
    for v in md.variables.iter().filter(|v| v.ty == Type3::Clock) {
        let kind = v.interval_variability.as_deref().unwrap_or("");
        let why = match (v.causality, kind) {
            (Causality3::Input, "constant" | "fixed" | "tunable" | "triggered") => continue,
            (Causality3::Input, "changing" | "countdown") => {
                "an aperiodic input clock, whose next interval the importer must ask for with \
                 fmi3GetIntervalDecimal in the Event Mode of its ticks (changing) or in every \
                 Event Mode (countdown; FMI 3.0.2 section 2.2.8.2, table \"Overview of Clock \
                 types\", and section 2.3.5); this host runs periodic and triggered input clocks"
            }
            (Causality3::Output | Causality3::Local, _) => {
                "an output or local clock, whose activation the importer must inquire with \
                 fmi3GetClock in Event Mode (FMI 3.0.2 section 2.2.8.2, table \"Overview of \
                 Clock types\"); this host runs periodic and triggered input clocks"
            }
            _ => "a clock without a known intervalVariability (FMI 3.0.2 section 2.4.7.6)",
        };
        return Some(format!(
            "FMI 3.0 clock '{}' is not supported in Model Exchange: it is {why}",
            v.name
        ));
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

/// The periodic input clocks of a run and their next ticks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClockSchedule {
    clocks: Vec<Periodic>,
}

impl ClockSchedule {
    /// The clocks of the instance's description, their intervals and shifts settled in
    /// Initialization Mode (where `inst` must be) for a run from `start`.
    pub fn initialize(inst: &mut Instance3<'_>, start: f64) -> Result<Self> {
        let periodic: Vec<(u32, String, Option<f64>, Option<f64>)> = inst
            .fmu()
            .model_description()
            .variables
            .iter()
            .filter(|v| v.ty == Type3::Clock && v.causality == Causality3::Input)
            .filter_map(|v| {
                let kind = v.interval_variability.clone()?;
                matches!(kind.as_str(), "constant" | "fixed" | "tunable").then(|| {
                    let shift = v.shift_decimal;
                    (v.value_reference, kind, v.interval_decimal, shift)
                })
            })
            .collect();
        if periodic.is_empty() {
            return Ok(ClockSchedule::default());
        }
        let f = clock_functions(inst)?;
        let mut clocks = Vec::with_capacity(periodic.len());
        for (vr, kind, interval, shift) in periodic {
            let (interval, shift) = match interval {
                Some(t) => {
                    if kind != "constant" {
                        let _w = watch::enter3(Call::Other, Some(start));
                        // SAFETY: one value reference, one interval.
                        let raw = unsafe { (f.set_interval_decimal)(inst.instance, &vr, 1, &t) };
                        inst.check("fmi3SetIntervalDecimal", raw)?;
                    }
                    (t, shift.unwrap_or(0.0))
                }
                None => asked(inst, &f, vr, start)?,
            };
            if !(interval > 0.0 && interval.is_finite() && shift.is_finite()) {
                return Err(crate::error::HostError::Request(format!(
                    "clock (value reference {vr}): interval {interval} and shift {shift}; FMI \
                     3.0.2 section 2.2.8.2 asks for an interval > 0"
                )));
            }
            clocks.push(Periodic {
                vr,
                t0: start + shift,
                interval,
                k: 0,
            });
        }
        Ok(ClockSchedule { clocks })
    }

    /// The earliest next tick, if any clock ticks.
    pub fn next_tick(&self) -> Option<f64> {
        self.clocks.iter().map(Periodic::next).reduce(f64::min)
    }

    /// The clocks whose tick is due at `t` (within `isclose` of it, or passed), each advanced
    /// to its next tick.
    pub fn due(&mut self, t: f64) -> Vec<u32> {
        let mut due = Vec::new();
        for c in &mut self.clocks {
            if c.next() <= t || super::isclose(c.next(), t) {
                due.push(c.vr);
                while c.next() <= t || super::isclose(c.next(), t) {
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
}

fn clock_functions(inst: &Instance3<'_>) -> Result<ClockFunctions3> {
    inst.fmu.functions.me.and_then(|m| m.clocks).ok_or_else(|| {
        crate::error::HostError::Request(
            "the FMU declares input clocks but its binary does not export fmi3SetClock, \
                 fmi3GetIntervalDecimal, fmi3GetShiftDecimal and fmi3SetIntervalDecimal"
                .into(),
        )
    })
}

/// Interval and shift of clock `vr` from the FMU (Initialization Mode).
fn asked(inst: &mut Instance3<'_>, f: &ClockFunctions3, vr: u32, t: f64) -> Result<(f64, f64)> {
    let (mut interval, mut qualifier, mut shift) = (0.0, 0 as c_int, 0.0);
    let _w = watch::enter3(Call::Other, Some(t));
    // SAFETY: one value reference, one interval, one qualifier.
    let raw =
        unsafe { (f.get_interval_decimal)(inst.instance, &vr, 1, &mut interval, &mut qualifier) };
    inst.check("fmi3GetIntervalDecimal", raw)?;
    // SAFETY: one value reference, one shift.
    let raw = unsafe { (f.get_shift_decimal)(inst.instance, &vr, 1, &mut shift) };
    inst.check("fmi3GetShiftDecimal", raw)?;
    Ok((interval, shift))
}

#[cfg(test)]
mod tests {
    use super::{ClockSchedule, Periodic};

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
}
