//! Runtime checks of a Model Exchange FMU written against [`ModelExchange`], so that the FMI 2.0
//! and FMI 3.0 probes share them: the directional derivatives of the state derivatives against
//! finite differences, the event flags against what the event did to the states, and a short
//! explicit Euler run whose states can be compared bit for bit (FMU state save/restore).
//!
//! The check of a restored FMU state ([`check_state_restore`]) serves the Co-Simulation probe of
//! FMI 3.0 too.
//!
//! Each check returns a [`Verdict`]: `Ok(None)` when the FMU does what the standard says,
//! `Ok(Some(message))` with what it did instead, and `Err` when a call the standard allows failed.

use super::cases::MakeFinding;
use super::error::{ProbeError, Verdict};
use super::instance::{FmuStates, StateCallNames};
use super::Finding;
use host::me::ModelExchange;

/// Where the probe's normal Model Exchange sequence left an instance (in Continuous-Time Mode).
#[derive(Clone, Copy, Debug)]
pub struct Reached {
    /// The time reached.
    pub t: f64,
    /// The next time event the last event iteration announced (`nextEventTime`).
    pub next_event: Option<f64>,
}

/// The normal run of a Model Exchange probe, case `name`, when `step` lets it run: `run`
/// instantiates, initializes, goes through the normal sequence and terminates. Whether the
/// probe goes on: the other cases assume a working FMU, so a failing run ends it.
pub fn normal_case(
    name: &str,
    step: &mut dyn FnMut(&str) -> bool,
    f: &mut Vec<Finding>,
    finding: MakeFinding,
    run: impl FnOnce() -> Result<(), ProbeError>,
) -> bool {
    if !step(name) {
        return false;
    }
    let Err(e) = run() else {
        return true;
    };
    let m = format!(
        "instantiate (Model Exchange), initialize, event iteration, Continuous-Time Mode, \
         derivatives, 3 Euler steps, terminate failed: {e}"
    );
    f.push(finding("probe-normal-run", format!("probe {name}"), m));
    false
}

/// Check case `name` of a Model Exchange probe, when `step` lets it run (see [`super::probe`]):
/// `run` takes a fresh instance through the normal sequence and makes the check. Its message is
/// a finding `check`; a failing call is one of the normal run, since the check could not be
/// made. `finding` gives the FMI version's clause (the FMI 2.0 and 3.0 probes differ only there
/// and in how they instantiate).
pub fn check_case(
    (name, check): (&str, &str),
    step: &mut dyn FnMut(&str) -> bool,
    f: &mut Vec<Finding>,
    finding: MakeFinding,
    run: impl FnOnce() -> Verdict,
) {
    if !step(name) {
        return;
    }
    let loc = format!("probe {name}");
    match run() {
        Ok(None) => {}
        Ok(Some(m)) => f.push(finding(check, loc, m)),
        Err(e) => f.push(finding("probe-normal-run", loc, e.to_string())),
    }
}

/// The cube root of the machine epsilon, 2^(-52/3): the relative step of a central difference
/// that balances its truncation error against rounding.
const CBRT_EPSILON: f64 = 6.055454452393344e-6;

/// Relative tolerance between a directional derivative and a finite difference. Generous: a
/// wrong entry is typically off by its own size, while a correct one differs from a difference
/// quotient by the truncation error, of order delta * |f''| (forward) or delta^2 * |f'''|
/// (central), with delta = 6e-6 relative.
const DERIVATIVE_RTOL: f64 = 1e-2;

/// The directional derivatives `d der(x_i) / d x_j` (one seed per state, as an implicit
/// integrator asks for them) against finite differences of `getDerivatives` at the current
/// states, in Continuous-Time Mode. An entry is wrong only when it disagrees with the forward,
/// the backward and the central difference alike (a kink of the right-hand side at the point
/// spoils one-sided differences, not all three). The states are restored afterwards. States the
/// FMU refuses near the current ones end the check without a verdict.
pub fn check_directional<M: ModelExchange>(me: &mut M) -> Verdict {
    if !me.provides_directional_derivative() || me.states() == 0 {
        return Ok(None);
    }
    let n = me.states();
    let (mut x, mut nominal) = (vec![0.0; n], vec![0.0; n]);
    me.get_states(&mut x)?;
    me.get_nominals(&mut nominal)?;
    let Some(f0) = derivatives_at(me, &x) else {
        return Ok(None);
    };
    let mut column = vec![0.0; n];
    for j in 0..n {
        // delta = eps^(1/3) * scale balances the central difference's truncation and rounding
        let scale = x[j].abs().max(nominal[j].abs()).max(1e-3);
        let delta = CBRT_EPSILON * scale;
        let mut xp = x.clone();
        xp[j] += delta;
        // A state the FMU refuses a few ulps-of-scale away (at a bound of its domain, say)
        // leaves the check without a verdict: the FMU may be in an error state from here on.
        let Some(fp) = derivatives_at(me, &xp) else {
            return Ok(None);
        };
        xp[j] = x[j] - delta;
        let Some(fm) = derivatives_at(me, &xp) else {
            return Ok(None);
        };
        me.set_states(&x)?;
        me.state_derivative_column(j, &mut column)?;
        for i in 0..n {
            let forward = (fp[i] - f0[i]) / delta;
            let backward = (f0[i] - fm[i]) / delta;
            let central = (fp[i] - fm[i]) / (2.0 * delta);
            // rounding of the derivatives themselves, amplified by 1/delta
            let size = f0[i].abs().max(fp[i].abs()).max(fm[i].abs());
            let noise = 1e3 * f64::EPSILON * size / delta;
            let agrees = |fd: f64| {
                (column[i] - fd).abs() <= DERIVATIVE_RTOL * column[i].abs().max(fd.abs()) + noise
            };
            if !(agrees(forward) || agrees(backward) || agrees(central)) || !column[i].is_finite() {
                return Ok(Some(format!(
                    "d der(x{i}) / d x{j} (state derivative {i} with respect to state {j}, in \
                     the order of the state vector) is {} from the directional derivative but \
                     {central:.6e} from central differences (forward {forward:.6e}, backward \
                     {backward:.6e}, step {delta:.1e}) at x = {x:?}",
                    column[i]
                )));
            }
        }
    }
    me.set_states(&x)?;
    Ok(None)
}

/// The state derivatives at the states `x` (set first); None when the FMU refuses the states
/// or discards the derivatives there, or they are not finite.
fn derivatives_at<M: ModelExchange>(me: &mut M, x: &[f64]) -> Option<Vec<f64>> {
    let mut dx = vec![0.0; x.len()];
    me.set_states(x).ok()?;
    let valid = me.get_derivatives(&mut dx).ok()?;
    (valid && dx.iter().all(|d| d.is_finite())).then_some(dx)
}

/// One explicit Euler step of length `h` from time `t` (x(t + h) = x(t) + h dx/dt(t)), with
/// `completedIntegratorStep` when the FMU needs it. Returns whether it asked for an event.
pub fn euler_step<M: ModelExchange>(me: &mut M, t: f64, h: f64) -> Result<bool, ProbeError> {
    let n = me.states();
    let (mut x, mut dx) = (vec![0.0; n], vec![0.0; n]);
    me.set_time(t)?;
    get_states(me, &mut x)?;
    get_derivatives(me, &mut dx)?;
    if let Some(i) = dx.iter().position(|d| !d.is_finite()) {
        return Err(ProbeError::DerivativeNotFinite {
            index: i,
            value: dx[i],
            time: t,
        });
    }
    for (xi, di) in x.iter_mut().zip(&dx) {
        *xi += h * di;
    }
    me.set_time(t + h)?;
    set_states(me, &x)?;
    if me.needs_completed_integrator_step() {
        return Ok(me.completed_integrator_step()?.enter_event_mode);
    }
    Ok(false)
}

/// `steps` explicit Euler steps of length `h` from `t`; the states after each, as bits (the
/// FMU state check compares two such runs from one saved state).
pub fn euler_run<M: ModelExchange>(
    me: &mut M,
    t: f64,
    h: f64,
    steps: usize,
) -> Result<Vec<u64>, ProbeError> {
    let mut x = vec![0.0; me.states()];
    let mut bits = Vec::new();
    for k in 0..steps {
        euler_step(me, t + k as f64 * h, h)?;
        get_states(me, &mut x)?;
        bits.extend(x.iter().map(|v| v.to_bits()));
    }
    Ok(bits)
}

/// Most explicit Euler steps [`check_event`] takes looking for the first state event.
pub const EVENT_SEARCH_STEPS: usize = 1000;

/// Integrates with explicit Euler steps of `h` from `from` (in Continuous-Time Mode) until the
/// first state event (an event indicator changes domain, `z > 0` against `z <= 0`: FMI 2.0.4
/// section 3.1, FMI 3.0.2 section 3.1), at most [`EVENT_SEARCH_STEPS`] steps; time and step
/// events met on the way are handled too. At each event the states are read before and after
/// the event iteration: states that changed while every `newDiscreteStates` /
/// `fmi3UpdateDiscreteStates` call reported `valuesOfContinuousStatesChanged = false` are a
/// finding (the importer would integrate on from the old states). A search that explicit Euler
/// cannot carry (a stiff FMU) ends without a verdict.
pub fn check_event<M: ModelExchange>(me: &mut M, from: Reached, h: f64) -> Verdict {
    let (n, m) = (me.states(), me.indicators());
    let (mut z0, mut z1) = (vec![0.0; m], vec![0.0; m]);
    let (mut t, mut next_time) = (from.t, from.next_event);
    me.get_event_indicators(&mut z0)?;
    for _ in 0..EVENT_SEARCH_STEPS {
        let step = next_time.map_or(h, |te| (te - t).clamp(0.0, h));
        // Explicit Euler is unstable on a stiff FMU with this step: derivatives that the FMU
        // refuses or that are not finite end the search without a verdict (the normal run
        // checked them at valid states).
        let Ok(step_event) = euler_step(me, t, step) else {
            return Ok(None);
        };
        t += step;
        if me.get_event_indicators(&mut z1).is_err() || z1.iter().any(|z| !z.is_finite()) {
            return Ok(None);
        }
        let state_event = z0.iter().zip(&z1).any(|(a, b)| (*a > 0.0) != (*b > 0.0));
        let time_event = next_time.is_some_and(|te| t >= te);
        if state_event || time_event || step_event {
            let mut before = vec![0.0; n];
            get_states(me, &mut before)?;
            me.enter_event_mode()?;
            let (mut changed, mut terminate) = (false, false);
            next_time = None;
            for _ in 0..1000 {
                let info = me.new_discrete_states()?;
                changed |= info.values_changed;
                terminate |= info.terminate_simulation;
                next_time = info.next_event_time;
                if !info.new_discrete_states_needed || terminate {
                    break;
                }
            }
            let mut after = vec![0.0; n];
            get_states(me, &mut after)?;
            let moved = before
                .iter()
                .zip(&after)
                .position(|(a, b)| a.to_bits() != b.to_bits());
            if let (Some(i), false) = (moved, changed) {
                let kind = if state_event { "state" } else { "time or step" };
                return Ok(Some(format!(
                    "at the {kind} event at t = {t}, state {i} changed from {:e} to {:e} in the \
                     event iteration, but every call reported \
                     valuesOfContinuousStatesChanged = false",
                    before[i], after[i]
                )));
            }
            if terminate || state_event {
                return Ok(None);
            }
            me.enter_continuous_time_mode()?;
            me.get_event_indicators(&mut z1)?;
        }
        std::mem::swap(&mut z0, &mut z1);
    }
    Ok(None)
}

/// Saves the FMU state, runs `run`, restores the state and runs it again, then (if `serialize`)
/// the same from a serialized and deserialized copy: what `run` gives (its `what`, in the
/// messages) must be the same bits each time (FMI 2.0.4 section 2.1.8, FMI 3.0.2 section
/// 2.2.7.4). Both states are freed.
pub(crate) fn check_state_restore<I: FmuStates>(
    inst: &mut I,
    (what, serialize): (&str, bool),
    run: &mut dyn FnMut(&mut I) -> Result<Vec<u64>, ProbeError>,
) -> Verdict {
    let StateCallNames { get, set, copy } = I::NAMES;
    let saved = inst.get_state()?;
    let result = (|| -> Verdict {
        let first = run(inst)?;
        inst.set_state(&saved)?;
        if run(inst)? != first {
            return Ok(Some(format!(
                "after {set} the {what} differ from those after {get} (the state is not fully \
                 restored)"
            )));
        }
        if !serialize {
            return Ok(None);
        }
        let restored = inst.serialized_copy(&saved)?;
        let again = inst
            .set_state(&restored)
            .map_err(ProbeError::from)
            .and_then(|()| run(inst));
        inst.free_state(restored);
        Ok((again? != first)
            .then(|| format!("after {copy} the {what} differ from those after {get}")))
    })();
    inst.free_state(saved);
    result
}

/// `getContinuousStates` into `x`; with no continuous states (nx = 0) not called: there is
/// nothing to get ("The number of Unknown elements in the Derivatives element uniquely defines
/// the number of continuous time state variables", FMI 2.0.4 section 2.2.8; FMI 3.0.2 section
/// 2.4.8 likewise), and some FMUs answer an empty call with an error.
fn get_states<M: ModelExchange>(me: &mut M, x: &mut [f64]) -> Result<(), host::HostError> {
    match x.is_empty() {
        true => Ok(()),
        false => me.get_states(x),
    }
}

/// `setContinuousStates` of `x`; not called with no continuous states (see [`get_states`]).
fn set_states<M: ModelExchange>(me: &mut M, x: &[f64]) -> Result<(), host::HostError> {
    match x.is_empty() {
        true => Ok(()),
        false => me.set_states(x),
    }
}

/// `getDerivatives` into `dx` (false: the FMU asked for a smaller step); not called with no
/// continuous states (see [`get_states`]).
fn get_derivatives<M: ModelExchange>(me: &mut M, dx: &mut [f64]) -> Result<bool, host::HostError> {
    match dx.is_empty() {
        true => Ok(true),
        false => me.get_derivatives(dx),
    }
}
