//! The runtime state-machine probes of an FMI 2.0 FMU: Co-Simulation ([`probe`]: a normal run,
//! FMU state save/restore, calls in wrong states or with bad arguments; FMI 2.0.4 sections 2.1
//! and 4.2.4) and Model Exchange ([`probe_me`], written once for both versions in
//! [`super::probe_me`]).

use super::cases::{self, CaseRules, Progress, SetupFailure, WrongCall, FMI2};
use super::error::{at, ProbeError, Stage, Verdict};
use super::instance::{Probed, ProbedFmu};
use super::probe_me::{probe_model_exchange, MeProbe};
use super::Finding;
use host::md::{Causality, ModelDescription, ScalarVariable, StartValue, VarKind, Variability};
use host::{Fmu, HostError, Instance, Status};
use std::collections::BTreeSet;

/// The wrong-call cases of the Co-Simulation probe: clauses of [`super::classify`].
const CS_RULES: CaseRules = CaseRules {
    dialect: &FMI2,
    finding: |check, loc, message| Finding::new(check, loc, message),
    setup: SetupFailure::NormalRun("fmi2Instantiate failed: "),
};

/// The state-machine probe. `step` is called with the name of each case (see [`super::PROBE_CASES`])
/// before it runs and returns whether to run it (the CLI prints the name so that a crash can
/// be attributed, and skips cases that crashed in an earlier attempt). Each case uses a fresh
/// instance.
pub fn probe(fmu: &Fmu, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let md = fmu.model_description();
    let mut f = Vec::new();
    let experiment = fmu.experiment();
    let (t0, h) = (experiment.start, cases::probe_step(experiment.step_size));
    if !CS_RULES.normal_run("normal-run", (step, &mut f), || normal_run(fmu, t0, h)) {
        return f;
    }
    // Capability flags kept: a restored (and a deserialized) FMU state continues bit-identically.
    let cs = md.co_simulation.clone().unwrap_or_default();
    if cs.can_get_and_set_fmu_state && step("fmu-state") {
        let m = match check_fmu_state(fmu, (t0, h), cs.can_serialize_fmu_state) {
            Ok(None) => None,
            Ok(Some(m)) => Some(m),
            Err(e) => Some(e.to_string()),
        };
        if let Some(m) = m {
            f.push(Finding::new("probe-fmu-state", "probe fmu-state", m));
        }
    }
    step_cases(fmu, (t0, h), (step, &mut f));
    variable_cases(fmu, t0, (step, &mut f));
    let terminated = WrongCall {
        name: "do-step-after-terminate",
        what: "fmi2DoStep after fmi2Terminate",
        init_at: Some(t0),
        accepted: "probe-wrong-call",
    };
    CS_RULES.run(fmu, &terminated, (step, &mut f), &mut |i| {
        i.terminate()
            .map_err(|e| HostError::Request(format!("fmi2Terminate failed: {e}")))?;
        i.do_step(t0, h, true)
    });
    f
}

/// The Real outputs' value references.
fn real_outputs(md: &ModelDescription) -> Vec<u32> {
    md.with_causality(Causality::Output)
        .filter(|v| v.kind == VarKind::Real)
        .map(|v| v.value_reference)
        .collect()
}

/// Instantiate, initialize, 10 steps with finite Real outputs, terminate, reset, initialize
/// again and one step: a legal calling sequence that must succeed. `Ok(Some(message))` when
/// `fmi2Reset` answered fmi2Error, which any call may (FMI 2.0.4 section 2.1.3: "The FMU
/// encountered an error"); an FMU whose vendor runtime this host lacks does, so it is a note and
/// the re-initialization is not probed.
fn normal_run(fmu: &Fmu, t0: f64, h: f64) -> Result<Option<String>, ProbeError> {
    let outs = real_outputs(fmu.model_description());
    let mut inst = fmu.instantiate("probe")?;
    inst.initialize(t0)?;
    let mut buf = vec![0.0; outs.len()];
    for k in 0..10 {
        inst.do_step(t0 + k as f64 * h, h, true)
            .map_err(at(Stage::Step(k)))?;
        inst.get_real(&outs, &mut buf)?;
        if let Some(i) = buf.iter().position(|x| !x.is_finite()) {
            return Err(ProbeError::OutputNotFinite {
                value_reference: outs[i],
                value: buf[i],
                step: k,
                time: t0 + (k + 1) as f64 * h,
            });
        }
    }
    inst.terminate()?;
    let reset = cases::reset_answer("fmi2", inst.reset());
    if let Some(m) = reset.map_err(at(Stage::AfterTerminate))? {
        return Ok(Some(m));
    }
    inst.initialize(t0).map_err(at(Stage::AfterReset))?;
    inst.do_step(t0, h, true).map_err(at(Stage::AfterReset))?;
    Ok(None)
}

/// Steps 5 times, saves the state, steps 5 more and records the Real outputs; restores the
/// state (and, if `serialize`, a serialized-then-deserialized copy) and repeats the 5 steps:
/// the outputs must be bit-identical (the capabilities canGetAndSetFMUstate /
/// canSerializeFMUstate the description declares).
fn check_fmu_state(fmu: &Fmu, (t0, h): (f64, f64), serialize: bool) -> Verdict {
    let outs = real_outputs(fmu.model_description());
    let mut inst = fmu.instantiate("probe")?;
    inst.initialize(t0)?;
    let t = |k: usize| t0 + k as f64 * h;
    for k in 0..5 {
        inst.do_step(t(k), h, false)?;
    }
    let saved = inst.get_fmu_state()?;
    let bytes = if serialize {
        Some(inst.serialize_fmu_state(&saved)?)
    } else {
        None
    };
    let run5 = |inst: &mut Instance<'_>| -> Result<Vec<u64>, HostError> {
        let (mut bits, mut buf) = (Vec::new(), vec![0.0; outs.len()]);
        for k in 5..10 {
            inst.do_step(t(k), h, false)?;
            inst.get_real(&outs, &mut buf)?;
            bits.extend(buf.iter().map(|x| x.to_bits()));
        }
        Ok(bits)
    };
    let first = run5(&mut inst)?;
    inst.set_fmu_state(&saved)?;
    let again = run5(&mut inst).map_err(at(Stage::AfterRestore("fmi2SetFMUstate")))?;
    if again != first {
        return Ok(Some("after fmi2SetFMUstate the outputs differ from the first run (state not fully restored)".into()));
    }
    if let Some(bytes) = bytes {
        let restored = inst.deserialize_fmu_state(&bytes)?;
        inst.set_fmu_state(&restored)?;
        let third = run5(&mut inst).map_err(at(Stage::AfterRestore("fmi2DeSerializeFMUstate")))?;
        if third != first {
            return Ok(Some("after fmi2DeSerializeFMUstate + fmi2SetFMUstate the outputs differ from the first run".into()));
        }
    }
    Ok(None)
}

/// A wrong-call case of the Co-Simulation probe, called before initialization when
/// `before_init`; an accepted NaN is a `probe-nan` note.
fn cs_case<'c>(name: &'c str, what: &'c str, before_init: bool, t0: f64) -> WrongCall<'c> {
    WrongCall {
        name,
        what,
        init_at: (!before_init).then_some(t0),
        accepted: if name.starts_with("nan") {
            "probe-nan"
        } else {
            "probe-wrong-call"
        },
    }
}

/// `fmi2DoStep` in wrong states and with wrong arguments.
fn step_cases<'f>(fmu: &'f Fmu, (t0, h): (f64, f64), (step, f): Progress<'_>) {
    let cases: [(&str, &str, bool, f64, f64); 3] = [
        (
            "do-step-before-init",
            "fmi2DoStep before initialization",
            true,
            t0,
            h,
        ),
        (
            "negative-step",
            "fmi2DoStep with a negative step size",
            false,
            t0,
            -h,
        ),
        (
            "wrong-communication-point",
            "fmi2DoStep with currentCommunicationPoint != current time",
            false,
            t0 + 100.0 * h + 1.0,
            h,
        ),
    ];
    for (name, what, before_init, t, dt) in cases {
        let case = cs_case(name, what, before_init, t0);
        CS_RULES.run(
            fmu,
            &case,
            (&mut *step, &mut *f),
            &mut |i: &mut Instance<'f>| i.do_step(t, dt, true),
        );
    }
}

/// Calls on variables: an unknown value reference, NaN on a Real input (else parameter), a
/// fixed parameter set after initialization, `fmi2SetBoolean` on a Real.
fn variable_cases<'f>(fmu: &'f Fmu, t0: f64, (step, f): Progress<'_>) {
    let md = fmu.model_description();
    let mut case =
        |name: &str,
         what: &str,
         before_init: bool,
         call: &mut dyn FnMut(&mut Instance<'f>) -> Result<Status, HostError>| {
            let case = cs_case(name, what, before_init, t0);
            CS_RULES.run(fmu, &case, (&mut *step, &mut *f), call);
        };
    let unknown_vr =
        cases::unknown_value_reference(md.model_variables.iter().map(|v| v.value_reference));
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
    // NaN on a Real input after initialization, else on a parameter before it
    let nan_target = real_input
        .map(|v| (v, "nan-input", "input", false))
        .or_else(|| real_param.map(|v| (v, "nan-parameter", "parameter", true)));
    if let Some((v, name, role, before_init)) = nan_target {
        let vr = v.value_reference;
        let what = format!("fmi2SetReal NaN on {role} '{}'", v.name);
        case(name, &what, before_init, &mut |i| {
            i.set_real(&[vr], &[f64::NAN])
        });
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
}

/// The Model Exchange probe of FMI 2.0: FMI 2.0.4 clauses, calls by their FMI 2.0 names.
const ME_PROBE: MeProbe = MeProbe {
    prefix: "",
    rules: CaseRules {
        dialect: &FMI2,
        finding: me_finding,
        setup: SetupFailure::NormalRun("fmi2Instantiate (Model Exchange) failed: "),
    },
    get_derivatives: "fmi2GetDerivatives",
    set_states: "fmi2SetContinuousStates",
};

/// The state-machine probe of an FMI 2.0 Model Exchange FMU (`fmu` opened with the Model
/// Exchange interface): a normal run (instantiate, initialize, event iteration, Continuous-Time
/// Mode, derivatives finite, a few explicit Euler steps with `fmi2CompletedIntegratorStep`,
/// terminate), then calls the state machine of FMI 2.0.4 section 3.2.3 does not allow. `step`
/// as for [`probe`].
pub fn probe_me(fmu: &Fmu, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    probe_model_exchange(fmu, &ME_PROBE, step)
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
