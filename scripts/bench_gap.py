"""Gap-workflow part of scripts/bench: `actuator-fmu gap` on a 10 s trace sampled at 1 kHz
(HydraulicJoint, one hidden effect, 1% noise, base parameters drawn off their defaults; made by
examples/gapgen.py through FMPy), timed with its own split between simulation and fitting, against
a Python baseline in the same run: the same FMU calibrated over the same default calibration
parameters through FMPy and scipy.optimize.least_squares (base model only, which is a subset of
the work the Rust workflow does, so the ratio is a lower bound of the speedup)."""
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402

QUICK = "--quick" in sys.argv
MODEL = "HydraulicJoint"
DURATION = 2.0 if QUICK else 10.0


def python_baseline(ds, names, vs):
    """Weighted least squares over `names` (scaled to [0, 1] within min/max) via FMPy."""
    x0 = np.array([vs[n]["start"] for n in names])
    lo = np.array([vs[n]["min"] for n in names])
    hi = np.array([vs[n]["max"] for n in names])
    outs = list(ds["outputs"])
    w = {n: 1.0 / max(ds["noise_sigma"][n], 1e-12) for n in outs}
    evals = [0]

    def residual(z):
        evals[0] += 1
        p = {n: float(lo[i] + z[i] * (hi[i] - lo[i])) for i, n in enumerate(names)}
        res = gapgen.simulate(MODEL, ds["time"], ds["inputs"], p, outputs=outs)
        return np.concatenate([(res[n] - ds["outputs"][n]) * w[n] for n in outs])

    z0 = (x0 - lo) / (hi - lo)
    t0 = time.perf_counter()
    sol = least_squares(residual, z0, bounds=(0.0, 1.0), x_scale="jac", max_nfev=200)
    return time.perf_counter() - t0, evals[0], sol


def main():
    ds = gapgen.make(MODEL, seed=7, hidden=("internal_leakage",), duration=DURATION)
    vs = gapgen.variables(MODEL)
    names = gapgen.calibrated(MODEL)
    with tempfile.TemporaryDirectory() as d:
        data = Path(d) / "trace.csv"
        gapgen.write_csv(ds, data)
        out = Path(d) / "report"
        t0 = time.perf_counter()
        subprocess.run([str(REPO / "target/release/actuator-fmu"), "gap", str(REPO / f"dist/{MODEL}.fmu"),
                        "--data", str(data), "--out", str(out)], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        report = json.loads((out / "report.json").read_text())
    timing = report["timing"]
    print(f"gap time {wall:.1f} s wall for a {DURATION:g} s trace at 1 kHz ({MODEL}, hidden "
          f"internal_leakage, named {report['named']}); split: simulate {timing['simulate_s']:.1f} s, "
          f"fit {timing['fit_s']:.1f} s, total {timing['total_s']:.1f} s", flush=True)
    t_py, n_py, sol = python_baseline(ds, names, vs)
    print(f"gap speedup {t_py / wall:.1f}x against the Python baseline (FMPy + "
          f"scipy.optimize.least_squares calibrating {', '.join(names)} on the base model only: "
          f"{t_py:.1f} s, {n_py} simulations; the Rust workflow did calibration, screening and refits "
          f"in {wall:.1f} s)", flush=True)


if __name__ == "__main__":
    main()
