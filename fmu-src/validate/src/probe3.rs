//! The runtime state-machine probes of an FMI 3.0 FMU: Co-Simulation (FMI 3.0.2 section 4.2)
//! and Model Exchange (section 3.2, written once for both versions in [`super::probe_me`]),
//! each a normal run, then checks of what the standard requires (a saved FMU state restored,
//! directional derivatives against finite differences, re-initialized states signalled at an
//! event), then calls the state machine (section 2.3) does not allow. As for FMI 2.0, a failing
//! normal run or a crash is a finding, the answer to a call the importer must not make is the
//! FMU's (a note unless it is fmi3Error). The host instantiates with `loggingOn = fmi3False`,
//! with which the FMU must not call the logger (section 2.3.1), so an error without a logged
//! message is no finding here.

use super::cases::{self, CaseRules, Progress, SetupFailure, WrongCall, FMI3};
use super::error::{ProbeError, Verdict};
use super::instance::{declares, Probed, ProbedFmu};
use super::me_checks;
use super::probe_me::{probe_model_exchange, MeProbe};
use super::Finding;
use host::fmi3::md::Causality3;
use host::fmi3::value::{Type3, Values};
use host::fmi3::{Fmu3, Instance3};
use host::md::Variability;
use host::{HostError, Status};

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
        "probe-reset" => {
            "FMI 3.0.2 §2.2.4: any call may return fmi3Error (\"The call failed\"); §2.3.1 \
             requires no more of fmi3Reset"
        }
        "probe-event" => {
            "FMI 3.0.2 §2.3.5: fmi3UpdateDiscreteStates signals re-initialized states \
             (valuesOfContinuousStatesChanged)"
        }
        _ => "FMI 3.0.2 §2.2.4: every call returns a status",
    }
}

/// A finding of an FMI 3.0 probe, with its FMI 3.0.2 clause.
fn finding3(check: &str, loc: String, message: String) -> Finding {
    let mut f = Finding::new(check, loc, message);
    f.clause = clause3(check).to_string();
    f
}

/// The wrong-call cases of the Co-Simulation probe.
const CS_RULES: CaseRules = CaseRules {
    dialect: &FMI3,
    finding: finding3,
    setup: SetupFailure::NormalRun(""),
};

/// The probe of `fmu` (opened for Co-Simulation); `step` as for [`super::probe`].
pub fn probe3(fmu: &Fmu3, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let experiment = fmu.experiment();
    let (t0, h) = (experiment.start, cases::probe_step(experiment.step_size));
    let mut f = Vec::new();
    if !CS_RULES.normal_run("fmi3-normal-run", (step, &mut f), || normal_run(fmu, t0, h)) {
        return f;
    }
    if declares(fmu, false, "canGetAndSetFMUState") {
        let case = ("fmi3-fmu-state", "probe-fmu-state");
        me_checks::check_case(case, step, &mut f, finding3, || check_fmu_state(fmu, t0, h));
    }
    wrong_calls(fmu, (t0, h), (step, &mut f));
    f
}

/// Instantiate, initialize, 10 steps (fewer when the FMU asks to terminate), terminate, reset,
/// initialize again and one step: a legal calling sequence that must succeed, but for
/// fmi3Reset returning fmi3Error (Some: its message), which FMI 3.0.2 allows: section 2.2.4
/// lets any call return fmi3Error ("The call failed"), and section 2.3.1 asks fmi3Reset for the
/// state after instantiation only when it succeeds.
fn normal_run(fmu: &Fmu3, t0: f64, h: f64) -> Result<Option<String>, HostError> {
    let mut inst = fmu.instantiate("probe")?;
    inst.initialize(t0)?;
    for k in 0..10 {
        if inst.do_step(t0 + k as f64 * h, h, true)?.terminate {
            break;
        }
    }
    inst.terminate()?;
    if let Some(m) = cases::reset_answer("fmi3", inst.reset())? {
        return Ok(Some(m));
    }
    inst.initialize(t0)?;
    inst.do_step(t0, h, true)?;
    Ok(None)
}

/// The calls the Co-Simulation state machine does not allow: `fmi3DoStep` before
/// initialization, with a negative step, after terminate and at a wrong communication point;
/// an unknown value reference; a fixed parameter set in Step Mode.
fn wrong_calls<'f>(fmu: &'f Fmu3, (t0, h): (f64, f64), (step, f): Progress<'_>) {
    let md = fmu.model_description();
    let mut case =
        |name: &str,
         what: &str,
         init: bool,
         call: &mut dyn FnMut(&mut Instance3<'f>) -> Result<(), HostError>| {
            let case = WrongCall {
                name,
                what,
                init_at: init.then_some(t0),
                accepted: "probe-wrong-call",
            };
            CS_RULES.run(fmu, &case, (&mut *step, &mut *f), &mut |i| {
                call(i).map(|()| Status::Ok)
            });
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
    let unknown_vr = cases::unknown_value_reference(md.variables.iter().map(|v| v.value_reference));
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
}

/// Steps 5 times, then the Float64 outputs after each of 5 more steps must repeat to the bit
/// from a restored FMU state.
fn check_fmu_state(fmu: &Fmu3, t0: f64, h: f64) -> Verdict {
    let md = fmu.model_description();
    let outs: Vec<u32> = md
        .with_causality(Causality3::Output)
        .filter(|v| v.ty == Type3::Float64 && !v.is_array())
        .map(|v| v.value_reference)
        .collect();
    let mut inst = fmu.instantiate("probe")?;
    inst.initialize(t0)?;
    let t = |k: usize| t0 + k as f64 * h;
    for k in 0..5 {
        inst.do_step(t(k), h, false)?;
    }
    let mut run5 = |inst: &mut Instance3<'_>| -> Result<Vec<u64>, ProbeError> {
        let mut bits = Vec::new();
        for k in 5..10 {
            inst.do_step(t(k), h, false)?;
            if let Values::Float64(v) = inst.get(Type3::Float64, &outs, outs.len())? {
                bits.extend(v.iter().map(|x| x.to_bits()));
            }
        }
        Ok(bits)
    };
    let what = "Float64 outputs of the next 5 steps";
    let serialize = declares(fmu, false, "canSerializeFMUState");
    me_checks::check_state_restore(&mut inst, (what, serialize), &mut run5)
}

/// The Model Exchange probe of FMI 3.0: FMI 3.0.2 clauses, calls by their FMI 3.0 names, and
/// a failing set-up of a wrong call judged as its answer.
const ME_PROBE: MeProbe = MeProbe {
    prefix: "fmi3-",
    rules: CaseRules {
        dialect: &FMI3,
        finding: finding3,
        setup: SetupFailure::Answer,
    },
    get_derivatives: "fmi3GetContinuousStateDerivatives",
    set_states: "fmi3SetContinuousStates",
};

/// The Model Exchange probe of `fmu` (opened for Model Exchange): see [`super::probe_me`];
/// `step` as for [`super::probe`].
pub fn probe3_me(fmu: &Fmu3, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    probe_model_exchange(fmu, &ME_PROBE, step)
}
