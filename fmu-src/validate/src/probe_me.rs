//! The Model Exchange probe of either FMI version (FMI 2.0.4 section 3.2.3, FMI 3.0.2 sections
//! 2.3 and 3.2): a normal run (instantiate, initialize, event iteration, Continuous-Time Mode,
//! finite derivatives over 3 explicit Euler steps, terminate); directional derivatives against
//! finite differences, the event flags at the first state event, a restored FMU state; then the
//! state derivatives before initialization and continuous states set in Event Mode, which the
//! state machine does not allow. The versions differ in their case names, clauses and calls
//! ([`MeProbe`]).

use super::cases::{CaseRules, WrongCall};
use super::error::{ProbeError, Verdict};
use super::instance::{Probed, ProbedFmu};
use super::me_checks::{self, Reached};
use super::Finding;
use host::me::ModelExchange;

/// One version's Model Exchange probe.
pub(crate) struct MeProbe {
    /// Prefix of its case names (`fmi3-`; none for FMI 2.0).
    pub prefix: &'static str,
    /// Its clauses, spelling and how a failing set-up of a wrong call counts.
    pub rules: CaseRules,
    /// The call that gets the state derivatives (`fmi2GetDerivatives`).
    pub get_derivatives: &'static str,
    /// The call that sets the continuous states (`fmi2SetContinuousStates`).
    pub set_states: &'static str,
}

/// Most `newDiscreteStates` calls of one event iteration of the normal sequence.
const MAX_EVENT_ITERATIONS: usize = 1000;

/// Step of the explicit Euler steps of the normal sequence (s).
const NORMAL_STEP: f64 = 1e-4;

/// The Model Exchange probe of `fmu` (opened for Model Exchange), the cases named and judged as
/// `p` says; `step` as for [`super::probe`].
pub(crate) fn probe_model_exchange<'f, F: ProbedFmu>(
    fmu: &'f F,
    p: &MeProbe,
    step: &mut dyn FnMut(&str) -> bool,
) -> Vec<Finding> {
    let experiment = fmu.experiment();
    let t0 = experiment.start;
    let finding = p.rules.finding;
    let name = |case: &str| format!("{}{case}", p.prefix);
    let mut f = Vec::new();
    let normal = || -> Result<(), ProbeError> {
        let mut inst = fmu.instantiate()?;
        inst.initialize(t0)?;
        me_sequence(&mut inst.model_exchange()?, t0)?;
        inst.end()?;
        Ok(())
    };
    if !me_checks::normal_case(&name("me-normal-run"), step, &mut f, finding, normal) {
        return f;
    }
    let h = event_search_step(t0, experiment.stop);
    let mut check =
        |case: &str, check: &str, run: &mut dyn FnMut(&mut F::Instance<'f>, Reached) -> Verdict| {
            me_checks::check_case((&name(case), check), step, &mut f, finding, || {
                let mut inst = fmu.instantiate()?;
                inst.initialize(t0)?;
                let reached = me_sequence(&mut inst.model_exchange()?, t0)?;
                run(&mut inst, reached)
            });
        };
    check(
        "me-directional-derivatives",
        "probe-directional-derivative",
        &mut |inst, _| me_checks::check_directional(&mut inst.model_exchange()?),
    );
    check("me-state-event", "probe-event", &mut |inst, reached| {
        me_checks::check_event(&mut inst.model_exchange()?, reached, h)
    });
    let (get_and_set, serialize) = fmu.model_exchange_states();
    if get_and_set {
        check("me-fmu-state", "probe-fmu-state", &mut |inst, reached| {
            check_fmu_state(inst, (reached.t, h), serialize)
        });
    }
    let case = WrongCall {
        name: &name("me-derivatives-before-init"),
        what: &format!("{} before initialization", p.get_derivatives),
        init_at: None,
        accepted: "probe-wrong-call",
    };
    p.rules.run_me(fmu, &case, (step, &mut f), &mut |me| {
        let mut dx = vec![0.0; me.states()];
        me.get_derivatives(&mut dx).map(drop)
    });
    // After exitInitializationMode a Model Exchange instance is in Event Mode, where the
    // continuous states may not be set (FMI 2.0.4 section 3.2.3, FMI 3.0.2 section 2.3.5).
    let case = WrongCall {
        name: &name("me-set-states-in-event-mode"),
        what: &format!("{} in Event Mode", p.set_states),
        init_at: Some(t0),
        accepted: "probe-wrong-call",
    };
    p.rules.run_me(fmu, &case, (step, &mut f), &mut |me| {
        let mut x = vec![0.0; me.states()];
        me.get_states(&mut x)?;
        me.set_states(&x)
    });
    f
}

/// In Continuous-Time Mode at `t`: the continuous states after each of 5 explicit Euler steps
/// of `h` must repeat to the bit from a restored FMU state (FMI 2.0.4 section 2.1.8, FMI 3.0.2
/// section 2.2.7.4).
fn check_fmu_state<I: Probed>(inst: &mut I, (t, h): (f64, f64), serialize: bool) -> Verdict {
    let what = "continuous states of the next 5 Euler steps";
    me_checks::check_state_restore(inst, (what, serialize), &mut |inst| {
        me_checks::euler_run(&mut inst.model_exchange()?, t, h, 5)
    })
}

/// The Model Exchange sequence after initialization, whatever the FMI version: event iteration
/// until no new discrete states are needed, Continuous-Time Mode, then 3 explicit Euler steps
/// with finite derivatives and `completedIntegratorStep` where the FMU needs it. Returns the
/// time reached and the next time event the event iteration announced.
pub(crate) fn me_sequence<M: ModelExchange>(me: &mut M, t0: f64) -> Result<Reached, ProbeError> {
    let mut iterations = 0;
    let next_event = loop {
        let info = me.new_discrete_states()?;
        if !info.new_discrete_states_needed {
            break info.next_event_time;
        }
        iterations += 1;
        if iterations > MAX_EVENT_ITERATIONS {
            return Err(ProbeError::EventIterationEndless {
                limit: MAX_EVENT_ITERATIONS,
                time: t0,
            });
        }
    };
    me.enter_continuous_time_mode()?;
    for k in 0..3 {
        me_checks::euler_step(me, t0 + k as f64 * NORMAL_STEP, NORMAL_STEP)?;
    }
    Ok(Reached {
        t: t0 + 3.0 * NORMAL_STEP,
        next_event,
    })
}

/// Step of the explicit Euler search for a state event: the experiment (default: 1 s) in
/// [`me_checks::EVENT_SEARCH_STEPS`] steps.
pub(crate) fn event_search_step(start: f64, stop: Option<f64>) -> f64 {
    let span = stop.filter(|s| *s > start).map_or(1.0, |s| s - start);
    span / me_checks::EVENT_SEARCH_STEPS as f64
}
