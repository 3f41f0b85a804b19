"""Tunable parameters: what a real rig changes between steps without re-initialising (payload mass,
controller gains and set-point limits; never geometry) is `variability="tunable"`, accepted by
fmi2SetReal in Step mode and effective from the next step. Driven through FMPy's FMU2Slave."""
import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy import calloc, free
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy import extract

from conftest import fmu_path

TUNABLE = {
    "HydraulicJoint": {"load_mass", "controller_gain", "controller_cocontraction"},
    "TwistedString": {"load_mass", "current_limit", "speed_limit", "controller_current_P",
                      "controller_current_Ti", "controller_speed_P", "controller_speed_Ti",
                      "controller_position_P"},
}
# (set-point input and value, tuned parameter and new value, an output that must respond)
CASES = {
    "HydraulicJoint": ("theta_ref", 0.5, "load_mass", 6.0, "theta"),
    "TwistedString": ("theta_motor_ref", 1200.0, "controller_position_P", 2.0, "theta_motor"),
}
H, T_CHANGE, T_END = 1e-3, 0.5, 1.0


@pytest.mark.parametrize("model", sorted(TUNABLE))
def test_the_tunable_parameters_are_the_rig_settings(model):
    md = read_model_description(fmu_path(model))
    tunable = {v.name for v in md.modelVariables if v.variability == "tunable"}
    assert tunable == TUNABLE[model]
    assert all(v.causality == "parameter" for v in md.modelVariables if v.name in tunable)


def run(model, change=None):
    """Outputs at every step to T_END; `change` = (name, value) set in Step mode at T_CHANGE.
    Returns (times, outputs, status of the set call or None)."""
    md = read_model_description(fmu_path(model))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    inp, u, _, _, out = CASES[model]
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu_path(model)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="tune")
    # Own callbacks: FMPy's default ones go through its logger proxy, whose C global may point to
    # a logger of an earlier simulate_fmu call that no longer exists.
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda *args: None)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu.instantiate(callbacks=callbacks)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr[inp]], [u])
    fmu.exitInitializationMode()
    ts, ys, status = [], [], None
    for k in range(int(round(T_END / H))):
        t = k * H
        if change and abs(t - T_CHANGE) < H / 2:
            try:
                fmu.setReal([vr[change[0]]], [change[1]])
                status = "ok"
            except FMICallException as e:
                status = str(e)
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=H)
        ts.append(t + H)
        ys.append(fmu.getReal([vr[out]])[0])
    fmu.terminate()
    fmu.freeInstance()
    return np.array(ts), np.array(ys), status


@pytest.mark.parametrize("model", sorted(CASES))
def test_a_tuned_parameter_acts_from_the_next_step(model):
    _, _, name, value, _ = CASES[model]
    t, base, _ = run(model)
    t, tuned, status = run(model, (name, value))
    assert status == "ok"
    before = t <= T_CHANGE + H / 2
    assert np.array_equal(tuned[before], base[before]), "changed before it was set"
    first_after = np.argmax(~before)
    assert tuned[first_after] != base[first_after], "not effective at the next step"
    assert np.max(np.abs(tuned - base)) > 1e-3 * np.ptp(base), "no visible effect"


@pytest.mark.parametrize("model", sorted(CASES))
def test_an_out_of_range_tuned_value_is_refused_and_changes_nothing(model):
    _, _, name, _, _ = CASES[model]
    md = read_model_description(fmu_path(model))
    (v,) = [v for v in md.modelVariables if v.name == name]
    t, base, _ = run(model)
    t, after, status = run(model, (name, float(v.max) * 10))
    assert status != "ok", "an out-of-range value was accepted"
    assert np.array_equal(after, base)


def test_a_fixed_parameter_is_still_refused_in_step_mode():
    t, base, _ = run("HydraulicJoint")
    t, after, status = run("HydraulicJoint", ("load_radius", 0.4))
    assert status != "ok"
    assert np.array_equal(after, base)
