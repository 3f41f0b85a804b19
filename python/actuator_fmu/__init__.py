"""actuator-fmu from Python: the shipped FMUs and the ``actuator-fmu`` CLI as functions that
return plain data (dicts, lists of floats).

>>> import actuator_fmu as af
>>> path = af.fmu_path("HydraulicJoint", fmi_version=3)
>>> af.validate(path)["findings"]
[]
>>> res = af.simulate(path, stop=0.5)
>>> list(res)[:3]
['time', 'theta', 'omega']

Every function runs the CLI installed with this package (``actuator-fmu --help`` lists all it
can do); a refused input raises :class:`UsageError` with the CLI's one-line message, any other
failure :class:`CliError`.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from importlib import resources
from typing import Dict, Iterable, List, Mapping, Optional, Union

__all__ = [
    "MODELS",
    "CliError",
    "UsageError",
    "cli_path",
    "fmu_path",
    "gap",
    "simulate",
    "validate",
]

#: The models whose FMUs this package carries (FMI 2.0 and FMI 3.0 each).
MODELS = ("HydraulicJoint", "TwistedString", "EMPS")

PathLike = Union[str, "os.PathLike[str]"]

# The CLI answers bad input with exit status 2 and one message (its documented contract).
_EXIT_BAD_INPUT = 2
# `validate` exits 1 when an FMU has findings: a result, not a failure of the call.
_EXIT_FINDINGS = 1


class CliError(RuntimeError):
    """The CLI failed (status other than 0, or 1 for validate's findings)."""

    def __init__(self, args: List[str], status: int, stderr: str):
        self.args_run = args
        self.status = status
        self.stderr = stderr
        super().__init__(f"actuator-fmu exited with status {status}: {stderr.strip()}")


class UsageError(CliError, ValueError):
    """The CLI refused the input (exit status 2), e.g. a missing file or an unknown variable."""


def cli_path() -> str:
    """Path of the ``actuator-fmu`` executable installed with this package (the environment's
    scripts folder first, so that another one on PATH does not shadow it)."""
    exe = "actuator-fmu.exe" if sys.platform == "win32" else "actuator-fmu"
    here = os.path.join(sysconfig.get_path("scripts"), exe)
    if os.path.isfile(here):
        return here
    found = shutil.which("actuator-fmu")
    if found is None:
        raise FileNotFoundError("the actuator-fmu executable is not installed with this package")
    return found


def fmu_path(model: str, fmi_version: int = 2) -> str:
    """Path of a shipped FMU: ``model`` one of :data:`MODELS`, ``fmi_version`` 2 or 3."""
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; the package carries {', '.join(MODELS)}")
    if fmi_version not in (2, 3):
        raise ValueError(f"fmi_version must be 2 or 3, not {fmi_version!r}")
    ref = resources.files(__name__) / "fmus" / f"fmi{fmi_version}" / f"{model}.fmu"
    if not ref.is_file():
        raise FileNotFoundError(f"{model}.fmu (FMI {fmi_version}.0) is not in this package")
    return str(ref)


def _run(args: List[str], ok: Iterable[int] = (0,)) -> subprocess.CompletedProcess:
    cmd = [cli_path(), *args]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode in ok:
        return done
    if done.returncode == _EXIT_BAD_INPUT:
        raise UsageError(cmd, done.returncode, done.stderr)
    raise CliError(cmd, done.returncode, done.stderr)


def _settings(values: Optional[Mapping[str, object]]) -> List[str]:
    args: List[str] = []
    for name, value in (values or {}).items():
        text = ("true" if value else "false") if isinstance(value, bool) else str(value)
        args += ["--set", f"{name}={text}"]
    return args


def validate(fmu: PathLike, effects: bool = False, timeout: float = 120) -> Dict[str, object]:
    """Check one FMU against its version of the standard: the CLI's JSON report of that FMU
    (``findings``, ``notes``, ``binaries``...; see ``actuator-fmu validate --help``)."""
    args = ["validate", "--json", "--timeout", str(timeout), os.fspath(fmu)]
    if effects:
        args.insert(1, "--effects")
    done = _run(args, ok=(0, _EXIT_FINDINGS))
    reports = json.loads(done.stdout)
    return reports[0]


def simulate(
    fmu: PathLike,
    data: Optional[PathLike] = None,
    stop: Optional[float] = None,
    step: Optional[float] = None,
    set: Optional[Mapping[str, object]] = None,
    interface: Optional[str] = None,
    tolerance: Optional[float] = None,
) -> Dict[str, List[float]]:
    """Simulate an FMU (inputs from the CSV ``data``, values ``set`` before initialization) and
    return each recorded column, ``time`` first, as a list of floats."""
    with tempfile.TemporaryDirectory(prefix="actuator-fmu-") as tmp:
        out = os.path.join(tmp, "out.csv")
        args = ["simulate", os.fspath(fmu), "--out", out, *_settings(set)]
        for flag, value in (("--data", data), ("--stop", stop), ("--step", step),
                            ("--interface", interface), ("--tolerance", tolerance)):
            if value is not None:
                args += [flag, os.fspath(value) if flag == "--data" else str(value)]
        _run(args)
        with open(out, newline="") as f:
            rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [float(row[i]) for row in body] for i, name in enumerate(header)}


def gap(
    fmu: PathLike,
    data: PathLike,
    out: Optional[PathLike] = None,
    set: Optional[Mapping[str, object]] = None,
    effects: Optional[Iterable[str]] = None,
    rounds: Optional[int] = None,
) -> Dict[str, object]:
    """Run the gap workflow on measured ``data`` and return its ``report.json`` as a dict.
    ``out`` keeps the report, its Markdown and plots in that directory (else they are removed)."""
    with tempfile.TemporaryDirectory(prefix="actuator-fmu-gap-") as tmp:
        target = os.fspath(out) if out is not None else tmp
        args = ["gap", os.fspath(fmu), "--data", os.fspath(data), "--out", target, "--quiet",
                *_settings(set)]
        if effects is not None:
            args += ["--effects", ",".join(effects)]
        if rounds is not None:
            args += ["--rounds", str(rounds)]
        _run(args)
        with open(os.path.join(target, "report.json")) as f:
            return json.load(f)
