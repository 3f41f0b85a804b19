"""Directional (and adjoint) derivatives in Co-Simulation, FMI 2.0 (dist/<Model>.fmu) and FMI 3.0
(dist/fmi3/<Model>.fmu), through FMPy's low-level API.

At a communication point the unknowns of <ModelStructure> are the outputs and the state
derivatives, their knowns the inputs and the continuous states, in FMI 3.0 also the Float64
parameters (FMI 2.0.4 sections 2.1.9 and 2.2.8; FMI 3.0.2 sections 2.2.11 and 2.4.8; a
parameter's partials are compared with the Model Exchange instance's at the same point, which
tests/test_fmi3_me.py checks against set/get): the partial derivatives of the model equations at the
point the Co-Simulation instance reached with its own solver and controllers. The reference is
independent of the Co-Simulation code path: a Model Exchange instance of the same archive is put at
that point (time, states, inputs, and the controller's sample at that time as its event update
computes it; every state derivative and output agrees with the Co-Simulation instance's before
anything is differentiated) and differentiated by central differences of fmi2GetDerivatives /
fmi3GetContinuousStateDerivatives and the outputs, step 1e-6 of each known's magnitude or nominal.
Every (unknown, known) pair agrees within 1e-6 of the row's largest |J_ij| s_j (s_j the known's
scale), every effect on, closed and open loop, at several operating points of each model.

In Initialization Mode (both interfaces) the unknowns are the initial unknowns and the knowns the
inputs and the variables with initial="exact": checked against central differences through the
importer's own set and get calls.
"""
import xml.etree.ElementTree as ET
import zipfile

import fmpy
import numpy as np
import pytest
from ctypes import POINTER, c_double
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.simulation import apply_start_values

from conftest import fmu3_path, fmu_path

EFFECTS = {
    "HydraulicJoint": ("seal_friction", "valve_overlap", "internal_leakage", "cable_friction",
                       "entrained_air", "valve_dynamics"),
    "TwistedString": ("string_compliance", "twist_hysteresis", "motor_friction", "gear_backlash",
                      "radius_growth"),
}
# Per model and loop: the inputs held over the run and the communication points where the
# Jacobian is taken, while the actuator moves and while it settles. Both models' Co-Simulation
# takes a sample on a communication point at the start of the step from there (HydraulicJoint's
# 25 ms samples lie between the points here, each of TwistedString's 1 ms samples on one).
CASES = {
    ("HydraulicJoint", "closed"): ({"theta_ref": 0.5, "tau_ext": 1.5}, (0.105, 0.305)),
    ("HydraulicJoint", "open"): ({"u_left": 4.0, "u_right": -3.0, "tau_ext": 1.5}, (0.05,)),
    ("TwistedString", "closed"): ({"theta_motor_ref": 900.0, "F_load": 12.0}, (0.05, 0.2)),
    ("TwistedString", "open"): ({"voltage": 5.0, "F_load": 12.0}, (0.1,)),
}
H = 1e-3
RTOL = 1e-6


def ptr(a):
    return a.ctypes.data_as(POINTER(c_double))


class Fmu:
    """One instance (Co-Simulation or Model Exchange) of an FMI 2.0 or 3.0 archive, with the
    calls this test needs under version-neutral names."""

    def __init__(self, version, model, cs):
        self.path = path = fmu_path(model) if version == 2 else fmu3_path(model)
        self.md = fmpy.read_model_description(path)
        self.v3 = version == 3
        kind = (FMU3Slave if cs else FMU3Model) if self.v3 else (FMU2Slave if cs else FMU2Model)
        ident = (self.md.coSimulation if cs else self.md.modelExchange).modelIdentifier
        self.fmu = kind(guid=self.md.guid, unzipDirectory=fmpy.extract(path),
                        modelIdentifier=ident)
        self.fmu.instantiate()
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.nx = len(self.md.derivatives)
        self.states = [d.variable.derivative.valueReference for d in self.md.derivatives]
        self.ders = [d.variable.valueReference for d in self.md.derivatives]
        self.outputs = [o.variable.valueReference for o in self.md.outputs
                        if o.variable.type in ("Real", "Float64")]
        self.inputs = [v.valueReference for v in self.md.modelVariables
                       if v.causality == "input"]

    def initialize(self, start):
        if not self.v3:
            self.fmu.setupExperiment(startTime=0.0)
        apply_start_values(self.fmu, self.md, start)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def get(self, vrs):
        return np.array(self.fmu.getFloat64(vrs) if self.v3 else self.fmu.getReal(vrs))

    def set(self, vrs, values):
        values = [float(v) for v in values]
        return self.fmu.setFloat64(vrs, values) if self.v3 else self.fmu.setReal(vrs, values)

    def directional(self, unknowns, knowns, seed):
        return np.array(self.fmu.getDirectionalDerivative(unknowns, knowns, list(seed)))

    # Model Exchange
    def event(self, enter=True):
        """Event Mode at the current time (the instance is in it after initialization) until
        the discrete states settle, then Continuous-Time Mode."""
        if enter:
            self.fmu.enterEventMode()
        while (self.fmu.updateDiscreteStates() if self.v3 else self.fmu.newDiscreteStates())[0]:
            pass
        self.fmu.enterContinuousTimeMode()

    def set_states(self, x):
        x = np.array(x, dtype=float)
        self.fmu.setContinuousStates(ptr(x), self.nx)

    def derivatives(self):
        dx = np.zeros(self.nx)
        if self.v3:
            self.fmu.getContinuousStateDerivatives(ptr(dx), self.nx)
        else:
            self.fmu.getDerivatives(ptr(dx), self.nx)
        return dx

    def nominals(self):
        n = np.zeros(self.nx)
        self.fmu.getNominalsOfContinuousStates(ptr(n), self.nx)
        return n

    def free(self):
        try:
            self.fmu.terminate()
        except FMICallException:
            pass  # a failed test may leave the instance where terminate is not allowed
        self.fmu.freeInstance()
        self.fmu.freeLibrary()


def place(me, cs, t):
    """Put the Model Exchange instance at the Co-Simulation instance's point: time, inputs,
    states; before any event at that time (the left limit, where Co-Simulation's outputs at a
    communication point are: a sample there comes with the next step)."""
    me.fmu.setTime(t)
    me.set(me.inputs, cs.get(cs.inputs))
    me.set_states(cs.get(cs.states))


def follow(me, cs, t):
    """`place`, then the event at that time, as the Co-Simulation step from t begins: each
    controller sample (and the controller's own state, such as an integral) is computed from the
    states and inputs Co-Simulation has there."""
    place(me, cs, t)
    me.event()


def reference_jacobian(me, x, u, scales):
    """Central differences of the Model Exchange instance's derivatives and outputs with respect
    to the states, then the inputs, at (x, u); step 1e-6 of each known's scale."""
    n = me.nx
    cols = []
    for j, s in enumerate(scales):
        h = 1e-6 * s
        f = []
        for sign in (1.0, -1.0):
            xs, us = np.array(x), np.array(u)
            if j < n:
                xs[j] += sign * h
            else:
                us[j - n] += sign * h
            me.set(me.inputs, us)
            me.set_states(xs)
            f.append(np.concatenate([me.derivatives(), me.get(me.outputs)]))
        cols.append((f[0] - f[1]) / (2.0 * h))
    me.set(me.inputs, u)
    me.set_states(x)
    return np.array(cols).T


def check_against(jac, ref, scales, where, noise=None):
    """|J_ij - ref_ij| s_j within RTOL of the row's largest |ref_ij| s_j; with `noise` (the
    reference's own scatter per entry), a row's scale is at least 10 times its largest
    scattered entry over RTOL: a row that is zero up to the rounding of an iterative
    initialization is then compared at that rounding."""
    scaled = np.abs(ref) * scales
    floor = 0.0 if noise is None else (10.0 / RTOL) * (noise * scales).max(axis=1,
                                                                          keepdims=True)
    err = np.abs(jac - ref) * scales / (np.maximum(scaled.max(axis=1, keepdims=True), floor)
                                        + 1e-300)
    i, j = np.unravel_index(np.argmax(err), err.shape)
    assert err.max() < RTOL, (where, (i, j), err.max(), jac[i, j], ref[i, j])


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("model,loop", sorted(CASES))
def test_co_simulation_directional_derivatives_match_central_differences(version, model, loop):
    reals, times = CASES[(model, loop)]
    start = {**reals, "internal_controller": loop == "closed",
             **{f"{e}.enabled": True for e in EFFECTS[model]}}
    cs, me = Fmu(version, model, cs=True), Fmu(version, model, cs=False)
    try:
        with zipfile.ZipFile(cs.path) as z:
            element = ET.fromstring(z.read("modelDescription.xml")).find("CoSimulation")
        flags = ["providesDirectionalDerivative"] if version == 2 else [
            "providesDirectionalDerivatives", "providesAdjointDerivatives"]
        assert [element.get(f) for f in flags] == ["true"] * len(flags)
        cs.initialize(start)
        me.initialize(start)
        me.event(enter=False)
        unknowns, knowns = cs.ders + cs.outputs, cs.states + cs.inputs
        t = 0.0
        for t_point in times:
            while t < t_point - H / 2:
                follow(me, cs, t)
                cs.fmu.doStep(t, H)
                t += H
            place(me, cs, t)
            x, u = cs.get(cs.states), cs.get(cs.inputs)
            where = (model, loop, t_point)
            np.testing.assert_allclose(me.derivatives(), cs.get(cs.ders), rtol=1e-9,
                                       atol=1e-12, err_msg=str(where))
            np.testing.assert_allclose(me.get(me.outputs), cs.get(cs.outputs), rtol=1e-9,
                                       atol=1e-12, err_msg=str(where))
            scales = np.concatenate([np.maximum(np.abs(x), me.nominals()),
                                     np.maximum(np.abs(u), 1.0)])
            ref = reference_jacobian(me, x, u, scales)
            jac = np.array([cs.directional(unknowns, [k], [1.0]) for k in knowns]).T
            check_against(jac, ref, scales, where)
            assert np.count_nonzero(jac[:cs.nx, :cs.nx]) >= 2 * cs.nx - 1  # not vacuous
            # a seed over every known at once is the same linear combination of the columns
            seed = np.random.default_rng(7).standard_normal(len(knowns))
            combined = cs.directional(unknowns, knowns, seed)
            np.testing.assert_allclose(combined, jac @ seed, rtol=1e-12,
                                       atol=1e-12 * float(np.max(np.abs(jac) @ np.abs(seed))))
            if version == 3:
                w = np.random.default_rng(8).standard_normal(len(unknowns))
                adjoint = cs.fmu.getAdjointDerivative(unknowns, knowns, list(w),
                                                      nSensitivity=len(knowns))
                np.testing.assert_allclose(adjoint, w @ jac, rtol=1e-12,
                                           atol=1e-12 * float(np.max(np.abs(w) @ np.abs(jac))))
                # FMI 3.0.2 section 2.4.8: the Float64 parameters are knowns too; at the
                # communication point their partials are the Model Exchange instance's at the
                # same point (tests/test_fmi3_me.py checks those against set/get)
                params = [v.valueReference for v in cs.md.modelVariables
                          if v.causality == "parameter" and v.type == "Float64"]
                jp = np.array([cs.directional(unknowns, [k], [1.0]) for k in params]).T
                ref_p = np.array([me.directional(unknowns, [k], [1.0]) for k in params]).T
                scales_p = np.array([abs(v) if v != 0 else 1.0 for v in cs.get(params)])
                check_against(jp, ref_p, scales_p, where + ("parameters",))
                assert np.count_nonzero(jp) >= 30, np.count_nonzero(jp)  # not vacuous
            # nothing changed: the next step continues from the same point
            np.testing.assert_array_equal(cs.get(cs.states), x)
    finally:
        cs.free()
        me.free()


# Per model: start values (open loop, every effect on, an input away from zero) and parameters
# with initial="exact" taken as knowns besides the inputs.
INITIAL = {
    "HydraulicJoint": ({"u_left": 4.0, "u_right": -3.0, "tau_ext": 1.5, "theta_ref": 0.2},
                       ["load_mass", "supply_pressure", "spring_pretension"]),
    "TwistedString": ({"voltage": 5.0, "F_load": 12.0, "theta_motor_ref": 100.0},
                      ["load_mass", "motor_resistance", "spring_preload"]),
}


@pytest.mark.parametrize("cs", [True, False], ids=["CoSimulation", "ModelExchange"])
@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("model", sorted(INITIAL))
def test_initialization_mode_directional_derivatives_match_central_differences(model, version,
                                                                               cs):
    """In Initialization Mode the unknowns are the Real <InitialUnknowns>, the knowns the inputs
    and the variables with initial="exact" (FMI 2.0.4 section 2.2.8, FMI 3.0.2 section 2.4.8):
    every column against central differences through the importer's calls (fmi2SetReal /
    fmi3SetFloat64 of the known, fmi2GetReal / fmi3GetFloat64 of the unknowns, which
    re-initialize), and TwistedString's closed form d(der(current))/d(voltage) = 1/L at rest
    (open loop; the load starts in equilibrium, so der(v_load) stays 0 whatever F_load)."""
    reals, parameters = INITIAL[model]
    fmu = Fmu(version, model, cs=cs)
    try:
        if not fmu.v3:
            fmu.fmu.setupExperiment(startTime=0.0)
        apply_start_values(fmu.fmu, fmu.md, {
            **reals, "internal_controller": False,
            **{f"{e}.enabled": True for e in EFFECTS[model]}})
        fmu.fmu.enterInitializationMode()
        unknowns = [u.variable.valueReference for u in fmu.md.initialUnknowns
                    if u.variable.type in ("Real", "Float64")]
        knowns = fmu.inputs + [fmu.vr[p] for p in parameters]
        values = fmu.get(knowns)
        shape = (len(unknowns), len(knowns))
        jac, ref, noise = np.zeros(shape), np.zeros(shape), np.zeros(shape)
        scales = np.where(values == 0.0, 1.0, np.abs(values))

        def central(k, v, h):
            f = []
            for sign in (1.0, -1.0):
                fmu.set([k], [v + sign * h])
                f.append(fmu.get(unknowns))
            fmu.set([k], [v])
            return (f[0] - f[1]) / (2.0 * h)

        for j, (k, v) in enumerate(zip(knowns, values)):
            jac[:, j] = fmu.directional(unknowns, [k], [1.0])
            ref[:, j] = central(k, v, 1e-6 * scales[j])
            # the reference's scatter: its change with a 4 times larger step
            noise[:, j] = np.abs(ref[:, j] - central(k, v, 4e-6 * scales[j]))
        check_against(jac, ref, scales, (model, version, cs), noise)
        assert np.count_nonzero(jac) >= 2 * len(knowns)  # not vacuous
        if model == "TwistedString":
            d = lambda u, k: fmu.directional([fmu.vr[u]], [fmu.vr[k]], [1.0])[0]
            (inductance,) = fmu.get([fmu.vr["motor_inductance"]])
            assert d("der(current)", "voltage") == pytest.approx(1.0 / inductance, rel=1e-6)
        fmu.fmu.exitInitializationMode()
    finally:
        fmu.free()
