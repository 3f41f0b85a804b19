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
