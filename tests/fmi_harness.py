"""Low-level FMI 2.0 driver for tests: FMPy's ctypes bindings, a logger that records every
message, and raw calls that return the status instead of raising."""
import ctypes
from ctypes import byref, c_char, c_double, c_int, c_size_t, c_uint, c_void_p, POINTER

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
