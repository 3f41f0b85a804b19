"""Our FMUs compute the same bits on every CPU and platform.

The platform's libm picks its code paths by CPU (glibc: FMA or not) and differs on Windows and
macOS, so the FMUs compute transcendental functions with the `libm` crate compiled into the
binary (workspace clippy.toml forbids `f64::exp` and the like in FMU code). Checked here:
- no binary of a shipped FMU (FMI 2.0 and 3.0) imports a transcendental function from the platform;
- both FMUs (every candidate effect off, and on) give bit-identical outputs with glibc's default
  code paths and with its FMA/AVX2 paths switched off (GLIBC_TUNABLES);
- tests/test_platforms.py: the win64 DLL under Wine gives the linux64 binary's bits.
"""
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest

from conftest import fmu3_path, fmu_path

MODELS = ["HydraulicJoint", "TwistedString", "EMPS"]
# C99 <math.h> transcendental functions (and their float/long double forms): none may be imported.
MATH = {f + s for f in """exp exp2 expm1 log log2 log10 log1p pow sin cos tan sincos asin acos
atan atan2 sinh cosh tanh asinh acosh atanh hypot cbrt fma erf erfc tgamma lgamma""".split()
        for s in ("", "f", "l")}
NO_FMA = "glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX512F"
# A sinusoid on the set point (the input that drives each model through its range).
DRIVE = {"HydraulicJoint": ("theta_ref", 0.6), "TwistedString": ("theta_motor_ref", 900.0),
         "EMPS": ("qg", 0.1)}


def imported_symbols(binary: Path) -> set:
    """Names a binary imports, read with LLVM's tools (ELF, PE and universal Mach-O)."""
    data = binary.read_bytes()[:4]
    if data == b"MZ\x90\x00" or data[:2] == b"MZ":
        text = subprocess.run(["llvm-objdump", "-p", str(binary)], capture_output=True,
                              text=True, check=True).stdout
        return {line.split()[-1] for line in text.splitlines()
                if line.strip() and line.split()[0].isdigit() and len(line.split()) == 2}
    text = subprocess.run(["llvm-nm", "-D" if data == b"\x7fELF" else "--arch=all",
                           "--undefined-only", str(binary)],
                          capture_output=True, text=True, check=True).stdout
    names = {line.split()[-1].split("@")[0] for line in text.splitlines()
             if line.strip() and not line.endswith(":")}
    return {n[1:] if data != b"\x7fELF" and n.startswith("_") else n for n in names}


@pytest.mark.parametrize("version", ["2.0", "3.0"])
@pytest.mark.parametrize("model", MODELS)
def test_no_binary_imports_the_platforms_math(model, version, tmp_path):
    with zipfile.ZipFile(fmu_path(model) if version == "2.0" else fmu3_path(model)) as z:
        binaries = [n for n in z.namelist() if n.startswith("binaries/") and not n.endswith("/")]
        z.extractall(tmp_path, binaries)
    assert len(binaries) >= 3, binaries
    for name in binaries:
        imports = imported_symbols(tmp_path / name)
        assert imports, f"{name}: no imports read; the check would be empty"
        assert not imports & MATH, (name, sorted(imports & MATH))


RUN = r"""
import hashlib, json, sys
import numpy as np
from fmpy import read_model_description, simulate_fmu
fmu, inp, amp, effects = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4] == "on"
md = read_model_description(fmu)
start = {v.name: True for v in md.modelVariables if effects and v.name.endswith(".enabled")}
t = np.linspace(0.0, 2.0, 2001)
signal = np.array(list(zip(t, amp * np.sin(3.0 * t))), dtype=[("time", float), (inp, float)])
res = simulate_fmu(fmu, stop_time=2.0, output_interval=1e-3, input=signal, start_values=start,
                   fmi_type="CoSimulation")
outputs = [n for n in res.dtype.names if n != "time"]
print(json.dumps({n: hashlib.sha256(np.ascontiguousarray(res[n]).tobytes()).hexdigest()
                  for n in outputs} | {"_moves": [n for n in outputs if np.ptp(res[n]) > 0]}))
"""


def output_hashes(model: str, effects: str, tunables: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "GLIBC_TUNABLES"}
    if tunables:
        env["GLIBC_TUNABLES"] = tunables
    inp, amp = DRIVE[model]
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "run.py"
        script.write_text(RUN)
        res = subprocess.run([sys.executable, str(script), fmu_path(model), inp, str(amp), effects],
                             capture_output=True, text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("effects", ["off", "on"])
@pytest.mark.parametrize("model", MODELS)
def test_outputs_are_bit_identical_without_glibcs_fma_paths(model, effects):
    default = output_hashes(model, effects, None)
    no_fma = output_hashes(model, effects, NO_FMA)
    assert len(default["_moves"]) >= 3, default["_moves"]
    differ = [n for n in default if default[n] != no_fma[n]]
    assert not differ, f"outputs that change with {NO_FMA}: {differ}"
