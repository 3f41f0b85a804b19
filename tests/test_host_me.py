"""Model Exchange in the host: `simulate --interface me` integrates the toy FMUs (FMI 2.0 and
3.0, tests/fixtures/toy-fmus/, all declare <ModelExchange>) with the host's Rosenbrock solver and
agrees with FMPy's ModelExchange run (CVode) on the same output grid: the same rows (the output
points, plus a row before and one after each event at its time, as FMPy's record_events),
Reals within the tolerance, event times within it, discrete values exactly. The reference is
FMPy at relative tolerance 1e-10, so that the comparison measures our error at RTOL, not
CVode's (whose global error at its own 1e-6 is some 20 times the tolerance on VanDerPol). The
continuous models are also held to their independent solutions (Dahlquist's exponential,
SciPy's Van der Pol, the bouncing ball's closed-form bounce times, StateSpace integrated by
SciPy).

A crash inside an ME call is reported with the call and the time, as for Co-Simulation.
"""
import csv
import math
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from conftest import REPO, cli_path
from test_toy_fmus import feedthrough_inputs, fmpy_signals, independent_solution, write_inputs

fmpy = pytest.importorskip("fmpy")

MODELS = ["BouncingBall", "Dahlquist", "VanDerPol", "Feedthrough", "Resource", "Stair"]
RTOL = 1e-6

pytestmark = pytest.mark.skipif(sys.platform != "linux",
                                reason="the fixtures are built for linux64")


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
def test_model_exchange_agrees_with_fmpy(model, toy, tmp_path):
    fmu = toy(model)
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
    if model in ("Dahlquist", "VanDerPol"):
        for name, want in independent_solution(model, ours["time"]).items():
            scale = max(1.0, np.abs(want).max())
            np.testing.assert_allclose(ours[name], want, rtol=0, atol=RTOL * scale, err_msg=name)


def test_bouncing_ball_bounces_at_the_closed_form_times(toy, tmp_path):
    """h'' = -g from h0 = 1, v0 = 0, v -> -e v at h = 0 (BouncingBall's equations, g = 9.81,
    e = 0.7): the k-th bounce at t1 = sqrt(2 h0 / g), then t_{k+1} = t_k + 2 e^k v1 / g."""
    r = run("simulate", toy("BouncingBall"), "--interface", "me", "--stop", 2,
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


def test_state_events_of_an_fmu_without_states_are_located(toy, tmp_path):
    """Relay has no continuous state and one event indicator z = cos(2 pi t): z crosses 0 at
    t = 0.25 + 0.5 k, where the relay output y flips (it changes in the event iteration only).
    Nothing is integrated, yet each crossing is an event, as FMPy's CVode run finds them."""
    fmu = toy("Relay")
    r = run("simulate", fmu, "--interface", "me", "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "o.csv")
    ours = {name: np.array([float(row[j]) for row in rows]) for j, name in enumerate(header)}
    want = 0.25 + 0.5 * np.arange(4)  # the crossings in [0, 2]
    np.testing.assert_allclose(event_times(ours["time"]), want, rtol=1e-9)
    assert ours["n"][-1] == 4 and abs(ours["t_event"][-1] - 1.75) < 1e-9, (ours["n"][-1], ours["t_event"][-1])
    # between the events the relay follows the sign of cos(2 pi t)
    regular = np.abs(np.cos(2 * np.pi * ours["time"])) > 1e-6
    np.testing.assert_array_equal(ours["y"][regular], np.sign(np.cos(2 * np.pi * ours["time"][regular])))
    ref = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", relative_tolerance=1e-10)
    assert len(rows) == len(ref), (len(rows), len(ref))
    np.testing.assert_allclose(ours["time"], ref["time"], rtol=1e-9, atol=0)
    for name in ("y", "n"):
        assert np.array_equal(ours[name], np.asarray(ref[name], dtype=float)), name


def test_interface_cs_is_the_default_and_me_is_refused_without_model_exchange(toy, tmp_path):
    r = run("simulate", toy("Dahlquist"), "--stop", 1, "--step", 0.5, "--out",
            tmp_path / "cs.csv")
    assert r.returncode == 0, r.stderr
    r = run("simulate", toy("Dahlquist"), "--stop", 1, "--step", 0.5, "--interface", "cs",
            "--out", tmp_path / "cs2.csv")
    assert (tmp_path / "cs.csv").read_text() == (tmp_path / "cs2.csv").read_text()
    only_cs = without_element(toy("Dahlquist"), tmp_path / "cs-only.fmu", "ModelExchange")
    r = run("simulate", only_cs, "--interface", "me", "--out", tmp_path / "me.csv")
    assert r.returncode == 2 and "no <ModelExchange> element" in r.stderr, r.stderr
    assert not (tmp_path / "me.csv").exists()


def without_element(src, dst, element):
    """A copy of the FMU `src` whose modelDescription.xml lacks the interface `element`."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                a = text.index(f"<{element}")
                close = f"</{element}>"
                b = text.index(close) + len(close) if close in text else text.index("/>", a) + 2
                data = (text[:a] + text[b:]).encode()
            zout.writestr(item, data)
    return dst


@pytest.mark.parametrize("version", [2, 3])
def test_an_fmu_without_co_simulation_runs_as_model_exchange_by_default(version, toy, tmp_path):
    fmu = toy("Dahlquist", version)
    only_me = without_element(fmu, tmp_path / "me-only.fmu", "CoSimulation")
    common = ["--stop", 1, "--step", 0.1, "--tolerance", RTOL]
    r = run("simulate", only_me, *common, "--out", tmp_path / "default.csv")
    assert r.returncode == 0, r.stderr
    r = run("simulate", fmu, *common, "--interface", "me", "--out", tmp_path / "me.csv")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "default.csv").read_text() == (tmp_path / "me.csv").read_text()
    r = run("simulate", only_me, *common, "--interface", "cs", "--out", tmp_path / "cs.csv")
    assert r.returncode == 2 and "<CoSimulation>" in r.stderr, r.stderr


def crashing_me_copy(toy, tmp_path, *defines):
    """BouncingBall whose fmi2GetDerivatives crashes (with -DHANG: hangs) from t = 0.5 s on (the
    crash shim of tests/drivers/broken, which forwards every other call to the real binary)."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    so = tmp_path / "shim.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", '-DMODEL_ID="BouncingBall"',
                    "-DME_FAIL_AT=0.5", *defines, "-o", str(so),
                    str(REPO / "tests/drivers/broken/crash_shim.c"), "-ldl"], check=True)
    binary = "binaries/linux64/BouncingBall.so"
    dst = tmp_path / "crash-me.fmu"
    with zipfile.ZipFile(toy("BouncingBall")) as zin, \
            zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == binary:
                zout.writestr("binaries/linux64/real_BouncingBall.so", data)
                data = so.read_bytes()
            zout.writestr(item.filename, data)
    return dst


def test_a_crash_in_a_model_exchange_call_is_reported_with_the_call_and_time(toy, tmp_path):
    fmu = crashing_me_copy(toy, tmp_path)
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


FMI3_MODELS = ["Dahlquist", "VanDerPol", "Stair", "Resource", "StateSpace"]


def state_space_reference(grid, t, u):
    """StateSpace with its start values A = B = C = D = I, x0 = 0 (asserted from the model
    description by the caller): x' = x + u, y = x + u, u interpolated linearly between rows;
    SciPy DOP853 at rtol 1e-12 row interval by row interval (u is smooth within one)."""
    from scipy.integrate import solve_ivp

    def uf(s):
        return np.array([np.interp(s, t, u[:, i]) for i in range(u.shape[1])])

    ys, x = [], np.zeros(u.shape[1])
    knots = sorted(set(grid) | set(t))
    for a, b in zip(knots, knots[1:]):
        if a in grid:
            ys.append(x + uf(a))
        x = solve_ivp(lambda s, x: x + uf(s), (a, b), x, method="DOP853", rtol=1e-12,
                      atol=1e-12).y[:, -1]
    ys.append(x + uf(knots[-1]))
    return np.array(ys)


@pytest.mark.parametrize("model", FMI3_MODELS)
def test_fmi3_model_exchange_agrees_with_fmpy(model, toy, tmp_path):
    """The same loop through the FMI 3.0 binding (fmi3InstantiateModelExchange,
    fmi3UpdateDiscreteStates, ...): StateSpace with an array input and array states."""
    from test_fmi3_host import state_space_inputs, write_array_input
    fmu = toy(model, 3)
    md = fmpy.read_model_description(str(fmu))
    stop = float(md.defaultExperiment.stopTime)
    step = float(md.defaultExperiment.stepSize or 0.1)
    args = ["simulate", fmu, "--interface", "me", "--tolerance", RTOL, "--stop", stop,
            "--step", step, "--out", tmp_path / "out.csv"]
    kw = dict(fmi_type="ModelExchange", start_time=0.0, stop_time=stop, output_interval=step,
              relative_tolerance=1e-9)
    if model == "StateSpace":
        t = np.round(np.arange(0.0, stop + 1e-9, 0.25), 10)
        u = state_space_inputs(t)
        write_array_input(tmp_path / "in.csv", t, u, per_element=False)
        args[2:2] = ["--data", tmp_path / "in.csv"]
        sig = np.zeros(len(t), dtype=[("time", float), ("u", float, (3,))])
        sig["time"], sig["u"] = t, u
        kw["input"] = sig
    if model == "StateSpace":
        # FMPy's ModelExchange run sets continuous inputs only between its output points (its
        # CVode right-hand side does not apply them), 7 % off at t = 10 s on this growing
        # system: the reference is the closed system integrated by SciPy. x' = x + u amplifies
        # the local errors (e^10), so the host runs at 1e-9 to be within RTOL at the end.
        for name, start in (("A", "1 0 0 0 1 0 0 0 1"), ("B", "1 0 0 0 1 0 0 0 1"),
                            ("C", "1 0 0 0 1 0 0 0 1"), ("D", "1 0 0 0 1 0 0 0 1"),
                            ("x0", "0 0 0")):
            v = next(v for v in md.modelVariables if v.name == name)
            assert " ".join(str(v.start).split()) == start, (name, v.start)
        args[args.index(RTOL)] = 1e-9
        grid = np.round(np.arange(0.0, stop + 1e-9, step), 10)
        ref = np.zeros(len(grid), dtype=[("time", float), ("y", float, (3,))])
        ref["time"], ref["y"] = grid, state_space_reference(list(grid), list(t), u)
    r = run(*args)
    assert r.returncode == 0, r.stderr
    if model != "StateSpace":
        ref = fmpy.simulate_fmu(str(fmu), **kw)
    header, rows = read_csv(tmp_path / "out.csv")
    ours = {name: [row[j] for row in rows] for j, name in enumerate(header)}
    assert len(rows) == len(ref), (len(rows), len(ref))
    np.testing.assert_allclose([float(x) for x in ours["time"]], ref["time"], rtol=RTOL, atol=1e-12)
    floats = {v.name for v in md.modelVariables
              if v.type in ("Float32", "Float64") and v.variability == "continuous"}
    for name in ref.dtype.names[1:]:
        got = np.array([[float(x) for x in cell.split()] for cell in ours[name]])
        want = np.asarray(ref[name], dtype=float).reshape(got.shape)
        if name in floats:
            scale = max(1.0, np.abs(want).max())
            np.testing.assert_allclose(got, want, rtol=0, atol=RTOL * scale, err_msg=name)
        else:
            assert np.array_equal(got, want), (name, got[:12], want[:12])


def test_a_hang_in_a_model_exchange_call_is_stopped_after_the_timeout(toy, tmp_path):
    fmu = crashing_me_copy(toy, tmp_path, "-DHANG")
    out = tmp_path / "o.csv"
    r = run("simulate", fmu, "--interface", "me", "--stop", 1, "--step", 0.1, "--timeout", 1,
            "--out", out)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "did not return from fmi2GetDerivatives at t = 0.5" in lines[0] \
        and "within 1 s" in lines[0], r.stderr
    assert not out.exists()


def test_our_oscillator_agrees_between_its_interfaces(tmp_path):
    """The test oscillator (this project's FMU, fmi2-export's Model Exchange) integrated by the
    host agrees with its own Co-Simulation run: the same model and solver family, so at
    tolerance 1e-10 within 1e-8 of each output's range (measured: 1e-13)."""
    from conftest import fmu_path
    fmu = fmu_path("Oscillator")
    outs = {}
    for interface in ("cs", "me"):
        out = tmp_path / f"{interface}.csv"
        r = run("simulate", fmu, "--interface", interface, "--tolerance", 1e-10, "--stop", 2,
                "--step", 1e-3, "--out", out)
        assert r.returncode == 0, r.stderr
        outs[interface] = np.genfromtxt(out, delimiter=",", names=True)
    cs, me = outs["cs"], outs["me"]
    assert len(cs) == len(me) and np.array_equal(cs["time"], me["time"])
    for name in cs.dtype.names[1:]:
        span = max(np.ptp(cs[name]), 1e-12)
        assert np.abs(me[name] - cs[name]).max() <= 1e-8 * span, name


def test_an_error_status_from_a_model_exchange_call_ends_the_run_naming_the_call(toy, tmp_path):
    fmu = crashing_me_copy(toy, tmp_path, "-DME_ERROR")
    out = tmp_path / "o.csv"
    r = run("simulate", fmu, "--interface", "me", "--stop", 1, "--step", 0.1, "--out", out)
    assert r.returncode == 1, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "fmi2GetDerivatives returned fmi2Error" in lines[0], r.stderr
    assert not out.exists()


def test_gap_calibrates_an_fmi2_model_exchange_fmu(toy, tmp_path):
    """gap through --interface me (FMI 2.0): Dahlquist's k recovered from the closed form
    x = exp(-k t) with k = 1.5 (start 1)."""
    import json
    fmu = toy("Dahlquist")
    t = np.round(np.arange(0, 61) * 0.05, 12)
    with open(tmp_path / "d.csv", "w") as f:
        f.write("time,x\n" + "".join(f"{ti!r},{math.exp(-1.5 * ti)!r}\n" for ti in t.tolist()))
    p = run("gap", fmu, "--interface", "me", "--data", tmp_path / "d.csv", "--out",
            tmp_path / "g", "--fit", "k", "--quiet")
    assert p.returncode == 0, p.stderr
    rep = json.loads((tmp_path / "g" / "report.json").read_text())
    assert rep["named"] == []
    assert abs(rep["parameters"]["k"]["value"] - 1.5) < 1e-4, rep["parameters"]["k"]
