"""FMI 3.0 Model Exchange of dist/fmi3/<Model>.fmu and the FMI 3.0 test oscillator.

- the test oscillator under FMPy's CVode (fmi_type='ModelExchange') follows the closed form of
  the damped oscillator;
- each model's FMI 3.0 Model Exchange run agrees with its FMI 2.0 Model Exchange run (the same
  model code behind another C interface, the same solver in FMPy), and keeps one paper number:
  HydraulicJoint's Fig. 6 bench (extending faster than retracting, the dead band), TwistedString's
  section 6 speed at the 8000 rpm limit (lightest load);
- the model description names the states (`derivative=`), their derivatives
  (`<ContinuousStateDerivative>`) and TwistedString's event indicator (`<EventIndicator>`);
- a call in a state the FMI 3.0 Model Exchange state machine does not allow is refused with
  fmi3Error and changes nothing; a Co-Simulation function on a Model Exchange instance and a
  Model Exchange function on a Co-Simulation instance are refused.
"""
import math
import xml.etree.ElementTree as ET
import zipfile
from ctypes import POINTER, byref, c_bool, c_double

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Model, FMU3Slave

from conftest import fmu3_path, fmu_path

ME = "ModelExchange"
# Twisted string section 6: motor at its 8000 rpm limit (rad/s), motor angle range of the
# measurement (1000 -> 6000 deg of output twist at the 19.2:1 gear), paper speed at 23 N.
RPM8000 = 8000.0 * 2.0 * math.pi / 60.0
DEG1000 = math.radians(1000.0) * 19.2
DEG6000 = math.radians(6000.0) * 19.2


def me_run(path, params=None, inputs=None, t_end=1.0, dt=1e-3, output=None, tolerance=None):
    """FMPy's CVode on the Model Exchange interface; inputs {name: (times, values)}."""
    table = None
    if inputs:
        times = next(iter(inputs.values()))[0]
        table = np.zeros(len(times), dtype=[("time", float)] + [(k, float) for k in inputs])
        table["time"] = times
        for k, (_, v) in inputs.items():
            table[k] = v
    return fmpy.simulate_fmu(path, fmi_type=ME, start_values=params or {}, input=table,
                             output=output, stop_time=t_end, output_interval=dt,
                             relative_tolerance=tolerance, record_events=False)


def test_oscillator_follows_the_closed_form():
    """x = x0 e^(-zeta wn t) (cos wd t + zeta wn / wd sin wd t), from the parameters of the
    model description (free oscillation, force 0)."""
    path = fmu3_path("Oscillator")
    start = {v.name: float(v.start) for v in fmpy.read_model_description(path).modelVariables
             if v.causality == "parameter" and v.type == "Float64"}
    res = me_run(path, t_end=2.0, dt=0.01, output=["x", "v"], tolerance=1e-8)
    m, k, c, x0 = start["mass"], start["stiffness"], start["damping"], start["x0"]
    wn = math.sqrt(k / m)
    zeta = c / (2.0 * math.sqrt(k * m))
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    t = res["time"]
    x = x0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    assert len(t) == 201 and t[-1] == pytest.approx(2.0)
    assert np.max(np.abs(res["x"] - x)) < 1e-6 * x0 * 100  # 1e-4 of the amplitude


RUNS = {
    "HydraulicJoint": ("theta_ref", lambda t: 0.5 * np.sin(2 * np.pi * t)),
    "TwistedString": ("theta_motor_ref", lambda t: 600.0 * t),
}


@pytest.mark.parametrize("model", sorted(RUNS))
def test_fmi3_model_exchange_agrees_with_fmi2(model):
    name, f = RUNS[model]
    t = np.linspace(0.0, 1.0, 1001)
    inputs = {name: (t, f(t))}
    fmi3 = me_run(fmu3_path(model), inputs=inputs)
    fmi2 = me_run(fmu_path(model), inputs=inputs)
    assert fmi3.dtype.names == fmi2.dtype.names and len(fmi3) == len(fmi2) == 1001
    for n in fmi2.dtype.names:
        a, b = fmi3[n], fmi2[n]
        scale = max(float(np.max(np.abs(b))), 1e-12)
        assert np.max(np.abs(a - b)) <= 1e-6 * scale, n


def bench_speed(u, t_end=0.06):
    """Fig. 6 bench (cables detached, open loop): step U on the left valve; mean piston speed
    between 20 and 60 ms."""
    t = np.array([0.0, t_end])
    res = me_run(fmu3_path("HydraulicJoint"),
                 {"internal_controller": False, "cables_attached": False},
                 {"u_left": (t, [u, u]), "u_right": (t, [0.0, 0.0])}, t_end=t_end,
                 output=["v_left"])
    return float(np.mean(res["v_left"][(res["time"] >= 0.02) & (res["time"] <= t_end)]))


def test_hydraulic_joint_fig6_bench():
    """Paper, Fig. 6: no motion inside the dead band (-1.8 .. 1.5 V); outside it 'the velocity
    is higher when the fluid is flowing to the piston side' (extending)."""
    assert abs(bench_speed(1.0)) < 1e-3
    extend, retract = bench_speed(5.0), bench_speed(-5.0)
    assert extend > 0 > retract
    assert extend > 1.1 * abs(retract), (extend, retract)


def test_twisted_string_speed_at_8000rpm():
    """Section 6: at the 8000 rpm limit, 23 N load, the actuator contracts at 1.58 cm/s over the
    motor angle range 335.1 -> 2011 rad (within 0.1 cm/s), the motor at 8000 rpm within 1 %."""
    res = me_run(fmu3_path("TwistedString"),
                 {"load_mass": 23 / 9.81, "string_compliance.enabled": True},
                 {"theta_motor_ref": ([0, 1.5, 1.5], [DEG1000, DEG1000, 2100.0])}, t_end=4.0,
                 output=["theta_motor", "p"])
    th, p, t = res["theta_motor"], res["p"], res["time"]
    k0 = int(np.argmax((t >= 1.5) & (th > DEG1000 + 0.5)))
    k1 = int(np.argmax(th >= DEG6000))
    assert k1 > k0 > 0
    assert 0.99 * RPM8000 < (th[k1] - th[k0]) / (t[k1] - t[k0]) < 1.01 * RPM8000
    v = (p[k0] - p[k1]) / (t[k1] - t[k0]) * 100.0
    assert abs(v - 1.58) < 0.1, v


@pytest.mark.parametrize("model,states,indicators", [("HydraulicJoint", 18, 0),
                                                      ("TwistedString", 13, 1)])
def test_description_names_states_derivatives_and_indicators(model, states, indicators):
    md = fmpy.read_model_description(fmu3_path(model))
    assert md.modelExchange is not None and md.coSimulation is not None
    assert md.numberOfContinuousStates == states == len(md.derivatives)
    assert md.numberOfEventIndicators == indicators
    for d in md.derivatives:
        assert d.variable.derivative is not None
        assert d.variable.name == f"der({d.variable.derivative.name})"


@pytest.fixture
def me_instance():
    path = fmu3_path("TwistedString")
    md = fmpy.read_model_description(path)
    fmu = FMU3Model(guid=md.guid, unzipDirectory=fmpy.extract(path),
                    modelIdentifier=md.modelExchange.modelIdentifier)
    messages = []
    fmu.instantiate(logMessage=lambda env, status, category, message: messages.append(message))
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    yield fmu, md, messages
    fmu.freeInstance()
    fmu.freeLibrary()


def test_calls_in_the_wrong_state_are_refused(me_instance):
    """After fmi3ExitInitializationMode the instance is in Event Mode: fmi3EnterEventMode,
    fmi3SetContinuousStates and fmi3CompletedIntegratorStep (Continuous-Time Mode only) and
    fmi3DoStep (Co-Simulation) are refused, each with its reason logged; the instance then
    proceeds normally."""
    fmu, md, messages = me_instance
    n = md.numberOfContinuousStates
    x, dx, z = (np.zeros(k) for k in (n, n, 1))
    fmu.getContinuousStates(x.ctypes.data_as(POINTER(c_double)), n)
    flag, t = c_bool(), c_double()
    refused = {
        "fmi3EnterEventMode": lambda: fmu.fmi3EnterEventMode(fmu.component),
        "fmi3SetContinuousStates": lambda: fmu.fmi3SetContinuousStates(
            fmu.component, x.ctypes.data_as(POINTER(c_double)), n),
        "fmi3CompletedIntegratorStep": lambda: fmu.fmi3CompletedIntegratorStep(
            fmu.component, True, byref(flag), byref(flag)),
        "fmi3DoStep": lambda: fmu.fmi3DoStep(fmu.component, 0.0, 1e-3, True, byref(flag),
                                             byref(flag), byref(flag), byref(t)),
    }
    for name, call in refused.items():
        with pytest.raises(FMICallException) as e:
            call()
        assert e.value.status == 3
        assert messages[-1].startswith(name.encode() + b": "), messages[-1]
    assert all(m.endswith(b"illegal call sequence: not allowed in Event Mode") for m in messages)
    need_update, _, _, _, next_defined, next_time = fmu.updateDiscreteStates()
    assert not need_update and next_defined and next_time > 0.0  # the next controller tick
    fmu.enterContinuousTimeMode()
    fmu.setTime(1e-4)
    fmu.setContinuousStates(x.ctypes.data_as(POINTER(c_double)), n)
    fmu.getContinuousStateDerivatives(dx.ctypes.data_as(POINTER(c_double)), n)
    fmu.getEventIndicators(z.ctypes.data_as(POINTER(c_double)), 1)
    assert np.all(np.isfinite(dx)) and np.isfinite(z[0])
    # FMI 3.0.2 section 3.2.1: a continuous-time state may be set by fmi3SetFloat64 in
    # Continuous-Time Mode (as by fmi3SetContinuousStates); a parameter may not
    theta = md.derivatives[1].variable.derivative
    assert theta.name == "theta_motor"
    fmu.setFloat64([theta.valueReference], [12.5])
    fmu.getContinuousStates(x.ctypes.data_as(POINTER(c_double)), n)
    assert x[1] == 12.5 and fmu.getFloat64([theta.valueReference]) == [12.5]
    load = next(v for v in md.modelVariables if v.name == "load_mass")
    with pytest.raises(FMICallException):
        fmu.setFloat64([load.valueReference], [3.0])
    with pytest.raises(FMICallException):
        fmu.updateDiscreteStates()
    fmu.enterEventMode()
    fmu.terminate()


def test_model_exchange_function_on_co_simulation_instance_is_refused():
    path = fmu3_path("TwistedString")
    md = fmpy.read_model_description(path)
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmpy.extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    messages = []
    fmu.instantiate(logMessage=lambda env, status, category, message: messages.append(message))
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    n = md.numberOfContinuousStates
    dx = np.zeros(n)
    with pytest.raises(FMICallException):
        fmu.fmi3GetContinuousStateDerivatives(fmu.component, dx.ctypes.data_as(POINTER(c_double)),
                                              n)
    assert messages[-1] == (b"fmi3GetContinuousStateDerivatives: a Model Exchange function "
                            b"called on a Co-Simulation instance")
    # directional derivatives are offered in Co-Simulation too: d(der(theta_motor))/d(omega_motor)
    # is 1 (the motor angle's derivative is the motor speed)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    assert fmu.getDirectionalDerivative([vr["der(theta_motor)"]], [vr["omega_motor"]],
                                        [1.0]) == [1.0]
    fmu.doStep(0.0, 1e-3)
    fmu.terminate()
    fmu.freeInstance()
    fmu.freeLibrary()


def ptr(a):
    return a.ctypes.data_as(POINTER(c_double))


def twisted_string_taut(md, theta=600.0, omega=300.0, current=0.4):
    """Every effect on, the strings carrying about 100 N at motor angle `theta` (eq. 9-10 with
    the defaults, radius growth 0.005 per turn), the gearhead output on the +b/2 flank of a 1 deg
    backlash, turning 10 % slower than the motor side: away from every kink."""
    start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None
             and v.type == "Float64"}
    r0, g, n = start["string_radius"], 0.005, 19.2
    a1, a2, a3 = (start[f"string_compliance.{k}"] for k in ("a1", "a2", "a3"))
    delta = 0.5 * math.radians(1.0) + 1e-4
    th_t = theta / n - delta
    a = th_t * r0 * (1 + g * abs(th_t) / (2 * math.pi))
    lfree = 0.0897 + a1 * abs(n * th_t) + a2 * (n * th_t) ** 2
    p = math.sqrt((lfree + 100.0 * a3) ** 2 - a * a)
    # i, theta, omega, p, v, z_i, z_w, E_el, E_diss, E_kin, delta, omega_t, W_ext
    return [current, theta, omega, p, -0.004, 2e-4, 3.0, 1.0, 0.8, 0.1, delta, 0.9 * omega / n,
            0.2]


# Per model: start values (parameters and inputs) and an operating point away from the
# non-smooth points (end stops, stiction, dead band, zero twist), where central differences
# are valid.
JACOBIAN_POINTS = {
    "Oscillator": ({"force": 2.0}, lambda md: [0.004, -0.3]),
    "HydraulicJoint": (
        {"u_left": 4.0, "u_right": -3.0, "tau_ext": 1.5, "internal_controller": False,
         **{f"{e}.enabled": True for e in ("seal_friction", "valve_overlap", "internal_leakage",
                                           "cable_friction", "entrained_air", "valve_dynamics")}},
        lambda md: [0.1, 0.5, 0.055, 0.05, 3e6, 5e6, 0.045, -0.04, 4e6, 2e6, 1e-6, 2e-6, 2.0,
                    30.0, -2.5, -10.0, 0.02, -0.03]),
    "TwistedString": (
        {"voltage": 5.0, "F_load": 12.0, "theta_motor_ref": 900.0,
         **{f"{e}.enabled": True for e in ("string_compliance", "twist_hysteresis",
                                           "motor_friction", "gear_backlash", "radius_growth")}},
        twisted_string_taut),
}


@pytest.mark.parametrize("model", sorted(JACOBIAN_POINTS))
def test_directional_and_adjoint_derivatives_match_central_differences(model):
    """d(der x)/dx column by column from fmi3GetDirectionalDerivative (the model's analytic
    Jacobian) against a central difference of fmi3GetContinuousStateDerivatives with step 1e-6 of
    the state's magnitude or nominal: within 1e-6 of the row's largest |J_ij| nominal_j, every
    effect on, at an operating point of each model; fmi3GetAdjointDerivative with a random seed w
    gives w^T J of the same Jacobian."""
    path = fmu3_path(model)
    md = fmpy.read_model_description(path)
    with zipfile.ZipFile(path) as z:
        me = ET.fromstring(z.read("modelDescription.xml")).find("ModelExchange")
    assert me.get("providesDirectionalDerivatives") == me.get("providesAdjointDerivatives") == "true"
    fmu = FMU3Model(guid=md.guid, unzipDirectory=fmpy.extract(path),
                    modelIdentifier=md.modelExchange.modelIdentifier)
    fmu.instantiate()
    start, point = JACOBIAN_POINTS[model]
    fmpy.simulation.apply_start_values(fmu, md, start)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.updateDiscreteStates()
    fmu.enterContinuousTimeMode()
    n = md.numberOfContinuousStates
    states = [d.variable.derivative.valueReference for d in md.derivatives]
    ders = [d.variable.valueReference for d in md.derivatives]
    nom, f = np.zeros(n), np.zeros(n)
    fmu.getNominalsOfContinuousStates(ptr(nom), n)
    x = np.array(point(md), dtype=float)
    fmu.setContinuousStates(ptr(x), n)
    jac = np.zeros((n, n))
    fd = np.zeros((n, n))
    for j in range(n):
        jac[:, j] = fmu.getDirectionalDerivative(ders, [states[j]], [1.0])
        h = 1e-6 * max(abs(x[j]), nom[j])
        cols = []
        for sign in (1, -1):
            xs = x.copy()
            xs[j] += sign * h
            fmu.setContinuousStates(ptr(xs), n)
            fmu.getContinuousStateDerivatives(ptr(f), n)
            cols.append(f.copy())
        fd[:, j] = (cols[0] - cols[1]) / (2 * h)
        fmu.setContinuousStates(ptr(x), n)
    scaled = np.abs(jac) * nom
    err = np.abs(jac - fd) * nom / (scaled.max(axis=1, keepdims=True) + 1e-300)
    assert err.max() < 1e-6, (np.unravel_index(np.argmax(err), err.shape), err.max())
    assert np.count_nonzero(jac) >= 2 * n - 1  # not vacuous
    w = np.random.default_rng(1).standard_normal(n)
    adjoint = fmu.getAdjointDerivative(ders, states, list(w), nSensitivity=n)
    assert np.allclose(adjoint, w @ jac, rtol=1e-12, atol=1e-12 * float(np.max(np.abs(w) @ np.abs(jac))))
    fmu.terminate()
    fmu.freeInstance()
    fmu.freeLibrary()


# ---- parameters as knowns (FMI 3.0.2 section 2.4.8) ----------------------------------------
# Outputs and state derivatives list the parameters they depend on: in Event and Continuous-Time
# Mode the knowns are the inputs, the states, the parameters and time, and a known left out of
# `dependencies` claims a partial derivative identically zero. Per model, every effect on, two
# operating points (closed loop: the controller's held output computed at the initial tick from
# its parameters; open loop: the inputs act), and one with every effect off, each with its start
# values and states.
HJ_EFFECTS = {f"{e}.enabled": True for e in ("seal_friction", "valve_overlap", "internal_leakage",
                                             "cable_friction", "entrained_air", "valve_dynamics")}
TS_EFFECTS = {f"{e}.enabled": True for e in ("string_compliance", "twist_hysteresis",
                                             "motor_friction", "gear_backlash", "radius_growth")}
PARAMETER_POINTS = {
    ("HydraulicJoint", "open loop"): JACOBIAN_POINTS["HydraulicJoint"],
    ("HydraulicJoint", "closed loop"): (
        {"theta_ref": 0.3, "tau_ext": -2.0, **HJ_EFFECTS},
        lambda md: [0.2, -0.4, 0.05, -0.03, 4e6, 3e6, 0.05, 0.02, 2.5e6, 4.5e6, 2e-6, 1e-6, 3.0,
                    20.0, -2.0, -15.0, -0.01, 0.025]),
    ("TwistedString", "closed loop"): JACOBIAN_POINTS["TwistedString"],
    ("TwistedString", "open loop"): (
        {"internal_controller": False, "voltage": -4.0, "F_load": 20.0, **TS_EFFECTS},
        lambda md: twisted_string_taut(md, theta=900.0, omega=250.0, current=0.3)),
    # every effect off: the parameters only the base model uses (a string stiffness where the
    # compliance law would replace it); open loop with the valves open, closed loop with the
    # set point 0 (the speed and current loops act on the motor's speed)
    ("HydraulicJoint", "effects off"): (
        {"internal_controller": False, "u_left": -5.0, "u_right": 6.0, "tau_ext": 0.8},
        lambda md: [0.1, 0.3, 0.052, 0.1, 3.5e6, 4e6, 0.048, -0.05, 3e6, 3.2e6, 1e-6, 2e-6, 0.0,
                    0.0, 0.0, 0.0, 0.0, 0.0]),
    ("TwistedString", "effects off"): (
        {"theta_motor_ref": 0.0, "F_load": 5.0},
        lambda md: twisted_string_taut(md, theta=700.0, omega=200.0, current=0.2)[:10]
        + [0.0, 0.0, 0.1]),
}


class ParameterProbe:
    """One FMI 3.0 Model Exchange instance of `model` at an operating point, re-initialized with
    any parameter values (fmi3Reset, start values, initialization, the initial event, then the
    point's states in Continuous-Time Mode): the unknowns (outputs, then state derivatives) as a
    function of the parameters by fmi3SetFloat64 and fmi3GetFloat64 alone."""

    def __init__(self, model, loop, override=None):
        path = fmu3_path(model)
        self.md = md = fmpy.read_model_description(path)
        self.fmu = FMU3Model(guid=md.guid, unzipDirectory=fmpy.extract(path),
                             modelIdentifier=md.modelExchange.modelIdentifier)
        self.fmu.instantiate()
        start, point = PARAMETER_POINTS[(model, loop)]
        self.start = {**start, **(override or {})}
        self.x = np.array(point(md), dtype=float)
        self.n = md.numberOfContinuousStates
        self.outputs = [v for v in md.modelVariables if v.causality == "output"]
        self.derivatives = [d.variable for d in md.derivatives]
        self.unknowns = self.outputs + self.derivatives
        self.parameters = [v for v in md.modelVariables
                           if v.causality == "parameter" and v.type == "Float64"]

    def at(self, values=None):
        """The unknowns with the parameters `values` ({name: value}), the rest at their starts."""
        fmu = self.fmu
        fmu.reset()
        fmpy.simulation.apply_start_values(fmu, self.md, {**self.start, **(values or {})})
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.updateDiscreteStates()
        fmu.enterContinuousTimeMode()
        fmu.setContinuousStates(ptr(self.x), self.n)
        f = np.zeros(self.n)
        fmu.getContinuousStateDerivatives(ptr(f), self.n)
        y = fmu.getFloat64([v.valueReference for v in self.outputs])
        return np.concatenate([y, f])

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def scale_and_bounds(v):
    """A parameter's magnitude (its range's width at 0, else 1) and its range."""
    value = float(v.start)
    lo = float(v.min) if v.min is not None else -math.inf
    hi = float(v.max) if v.max is not None else math.inf
    scale = abs(value) if value != 0 else (hi - lo if math.isfinite(hi - lo) else 1.0)
    return value, scale, lo, hi


def declared_parameters(md):
    """{unknown name: names of the parameters in its dependencies} from the model description."""
    unknowns = md.outputs + md.derivatives
    return {u.variable.name: {d.name for d in u.dependencies if d.causality == "parameter"}
            for u in unknowns}


@pytest.mark.parametrize("model,loop", sorted(PARAMETER_POINTS))
def test_parameter_dependencies_hold(model, loop):
    """Each Float64 parameter moved by 1e-3 of its magnitude (inward at an end of its range)
    changes only the unknowns whose dependencies list it (bit for bit: an unknown that does not
    depend on it is computed from the same numbers). Not vacuous: most parameters that act move
    some unknown."""
    probe = ParameterProbe(model, loop)
    declared = declared_parameters(probe.md)
    names = [v.name for v in probe.unknowns]
    base = probe.at()
    undeclared, moved = [], set()
    for p in probe.parameters:
        value, scale, lo, hi = scale_and_bounds(p)
        step = 1e-3 * scale
        moved_value = value + step if value + step <= hi else value - step
        now = probe.at({p.name: moved_value})
        for name, a, b in zip(names, base, now):
            if a != b:
                moved.add(p.name)
                if p.name not in declared[name]:
                    undeclared.append((name, p.name))
    probe.free()
    assert not undeclared, f"changed but not listed (unknown, parameter): {undeclared}"
    # with the effects off their parameters (`<effect>.<name>`) act nowhere
    acting = [p for p in probe.parameters if loop != "effects off" or "." not in p.name]
    assert len(moved) >= 0.6 * len(acting), sorted(moved)


def central_columns(probe, h_rel=1e-6):
    """d(unknowns)/d(parameter) per Float64 parameter by central differences of set/get with a
    step 1e-6 of its magnitude; at an end of its range the one-sided difference of second order
    into the range. Returns the columns and the parameters' magnitudes."""
    columns, scales = [], []
    for p in probe.parameters:
        value, scale, lo, hi = scale_and_bounds(p)
        h = h_rel * scale
        if value - 2 * h >= lo and value + 2 * h <= hi:
            col = (probe.at({p.name: value + h}) - probe.at({p.name: value - h})) / (2 * h)
        else:
            s = 1.0 if value + 2 * h <= hi else -1.0
            f0, f1, f2 = (probe.at({p.name: value + k * s * h}) for k in (0, 1, 2))
            col = s * (4 * (f1 - f0) - (f2 - f0)) / (2 * h)  # exactly 0 when flat
        columns.append(col)
        scales.append(scale)
    return np.array(columns).T, np.array(scales)


# The set point at the initial tick 0 (the initial state is at rest, untwisted): the controller's
# held output is then 0 whatever its parameters, so differences of set/get, which re-initialize,
# see the same held output as the directional derivative, which holds it (a discrete state).
AT_REST = {"HydraulicJoint": {"theta_ref": 0.0}, "TwistedString": {"theta_motor_ref": 0.0}}


@pytest.mark.parametrize("model,loop", sorted(PARAMETER_POINTS))
def test_parameter_directional_and_adjoint_derivatives(model, loop):
    """Every effect on, open loop and closed loop (the continuous current and speed loops of
    TwistedString act): fmi3GetDirectionalDerivative of every output and state derivative with
    respect to each Float64 parameter agrees with central differences of set/get (within 1e-6
    of the row's largest |J_ij| times parameter magnitude); fmi3GetAdjointDerivative with a
    random seed w gives w^T J of the same matrix; neither call changes any value of the
    instance (bit for bit)."""
    probe = ParameterProbe(model, loop, AT_REST[model] if loop == "closed loop" else None)
    fd, scales = central_columns(probe)
    probe.at()
    fmu = probe.fmu
    everything = [v.valueReference for v in probe.md.modelVariables if v.type == "Float64"]
    before = fmu.getFloat64(everything)
    unknowns = [v.valueReference for v in probe.unknowns]
    knowns = [p.valueReference for p in probe.parameters]
    jac = np.array([fmu.getDirectionalDerivative(unknowns, [k], [1.0]) for k in knowns]).T
    scaled = np.abs(fd) * scales
    row = scaled.max(axis=1, keepdims=True)
    err = np.abs(jac - fd) * scales / (row + 1e-300)
    worst = np.unravel_index(np.argmax(err), err.shape)
    assert err.max() < 1e-6, (probe.unknowns[worst[0]].name, probe.parameters[worst[1]].name,
                              err.max())
    assert np.count_nonzero(row) >= 12 and np.count_nonzero(fd) >= 60, (np.count_nonzero(row), np.count_nonzero(fd))  # not vacuous
    w = np.random.default_rng(2).standard_normal(len(unknowns))
    adjoint = fmu.getAdjointDerivative(unknowns, knowns, list(w), nSensitivity=len(knowns))
    bound = 1e-12 * float(np.max(np.abs(w) @ np.abs(jac)))
    assert np.allclose(adjoint, w @ jac, rtol=1e-12, atol=bound)
    assert fmu.getFloat64(everything) == before
    probe.free()
