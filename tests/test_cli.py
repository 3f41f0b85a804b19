"""End-to-end tests of `target/release/actuator-fmu` (simulate, validate) on the project's FMUs.

References: FMPy 0.3.32 (an independent FMI importer) simulating the same FMU with the same
inputs, communication step and start values; closed-form checks are in the Rust tests
(fmu-src/host/tests, fmu-src/cli/tests). Broken FMUs are made here from the real ones (a
modelDescription.xml with an output removed from ModelStructure) or compiled from
fmu-src/host/tests/fixtures/testfmu.c (a binary that crashes on a wrong call order).
"""
import csv
import json
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import REPO, cli_path, fmu_path

FIXTURES = REPO / "fmu-src" / "host" / "tests" / "fixtures"


def run(*args):
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True, timeout=600)


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    data = np.array([[float(c) for c in r] for r in rows[1:]])
    return {name: data[:, j] for j, name in enumerate(header)}


def write_csv(path, columns):
    names = list(columns)
    n = len(columns[names[0]])
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for k in range(n):
            f.write(",".join(repr(float(columns[c][k])) for c in names) + "\n")


def assert_close_to_fmpy(ours, ref, names, rel=1e-9):
    """Every signal within rel * its range (+1e-12) of FMPy's."""
    assert len(ours["time"]) == len(ref["time"])
    np.testing.assert_allclose(ours["time"], ref["time"], rtol=0, atol=1e-12)
    for n in names:
        span = float(np.ptp(ref[n])) + 1e-12
        err = float(np.max(np.abs(ours[n] - ref[n])))
        assert err <= rel * span + 1e-12, f"{n}: max |ours - FMPy| = {err:g} (range {span:g})"


def all_fmus():
    return [fmu_path("Oscillator"), fmu_path("HydraulicJoint"), fmu_path("TwistedString")]


def test_validate_passes_every_project_fmu():
    r = run("validate", *all_fmus())
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("OK (no findings)") == 3, r.stdout


def test_validate_effects_convention_holds_for_both_actuators():
    """Effect switches off by default, effect parameters with unit and min/max, a
    [calibrate] default set; the test oscillator (no effects, no calibration tags) is caught."""
    r = run("validate", "--effects", fmu_path("HydraulicJoint"), fmu_path("TwistedString"))
    assert r.returncode == 0, r.stdout + r.stderr
    r = run("validate", "--effects", fmu_path("Oscillator"))
    assert r.returncode == 1 and "[effect-convention]" in r.stdout, r.stdout


def test_validate_json_lists_each_fmu():
    r = run("validate", "--json", fmu_path("Oscillator"))
    assert r.returncode == 0, r.stdout + r.stderr
    (report,) = json.loads(r.stdout)
    assert report["fmu"] == fmu_path("Oscillator") and report["findings"] == []
    (binary,) = report["binaries"]
    assert binary["entry"] == "binaries/linux64/Oscillator.so" and binary["format"] == "ELF"


def rewrite_md(src, dst, edit):
    """Copies the FMU `src` to `dst` with modelDescription.xml passed through `edit`."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                new = edit(data.decode())
                assert new != data.decode(), "the edit changed nothing"
                data = new.encode()
            zout.writestr(item, data)


def test_validate_catches_an_output_missing_from_model_structure(tmp_path):
    import re

    src = fmu_path("Oscillator")
    broken = tmp_path / "NoOutput.fmu"

    def drop_last_output(xml):
        outputs = re.search(r"<Outputs>(.*?)</Outputs>", xml, re.S)
        unknowns = re.findall(r"<Unknown [^>]*/>", outputs.group(1))
        return xml.replace(unknowns[-1], "", 1)

    rewrite_md(src, broken, drop_last_output)
    r = run("validate", broken)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "[outputs-listed]" in r.stdout and "is missing from <ModelStructure><Outputs>" in r.stdout, r.stdout


def test_validate_survives_a_binary_that_crashes_on_a_wrong_call_order(tmp_path):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    root = tmp_path / "Crash"
    (root / "binaries" / "linux64").mkdir(parents=True)
    shutil.copy(FIXTURES / "modelDescription.xml", root / "modelDescription.xml")
    subprocess.run([cc, "-shared", "-fPIC", "-DCRASH_ON_WRONG_ORDER", "-o",
                    str(root / "binaries" / "linux64" / "Dummy.so"), str(FIXTURES / "testfmu.c"), "-lm"],
                   check=True)
    fmu = tmp_path / "Crash.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for p in root.rglob("*"):
            if p.is_file():
                z.write(p, p.relative_to(root).as_posix())
    r = run("validate", "--json", fmu)
    # a call the importer must not make (FMI 2.0.4 section 4.2.4) has an undefined outcome: a
    # crash there is a note, exit 0
    assert r.returncode == 0, r.stdout + r.stderr
    [report] = json.loads(r.stdout)
    assert report["findings"] == [], report
    notes = report["notes"]
    # re-run past each crashing case: both wrong-order calls are reported, nothing else
    assert [f["check"] for f in notes] == ["probe-wrong-call", "probe-wrong-call"], notes
    assert [f["location"] for f in notes] == ["probe do-step-before-init", "probe do-step-after-terminate"]
    assert all("SIGSEGV" in f["message"] for f in notes)


def test_closed_stdout_is_not_a_crash(tmp_path):
    """`actuator-fmu ... | head -1` closes stdout early: the summary lines are lost, not the run.
    The pipe's read end is closed before the program starts, so every write fails (EPIPE); the
    exit status stays that of the work and nothing panics."""
    import os
    r, w = os.pipe()
    os.close(r)
    try:
        cases = [
            ([cli_path(), "validate", fmu_path("HydraulicJoint")], 0),
            ([cli_path(), "gap", fmu_path("TwistedString"), "--data",
              str(REPO / "examples" / "twisted_string_string_compliance.csv"),
              "--out", str(tmp_path / "gap"), "--quiet", "--rounds", "0"], 0),
        ]
        for cmd, code in cases:
            p = subprocess.run(cmd, stdout=w, stderr=subprocess.PIPE, text=True, timeout=300)
            assert "panicked" not in p.stderr, p.stderr
            assert p.returncode == code, (cmd, p.returncode, p.stderr)
        assert (tmp_path / "gap" / "report.json").exists()
    finally:
        os.close(w)


def test_validate_usage_errors_exit_2(tmp_path):
    assert run("validate", tmp_path / "missing.fmu").returncode == 2
    assert run("validate").returncode == 2


def oscillator_inputs(tmp_path):
    """A force sampled every 0.05 s (coarser than the 0.01 s step, so interpolation matters)."""
    t = np.round(np.arange(0, 2.0 + 1e-9, 0.05), 10)
    force = 5.0 * np.sin(3.0 * t) + 2.0 * (t > 1.0)
    path = tmp_path / "in.csv"
    write_csv(path, {"time": t, "force": force})
    return path, t, force


def test_simulate_oscillator_agrees_with_fmpy(tmp_path):
    fmu = fmu_path("Oscillator")
    data, t, force = oscillator_inputs(tmp_path)
    out = tmp_path / "out.csv"
    r = run("simulate", fmu, "--data", data, "--step", "0.01", "--set", "stiffness=250",
            "--set", "damping=1.5", "--out", out)
    assert r.returncode == 0, r.stderr
    ours = read_csv(out)
    assert list(ours) == ["time", "x", "v", "energy"]
    signal = np.array(list(zip(t, force)), dtype=[("time", float), ("force", float)])
    ref = simulate_fmu(fmu, stop_time=2.0, output_interval=0.01, input=signal,
                       start_values={"stiffness": 250.0, "damping": 1.5}, output=["x", "v", "energy"])
    assert_close_to_fmpy(ours, ref, ["x", "v", "energy"])
    assert np.ptp(ours["x"]) > 1e-3  # the force visibly moves the mass


def test_simulate_boolean_set_and_missing_input_column(tmp_path):
    fmu = fmu_path("Oscillator")
    # only an output column: the input `force` keeps its start value
    t = np.round(np.arange(0, 1.0 + 1e-9, 0.01), 10)
    data = tmp_path / "measured.csv"
    write_csv(data, {"time": t, "x": np.zeros_like(t)})
    out = tmp_path / "out.csv"
    r = run("simulate", fmu, "--data", data, "--out", out)
    assert r.returncode == 0, r.stderr
    ours = read_csv(out)
    ref = simulate_fmu(fmu, stop_time=1.0, output_interval=0.01, output=["x", "v", "energy"])
    assert_close_to_fmpy(ours, ref, ["x", "v", "energy"])
    r = run("simulate", fmu, "--data", data, "--set", "locked=true", "--out", out)
    assert r.returncode == 0, r.stderr
    locked = read_csv(out)
    ref = simulate_fmu(fmu, stop_time=1.0, output_interval=0.01, start_values={"locked": True},
                       output=["x", "v", "energy"])
    assert_close_to_fmpy(locked, ref, ["x", "v", "energy"])
    assert np.ptp(locked["x"]) < np.ptp(ours["x"])


def test_simulate_hydraulic_joint_with_some_inputs_matches_fmpy(tmp_path):
    """Inputs without a column keep their start value; the step is the CSV's sample
    interval (0.001 s here, written as k * 0.001 so single differences carry rounding noise)."""
    fmu = fmu_path("HydraulicJoint")
    t = np.arange(0, 2001) * 0.001
    theta_ref = np.radians(45.0) * np.clip(t - 0.5, 0.0, 1.0)
    data = tmp_path / "reach.csv"
    write_csv(data, {"time": t, "theta_ref": theta_ref})
    out = tmp_path / "out.csv"
    r = run("simulate", fmu, "--data", data, "--out", out)
    assert r.returncode == 0, r.stderr
    ours = read_csv(out)
    signal = np.array(list(zip(t, theta_ref)), dtype=[("time", float), ("theta_ref", float)])
    ref = simulate_fmu(fmu, stop_time=2.0, output_interval=0.001, input=signal)
    names = [n for n in ref.dtype.names if n != "time"]
    assert set(names) <= set(ours)
    # measured: bit-identical to FMPy (same communication points and interpolation formula)
    assert_close_to_fmpy(ours, ref, names, rel=1e-12)
    assert np.degrees(ours["theta"][-1]) > 10.0  # the joint moved toward the reference


@pytest.mark.parametrize("content,where,what", [
    ("", ":1:", "empty file"),
    ("t,force\n0,1\n", ":1:1:", "no 'time' column"),
    ("time,force\n0,1\n0.1,1\n0.05,2\n", ":4:1:", "time must increase (a time repeated once"),
    ("time,force,nope\n0,1,2\n", ":1:3:", "column 'nope' is not a variable of the FMU"),
    ("time,force\n0,1\n0.1,nan\n", ":3:2:", "NaN in column 'force'"),
    ("time,force\n0,1\n0.1,abc\n", ":3:2:", "non-numeric cell 'abc'"),
    ("time,force\n0,1\n0.1\n", ":3:2:", "row has 1 cells"),
])
def test_simulate_bad_data_exit_2_with_file_line_column(tmp_path, content, where, what):
    data = tmp_path / "bad.csv"
    data.write_text(content)
    r = run("simulate", fmu_path("Oscillator"), "--data", data, "--out", tmp_path / "o.csv")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert f"{data}{where}" in lines[0] and what in lines[0], lines[0]


def test_simulate_bad_fmu_and_bad_set_exit_2(tmp_path):
    data, _, _ = oscillator_inputs(tmp_path)
    junk = tmp_path / "junk.fmu"
    junk.write_text("not a zip")
    r = run("simulate", junk, "--data", data, "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "not a valid FMU" in r.stderr, r.stderr
    r = run("simulate", fmu_path("Oscillator"), "--data", data, "--set", "locked=maybe", "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "expected true or false" in r.stderr, r.stderr
    r = run("simulate", fmu_path("Oscillator"), "--data", data, "--set", "mass=abc", "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "not a number" in r.stderr, r.stderr
