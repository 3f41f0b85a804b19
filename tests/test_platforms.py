"""The shipped FMUs carry real binaries for Linux, Windows and macOS.

- every dist/*.fmu holds binaries/linux64/*.so, binaries/win64/*.dll, binaries/darwin64/*.dylib;
- each binary (each slice of the universal macOS one) exports exactly the FMI 2.0 Co-Simulation
  functions, listed below from the standard's header fmi2Functions.h, no more and no fewer;
- the linux64 binary needs no GLIBC symbol version above 2.17 (RHEL 7, Ubuntu 14.04 and later);
- the darwin64 binary is universal: x86-64 and arm64;
- the win64 DLL runs under Wine (a C driver cross-compiled with mingw-w64) and its outputs are
  bit-identical to the linux64 binary's, run by the same driver compiled natively, with every
  candidate effect off and on (the FMUs compute transcendental functions with the `libm` crate,
  not the platform's: tests/test_determinism.py); in Co-Simulation and in Model Exchange (a
  driver integrating the states with the FMU's directional derivatives).
macOS binaries cannot be executed here: they are checked by their Mach-O headers, load commands
and export tries (read with goblin by `actuator-fmu validate`).
"""
import json
import shutil
import subprocess
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO, cli_path, fmu_path

MODELS = ["HydraulicJoint", "TwistedString"]
# FMI 2.0.4, fmi2Functions.h: the common functions and those of Co-Simulation and of Model
# Exchange (every binary exports both sets; a model without Model Exchange refuses its calls).
FMI2_ALL = sorted("""
fmi2GetTypesPlatform fmi2GetVersion fmi2SetDebugLogging fmi2Instantiate fmi2FreeInstance
fmi2SetupExperiment fmi2EnterInitializationMode fmi2ExitInitializationMode fmi2Terminate
fmi2Reset fmi2GetReal fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetReal fmi2SetInteger
fmi2SetBoolean fmi2SetString fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate
fmi2SerializedFMUstateSize fmi2SerializeFMUstate fmi2DeSerializeFMUstate
fmi2GetDirectionalDerivative fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives
fmi2DoStep fmi2CancelStep fmi2GetStatus fmi2GetRealStatus fmi2GetIntegerStatus
fmi2GetBooleanStatus fmi2GetStringStatus
fmi2EnterEventMode fmi2NewDiscreteStates fmi2EnterContinuousTimeMode fmi2CompletedIntegratorStep
fmi2SetTime fmi2SetContinuousStates fmi2GetDerivatives fmi2GetEventIndicators
fmi2GetContinuousStates fmi2GetNominalsOfContinuousStates""".split())
DRIVER = REPO / "tests" / "drivers" / "platform"
# (input, value held, outputs compared) per model: a step of the set point.
RUNS = {
    "HydraulicJoint": ("theta_ref", 0.5, ["theta", "x_left", "p1_left", "T_left"]),
    "TwistedString": ("theta_motor_ref", 600.0, ["p", "theta_motor", "current"]),
}


def validate_json(model):
    out = subprocess.run([cli_path(), "validate", "--json", fmu_path(model)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    (report,) = json.loads(out.stdout)
    return {b["entry"]: b for b in report["binaries"]}


@pytest.mark.parametrize("model", MODELS)
def test_every_shipped_fmu_holds_linux_windows_and_macos_binaries(model):
    names = set(zipfile.ZipFile(fmu_path(model)).namelist())
    for entry in (f"binaries/linux64/{model}.so", f"binaries/win64/{model}.dll",
                  f"binaries/darwin64/{model}.dylib"):
        assert entry in names, sorted(n for n in names if n.startswith("binaries/"))


@pytest.mark.parametrize("model", MODELS)
def test_each_binary_exports_exactly_the_fmi2_functions(model):
    binaries = validate_json(model)
    expect = {"linux64": ("ELF", ["x86_64"]), "win64": ("PE", ["x86_64"]),
              "darwin64": ("Mach-O", ["x86_64", "aarch64"])}
    assert sorted(e.split("/")[1] for e in binaries) == sorted(expect)
    for entry, b in binaries.items():
        fmt, archs = expect[entry.split("/")[1]]
        assert b["format"] == fmt, entry
        assert [s["architecture"] for s in b["slices"]] == archs, entry
        for s in b["slices"]:
            assert s["exports"] == FMI2_ALL, (entry, s["architecture"],
                                             set(s["exports"]) ^ set(FMI2_ALL))


@pytest.mark.parametrize("model", MODELS)
def test_linux_binary_needs_glibc_2_17_at_most(model, tmp_path):
    b = validate_json(model)[f"binaries/linux64/{model}.so"]
    version = tuple(int(x) for x in b["max_glibc"].removeprefix("GLIBC_").split("."))
    assert version <= (2, 17), b["max_glibc"]
    # the same read by binutils, independently of goblin
    if shutil.which("objdump"):
        so = tmp_path / "lib.so"
        so.write_bytes(zipfile.ZipFile(fmu_path(model)).read(f"binaries/linux64/{model}.so"))
        text = subprocess.run(["objdump", "-T", str(so)], capture_output=True, text=True).stdout
        versions = {tuple(int(x) for x in v.split(".")) for v in
                    __import__("re").findall(r"GLIBC_([0-9.]+)", text)}
        assert versions and max(versions) <= (2, 17), sorted(versions)


def variable_refs(model):
    from fmpy import read_model_description
    md = read_model_description(fmu_path(model))
    return md.guid, {v.name: v.valueReference for v in md.modelVariables}


def me_arguments(model):
    """NZ, STATE_VRS, DERIVATIVE_VRS of the Model Exchange driver, from the model description."""
    from fmpy import read_model_description
    md = read_model_description(fmu_path(model))
    states = ",".join(str(d.variable.derivative.valueReference) for d in md.derivatives)
    ders = ",".join(str(d.variable.valueReference) for d in md.derivatives)
    return md.numberOfEventIndicators, states, ders


def run_driver(cmd, lib, model, cwd, effects, stop=0.5, h=1e-3, me=False):
    guid, vr = variable_refs(model)
    inp, value, outs = RUNS[model]
    switches = [f"+{vr[name]}" for name in vr if effects and name.endswith(".enabled")]
    if me:
        nz, states, ders = me_arguments(model)
        args = [*cmd, lib, guid, str(nz), str(stop), str(h), str(vr[inp]), str(value), states,
                ders, *switches, *[str(vr[o]) for o in outs]]
    else:
        args = [*cmd, lib, guid, str(stop), str(h), str(vr[inp]), str(value), *switches,
                *[str(vr[o]) for o in outs]]
    env = {"WINEDEBUG": "-all", "PATH": "/usr/bin:/bin", "HOME": str(Path.home())}
    res = subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=600, env=env)
    # The driver prints a message on each of its failures; a failure with nothing on stderr is
    # Wine failing to start the program (seen once in ~20 runs while its wineserver from the
    # previous test shut down). Retry that case, with Wine's own messages on.
    for _ in range(2):
        if res.returncode == 0 or res.stderr.strip() or cmd[0] != "wine":
            break
        time.sleep(1)
        res = subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=600,
                             env={**env, "WINEDEBUG": "err+all"})
    assert res.returncode == 0, res.stderr[-2000:]
    data = np.array([[float(x) for x in line.split(",")] for line in res.stdout.split()])
    assert data.shape == (int(round(stop / h)), 1 + len(outs))
    return data


def compile_drivers(model, driver, tmp_path):
    for tool in ("gcc", "x86_64-w64-mingw32-gcc", "wine"):
        if not shutil.which(tool):
            pytest.fail(f"{tool} is missing: scripts/test installs it (apt-get)")
    with zipfile.ZipFile(fmu_path(model)) as z:
        z.extractall(tmp_path)
    src = DRIVER / f"{driver}.c"
    subprocess.run(["gcc", "-O2", "-o", tmp_path / driver, src, "-ldl", "-lm"], check=True)
    subprocess.run(["x86_64-w64-mingw32-gcc", "-O2", "-o", tmp_path / f"{driver}.exe", src],
                   check=True)
    subprocess.run(["x86_64-w64-mingw32-gcc", "-shared", "-O2", "-o",
                    tmp_path / "bcryptprimitives.dll", DRIVER / "bcryptprimitives.c", "-ladvapi32"],
                   check=True)


@pytest.mark.parametrize("effects", [False, True], ids=["effects-off", "effects-on"])
@pytest.mark.parametrize("model", MODELS)
def test_windows_dll_under_wine_computes_the_linux_binarys_bits(model, effects, tmp_path):
    compile_drivers(model, "fmu_run", tmp_path)
    linux = run_driver([str(tmp_path / "fmu_run")], f"binaries/linux64/{model}.so", model,
                       tmp_path, effects)
    windows = run_driver(["wine", str(tmp_path / "fmu_run.exe")],
                         f"binaries\\win64\\{model}.dll", model, tmp_path, effects)
    assert_same_bits(model, linux, windows)


@pytest.mark.parametrize("model", MODELS)
def test_windows_dll_under_wine_model_exchange_computes_the_linux_binarys_bits(model, tmp_path):
    """FMI 2.0 Model Exchange, every effect on: the same C driver (linearly implicit Euler on
    the FMU's states with the Jacobian from fmi2GetDirectionalDerivative, time events of the
    sampled controller, event indicators) on the win64 DLL under Wine and on the linux64 binary
    gives the same output bits."""
    compile_drivers(model, "fmu_me_run", tmp_path)
    linux = run_driver([str(tmp_path / "fmu_me_run")], f"binaries/linux64/{model}.so", model,
                       tmp_path, True, stop=0.2, me=True)
    windows = run_driver(["wine", str(tmp_path / "fmu_me_run.exe")],
                         f"binaries\\win64\\{model}.dll", model, tmp_path, True, stop=0.2,
                         me=True)
    assert_same_bits(model, linux, windows)


def assert_same_bits(model, linux, windows):
    assert np.array_equal(linux[:, 0], windows[:, 0])
    for k, name in enumerate(RUNS[model][2], start=1):
        assert np.ptp(linux[:, k]) > 0, f"{name} does not move: the comparison would be empty"
        differ = np.flatnonzero(linux[:, k] != windows[:, k])
        assert differ.size == 0, (name, f"{differ.size} samples differ, first at t = "
                                  f"{linux[differ[0], 0]}: {linux[differ[0], k]!r} (linux64) "
                                  f"vs {windows[differ[0], k]!r} (win64)")
