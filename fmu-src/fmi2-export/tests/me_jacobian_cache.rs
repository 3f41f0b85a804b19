//! `fmi2GetDirectionalDerivative` in Model Exchange computes the model's state Jacobian once per
//! point and serves the other columns from it: every column must still be exactly the Jacobian
//! of the instance's current point. The reference is the model's own analytic Jacobian evaluated
//! afresh at that point (`ModelExchange::state_jacobian`); each change below is checked to move
//! the Jacobian, so that a stale one would fail the comparison.

use fmi2_export::calls;
use fmu_core::{EventInfo, Experiment, Instance, Interface, ModelExchange, Status, VarType};
use hydraulic_joint::me::STATES;
use hydraulic_joint::{HydraulicJoint, V, VARIABLES};

fn vr(v: V) -> u32 {
    VARIABLES[v as usize].value_reference
}

/// Value references of the states and of their derivatives, in the order of the state vector.
fn state_references() -> (Vec<u32>, Vec<u32>) {
    HydraulicJoint::state_variables()
        .iter()
        .map(|&(x, d)| (VARIABLES[x].value_reference, VARIABLES[d].value_reference))
        .unzip()
}

/// An instance in Continuous-Time Mode at t = 0, closed loop or open loop.
fn running(closed_loop: bool) -> Instance<HydraulicJoint> {
    let names = calls::STATE_NAMES;
    let mut inst = Instance::with_interface(
        "cache",
        String::new(),
        false,
        Interface::ModelExchange,
        names,
    )
    .expect("HydraulicJoint offers Model Exchange");
    let experiment = Experiment {
        start: 0.0,
        stop: None,
        tolerance: None,
    };
    let s = inst.call(calls::SETUP_EXPERIMENT, |i, c| {
        i.setup_experiment(c, experiment)
    });
    assert_eq!(s, Status::Ok);
    let flag = if closed_loop { 1.0 } else { 0.0 };
    let internal = [vr(V::INTERNAL_CONTROLLER)];
    assert_eq!(
        inst.call(calls::SET_BOOLEAN, |i, c| i.set_values(
            c,
            VarType::Boolean,
            &internal,
            &[flag]
        )),
        Status::Ok
    );
    let s = inst.call(calls::ENTER_INITIALIZATION_MODE, |i, c| {
        i.enter_initialization_mode(c)
    });
    assert_eq!(s, Status::Ok);
    let s = inst.call(calls::EXIT_INITIALIZATION_MODE, |i, c| {
        i.exit_initialization_mode(c)
    });
    assert_eq!(s, Status::Ok);
    assert_eq!(
        inst.call(calls::NEW_DISCRETE_STATES, |i, c| {
            i.new_discrete_states(c, &mut EventInfo::default())
        }),
        Status::Ok
    );
    assert_eq!(
        inst.call(calls::ENTER_CONTINUOUS_TIME_MODE, |i, c| i
            .enter_continuous_time_mode(c)),
        Status::Ok
    );
    inst
}

/// The Jacobian as an importer asks for it: one directional derivative per state (unit seed).
fn by_columns(inst: &mut Instance<HydraulicJoint>) -> Vec<f64> {
    let (states, derivatives) = state_references();
    let mut jac = vec![0.0; STATES * STATES];
    let mut column = vec![0.0; STATES];
    for (j, &x) in states.iter().enumerate() {
        let s = inst.call(calls::GET_DIRECTIONAL_DERIVATIVE, |i, c| {
            i.get_directional_derivative(c, &derivatives, &[x], &[1.0], &mut column)
        });
        assert_eq!(s, Status::Ok, "{:?}", inst.log);
        for (i, &c) in column.iter().enumerate() {
            jac[i * STATES + j] = c;
        }
    }
    jac
}

/// The model's analytic Jacobian at the instance's current point, evaluated now.
fn fresh(inst: &Instance<HydraulicJoint>) -> Vec<f64> {
    let mut jac = vec![0.0; STATES * STATES];
    inst.model
        .state_jacobian(&inst.vars, inst.time, &mut jac)
        .expect("initialized");
    // the directional derivative is 0 + J_ij * 1: a -0.0 entry comes back as +0.0
    jac.iter().map(|v| v + 0.0).collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The columns agree with a new evaluation bit for bit, and differ from `before` (the change
/// moved the Jacobian, so a stale cache would be caught).
fn check_moved(inst: &mut Instance<HydraulicJoint>, before: &[f64], what: &str) -> Vec<f64> {
    let jac = by_columns(inst);
    assert_eq!(bits(&jac), bits(&fresh(inst)), "after {what}");
    assert_ne!(
        bits(&jac),
        bits(before),
        "{what} does not move the Jacobian"
    );
    jac
}

#[test]
fn every_column_is_the_jacobian_of_the_current_point() {
    let mut inst = running(true);
    let j0 = by_columns(&mut inst);
    assert_eq!(bits(&j0), bits(&fresh(&inst)));
    assert!(j0.iter().any(|&v| v != 0.0));
    // asked again at the same point (another seed, a subset of unknowns): the same values
    assert_eq!(bits(&by_columns(&mut inst)), bits(&j0));
    let (states, derivatives) = state_references();
    let mut dz = [0.0; 2];
    let s = inst.call(calls::GET_DIRECTIONAL_DERIVATIVE, |i, c| {
        let (u, k) = ([derivatives[5], derivatives[4]], [states[4], states[3]]);
        i.get_directional_derivative(c, &u, &k, &[2.0, -0.5], &mut dz)
    });
    assert_eq!(s, Status::Ok);
    let expected = [
        0.0 + j0[5 * STATES + 4] * 2.0 + j0[5 * STATES + 3] * -0.5,
        0.0 + j0[4 * STATES + 4] * 2.0 + j0[4 * STATES + 3] * -0.5,
    ];
    assert_eq!(bits(&dz), bits(&expected));

    // fmi2SetContinuousStates: the left piston's chamber pressures and position
    let mut x = vec![0.0; STATES];
    assert_eq!(
        inst.call(calls::GET_CONTINUOUS_STATES, |i, c| i
            .get_continuous_states(c, &mut x)),
        Status::Ok
    );
    let saved_x = x.clone();
    let snapshot = inst.snapshot();
    x[2] += 1e-3;
    x[4] *= 1.7;
    x[5] *= 0.6;
    assert_eq!(
        inst.call(calls::SET_CONTINUOUS_STATES, |i, c| i
            .set_continuous_states(c, &x)),
        Status::Ok
    );
    let j1 = check_moved(&mut inst, &j0, "fmi2SetContinuousStates");

    // fmi2SetFMUstate: back to the first point
    assert_eq!(
        inst.call(calls::SET_FMU_STATE, |i, c| i.restore(c, &snapshot)),
        Status::Ok
    );
    let mut y = vec![0.0; STATES];
    assert_eq!(
        inst.call(calls::GET_CONTINUOUS_STATES, |i, c| i
            .get_continuous_states(c, &mut y)),
        Status::Ok
    );
    assert_eq!(bits(&y), bits(&saved_x));
    let j2 = check_moved(&mut inst, &j1, "restoring the FMU state");
    assert_eq!(bits(&j2), bits(&j0));

    // an event: the controller's tick at 25 ms on a new reference changes the held valve
    // commands (the model's discrete state)
    assert_eq!(
        inst.call(calls::SET_TIME, |i, c| i.set_time(c, 0.025)),
        Status::Ok
    );
    assert_eq!(
        inst.call(calls::ENTER_EVENT_MODE, |i, c| i.enter_event_mode(c)),
        Status::Ok
    );
    let reference = [vr(V::THETA_REF)];
    assert_eq!(
        inst.call(calls::SET_REAL, |i, c| i.set_values(
            c,
            VarType::Real,
            &reference,
            &[0.5]
        )),
        Status::Ok
    );
    assert_eq!(
        inst.call(calls::NEW_DISCRETE_STATES, |i, c| {
            i.new_discrete_states(c, &mut EventInfo::default())
        }),
        Status::Ok
    );
    assert_eq!(
        inst.call(calls::ENTER_CONTINUOUS_TIME_MODE, |i, c| i
            .enter_continuous_time_mode(c)),
        Status::Ok
    );
    check_moved(&mut inst, &j2, "the controller's event update");
}

#[test]
fn an_input_set_in_continuous_time_mode_moves_the_jacobian() {
    let mut inst = running(false);
    let u = [vr(V::U_LEFT), vr(V::U_RIGHT)];
    assert_eq!(
        inst.call(calls::SET_REAL, |i, c| i.set_values(
            c,
            VarType::Real,
            &u,
            &[3.0, -2.0]
        )),
        Status::Ok
    );
    let j0 = by_columns(&mut inst);
    assert_eq!(bits(&j0), bits(&fresh(&inst)));
    assert_eq!(
        inst.call(calls::SET_REAL, |i, c| i.set_values(
            c,
            VarType::Real,
            &u,
            &[-6.0, 5.0]
        )),
        Status::Ok
    );
    check_moved(&mut inst, &j0, "fmi2SetReal of the valve inputs");
}
