"""Model Exchange in the host: `simulate --interface me` integrates the Reference-FMUs (FMI 2.0,
tests/fixtures/reference-fmus/, all declare <ModelExchange>) with the host's Rosenbrock solver and
agrees with FMPy's ModelExchange run (CVode) on the same output grid: the same rows (the output
points, plus a row before and one after each event at its time, as FMPy's record_events),
Reals within the tolerance, event times within it, discrete values exactly. The reference is
FMPy at relative tolerance 1e-10, so that the comparison measures our error at RTOL, not
CVode's (whose global error at its own 1e-6 is some 20 times the tolerance on VanDerPol).

A crash inside an ME call is reported with the call and the time, as for Co-Simulation.
"""
import csv
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO, cli_path
from test_reference_fmus import feedthrough_inputs, fmpy_signals, write_inputs

fmpy = pytest.importorskip("fmpy")

REF = REPO / "tests" / "fixtures" / "reference-fmus"
MODELS = ["BouncingBall", "Dahlquist", "VanDerPol", "Feedthrough", "Resource", "Stair"]
RTOL = 1e-6

pytestmark = pytest.mark.skipif(sys.platform != "linux",
                                reason="the fixtures hold linux64 binaries only")


def run(*args):
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def event_times(t):
    """Times recorded twice in a row: the events (rows before and after)."""
    t = np.asarray(t, dtype=float)
    return t[1:][np.diff(t) == 0]


@pytest.mark.parametrize("model", MODELS)
def test_model_exchange_agrees_with_fmpy(model, tmp_path):
    fmu = REF / f"{model}.fmu"
    md = fmpy.read_model_description(str(fmu))
    de = md.defaultExperiment
    stop = float(de.stopTime)
    step = float(de.stepSize) if de.stepSize else 0.01
    args = ["simulate", fmu, "--interface", "me", "--tolerance", RTOL, "--stop", stop,
            "--step", step, "--out", tmp_path / "out.csv"]
    kw = dict(fmi_type="ModelExchange", start_time=0.0, stop_time=stop, output_interval=step,
              relative_tolerance=1e-10)
    if model == "Feedthrough":
        t = np.round(np.arange(0.0, stop + 1e-9, 0.1), 10)
        inputs = feedthrough_inputs(t)
        write_inputs(tmp_path / "in.csv", t, inputs)
        args[2:2] = ["--data", tmp_path / "in.csv"]
        kw["input"] = fmpy_signals(t, inputs)
    r = run(*args)
    assert r.returncode == 0, r.stderr
    ref = fmpy.simulate_fmu(str(fmu), **kw)
    text = {v.name for v in md.modelVariables if v.type == "String"}
    header, rows = read_csv(tmp_path / "out.csv")
    ours = {name: [row[j] for row in rows] for j, name in enumerate(header)}
    ours = {name: np.array(col if name in text else [float(x) for x in col])
            for name, col in ours.items()}
    assert len(rows) == len(ref), (len(rows), len(ref))
    # output points exactly; event times (the state events of BouncingBall) within the tolerance
    np.testing.assert_allclose(ours["time"], ref["time"], rtol=RTOL, atol=0)
    assert np.array_equal(event_times(ours["time"]) > 0, event_times(ref["time"]) > 0)
    real = {v.name for v in md.modelVariables if v.type == "Real" and v.variability != "discrete"}
    for name in ref.dtype.names[1:]:
        if name in text:
            assert list(ours[name]) == [x.decode() if isinstance(x, bytes) else x
                                        for x in ref[name]], name
            continue
        want = np.asarray(ref[name], dtype=float)
        if name in real:
            scale = max(1.0, np.abs(want).max())
            np.testing.assert_allclose(ours[name], want, rtol=0, atol=RTOL * scale, err_msg=name)
        else:
            assert np.array_equal(ours[name], want), (name, ours[name][:12], want[:12])


def test_bouncing_ball_bounces_at_the_closed_form_times(tmp_path):
    """h'' = -g from h0 = 1, v0 = 0, v -> -e v at h = 0 (BouncingBall's equations, g = 9.81,
    e = 0.7): the k-th bounce at t1 = sqrt(2 h0 / g), then t_{k+1} = t_k + 2 e^k v1 / g."""
    r = run("simulate", REF / "BouncingBall.fmu", "--interface", "me", "--stop", 2,
            "--step", 0.01, "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    _, rows = read_csv(tmp_path / "o.csv")
    got = event_times([float(row[0]) for row in rows])
    g, e = 9.81, 0.7
    t1 = np.sqrt(2 / g)
    v1 = g * t1
    want = [t1]
    while len(want) < len(got):
        want.append(want[-1] + 2 * e ** len(want) * v1 / g)
    assert len(got) == 4, got
    np.testing.assert_allclose(got, want, rtol=1e-5)


def test_interface_cs_is_the_default_and_me_is_refused_without_model_exchange(tmp_path):
    r = run("simulate", REF / "Dahlquist.fmu", "--stop", 1, "--step", 0.5, "--out",
            tmp_path / "cs.csv")
    assert r.returncode == 0, r.stderr
    r = run("simulate", REF / "Dahlquist.fmu", "--stop", 1, "--step", 0.5, "--interface", "cs",
            "--out", tmp_path / "cs2.csv")
    assert (tmp_path / "cs.csv").read_text() == (tmp_path / "cs2.csv").read_text()
    only_cs = tmp_path / "cs-only.fmu"
    with zipfile.ZipFile(REF / "Dahlquist.fmu") as zin, \
            zipfile.ZipFile(only_cs, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                a = text.index("<ModelExchange")
                b = text.index("</ModelExchange>") + len("</ModelExchange>") \
                    if "</ModelExchange>" in text else text.index("/>", a) + 2
                data = (text[:a] + text[b:]).encode()
            zout.writestr(item, data)
    r = run("simulate", only_cs, "--interface", "me", "--out", tmp_path / "me.csv")
    assert r.returncode == 2 and "no <ModelExchange> element" in r.stderr, r.stderr
    assert not (tmp_path / "me.csv").exists()


def crashing_me_copy(tmp_path):
    """BouncingBall whose fmi2GetDerivatives crashes from t = 0.5 s on (the crash shim of
    tests/drivers/broken, which forwards every other call to the real binary)."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    so = tmp_path / "shim.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", '-DMODEL_ID="BouncingBall"',
                    "-DME_FAIL_AT=0.5", "-o", str(so),
                    str(REPO / "tests/drivers/broken/crash_shim.c"), "-ldl"], check=True)
    binary = "binaries/linux64/BouncingBall.so"
    dst = tmp_path / "crash-me.fmu"
    with zipfile.ZipFile(REF / "BouncingBall.fmu") as zin, \
            zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == binary:
                zout.writestr("binaries/linux64/real_BouncingBall.so", data)
                data = so.read_bytes()
            zout.writestr(item.filename, data)
    return dst


def test_a_crash_in_a_model_exchange_call_is_reported_with_the_call_and_time(tmp_path):
    fmu = crashing_me_copy(tmp_path)
    out = tmp_path / "o.csv"
    r = run("simulate", fmu, "--interface", "me", "--stop", 1, "--step", 0.1, "--out", out)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "crashed (SIGSEGV) in fmi2GetDerivatives at t = 0.5" in lines[0], \
        r.stderr
    assert not out.exists()
    # the same FMU runs as Co-Simulation (the shim crashes only in the ME call)
    r = run("simulate", fmu, "--stop", 1, "--step", 0.1, "--out", out)
    assert r.returncode == 0, r.stderr
