"""A second, independent importer (libcosim), so conformance is not judged by FMPy alone. Every FMU in dist/ (and the Oscillator test
model) runs in libcosim (DNV's C++ co-simulation library, through the `libcosimpy` wheel) and in
FMPy (through tests/fmi_harness.py) over the same inputs, the same non-default parameter and the
same communication step; every output agrees within 1e-6 of that signal's range.

libcosim is driven with a fixed-step execution, an override manipulator for the inputs (applied
before the step that starts at t_k, as FMPy's fmi2SetReal before fmi2DoStep(t_k, h)) and a
last-value observer read after each step (the outputs at t_k + h). Parameters go through
`real_initial_value`, which libcosim applies in initialization mode.
"""
import math

import numpy as np
import pytest

from conftest import DIST, fmu_path
from fmi_harness import OK, WARNING, Harness

libcosim = pytest.importorskip("libcosimpy")
from libcosimpy.CosimExecution import CosimExecution  # noqa: E402
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level  # noqa: E402
from libcosimpy.CosimManipulator import CosimManipulator  # noqa: E402
from libcosimpy.CosimObserver import CosimObserver  # noqa: E402
from libcosimpy.CosimSlave import CosimLocalSlave  # noqa: E402

log_output_level(CosimLogLevel.ERROR)

H = 1e-3  # communication step [s]

# name -> (steps, {parameter: value}, {input: u(t)})
CASES = {
    "HydraulicJoint": (
        1000,
        {"load_mass": 3.0},
        {"theta_ref": lambda t: 0.4 * math.sin(4.0 * t), "tau_ext": lambda t: 0.5 * math.cos(7.0 * t)},
    ),
    "TwistedString": (
        600,
        {"load_mass": 3.0},
        {"theta_motor_ref": lambda t: 400.0 * math.sin(3.0 * t), "F_load": lambda t: 5.0 * t},
    ),
    "Oscillator": (
        1000,
        {"mass": 1.5},
        {"force": lambda t: 50.0 * math.sin(10.0 * t)},
    ),
}


def _cases():
    """Every FMU in dist/ plus the Oscillator; an FMU without an entry in CASES gets small
    sinusoids on all its Real inputs and default parameters."""
    names = sorted({p.stem for p in DIST.glob("*.fmu")} | set(CASES))
    return names


def _case(name):
    if name in CASES:
        return CASES[name]
    md = Harness(fmu_path(name)).md
    inputs = {v.name: (lambda t, k=k: 0.1 * math.sin((2.0 + k) * t))
              for k, v in enumerate(md.modelVariables) if v.causality == "input" and v.type == "Real"}
    return 1000, {}, inputs


def _outputs(md):
    return [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]


def run_fmpy(name, steps, params, inputs):
    h = Harness(fmu_path(name))
    assert h.instantiate()
    assert h.initialize(reals=params) == OK, h.last_error()
    outs = [v.name for v in _outputs(h.md)]
    rows = []
    for k in range(steps):
        t = k * H
        for n, u in inputs.items():
            assert h.set_real([n], [u(t)]) <= WARNING
        assert h.do_step(t, H) == OK, h.last_error()
        s, y = h.get_real(outs)
        assert s == OK
        rows.append(y)
    h.free()
    return outs, np.array(rows)


def run_libcosim(name, steps, params, inputs, md):
    ex = CosimExecution.from_step_size(int(round(H * 1e9)))
    slave = CosimLocalSlave(fmu_path=fmu_path(name), instance_name=name.lower())
    idx = ex.add_local_slave(slave)
    assert idx >= 0, "libcosim could not load the FMU"
    vr = {v.name: v.valueReference for v in md.modelVariables}
    for n, x in params.items():
        assert ex.real_initial_value(idx, vr[n], x)
    manipulator = CosimManipulator.create_override()
    assert ex.add_manipulator(manipulator)
    observer = CosimObserver.create_last_value()
    assert ex.add_observer(observer)
    out_vrs = [v.valueReference for v in _outputs(md)]
    in_vrs = [vr[n] for n in inputs]
    rows = []
    for k in range(steps):
        t = k * H
        assert manipulator.slave_real_values(idx, in_vrs, [u(t) for u in inputs.values()])
        assert ex.step(1), f"libcosim step {k} failed"
        rows.append(observer.last_real_values(idx, out_vrs))
    status = ex.status()
    assert status.current_time == steps * int(round(H * 1e9))
    ex.stop()
    return np.array(rows)


@pytest.mark.parametrize("name", _cases())
def test_libcosim_agrees_with_fmpy(name):
    steps, params, inputs = _case(name)
    outs, a = run_fmpy(name, steps, params, inputs)
    md = Harness(fmu_path(name)).md
    b = run_libcosim(name, steps, params, inputs, md)
    assert a.shape == b.shape
    assert np.all(np.isfinite(b))
    scale = np.maximum(np.ptp(a, axis=0), 1e-300)
    rel = np.abs(a - b).max(axis=0) / scale
    worst = {outs[j]: rel[j] for j in np.argsort(rel)[::-1][:3]}
    assert np.all(rel <= 1e-6), f"libcosim and FMPy differ (relative to range): {worst}"
    # the run is not trivial: most outputs move
    assert np.count_nonzero(np.ptp(a, axis=0) > 0) >= len(outs) // 2
