"""The generic FMI 2.0 Co-Simulation layer (fmi2-export over fmu-core), proven on the Oscillator test model and
on every FMU in dist/: validation, every exported function with its status and logged message,
wrong call order, bad arguments, FMU state save/restore/serialize to the last bit, reproducible
packaging and model descriptions that match the committed ones."""
import hashlib
import math
import subprocess
from ctypes import byref, c_double, c_int, c_size_t, c_uint, c_void_p, POINTER, c_char_p
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import DIST, REPO, fmu3_path, fmu_path
from fmi_harness import DISCARD, ERROR, OK, WARNING, Harness

PRODUCTS = ["HydraulicJoint", "TwistedString", "EMPS"]
ALL = PRODUCTS + ["Oscillator"]

EXPORTED = """fmi2GetTypesPlatform fmi2GetVersion fmi2SetDebugLogging fmi2Instantiate fmi2FreeInstance
fmi2SetupExperiment fmi2EnterInitializationMode fmi2ExitInitializationMode fmi2Terminate fmi2Reset
fmi2GetReal fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetReal fmi2SetInteger fmi2SetBoolean
fmi2SetString fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate fmi2SerializedFMUstateSize
fmi2SerializeFMUstate fmi2DeSerializeFMUstate fmi2GetDirectionalDerivative
fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives fmi2DoStep fmi2CancelStep fmi2GetStatus
fmi2GetRealStatus fmi2GetIntegerStatus fmi2GetBooleanStatus fmi2GetStringStatus
fmi2EnterEventMode fmi2NewDiscreteStates fmi2EnterContinuousTimeMode fmi2CompletedIntegratorStep
fmi2SetTime fmi2SetContinuousStates fmi2GetDerivatives fmi2GetEventIndicators
fmi2GetContinuousStates fmi2GetNominalsOfContinuousStates""".split()


@pytest.fixture
def osc():
    h = Harness(fmu_path("Oscillator"))
    assert h.instantiate()
    yield h
    h.free()


@pytest.mark.parametrize("name", ALL)
def test_fmpy_validation_reports_nothing(name):
    assert validate_fmu(fmu_path(name)) == []


@pytest.mark.parametrize("name", ALL)
def test_every_fmi2_function_is_exported(name):
    import ctypes
    from fmpy import extract

    md_dir = extract(fmu_path(name))
    lib = ctypes.CDLL(str(Path(md_dir) / "binaries" / "linux64" / f"{name}.so"))
    missing = [f for f in EXPORTED if not hasattr(lib, f)]
    assert missing == []


def test_oscillator_matches_closed_form():
    # m x'' + c x' + k x = 0, x(0) = 0.01: underdamped closed form (independent of the code).
    res = simulate_fmu(fmu_path("Oscillator"), stop_time=2.0, output_interval=1e-3, output=["x"])
    k, c, m, x0 = 100.0, 0.5, 1.0, 0.01
    wn = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    t = res["time"]
    exact = x0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    assert np.max(np.abs(res["x"] - exact)) < 1e-9


def test_version_and_platform(osc):
    f = osc.slave._functions
    f["fmi2GetVersion"].restype = c_char_p
    f["fmi2GetTypesPlatform"].restype = c_char_p
    assert osc.slave.fmi2GetVersion() == b"2.0"
    assert osc.slave.fmi2GetTypesPlatform() == b"default"


def test_instantiate_rejects_bad_arguments():
    h = Harness(fmu_path("Oscillator"))
    assert not h.instantiate(guid="{wrong}")
    assert "GUID" in h.last_error()
    assert not h.instantiate(fmu_type=2)
    assert "Co-Simulation" in h.last_error()
    assert not h.instantiate(name=b"")
    assert "instanceName" in h.last_error()
    assert h.instantiate()
    h.free()


def test_wrong_call_order_is_an_error_and_harmless(osc):
    # Before initialization: no step, no exit-init, no terminate, no get.
    assert osc.do_step(0.0, 0.01) == ERROR
    assert "illegal call sequence" in osc.last_error()
    assert osc.call("ExitInitializationMode") == ERROR
    assert osc.call("Terminate") == ERROR
    assert osc.get_real(["x"])[0] == ERROR
    # The instance is still usable.
    assert osc.initialize() == OK
    assert osc.call("EnterInitializationMode") == ERROR
    assert osc.call("SetupExperiment", 0, 0.0, 0.0, 0, 0.0) == ERROR
    assert osc.do_step(0.0, 0.01) == OK
    assert osc.call("Terminate") == OK
    assert osc.do_step(0.01, 0.01) == ERROR
    assert osc.get_real(["x"])[0] == OK
    assert osc.call("Reset") == OK
    assert osc.initialize() == OK
    assert osc.do_step(0.0, 0.01) == OK


def test_bad_arguments_are_errors_with_messages(osc):
    assert osc.initialize() == OK
    # unknown value reference
    assert osc.get_real([9999])[0] == ERROR
    assert "unknown value reference 9999" in osc.last_error()
    # wrong type: a Boolean read as Real
    assert osc.get_real([osc.vr["locked"]])[0] == ERROR
    assert "Boolean" in osc.last_error()
    # NaN and infinity
    for bad in (float("nan"), float("inf"), -float("inf")):
        assert osc.set_real(["force"], [bad]) == ERROR
        assert "not finite" in osc.last_error()
    # fixed parameter after initialization
    assert osc.set_real(["mass"], [2.0]) == ERROR
    assert "fixed parameter" in osc.last_error()
    # outputs cannot be set
    assert osc.set_real(["x"], [1.0]) == ERROR
    # null pointers
    assert osc.call("GetReal", None, 1, None) == ERROR
    assert osc.call("SetReal", None, 1, None) == ERROR
    # zero, negative, NaN and huge-but-wrong steps
    for h in (0.0, -0.01, float("nan"), float("inf")):
        assert osc.do_step(0.0, h) == ERROR
        assert "communicationStepSize" in osc.last_error()
    # communication point that is not the current time
    assert osc.do_step(0.5, 0.01) == ERROR
    assert "not the current time" in osc.last_error()
    # all of that left the instance intact: the next step is fine and values are unchanged
    s, before = osc.get_real(["x", "v"])
    assert s == OK and before[0] == pytest.approx(0.01)
    assert osc.do_step(0.0, 0.01) == OK
    # atomic set: one bad value in a list changes nothing
    assert osc.set_real(["force", "x"], [5.0, 1.0]) == ERROR
    assert osc.get_real(["force"]) == (OK, [0.0])
    # input outside its declared range is accepted with a warning
    assert osc.set_real(["force"], [5000.0]) == WARNING


def test_null_component_is_an_error():
    h = Harness(fmu_path("Oscillator"))
    f = h.slave._functions
    assert f["fmi2DoStep"](None, c_double(0.0), c_double(0.1), 1) == ERROR
    assert f["fmi2ExitInitializationMode"](None) == ERROR
    f["fmi2FreeInstance"](None)  # must not crash


def test_parameter_out_of_range_refused_at_exit_initialization(osc):
    assert osc.setup() == OK
    assert osc.call("EnterInitializationMode") == OK
    assert osc.set_real(["mass"], [-1.0]) == OK
    assert osc.call("ExitInitializationMode") == ERROR
    assert "'mass'" in osc.last_error() and "range" in osc.last_error()
    # corrected, initialization succeeds
    assert osc.set_real(["mass"], [2.0]) == OK
    assert osc.call("ExitInitializationMode") == OK


def test_ill_posed_combination_refused_naming_the_parameter(osc):
    assert osc.initialize(reals={"stiffness": 0.0, "damping": 0.0}) == ERROR
    assert "'stiffness'" in osc.last_error()


def test_failed_step_is_an_error_and_keeps_last_good_outputs(osc):
    assert osc.initialize(reals={"fail_at": 0.05}) == OK
    t = 0.0
    for _ in range(4):
        assert osc.do_step(t, 0.01) == OK
        t += 0.01
    _, good = osc.get_real(["x", "v"])
    assert osc.do_step(t, 0.01) == ERROR
    assert "deliberate failure" in osc.last_error()
    assert osc.get_real(["x", "v"]) == (OK, good)
    assert osc.do_step(t, 0.01) == ERROR  # error state: no more steps
    assert osc.call("Reset") == OK
    assert osc.initialize() == OK


def test_debug_logging_categories(osc):
    cats = (c_char_p * 1)(b"logEvents")
    assert osc.call("SetDebugLogging", 1, 1, cats) == OK
    assert osc.initialize() == OK
    assert any(m[1] == "logEvents" and "initialized" in m[2] for m in osc.messages)
    bad = (c_char_p * 1)(b"noSuchCategory")
    assert osc.call("SetDebugLogging", 1, 1, bad) == ERROR
    assert "noSuchCategory" in osc.last_error()
    assert osc.call("SetDebugLogging", 0, 0, None) == OK
    n = len(osc.messages)
    assert osc.do_step(0.0, 0.01) == OK
    assert len(osc.messages) == n  # nothing logged with logging off


def _tolerances_after_init(name, tolerance, reals=None):
    """rtol and atol as fmi2GetReal shows them after initialization, with `tolerance` passed to
    fmi2SetupExperiment (None: not defined); also the status of that call."""
    h = Harness(fmu_path(name))
    assert h.instantiate()
    try:
        st = h.setup(tolerance=tolerance)
        assert h.call("EnterInitializationMode") == OK
        if reals:
            assert h.set_real(list(reals), list(reals.values())) == OK
        assert h.call("ExitInitializationMode") == OK
        assert h.do_step(0.0, 1e-3) == OK
        status, values = h.get_real(["rtol", "atol"])
        assert status == OK
        return st, values, h.messages
    finally:
        h.free()


@pytest.mark.parametrize("name", PRODUCTS)
def test_the_importers_tolerance_reaches_the_solver_unless_the_user_set_one(name):
    """FMI 2.0.4 section 4.2.1: a tolerance defined in fmi2SetupExperiment is the one the FMU's
    solver should use. It replaces rtol and atol left at their start values (1e-6), clamped
    into their ranges; a value the user set wins; an unusable tolerance is a warning."""
    assert _tolerances_after_init(name, None)[:2] == (OK, [1e-6, 1e-6])
    assert _tolerances_after_init(name, 1e-4)[:2] == (OK, [1e-4, 1e-4])
    assert _tolerances_after_init(name, 0.5)[:2] == (OK, [1e-2, 1e-2])  # the range's end
    st, tol, _ = _tolerances_after_init(name, 1e-4, reals={"rtol": 1e-8})
    assert (st, tol) == (OK, [1e-8, 1e-4])
    st, tol, msgs = _tolerances_after_init(name, -1.0)
    assert (st, tol) == (WARNING, [1e-6, 1e-6])
    assert any("tolerance -1 is not a positive number" in m[2] for m in msgs), msgs


def test_unsupported_functions_error_with_reason(osc):
    assert osc.initialize() == OK
    vr = (c_uint * 1)(osc.vr["x"])
    order = (c_int * 1)(1)
    val = (c_double * 1)()
    # directional derivatives are provided (tests/test_directional_cs.py), of outputs and state
    # derivatives with respect to states and inputs only
    mass = (c_uint * 1)(osc.vr["mass"])
    assert osc.call("GetDirectionalDerivative", vr, 1, mass, 1, val, val) == ERROR
    assert "is not a state or an input" in osc.last_error()
    assert osc.call("SetRealInputDerivatives", vr, 1, order, val) == ERROR
    assert osc.call("GetRealOutputDerivatives", vr, 1, order, val) == ERROR
    assert osc.call("CancelStep") == ERROR
    status = c_int()
    assert osc.call("GetStatus", 0, byref(status)) == DISCARD
    t = c_double()
    assert osc.call("GetRealStatus", 2, byref(t)) == OK and t.value == 0.0
    assert osc.call("GetString", vr, 1, None) == ERROR


def test_fmu_state_functions_reject_foreign_handles(osc):
    assert osc.initialize() == OK
    assert osc.call("SetFMUstate", c_void_p(12345)) == ERROR
    assert osc.deserialize(b"garbage")[0] == ERROR
    assert "bad header" in osc.last_error()
    s, state = osc.get_state()
    data = osc.serialize(state)
    assert osc.deserialize(data[: len(data) // 2])[0] == ERROR
    assert osc.call("FreeFMUstate", byref(state)) == OK
    assert state.value is None


def _run_with_state_roundtrip(name, reals=None, booleans=None, inputs=None, t_end=1.0, h=1e-3):
    """Simulate 0..t_end; save the state at t_end/2 in memory and serialized; continue to t_end;
    restore each and continue again. Returns the three second-half trajectories."""
    hs = Harness(fmu_path(name))
    assert hs.instantiate()
    assert hs.initialize(reals=reals, booleans=booleans) == OK
    outputs = [v.name for v in hs.md.modelVariables if v.causality == "output"]
    n = int(round(t_end / h))
    half = n // 2

    def run(k0, k1):
        rows = []
        for k in range(k0, k1):
            if inputs:
                for nm, fn in inputs.items():
                    assert hs.set_real([nm], [fn(k * h)]) <= WARNING
            assert hs.do_step(k * h, h) == OK, hs.last_error()
            rows.append(hs.get_real(outputs)[1])
        return np.array(rows)

    run(0, half)
    s, mem = hs.get_state()
    assert s == OK
    data = hs.serialize(mem)
    first = run(half, n)
    assert hs.call("SetFMUstate", mem) == OK
    second = run(half, n)
    hs.call("Reset")
    s, restored = hs.deserialize(data)
    assert s == OK
    assert hs.call("SetFMUstate", restored) == OK
    third = run(half, n)
    hs.free()
    return first, second, third


@pytest.mark.parametrize("name", ALL)
def test_state_save_restore_and_serialization_are_bit_identical(name):
    inputs = None
    if name == "HydraulicJoint":
        inputs = {"theta_ref": lambda t: 0.3 * math.sin(3 * t)}
    elif name == "TwistedString":
        inputs = {"theta_motor_ref": lambda t: 300.0 * min(t, 0.5)}
    elif name == "Oscillator":
        inputs = {"force": lambda t: math.sin(10 * t)}
    elif name == "EMPS":
        inputs = {"qg": lambda t: 0.05 * min(t, 0.5)}
    first, second, third = _run_with_state_roundtrip(name, inputs=inputs)
    assert first.shape[0] > 0
    assert np.array_equal(first.view(np.uint64), second.view(np.uint64))
    assert np.array_equal(first.view(np.uint64), third.view(np.uint64))


def test_instances_are_independent():
    a, b = Harness(fmu_path("Oscillator")), Harness(fmu_path("Oscillator"))
    assert a.instantiate() and b.instantiate()
    assert a.initialize(reals={"x0": 0.02}) == OK
    assert b.initialize() == OK
    for k in range(10):
        assert a.do_step(k * 0.01, 0.01) == OK
        assert b.do_step(k * 0.01, 0.01) == OK
    assert a.get_real(["x"])[1] != b.get_real(["x"])[1]
    a.free()
    assert b.do_step(0.1, 0.01) == OK
    b.free()


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.mark.long
def test_packaging_is_reproducible():
    """Relinking and repackaging one product for every platform of both versions gives the same
    bytes (every model takes the same path through scripts/build; one keeps the test short)."""
    paths = [fmu_path("HydraulicJoint"), fmu3_path("HydraulicJoint")]
    before = [_sha(p) for p in paths]
    subprocess.run([str(REPO / "scripts" / "build"), "HydraulicJoint"], check=True,
                   capture_output=True)
    assert [_sha(p) for p in paths] == before


def test_build_refuses_an_unknown_model():
    p = subprocess.run([str(REPO / "scripts" / "build"), "NoSuchModel"], capture_output=True,
                       text=True)
    assert p.returncode == 2 and "unknown model" in p.stderr


@pytest.mark.parametrize("name", PRODUCTS)
def test_committed_model_description_is_up_to_date(name):
    import zipfile

    fmu_path(name)
    committed = (REPO / "modelDescription" / f"{name}.xml").read_text()
    with zipfile.ZipFile(DIST / f"{name}.fmu") as z:
        packaged = z.read("modelDescription.xml").decode()
    assert packaged == committed, (
        f"modelDescription/{name}.xml is out of date: run scripts/build && "
        "scripts/update-model-descriptions"
    )


@pytest.mark.parametrize("name", ALL)
def test_documentation_is_packaged(name):
    import zipfile

    with zipfile.ZipFile(fmu_path(name)) as z:
        html = z.read("documentation/index.html").decode()
    assert "<table>" in html and name in html
