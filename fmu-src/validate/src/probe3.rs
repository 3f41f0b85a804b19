//! The runtime state-machine probes of an FMI 3.0 FMU: Co-Simulation (FMI 3.0.2 section 4.2)
//! and Model Exchange (section 3.2), each a normal run, then checks of what the standard
//! requires (a saved FMU state restored, directional derivatives against finite differences,
//! re-initialized states signalled at an event), then calls the state machine (section 2.3) does
//! not allow. As for FMI 2.0, a failing normal run or a crash is a finding, the answer to a call
//! the importer must not make is the FMU's (a note unless it is fmi3Error). The host
//! instantiates with `loggingOn = fmi3False`, with which the FMU must not call the logger
//! (section 2.3.1), so an error without a logged message is no finding here.

use super::me_checks::{self, FmuStates, Reached, StateCallNames, Verdict};
use super::probe::{event_search_step, me_sequence, probe_step, unknown_value_reference};
use super::Finding;
use host::fmi3::md::Causality3;
use host::fmi3::value::{Type3, Values};
use host::fmi3::{Fmu3, Instance3};
use host::md::Variability;
use host::me::fmi3::Fmi3Me;
use host::me::ModelExchange;
use host::{FmuStateHandle3, HostError, Status};

/// Names of the FMI 3.0 probe cases in the order [`probe3`] and [`probe3_me`] run them.
pub const PROBE3_CASES: &[&str] = &[
    "fmi3-normal-run",
    "fmi3-fmu-state",
    "fmi3-do-step-before-init",
    "fmi3-negative-step",
    "fmi3-do-step-after-terminate",
    "fmi3-wrong-communication-point",
    "fmi3-unknown-value-reference",
    "fmi3-fixed-parameter-after-init",
    "fmi3-me-normal-run",
    "fmi3-me-directional-derivatives",
    "fmi3-me-state-event",
    "fmi3-me-fmu-state",
    "fmi3-me-derivatives-before-init",
    "fmi3-me-set-states-in-event-mode",
];

/// The clause of an FMI 3.0 probe result.
pub fn clause3(check: &str) -> &'static str {
    match check {
        "probe-normal-run" => "FMI 3.0.2 §2.3, §3.2 and §4.2: a legal calling sequence",
        "probe-wrong-call" => {
            "FMI 3.0.2 §2.3, §3.2 and §4.2: the importer must not make this call, so the answer \
             is the FMU's"
        }
        "probe-fmu-state" => {
            "FMI 3.0.2 §2.2.7.4: canGetAndSetFMUState declared: fmi3SetFMUState restores the \
             state fmi3GetFMUState saved"
        }
        "probe-directional-derivative" => {
            "FMI 3.0.2 §2.2.12.1: fmi3GetDirectionalDerivative gives the partial derivatives"
        }
        "probe-event" => {
            "FMI 3.0.2 §2.3.5: fmi3UpdateDiscreteStates signals re-initialized states \
             (valuesOfContinuousStatesChanged)"
        }
        _ => "FMI 3.0.2 §2.2.4: every call returns a status",
    }
}

fn finding3(check: &str, loc: impl Into<String>, message: impl Into<String>) -> Finding {
    let mut f = Finding::new(check, loc, message);
    f.clause = clause3(check).to_string();
    f
}

/// [`finding3`] as the shared Model Exchange checks take it.
fn me_finding3(check: &str, loc: String, message: String) -> Finding {
    finding3(check, loc, message)
}

fn initialize(inst: &mut Instance3<'_>, t0: f64) -> Result<(), HostError> {
    inst.enter_initialization_mode(None, t0, None)?;
    inst.exit_initialization_mode()?;
    Ok(())
}

/// What the answer to a call the importer must not make gives: nothing for fmi3Error (the
/// usual answer), a note otherwise, a normal-run finding when something else failed.
fn answer(what: &str, loc: String, result: Result<(), HostError>, f: &mut Vec<Finding>) {
    match result {
        Ok(()) => f.push(finding3(
            "probe-wrong-call",
            loc,
            format!("{what} returned fmi3OK; fmi3Error would warn the importer"),
        )),
        Err(HostError::Fmi {
            status: Status::Error,
            ..
        }) => {}
        Err(HostError::Fmi { status, .. }) => f.push(finding3(
            "probe-wrong-call",
            loc,
            format!("{what} returned fmi3{status:?}; fmi3Error is the usual answer"),
        )),
        Err(e) => f.push(finding3("probe-normal-run", loc, format!("{what}: {e}"))),
    }
}

/// `inst` bound as Model Exchange (the counts of states and event indicators queried).
fn me<'i, 'a>(inst: &'i mut Instance3<'a>) -> Result<Fmi3Me<'i, 'a>, String> {
    Fmi3Me::new(inst).map_err(|e| e.to_string())
}

/// Whether the description declares `canSerializeFMUState` for the interface.
fn can_serialize(fmu: &Fmu3, model_exchange: bool) -> bool {
    let md = fmu.model_description();
    let element = if model_exchange {
        md.model_exchange.as_ref()
    } else {
        md.co_simulation.as_ref()
    };
    element.is_some_and(|e| e.flag("canSerializeFMUState"))
}

/// Whether the description declares `canGetAndSetFMUState` for `interface`.
fn can_get_and_set(fmu: &Fmu3, model_exchange: bool) -> bool {
    let md = fmu.model_description();
    let element = if model_exchange {
        md.model_exchange.as_ref()
    } else {
        md.co_simulation.as_ref()
    };
    element.is_some_and(|e| e.flag("canGetAndSetFMUState"))
}

/// The probe of `fmu` (opened for Co-Simulation); `step` as for [`super::probe`].
pub fn probe3(fmu: &Fmu3, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let md = fmu.model_description();
    let de = md.default_experiment.clone().unwrap_or_default();
    let t0 = de.start_time.unwrap_or(0.0);
    let h = probe_step(de.step_size);
    let mut f = Vec::new();
    if !step("fmi3-normal-run") {
        return f;
    }
    let normal = (|| -> Result<(), HostError> {
        let mut inst = fmu.instantiate("probe")?;
        initialize(&mut inst, t0)?;
        for k in 0..10 {
            if inst.do_step(t0 + k as f64 * h, h, true)?.terminate {
                break;
            }
        }
        inst.terminate()?;
        inst.reset()?;
        initialize(&mut inst, t0)?;
        inst.do_step(t0, h, true)?;
        Ok(())
    })();
    if let Err(e) = normal {
        let m = format!(
            "instantiate, initialize, 10 steps, terminate, reset, re-initialize, step failed: {e}"
        );
        f.push(finding3("probe-normal-run", "probe fmi3-normal-run", m));
        return f;
    }
    if can_get_and_set(fmu, false) && step("fmi3-fmu-state") {
        match check_fmu_state_cs(fmu, t0, h) {
            Ok(None) => {}
            Ok(Some(m)) => f.push(finding3("probe-fmu-state", "probe fmi3-fmu-state", m)),
            Err(e) => f.push(finding3("probe-normal-run", "probe fmi3-fmu-state", e)),
        }
    }
    let mut case =
        |name: &str,
         what: &str,
         init: bool,
         call: &mut dyn FnMut(&mut Instance3<'_>) -> Result<(), HostError>| {
            if !step(name) {
                return;
            }
            let loc = format!("probe {name}");
            let mut inst = match fmu.instantiate("probe") {
                Ok(i) => i,
                Err(e) => {
                    f.push(finding3("probe-normal-run", loc, e.to_string()));
                    return;
                }
            };
            if init {
                if let Err(e) = initialize(&mut inst, t0) {
                    let m = format!("initialization failed: {e}");
                    f.push(finding3("probe-normal-run", loc, m));
                    return;
                }
            }
            answer(what, loc, call(&mut inst), &mut f);
        };
    case(
        "fmi3-do-step-before-init",
        "fmi3DoStep before initialization",
        false,
        &mut |i| i.do_step(t0, h, true).map(drop),
    );
    case(
        "fmi3-negative-step",
        "fmi3DoStep with a negative step size",
        true,
        &mut |i| i.do_step(t0, -h, true).map(drop),
    );
    case(
        "fmi3-do-step-after-terminate",
        "fmi3DoStep after fmi3Terminate",
        true,
        &mut |i| {
            i.terminate()?;
            i.do_step(t0, h, true).map(drop)
        },
    );
    // currentCommunicationPoint is the time the instance reached (FMI 3.0.2 section 4.2.1)
    case(
        "fmi3-wrong-communication-point",
        "fmi3DoStep with currentCommunicationPoint != current time",
        true,
        &mut |i| i.do_step(t0 + 100.0 * h + 1.0, h, true).map(drop),
    );
    let unknown_vr = unknown_value_reference(md.variables.iter().map(|v| v.value_reference));
    case(
        "fmi3-unknown-value-reference",
        &format!("fmi3GetFloat64 of unknown valueReference {unknown_vr}"),
        true,
        &mut |i| i.get(Type3::Float64, &[unknown_vr], 1).map(drop),
    );
    // In Step Mode only inputs and tunable parameters may be set (FMI 3.0.2 section 4.2.1).
    let fixed = md.variables.iter().find(|v| {
        v.causality == Causality3::Parameter
            && v.variability == Variability::Fixed
            && v.ty == Type3::Float64
            && !v.is_array()
    });
    if let Some(v) = fixed {
        let (vr, start) = (v.value_reference, v.start.clone());
        let what = format!("setting fixed parameter '{}' after initialization", v.name);
        case("fmi3-fixed-parameter-after-init", &what, true, &mut |i| {
            let value = start.clone().unwrap_or(Values::Float64(vec![0.0]));
            i.set(&[vr], &value).map(drop)
        });
    }
    f
}

/// Steps 5 times, then the Float64 outputs after each of 5 more steps must repeat to the bit
/// from a restored FMU state.
fn check_fmu_state_cs(fmu: &Fmu3, t0: f64, h: f64) -> Verdict {
    let md = fmu.model_description();
    let outs: Vec<u32> = md
        .with_causality(Causality3::Output)
        .filter(|v| v.ty == Type3::Float64 && !v.is_array())
        .map(|v| v.value_reference)
        .collect();
    let s = |e: HostError| e.to_string();
    let mut inst = fmu.instantiate("probe").map_err(s)?;
    initialize(&mut inst, t0).map_err(s)?;
    let t = |k: usize| t0 + k as f64 * h;
    for k in 0..5 {
        inst.do_step(t(k), h, false).map_err(s)?;
    }
    let mut run5 = |inst: &mut Instance3<'_>| -> Result<Vec<u64>, String> {
        let mut bits = Vec::new();
        for k in 5..10 {
            inst.do_step(t(k), h, false).map_err(s)?;
            if let Values::Float64(v) = inst.get(Type3::Float64, &outs, outs.len()).map_err(s)? {
                bits.extend(v.iter().map(|x| x.to_bits()));
            }
        }
        Ok(bits)
    };
    let what = "Float64 outputs of the next 5 steps";
    let serialize = can_serialize(fmu, false);
    me_checks::check_state_restore(&mut inst, (what, serialize), &mut run5)
}

/// The Model Exchange probe of `fmu` (opened for Model Exchange): a normal run (initialization,
/// event iteration, Continuous-Time Mode, finite derivatives over 3 explicit Euler steps,
/// terminate); directional derivatives against finite differences, the event flags at the first
/// state event, a restored FMU state; then `fmi3GetContinuousStateDerivatives` before
/// initialization and `fmi3SetContinuousStates` in Event Mode, which the state machine of FMI
/// 3.0.2 sections 2.3 and 3.2 does not allow. `step` as
/// for [`super::probe`].
pub fn probe3_me(fmu: &Fmu3, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let de = fmu
        .model_description()
        .default_experiment
        .clone()
        .unwrap_or_default();
    let t0 = de.start_time.unwrap_or(0.0);
    let mut f = Vec::new();
    let normal = || -> Result<(), String> {
        let s = |e: HostError| e.to_string();
        let mut inst = fmu.instantiate("probe").map_err(s)?;
        initialize(&mut inst, t0).map_err(s)?;
        me_sequence(&mut Fmi3Me::new(&mut inst).map_err(s)?, t0)?;
        inst.terminate().map(drop).map_err(s)
    };
    if !me_checks::normal_case("fmi3-me-normal-run", step, &mut f, me_finding3, normal) {
        return f;
    }
    let h = event_search_step(t0, de.stop_time);
    let mut check =
        |name: &str, check: &str, run: &mut dyn FnMut(&mut Instance3<'_>, Reached) -> Verdict| {
            me_checks::check_case((name, check), step, &mut f, me_finding3, || {
                let s = |e: HostError| e.to_string();
                let mut inst = fmu.instantiate("probe").map_err(s)?;
                initialize(&mut inst, t0).map_err(s)?;
                let t = me_sequence(&mut Fmi3Me::new(&mut inst).map_err(s)?, t0)?;
                run(&mut inst, t)
            });
        };
    check(
        "fmi3-me-directional-derivatives",
        "probe-directional-derivative",
        &mut |inst, _| me_checks::check_directional(&mut me(inst)?),
    );
    check(
        "fmi3-me-state-event",
        "probe-event",
        &mut |inst, reached| me_checks::check_event(&mut me(inst)?, reached, h),
    );
    if can_get_and_set(fmu, true) {
        check(
            "fmi3-me-fmu-state",
            "probe-fmu-state",
            &mut |inst, reached| check_fmu_state_me(inst, reached.t, h),
        );
    }
    let name = "fmi3-me-derivatives-before-init";
    if step(name) {
        let what = "fmi3GetContinuousStateDerivatives before initialization";
        let result = fmu.instantiate("probe").and_then(|mut inst| {
            let mut me = Fmi3Me::new(&mut inst)?;
            let mut dx = vec![0.0; me.states()];
            me.get_derivatives(&mut dx).map(drop)
        });
        answer(what, format!("probe {name}"), result, &mut f);
    }
    // After fmi3ExitInitializationMode a Model Exchange instance is in Event Mode, where
    // fmi3SetContinuousStates is not allowed (FMI 3.0.2 section 2.3.5).
    let name = "fmi3-me-set-states-in-event-mode";
    if step(name) {
        let what = "fmi3SetContinuousStates in Event Mode";
        let result = fmu.instantiate("probe").and_then(|mut inst| {
            initialize(&mut inst, t0)?;
            let mut me = Fmi3Me::new(&mut inst)?;
            let mut x = vec![0.0; me.states()];
            me.get_states(&mut x)?;
            me.set_states(&x)
        });
        answer(what, format!("probe {name}"), result, &mut f);
    }
    f
}

/// In Continuous-Time Mode at `t`: the continuous states after each of 5 explicit Euler steps
/// of `h` must repeat to the bit from a restored FMU state.
fn check_fmu_state_me(inst: &mut Instance3<'_>, t: f64, h: f64) -> Verdict {
    let what = "continuous states of the next 5 Euler steps";
    let serialize = can_serialize(inst.fmu(), true);
    me_checks::check_state_restore(inst, (what, serialize), &mut |inst| {
        me_checks::euler_run(&mut me(inst)?, t, h, 5)
    })
}

impl FmuStates for Instance3<'_> {
    type State = FmuStateHandle3;
    const NAMES: StateCallNames = StateCallNames {
        get: "fmi3GetFMUState",
        set: "fmi3SetFMUState",
        copy: "fmi3SerializeFMUState, fmi3DeserializeFMUState and fmi3SetFMUState",
    };

    fn get_state(&mut self) -> Result<FmuStateHandle3, String> {
        self.get_fmu_state().map_err(|e| e.to_string())
    }

    fn set_state(&mut self, state: &FmuStateHandle3) -> Result<(), String> {
        self.set_fmu_state(state)
            .map(drop)
            .map_err(|e| e.to_string())
    }

    fn serialized_copy(&mut self, state: &FmuStateHandle3) -> Result<FmuStateHandle3, String> {
        let bytes = self.serialize_fmu_state(state).map_err(|e| e.to_string())?;
        self.deserialize_fmu_state(&bytes)
            .map_err(|e| e.to_string())
    }

    fn free_state(&mut self, state: FmuStateHandle3) {
        let _ = self.free_fmu_state(state);
    }
}
