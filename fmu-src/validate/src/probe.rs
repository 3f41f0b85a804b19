//! The runtime state-machine probe: calls in wrong states or with bad arguments, a normal run,
//! FMU state save/restore (FMI 2.0.4 sections 2.1 and 4.2.4).

use super::me_checks::{self, FmuStates, Reached, StateCallNames, Verdict};
use super::Finding;
use host::md::{Causality, ScalarVariable, StartValue, VarKind, Variability};
use host::me::fmi2::Fmi2Me;
use host::me::ModelExchange;
use host::Fmu;
use host::{FmuStateHandle, Instance};
use host::{HostError, Status};
use std::collections::BTreeSet;

/// Names of the probe cases in the order [`probe`] runs them.
pub const PROBE_CASES: &[&str] = &[
    "normal-run",
    "fmu-state",
    "do-step-before-init",
    "negative-step",
    "wrong-communication-point",
    "unknown-value-reference",
    "nan-input",
    "nan-parameter",
    "fixed-parameter-after-init",
    "wrong-type",
    "do-step-after-terminate",
];

/// The state-machine probe. `step` is called with the name of each case (see [`PROBE_CASES`])
/// before it runs and returns whether to run it (the CLI prints the name so that a crash can
/// be attributed, and skips cases that crashed in an earlier attempt). Each case uses a fresh
/// instance.
pub fn probe(fmu: &Fmu, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let md = fmu.model_description();
    let mut f = Vec::new();
    let de = md.default_experiment.clone().unwrap_or_default();
    let t0 = de.start_time.unwrap_or(0.0);
    let h = probe_step(de.step_size);
    let loc = |case: &str| format!("probe {case}");

    let init = |inst: &mut Instance<'_>| -> Result<(), HostError> {
        inst.setup_experiment(None, t0, None)?;
        inst.enter_initialization_mode()?;
        inst.exit_initialization_mode()?;
        Ok(())
    };

    // Normal run: must succeed.
    if !step("normal-run") {
        return f;
    }
    let normal = (|| -> Result<(), String> {
        let mut inst = fmu.instantiate("probe").map_err(|e| e.to_string())?;
        init(&mut inst).map_err(|e| e.to_string())?;
        let outs: Vec<u32> = md
            .with_causality(Causality::Output)
            .filter(|v| v.kind == VarKind::Real)
            .map(|v| v.value_reference)
            .collect();
        let mut buf = vec![0.0; outs.len()];
        for k in 0..10 {
            inst.do_step(t0 + k as f64 * h, h, true)
                .map_err(|e| format!("step {k}: {e}"))?;
            inst.get_real(&outs, &mut buf).map_err(|e| e.to_string())?;
            if let Some(i) = buf.iter().position(|x| !x.is_finite()) {
                return Err(format!(
                    "output vr {} is {} after step {k}",
                    outs[i], buf[i]
                ));
            }
        }
        inst.terminate().map_err(|e| e.to_string())?;
        inst.reset().map_err(|e| format!("after terminate: {e}"))?;
        init(&mut inst).map_err(|e| format!("after reset: {e}"))?;
        inst.do_step(t0, h, true)
            .map_err(|e| format!("after reset: {e}"))?;
        Ok(())
    })();
    if let Err(e) = normal {
        f.push(Finding::new("probe-normal-run", loc("normal-run"), format!("instantiate, initialize, 10 steps, terminate, reset, re-initialize, step failed: {e}")));
        return f; // the wrong-call cases below assume a working FMU
    }

    // Capability flags kept: a restored (and a deserialized) FMU state continues bit-identically.
    let cs = md.co_simulation.clone().unwrap_or_default();
    if cs.can_get_and_set_fmu_state && step("fmu-state") {
        if let Err(e) = check_fmu_state(fmu, &init, t0, h, cs.can_serialize_fmu_state) {
            f.push(Finding::new("probe-fmu-state", loc("fmu-state"), e));
        }
    }

    let mut case =
        |name: &str,
         what: &str,
         before_init: bool,
         call: &mut dyn FnMut(&mut Instance<'_>) -> Result<Status, HostError>| {
            if !step(name) {
                return;
            }
            let mut inst = match fmu.instantiate("probe") {
                Ok(i) => i,
                Err(e) => {
                    f.push(Finding::new(
                        "probe-normal-run",
                        loc(name),
                        format!("fmi2Instantiate failed: {e}"),
                    ));
                    return;
                }
            };
            if !before_init {
                if let Err(e) = init(&mut inst) {
                    f.push(Finding::new(
                        "probe-normal-run",
                        loc(name),
                        format!("initialization failed: {e}"),
                    ));
                    return;
                }
            }
            match call(&mut inst) {
                Ok(st) => f.push(Finding::new(
                    if name.starts_with("nan") {
                        "probe-nan"
                    } else {
                        "probe-wrong-call"
                    },
                    loc(name),
                    format!("{what} returned {st}; fmi2Error with a logged message would warn the importer"),
                )),
                Err(HostError::Fmi {
                    status: Status::Error,
                    messages,
                    ..
                }) => {
                    if messages.is_empty() {
                        f.push(Finding::new(
                            "probe-log",
                            loc(name),
                            format!("{what} returned fmi2Error but logged no message"),
                        ));
                    }
                }
                Err(HostError::Fmi { status, .. }) => f.push(Finding::new(
                    "probe-wrong-call",
                    loc(name),
                    format!("{what} returned {status}; fmi2Error is the usual answer"),
                )),
                Err(e) => f.push(Finding::new("probe-normal-run", loc(name), format!("{what}: {e}"))),
            }
        };

    case(
        "do-step-before-init",
        "fmi2DoStep before initialization",
        true,
        &mut |i| i.do_step(t0, h, true),
    );
    case(
        "negative-step",
        "fmi2DoStep with a negative step size",
        false,
        &mut |i| i.do_step(t0, -h, true),
    );
    case(
        "wrong-communication-point",
        "fmi2DoStep with currentCommunicationPoint != current time",
        false,
        &mut |i| i.do_step(t0 + 100.0 * h + 1.0, h, true),
    );
    let unknown_vr = unknown_value_reference(md.model_variables.iter().map(|v| v.value_reference));
    case(
        "unknown-value-reference",
        &format!("fmi2GetReal of unknown valueReference {unknown_vr}"),
        false,
        &mut |i| {
            let mut out = [0.0];
            i.get_real(&[unknown_vr], &mut out)
        },
    );
    let real_input = md
        .model_variables
        .iter()
        .find(|v| v.causality == Causality::Input && v.kind == VarKind::Real);
    let real_param = md.model_variables.iter().find(|v| {
        v.causality == Causality::Parameter
            && v.kind == VarKind::Real
            && v.variability != Variability::Constant
    });
    if let Some(v) = real_input {
        let vr = v.value_reference;
        case(
            "nan-input",
            &format!("fmi2SetReal NaN on input '{}'", v.name),
            false,
            &mut |i| i.set_real(&[vr], &[f64::NAN]),
        );
    } else if let Some(v) = real_param {
        let vr = v.value_reference;
        case(
            "nan-parameter",
            &format!("fmi2SetReal NaN on parameter '{}'", v.name),
            true,
            &mut |i| i.set_real(&[vr], &[f64::NAN]),
        );
    }
    let fixed = md.model_variables.iter().find(|v| {
        v.causality == Causality::Parameter
            && v.variability == Variability::Fixed
            && v.kind != VarKind::String
    });
    if let Some(v) = fixed {
        let vr = v.value_reference;
        let what = format!("setting fixed parameter '{}' after initialization", v.name);
        let start = v.start.as_ref().and_then(StartValue::as_f64).unwrap_or(0.0);
        let kind = v.kind;
        case(
            "fixed-parameter-after-init",
            &what,
            false,
            &mut |i| match kind {
                VarKind::Real => i.set_real(&[vr], &[start]),
                VarKind::Boolean => i.set_boolean(&[vr], &[start != 0.0]),
                _ => i.set_integer(&[vr], &[start as i32]),
            },
        );
    }
    // fmi2SetBoolean on a Real variable (value references are per type: only when no Boolean
    // variable uses the same number).
    let bool_vrs: BTreeSet<u32> = md
        .model_variables
        .iter()
        .filter(|v| v.kind == VarKind::Boolean)
        .map(|v| v.value_reference)
        .collect();
    let untyped = |v: &&ScalarVariable| !bool_vrs.contains(&v.value_reference);
    let target = real_input
        .filter(untyped)
        .map(|v| (v, false))
        .or_else(|| real_param.filter(untyped).map(|v| (v, true)));
    if let Some((v, before_init)) = target {
        let vr = v.value_reference;
        let what = format!("fmi2SetBoolean on Real variable '{}'", v.name);
        case("wrong-type", &what, before_init, &mut |i| {
            i.set_boolean(&[vr], &[true])
        });
    }
    case(
        "do-step-after-terminate",
        "fmi2DoStep after fmi2Terminate",
        false,
        &mut |i| {
            i.terminate()
                .map_err(|e| HostError::Request(format!("fmi2Terminate failed: {e}")))?;
            i.do_step(t0, h, true)
        },
    );
    f
}

/// The communication step of the Co-Simulation probes: the default experiment's step size when
/// it is a positive number (1 ms otherwise), at most 10 ms so that 10 steps stay near the start.
pub(super) fn probe_step(step_size: Option<f64>) -> f64 {
    step_size
        .filter(|h| *h > 0.0 && h.is_finite())
        .unwrap_or(1e-3)
        .min(1e-2)
}

/// A value reference no variable has: 1000 above the largest (0 without variables).
pub(super) fn unknown_value_reference(vrs: impl Iterator<Item = u32>) -> u32 {
    vrs.max().unwrap_or(0).saturating_add(1000)
}

/// Steps 5 times, saves the state, steps 5 more and records the Real outputs; restores the
/// state (and, if `serialize`, a serialized-then-deserialized copy) and repeats the 5 steps:
/// the outputs must be bit-identical (the capabilities canGetAndSetFMUstate /
/// canSerializeFMUstate the description declares).
fn check_fmu_state(
    fmu: &Fmu,
    init: &dyn Fn(&mut Instance<'_>) -> Result<(), HostError>,
    t0: f64,
    h: f64,
    serialize: bool,
) -> Result<(), String> {
    let md = fmu.model_description();
    let outs: Vec<u32> = md
        .with_causality(Causality::Output)
        .filter(|v| v.kind == VarKind::Real)
        .map(|v| v.value_reference)
        .collect();
    let mut inst = fmu.instantiate("probe").map_err(|e| e.to_string())?;
    init(&mut inst).map_err(|e| e.to_string())?;
    let t = |k: usize| t0 + k as f64 * h;
    for k in 0..5 {
        inst.do_step(t(k), h, false).map_err(|e| e.to_string())?;
    }
    let saved = inst.get_fmu_state().map_err(|e| e.to_string())?;
    let bytes = if serialize {
        Some(
            inst.serialize_fmu_state(&saved)
                .map_err(|e| e.to_string())?,
        )
    } else {
        None
    };
    let run5 = |inst: &mut Instance<'_>| -> Result<Vec<f64>, String> {
        let mut all = Vec::new();
        let mut buf = vec![0.0; outs.len()];
        for k in 5..10 {
            inst.do_step(t(k), h, false).map_err(|e| e.to_string())?;
            inst.get_real(&outs, &mut buf).map_err(|e| e.to_string())?;
            all.extend_from_slice(&buf);
        }
        Ok(all)
    };
    let first = run5(&mut inst)?;
    inst.set_fmu_state(&saved).map_err(|e| e.to_string())?;
    let again = run5(&mut inst).map_err(|e| format!("after fmi2SetFMUstate: {e}"))?;
    if again
        .iter()
        .map(|x| x.to_bits())
        .ne(first.iter().map(|x| x.to_bits()))
    {
        return Err("after fmi2SetFMUstate the outputs differ from the first run (state not fully restored)".into());
    }
    if let Some(bytes) = bytes {
        let restored = inst
            .deserialize_fmu_state(&bytes)
            .map_err(|e| e.to_string())?;
        inst.set_fmu_state(&restored).map_err(|e| e.to_string())?;
        let third = run5(&mut inst).map_err(|e| format!("after fmi2DeSerializeFMUstate: {e}"))?;
        if third
            .iter()
            .map(|x| x.to_bits())
            .ne(first.iter().map(|x| x.to_bits()))
        {
            return Err("after fmi2DeSerializeFMUstate + fmi2SetFMUstate the outputs differ from the first run".into());
        }
    }
    Ok(())
}

/// Names of the Model Exchange probe cases in the order [`probe_me`] runs them.
pub const ME_PROBE_CASES: &[&str] = &[
    "me-normal-run",
    "me-directional-derivatives",
    "me-state-event",
    "me-fmu-state",
    "me-derivatives-before-init",
    "me-set-states-in-event-mode",
];

/// The state-machine probe of an FMI 2.0 Model Exchange FMU (`fmu` opened with the Model
/// Exchange interface): a normal run (instantiate, initialize, event iteration, Continuous-Time
/// Mode, derivatives finite, a few explicit Euler steps with `fmi2CompletedIntegratorStep`,
/// terminate), then calls the state machine of FMI 2.0.4 section 3.2.3 does not allow. `step`
/// as for [`probe`].
pub fn probe_me(fmu: &Fmu, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let md = fmu.model_description();
    let mut f = Vec::new();
    let t0 = md
        .default_experiment
        .as_ref()
        .and_then(|d| d.start_time)
        .unwrap_or(0.0);
    if !me_checks::normal_case("me-normal-run", step, &mut f, me_finding, || {
        me_normal_run(fmu, t0)
    }) {
        return f;
    }
    me_check_case(
        fmu,
        (
            "me-directional-derivatives",
            "probe-directional-derivative",
            t0,
        ),
        &mut f,
        step,
        &mut |me, _| me_checks::check_directional(me),
    );
    let h = event_search_step(t0, md.default_experiment.as_ref().and_then(|d| d.stop_time));
    me_check_case(
        fmu,
        ("me-state-event", "probe-event", t0),
        &mut f,
        step,
        &mut |me, reached| me_checks::check_event(me, reached, h),
    );
    if md.me_can_get_and_set_fmu_state {
        let serialize = md.me_can_serialize_fmu_state;
        let case = ("me-fmu-state", "probe-fmu-state");
        me_checks::check_case(case, step, &mut f, me_finding, || {
            let s = |e: HostError| e.to_string();
            let mut inst = fmu.instantiate("probe").map_err(s)?;
            me_initialize(&mut inst, t0).map_err(s)?;
            let reached = me_sequence(&mut Fmi2Me::new(&mut inst).map_err(s)?, t0)?;
            check_fmu_state_me(&mut inst, reached.t, h, serialize)
        });
    }
    me_case(
        fmu,
        ("me-derivatives-before-init", None),
        "fmi2GetDerivatives before initialization",
        &mut f,
        step,
        &mut |me| {
            let mut dx = vec![0.0; me.states()];
            me.get_derivatives(&mut dx).map(drop)
        },
    );
    // After fmi2ExitInitializationMode a Model Exchange instance is in Event Mode.
    me_case(
        fmu,
        ("me-set-states-in-event-mode", Some(t0)),
        "fmi2SetContinuousStates in Event Mode",
        &mut f,
        step,
        &mut |me| {
            let mut x = vec![0.0; me.states()];
            me.get_states(&mut x)?;
            me.set_states(&x)
        },
    );
    f
}

/// Enters and leaves Initialization Mode at `t0`: a Model Exchange instance is then in Event
/// Mode.
fn me_initialize(inst: &mut Instance<'_>, t0: f64) -> Result<(), HostError> {
    inst.setup_experiment(None, t0, None)?;
    inst.enter_initialization_mode()?;
    inst.exit_initialization_mode()?;
    Ok(())
}

/// The normal Model Exchange run of [`probe_me`].
fn me_normal_run(fmu: &Fmu, t0: f64) -> Result<(), String> {
    let s = |e: HostError| e.to_string();
    let mut inst = fmu.instantiate("probe").map_err(s)?;
    me_initialize(&mut inst, t0).map_err(s)?;
    let mut me = Fmi2Me::new(&mut inst).map_err(s)?;
    me_sequence(&mut me, t0)?;
    drop(me);
    inst.terminate().map_err(s)?;
    Ok(())
}

/// A check of [`me_checks`] on a fresh instance after the normal sequence: its message is a
/// finding `check`, a failing call one of the normal run.
fn me_check_case(
    fmu: &Fmu,
    (name, check, t0): (&str, &str, f64),
    f: &mut Vec<Finding>,
    step: &mut dyn FnMut(&str) -> bool,
    run: &mut dyn FnMut(&mut Fmi2Me<'_, '_>, Reached) -> Verdict,
) {
    me_checks::check_case((name, check), step, f, me_finding, || {
        let s = |e: HostError| e.to_string();
        let mut inst = fmu.instantiate("probe").map_err(s)?;
        me_initialize(&mut inst, t0).map_err(s)?;
        let mut me = Fmi2Me::new(&mut inst).map_err(s)?;
        let t = me_sequence(&mut me, t0)?;
        run(&mut me, t)
    });
}

/// In Continuous-Time Mode at `t`: the continuous states after each of 5 explicit Euler steps
/// of `h` must repeat to the bit from a restored FMU state (FMI 2.0.4 section 2.1.8).
fn check_fmu_state_me(inst: &mut Instance<'_>, t: f64, h: f64, serialize: bool) -> Verdict {
    let what = "continuous states of the next 5 Euler steps";
    me_checks::check_state_restore(inst, (what, serialize), &mut |inst| {
        let mut me = Fmi2Me::new(inst).map_err(|e| e.to_string())?;
        me_checks::euler_run(&mut me, t, h, 5)
    })
}

impl FmuStates for Instance<'_> {
    type State = FmuStateHandle;
    const NAMES: StateCallNames = StateCallNames {
        get: "fmi2GetFMUstate",
        set: "fmi2SetFMUstate",
        copy: "fmi2SerializeFMUstate, fmi2DeSerializeFMUstate and fmi2SetFMUstate",
    };

    fn get_state(&mut self) -> Result<FmuStateHandle, String> {
        self.get_fmu_state().map_err(|e| e.to_string())
    }

    fn set_state(&mut self, state: &FmuStateHandle) -> Result<(), String> {
        self.set_fmu_state(state)
            .map(drop)
            .map_err(|e| e.to_string())
    }

    fn serialized_copy(&mut self, state: &FmuStateHandle) -> Result<FmuStateHandle, String> {
        let bytes = self.serialize_fmu_state(state).map_err(|e| e.to_string())?;
        self.deserialize_fmu_state(&bytes)
            .map_err(|e| e.to_string())
    }

    fn free_state(&mut self, state: FmuStateHandle) {
        let _ = self.free_fmu_state(state);
    }
}

/// A finding of the Model Exchange probe, with its FMI 2.0.4 clause.
fn me_finding(check: &str, loc: String, message: String) -> Finding {
    let mut f = Finding::new(check, loc, message);
    f.clause = me_clause(check).to_string();
    f
}

/// The FMI 2.0.4 clause of a Model Exchange probe result (chapter 3: Model Exchange).
fn me_clause(check: &str) -> &'static str {
    match check {
        "probe-directional-derivative" => {
            "FMI 2.0.4 §2.1.9: fmi2GetDirectionalDerivative gives the partial derivatives"
        }
        "probe-event" => {
            "FMI 2.0.4 §3.2.2: fmi2NewDiscreteStates signals re-initialized states \
             (valuesOfContinuousStatesChanged)"
        }
        "probe-normal-run" => "FMI 2.0.4 §3.2.3: a legal calling sequence",
        "probe-wrong-call" => {
            "FMI 2.0.4 §3.2.3: the importer must not make this call, so the answer is the FMU's"
        }
        other => super::classify(other).1,
    }
}

/// The Model Exchange sequence after initialization, whatever the FMI version: event iteration
/// until no new discrete states are needed, Continuous-Time Mode, then 3 explicit Euler steps
/// with finite derivatives and `completedIntegratorStep` where the FMU needs it. Returns the
/// time reached and the next time event the event iteration announced.
pub(super) fn me_sequence<M: ModelExchange>(me: &mut M, t0: f64) -> Result<Reached, String> {
    let s = |e: HostError| e.to_string();
    let mut iterations = 0;
    let next_event = loop {
        let info = me.new_discrete_states().map_err(s)?;
        if !info.new_discrete_states_needed {
            break info.next_event_time;
        }
        iterations += 1;
        if iterations > 1000 {
            return Err("the event iteration still needs iterations after 1000 calls".into());
        }
    };
    me.enter_continuous_time_mode().map_err(s)?;
    let h = 1e-4;
    for k in 0..3 {
        me_checks::euler_step(me, t0 + k as f64 * h, h)?;
    }
    Ok(Reached {
        t: t0 + 3.0 * h,
        next_event,
    })
}

/// Step of the explicit Euler search for a state event: the experiment (default: 1 s) in
/// [`me_checks::EVENT_SEARCH_STEPS`] steps.
pub(super) fn event_search_step(start: f64, stop: Option<f64>) -> f64 {
    let span = stop.filter(|s| *s > start).map_or(1.0, |s| s - start);
    span / me_checks::EVENT_SEARCH_STEPS as f64
}

/// One wrong-call case of [`probe_me`] on a fresh instance, initialized at the time given with
/// the case's name: the call's answer is a note unless it is fmi2Error with a logged message.
fn me_case(
    fmu: &Fmu,
    (name, init_at): (&str, Option<f64>),
    what: &str,
    f: &mut Vec<Finding>,
    step: &mut dyn FnMut(&str) -> bool,
    call: &mut dyn FnMut(&mut Fmi2Me<'_, '_>) -> Result<(), HostError>,
) {
    if !step(name) {
        return;
    }
    let loc = format!("probe {name}");
    let mut inst = match fmu.instantiate("probe") {
        Ok(i) => i,
        Err(e) => {
            let m = format!("fmi2Instantiate (Model Exchange) failed: {e}");
            f.push(me_finding("probe-normal-run", loc, m));
            return;
        }
    };
    if let Some(t0) = init_at {
        if let Err(e) = me_initialize(&mut inst, t0) {
            let m = format!("initialization failed: {e}");
            f.push(me_finding("probe-normal-run", loc, m));
            return;
        }
    }
    let mut me = match Fmi2Me::new(&mut inst) {
        Ok(me) => me,
        Err(e) => {
            f.push(me_finding("probe-normal-run", loc, e.to_string()));
            return;
        }
    };
    match call(&mut me) {
        Ok(()) => f.push(me_finding(
            "probe-wrong-call",
            loc,
            format!(
                "{what} returned fmi2OK; fmi2Error with a logged message would warn the importer"
            ),
        )),
        Err(HostError::Fmi {
            status: Status::Error,
            messages,
            ..
        }) => {
            if messages.is_empty() {
                let m = format!("{what} returned fmi2Error but logged no message");
                f.push(me_finding("probe-log", loc, m));
            }
        }
        Err(HostError::Fmi { status, .. }) => f.push(me_finding(
            "probe-wrong-call",
            loc,
            format!("{what} returned {status}; fmi2Error is the usual answer"),
        )),
        Err(e) => f.push(me_finding("probe-normal-run", loc, format!("{what}: {e}"))),
    }
}
