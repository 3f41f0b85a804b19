"""Builds the FMI 3.0 BouncingBall3 test FMU (tests/fixtures/bouncing-ball-fmi3: bouncing_ball.c
and its modelDescription.xml) with the C compiler, optionally with -D switches that break one
rule each (listed at the top of bouncing_ball.c). The prototypes come from FMPy's copy of the
FMI 3.0 headers, so the compiler checks every exported signature against the standard's."""
import os
import shutil
import subprocess
import zipfile

import pytest

from conftest import REPO

SOURCE = REPO / "tests" / "fixtures" / "bouncing-ball-fmi3"
BINARY = "binaries/x86_64-linux/BouncingBall3.so"


def fmi3_headers():
    fmpy = pytest.importorskip("fmpy")
    return os.path.join(os.path.dirname(fmpy.__file__), "c-code")


def build(directory, label, *defines):
    """`directory`/`label`.fmu built with `defines` (e.g. "NO_RESTORE")."""
    if shutil.which("gcc") is None:
        pytest.fail("gcc is needed to build the BouncingBall3 test FMU")
    lib = directory / f"{label}.so"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-O1",
                    "-I", fmi3_headers(), *(f"-D{d}" for d in defines), "-o", str(lib),
                    str(SOURCE / "bouncing_ball.c"), "-lm"], check=True)
    fmu = directory / f"{label}.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(SOURCE / "modelDescription.xml", "modelDescription.xml")
        z.write(lib, BINARY)
    return fmu
