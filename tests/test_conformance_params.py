"""Bad parameters are refused at fmi2ExitInitializationMode with a message naming
the parameter, never discovered later as NaN; and values inside the declared ranges work.

- every Real parameter of every FMU, set to the nearest double outside its min or max (all other
  parameters at their defaults): fmi2Error at fmi2ExitInitializationMode, the message names it,
  the instance stays in initialization mode and accepts the corrected value;
- ill-posed combinations of in-range values (annulus area not below the piston area, return
  pressure not below supply pressure, a speed limit the supply voltage cannot reach, an undamped
  unbounded oscillator): refused the same way;
- every Real parameter at its min and at its max: either refused with a message naming a parameter,
  or 0.1 s of simulation with fmi2OK and finite outputs (a failed step must say why);
- candidate effects (`<effect>.enabled` = true) with each effect parameter at its min and its max:
  initialization and 0.2 s of simulation succeed with finite outputs (the candidate-effect convention).
"""
import math
import re

import numpy as np
import pytest
from fmpy import read_model_description

from conftest import fmu_path
from fmi_harness import ERROR, OK, WARNING, Harness
from fmpy.fmi2 import fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy
from ctypes import byref

ALL = ["HydraulicJoint", "TwistedString", "Oscillator"]
H = 1e-3

_MD = {}
_H = {}


def md(name):
    if name not in _MD:
        _MD[name] = read_model_description(fmu_path(name))
    return _MD[name]


def harness(name):
    """One harness per FMU (FMPy's logger proxy forwards to the last registered logger)."""
    if name not in _H:
        _H[name] = Harness(fmu_path(name))
    h = _H[name]
    h.free()
    h.messages.clear()
    # FMPy's variadic-logger proxy forwards to the most recently registered Python logger
    h._logger_ref = fmi2CallbackLoggerTYPE(h._log)
    h.callbacks.logger = h._logger_ref
    addLoggerProxy(byref(h.callbacks))
    assert h.instantiate()
    return h


# the Oscillator's `fail_at` exists to make a step fail on purpose
DELIBERATE = {"fail_at"}


def real_parameters(name):
    return [v for v in md(name).modelVariables
            if v.causality == "parameter" and v.type == "Real" and (v.min is not None or v.max is not None)
            and v.name not in DELIBERATE]


def outputs(name):
    return [v.name for v in md(name).modelVariables if v.causality == "output" and v.type == "Real"]


def _outside_cases():
    for name in ALL:
        for v in real_parameters(name):
            if v.min is not None:
                yield pytest.param(name, v.name, math.nextafter(float(v.min), -math.inf), id=f"{name}-{v.name}-below")
            if v.max is not None:
                yield pytest.param(name, v.name, math.nextafter(float(v.max), math.inf), id=f"{name}-{v.name}-above")


@pytest.mark.parametrize("name,param,value", list(_outside_cases()))
def test_parameter_just_outside_range_is_refused(name, param, value):
    h = harness(name)
    assert h.setup() == OK and h.call("EnterInitializationMode") == OK
    assert h.set_real([param], [value]) == OK  # fixed parameters are checked at exit
    assert h.call("ExitInitializationMode") == ERROR
    msg = h.last_error()
    assert f"'{param}'" in msg and "range" in msg, msg
    assert "fmi2ExitInitializationMode" in msg
    # still in initialization mode: the corrected value is accepted
    assert h.set_real([param], [float(h.var[param].start)]) == OK
    assert h.call("ExitInitializationMode") == OK, h.last_error()
    assert h.do_step(0.0, H) == OK


ILL_POSED = [
    ("HydraulicJoint", {"annulus_area": 2.0e-4, "piston_area": 2.0e-4}, "annulus_area"),
    ("HydraulicJoint", {"annulus_area": 1.0e-3, "piston_area": 5.0e-4}, "annulus_area"),
    ("HydraulicJoint", {"return_pressure": 1.0e6, "supply_pressure": 1.0e6}, "return_pressure"),
    ("TwistedString", {"speed_limit": 2000.0, "back_emf_constant": 0.5, "supply_voltage": 12.0}, "speed_limit"),
    ("Oscillator", {"stiffness": 0.0, "damping": 0.0}, "stiffness"),
]


@pytest.mark.parametrize("name,values,culprit", ILL_POSED)
def test_ill_posed_combination_is_refused(name, values, culprit):
    h = harness(name)
    assert h.initialize(reals=values) == ERROR
    msg = h.last_error()
    assert culprit in msg, msg
    assert h.call("Reset") == OK
    assert h.initialize() == OK


def _names_a_parameter(name, msg):
    params = [v.name for v in md(name).modelVariables if v.causality == "parameter"]
    return any(re.search(rf"(?<![\w.]){re.escape(p)}(?![\w.])", msg) for p in params)


def _run(h, name, steps, inputs=None):
    """Steps of H; returns (status of the first failing step or OK, outputs array)."""
    outs = outputs(name)
    rows = []
    for k in range(steps):
        for n, u in (inputs or {}).items():
            assert h.set_real([n], [u(k * H)]) <= WARNING
        s = h.do_step(k * H, H)
        if s != OK:
            return s, np.array(rows)
        st, y = h.get_real(outs)
        assert st == OK
        rows.append(y)
    return OK, np.array(rows)


INPUTS = {
    "HydraulicJoint": {"theta_ref": lambda t: 0.3 * math.sin(6.0 * t)},
    "TwistedString": {"theta_motor_ref": lambda t: 300.0 * math.sin(6.0 * t)},
    "Oscillator": {"force": lambda t: 10.0 * math.sin(20.0 * t)},
}


@pytest.mark.parametrize("name", ALL)
def test_parameters_at_their_bounds_fail_loudly_or_run_finite(name):
    refused, failed = [], []
    for v in real_parameters(name):
        for bound in (v.min, v.max):
            if bound is None:
                continue
            h = harness(name)
            s = h.initialize(reals={v.name: float(bound)})
            if s == ERROR:
                msg = h.last_error()
                assert msg and _names_a_parameter(name, msg), f"{v.name}={bound}: refusal naming no parameter {msg!r}"
                refused.append(f"{v.name}={bound}: {msg}")
                continue
            assert s == OK, h.messages
            st, y = _run(h, name, 100, INPUTS[name])
            if st != OK:
                assert st == ERROR and h.last_error(), f"{v.name}={bound}: step status {st} without message"
                failed.append(f"{v.name}={bound}: {h.last_error()}")
            assert np.all(np.isfinite(y)), f"{v.name}={bound}: non-finite output with fmi2OK"
    print(f"\n{name}: {len(refused)} bound values refused at initialization, {len(failed)} failed in a step")
    for r in refused + failed:
        print("  ", r)
    # in-range values must not make the solver fail: a failure here is a model robustness bug
    assert not failed, "in-range parameter values made fmi2DoStep fail:\n" + "\n".join(failed)


def _effects(name):
    vs = md(name).modelVariables
    flags = [v.name for v in vs if v.causality == "parameter" and v.type == "Boolean" and v.name.endswith(".enabled")]
    return {f[: -len(".enabled")]: [v for v in vs if v.name.startswith(f[: -len("enabled")]) and v.type == "Real"]
            for f in flags}


def _effect_cases():
    for name in ("HydraulicJoint", "TwistedString"):
        for effect, params in _effects(name).items():
            for v in params:
                for which in ("min", "max"):
                    yield pytest.param(name, effect, v.name, which, id=f"{name}-{v.name}-{which}")


@pytest.mark.parametrize("name,effect,param,which", list(_effect_cases()))
def test_effect_parameters_in_range_simulate_finite(name, effect, param, which):
    h = harness(name)
    value = float(getattr(h.var[param], which))
    s = h.initialize(reals={param: value}, booleans={f"{effect}.enabled": True})
    assert s == OK, h.last_error()
    st, y = _run(h, name, 200, INPUTS[name])
    assert st == OK, h.last_error()
    assert np.all(np.isfinite(y))
