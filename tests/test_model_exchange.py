"""FMI 2.0 Model Exchange of the generic layer (fmi2-export over fmu-core), proven on the Oscillator test model:
FMPy's CVode agrees with the closed form, the Model Exchange state machine (FMI 2.0.4 section
3.2.3) refuses calls in the wrong state with fmi2Error and a message and changes nothing, array
sizes are checked, and an FMU state saved in Continuous-Time Mode continues bit for bit."""
import math
from ctypes import POINTER, byref, c_double, c_int, c_size_t, c_uint, c_void_p, Structure

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import fmu_path
from fmi_harness import ERROR, OK, Harness

# (position, velocity) of m x'' + c x' + k x = 0, x(0) = x0, v(0) = 0: the underdamped closed
# form, independent of the code.
K, C, M, X0 = 100.0, 0.5, 1.0, 0.01


def closed_form(t):
    wn = math.sqrt(K / M)
    zeta = C / (2 * math.sqrt(K * M))
    wd = wn * math.sqrt(1 - zeta**2)
    e = np.exp(-zeta * wn * t)
    x = X0 * e * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    v = -X0 * e * (wn**2 / wd) * np.sin(wd * t)
    return x, v


class EventInfo(Structure):
    _fields_ = [("newDiscreteStatesNeeded", c_int), ("terminateSimulation", c_int),
                ("nominalsOfContinuousStatesChanged", c_int),
                ("valuesOfContinuousStatesChanged", c_int), ("nextEventTimeDefined", c_int),
                ("nextEventTime", c_double)]


class Me(Harness):
    """The Harness with the Model Exchange functions bound from the same library."""

    SIGNATURES = {
        "SetTime": [c_double], "SetContinuousStates": [POINTER(c_double), c_size_t],
        "EnterEventMode": [], "NewDiscreteStates": [POINTER(EventInfo)],
        "EnterContinuousTimeMode": [],
        "CompletedIntegratorStep": [c_int, POINTER(c_int), POINTER(c_int)],
        "GetDerivatives": [POINTER(c_double), c_size_t],
        "GetEventIndicators": [POINTER(c_double), c_size_t],
        "GetContinuousStates": [POINTER(c_double), c_size_t],
        "GetNominalsOfContinuousStates": [POINTER(c_double), c_size_t],
        "GetDirectionalDerivative": [POINTER(c_uint), c_size_t, POINTER(c_uint), c_size_t,
                                     POINTER(c_double), POINTER(c_double)],
    }

    def __init__(self, fmu_file):
        super().__init__(fmu_file)
        self.nx = len(self.md.derivatives)
        for name, args in self.SIGNATURES.items():
            f = getattr(self.slave.dll, "fmi2" + name)
            f.argtypes = [c_void_p] + args
            f.restype = c_int
            self.slave._functions["fmi2" + name] = f

    def array(self, name, n=None):
        n = self.nx if n is None else n
        out = (c_double * max(n, 1))()
        return self.call(name, out, n), list(out)[:n]

    def directional(self, unknowns, knowns, dv):
        """(status, dz) of fmi2GetDirectionalDerivative by variable names."""
        u = [self.vr[n] for n in unknowns]
        k = [self.vr[n] for n in knowns]
        dz = (c_double * len(u))()
        s = self.call("GetDirectionalDerivative", (c_uint * len(u))(*u), len(u),
                      (c_uint * len(k))(*k), len(k), (c_double * len(k))(*dv), dz)
        return s, list(dz)

    def set_states(self, x):
        return self.call("SetContinuousStates", (c_double * len(x))(*x), len(x))

    def new_discrete_states(self):
        info = EventInfo()
        return self.call("NewDiscreteStates", byref(info)), info

    def start(self, reals=None, booleans=None):
        """Instantiate for Model Exchange, initialize, settle the initial event, and enter
        Continuous-Time Mode."""
        assert self.instantiate(fmu_type=0)
        assert self.initialize(reals, booleans) == OK
        s, info = self.new_discrete_states()
        assert s == OK and not info.newDiscreteStatesNeeded
        assert self.call("EnterContinuousTimeMode") == OK
        return info


@pytest.fixture
def me():
    h = Me(fmu_path("Oscillator"))
    yield h
    h.free()


def euler(h, t, dt, n):
    """n explicit Euler steps of the Model Exchange instance (the importer's side)."""
    for _ in range(n):
        _, x = h.array("GetContinuousStates")
        _, dx = h.array("GetDerivatives")
        t += dt
        assert h.call("SetTime", c_double(t)) == OK
        assert h.set_states([a + dt * b for a, b in zip(x, dx)]) == OK
        enter, term = c_int(), c_int()
        assert h.call("CompletedIntegratorStep", 1, byref(enter), byref(term)) == OK
        assert (enter.value, term.value) == (0, 0)
    return t


def test_cvode_matches_closed_form():
    res = simulate_fmu(fmu_path("Oscillator"), fmi_type="ModelExchange", stop_time=2.0,
                       output_interval=1e-3, relative_tolerance=1e-10, output=["x", "v", "der(x)"])
    x, v = closed_form(res["time"])
    assert np.max(np.abs(res["x"] - x)) < 1e-8
    assert np.max(np.abs(res["v"] - v)) < 1e-7
    # der(x) is v by the model's equation: the derivative variable shows what the solver used.
    assert np.array_equal(res["der(x)"], res["v"])


def test_states_derivatives_and_nominals(me):
    assert me.nx == 2
    assert me.instantiate(fmu_type=0)
    s, n = me.array("GetNominalsOfContinuousStates")
    assert s == OK and all(v > 0 for v in n)
    assert me.initialize({"x0": 0.02}) == OK
    s, info = me.new_discrete_states()
    assert s == OK and not info.nextEventTimeDefined and not info.valuesOfContinuousStatesChanged
    assert me.array("GetContinuousStates") == (OK, [0.02, 0.0])
    # der(v) = (F - c v - k x) / m at x = 0.02, v = 0, F = 0.
    assert me.array("GetDerivatives") == (OK, [0.0, -K * 0.02 / M])
    assert me.array("GetEventIndicators", 0)[0] == OK
    assert me.call("EnterContinuousTimeMode") == OK
    assert me.set_states([0.001, 0.5]) == OK
    assert me.set_real(["force"], [3.0]) == OK
    assert me.array("GetDerivatives") == (OK, [0.5, (3.0 - C * 0.5 - K * 0.001) / M])
    s, out = me.get_real(["x", "v", "energy", "der(x)", "der(v)"])
    assert out == [0.001, 0.5, 0.5 * M * 0.25 + 0.5 * K * 1e-6, 0.5, (3.0 - C * 0.5 - K * 1e-3) / M]


def test_wrong_state_is_refused_and_changes_nothing(me):
    assert me.instantiate(fmu_type=0)
    # Before initialization: no states, no derivatives, no time.
    for name, args in [("SetTime", (c_double(1.0),)), ("EnterEventMode", ()),
                       ("EnterContinuousTimeMode", ()), ("NewDiscreteStates", (byref(EventInfo()),))]:
        assert me.call(name, *args) == ERROR, name
        assert "illegal call sequence" in me.last_error(), name
    assert me.array("GetDerivatives")[0] == ERROR
    assert me.initialize() == OK
    # Event Mode: no states set, no integrator step, no Co-Simulation step.
    assert me.set_states([1.0, 1.0]) == ERROR
    enter, term = c_int(), c_int()
    assert me.call("CompletedIntegratorStep", 1, byref(enter), byref(term)) == ERROR
    assert me.do_step(0.0, 1e-3) == ERROR
    assert me.new_discrete_states()[0] == OK
    assert me.call("EnterContinuousTimeMode") == OK
    # Continuous-Time Mode: no event update, no parameter; a wrong size is refused.
    assert me.new_discrete_states()[0] == ERROR
    assert me.set_real(["stiffness"], [5.0]) == ERROR
    assert "cannot be set" in me.last_error()
    assert me.set_states([1.0]) == ERROR and "nx is 1" in me.last_error()
    assert me.set_states([1.0, float("nan")]) == ERROR and "not finite" in me.last_error()
    assert me.array("GetDerivatives", 3)[0] == ERROR
    assert me.array("GetContinuousStates") == (OK, [X0, 0.0])
    assert me.array("GetDerivatives") == (OK, [0.0, -K * X0 / M])
    assert me.call("Terminate") == OK
    assert me.call("SetTime", c_double(1.0)) == ERROR


def test_interfaces_stay_apart():
    h = Me(fmu_path("Oscillator"))
    assert not h.instantiate(fmu_type=2)
    assert "fmuType 2" in h.last_error()
    assert h.instantiate(fmu_type=1)
    assert h.initialize() == OK
    assert h.call("SetTime", c_double(0.5)) == ERROR
    assert "Co-Simulation instance" in h.last_error()
    assert h.array("GetDerivatives")[0] == ERROR
    # Directional derivatives in Co-Simulation too, at the communication point: the closed form
    # d(der(v))/dx = -k/m of the oscillator.
    s, (dvx,) = h.directional(["der(v)"], ["x"], [1.0])
    assert s == OK and dvx == pytest.approx(-K / M, rel=1e-12)
    # In Co-Simulation the derivative variables are the right-hand side at each communication
    # point: der(x) is v.
    assert h.do_step(0.0, 1e-2) == OK
    _, (v, dx) = h.get_real(["v", "der(x)"])
    assert v == dx and v != 0.0
    # A Co-Simulation FMU state cannot be set into a Model Exchange instance (same GUID).
    _, st = h.get_state()
    data = h.serialize(st)
    h.free()
    h2 = Me(fmu_path("Oscillator"))
    h2.start()
    s, st2 = h2.deserialize(data)
    assert s == OK
    assert h2.call("SetFMUstate", st2) == ERROR
    assert "StepComplete" in h2.last_error()
    assert h2.array("GetContinuousStates") == (OK, [X0, 0.0])
    h2.free()


def test_fmu_state_continues_bit_for_bit(me):
    me.start()
    t = euler(me, 0.0, 1e-3, 200)
    s, state = me.get_state()
    assert s == OK
    data = me.serialize(state)
    euler(me, t, 1e-3, 100)
    _, x_first = me.array("GetContinuousStates")
    assert me.call("SetFMUstate", state) == OK
    euler(me, t, 1e-3, 100)
    assert me.array("GetContinuousStates") == (OK, x_first)
    s, restored = me.deserialize(data)
    assert s == OK and me.call("SetFMUstate", restored) == OK
    euler(me, t, 1e-3, 100)
    assert me.array("GetContinuousStates") == (OK, x_first)
    # The Euler trace is not vacuous: it has left the start and is near the closed form.
    x, _ = closed_form(np.array([0.3]))
    assert x_first[0] != X0 and abs(x_first[0] - x[0]) < 2e-3


def test_failed_derivative_evaluation_is_an_error(me):
    me.start({"fail_at": 0.05})
    euler(me, 0.0, 1e-2, 4)
    assert me.array("GetDerivatives")[0] == OK
    assert me.call("SetTime", c_double(0.05)) == OK
    assert me.array("GetDerivatives")[0] == ERROR
    assert "fail_at" in me.last_error()


def test_directional_derivatives_are_the_jacobian(me):
    """d(der(x), der(v))/d(x, v) = [[0, 1], [-k/m, -c/m]] (closed form), along any direction;
    outputs and inputs by the layer's central differences: d(energy)/dx = k x, d(der(v))/dF =
    1/m."""
    assert me.md.modelExchange.providesDirectionalDerivative
    assert me.md.coSimulation.providesDirectionalDerivative
    me.start()
    assert me.set_states([0.004, -0.3]) == OK
    s, dz = me.directional(["der(x)", "der(v)"], ["x", "v"], [2.0, -1.0])
    assert s == OK and dz == [-1.0, -K / M * 2.0 + C / M]
    s, (de, dv) = me.directional(["energy", "der(v)"], ["x", "force"], [1.0, 0.0])
    assert s == OK and abs(de - K * 0.004) < 1e-9 and dv == -K / M
    s, (dvf,) = me.directional(["der(v)"], ["force"], [1.0])
    assert s == OK and abs(dvf - 1.0 / M) < 1e-9
    # wrong roles are refused, naming the variable
    assert me.directional(["force"], ["v"], [1.0])[0] == ERROR and "'force'" in me.last_error()
    assert me.directional(["x"], ["energy"], [1.0])[0] == ERROR and "'energy'" in me.last_error()
    # an output that is a state: dx/dv = 0, dx/dx = 1
    s, (dx,) = me.directional(["x"], ["v", "x"], [1.0, 0.5])
    assert s == OK and abs(dx - 0.5) < 1e-9
    assert me.directional(["der(x)"], ["mass"], [1.0])[0] == ERROR
    assert "'mass'" in me.last_error()


# The Model Exchange state machine (FMI 2.0.4 section 3.2.3; the masks of the Modelica
# Association's Reference-FMUs): the states in which each function is allowed.
# I instantiated, N initialization mode, E event mode, C continuous-time mode, T terminated.
ME_ALLOWED = {
    "SetTime": "EC", "SetContinuousStates": "C", "EnterEventMode": "EC", "NewDiscreteStates": "E",
    "EnterContinuousTimeMode": "E", "CompletedIntegratorStep": "C", "GetDerivatives": "ECT",
    "GetEventIndicators": "NECT", "GetContinuousStates": "NECT",
    "GetNominalsOfContinuousStates": "IECT", "GetDirectionalDerivative": "NECT",
    "Terminate": "EC", "GetReal": "NECT", "DoStep": "", "GetRealStatus": "",
}


def reach(h, state):
    assert h.instantiate(fmu_type=0)
    if state == "I":
        return
    assert h.setup() == OK and h.call("EnterInitializationMode") == OK
    if state == "N":
        return
    assert h.call("ExitInitializationMode") == OK
    if state == "E":
        return
    assert h.new_discrete_states()[0] == OK and h.call("EnterContinuousTimeMode") == OK
    if state == "T":
        assert h.call("Terminate") == OK


def call(h, fn):
    x = (c_double * 2)()
    if fn == "SetTime":
        return h.call(fn, c_double(0.0))
    if fn == "SetContinuousStates":
        return h.set_states([X0, 0.0])
    if fn in ("EnterEventMode", "EnterContinuousTimeMode", "Terminate"):
        return h.call(fn)
    if fn == "NewDiscreteStates":
        return h.new_discrete_states()[0]
    if fn == "CompletedIntegratorStep":
        return h.call(fn, 1, byref(c_int()), byref(c_int()))
    if fn in ("GetDerivatives", "GetContinuousStates", "GetNominalsOfContinuousStates"):
        return h.call(fn, x, 2)
    if fn == "GetEventIndicators":
        return h.call(fn, x, 0)
    if fn == "GetDirectionalDerivative":
        # with respect to a known of every state: the force input (in Initialization Mode the
        # states are initial unknowns, not knowns)
        return h.directional(["der(v)"], ["force"], [1.0])[0]
    if fn == "GetReal":
        return h.get_real(["x"])[0]
    if fn == "DoStep":
        return h.do_step(0.0, 1e-3)
    if fn == "GetRealStatus":
        return h.call(fn, 2, byref(c_double()))
    raise AssertionError(fn)


@pytest.mark.parametrize("state", "INECT")
def test_each_function_is_allowed_exactly_in_its_states(state):
    for fn, allowed in ME_ALLOWED.items():
        h = Me(fmu_path("Oscillator"))
        reach(h, state)
        s = call(h, fn)
        if state in allowed:
            assert s == OK, (fn, state, h.last_error())
        else:
            assert s == ERROR, (fn, state)
            assert h.last_error(), (fn, state)
        h.free()
