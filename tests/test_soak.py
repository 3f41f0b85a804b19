"""Issue 8, item 6, short version: 2*10^4 communication steps of each FMU with random inputs
inside their ranges (tests/drivers/hostdrivers, soak-driver): every step fmi2OK, every output finite, and the
balances the outputs allow. The long run (10^6 steps) is scripts/soak.

Balances (see tests/drivers/hostdrivers/src/bin/soak-driver.rs):
- Oscillator, damping 0: energy, E(t+h) - E(t) = F (x(t+h) - x(t)) with F held over the step;
  exact for the model, so the accumulated residual is the solver error (rtol 1e-6 of max E).
- HydraulicJoint: link angular momentum, paper eq. (1), the tension impulse by the trapezoidal
  rule on the 1 ms grid: closes to the quadrature error, bounded here at 1e-3 of the impulse.
"""
import re
import subprocess

import pytest

from conftest import REPO, fmu_path

DRIVER = REPO / "tests" / "drivers" / "hostdrivers"


@pytest.fixture(scope="module")
def driver():
    subprocess.run(["cargo", "build", "--release", "--quiet", "--manifest-path", str(DRIVER / "Cargo.toml"),
                    "--target-dir", str(REPO / "target")], check=True, cwd=REPO, timeout=900)
    return str(REPO / "target" / "release" / "soak-driver")


def soak(driver, name, steps=20000, seed=7):
    r = subprocess.run([driver, "--steps", str(steps), "--seed", str(seed), fmu_path(name)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "all fmi2OK, all outputs finite" in r.stdout
    return {m.group(1): float(m.group(2)) for m in re.finditer(r"^BALANCE (\w+) (\S+)$", r.stdout, re.M)}


@pytest.mark.parametrize("name", ["HydraulicJoint", "TwistedString", "Oscillator"])
def test_short_soak(driver, name):
    balances = soak(driver, name)
    if name == "Oscillator":
        assert balances["energy"] < 1e-6
    if name == "HydraulicJoint":
        assert balances["momentum"] < 1e-3
