"""A jump of the inputs written as FMPy writes it: the time repeated, the row before the jump
and the row after it (FMPy's `Input.findEvents` makes it a time event). `simulate --data` takes
such a file in both FMI versions and both interfaces, and gets what FMPy gets from it; a time
on three rows, or a repeated time in a measured record for `gap`, is refused with its line."""
import sys

import fmpy
import numpy as np
import pytest

from conftest import fmu_path, read_csv_floats, run_cli

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="the fixtures are built for linux64")

# A ramp of the continuous input that jumps by 2 at t = 0.5: u = t before, u = t + 2 after.
ROWS = [(0.0, 0.0), (0.5, 0.5), (0.5, 2.5), (1.0, 3.0)]


def write_rows(path, name, rows):
    path.write_text(f"time,{name}\n" + "".join(f"{t!r},{u!r}\n" for t, u in rows))


def fmpy_input(name, rows):
    return np.array(rows, dtype=[("time", float), (name, float)])


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_a_repeated_time_is_a_jump_of_the_inputs_as_in_fmpy(toy, tmp_path, interface):
    fmu = toy("Feedthrough")
    data = tmp_path / "in.csv"
    write_rows(data, "Float64_continuous_input", ROWS)
    r = run_cli("simulate", fmu, "--interface", interface, "--data", data, "--stop", 1.0,
                "--step", 0.1, "--outputs", "Float64_continuous_output",
                "--out", tmp_path / "out.csv")
    assert r.returncode == 0, r.stderr
    header, ours = read_csv_floats(tmp_path / "out.csv")
    t, y = ours[:, 0], ours[:, header.index("Float64_continuous_output")]
    # the closed form: the output is the input, u = t before the jump and t + 2 from it on
    # (Co-Simulation: the output after a step is the input set at its start)
    lag = 0.1 if interface == "cs" else 0.0
    before = t < 0.5 + lag - 1e-9
    expect = np.where(before, np.maximum(t - lag, 0.0), t - lag + 2.0)
    if interface == "me":
        # the row at the jump, written twice: the left limit (0.5), then the value after (2.5)
        [i] = np.flatnonzero((t[1:] == 0.5) & (t[:-1] == 0.5))
        assert (y[i], y[i + 1]) == pytest.approx((0.5, 2.5), abs=1e-12)
        expect[i] = 0.5
    np.testing.assert_allclose(y, expect, atol=1e-12)
    fmi_type = "CoSimulation" if interface == "cs" else "ModelExchange"
    ref = fmpy.simulate_fmu(str(fmu), fmi_type=fmi_type, stop_time=1.0, output_interval=0.1,
                            input=fmpy_input("Float64_continuous_input", ROWS))
    assert len(ref) == len(t), (len(ref), len(t))
    np.testing.assert_allclose(ref["time"], t, atol=1e-12)
    np.testing.assert_allclose(ref["Float64_continuous_output"], y, atol=1e-12)


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_input_events_between_output_points_as_in_fmpy(toy, tmp_path, interface):
    """A jump at 0.55 s and a held (discrete) input changing at 0.25 s, both between the 0.1 s
    output points: FMPy ends a Co-Simulation step at each (the FMU handles a variable step
    size) and records a row there; Model Exchange makes them input events. Same rows, same
    values as FMPy."""
    fmu = toy("Feedthrough")
    rows = [(0.0, 0.0, 1.0), (0.25, 0.25, 1.0), (0.25, 0.25, 4.0), (0.55, 0.55, 4.0),
            (0.55, 2.55, 4.0), (1.0, 3.0, 4.0)]
    names = ("Float64_continuous_input", "Float64_discrete_input")
    data = tmp_path / "in.csv"
    data.write_text(f"time,{','.join(names)}\n" + "".join(f"{t!r},{u!r},{d!r}\n"
                                                          for t, u, d in rows))
    outputs = ("Float64_continuous_output", "Float64_discrete_output")
    r = run_cli("simulate", fmu, "--interface", interface, "--data", data, "--stop", 1.0,
                "--step", 0.1, "--outputs", ",".join(outputs), "--out", tmp_path / "out.csv")
    assert r.returncode == 0, r.stderr
    header, ours = read_csv_floats(tmp_path / "out.csv")
    signals = np.array(rows, dtype=[("time", float), (names[0], float), (names[1], float)])
    fmi_type = "CoSimulation" if interface == "cs" else "ModelExchange"
    ref = fmpy.simulate_fmu(str(fmu), fmi_type=fmi_type, stop_time=1.0, output_interval=0.1,
                            input=signals, output=list(outputs))
    np.testing.assert_allclose(ours[:, 0], ref["time"], atol=1e-12)
    assert 0.55 in list(np.round(ours[:, 0], 12)) and 0.25 in list(np.round(ours[:, 0], 12))
    for j, name in enumerate(outputs, start=1):
        np.testing.assert_allclose(ours[:, j], ref[name], atol=1e-12, err_msg=name)


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_a_step_of_an_fmi3_input_written_as_a_repeated_time(toy, tmp_path, interface):
    """FMI 3.0 Alias, der(x) = u - x from x(0) = 0, with u stepping from 0 to 1 at t = 0.5 (the
    time repeated): x = 0 up to 0.5, then x = 1 - exp(-(t - 0.5)), the closed form (Model
    Exchange within its tolerance; Co-Simulation advances with the exact solution for an input
    held over the step)."""
    data = tmp_path / "in.csv"
    write_rows(data, "u", [(0.0, 0.0), (0.5, 0.0), (0.5, 1.0), (1.0, 1.0)])
    r = run_cli("simulate", toy("Alias", 3), "--interface", interface, "--data", data,
                "--stop", 1.0, "--step", 0.1, "--tolerance", 1e-8, "--out", tmp_path / "out.csv")
    assert r.returncode == 0, r.stderr
    header, ours = read_csv_floats(tmp_path / "out.csv")
    t, x = ours[:, 0], ours[:, header.index("x")]
    expect = np.where(t > 0.5 + 1e-9, 1.0 - np.exp(-(t - 0.5)), 0.0)
    np.testing.assert_allclose(x, expect, atol=1e-6)
    assert x[-1] == pytest.approx(1.0 - np.exp(-0.5), abs=1e-6)


def test_a_time_on_three_rows_is_refused_with_its_line(toy, tmp_path):
    data = tmp_path / "in.csv"
    write_rows(data, "Float64_continuous_input", [*ROWS[:3], (0.5, 9.0), (1.0, 3.0)])
    r = run_cli("simulate", toy("Feedthrough"), "--data", data, "--out", tmp_path / "out.csv")
    assert r.returncode == 2, r.stderr
    [line] = r.stderr.strip().splitlines()
    assert f"{data}:5:1:" in line and "not three" in line, line


def test_gap_refuses_a_measured_record_with_a_repeated_time(tmp_path):
    data = tmp_path / "record.csv"
    data.write_text("time,theta\n0,0\n0.1,0\n0.1,0.01\n0.2,0.02\n")
    r = run_cli("gap", fmu_path("HydraulicJoint"), "--data", data, "--out", tmp_path / "gap")
    assert r.returncode == 2, r.stderr
    assert f"{data}:4:1:" in r.stderr and "time must increase strictly" in r.stderr, r.stderr
