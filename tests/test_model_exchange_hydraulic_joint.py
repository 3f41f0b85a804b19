"""HydraulicJoint as FMI 2.0 Model Exchange: FMPy's CVode integrating the model's 18 states
agrees with the Co-Simulation FMU's own integrator on the same runs (every effect on in at least
one), the 40 Hz controller ticks are time events at t0 + k/f with the valve commands changed in
Event Mode only, the outputs' dependencies in <ModelStructure> hold numerically, and the directional derivatives
(the analytic Jacobian) agree with central differences at several operating points, every effect
on.

Traces are compared within 1e-3 of each output's range, the tolerance the reference tests use
(tests/test_hydraulic_joint.py); measured: below 2e-4 (see the README's interface section)."""
import sys
from ctypes import c_double
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu

from conftest import fmu_path
from fmi_harness import (OK, event_trace, fmu_state_replays, jacobian_and_central_differences,
                         perturbations_moving_derivatives, scaled_jacobian_error,
                         states_and_derivatives)
from test_model_exchange import Me

sys.path.insert(0, str(Path(__file__).parent / "reference"))
import hydraulic_joint_ref as ref  # noqa: E402

EFFECTS = ["seal_friction", "valve_overlap", "internal_leakage", "cable_friction",
           "entrained_air", "valve_dynamics"]
ALL_ON = {f"{e}.enabled": True for e in EFFECTS}
TOL = 1e-3  # of each output's range


@pytest.fixture(scope="module")
def fmu():
    return extract(fmu_path("HydraulicJoint"))


def held(times, rows, names):
    """Piecewise-constant inputs: each jump repeats its time (FMPy then stops its solver there,
    an input event), so both interfaces see the same signal."""
    data = []
    for k, (t, row) in enumerate(zip(times, rows)):
        if k:
            data.append((t, *rows[k - 1]))
        data.append((t, *row))
    return np.array(data, dtype=[("time", float)] + [(n, float) for n in names])


def both(fmu, params, inp, t_end, dt=1e-3):
    """(Co-Simulation, Model Exchange) results on the grid of the Co-Simulation run."""
    kw = dict(start_values=params, input=inp, output=ref.OUTPUTS, stop_time=t_end,
              output_interval=dt)
    cs = simulate_fmu(fmu, step_size=dt, **kw)
    me = simulate_fmu(fmu, fmi_type="ModelExchange", **kw)
    _, first = np.unique(np.round(me["time"], 9), return_index=True)
    me = me[first]
    assert np.allclose(me["time"], cs["time"], rtol=0, atol=1e-9)
    return cs, me


def worst(cs, me):
    """The largest difference relative to its output's range (a constant output: to 1e-9 of
    its magnitude, as the reference tests scale), with the output's name."""
    def scale(x):
        return max(float(np.ptp(x)), 1e-9 * float(np.max(np.abs(x))), 1e-15)
    return max((float(np.max(np.abs(me[o] - cs[o]))) / scale(cs[o]), o) for o in ref.OUTPUTS)


def catching(t_end=1.2, dt=1e-3):
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    inp = np.zeros(len(t), dtype=[("time", float), ("theta_ref", float)])
    inp["time"], inp["theta_ref"] = t, ref.min_jerk(t)
    return inp


CASES = {
    # closed loop: theta_ref acts at the controller's samples only
    "catching": ({}, catching()),
    "catching_all_effects": (ALL_ON, catching()),
    # open loop, valve and torque steps (into and out of the end stops), every effect on
    "open_loop_steps_all_effects": (
        {"internal_controller": False, **ALL_ON},
        held([0.0, 0.15, 0.3], [(6.0, -6.0, 2.0), (-7.0, 7.0, -1.0), (-7.0, 7.0, -1.0)],
             ["u_left", "u_right", "tau_ext"])),
    # the Fig. 6 bench: a free piston
    "bench": ({"internal_controller": False, "cables_attached": False},
              held([0.0, 0.06], [(2.5, 0.0), (2.5, 0.0)], ["u_left", "u_right"])),
}


@pytest.mark.parametrize("case", CASES)
def test_model_exchange_agrees_with_co_simulation(fmu, case):
    params, inp = CASES[case]
    cs, me = both(fmu, params, inp, float(inp["time"][-1]))
    err, name = worst(cs, me)
    assert err < TOL, (name, err)
    # not vacuous: the run moves
    assert np.ptp(cs["x_left"]) > 1e-3


@pytest.fixture
def me():
    h = Me(fmu_path("HydraulicJoint"))
    yield h
    h.free()


def test_controller_ticks_are_time_events(me):
    assert me.nx == 18
    info = me.start({"theta_ref": 0.3})
    # the tick at t0 ran at initialization/the first event; the next is one period later
    assert info.nextEventTimeDefined and info.nextEventTime == 1.0 / 40.0
    _, u0 = me.get_real(["u_valve_left", "u_valve_right"])
    assert u0[0] > 0 > u0[1]
    # a set point change between ticks changes nothing in Continuous-Time Mode
    _, dx0 = me.array("GetDerivatives")
    assert me.set_real(["theta_ref"], [-0.3]) == OK
    assert me.get_real(["u_valve_left", "u_valve_right"])[1] == u0
    assert me.array("GetDerivatives")[1] == dx0
    # at the tick it acts (Event Mode), and the next tick is announced
    assert me.call("SetTime", c_double(1.0 / 40.0)) == OK
    assert me.call("EnterEventMode") == OK
    s, info = me.new_discrete_states()
    assert s == OK and info.nextEventTime == 2.0 / 40.0
    _, u1 = me.get_real(["u_valve_left", "u_valve_right"])
    assert u1[0] < 0 < u1[1]


def test_output_dependencies_hold(me):
    """Each output depends on the states and on the inputs <ModelStructure> names for it: an
    input changed in Continuous-Time Mode moves no other output (open loop, where the valve
    commands are the inputs)."""
    md = read_model_description(fmu_path("HydraulicJoint"))
    states = {md.modelVariables.index(d.variable.derivative) for d in md.derivatives}
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    outs = [u.variable for u in md.outputs]
    deps = {u.variable.name: {md.modelVariables.index(d) for d in u.dependencies}
            for u in md.outputs}
    me.start({"u_left": 3.0, "u_right": -3.0}, {"internal_controller": False})
    _, before = me.get_real([o.name for o in outs])
    for v in inputs:
        _, (old,) = me.get_real([v.name])
        assert me.set_real([v.name], [float(v.max)]) == OK
        _, now = me.get_real([o.name for o in outs])
        moved = {o.name for o, a, b in zip(outs, before, now) if a != b}
        i = md.modelVariables.index(v)
        declared = {n for n, d in deps.items() if i in d}
        assert moved <= declared, (v.name, moved - declared)
        # the valve inputs act on outputs at once; the torque through the derivatives only,
        # the set point at the controller's ticks only
        assert bool(moved) == (v.name in ("u_left", "u_right")), (v.name, moved)
        assert me.set_real([v.name], [old]) == OK
    # every output lists every state (they are all computed from the state vector)
    assert all(states <= d for d in deps.values())
    # and the declared feedthrough is real: u_left moves u_valve_left at once
    assert me.set_real(["u_left"], [7.0]) == OK
    assert me.get_real(["u_valve_left"])[1] == [7.0]


# Operating points (the 18 states): at rest as initialized, moving, and with the left piston in
# its end stop, the right cable slack, spools saturated and the seal friction sticking.
POINTS = {
    "moving": [0.1, 0.5, 0.055, 0.05, 3e6, 5e6, 0.045, -0.04, 4e6, 2e6, 1e-6, 2e-6, 2.0, 30.0,
               -2.5, -10.0, 0.02, -0.03],
    "stop_slack_stick": [0.3, -0.2, 0.09999, 0.01, 8e6, 1e5, 0.02, -0.01, 2e5, 7e6, 0.0, 0.0,
                         8.0, 0.0, -8.0, 0.0, 0.005, 1e-4],
}


def test_directional_derivatives_match_central_differences(me):
    """Each column of d(der x)/dx from fmi2GetDirectionalDerivative (the plant's analytic
    Jacobian) against a central difference of fmi2GetDerivatives with step 1e-6 of the state's
    magnitude or nominal: within 1e-6 of the row's largest |J_ij| nominal_j. Plus the closed
    form d(der(omega))/d(tau_ext) = 1/I, I = link_inertia + load_mass load_radius^2."""
    me.start({"u_left": 4.0, "u_right": -3.0, "tau_ext": 1.5},
             {"internal_controller": False, **ALL_ON})
    states, ders, nom, rest = states_and_derivatives(me)
    for point, x in {"rest": rest, **POINTS}.items():
        jac, fd = jacobian_and_central_differences(me, ders, states, nom, x)
        assert jac.shape == (18, 18)
        err = scaled_jacobian_error(jac, fd, nom)
        assert err.max() < 1e-6, (point, np.unravel_index(np.argmax(err), err.shape), err.max())
        assert np.count_nonzero(jac) > 50  # not vacuous
    _, (dw,) = me.directional(["der(omega)"], ["tau_ext"], [1.0])
    assert dw == pytest.approx(1.0 / (0.056 + 2.0 * 0.30**2), rel=1e-6)


def test_fmu_state_keeps_the_controller(me):
    """An FMU state saved in Continuous-Time Mode carries the states and the controller (held
    commands, next sample): restored, or deserialized, the same calls give the same bits."""
    me.start({"theta_ref": 0.4}, ALL_ON)
    names = [u.variable.name for u in me.md.outputs]

    def ticks(k0, n):
        # a new state each tick, the controller's period 1/40 s apart
        moving = POINTS["moving"]
        return event_trace(me, names, k0, n, lambda k: [v * (1 + 0.01 * k) for v in moving],
                           lambda k: k / 40.0)

    first = fmu_state_replays(me, ticks)
    u = names.index("u_valve_left")
    assert len({row[u] for row in first}) == 3  # the controller acted at each tick


@pytest.mark.parametrize("setting", [
    ({}, ALL_ON),
    ({"u_left": 4.0, "u_right": -3.0}, {"internal_controller": False, **ALL_ON}),
    ({"u_left": 4.0, "u_right": -3.0}, {"internal_controller": False}),
    ({"u_left": 4.0, "u_right": -3.0}, {"internal_controller": False, **ALL_ON,
                                        "valve_dynamics.enabled": False}),
], ids=["closed_loop_all_effects", "open_loop_all_effects", "open_loop", "open_loop_no_spool"])
def test_derivative_dependencies_hold(me, setting):
    """<Derivatives> lists what each derivative depends on: moving any other state or input
    leaves it unchanged to the bit, at two operating points."""
    reals, booleans = setting
    me.start({"tau_ext": 1.0, **reals}, booleans)
    md = me.md
    states = [d.variable.derivative.name for d in md.derivatives]
    deps = [{d.name for d in u.dependencies} for u in md.derivatives]
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    _, nom = me.array("GetNominalsOfContinuousStates")
    moved = sum(perturbations_moving_derivatives(me, x, states, inputs, deps, nom)
                for x in POINTS.values())
    assert moved > 40  # not vacuous: the perturbations move the derivatives they list
