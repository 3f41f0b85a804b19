"""Hostile call sequences, table-driven, on every FMU in dist/ and the Oscillator.

Every exported function is called in every state of the FMI 2.0 Co-Simulation state machine that
the FMU can reach (instantiated, initialization mode, step complete, terminated, and error, which
only the Oscillator can reach on purpose, with `fail_at`). The allowed states are the table of
FMI 2.0.4 section 4.2.4 ("State Machine of Calling Sequence from Master to Slave"), written below
as ALLOWED from the standard, not from the implementation. Expectations:

- allowed + valid arguments: the prescribed status (fmi2OK; fmi2Discard for a status kind that is
  not available; fmi2Error with a reason for the functions the FMU declares it does not provide);
- not allowed: fmi2Error and a logged error message naming the function;
- a rejected call changes nothing: the instance answers a fixed probe exactly as an untouched
  instance in the same state does, and it can be reset and run again;
- bad arguments in every state where the function is allowed (NULL pointers, unknown value
  references, wrong types, NaN/inf, zero/negative/NaN steps, wrong communication point, fixed
  parameter after initialization, foreign/damaged FMU states): fmi2Error, a message, nothing
  changed.

test_fmi_layer.py already checks several of these on the Oscillator in one state; this file
sweeps them over all states and all FMUs.
"""
import subprocess
import sys
from ctypes import byref, c_char, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

import pytest

from conftest import REPO, fmu_path
from fmi_harness import DISCARD, ERROR, OK, WARNING, Harness
from fmpy.fmi2 import fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

ALL = ["HydraulicJoint", "TwistedString", "Oscillator"]

I, N, C, T, E = "instantiated", "initializationMode", "stepComplete", "terminated", "error"
STATES = [I, N, C, T, E]

# FMI 2.0.4, section 4.2.4, table of allowed calls for Co-Simulation (stepInProgress, stepFailed
# and stepCanceled are not reachable: these FMUs never run asynchronously).
ANY = {I, N, C, T, E}
ALLOWED = {
    "SetDebugLogging": ANY,
    "SetupExperiment": {I},
    "EnterInitializationMode": {I},
    "ExitInitializationMode": {N},
    "Terminate": {C},
    "Reset": ANY,
    "GetReal": {N, C, T, E},
    "GetInteger": {N, C, T, E},
    "GetBoolean": {N, C, T, E},
    "GetString": {N, C, T, E},
    "SetReal": {I, N, C},
    "SetInteger": {I, N, C},
    "SetBoolean": {I, N, C},
    "SetString": {I, N, C},
    "GetFMUstate": ANY,
    "SetFMUstate": ANY,
    "FreeFMUstate": ANY,
    "SerializedFMUstateSize": ANY,
    "SerializeFMUstate": ANY,
    "DeSerializeFMUstate": ANY,
    "GetDirectionalDerivative": {N, C, T, E},
    "SetRealInputDerivatives": {I, N, C},
    "GetRealOutputDerivatives": {C, T, E},
    "DoStep": {C},
    "CancelStep": set(),  # only in stepInProgress
    "GetStatus": {C, T},
    "GetRealStatus": {C, T},
    "GetIntegerStatus": {C, T},
    "GetBooleanStatus": {C, T},
    "GetStringStatus": {C, T},
}
# Declared as not provided in modelDescription.xml: fmi2Error with the reason, in every state.
UNPROVIDED = {"SetRealInputDerivatives", "GetRealOutputDerivatives", "CancelStep"}
# Status kinds that are not available (no asynchronous steps): fmi2Discard where allowed.
DISCARDED = {"GetStatus", "GetIntegerStatus", "GetStringStatus"}

H = 1e-3
# per model: a Real input, a Real output, a Boolean fixed parameter, a Real fixed parameter
ROLES = {
    "HydraulicJoint": ("theta_ref", "theta", "internal_controller", "load_radius"),
    "TwistedString": ("theta_motor_ref", "p", "internal_controller", "string_length"),
    "Oscillator": ("force", "x", "locked", "mass"),
}
OTHER = {"HydraulicJoint": "TwistedString", "TwistedString": "HydraulicJoint", "Oscillator": "HydraulicJoint"}


class Driver:
    """A harness that can be brought into any state, with a saved FMU state and its bytes."""

    _cache = {}

    def __init__(self, name):
        if name not in Driver._cache:
            Driver._cache[name] = Harness(fmu_path(name))
        self.h = Driver._cache[name]
        self.name = name
        self.inp, self.out, self.flag, self.par = ROLES[name]

    def vr(self, n):
        return self.h.vr[n]

    def goto(self, state):
        """Fresh instance in `state`; returns the harness with an FMU state saved right after
        instantiation (self.saved) and its serialized bytes (self.saved_bytes)."""
        h = self.h
        h.free()
        h.messages.clear()
        # FMPy's variadic-logger proxy forwards to the most recently registered Python logger
        # (one per process): register this harness's logger again before instantiating.
        h._logger_ref = fmi2CallbackLoggerTYPE(h._log)
        h.callbacks.logger = h._logger_ref
        addLoggerProxy(byref(h.callbacks))
        assert h.instantiate()
        s, self.saved = h.get_state()
        assert s == OK
        self.saved_bytes = h.serialize(self.saved)
        self.time = 0.0
        if state == I:
            pass
        elif state == N:
            assert h.setup() == OK and h.call("EnterInitializationMode") == OK
        elif state in (C, T):
            assert h.initialize() == OK, h.last_error()
            assert h.do_step(0.0, H) == OK
            self.time = H
            if state == T:
                assert h.call("Terminate") == OK
        elif state == E:
            assert self.name == "Oscillator"
            assert h.initialize(reals={"fail_at": 0.5 * H}) == OK
            assert h.do_step(0.0, H) == ERROR
        h.messages.clear()
        return h

    def probe(self):
        """Statuses of a fixed sequence that tells the states apart (the last call may move it)."""
        h = self.h
        t = c_double()
        return (
            h.get_real([self.out])[0],
            h.call("GetRealStatus", 2, byref(t)),
            t.value,
            h.call("ExitInitializationMode"),
            h.do_step(self.time, H),
        )

    def still_usable(self):
        h = self.h
        assert h.call("Reset") == OK, h.last_error()
        assert h.initialize() == OK, h.last_error()
        assert h.do_step(0.0, H) == OK, h.last_error()

    # Valid arguments for every function (the FMU state handle from goto()).
    def call_valid(self, fn):
        h = self.h
        v1 = lambda x: (c_uint * 1)(x)  # noqa: E731
        if fn == "SetDebugLogging":
            return h.call(fn, 1, 1, (c_char_p * 1)(b"logEvents"))
        if fn == "SetupExperiment":
            return h.call(fn, 0, 0.0, 0.0, 0, 0.0)
        if fn in ("EnterInitializationMode", "ExitInitializationMode", "Terminate", "Reset", "CancelStep"):
            return h.call(fn)
        if fn == "GetReal":
            return h.get_real([self.out])[0]
        if fn == "GetBoolean":
            return h.call(fn, v1(self.vr(self.flag)), 1, (c_int * 1)())
        if fn in ("GetInteger", "SetInteger"):
            # these models have no Integer or String variables: an empty list checks the state
            return h.call(fn, (c_uint * 1)(), 0, (c_int * 1)())
        if fn in ("GetString", "SetString"):
            return h.call(fn, (c_uint * 1)(), 0, (c_char_p * 1)())
        if fn == "SetReal":
            return h.set_real([self.inp], [0.01])
        if fn == "SetBoolean":
            # a fixed parameter: settable before initialization only (checked separately)
            return h.call(fn, v1(self.vr(self.flag)), 0, (c_int * 1)(1))
        if fn == "GetFMUstate":
            st = c_void_p()
            s = h.call(fn, byref(st))
            if s == OK:
                assert h.call("FreeFMUstate", byref(st)) == OK
            return s
        if fn == "SetFMUstate":
            return h.call(fn, self.saved)
        if fn == "FreeFMUstate":
            s = h.call(fn, byref(self.saved))
            if s == OK:
                assert self.saved.value is None
            return s
        if fn == "SerializedFMUstateSize":
            size = c_size_t()
            s = h.call(fn, self.saved, byref(size))
            if s == OK:
                assert size.value == len(self.saved_bytes)
            return s
        if fn == "SerializeFMUstate":
            buf = (c_char * len(self.saved_bytes))()
            s = h.call(fn, self.saved, buf, len(self.saved_bytes))
            if s == OK:
                assert bytes(buf) == self.saved_bytes
            return s
        if fn == "DeSerializeFMUstate":
            s, st = h.deserialize(self.saved_bytes)
            if s == OK:
                assert h.call("FreeFMUstate", byref(st)) == OK
            return s
        if fn == "GetDirectionalDerivative":
            # d(output)/d(input): an initial unknown and a known in Initialization Mode, an
            # output and an input at a communication point
            d = (c_double * 1)(1.0)
            return h.call(fn, v1(self.vr(self.out)), 1, v1(self.vr(self.inp)), 1, d,
                          (c_double * 1)())
        if fn == "SetRealInputDerivatives":
            return h.call(fn, v1(self.vr(self.inp)), 1, (c_int * 1)(1), (c_double * 1)(0.0))
        if fn == "GetRealOutputDerivatives":
            return h.call(fn, v1(self.vr(self.out)), 1, (c_int * 1)(1), (c_double * 1)())
        if fn == "DoStep":
            return h.do_step(self.time, H)
        if fn == "GetStatus":
            return h.call(fn, 0, byref(c_int()))
        if fn == "GetRealStatus":
            return h.call(fn, 2, byref(c_double()))
        if fn == "GetIntegerStatus":
            return h.call(fn, 0, byref(c_int()))
        if fn == "GetBooleanStatus":
            return h.call(fn, 3, byref(c_int()))
        if fn == "GetStringStatus":
            return h.call(fn, 1, byref(c_char_p()))
        raise AssertionError(fn)


def _states(name):
    return STATES if name == "Oscillator" else [s for s in STATES if s != E]


def _baseline(d, state):
    d.goto(state)
    return d.probe()


def _errors(h):
    return [m for m in h.messages if m[0] >= ERROR]


@pytest.mark.parametrize("fn", list(ALLOWED))
@pytest.mark.parametrize("name", ALL)
def test_every_function_in_every_state(name, fn):
    d = Driver(name)
    problems = []
    for state in _states(name):
        base = _baseline(d, state)
        h = d.goto(state)
        status = d.call_valid(fn)
        allowed = state in ALLOWED[fn]
        if fn in UNPROVIDED:
            want = ERROR
        elif not allowed:
            want = ERROR
        elif fn in DISCARDED:
            want = DISCARD
        else:
            want = OK
        if status != want:
            problems.append(f"{state}: status {status}, expected {want}; log {h.messages[-3:]}")
            continue
        if status == ERROR:
            errs = _errors(h)
            if not errs or f"fmi2{fn}" not in errs[-1][2]:
                problems.append(f"{state}: fmi2Error without a message naming fmi2{fn}: {h.messages}")
                continue
            if not allowed and fn not in UNPROVIDED and "illegal call sequence" not in errs[-1][2]:
                problems.append(f"{state}: message does not say 'illegal call sequence': {errs[-1][2]}")
            # a rejected call changes nothing
            after = d.probe()
            if repr(after) != repr(base):
                problems.append(f"{state}: rejected call changed the state: probe {after} != {base}")
        if status == DISCARD and not [m for m in h.messages if m[0] == DISCARD]:
            problems.append(f"{state}: fmi2Discard without a logged reason")
        d.goto(state)
        d.call_valid(fn)
        d.still_usable()
    assert not problems, "\n".join(problems)


def test_free_instance_in_every_state():
    for name in ALL:
        d = Driver(name)
        for state in _states(name):
            h = d.goto(state)
            st = c_void_p()
            assert h.call("GetFMUstate", byref(st)) == OK  # owned states are freed with it
            h.free()
    h = Driver("Oscillator").goto(C)
    assert h.instantiate()  # a second instance in the same process is unaffected
    assert h.initialize() == OK and h.do_step(0.0, H) == OK
    h.free()


# ---------------------------------------------------------------------------------------------
# Bad arguments in every state where the function is allowed.


def _bad_cases(d):
    """(function, label, call, expected message fragment); each must give fmi2Error."""
    h = d.h
    v1 = lambda x: (c_uint * 1)(x)  # noqa: E731
    d1 = lambda x: (c_double * 1)(x)  # noqa: E731
    unknown = len(h.md.modelVariables) + 7
    inp, out, flag, par = d.vr(d.inp), d.vr(d.out), d.vr(d.flag), d.vr(d.par)
    other = _OTHER_BYTES[d.name]
    cases = [
        ("GetReal", "NULL vr", lambda: h.call("GetReal", None, 1, (c_double * 1)()), "NULL"),
        ("GetReal", "NULL value", lambda: h.call("GetReal", v1(out), 1, None), "NULL"),
        ("GetReal", "unknown vr", lambda: h.get_real([unknown])[0], f"unknown value reference {unknown}"),
        ("GetReal", "Boolean read as Real", lambda: h.get_real([flag])[0], "Boolean"),
        ("GetBoolean", "Real read as Boolean", lambda: h.call("GetBoolean", v1(out), 1, (c_int * 1)()), "Real"),
        ("GetInteger", "Real read as Integer", lambda: h.call("GetInteger", v1(out), 1, (c_int * 1)()), "Real"),
        ("GetString", "unknown String", lambda: h.call("GetString", v1(out), 1, (c_char_p * 1)()), "String"),
        ("SetReal", "NULL vr", lambda: h.call("SetReal", None, 1, d1(0.0)), "NULL"),
        ("SetReal", "NULL value", lambda: h.call("SetReal", v1(inp), 1, None), "NULL"),
        ("SetReal", "unknown vr", lambda: h.set_real([unknown], [0.0]), f"unknown value reference {unknown}"),
        ("SetReal", "NaN", lambda: h.set_real([inp], [float("nan")]), "not finite"),
        ("SetReal", "+inf", lambda: h.set_real([inp], [float("inf")]), "not finite"),
        ("SetReal", "-inf", lambda: h.set_real([inp], [-float("inf")]), "not finite"),
        ("SetReal", "parameter NaN", lambda: h.set_real([par], [float("nan")]),
         "not finite|fixed parameter"),
        ("SetReal", "output", lambda: h.set_real([out], [1.0]), "output"),
        ("SetReal", "Boolean as Real", lambda: h.set_real([flag], [1.0]), "Boolean"),
        ("SetReal", "atomic: good then bad", lambda: h.set_real([inp, unknown], [0.3, 0.0]), "unknown"),
        ("SetBoolean", "Real as Boolean", lambda: h.call("SetBoolean", v1(inp), 1, (c_int * 1)(1)), "Real"),
        ("SetInteger", "unknown vr", lambda: h.call("SetInteger", v1(unknown), 1, (c_int * 1)(1)), "unknown"),
        ("SetString", "not a String", lambda: h.call("SetString", v1(inp), 1, (c_char_p * 1)(b"x")), "String"),
        ("SetDebugLogging", "unknown category", lambda: h.call("SetDebugLogging", 1, 1, (c_char_p * 1)(b"nope")), "nope"),
        ("SetDebugLogging", "NULL categories", lambda: h.call("SetDebugLogging", 1, 2, None), "NULL"),
        ("SetDebugLogging", "NULL category", lambda: h.call("SetDebugLogging", 1, 1, (c_char_p * 1)(None)), "NULL"),
        ("GetFMUstate", "NULL", lambda: h.call("GetFMUstate", None), "NULL"),
        ("GetFMUstate", "foreign *state", lambda: h.call("GetFMUstate", byref(c_void_p(0x1234))), "not a state"),
        ("SetFMUstate", "NULL", lambda: h.call("SetFMUstate", None), "NULL"),
        ("SetFMUstate", "foreign", lambda: h.call("SetFMUstate", c_void_p(0x1234)), "not a state"),
        ("FreeFMUstate", "NULL", lambda: h.call("FreeFMUstate", None), "NULL"),
        ("FreeFMUstate", "foreign", lambda: h.call("FreeFMUstate", byref(c_void_p(0x1234))), "not a state"),
        ("SerializedFMUstateSize", "NULL size", lambda: h.call("SerializedFMUstateSize", d.saved, None), "NULL"),
        ("SerializedFMUstateSize", "NULL state", lambda: h.call("SerializedFMUstateSize", None, byref(c_size_t())), "NULL"),
        ("SerializeFMUstate", "short buffer",
         lambda: h.call("SerializeFMUstate", d.saved, (c_char * 8)(), 8), "smaller"),
        ("SerializeFMUstate", "NULL buffer", lambda: h.call("SerializeFMUstate", d.saved, None, 100), "NULL"),
        ("DeSerializeFMUstate", "garbage", lambda: h.deserialize(b"\0" * 64)[0], "bad header"),
        ("DeSerializeFMUstate", "truncated", lambda: h.deserialize(d.saved_bytes[:-9])[0], "damaged"),
        ("DeSerializeFMUstate", "another model's state",
         lambda: h.deserialize(other)[0], "GUID"),
        ("DeSerializeFMUstate", "NULL bytes", lambda: h.call("DeSerializeFMUstate", None, 10, byref(c_void_p())), "NULL"),
        ("DeSerializeFMUstate", "NULL state", lambda: h.call("DeSerializeFMUstate", (c_char * 4)(), 4, None), "NULL"),
        ("GetRealStatus", "NULL value", lambda: h.call("GetRealStatus", 2, None), "NULL"),
        ("GetBooleanStatus", "NULL value", lambda: h.call("GetBooleanStatus", 3, None), "NULL"),
        ("SetupExperiment", "NaN start", lambda: h.call("SetupExperiment", 0, 0.0, float("nan"), 0, 0.0), "not finite"),
        ("SetupExperiment", "stop before start", lambda: h.call("SetupExperiment", 0, 0.0, 1.0, 1, 0.5), "before"),
    ]
    for label, hh in [("zero", 0.0), ("negative", -H), ("NaN", float("nan")), ("+inf", float("inf")),
                      ("-inf", -float("inf")), ("denormal negative", -5e-324)]:
        cases.append(("DoStep", f"{label} step", lambda hh=hh: h.do_step(d.time, hh), "communicationStepSize"))
    for label, t in [("ahead", 0.5), ("behind", -H), ("NaN", float("nan")), ("inf", float("inf"))]:
        cases.append(("DoStep", f"communication point {label}",
                      lambda t=t: h.do_step(d.time + t if label in ("ahead", "behind") else t, H), "not the current time"))
    return cases


_OTHER_BYTES = {}


@pytest.mark.parametrize("name", ALL)
def test_bad_arguments_in_every_state(name):
    other = Driver(OTHER[name])
    other.goto(I)
    _OTHER_BYTES[name] = other.saved_bytes
    other.h.free()
    d = Driver(name)
    problems = []
    checked = 0
    for state in _states(name):
        base = _baseline(d, state)
        for fn, label, call, fragment in _bad_cases(d):
            if state not in ALLOWED[fn]:
                continue
            h = d.goto(state)
            status = call()
            checked += 1
            errs = _errors(h)
            if status != ERROR:
                problems.append(f"{state} {fn} {label}: status {status}")
            elif (not errs or f"fmi2{fn}" not in errs[-1][2]
                  or not any(f in errs[-1][2] for f in fragment.split("|"))):
                problems.append(f"{state} {fn} {label}: message {errs[-1][2] if errs else None!r} "
                                f"lacks {fragment!r}")
            else:
                after = d.probe()
                if repr(after) != repr(base):
                    problems.append(f"{state} {fn} {label}: state changed: {after} != {base}")
    assert checked > 100
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("name", ALL)
def test_fixed_parameter_after_initialization(name):
    d = Driver(name)
    for state, want in [(I, OK), (N, OK), (C, ERROR), (T, ERROR)]:
        h = d.goto(state)
        start = h.var[d.par].start
        assert h.set_real([d.par], [float(start)]) == want, state
        assert h.set_boolean([d.flag], [True]) == want, state
        if want == ERROR:
            msg = h.last_error()
            assert d.flag in msg or state != C
            expected = "fixed parameter" if state == C else "illegal call sequence"
            assert expected in msg, msg
    # the input stays settable after initialization, with a warning outside its range
    h = d.goto(C)
    assert h.set_real([d.inp], [0.02]) == OK
    if name == "HydraulicJoint":
        assert h.set_real(["u_left"], [11.0]) == WARNING
        assert any("outside its range" in m[2] for m in h.messages)


def test_error_state_recovers_through_fmu_state():
    """Oscillator: a failed step puts the instance in the error state; fmi2SetFMUstate to a state
    saved before the failure recovers it (FMI 2.0.4 section 2.1.3, fmi2Error)."""
    h = Harness(fmu_path("Oscillator"))
    assert h.instantiate()
    assert h.initialize(reals={"fail_at": 2.5 * H}) == OK
    assert h.do_step(0.0, H) == OK
    s, st = h.get_state()
    _, good = h.get_real(["x", "v"])
    assert h.do_step(H, H) == OK
    assert h.do_step(2 * H, H) == ERROR
    assert h.do_step(3 * H, H) == ERROR and "illegal call sequence" in h.last_error()
    assert h.get_real(["x", "v"])[0] == OK  # values still readable for debugging
    assert h.call("SetFMUstate", st) == OK
    assert h.get_real(["x", "v"]) == (OK, good)
    assert h.do_step(H, H) == OK
    h.free()


HUGE_STEP = """
import sys, math
sys.path.insert(0, {tests!r})
from fmi_harness import Harness
h = Harness({fmu!r})
assert h.instantiate()
assert h.initialize() == 0
status = h.do_step(0.0, {step!r})
if status == 0:
    s, y = h.get_real([v.name for v in h.md.modelVariables if v.causality == "output" and v.type == "Real"])
    assert s == 0 and all(math.isfinite(x) for x in y), y
else:
    assert status in (2, 3), status
    assert h.last_error() or any(m[0] == 2 for m in h.messages), h.messages
print("status", status, h.last_error())
"""


@pytest.mark.parametrize("step", [1e3, 1e300])
@pytest.mark.parametrize("name", ALL)
def test_huge_step_returns_promptly(name, step):
    """A huge communication step (no stopTime set) must not hang the importer's process: within
    10 s the FMU either completes it with finite outputs or refuses it (fmi2Discard/fmi2Error)
    with a message."""
    code = HUGE_STEP.format(tests=str(REPO / "tests"), fmu=fmu_path(name), step=step)
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=10)
    except subprocess.TimeoutExpired:
        pytest.fail(f"fmi2DoStep(0, {step}) on {name} did not return within 10 s")
    assert r.returncode == 0, r.stderr[-2000:]


def test_step_beyond_stop_time_is_refused():
    for name in ALL:
        h = Harness(fmu_path(name))
        assert h.instantiate()
        assert h.setup(0.0, stop=0.01) == OK
        assert h.call("EnterInitializationMode") == OK and h.call("ExitInitializationMode") == OK
        assert h.do_step(0.0, 1e300) == ERROR
        assert "stopTime" in h.last_error()
        assert h.do_step(0.0, 0.01) == OK
        h.free()


LATE_START = """
import sys
sys.path.insert(0, {tests!r})
from fmi_harness import Harness
h = Harness({fmu!r})
assert h.instantiate()
assert h.initialize(start={start!r}) == 0, h.last_error()
status = h.do_step({start!r}, {step!r})
print("status", status, h.last_error())
assert status == 3, status
assert "does not advance time" in h.last_error(), h.last_error()
"""


@pytest.mark.parametrize("start,step", [(1e300, 1e-3), (1.7e308, 1.7e308)])
@pytest.mark.parametrize("name", ALL)
def test_step_that_cannot_advance_time_is_refused(name, start, step):
    """At a huge start time a small step is lost in rounding (t + h == t) and a huge one
    overflows: fmi2Error with a message, promptly, never fmi2OK without progress (or a hang in a
    sample clock that cannot reach t + h)."""
    code = LATE_START.format(tests=str(REPO / "tests"), fmu=fmu_path(name), start=start, step=step)
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=10)
    except subprocess.TimeoutExpired:
        pytest.fail(f"fmi2DoStep({start}, {step}) on {name} did not return within 10 s")
    assert r.returncode == 0, r.stdout + r.stderr[-2000:]


@pytest.mark.parametrize("name", ALL)
def test_null_logger_and_null_callbacks(name):
    """fmi2Instantiate with callbacks whose logger is NULL: errors are still returned (nothing can
    be logged), nothing crashes; with NULL callbacks the instantiation is refused."""
    from fmpy.fmi2 import fmi2CallbackFunctions

    h = Harness(fmu_path(name))
    f = h.slave._functions["fmi2Instantiate"]
    assert not f(b"x", 1, h.md.guid.encode(), b"file:///tmp", None, 0, 0)
    cb = fmi2CallbackFunctions()  # all NULL
    c = f(b"x", 1, h.md.guid.encode(), b"file:///tmp", byref(cb), 0, 1)
    assert c
    h.component = c
    assert h.do_step(0.0, H) == ERROR
    assert h.set_real([len(h.md.modelVariables) + 3], [0.0]) == ERROR
    assert h.initialize() == OK
    assert h.do_step(0.0, H) == OK
    h.free()


@pytest.mark.parametrize("name", ["HydraulicJoint", "TwistedString"])
def test_every_single_bit_flip_of_a_serialized_state_is_refused(name, capfd):
    """A serialized FMU state carries a format magic, its GUID, its payload length and a checksum:
    200 single-bit flips spread over the whole buffer (magic, GUID, length, payload, checksum) are
    each refused with fmi2Error and a logged reason, nothing is printed (no panic text), and the
    intact bytes still restore the state."""
    import random

    h = Harness(fmu_path(name))
    h.instantiate()
    assert h.initialize() == OK
    assert h.do_step(0.0, 0.01) == OK
    s, state = h.get_state()
    assert s == OK
    data = h.serialize(state)
    bits = random.Random(1234).sample(range(8 * len(data)), 200)
    accepted = []
    for bit in bits:
        b = bytearray(data)
        b[bit // 8] ^= 1 << (bit % 8)
        n_before = len(h.messages)
        s, _ = h.deserialize(bytes(b))
        if s != ERROR or len(h.messages) == n_before:
            accepted.append(bit)
    assert not accepted, f"{len(accepted)} of 200 flips accepted (bits {accepted[:10]})"
    s, restored = h.deserialize(data)
    assert s == OK and h.call("SetFMUstate", restored) == OK
    out = capfd.readouterr()
    assert "panicked" not in out.err + out.out
    h.free()
