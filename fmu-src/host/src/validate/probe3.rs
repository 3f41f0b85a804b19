//! The runtime state-machine probe of an FMI 3.0 Co-Simulation FMU (FMI 3.0.2 section 4.2:
//! the Co-Simulation state machine): a normal run, then calls the state machine does not
//! allow. As for FMI 2.0, a failing normal run or a crash is a finding, the answer to a call the
//! importer must not make is the FMU's (a note unless it is fmi3Error with a logged message).

use super::Finding;
use crate::error::{HostError, Status};
use crate::fmi3::{Fmu3, Instance3};
use crate::me::fmi3::Fmi3Me;
use crate::me::ModelExchange;

/// Names of the FMI 3.0 probe cases in the order [`probe3`] runs them.
pub const PROBE3_CASES: &[&str] = &[
    "fmi3-normal-run",
    "fmi3-do-step-before-init",
    "fmi3-negative-step",
    "fmi3-do-step-after-terminate",
    "fmi3-me-normal-run",
    "fmi3-me-derivatives-before-init",
];

/// The clause of an FMI 3.0 probe result.
fn clause3(check: &str) -> &'static str {
    match check {
        "probe-normal-run" => "FMI 3.0.2 §3.2 and §4.2: a legal calling sequence",
        "probe-wrong-call" => {
            "FMI 3.0.2 §4.2: the importer must not make this call, so the answer is the FMU's"
        }
        "probe-log" => "FMI 3.0.2 §2.3.1: logging is the FMU's choice",
        _ => "FMI 3.0.2 §2.2.3: every call returns a status",
    }
}

fn finding3(check: &str, loc: impl Into<String>, message: impl Into<String>) -> Finding {
    let mut f = Finding::new(check, loc, message);
    f.clause = clause3(check).to_string();
    f
}

fn initialize(inst: &mut Instance3<'_>, t0: f64) -> Result<(), HostError> {
    inst.enter_initialization_mode(None, t0, None)?;
    inst.exit_initialization_mode()?;
    Ok(())
}

/// The probe of `fmu` (opened for Co-Simulation); `step` as for [`super::probe`].
pub fn probe3(fmu: &Fmu3, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let md = fmu.model_description();
    let de = md.default_experiment.clone().unwrap_or_default();
    let t0 = de.start_time.unwrap_or(0.0);
    let h = de
        .step_size
        .filter(|h| *h > 0.0 && h.is_finite())
        .unwrap_or(1e-3)
        .min(1e-2);
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
            match call(&mut inst) {
                Ok(()) => f.push(finding3(
                    "probe-wrong-call",
                    loc,
                    format!(
                        "{what} returned fmi3OK; fmi3Error with a logged message would warn the \
                     importer"
                    ),
                )),
                Err(HostError::Fmi {
                    status: Status::Error,
                    messages,
                    ..
                }) => {
                    if messages.is_empty() {
                        let m = format!("{what} returned fmi3Error but logged no message");
                        f.push(finding3("probe-log", loc, m));
                    }
                }
                Err(HostError::Fmi { status, .. }) => f.push(finding3(
                    "probe-wrong-call",
                    loc,
                    format!("{what} returned fmi3{status:?}; fmi3Error is the usual answer"),
                )),
                Err(e) => f.push(finding3("probe-normal-run", loc, format!("{what}: {e}"))),
            }
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
    f
}

/// The Model Exchange probe of `fmu` (opened for Model Exchange): a normal run (initialization,
/// event iteration, Continuous-Time Mode, finite derivatives over 3 explicit Euler steps,
/// terminate), then `fmi3GetContinuousStateDerivatives` before initialization, which the state
/// machine of FMI 3.0.2 section 3.2 does not allow. `step` as for [`super::probe`].
pub fn probe3_me(fmu: &Fmu3, step: &mut dyn FnMut(&str) -> bool) -> Vec<Finding> {
    let t0 = fmu
        .model_description()
        .default_experiment
        .as_ref()
        .and_then(|d| d.start_time)
        .unwrap_or(0.0);
    let mut f = Vec::new();
    if !step("fmi3-me-normal-run") {
        return f;
    }
    let normal = (|| -> Result<(), String> {
        let s = |e: HostError| e.to_string();
        let mut inst = fmu.instantiate("probe").map_err(s)?;
        initialize(&mut inst, t0).map_err(s)?;
        let mut me = Fmi3Me::new(&mut inst).map_err(s)?;
        super::probe::me_sequence(&mut me, t0)?;
        drop(me);
        inst.terminate().map_err(s)?;
        Ok(())
    })();
    if let Err(e) = normal {
        let m = format!(
            "instantiate (Model Exchange), initialize, event iteration, Continuous-Time Mode, \
             derivatives, 3 Euler steps, terminate failed: {e}"
        );
        f.push(finding3("probe-normal-run", "probe fmi3-me-normal-run", m));
        return f;
    }
    let name = "fmi3-me-derivatives-before-init";
    if !step(name) {
        return f;
    }
    let what = "fmi3GetContinuousStateDerivatives before initialization";
    let loc = format!("probe {name}");
    let result = fmu.instantiate("probe").and_then(|mut inst| {
        let mut me = Fmi3Me::new(&mut inst)?;
        let mut dx = vec![0.0; me.states()];
        me.get_derivatives(&mut dx).map(drop)
    });
    match result {
        Ok(()) => f.push(finding3(
            "probe-wrong-call",
            loc,
            format!(
                "{what} returned fmi3OK; fmi3Error with a logged message would warn the importer"
            ),
        )),
        Err(HostError::Fmi {
            status: Status::Error,
            messages,
            ..
        }) => {
            if messages.is_empty() {
                let m = format!("{what} returned fmi3Error but logged no message");
                f.push(finding3("probe-log", loc, m));
            }
        }
        Err(HostError::Fmi { status, .. }) => f.push(finding3(
            "probe-wrong-call",
            loc,
            format!("{what} returned fmi3{status:?}; fmi3Error is the usual answer"),
        )),
        Err(e) => f.push(finding3("probe-normal-run", loc, format!("{what}: {e}"))),
    }
    f
}
