"""The host on FMI 3.0 FMUs: the toy FMUs of tests/fixtures/toy-fmus/ built as FMI 3.0 (plain C
models behind their own FMI 3.0 frame, built with gcc by the session fixture `toy`).

- `simulate` of every fixture offering Co-Simulation agrees with
  `fmpy.simulate_fmu(fmi_type='CoSimulation')` (an independent importer) on the same inputs and
  communication grid: Floats within 1e-6 relative, discrete values exactly; arrays are one column
  each, elements row-major separated by spaces (as FMPy's CSV files); and with each model's
  independent solution (closed forms; SciPy for Van der Pol).
- Structural parameters set in Configuration Mode resize the arrays (StateSpace with m = 2
  follows its closed form).
- An FMU that ends the run (Stair: terminateSimulation from fmi3DoStep) stops cleanly with its
  rows up to the last successful time; Scheduled Execution (Clocks) is refused naming it.
- Hostile FMI 3.0 descriptions (a modelIdentifier that is a path, an oversized file) are refused
  before anything is loaded; a binary crashing or hanging in fmi3DoStep is reported with the
  call and its time, as for FMI 2.0.
- Every FMI 3.0 type (the AllTypes test FMU, tests/fixtures/all-types-fmi3) is set from the CSV
  and recorded as FMPy records it.
"""
import csv
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from conftest import REPO, cli_path

fmpy = pytest.importorskip("fmpy")

CS_MODELS = ["Dahlquist", "VanDerPol", "Stair", "Resource", "StateSpace"]
linux_only = pytest.mark.skipif(sys.platform != "linux" or not hasattr(np, "float64"),
                                reason="the fixtures are built for x86_64-linux")


def run(*args):
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True, timeout=120)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def state_space_inputs(t):
    """A continuous Float64 array input u (3 elements), changing between rows."""
    return np.stack([np.sin(3 * t), np.cos(2 * t), 0.5 * t], axis=1)


def write_array_input(path, t, u, per_element):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        if per_element:
            w.writerow(["time", "u[1]", "u[2]", "u[3]"])
            w.writerows([repr(float(ti)), *map(repr, map(float, ui))] for ti, ui in zip(t, u))
        else:
            w.writerow(["time", "u"])
            w.writerows([repr(float(ti)), " ".join(map(repr, map(float, ui)))] for ti, ui in zip(t, u))


def compare(out_csv, ref, md):
    header, rows = read_csv(out_csv)
    ours = {name: [row[j] for row in rows] for j, name in enumerate(header)}
    assert len(rows) == len(ref), (len(rows), len(ref))
    np.testing.assert_allclose([float(x) for x in ours["time"]], ref["time"], rtol=1e-12, atol=1e-12)
    floats = {v.name for v in md.modelVariables
              if v.type in ("Float32", "Float64") and v.variability == "continuous"}
    for name in ref.dtype.names[1:]:
        got = np.array([[float(x) for x in cell.split()] for cell in ours[name]])
        want = np.asarray(ref[name], dtype=float).reshape(got.shape)
        if name in floats:
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12 * max(1.0, np.abs(want).max()),
                                       err_msg=name)
        else:
            assert np.array_equal(got, want), (name, got[:12], want[:12])


@linux_only
@pytest.mark.parametrize("model", CS_MODELS)
def test_simulate_agrees_with_fmpy_co_simulation(model, toy, tmp_path):
    from test_toy_fmus import independent_solution
    fmu = toy(model, 3)
    md = fmpy.read_model_description(str(fmu))
    stop = float(md.defaultExperiment.stopTime)
    step = float(md.defaultExperiment.stepSize or 0.1)
    args = ["simulate", fmu, "--stop", stop, "--step", step, "--out", tmp_path / "out.csv"]
    kw = dict(fmi_type="CoSimulation", start_time=0.0, stop_time=stop, output_interval=step)
    if model == "StateSpace":
        t = np.round(np.arange(0.0, stop + 1e-9, 0.25), 10)
        u = state_space_inputs(t)
        write_array_input(tmp_path / "in.csv", t, u, per_element=False)
        args[2:2] = ["--data", tmp_path / "in.csv"]
        sig = np.zeros(len(t), dtype=[("time", float), ("u", float, (3,))])
        sig["time"], sig["u"] = t, u
        kw["input"] = sig
    r = run(*args)
    assert r.returncode == 0, r.stderr
    compare(tmp_path / "out.csv", fmpy.simulate_fmu(str(fmu), **kw), md)
    header, rows = read_csv(tmp_path / "out.csv")
    ours = {name: np.array([[float(x) for x in row[j].split()] for row in rows])
            for j, name in enumerate(header)}
    grid = ours["time"][:, 0]
    if model == "StateSpace":
        solution = {"y": state_space_held(grid, t, u)}
    else:
        solution = {name: want[:, None] for name, want in independent_solution(model, grid).items()}
    for name, want in solution.items():
        np.testing.assert_allclose(ours[name], want, rtol=0,
                                   atol=1e-8 * max(1.0, np.abs(want).max()), err_msg=name)


def state_space_held(grid, t, u):
    """StateSpace's outputs in Co-Simulation at its start values (A = B = C = D = I, x0 = 0:
    x' = x + u, y = x + u), the input set at each communication point (u interpolated linearly
    between the rows t) and held over the step: x_{k+1} = e^h x_k + (e^h - 1) u_k. The output
    after a step is computed with the input set before it: y_0 = x_0 + u_0, y_k = x_k + u_{k-1}."""
    uk = np.stack([np.interp(grid, t, u[:, i]) for i in range(u.shape[1])], axis=1)
    x = np.zeros_like(uk)
    for k in range(len(grid) - 1):
        g = np.exp(grid[k + 1] - grid[k])
        x[k + 1] = g * x[k] + (g - 1) * uk[k]
    return x + np.concatenate([uk[:1], uk[:-1]])


@linux_only
def test_array_inputs_may_come_one_column_per_element(toy, tmp_path):
    fmu = toy("StateSpace", 3)
    t = np.round(np.arange(0.0, 1.0 + 1e-9, 0.1), 10)
    u = state_space_inputs(t)
    outs = []
    for per_element in (False, True):
        write_array_input(tmp_path / "in.csv", t, u, per_element)
        out = tmp_path / f"out{per_element}.csv"
        r = run("simulate", fmu, "--data", tmp_path / "in.csv", "--out", out)
        assert r.returncode == 0, r.stderr
        outs.append(out.read_text())
    assert outs[0] == outs[1]
    # an element missing from the per-element columns is named
    (tmp_path / "bad.csv").write_text("time,u[1],u[3]\n0,1,2\n1,1,2\n")
    r = run("simulate", fmu, "--data", tmp_path / "bad.csv", "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "element 2" in r.stderr, r.stderr


@linux_only
def test_structural_parameters_are_set_in_configuration_mode_and_resize_the_arrays(toy, tmp_path):
    fmu = toy("StateSpace", 3)
    # with m = 2 the input u has 2 elements: 3 values are refused before the FMU is called
    r = run("simulate", fmu, "--set", "m=2", "--set", "u=1 2 3", "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "'u' has 2 element(s), 3 value(s) given" in r.stderr, r.stderr
    # StateSpace takes m in Configuration Mode only: FMPy, which sets it after instantiation
    # outside that mode, is refused, so a run that follows the resized model shows the host
    # set it in Configuration Mode
    with pytest.raises(Exception, match="fmi3SetUInt64"):
        fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=1.0, start_values={"m": 2})
    r = run("simulate", fmu, "--set", "m=2", "--set", "u=1 2", "--stop", 1, "--step", 0.25,
            "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "o.csv")
    # B and D are 3 x 2 with ones on the diagonal: B u = D u = (1, 2, 0); from x0 = 0 with u
    # held, x = (e^t - 1) B u and y = x + D u = e^t (1, 2, 0)
    t = np.array([float(row[0]) for row in rows])
    y = np.array([[float(x) for x in row[header.index("y")].split()] for row in rows])
    assert y.shape == (5, 3), y
    np.testing.assert_allclose(y, np.exp(t)[:, None] * [1.0, 2.0, 0.0], rtol=1e-9, atol=1e-12)


@linux_only
def test_an_fmu_that_ends_the_run_stops_cleanly_at_its_last_successful_time(toy, tmp_path):
    out = tmp_path / "stair.csv"
    r = run("simulate", toy("Stair", 3), "--out", out)
    assert r.returncode == 0, r.stderr
    assert "ended the simulation at t = 9" in r.stderr and "fmi3DoStep" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "counter"]
    assert float(rows[-1][0]) == 9.0 and rows[-1][1] == "10", rows[-3:]


@linux_only
def test_scheduled_execution_is_refused_naming_what_is_unsupported(toy, tmp_path):
    r = run("simulate", toy("Clocks", 3), "--out", tmp_path / "o.csv")
    assert r.returncode == 2, r.stderr
    assert "Scheduled Execution is not supported" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "o.csv").exists()


def rewrite(src, dst, edit):
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = edit(data.decode()).encode()
            zout.writestr(item, data)
    return dst


@linux_only
def test_hostile_fmi3_descriptions_are_refused_before_anything_is_loaded(toy, tmp_path):
    fmu = rewrite(toy("Dahlquist", 3), tmp_path / "path.fmu",
                  lambda md: md.replace('modelIdentifier="Dahlquist"', 'modelIdentifier="../../x"'))
    r = run("simulate", fmu, "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "is not a C identifier" in r.stderr, r.stderr
    # above 64 MiB: refused by size, before parsing (a comment padded to 65 MiB compresses to
    # some 65 kB)
    fmu = rewrite(toy("Dahlquist", 3), tmp_path / "huge.fmu",
                  lambda md: md.replace("<ModelVariables>", "<!--" + " " * (65 << 20) + "-->\n<ModelVariables>"))
    r = run("simulate", fmu, "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "larger than" in r.stderr, r.stderr
    # a start value outside its type's range: one located message
    fmu = rewrite(toy("Stair", 3), tmp_path / "range.fmu",
                  lambda md: md.replace('start="1" max="10"', 'start="99999999999" max="10"'))
    r = run("simulate", fmu, "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "outside the range of Int32" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


CRASH_C = r'''
#include <stddef.h>
#define STUB(name) int name(void) { return 0; }
STUB(fmi3GetVersion) STUB(fmi3SetDebugLogging) STUB(fmi3EnterInitializationMode)
STUB(fmi3ExitInitializationMode) STUB(fmi3EnterEventMode) STUB(fmi3Terminate) STUB(fmi3Reset)
STUB(fmi3GetFloat32) STUB(fmi3GetInt8) STUB(fmi3GetUInt8) STUB(fmi3GetInt16)
STUB(fmi3GetUInt16) STUB(fmi3GetInt32) STUB(fmi3GetUInt32) STUB(fmi3GetInt64) STUB(fmi3GetUInt64)
STUB(fmi3GetBoolean) STUB(fmi3GetString) STUB(fmi3GetBinary) STUB(fmi3GetClock)
STUB(fmi3SetFloat32) STUB(fmi3SetFloat64) STUB(fmi3SetInt8) STUB(fmi3SetUInt8) STUB(fmi3SetInt16)
STUB(fmi3SetUInt16) STUB(fmi3SetInt32) STUB(fmi3SetUInt32) STUB(fmi3SetInt64) STUB(fmi3SetUInt64)
STUB(fmi3SetBoolean) STUB(fmi3SetString) STUB(fmi3SetBinary) STUB(fmi3SetClock)
static int instance;
void *fmi3InstantiateCoSimulation(void) { return &instance; }
void fmi3FreeInstance(void *i) { (void)i; }
int fmi3GetFloat64(void *i, const unsigned *vr, size_t nvr, double *v, size_t n) {
    for (size_t k = 0; k < n; k++) v[k] = 0.5; return 0; }
int fmi3DoStep(void *i, double t, double h) {
    volatile int spin = 1;
    if (t >= 0.3) {
#ifdef HANG
        while (spin) {}
#else
        *(volatile int *)0 = spin;
#endif
    }
    return 0;
}
'''

CRASH_MD = '''<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Crash" instantiationToken="{0}">
  <CoSimulation modelIdentifier="Crash"/>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="y" valueReference="1" causality="output"/>
  </ModelVariables>
  <ModelStructure><Output valueReference="1"/></ModelStructure>
</fmiModelDescription>
'''


def misbehaving_fmu(tmp_path, *defines):
    """The FMU of CRASH_C/CRASH_MD, compiled with `defines`."""
    if shutil.which("gcc") is None:
        pytest.fail("gcc is needed to build the misbehaving FMU")
    (tmp_path / "crash.c").write_text(CRASH_C)
    lib = tmp_path / "Crash.so"
    subprocess.run(["gcc", *defines, "-shared", "-fPIC", "-o", lib, tmp_path / "crash.c"], check=True)
    fmu = tmp_path / "Crash.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", CRASH_MD)
        z.write(lib, "binaries/x86_64-linux/Crash.so")
    return fmu


@linux_only
def test_a_crash_in_fmi3_do_step_is_reported_with_the_call_and_time(tmp_path):
    r = run("simulate", misbehaving_fmu(tmp_path), "--out", tmp_path / "o.csv")
    assert r.returncode == 2, r.stderr
    assert "crashed (SIGSEGV) in fmi3DoStep at t = 0.3" in r.stderr, r.stderr
    assert not (tmp_path / "o.csv").exists()


@linux_only
def test_an_fmi3_do_step_that_never_returns_is_stopped_after_the_timeout(tmp_path):
    r = run("simulate", misbehaving_fmu(tmp_path, "-DHANG"), "--timeout", 1, "--out", tmp_path / "o.csv")
    assert r.returncode == 2, r.stderr
    assert "did not return from fmi3DoStep at t = 0.3" in r.stderr, r.stderr
    assert not (tmp_path / "o.csv").exists()


ALL_TYPES = REPO / "tests" / "fixtures" / "all-types-fmi3"
NUMERIC = {  # type -> (numpy dtype, values cycling over the rows: the ends of each range)
    "Float32": (np.float32, [0.1, -3.5e-7, 1.0e20, 0.0]),
    "Int8": (np.int8, [-128, 127, 0, -1]),
    "UInt8": (np.uint8, [0, 255, 7, 128]),
    "Int16": (np.int16, [-32768, 32767, 5, -5]),
    "UInt16": (np.uint16, [65535, 0, 1, 300]),
    "Int32": (np.int32, [-2**31, 2**31 - 1, 42, 0]),
    "UInt32": (np.uint32, [2**32 - 1, 0, 3, 2**31]),
    "Int64": (np.int64, [-2**63, 2**63 - 1, 2**53 + 1, -7]),
    "UInt64": (np.uint64, [2**64 - 1, 0, 2**53 + 1, 9]),
    "Boolean": (np.bool_, [True, False, False, True]),
    "Enumeration": (np.int64, [1, 3, 2, 2]),
}


@pytest.fixture(scope="module")
def all_types(tmp_path_factory):
    """tests/fixtures/all-types-fmi3 compiled and zipped (an input and an output of every type)."""
    if shutil.which("gcc") is None:
        pytest.fail("gcc is needed to build the all-types FMU")
    d = tmp_path_factory.mktemp("all-types")
    lib = d / "all_types.so"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-O2",
                    "-o", lib, ALL_TYPES / "all_types.c"], check=True)
    fmu = d / "AllTypes.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.write(ALL_TYPES / "modelDescription.xml", "modelDescription.xml")
        z.write(lib, "binaries/x86_64-linux/all_types.so")
    return fmu


@linux_only
def test_every_type_is_set_from_the_csv_and_recorded_as_fmpy_records_it(all_types, tmp_path):
    t = np.round(np.arange(0.0, 1.0 + 1e-9, 0.1), 10)
    k = np.arange(len(t))
    inputs = {f"{ty}_input": np.array(vals, dtype=dt)[k % len(vals)] for ty, (dt, vals) in NUMERIC.items()}
    inputs["Float64_input"] = np.sin(3 * t)
    matrix = np.stack([k, -k, 0.5 * k, k * k], axis=1).astype(float)
    words = ["plain", "with, comma", 'say "hi"', "", "ünïcode", " padded "]
    blobs = ["", "00", "ff00ab", "0123456789abcdef", "7f", "80"]
    with open(tmp_path / "in.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", *inputs, "Matrix_input", "String_input", "Binary_input"])
        for i, ti in enumerate(t):
            cells = [str(v[i]).lower() if v.dtype == np.bool_ else repr(v[i].item()) for v in inputs.values()]
            w.writerow([repr(float(ti)), *cells, " ".join(repr(float(x)) for x in matrix[i]),
                        words[i % len(words)], blobs[i % len(blobs)]])
    r = run("simulate", all_types, "--data", tmp_path / "in.csv", "--out", tmp_path / "out.csv")
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "out.csv")
    ours = {name: [row[j] for row in rows] for j, name in enumerate(header)}
    sig = np.zeros(len(t), dtype=[("time", float)] + [(n, v.dtype) for n, v in inputs.items()]
                   + [("Matrix_input", float, (2, 2))])
    sig["time"] = t
    for n, v in inputs.items():
        sig[n] = v
    sig["Matrix_input"] = matrix.reshape(-1, 2, 2)
    ref = fmpy.simulate_fmu(str(all_types), fmi_type="CoSimulation", stop_time=1.0,
                            output_interval=0.1, input=sig)
    assert len(rows) == len(ref)
    for ty, (dt, _) in NUMERIC.items():
        name = f"{ty}_output"
        want = ref[name]
        if dt == np.bool_:
            got = np.array([float(x) != 0 for x in ours[name]])
        elif dt == np.float32:
            got = np.array([np.float32(x) for x in ours[name]])
        else:  # integers read exactly (Int64/UInt64 beyond 2^53 included)
            got = np.array([int(x) for x in ours[name]], dtype=dt)
        assert np.array_equal(got, want), (name, got, want)
    np.testing.assert_allclose([float(x) for x in ours["Float64_output"]], ref["Float64_output"],
                               rtol=1e-6, atol=1e-12)
    got = np.array([[float(x) for x in c.split()] for c in ours["Matrix_output"]])
    assert np.array_equal(got, ref["Matrix_output"].reshape(-1, 4)), got
    # String and Binary (which FMPy does not set from signals): the output after a step is the
    # input set before it, row 0 the first row's (set before initialization)
    for name, cells in (("String_output", words), ("Binary_output", blobs)):
        want = [cells[0]] + [cells[i % len(cells)] for i in range(len(t) - 1)]
        assert ours[name] == want, (name, ours[name], want)


@linux_only
def test_values_outside_their_type_are_refused_with_their_row(all_types, tmp_path):
    for column, cell, message in (("Int8_input", "128", "outside the range of Int8"),
                                  ("UInt64_input", "-1", "outside the range of UInt64"),
                                  ("Boolean_input", "maybe", "not a Boolean"),
                                  ("Binary_input", "abc", "hexadecimal"),
                                  ("Matrix_input", "1 2 3", "3 value(s) for 4 element(s)"),
                                  ("Float64_input", "NaN", "not a finite number"),
                                  ("Matrix_input", "1 2 1e300 4", "not a finite number")):
        (tmp_path / "in.csv").write_text(f"time,{column}\n0,{cell}\n1,{cell}\n")
        r = run("simulate", all_types, "--data", tmp_path / "in.csv", "--out", tmp_path / "o.csv")
        assert r.returncode == 2 and message in r.stderr and "row 1" in r.stderr, (column, r.stderr)


@linux_only
def test_a_structural_parameter_set_in_configuration_mode_resizes_its_arrays(all_types, tmp_path):
    """AllTypes' n sizes Vector_input/Vector_output and may be set in Configuration Mode only:
    `--set n=3` takes three elements, from --set or from the CSV (one column or per element)."""
    r = run("simulate", all_types, "--set", "n=3", "--set", "Vector_input=1 2 3", "--stop", 0.2,
            "--step", 0.1, "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "o.csv")
    j = header.index("Vector_output")
    assert [row[j] for row in rows] == ["1 2 3"] * 3, rows
    (tmp_path / "in.csv").write_text("time,Vector_input[1],Vector_input[2],Vector_input[3]\n"
                                     "0,1,2,3\n0.1,4,5,6\n0.2,7,8,9\n")
    r = run("simulate", all_types, "--set", "n=3", "--data", tmp_path / "in.csv", "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(tmp_path / "o.csv")
    j = header.index("Vector_output")
    # the output after a step is the input set before it
    assert [row[j] for row in rows] == ["1 2 3", "1 2 3", "4 5 6"], rows
    # at the default n = 2, three values are refused before the FMU is called
    r = run("simulate", all_types, "--set", "Vector_input=1 2 3", "--out", tmp_path / "o.csv")
    assert r.returncode == 2 and "'Vector_input' has 2 element(s), 3 value(s) given" in r.stderr, r.stderr
