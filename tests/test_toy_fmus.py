"""FMUs not made by our crates: the toy FMUs of tests/fixtures/toy-fmus/ (plain C models behind
their own FMI 2.0 frame, built with gcc by the session fixture `toy`), FMI 2.0 Co-Simulation for
linux64.

- `validate` reports no finding on any of them (what the standard permits them to do differently,
  such as accepting NaN, comes as notes and exit 0), and every finding or note cites its clause.
- `simulate` agrees with `fmpy.simulate_fmu` (an independent importer) on the same inputs and
  communication grid: Reals within 1e-6 relative, discrete values exactly; discrete inputs are
  held between rows, continuous Reals interpolated. Its results also match each model's
  independent solution: closed forms (Dahlquist's exponential, the bouncing ball's parabolas, the
  stair's count, the resource file's first byte) and SciPy for Van der Pol.
- String variables are set from the CSV and recorded as quoted text; an FMU that ends the run
  (Stair: fmi2Discard with fmi2Terminated) stops cleanly with its rows up to the last successful
  time.
"""
import csv
import json
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from conftest import REPO, cli_path

fmpy = pytest.importorskip("fmpy")

MODELS = ["BouncingBall", "Dahlquist", "VanDerPol", "Feedthrough", "Resource", "Stair"]


def run(*args):
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True, timeout=300)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


linux_only = pytest.mark.skipif(sys.platform != "linux", reason="the fixtures are built for linux64")


@linux_only
@pytest.mark.parametrize("model", MODELS)
def test_validate_finds_nothing_in_a_conforming_toy_fmu(model, toy):
    r = run("validate", "--json", toy(model))
    assert r.returncode == 0, r.stdout + r.stderr
    report = json.loads(r.stdout)[0]
    assert report["findings"] == [], report["findings"]
    for note in report["notes"]:
        assert note["severity"] == "note" and "FMI 2.0.4 §" in note["clause"], note


@linux_only
def test_probe_results_the_standard_permits_are_notes_with_their_clause(toy):
    # BouncingBall accepts NaN for a parameter and a fixed parameter set after initialization;
    # the standard does not require an FMU to refuse either.
    r = run("validate", "--json", toy("BouncingBall"))
    notes = json.loads(r.stdout)[0]["notes"]
    assert {n["check"] for n in notes} == {"probe-nan", "probe-wrong-call"}, notes
    assert any("§4.2.4" in n["clause"] for n in notes), notes
    r = run("validate", toy("BouncingBall"))
    assert r.returncode == 0 and "OK (no findings, 2 note(s))" in r.stdout, r.stdout


@linux_only
def test_a_model_exchange_library_linking_a_library_this_host_lacks_is_a_note(tmp_path):
    """An FMI 2.0 Model Exchange FMU whose library links libnotthere.so (built for the link,
    then deleted): "Shared libraries should be statically linked against their dependencies"
    (FMI 2.0.4 section 2.3) is a "should", so the FMU is not defective; this host lacks the
    library and does not probe it: a note, exit 0."""
    import toy_fmus
    (tmp_path / "notthere.c").write_text("int notthere_answer(void) { return 42; }\n")
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(tmp_path / "libnotthere.so"),
                    str(tmp_path / "notthere.c")], check=True)
    lib = tmp_path / "Dahlquist.so"
    subprocess.run(["gcc", "-std=c99", "-shared", "-fPIC", "-o", str(lib),
                    str(toy_fmus.SOURCE / "dahlquist.c"), "-lm", "-Wl,--no-as-needed",
                    f"-L{tmp_path}", "-lnotthere"], check=True)
    (tmp_path / "libnotthere.so").unlink()
    md = (toy_fmus.SOURCE / "Dahlquist.fmi2.xml").read_text()
    start = md.index("<CoSimulation")
    md = md[:start] + md[md.index("/>", start) + 2:]  # Model Exchange only
    fmu = tmp_path / "Dahlquist.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", md)
        z.write(lib, "binaries/linux64/Dahlquist.so")
    r = run("validate", "--json", fmu)
    report = json.loads(r.stdout)[0]
    assert r.returncode == 0 and report["findings"] == [], r.stdout + r.stderr
    [note] = [n for n in report["notes"] if n["check"] == "binary-not-probed"]
    assert "lacks libnotthere.so" in note["message"], note


def feedthrough_inputs(t):
    """Inputs of every type, changing on rows that lie on the communication grid."""
    k = np.rint(t * 10).astype(int)
    return {
        "Float64_continuous_input": np.sin(3 * t),
        "Float64_discrete_input": np.cos(2 * t),
        "Int32_input": (k * 7) % 5 - 2,
        "Boolean_input": (k % 3 == 0),
        "Enumeration_input": 1 + k % 2,
    }


def write_inputs(path, t, inputs, text=None):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        names = list(inputs) + list(text or {})
        w.writerow(["time", *names])
        for i, ti in enumerate(t):
            row = [repr(float(ti))]
            row += [repr(float(inputs[n][i])) if inputs[n].dtype.kind == "f" else str(int(inputs[n][i]))
                    for n in inputs]
            row += [text[n][i] for n in (text or {})]
            w.writerow(row)


def fmpy_signals(t, inputs):
    dtype = [("time", float)] + [(n, v.dtype) for n, v in inputs.items()]
    sig = np.zeros(len(t), dtype=dtype)
    sig["time"] = t
    for n, v in inputs.items():
        sig[n] = v
    return sig


def bouncing_ball(t, h0=1.0, g=9.81, e=0.7, v_min=0.1):
    """h and v of the ball dropped from h0 at the times t: parabolas between bounces, v -> -e v
    at each, at rest once a bounce leaves less than v_min."""
    hits, v_up = [np.sqrt(2 * h0 / g)], np.sqrt(2 * g * h0) * e
    while v_up >= v_min:
        hits.append(hits[-1] + 2 * v_up / g)
        v_up *= e
    h, v = np.zeros(len(t)), np.zeros(len(t))
    for i, ti in enumerate(t):
        if ti < hits[0]:
            h[i], v[i] = h0 - g * ti ** 2 / 2, -g * ti
            continue
        k = np.searchsorted(hits, ti, side="right") - 1
        if k == len(hits) - 1:
            continue  # at rest on the floor
        s, up = ti - hits[k], np.sqrt(2 * g * h0) * e ** (k + 1)
        h[i], v[i] = up * s - g * s ** 2 / 2, up - g * s
    return {"h": h, "v": v}


def van_der_pol(t, mu=1.0):
    from scipy.integrate import solve_ivp
    sol = solve_ivp(lambda s, x: [x[1], mu * (1 - x[0] ** 2) * x[1] - x[0]], (t[0], t[-1]),
                    [2.0, 0.0], method="DOP853", t_eval=t, rtol=1e-12, atol=1e-12)
    return {"x0": sol.y[0], "x1": sol.y[1]}


def independent_solution(model, t):
    """Each toy model's outputs at the times t from its equations, not from the FMU: closed
    forms, SciPy (DOP853 at rtol 1e-12) for Van der Pol; None for Feedthrough (its outputs are
    its inputs, checked against FMPy and by the String test)."""
    if model == "Dahlquist":
        return {"x": np.exp(-t)}
    if model == "VanDerPol":
        return van_der_pol(t)
    if model == "BouncingBall":
        return bouncing_ball(t)
    if model == "Stair":  # one more every whole second from 1
        return {"counter": 1 + np.floor(t + 1e-9)}
    if model == "Resource":  # the first byte of resources/y.txt
        first = (REPO / "tests" / "fixtures" / "toy-fmus" / "y.txt").read_bytes()[0]
        return {"y": np.full(len(t), float(first))}
    return None


@linux_only
@pytest.mark.parametrize("model", MODELS)
def test_simulate_agrees_with_fmpy_and_the_models_solution(model, toy, tmp_path):
    fmu = toy(model)
    md = fmpy.read_model_description(str(fmu))
    de = md.defaultExperiment
    stop = float(de.stopTime)
    step = float(de.stepSize) if de.stepSize else 0.01
    args = ["simulate", fmu, "--stop", stop, "--step", step, "--out", tmp_path / "out.csv"]
    kw = dict(fmi_type="CoSimulation", start_time=0.0, stop_time=stop, output_interval=step)
    if model == "Feedthrough":
        t = np.round(np.arange(0.0, stop + 1e-9, 0.1), 10)
        inputs = feedthrough_inputs(t)
        write_inputs(tmp_path / "in.csv", t, inputs)
        args[2:2] = ["--data", tmp_path / "in.csv"]
        kw["input"] = fmpy_signals(t, inputs)
    r = run(*args)
    assert r.returncode == 0, r.stderr
    ref = fmpy.simulate_fmu(str(fmu), **kw)
    header, rows = read_csv(tmp_path / "out.csv")
    ours = {name: [row[j] for row in rows] for j, name in enumerate(header)}
    assert len(rows) == len(ref), (len(rows), len(ref))
    np.testing.assert_allclose([float(x) for x in ours["time"]], ref["time"], rtol=1e-12, atol=1e-12)
    real = {v.name for v in md.modelVariables if v.type == "Real" and v.variability != "discrete"}
    for name in ref.dtype.names[1:]:
        got = np.array([float(x) for x in ours[name]])
        want = np.asarray(ref[name], dtype=float)
        if name in real:
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12 * max(1.0, np.abs(want).max()),
                                       err_msg=name)
        else:
            assert np.array_equal(got, want), (name, got[:12], want[:12])
    # Co-Simulation: Dahlquist and the ball step with their closed forms, Van der Pol with
    # 1 ms Runge-Kutta steps (error some 1e-10 over 20 s)
    solution = independent_solution(model, np.array([float(x) for x in ours["time"]]))
    for name, want in (solution or {}).items():
        got = np.array([float(x) for x in ours[name]])
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-8 * max(1.0, np.abs(want).max()),
                                   err_msg=name)


@linux_only
def test_string_variables_are_set_from_the_csv_and_recorded_as_quoted_text(toy, tmp_path):
    t = np.round(np.arange(0.0, 0.5 + 1e-9, 0.1), 10)
    inputs = {"Int32_input": np.arange(len(t))}
    words = ['plain', 'with, comma', 'say "hi"', ' padded ', '', 'ünïcode']
    write_inputs(tmp_path / "in.csv", t, inputs, text={"String_input": words})
    r = run("simulate", toy("Feedthrough"), "--data", tmp_path / "in.csv", "--step", 0.1,
            "--out", tmp_path / "out.csv")
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "out.csv")
    j = header.index("String_output")
    # Inputs are set before initialization, so row 0 shows the first word; in Co-Simulation the
    # output after a step holds the input set before it: row k shows the word of row k-1.
    got = [row[j] for row in rows]
    assert got[0] == words[0] and got[1:] == words[:-1], got
    # the text survives a round trip through a CSV reader (quoted where RFC 4180 requires)
    raw = (tmp_path / "out.csv").read_text()
    assert '"with, comma"' in raw and '"say ""hi"""' in raw, raw


@linux_only
def test_an_fmu_that_ends_the_run_stops_cleanly_at_its_last_successful_time(toy, tmp_path):
    out = tmp_path / "stair.csv"
    r = run("simulate", toy("Stair"), "--out", out)
    assert r.returncode == 0, r.stderr
    assert "ended the simulation at t = 9" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "counter"]
    assert float(rows[-1][0]) == 9.0 and rows[-1][1] == "10", rows[-3:]
    assert all(float(a[0]) < float(b[0]) for a, b in zip(rows, rows[1:]))


GAIN_SLAVE = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real


class Gain(Fmi2Slave):
    description = "y = k * u"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 2.0
        self.u = 0.0
        self.y = 0.0
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability="fixed"))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        self.y = self.k * self.u
        return True
'''


@pytest.fixture(scope="module")
def python_fmu(tmp_path_factory):
    """An FMU made by PythonFMU: its binary calls the CPython API without linking libpython."""
    pytest.importorskip("pythonfmu")
    d = tmp_path_factory.mktemp("pythonfmu")
    (d / "Gain.py").write_text(GAIN_SLAVE)
    subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", str(d / "Gain.py"), "-d", str(d)],
                   check=True, capture_output=True)
    return d / "Gain.fmu"


@pytest.mark.skipif(sys.platform != "linux", reason="linux64 binaries only")
def test_a_pythonfmu_fmu_runs_with_the_python_runtime_loaded_first(python_fmu, tmp_path):
    (tmp_path / "in.csv").write_text("time,u\n0,1\n0.1,2\n0.2,3\n")
    r = run("simulate", python_fmu, "--data", tmp_path / "in.csv", "--out", tmp_path / "o.csv",
            "--python", sys.executable)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "o.csv")
    assert header == ["time", "y"]
    # y after a step is k times the input set before it (k = 2)
    assert [float(row[1]) for row in rows] == [0.0, 2.0, 4.0], rows


def test_a_pythonfmu_fmu_without_a_python_runtime_gets_one_line_saying_what_it_needs(python_fmu, tmp_path):
    (tmp_path / "in.csv").write_text("time,u\n0,1\n0.1,2\n")
    r = run("simulate", python_fmu, "--data", tmp_path / "in.csv", "--out", tmp_path / "o.csv",
            "--python", tmp_path / "no-such-python")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs a Python runtime" in lines[0] and "--python" in lines[0], lines


@linux_only
def test_gap_runs_on_a_foreign_fmu_with_string_variables(toy, tmp_path):
    """Feedthrough's outputs include a String and an Enumeration: gap compares the numeric
    columns of the data and ignores the rest. The data are the FMU's own response (the output
    after a step is the input set before it), so nothing is missing."""
    t = np.round(np.arange(0.0, 2.0 + 1e-9, 0.01), 10)
    u = np.sin(3 * t)
    y = np.concatenate([[0.0], u[:-1]])
    with open(tmp_path / "d.csv", "w") as f:
        f.write("time,Float64_continuous_input,Float64_continuous_output\n")
        for row in zip(t, u, y):
            f.write(",".join(repr(float(x)) for x in row) + "\n")
    r = run("gap", toy("Feedthrough"), "--data", tmp_path / "d.csv", "--out", tmp_path / "g",
            "--fit", "Float64_tunable_parameter", "--quiet")
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "g" / "report.json").read_text())
    assert report["named"] == []
    assert report["outputs"]["Float64_continuous_output"]["rmse_after"] < 1e-9
