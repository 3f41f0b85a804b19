"""A level effect whose start value lies where it does nothing: the refit must find where in its
range it acts.

The FMU is the test suite's foreign geared DC motor (tests/fixtures/geared-motor, built here with
gcc), with one change to its description: the driver's current limit
(`current_saturation.limit`) ranges over [0, 100] A and starts at 100 A, far above any current
the motor draws under ±20 V steps (a few amperes), so at its start the limit never acts and the
sum of squares does not change with it. The record is simulated with FMPy with the limit at
2 A (the effect on), white noise of 1 % of each output's range, seeded. The truth is known by
construction, not from gap's output.
"""
import json
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from conftest import REPO, cli_path

sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402
import geared_motor as gm  # noqa: E402

LIMIT = 2.0
XML_GIVEN = '<Real start="5" unit="A" min="0.5" max="20"/>'
XML_ABOVE_THE_PEAK = '<Real start="100" unit="A" min="0" max="100"/>'
C_GIVEN = "[VR_IMAX] = {KIND_PARAMETER, 5.0, 0.5, 20.0,"
C_ABOVE_THE_PEAK = "[VR_IMAX] = {KIND_PARAMETER, 100.0, 0.0, 100.0,"


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    """The geared motor whose current limit starts at 100 A in a range [0, 100] A (source and
    description changed alike: the C code checks each value against its range)."""
    d = tmp_path_factory.mktemp("inert-limit")
    src = (gm.SRC / "geared_motor.c").read_text()
    assert src.count(C_GIVEN) == 1
    c = d / "geared_motor.c"
    c.write_text(src.replace(C_GIVEN, C_ABOVE_THE_PEAK))
    lib = d / "geared_motor.so"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Werror", "-shared", "-fPIC", "-O2", "-I", str(gm.SRC), "-o",
                    str(lib), str(c), "-lm"], check=True)
    text = gm.description()
    assert text.count(XML_GIVEN) == 1
    out = d / "GearedMotorHighLimit.fmu"
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", text.replace(XML_GIVEN, XML_ABOVE_THE_PEAK))
        z.write(lib, "binaries/linux64/geared_motor.so")
    return out


def test_a_limit_that_starts_above_the_peak_is_found_and_named(fmu, tmp_path):
    ds = gm.make(fmu, 61, ("current_saturation",), values={"current_saturation.limit": LIMIT})
    # The premise: the limit acts in the record (the current without it peaks well above) and
    # not at its start value.
    free = dict(ds["truth"], **{"current_saturation.enabled": False})
    unlimited = gm.simulate(fmu, ds["time"], ds["inputs"]["voltage"], free)["current"]
    peak = float(np.max(np.abs(unlimited)))
    assert LIMIT < 0.8 * peak < 100.0, peak
    csv = tmp_path / "limit.csv"
    gapgen.write_csv(ds, csv)
    out = tmp_path / "g"
    p = subprocess.run([cli_path(), "gap", str(fmu), "--data", str(csv), "--out", str(out),
                        "--quiet"], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr + p.stdout
    rep = json.loads((out / "report.json").read_text())
    assert rep["named"] == ["current_saturation"], rep["verdict"]
    est = rep["parameters"]["current_saturation.limit"]
    assert est["ci_low"] <= LIMIT <= est["ci_high"], est
