"""The FMU Compliance Checker (`fmuCheck`, FMI 2.0) on dist/HydraulicJoint.fmu and
dist/TwistedString.fmu, Co-Simulation and Model Exchange: no error and no warning in its summary,
none of our FMUs' messages above info level, and (Co-Simulation) the outputs it records agree with
FMPy's run of the same archive with the same input steps and communication step.

The checker is not in any package registry this project's machines reach (Debian, PyPI, npm,
crates.io; it is built from source against the FMI Library), so it cannot be installed by
scripts/lib.sh: these tests run where `fmuCheck` (or `fmuCheck.linux64`, or the path in
$FMUCHECK) is on the machine and are skipped, saying so, where it is not. The log format parsed
here is that of modelica-tools/FMUComplianceChecker (commit c704b98, built against FMI Library
2.0.3, the version its CMakeLists.txt fetches).
"""
import csv
import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import fmu_path


def checker():
    path = os.environ.get("FMUCHECK")
    if path and os.access(path, os.X_OK):
        return path
    for name in ("fmuCheck.linux64", "fmuCheck"):
        found = shutil.which(name)
        if found:
            return found
    return None


pytestmark = pytest.mark.skipif(
    checker() is None,
    reason="fmuCheck (FMU Compliance Checker) is not installed here and no package registry "
           "this project reaches provides it; set FMUCHECK to its path to run these tests")

# Stop time and step per interface: fmuCheck's Model Exchange run is forward Euler with a fixed
# step ("-h ... For ME simulation: Decides step size to use in forward Euler", its usage text), so
# it gets a step inside the stability region of the stiff plants (hydraulic capacitances, motor
# inductance: with the input steps below, forward Euler over 0.5 s diverged at a step of 1e-4 s
# for HydraulicJoint and 1e-3 s for TwistedString) and a short horizon; Co-Simulation steps the FMU's own solver.
RUNS = {"cs": (0.5, 1e-3), "me": (0.05, 5e-6)}

# Inputs (fmuCheck's -i file and FMPy's input: names, then rows of time and values; a repeated
# time is a step): a set-point step at 0.01 s and a load step at 0.03 s, inside both horizons, so
# the controllers, their time events and the plants' dynamics run, not only the initial
# equilibrium.
INPUTS = {
    "HydraulicJoint": (("theta_ref", "tau_ext", "u_left", "u_right"),
                       [(0.0, 0.0, 0.0, 0.0, 0.0), (0.01, 0.0, 0.0, 0.0, 0.0),
                        (0.01, 0.3, 0.0, 0.0, 0.0), (0.03, 0.3, 0.0, 0.0, 0.0),
                        (0.03, 0.3, 0.5, 0.0, 0.0), (1.0, 0.3, 0.5, 0.0, 0.0)]),
    "TwistedString": (("theta_motor_ref", "F_load", "voltage"),
                      [(0.0, 0.0, 0.0, 0.0), (0.01, 0.0, 0.0, 0.0), (0.01, 50.0, 0.0, 0.0),
                       (0.03, 50.0, 0.0, 0.0), (0.03, 50.0, 5.0, 0.0), (1.0, 50.0, 5.0, 0.0)]),
}


def input_signal(model):
    names, rows = INPUTS[model]
    return np.array(rows, dtype=[("time", float)] + [(name, float) for name in names])


def write_inputs(signal, path):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(signal.dtype.names)
        writer.writerows([repr(float(v)) for v in row] for row in signal)
    return path


def run_checker(fmu, kind, inputs, tmp_path):
    stop, step = RUNS[kind]
    out, log = tmp_path / f"{kind}.csv", tmp_path / f"{kind}.log"
    proc = subprocess.run(
        [checker(), "-k", kind, "-s", str(stop), "-h", str(step), "-n", "0", "-l", "4",
         "-i", str(inputs), "-o", str(out), "-e", str(log), "-t", str(tmp_path), fmu],
        capture_output=True, text=True, timeout=240)
    text = log.read_text(errors="replace") + proc.stdout + proc.stderr
    return proc.returncode, text, out


def summary(text):
    """(FMU-reported messages, checker warnings, checker errors) from the summary fmuCheck ends
    its log with:
        FMU check summary:
        FMU reported:
        <TAB>0 warning(s) and error(s)
        Checker reported:
        <TAB>0 Warning(s)
        <TAB>0 Error(s)
    (after a fatal error it adds "<TAB>N Fatal error(s) occurred during processing")."""
    fmu = re.search(r"FMU reported:\s*(\d+) warning\(s\) and error\(s\)", text)
    warnings = re.search(r"Checker reported:\s*(\d+) Warning\(s\)", text)
    errors = re.search(r"Checker reported:\s*\d+ Warning\(s\)\s*(\d+) Error\(s\)", text)
    assert fmu and warnings and errors, text[-2000:]
    return int(fmu.group(1)), int(warnings.group(1)), int(errors.group(1))


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = [n.strip().strip('"') for n in rows[0]]
    data = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=float)
    return {n: data[:, i] for i, n in enumerate(names)}


@pytest.mark.parametrize("kind", sorted(RUNS))
@pytest.mark.parametrize("model", sorted(INPUTS))
def test_compliance_checker_is_clean(model, kind, tmp_path):
    fmu = fmu_path(model)
    signal = input_signal(model)
    code, text, out = run_checker(fmu, kind, write_inputs(signal, tmp_path / "inputs.csv"),
                                  tmp_path)
    assert code == 0, text[-2000:]
    assert "Simulation finished successfully" in text, text[-2000:]
    fmu_messages, warnings, errors = summary(text)
    assert (fmu_messages, warnings, errors) == (0, 0, 0), text[-4000:]
    result = read_csv(out)
    stop, step = RUNS[kind]
    assert result["time"][0] == 0.0 and result["time"][-1] == pytest.approx(stop)
    for name, values in result.items():
        assert np.all(np.isfinite(values)), name
    if kind == "cs":
        # the same archive, inputs, communication step and start values under FMPy; fmuCheck
        # advances time as t += h and FMPy as n * h, so the communication points (and with them
        # the FMU's internal steps) differ in the last bits, which the solver's error control
        # carries to ~1e-9 of a signal's range, not more
        ref = simulate_fmu(fmu, stop_time=stop, output_interval=step, step_size=step,
                           input=signal)
        compared = [name for name in ref.dtype.names[1:] if name in result]
        assert len(compared) >= 15, compared
        for name in compared:
            got = np.interp(ref["time"], result["time"], result[name])
            span = max(np.ptp(ref[name]), 1e-12)
            assert np.max(np.abs(got - ref[name])) <= 1e-8 * span + 1e-12, name
        # the steps moved the plant: the outputs are not the initial equilibrium
        assert sum(np.ptp(ref[name]) > 0 for name in compared) >= 10
