"""`simulate` with its defaults does what FMPy's `simulate_fmu` does with its defaults on FMUs
built the way third-party exporters build them (our toy FMUs, tests/fixtures/toy-fmus/):

- an FMU without outputs: both record its continuous states (FMPy's `_get_output_variables`);
- an FMU that crashes in fmi2FreeInstance after a complete run: the results are written, a
  warning names the crash, exit status 3 (FMPy is not run: the abort would end its process);
- an FMU that calls the logger with a componentEnvironment it was not given (FMI 2.0.4 section
  2.1.5 requires the one it was given): the run completes, as FMPy's (whose logger ignores it);
- an FMU whose modelIdentifier is not a C identifier (`Dahlquist-c`) but names its library
  inside the FMU: it runs (as in FMPy), and `validate` reports the identifier;
- an FMU that asks for a second call of its event iteration after re-initializing a state and
  reports no change in that call: the ball still bounces (FMI 2.0.4 section 3.2.4, pseudocode:
  the "values changed" flags of all calls are or-ed).

Reference values come from FMPy on the same FMU and from the models' closed forms.
"""
import re
import sys
import zipfile

import numpy as np
import pytest

from conftest import read_csv_floats as read_csv
from conftest import run_cli as run
from test_toy_fmus import bouncing_ball

fmpy = pytest.importorskip("fmpy")

pytestmark = pytest.mark.skipif(sys.platform != "linux",
                                reason="the fixtures are built for linux64")


def without_outputs(src, dst):
    """Copy of the FMU `src` whose outputs are locals (and no <Outputs>/<Output> listed)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                md = data.decode().replace('causality="output"', 'causality="local"')
                md = re.sub(r"<Outputs>.*?</Outputs>|<Output [^>]*/>", "", md, flags=re.S)
                data = md.encode()
            zout.writestr(item, data)
    return dst


@pytest.mark.parametrize("model, version, states", [
    ("BouncingBall", 2, ["h", "v"]),
    ("Dahlquist", 3, ["x"]),
])
def test_an_fmu_without_outputs_records_its_states_as_fmpy_does(model, version, states, toy,
                                                                tmp_path):
    fmu = without_outputs(toy(model, version), tmp_path / f"{model}.fmu")
    r = run("simulate", fmu, "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, ours = read_csv(tmp_path / "o.csv")
    ref = fmpy.simulate_fmu(str(fmu))
    assert header == ["time", *states] == list(ref.dtype.names)
    assert len(ours) == len(ref)
    for j, name in enumerate(header):
        np.testing.assert_allclose(ours[:, j], ref[name], rtol=1e-9, atol=1e-12, err_msg=name)
    t = ours[:, 0]
    want = bouncing_ball(t) if model == "BouncingBall" else {"x": np.exp(-t)}
    for j, name in enumerate(header[1:], 1):
        np.testing.assert_allclose(ours[:, j], want[name], rtol=0, atol=1e-6, err_msg=name)


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_a_crash_in_free_instance_after_the_run_keeps_the_results(interface, toy, tmp_path):
    out = tmp_path / "o.csv"
    r = run("simulate", toy("CrashInFree"), "--interface", interface, "--stop", 2, "--out", out)
    assert r.returncode == 3, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "warning" in lines[0] and "SIGABRT" in lines[0], r.stderr
    assert "fmi2FreeInstance" in lines[0] and "results were written" in lines[0], r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "x"]
    assert rows[0, 0] == 0.0 and rows[-1, 0] == 2.0
    np.testing.assert_allclose(rows[:, 1], np.exp(-rows[:, 0]), rtol=0, atol=1e-4)


@pytest.mark.parametrize("version", [2, 3])
def test_a_logger_call_with_a_foreign_component_environment_does_not_stop_the_run(version, toy,
                                                                                   tmp_path):
    """ForeignLogEnv (Dahlquist, x' = -x from 1) logs at every fmi2DoStep / fmi3DoStep with
    componentEnvironment / instanceEnvironment (void*)1: the logger must not follow that
    pointer."""
    runs_as_fmpy_and_decays(toy("ForeignLogEnv", version), tmp_path)


def runs_as_fmpy_and_decays(fmu, tmp_path):
    """`simulate` on a Dahlquist variant (x' = -x from 1) gives FMPy's rows and exp(-t)."""
    r = run("simulate", fmu, "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, ours = read_csv(tmp_path / "o.csv")
    ref = fmpy.simulate_fmu(str(fmu))
    assert header == ["time", "x"] and len(ours) == len(ref)
    np.testing.assert_allclose(ours[:, 0], ref["time"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours[:, 1], ref["x"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ours[:, 1], np.exp(-ours[:, 0]), rtol=0, atol=1e-8)


@pytest.mark.parametrize("version", [2, 3])
def test_a_model_identifier_that_is_no_c_identifier_still_loads_its_library(version, toy, tmp_path):
    fmu = toy("Dahlquist-c", version)
    runs_as_fmpy_and_decays(fmu, tmp_path)
    v = run("validate", fmu)
    assert v.returncode == 1 and "not a valid C identifier" in v.stdout, v.stdout + v.stderr


def test_the_ball_bounces_when_its_event_iteration_takes_two_calls(toy, tmp_path):
    """BouncingBallTwoPass re-initializes v in the first call of the event iteration and asks
    for a second, which reports valuesOfContinuousStatesChanged false."""
    fmu = toy("BouncingBallTwoPass")
    r = run("simulate", fmu, "--interface", "me", "--stop", 2, "--step", 0.01,
            "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, ours = read_csv(tmp_path / "o.csv")
    t = ours[:, 0]
    events = t[1:][np.diff(t) == 0]
    assert len(events) == 4, events
    at_event = np.isin(t, events)  # rows before and after a bounce: v jumps there
    want = bouncing_ball(t[~at_event])
    for name in ("h", "v"):
        np.testing.assert_allclose(ours[~at_event, header.index(name)], want[name], rtol=0,
                                   atol=1e-3, err_msg=name)
    ref = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", stop_time=2.0,
                            output_interval=0.01)
    assert ref["time"][-1] == t[-1] == 2.0
    assert abs(ours[-1, header.index("h")] - ref["h"][-1]) < 1e-3
    assert ref["h"].min() > -1e-3 and ours[:, header.index("h")].min() > -1e-6


@pytest.mark.parametrize("interface, fmi_type", [("cs", "CoSimulation"),
                                                 ("me", "ModelExchange")])
def test_the_default_grid_is_fmpys(interface, fmi_type, toy, tmp_path):
    """Dahlquist: DefaultExperiment stop 10 s, stepSize 0.1 s. FMPy's simulate_fmu records
    Co-Simulation every stepSize, Model Exchange at its round auto interval (0.01 s)."""
    fmu = toy("Dahlquist")
    r = run("simulate", fmu, "--interface", interface, "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    _, ours = read_csv(tmp_path / "o.csv")
    ref = fmpy.simulate_fmu(str(fmu), fmi_type=fmi_type)
    assert len(ours) == len(ref) == {"cs": 101, "me": 1001}[interface]
    np.testing.assert_allclose(ours[:, 0], ref["time"], rtol=0, atol=1e-12)
