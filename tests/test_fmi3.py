"""The FMI 3.0 archives dist/fmi3/<Model>.fmu (Co-Simulation here; Model Exchange in
tests/test_fmi3_me.py).

- `fmpy validate` finds no problem (FMI 3.0 schema and FMPy's checks);
- every binary, under each of the five FMI 3.0 platform tuples, exports exactly the 75 functions
  of the standard's header fmi3Functions.h (read from FMPy's copy, not from our code) and no
  fmi2* function; the FMI 2.0 binaries export no fmi3* function; the Linux ones need GLIBC 2.17
  at most;
- simulated by FMPy through FMI 3.0, each model gives bit for bit the outputs of its FMI 2.0
  archive on the same inputs (the same model code), with the importer's tolerance honoured alike;
- an FMU state survives serialization and a damaged serialized state is refused; a bad value
  reference or a wrong type gives fmi3Error and leaves the instance usable; the functions of
  features not offered answer fmi3Error.
- the x86_64-windows DLL runs under Wine (a C driver cross-compiled with mingw-w64) and the
  aarch64-linux library under qemu-user (the driver cross-compiled by zig for glibc 2.17), and
  both agree with the x86_64-linux binary run by the same driver compiled natively.
macOS binaries are read (llvm-nm), not run; the Windows DLL's exports are read
(llvm-readobj).
"""
import re
import shutil
import subprocess
import time
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from conftest import REPO, fmu3_path, fmu_path

MODELS = ["HydraulicJoint", "TwistedString", "EMPS"]
PLATFORMS = {"x86_64-linux": "so", "aarch64-linux": "so", "x86_64-windows": "dll",
             "x86_64-darwin": "dylib", "aarch64-darwin": "dylib"}
ERROR = 3
HEADER = Path(fmpy.__file__).parent / "c-code" / "fmi3Functions.h"
FMI3_ALL = sorted(set(re.findall(r"^#define (fmi3\w+)\s+fmi3FullName", HEADER.read_text(), re.M)))
# (input, values over time, outputs) per model: the set point moved during the run.
RUNS = {
    "HydraulicJoint": ("theta_ref", lambda t: 0.5 * np.sin(2 * np.pi * t)),
    "TwistedString": ("theta_motor_ref", lambda t: 600.0 * t),
    "EMPS": ("qg", lambda t: 0.05 * np.sin(2 * np.pi * t)),
}


def test_the_header_lists_75_functions():
    assert len(FMI3_ALL) == 75, FMI3_ALL


@pytest.mark.parametrize("model", MODELS)
def test_fmpy_validate_finds_no_problem(model):
    assert validate_fmu(fmu3_path(model)) == []


@pytest.mark.parametrize("model", MODELS)
def test_documentation_and_icon_come_along(model):
    with zipfile.ZipFile(fmu3_path(model)) as z:
        names = set(z.namelist())
        html = z.read("documentation/index.html").decode()
    assert "model.png" in names and any(n.startswith("documentation/licenses/") for n in names)
    assert re.search(r"FMI 3\.0 Model Exchange \(\d+ continuous states, \d+ event indicators?\) "
                     r"and Co-Simulation, both with directional derivatives, instantiationToken",
                     html)
    assert "<table>" in html


def exports(path: Path):
    """The functions a shared library exports: ELF dynamic symbols, Mach-O external symbols
    (without the leading underscore), PE export table."""
    data = path.read_bytes()
    if data[:2] == b"MZ":
        text = subprocess.run(["llvm-readobj", "--coff-exports", str(path)], check=True,
                              capture_output=True, text=True).stdout
        return sorted(re.findall(r"Name: (\S+)", text))
    flags = ["-D"] if data[:4] == b"\x7fELF" else ["--extern-only"]
    text = subprocess.run(["llvm-nm", *flags, "--defined-only", "--format=just-symbols",
                           str(path)], check=True, capture_output=True, text=True).stdout
    names = [n.removeprefix("_") if data[:4] != b"\x7fELF" else n for n in text.split()]
    return sorted(n for n in names if n.startswith("fmi"))


@pytest.mark.parametrize("model", MODELS)
def test_each_binary_exports_exactly_the_fmi3_functions(model, tmp_path):
    if not (shutil.which("llvm-nm") and shutil.which("llvm-readobj")):
        pytest.fail("llvm-nm and llvm-readobj are needed (Debian package llvm)")
    with zipfile.ZipFile(fmu3_path(model)) as z:
        binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
        assert binaries == sorted(f"binaries/{p}/{model}.{e}" for p, e in PLATFORMS.items())
        z.extractall(tmp_path)
    for b in binaries:
        assert exports(tmp_path / b) == FMI3_ALL, b


@pytest.mark.parametrize("model", MODELS)
def test_the_fmi2_binaries_export_no_fmi3_function(model, tmp_path):
    with zipfile.ZipFile(fmu_path(model)) as z:
        binaries = [n for n in z.namelist() if n.startswith("binaries/")]
        z.extractall(tmp_path)
    for b in binaries:
        names = exports(tmp_path / b)
        assert names and not [n for n in names if n.startswith("fmi3")], b


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("platform", ["x86_64-linux", "aarch64-linux"])
def test_linux_binaries_need_glibc_2_17_at_most(model, platform, tmp_path):
    so = tmp_path / "lib.so"
    so.write_bytes(zipfile.ZipFile(fmu3_path(model)).read(f"binaries/{platform}/{model}.so"))
    text = subprocess.run(["objdump", "-T", str(so)], capture_output=True, text=True).stdout
    versions = {tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", text)}
    assert versions and max(versions) <= (2, 17), sorted(versions)


def simulate(path, model, tolerance=None, t_end=1.0, dt=1e-3):
    name, signal = RUNS[model]
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    inp = np.zeros(len(t), dtype=[("time", float), (name, float)])
    inp["time"], inp[name] = t, signal(t)
    return fmpy.simulate_fmu(path, fmi_type="CoSimulation", stop_time=t_end, step_size=dt,
                             output_interval=dt, input=inp, relative_tolerance=tolerance)


@pytest.mark.parametrize("model", MODELS)
def test_fmi3_gives_the_fmi2_outputs_bit_for_bit(model):
    fmi2 = simulate(fmu_path(model), model)
    fmi3 = simulate(fmu3_path(model), model)
    outputs = [n for n in fmi2.dtype.names if n != "time"]
    assert outputs and set(outputs) <= set(fmi3.dtype.names)
    assert np.array_equal(fmi2["time"], fmi3["time"])
    for n in outputs:
        assert np.array_equal(fmi2[n], fmi3[n]), n


def test_the_importers_tolerance_is_honoured_as_in_fmi2():
    """TwistedString hands the importer's tolerance to its solver: a loose tolerance changes the
    trace, and changes it identically through fmi3EnterInitializationMode and
    fmi2SetupExperiment."""
    loose3 = simulate(fmu3_path("TwistedString"), "TwistedString", tolerance=1e-3)
    loose2 = simulate(fmu_path("TwistedString"), "TwistedString", tolerance=1e-3)
    tight3 = simulate(fmu3_path("TwistedString"), "TwistedString", tolerance=1e-9)
    assert np.array_equal(loose3["p"], loose2["p"])
    assert not np.array_equal(loose3["p"], tight3["p"])


@pytest.fixture
def instance():
    """An initialized FMI 3.0 HydraulicJoint instance in Step Mode, with its variables."""
    path = fmu3_path("HydraulicJoint")
    md = fmpy.read_model_description(path)
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmpy.extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="t")
    fmu.instantiate(logMessage=lambda *args: None)
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    yield fmu, {v.name: v.valueReference for v in md.modelVariables}
    fmu.terminate()
    fmu.freeInstance()


def steps(fmu, vr, t0, n, h=1e-3):
    out = []
    for k in range(n):
        fmu.setFloat64([vr["theta_ref"]], [0.3])
        flags = fmu.doStep(t0 + k * h, h)
        assert flags[:3] == (False, False, False) and flags[3] == pytest.approx(t0 + (k + 1) * h)
        out.append(fmu.getFloat64([vr["theta"], vr["p1_left"], vr["time"]]))
    assert out[-1][2] == pytest.approx(t0 + n * h)  # `time` reads the time reached
    return np.array(out)


def test_fmu_state_round_trip_and_a_damaged_state_is_refused(instance):
    fmu, vr = instance
    steps(fmu, vr, 0.0, 50)
    blob = fmu.serializeFMUState(fmu.getFMUState())
    first = steps(fmu, vr, 0.05, 50)
    state = fmu.deserializeFMUState(blob)
    fmu.setFMUState(state)
    assert np.array_equal(steps(fmu, vr, 0.05, 50), first)
    damaged = bytearray(blob)
    damaged[len(damaged) // 2] ^= 0x01
    with pytest.raises(FMICallException) as e:
        fmu.deserializeFMUState(bytes(damaged))
    assert e.value.status == ERROR
    with pytest.raises(FMICallException):
        fmu.deserializeFMUState(blob[:-1])
    fmu.freeFMUState(state)


def test_bad_references_and_types_give_fmi3error_not_a_crash(instance):
    fmu, vr = instance
    calls = [
        lambda: fmu.getFloat64([999_999]),  # unknown reference
        lambda: fmu.getFloat64([vr["internal_controller"]]),  # a Boolean
        lambda: fmu.getBoolean([vr["theta"]]),  # a Float64
        lambda: fmu.getInt8([vr["theta"]]),  # no Int8 variables
        lambda: fmu.setFloat64([vr["time"]], [1.0]),  # the independent variable
        lambda: fmu.setFloat64([vr["theta"]], [1.0]),  # an output
        lambda: fmu.setFloat64([vr["load_radius"]], [0.2]),  # fixed after initialization
        lambda: fmu.doStep(0.5, 1e-3),  # not the current time
        lambda: fmu.enterStepMode(),  # no Event Mode
        # a Boolean parameter is no known of a derivative (a Float64 parameter is, FMI 3.0.2
        # section 2.4.8)
        lambda: fmu.getDirectionalDerivative([vr["theta"]], [vr["cables_attached"]], [1.0]),
        lambda: fmu.getDirectionalDerivative([vr["theta"]], [vr["F_left"]], [1.0]),  # an output
    ]
    for call in calls:
        with pytest.raises(FMICallException) as e:
            call()
        assert e.value.status == ERROR
    assert fmu.getFloat32([]) == []  # an empty request of a type without variables is fine
    steps(fmu, vr, 0.0, 3)  # the instance is still usable


def test_a_tunable_parameter_acts_from_the_next_step(instance):
    """load_mass is tunable: set in Step Mode it is accepted and changes the motion from the next
    step on, compared with the same steps from the same FMU state without the change."""
    fmu, vr = instance
    steps(fmu, vr, 0.0, 100)
    state = fmu.getFMUState()
    same = steps(fmu, vr, 0.1, 200)
    fmu.setFMUState(state)
    fmu.setFloat64([vr["load_mass"]], [8.0])
    assert fmu.getFloat64([vr["load_mass"]]) == [8.0]
    heavy = steps(fmu, vr, 0.1, 200)
    assert not np.allclose(heavy[-50:, 0], same[-50:, 0])
    fmu.setFMUState(state)
    assert np.array_equal(steps(fmu, vr, 0.1, 200), same)
    fmu.freeFMUState(state)


def test_event_mode_and_scheduled_execution_are_refused():
    """Co-Simulation with eventModeUsed and Scheduled Execution are not offered (Model Exchange
    is: tests/test_fmi3_me.py)."""
    path = fmu3_path("TwistedString")
    md = fmpy.read_model_description(path)
    lib = FMU3Slave(guid=md.guid, unzipDirectory=fmpy.extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    messages = []
    lib.logMessage = fmpy.fmi3.fmi3LogMessageCallback(lambda env, s, c, m: messages.append(m))
    f3 = fmpy.fmi3
    none = lib.fmi3InstantiateScheduledExecution(
        b"se", md.guid.encode(), b"", False, False, None, lib.logMessage,
        f3.fmi3ClockUpdateCallback(), f3.fmi3LockPreemptionCallback(),
        f3.fmi3UnlockPreemptionCallback())
    assert not none and b"Scheduled Execution" in messages[-1]
    with pytest.raises(Exception, match="instantiate"):
        lib.instantiate(eventModeUsed=True, logMessage=lambda *a: None)
    lib.freeLibrary()


DRIVER = REPO / "tests" / "drivers" / "platform"
# (input, value held, outputs compared) per model: a step of the set point.
WINE_RUNS = {
    "HydraulicJoint": ("theta_ref", 0.5, ["theta", "x_left", "p1_left", "T_left"]),
    "TwistedString": ("theta_motor_ref", 600.0, ["p", "theta_motor", "current"]),
    "EMPS": ("qg", 0.05, ["qm", "force", "velocity"]),
}


def run_driver(cmd, lib, model, cwd, stop=0.5, h=1e-3):
    md = fmpy.read_model_description(fmu3_path(model))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    inp, value, outs = WINE_RUNS[model]
    args = [*cmd, lib, md.guid, str(stop), str(h), str(vr[inp]), str(value),
            *[str(vr[o]) for o in outs]]
    env = {"WINEDEBUG": "-all", "PATH": "/usr/bin:/bin", "HOME": str(Path.home())}
    env = {**env, "QEMU_LD_PREFIX": "/usr/aarch64-linux-gnu"}
    res = subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=600, env=env)
    # Wine sometimes fails to start a program while the previous wineserver shuts down, with
    # nothing on stderr (the driver prints a message on each of its own failures): retry that.
    for _ in range(2):
        if res.returncode == 0 or res.stderr.strip() or cmd[0] != "wine":
            break
        time.sleep(1)
        res = subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=600, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    data = np.array([[float(x) for x in line.split(",")] for line in res.stdout.split()])
    assert data.shape == (int(round(stop / h)), 1 + len(outs))
    return data


@pytest.mark.parametrize("model", MODELS)
def test_windows_dll_under_wine_computes_the_linux_binarys_bits(model, tmp_path):
    for tool in ("gcc", "x86_64-w64-mingw32-gcc", "wine"):
        if not shutil.which(tool):
            pytest.fail(f"{tool} is missing: scripts/test installs it (apt-get)")
    with zipfile.ZipFile(fmu3_path(model)) as z:
        z.extractall(tmp_path)
    src = DRIVER / "fmu3_run.c"
    subprocess.run(["gcc", "-O2", "-o", tmp_path / "fmu3_run", src, "-ldl"], check=True)
    subprocess.run(["x86_64-w64-mingw32-gcc", "-O2", "-o", tmp_path / "fmu3_run.exe", src],
                   check=True)
    subprocess.run(["x86_64-w64-mingw32-gcc", "-shared", "-O2", "-o",
                    tmp_path / "bcryptprimitives.dll", DRIVER / "bcryptprimitives.c",
                    "-ladvapi32"], check=True)
    linux = run_driver([str(tmp_path / "fmu3_run")], f"binaries/x86_64-linux/{model}.so", model,
                       tmp_path)
    windows = run_driver(["wine", str(tmp_path / "fmu3_run.exe")],
                         f"binaries\\x86_64-windows\\{model}.dll", model, tmp_path)
    assert np.array_equal(linux[:, 0], windows[:, 0])
    # bit for bit: the FMUs compute with the `libm` crate, not the platform's (test_determinism.py)
    for k, name in enumerate(WINE_RUNS[model][2], start=1):
        assert np.ptp(linux[:, k]) > 0, f"{name} does not move: the comparison would be empty"
        differ = np.flatnonzero(linux[:, k] != windows[:, k])
        assert differ.size == 0, (name, f"{differ.size} samples differ, first at t = "
                                  f"{linux[differ[0], 0]}")


@pytest.mark.parametrize("model", MODELS)
def test_aarch64_linux_library_under_qemu_agrees_with_x86_64(model, tmp_path):
    """The aarch64 library (glibc 2.17) runs under qemu-user with Debian's aarch64 glibc and gives
    the x86-64 library's outputs bit for bit: the models' arithmetic is IEEE-754 operations and the
    pure-Rust `libm` (rustc never contracts a * b + c into a fused multiply-add on its own)."""
    for tool in ("gcc", "qemu-aarch64"):
        if not shutil.which(tool):
            pytest.fail(f"{tool} is missing: scripts/test installs it (apt-get)")
    if not Path("/usr/aarch64-linux-gnu/lib/ld-linux-aarch64.so.1").exists():
        pytest.fail("libc6-arm64-cross is missing: scripts/test installs it (apt-get)")
    with zipfile.ZipFile(fmu3_path(model)) as z:
        z.extractall(tmp_path)
    src = DRIVER / "fmu3_run.c"
    subprocess.run(["gcc", "-O2", "-o", tmp_path / "fmu3_run", src, "-ldl"], check=True)
    zig = [str(REPO / ".venv" / "bin" / "python"), "-m", "ziglang", "cc"]
    subprocess.run([*zig, "-target", "aarch64-linux-gnu.2.17", "-O2", "-o",
                    str(tmp_path / "fmu3_run_arm"), str(src), "-ldl"], check=True)
    x86 = run_driver([str(tmp_path / "fmu3_run")], f"binaries/x86_64-linux/{model}.so", model,
                     tmp_path)
    arm = run_driver(["qemu-aarch64", str(tmp_path / "fmu3_run_arm")],
                     f"binaries/aarch64-linux/{model}.so", model, tmp_path)
    assert np.array_equal(x86, arm)
    for k, name in enumerate(WINE_RUNS[model][2], start=1):
        assert np.ptp(x86[:, k]) > 0, f"{name} does not move: the comparison would be empty"


def test_terminate_and_reset_follow_the_state_machine(instance):
    """FMI 3.0.2 section 4.2: after fmi3Terminate the values can still be read but no step is
    taken; fmi3Reset returns to Instantiated with the start values, from which a new run gives
    the first run's outputs again."""
    fmu, vr = instance
    first = steps(fmu, vr, 0.0, 20)
    fmu.terminate()
    assert fmu.getFloat64([vr["theta"]]) == [first[-1][0]]
    with pytest.raises(FMICallException):
        fmu.doStep(0.02, 1e-3)
    fmu.reset()
    with pytest.raises(FMICallException):  # Instantiated: no value to read yet
        fmu.getFloat64([vr["theta"]])
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    assert np.array_equal(steps(fmu, vr, 0.0, 20), first)


def test_a_failed_step_is_an_error_from_which_a_state_or_reset_recovers():
    """The test oscillator's step reaching `fail_at` fails on purpose: fmi3DoStep returns
    fmi3Error, the outputs keep the last good point, and the instance is in the error state
    (FMI 3.0.2 section 2.2.3: only fmi3SetFMUState, fmi3Reset or fmi3FreeInstance continue):
    another step, a set or fmi3Terminate is refused; a state saved before restores it."""
    path = fmu3_path("Oscillator")
    md = fmpy.read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmpy.extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="t")
    messages = []
    fmu.instantiate(logMessage=lambda env, status, cat, msg: messages.append(msg))
    fmu.setFloat64([vr["fail_at"]], [0.05])
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    h, t = 0.01, 0.0
    for _ in range(4):
        fmu.doStep(t, h)
        t += h
    saved, x_good = fmu.getFMUState(), fmu.getFloat64([vr["x"]])
    with pytest.raises(FMICallException) as e:
        fmu.doStep(t, 2 * h)
    assert e.value.status == ERROR and b"fmi3DoStep" in messages[-1]
    assert fmu.getFloat64([vr["x"]]) == x_good  # the last good communication point
    for call in (lambda: fmu.doStep(t, h), lambda: fmu.setFloat64([vr["force"]], [1.0]),
                 lambda: fmu.terminate()):
        with pytest.raises(FMICallException):
            call()
    fmu.setFMUState(saved)
    fmu.setFloat64([vr["force"]], [0.0])  # Step Mode again
    fmu.reset()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    assert fmu.doStep(0.0, h)[3] == pytest.approx(h)
    fmu.freeFMUState(saved)
    fmu.terminate()
    fmu.freeInstance()
