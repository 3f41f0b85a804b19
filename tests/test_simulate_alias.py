"""`actuator-fmu simulate` against FMPy's `simulate_fmu` on the toy FMU `Alias`
(tests/fixtures/toy-fmus/alias.c, FMI 2.0 and FMI 3.0): der(x) = u - x from x(0) = 0, with u and
x under second names, and an output `tolerance` that records the relative tolerance the importer
gave the FMU (fmi2SetupExperiment / fmi3EnterInitializationMode; -1: toleranceDefined false).

- Tolerance: with no --tolerance a Co-Simulation run hands the FMU the DefaultExperiment's 1e-4,
  and nothing when the description has none; a Model Exchange run hands it nothing; a given
  --tolerance is handed over. FMPy's runs record the same values.
- Aliases: FMI 2.0 variables sharing a value reference (FMI 2.0.4 section 2.2.7) and FMI 3.0
  `<Alias>` elements (FMI 3.0.2 section 2.4.7.4) are columns of the result where FMPy writes
  them (its default selection: the outputs, FMI 3.0 aliases after the variables), may name the
  input column and be asked for with --outputs. Values: x = 1 - exp(-t) under u = 1.
"""
import csv
import math
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from conftest import cli_path

fmpy = pytest.importorskip("fmpy")

pytestmark = pytest.mark.skipif(sys.platform != "linux",
                                reason="the fixtures are built for linux64")

INTERFACES = {"cs": "CoSimulation", "me": "ModelExchange"}
ALIASES = {2: ["x_alias"], 3: ["x_ft", "x_alias"]}


def simulate(*args):
    r = subprocess.run([cli_path(), "simulate", *map(str, args)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return r


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def write_inputs(path, name, t_end=2.0):
    """u = 1 from the start, in a column called `name`, every 0.1 s."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", name])
        for k in range(int(round(t_end / 0.1)) + 1):
            w.writerow([repr(k * 0.1), "1"])


def fmpy_inputs(t_end=2.0):
    t = np.arange(int(round(t_end / 0.1)) + 1) * 0.1
    return np.array([(ti, 1.0) for ti in t], dtype=[("time", float), ("u", float)])


def without_tolerance(fmu, tmp_path):
    """A copy of `fmu` whose DefaultExperiment declares no tolerance."""
    out = tmp_path / f"no-tolerance-{fmu.name}"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                assert b' tolerance="1e-4"' in data
                data = data.replace(b' tolerance="1e-4"', b"")
            dst.writestr(item, data)
    return out


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("interface", ["cs", "me"])
@pytest.mark.parametrize("declared", [True, False], ids=["declared", "absent"])
def test_the_fmu_gets_the_tolerance_fmpy_gives_it(version, interface, declared, toy, tmp_path):
    fmu = toy("Alias", version)
    if not declared:
        fmu = without_tolerance(fmu, tmp_path)
    out = tmp_path / "out.csv"
    simulate(fmu, "--interface", interface, "--out", out)
    names, rows = read_csv(out)
    ours = set(rows[:, names.index("tolerance")])
    theirs = fmpy.simulate_fmu(str(fmu), fmi_type=INTERFACES[interface])
    # FMPy: Co-Simulation gets the DefaultExperiment's tolerance, else none; Model Exchange none
    expected = 1e-4 if declared and interface == "cs" else -1.0
    assert set(theirs["tolerance"]) == {expected}
    assert ours == {expected}


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("interface", ["cs", "me"])
def test_a_given_tolerance_reaches_the_fmu(version, interface, toy, tmp_path):
    """--tolerance is handed over in both interfaces (FMI 2.0.4 section 3.2.1: the model is
    integrated with it); FMPy hands it over in Co-Simulation only."""
    out = tmp_path / "out.csv"
    simulate(toy("Alias", version), "--interface", interface, "--tolerance", "1e-7", "--out", out)
    names, rows = read_csv(out)
    assert set(rows[:, names.index("tolerance")]) == {1e-7}
    if interface == "cs":
        theirs = fmpy.simulate_fmu(str(toy("Alias", version)), relative_tolerance=1e-7)
        assert set(theirs["tolerance"]) == {1e-7}


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("interface", ["cs", "me"])
def test_aliases_are_columns_where_fmpy_writes_them(version, interface, toy, tmp_path):
    fmu = toy("Alias", version)
    data, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_inputs(data, "u")
    simulate(fmu, "--interface", interface, "--data", data, "--out", out)
    names, rows = read_csv(out)
    theirs = fmpy.simulate_fmu(str(fmu), fmi_type=INTERFACES[interface], input=fmpy_inputs(),
                               output_interval=0.1)
    assert names == list(theirs.dtype.names)
    assert set(ALIASES[version]) <= set(names)
    t, x = rows[:, 0], rows[:, names.index("x")]
    exact = 1.0 - np.exp(-t)
    # CS steps with the closed form; ME integrates at the DefaultExperiment's 1e-4
    assert np.max(np.abs(x - exact)) <= (1e-12 if interface == "cs" else 1e-3)
    for alias in ALIASES[version]:
        assert np.array_equal(rows[:, names.index(alias)], x), alias
    if interface == "cs":
        assert np.allclose(x, theirs["x"], rtol=0, atol=1e-12)


@pytest.mark.parametrize("version", [2, 3])
def test_an_alias_names_the_input_column_and_an_output(version, toy, tmp_path):
    """u_alias (FMI 2.0: a local sharing u's value reference; FMI 3.0: u's <Alias>) sets u;
    --outputs takes alias names, in the order given."""
    fmu = toy("Alias", version)
    data, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_inputs(data, "u_alias")
    wanted = ["x_alias", "tolerance"] if version == 2 else ["x_ft", "u_alias", "tolerance"]
    simulate(fmu, "--data", data, "--outputs", ",".join(wanted), "--out", out)
    names, rows = read_csv(out)
    assert names == ["time", *wanted]
    x = rows[:, 1]
    assert np.max(np.abs(x - (1.0 - np.exp(-rows[:, 0])))) <= 1e-12
    assert x[-1] == pytest.approx(1.0 - math.exp(-2.0), abs=1e-12)
    if version == 3:
        assert set(rows[:, 2]) == {1.0}
