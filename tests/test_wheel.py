"""The Python wheel (scripts/wheel, maturin): installed with pip into a fresh venv it gives the
CLI, both versions' FMUs and the Python API, and the README's quick starts run from it."""
import os
import re
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from conftest import REPO

README = REPO / "README.md"
SECTION = "### Install in one line (Python wheel)"


def quick_starts():
    """The sh and python blocks of the README's wheel section, in order."""
    text = README.read_text()
    start = text.index(SECTION)
    end = text.index("\n#", start + len(SECTION))
    return re.findall(r"```(sh|python)\n(.*?)```", text[start:end], flags=re.S)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    subprocess.run([str(REPO / "scripts" / "wheel")], check=True, cwd=REPO)
    wheels = sorted((REPO / "target" / "wheels").glob("actuator_fmu-*.whl"))
    assert len(wheels) == 1, wheels
    root = tmp_path_factory.mktemp("wheel-venv")
    venv.create(root / "venv", with_pip=True, clear=True)
    py = root / "venv" / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "--no-index",
                    "--disable-pip-version-check", str(wheels[0])], check=True)
    # A clean environment: the venv's bin first, nothing of this repository on the paths, and the
    # working directory outside the clone, so that only the installed wheel can answer.
    env = {"PATH": f"{root / 'venv' / 'bin'}:/usr/bin:/bin", "HOME": str(root)}
    return py, env, root


def test_readme_quick_starts_run_from_the_wheel(installed):
    py, env, root = installed
    blocks = quick_starts()
    assert [kind for kind, _ in blocks] == ["sh", "python"]
    for kind, code in blocks:
        if kind == "sh":
            code = code.replace("target/wheels/actuator_fmu-*.whl", "--no-index actuator_fmu")
            code = code.replace("pip install", f"{py} -m pip install --quiet --find-links "
                                f"{REPO / 'target' / 'wheels'}")
            run = subprocess.run(["bash", "-euo", "pipefail", "-c", code], env=env, cwd=root,
                                 capture_output=True, text=True)
        else:
            run = subprocess.run([str(py), "-c", code], env=env, cwd=root,
                                 capture_output=True, text=True)
        assert run.returncode == 0, f"{kind} block failed:\n{code}\n{run.stdout}\n{run.stderr}"
    # The python block prints the peak axial force of TwistedString's default run: the paper's
    # 1 kg load held against gravity needs at least m g = 9.81 N in the strings.
    assert float(re.search(r"peak axial force ([\d.]+) N", run.stdout).group(1)) > 9.81


def test_wheel_carries_both_versions_and_the_api(installed):
    py, env, root = installed
    code = """
import json, zipfile, actuator_fmu as af
out = {}
for model in af.MODELS:
    for v in (2, 3):
        with zipfile.ZipFile(af.fmu_path(model, fmi_version=v)) as z:
            md = z.read("modelDescription.xml").decode()
        out[f"{model}/{v}"] = 'fmiVersion="3.0"' in md if v == 3 else 'fmiVersion="2.0"' in md
try:
    af.simulate(af.fmu_path("EMPS"), set={"no_such_variable": 1.0}, stop=0.01)
    out["usage"] = None
except af.UsageError as e:
    out["usage"] = [e.status, str(e)]
print(json.dumps(out))
"""
    run = subprocess.run([str(py), "-c", code], env=env, cwd=root, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    import json
    out = json.loads(run.stdout)
    usage = out.pop("usage")
    assert out and all(out.values()), out
    assert usage[0] == 2 and "no_such_variable" in usage[1]
    assert os.path.isfile(root / "venv" / "bin" / "actuator-fmu")
