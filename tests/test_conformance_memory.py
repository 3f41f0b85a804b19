"""Memory safety, short version: scripts/memcheck runs the C driver
tests/drivers/memcheck/fmu_cycle.c under valgrind memcheck (--error-exitcode=1,
--leak-check=full, definite and indirect leaks are errors) for 20 full instance life cycles of
every FMU. The long run (1,000 cycles) is `scripts/memcheck` without arguments."""
import shutil
import subprocess

import pytest

from conftest import REPO, fmu_path


@pytest.mark.skipif(shutil.which("valgrind") is None or shutil.which("gcc") is None,
                    reason="valgrind or gcc not installed")
def test_memcheck_short():
    fmus = [fmu_path(n) for n in ("HydraulicJoint", "TwistedString", "Oscillator")]
    r = subprocess.run([str(REPO / "scripts" / "memcheck"), "--reps", "20", "--steps", "10", *fmus],
                       capture_output=True, text=True, timeout=300, cwd=REPO)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    for name in ("HydraulicJoint", "TwistedString", "Oscillator"):
        assert f"{name}: memcheck clean" in r.stdout
    # the native run reports a bounded peak heap per instance
    peaks = [int(line.split("peak heap of one instance ")[1].split()[0])
             for line in r.stdout.splitlines() if "peak heap of one instance" in line]
    assert len(peaks) >= 3 and all(0 < p < 10_000_000 for p in peaks[::2]), peaks
