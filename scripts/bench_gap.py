"""Gap-workflow part of scripts/bench: `actuator-fmu gap` on a 10 s trace sampled at 1 kHz
(HydraulicJoint, one hidden effect, 1% noise, base parameters drawn off their defaults; made by
examples/gapgen.py through FMPy), timed with its own split between simulation and fitting, against
a Python workflow in the same run that does the workflow's first steps on the same FMU and data with
FMPy and SciPy (calibrate, screen every candidate, refit the best, held-out check; see
PythonWorkflow). gap goes on with a second round, the base re-check and the final fit for the
intervals, so a second line compares the wall time per simulation of the two.
--quick: a 2 s trace; --smoke (the tests): 0.5 s, to check that every part runs and prints.

A further line times gap on a real record, the EMPS estimation record (24 841 samples at 1 kHz,
24.8 s; converted by scripts/emps_csv.py from ../shared/data/emps/, skipped without it), default
candidates, as examples/emps/run.py runs it; the target is 60 s on 2 cores. --emps: that line
(scripts/bench runs it as `gap-emps`)."""
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
SMOKE = "--smoke" in sys.argv  # the tests: that every part runs and prints, not a measurement
MODEL = "HydraulicJoint"
DURATION = 0.5 if SMOKE else 2.0 if QUICK else 10.0


class PythonWorkflow:
    """The steps of `actuator-fmu gap`, written with FMPy and SciPy: calibrate the default
    calibration parameters on the training part (first 70 %), screen every candidate effect by a
    linearised test (the chi-square a Gauss-Newton step over the base and the effect parameters
    would explain, from the effect switched on at the geometric middle of its range), refit the
    most promising candidate with the base, and check the refit on the held-out last 30 %."""

    def __init__(self, ds, model):
        self.ds, self.model = ds, model
        self.vs = gapgen.variables(model)
        self.outs = list(ds["outputs"])
        self.w = {n: 1.0 / max(ds["noise_sigma"][n], 1e-12) for n in self.outs}
        self.n_train = int(0.7 * len(ds["time"]))
        self.simulations = 0

    def residual(self, params, part):
        self.simulations += 1
        res = gapgen.simulate(self.model, self.ds["time"], self.ds["inputs"], params,
                              outputs=self.outs)
        sl = slice(0, self.n_train) if part == "train" else slice(self.n_train, None)
        return np.concatenate([((res[n] - self.ds["outputs"][n]) * self.w[n])[sl]
                               for n in self.outs])

    def fit(self, names, fixed):
        """Bounded least squares over `names`, scaled to [0, 1] within min/max."""
        lo = np.array([self.vs[n]["min"] for n in names])
        hi = np.array([self.vs[n]["max"] for n in names])
        x0 = np.array([fixed.get(n, self.vs[n]["start"]) for n in names])
        to_p = lambda z: {**fixed, **{n: float(lo[i] + z[i] * (hi[i] - lo[i]))
                                      for i, n in enumerate(names)}}
        sol = least_squares(lambda z: self.residual(to_p(z), "train"), (x0 - lo) / (hi - lo),
                            bounds=(0.0, 1.0), x_scale="jac", max_nfev=200)
        return to_p(sol.x), float(sol.cost * 2)

    def screen(self, base, names, effect, params):
        """Chi-square a Gauss-Newton step over base + effect parameters would explain."""
        on = {**base, f"{effect}.enabled": True}
        for q in params:
            lo, hi = self.vs[q]["min"], self.vs[q]["max"]
            on[q] = float(np.sqrt(lo * hi)) if lo > 0 else 0.5 * (lo + hi)
        r0 = self.residual(on, "train")
        cols = []
        for q in list(names) + list(params):
            d = 1e-4 * (self.vs[q]["max"] - self.vs[q]["min"])
            cols.append((self.residual({**on, q: on[q] + d}, "train") - r0) / d)
        step, *_ = np.linalg.lstsq(np.array(cols).T, -r0, rcond=None)
        explained = float(r0 @ r0 - np.sum((r0 + np.array(cols).T @ step) ** 2))
        return on, explained

    def run(self):
        names = gapgen.calibrated(self.model)
        t0 = time.perf_counter()
        base, chi2_base = self.fit(names, {})
        scores = {e: self.screen(base, names, e, ps)
                  for e, ps in gapgen.effects(self.model).items()}
        best = max(scores, key=lambda e: scores[e][1])
        ps = gapgen.effects(self.model)[best]
        refit, chi2_refit = self.fit(names + ps, {**scores[best][0]})
        hold_base = self.residual(base, "holdout")
        hold_refit = self.residual(refit, "holdout")
        return dict(seconds=time.perf_counter() - t0, simulations=self.simulations, best=best,
                    chi2=(chi2_base, chi2_refit),
                    holdout=(float(hold_base @ hold_base), float(hold_refit @ hold_refit)))


def main():
    ds = gapgen.make(MODEL, seed=7, hidden=("internal_leakage",), duration=DURATION)
    names = gapgen.calibrated(MODEL)
    with tempfile.TemporaryDirectory() as d:
        data = Path(d) / "trace.csv"
        gapgen.write_csv(ds, data)
        out = Path(d) / "report"
        def gap(*extra):
            t0 = time.perf_counter()
            subprocess.run([str(REPO / "target/release/actuator-fmu"), *extra, "gap",
                            str(REPO / f"dist/{MODEL}.fmu"), "--data", str(data), "--out", str(out)],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            return time.perf_counter() - t0

        wall = gap()
        report = json.loads((out / "report.json").read_text())
        # The same run without the supervising process (crash/hang reports, cleanup on signals):
        # the cost of isolation, same work in the same session.
        bare = gap("--in-process")
    timing = report["timing"]
    print(f"gap time {wall:.1f} s wall for a {DURATION:g} s trace at 1 kHz ({MODEL}, hidden "
          f"internal_leakage, named {report['named']}); split: simulate {timing['simulate_s']:.1f} s, "
          f"fit {timing['fit_s']:.1f} s, total {timing['total_s']:.1f} s", flush=True)
    print(f"gap isolation cost {100 * (wall / bare - 1):+.1f} % (supervised worker {wall:.2f} s, "
          f"in-process {bare:.2f} s, same run)", flush=True)
    py = PythonWorkflow(ds, MODEL).run()
    print(f"gap speedup {py['seconds'] / wall:.1f}x against the Python workflow doing the "
          f"workflow's first steps (FMPy + SciPy: calibrate {', '.join(names)}, screen every "
          f"candidate, refit the best ({py['best']}), held-out check: {py['seconds']:.1f} s, "
          f"{py['simulations']} "
          f"simulations; actuator-fmu gap: {wall:.1f} s, {timing['simulations']} simulations, "
          f"with a second round, the base re-check and the final fit for the intervals)",
          flush=True)
    # Per simulation (see the module documentation): each side's whole wall time, fitting included.
    gap_ms = 1e3 * wall / max(timing["simulations"], 1)
    py_ms = 1e3 * py["seconds"] / max(py["simulations"], 1)
    print(f"gap per simulation {py_ms / gap_ms:.1f}x (wall per simulation: Python {py_ms:.0f} ms, "
          f"actuator-fmu gap {gap_ms:.0f} ms)", flush=True)


EMPS_DATA = REPO.parent / "shared" / "data" / "emps"
EMPS_TARGET_S = 60.0


def emps():
    """gap on the whole EMPS estimation record: wall time, its split and what it named."""
    if not (EMPS_DATA / "DATA_EMPS.mat").exists():
        print(f"gap EMPS: {EMPS_DATA}/DATA_EMPS.mat not found (EMPS.zip of "
              "nonlinearbenchmark.org), line skipped", flush=True)
        return
    with tempfile.TemporaryDirectory() as d:
        subprocess.run([sys.executable, str(REPO / "scripts" / "emps_csv.py"), "--data-dir",
                        str(EMPS_DATA), "--out-dir", d], check=True, stdout=subprocess.DEVNULL)
        out = Path(d) / "report"
        t0 = time.perf_counter()
        subprocess.run([str(REPO / "target/release/actuator-fmu"), "gap",
                        str(REPO / "dist/EMPS.fmu"), "--data", str(Path(d) / "emps_estimation.csv"),
                        "--out", str(out), "--quiet"], check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        report = json.loads((out / "report.json").read_text())
    timing = report["timing"]
    verdict = "within" if wall <= EMPS_TARGET_S else "ABOVE"
    print(f"gap EMPS time {wall:.1f} s wall for the estimation record (24.8 s at 1 kHz, "
          f"{report['samples']} samples; named {report['named']}); split: simulate "
          f"{timing['simulate_s']:.1f} s, fit {timing['fit_s']:.1f} s, {timing['simulations']} "
          f"simulations on {timing['threads']} threads; {verdict} the {EMPS_TARGET_S:g} s target",
          flush=True)


if __name__ == "__main__":
    if "--emps" in sys.argv:
        emps()
    else:
        main()
