"""<ModelStructure>: every output is listed, depending on the continuous states only (Model
Exchange; dependencies="" without it) or on an input the Model Exchange interface passes through
at once (tests/test_model_exchange_hydraulic_joint.py proves those numerically), and in
Co-Simulation the FMUs have no direct feedthrough: an input changed between steps changes no
output before the next fmi2DoStep
(each input jumped across its whole range, every output compared bit for bit), while the next
step does respond to it (so the comparison is not vacuous)."""
import pytest
from fmpy import read_model_description

from conftest import fmu_path
from fmi_harness import OK, Harness

MODELS = ["HydraulicJoint", "TwistedString", "EMPS"]


@pytest.mark.parametrize("model", MODELS)
def test_outputs_are_listed_with_state_dependencies(model):
    md = read_model_description(fmu_path(model))
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    listed = [u.variable for u in md.outputs]
    assert listed == outputs
    states = [d.variable.derivative for d in md.derivatives]
    if md.modelExchange is None:
        assert all(u.dependencies == [] for u in md.outputs)
    for u in md.outputs:
        assert all(d in states or d.causality == "input" for d in u.dependencies), u.variable.name
        assert set(states) <= set(u.dependencies), u.variable.name


@pytest.mark.parametrize("model", MODELS)
def test_no_output_depends_directly_on_an_input(model):
    h = Harness(fmu_path(model))
    h.instantiate()
    assert h.initialize() == OK
    t, dt = 0.0, 1e-3
    for _ in range(20):
        assert h.do_step(t, dt) == OK
        t += dt
    outs = [v.name for v in h.md.modelVariables if v.causality == "output"]
    _, before = h.get_real(outs)
    moved = set()
    for v in (v for v in h.md.modelVariables if v.causality == "input"):
        lo = float(v.min) if v.min is not None else -1e3
        hi = float(v.max) if v.max is not None else 1e3
        for x in (lo, hi):
            assert h.set_real([v.name], [x]) <= 1
            _, now = h.get_real(outs)
            assert now == before, (v.name, x, [o for o, a, b in zip(outs, before, now) if a != b])
        s, state = h.get_state()
        assert h.do_step(t, dt) == OK
        _, stepped = h.get_real(outs)
        moved |= {o for o, a, b in zip(outs, before, stepped) if a != b}
        assert h.call("SetFMUstate", state) == OK
    assert moved, "no input moved any output after a step"
