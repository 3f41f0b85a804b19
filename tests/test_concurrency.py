"""Instances in parallel threads share nothing: 8 threads, each with its own instance of each FMU (HydraulicJoint,
TwistedString, Oscillator, one loaded binary per FMU shared by all threads), each thread with
different inputs; every output at every step bit-identical to the same simulation run alone.
The driver is the standalone Rust crate tests/drivers/hostdrivers (bin concurrency-driver, using the host crate)."""
import subprocess

from conftest import REPO, fmu_path

DRIVER = REPO / "tests" / "drivers" / "hostdrivers"


def test_eight_threads_bit_identical_to_lone_runs():
    subprocess.run(["cargo", "build", "--release", "--quiet", "--manifest-path", str(DRIVER / "Cargo.toml"),
                    "--target-dir", str(REPO / "target")], check=True, cwd=REPO, timeout=900)
    fmus = [fmu_path(n) for n in ("HydraulicJoint", "TwistedString", "Oscillator")]
    r = subprocess.run([str(REPO / "target" / "release" / "concurrency-driver"), "--threads", "8",
                        "--steps", "2000", "--rounds", "2", *fmus],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "0 differences" in r.stdout and "bit-identical" in r.stdout, r.stdout
