"""Shared helpers for the pytest suite: where the packaged FMUs are, building them when missing.

Import as `from conftest import fmu_path, REPO` (pytest puts tests/ on sys.path).
"""
import atexit
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
DIST = REPO / "dist"
TEST_FMUS = REPO / "target" / "fmus"
CLI = REPO / "target" / "release" / "actuator-fmu"
TEST_MODELS = {"Oscillator"}


def fmu_path(name: str) -> str:
    """Path of the packaged FMU `name` (dist/ for products, target/fmus/ for test models);
    runs scripts/build once when it is missing."""
    path = (TEST_FMUS if name in TEST_MODELS else DIST) / f"{name}.fmu"
    if not path.exists():
        subprocess.run([str(REPO / "scripts" / "build")], check=True)
    if not path.exists():
        raise FileNotFoundError(f"{path} was not built by scripts/build")
    return str(path)


def fmu3_path(name: str) -> str:
    """Path of the FMI 3.0 archive `name`.fmu (dist/fmi3/ for products, target/fmus/fmi3/ for
    test models); runs scripts/build once when it is missing."""
    path = (TEST_FMUS if name in TEST_MODELS else DIST) / "fmi3" / f"{name}.fmu"
    if not path.exists():
        subprocess.run([str(REPO / "scripts" / "build")], check=True)
    if not path.exists():
        raise FileNotFoundError(f"{path} was not built by scripts/build")
    return str(path)


_CLI_COPY = []


def cli_path() -> str:
    """Path of this test process's own copy of the release `actuator-fmu` binary (built by
    scripts/build). A copy, because tests running beside this one relink target/release (the
    wheel's maturin build removes and relinks the binary), and a test must not see it vanish."""
    if _CLI_COPY:
        return _CLI_COPY[0]
    for _ in range(120):
        if CLI.exists():
            break
        time.sleep(0.5)  # another process is relinking it
    else:
        subprocess.run([str(REPO / "scripts" / "build")], check=True)
    directory = Path(tempfile.mkdtemp(prefix="actuator-fmu-cli-"))
    atexit.register(shutil.rmtree, directory, ignore_errors=True)
    shutil.copy2(CLI, directory / CLI.name)
    _CLI_COPY.append(str(directory / CLI.name))
    return _CLI_COPY[0]


def run_cli(*args, timeout=120):
    """`actuator-fmu ARGS` (each turned into a string), its output captured as text."""
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


def read_csv_floats(path):
    """(header, rows as a float array) of a CSV file `simulate` wrote."""
    import csv
    import numpy as np
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


os.environ.setdefault("ACTUATOR_FMU_REPO", str(REPO))


@pytest.fixture(scope="session")
def toy(tmp_path_factory):
    """toy(name, version=2): the toy FMU `name` of tests/fixtures/toy-fmus (FMI 2.0 or 3.0),
    built with gcc into a session temporary directory the first time it is asked for."""
    import toy_fmus
    directory = tmp_path_factory.mktemp("toy-fmus")
    built = {}

    def get(name, version=2):
        if (name, version) not in built:
            built[name, version] = toy_fmus.build(directory, name, version)
        return built[name, version]
    return get


# Under pytest-xdist (scripts/test: -n auto --dist loadgroup) a test file runs whole on one worker,
# so that its module fixtures are made once; the files below hold long tests that share nothing
# (no module fixture, no state), so their tests are spread over the workers one by one.
SPREAD_OVER_WORKERS = {"test_gap.py", "test_gap_records.py", "test_eval_scripts.py"}


# Regression tests of a minute or more each (marked `long`) run in scripts/test-long, which passes
# --long; scripts/test skips them to stay within its time budget.
LONG_SKIPPED = pytest.mark.skip(reason="a long regression test: scripts/test-long runs it")


def pytest_addoption(parser):
    parser.addoption("--long", action="store_true",
                     help="run the tests marked long (scripts/test-long)")


def pytest_configure(config):
    config.addinivalue_line("markers", "long: a regression test of a minute or more, "
                            "run by scripts/test-long")


def pytest_collection_modifyitems(config, items):
    run_long = config.getoption("--long")
    for item in items:
        if item.path.name not in SPREAD_OVER_WORKERS:
            item.add_marker(pytest.mark.xdist_group(item.path.name))
        if "long" in item.keywords and not run_long:
            item.add_marker(LONG_SKIPPED)
