"""Low-level FMI 2.0 driver for tests: FMPy's ctypes bindings, a logger that records every
message, and raw calls that return the status instead of raising."""
import ctypes
from ctypes import byref, c_char, c_double, c_int, c_size_t, c_uint, c_void_p, POINTER

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
)
from fmpy.logging import addLoggerProxy

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4

_libc = ctypes.CDLL(None)
_libc.calloc.restype = c_void_p
_libc.calloc.argtypes = [c_size_t, c_size_t]
_libc.free.argtypes = [c_void_p]


_LOGGERS_KEPT_ALIVE = []


class Harness:
    """One instance of an FMU, with every logged message kept in `messages` as
    (status, category, text)."""

    def __init__(self, fmu_file, unzip_dir=None, instance_name="instance"):
        self.md = read_model_description(fmu_file)
        self.unzip_dir = unzip_dir or extract(fmu_file)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.var = {v.name: v for v in self.md.modelVariables}
        self.messages = []
        self.slave = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.unzip_dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        # FMPy's logger proxy keeps the last logger it was given in a C global, also used by
        # FMPy's default callbacks: it must outlive this Harness, or a later FMU log message
        # (through any FMPy instance) calls freed memory.
        _LOGGERS_KEPT_ALIVE.append(self.callbacks.logger)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(_libc.calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(_libc.free)
        addLoggerProxy(byref(self.callbacks))
        self.component = None

    def _log(self, env, instance_name, status, category, message):
        self.messages.append((status, category.decode(), message.decode()))

    def instantiate(self, logging_on=False, guid=None, fmu_type=1, name=b"instance"):
        f = self.slave._functions["fmi2Instantiate"]
        self.component = f(
            name,
            fmu_type,
            (guid or self.md.guid).encode(),
            b"file:///tmp",
            byref(self.callbacks),
            0,
            1 if logging_on else 0,
        )
        return self.component

    def call(self, name, *args):
        """Call fmi2<name>(component, *args) and return the raw status."""
        return self.slave._functions["fmi2" + name](self.component, *args)

    def last_error(self):
        errors = [m for m in self.messages if m[0] >= ERROR]
        return errors[-1][2] if errors else None

    # Typed conveniences returning (status, values)
    def set_real(self, names_or_vrs, values):
        vrs = [self.vr.get(n, n) if isinstance(n, str) else n for n in names_or_vrs]
        n = len(vrs)
        return self.call("SetReal", (c_uint * n)(*vrs), n, (c_double * n)(*values))

    def get_real(self, names_or_vrs):
        vrs = [self.vr.get(n, n) if isinstance(n, str) else n for n in names_or_vrs]
        n = len(vrs)
        out = (c_double * n)()
        s = self.call("GetReal", (c_uint * n)(*vrs), n, out)
        return s, list(out)

    def set_boolean(self, names, values):
        vrs = [self.vr[n] for n in names]
        n = len(vrs)
        return self.call("SetBoolean", (c_uint * n)(*vrs), n, (c_int * n)(*[int(v) for v in values]))

    def setup(self, start=0.0, stop=None, tolerance=None):
        return self.call("SetupExperiment", 1 if tolerance is not None else 0, tolerance or 0.0,
                         start, 1 if stop is not None else 0, stop or 0.0)

    def initialize(self, reals=None, booleans=None, start=0.0):
        assert self.setup(start) == OK
        assert self.call("EnterInitializationMode") == OK
        if booleans:
            assert self.set_boolean(list(booleans), list(booleans.values())) <= WARNING
        if reals:
            assert self.set_real(list(reals), list(reals.values())) <= WARNING
        return self.call("ExitInitializationMode")

    def do_step(self, t, h):
        return self.call("DoStep", c_double(t), c_double(h), 1)

    def get_state(self):
        state = c_void_p()
        s = self.call("GetFMUstate", byref(state))
        return s, state

    def serialize(self, state):
        size = c_size_t()
        assert self.call("SerializedFMUstateSize", state, byref(size)) == OK
        buf = (c_char * size.value)()
        assert self.call("SerializeFMUstate", state, buf, size) == OK
        return bytes(buf)

    def deserialize(self, data):
        state = c_void_p()
        buf = (c_char * len(data)).from_buffer_copy(data)
        s = self.call("DeSerializeFMUstate", buf, len(data), byref(state))
        return s, state

    def free(self):
        if self.component:
            self.slave._functions["fmi2FreeInstance"](self.component)
            self.component = None


# ---- Model Exchange checks shared by the models' tests (`me`: test_model_exchange.Me) --------
def states_and_derivatives(me):
    """The names of the states and of their derivatives (in the order of <Derivatives>), the
    states' nominals and their values now, once the FMU says it gives directional derivatives."""
    assert me.md.modelExchange.providesDirectionalDerivative
    states = [d.variable.derivative.name for d in me.md.derivatives]
    ders = [d.variable.name for d in me.md.derivatives]
    _, nom = me.array("GetNominalsOfContinuousStates")
    _, x = me.array("GetContinuousStates")
    return states, ders, np.array(nom), x


def jacobian_and_central_differences(me, ders, states, nom, x):
    """At the states `x`: d(der x)/dx column by column from fmi2GetDirectionalDerivative, and a
    central difference of fmi2GetDerivatives with step 1e-6 of the state's magnitude or nominal
    `nom` (the independent reference the analytic Jacobian is held to). The states are restored
    after each column."""
    assert me.set_states(x) == OK
    jac, fd = np.zeros((len(ders), len(states))), np.zeros((len(ders), len(states)))
    for j, name in enumerate(states):
        s, jac[:, j] = me.directional(ders, [name], [1.0])
        assert s == OK, me.last_error()
        h = 1e-6 * max(abs(x[j]), nom[j])
        f = []
        for sign in (1, -1):
            xs = list(x)
            xs[j] += sign * h
            assert me.set_states(xs) == OK
            f.append(np.array(me.array("GetDerivatives")[1]))
        fd[:, j] = (f[0] - f[1]) / (2 * h)
        assert me.set_states(x) == OK
    return jac, fd


def scaled_jacobian_error(jac, fd, nom):
    """|J_ij - FD_ij| nominal_j relative to the row's largest |J_ij| nominal_j (an entry is
    judged against the size of the terms that make up its derivative)."""
    scaled = np.abs(jac) * nom
    return np.abs(jac - fd) * nom / (scaled.max(axis=1, keepdims=True) + 1e-300)


def perturbations_moving_derivatives(me, x, states, inputs, deps, nom):
    """At the states `x`, moves each state (by 1e-3 of its magnitude or nominal) and each input
    (by 0.5) in turn and asserts that only the derivatives listing it in <Derivatives>
    (`deps[k]`, names) change, to the bit; restores each. Returns how many derivatives moved
    (a count the caller checks, so that the check is not vacuous)."""
    moved = 0
    assert me.set_states(x) == OK
    _, base = me.array("GetDerivatives")
    for j, name in enumerate(states + inputs):
        if j < len(states):
            xs = list(x)
            xs[j] += 1e-3 * max(abs(x[j]), nom[j])
            assert me.set_states(xs) == OK
        else:
            _, (old,) = me.get_real([name])
            assert me.set_real([name], [old + 0.5]) == OK
        _, now = me.array("GetDerivatives")
        for k, (a, b) in enumerate(zip(base, now)):
            assert a == b or name in deps[k], (me.md.derivatives[k].variable.name, name)
            moved += a != b
        assert me.set_states(x) == OK
        if j >= len(states):
            assert me.set_real([name], [old]) == OK
    return moved


def event_trace(me, names, k0, n, states_at, time_at):
    """At each sample k of k0 .. k0 + n - 1: the states `states_at(k)` and time `time_at(k)` set,
    an event iteration announcing the next sample at `time_at(k + 1)`, then the outputs `names`
    and the derivatives in Continuous-Time Mode. Returns one row per sample."""
    trace = []
    for k in range(k0, k0 + n):
        assert me.set_states(states_at(k)) == OK
        assert me.call("SetTime", c_double(time_at(k))) == OK
        assert me.call("EnterEventMode") == OK
        s, info = me.new_discrete_states()
        assert s == OK and info.nextEventTime == pytest.approx(time_at(k + 1), rel=1e-12)
        assert me.call("EnterContinuousTimeMode") == OK
        trace.append(me.get_real(names)[1] + me.array("GetDerivatives")[1])
    return trace


def fmu_state_replays(me, run):
    """Runs `run(1, 2)`, saves the FMU state (and a serialized copy), runs `run(3, 3)`, then
    restores the state, and then the deserialized copy, and asserts each time that `run(3, 3)`
    gives the same bits. Returns the first trace of `run(3, 3)`."""
    run(1, 2)
    s, state = me.get_state()
    assert s == OK
    data = me.serialize(state)
    first = run(3, 3)
    assert me.call("SetFMUstate", state) == OK
    assert run(3, 3) == first
    s, restored = me.deserialize(data)
    assert s == OK and me.call("SetFMUstate", restored) == OK
    assert run(3, 3) == first
    return first
