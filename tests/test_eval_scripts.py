"""Smoke runs of the long evaluations that are not part of CI in full: `scripts/gap-eval` (the
rates at which `gap` names the right effect over many datasets), `scripts/gap-robustness` (its
answer under perturbations far below the noise), the gap part of
`scripts/bench` (`scripts/bench_gap.py`, `gap` against a Python workflow doing the same steps)
and its interface lines (ME under FMPy's CVode against CS, FMI 3.0 CS against FMI 2.0 CS).
Each runs on the smallest case and is checked for the lines a reader of its output relies on."""
import math
import os
import re
import subprocess
import sys

import numpy as np

from conftest import REPO, cli_path, fmu3_path, fmu_path

sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402


def test_gap_eval_runs_and_summarises(tmp_path):
    fmu_path("HydraulicJoint")
    cli_path()
    p = subprocess.run(
        [str(REPO / "scripts" / "gap-eval"), "--n", "1", "--models", "HydraulicJoint",
         "--conditions", "single1", "--duration", "2", "--rate", "100", "--seed0", "990000",
         "--out", str(tmp_path / "eval")],
        capture_output=True, text=True, timeout=600, cwd=REPO,
        env={**os.environ, "GAP_EVAL_BIN": cli_path()})
    assert p.returncode == 0, p.stderr[-2000:]
    line = next(l for l in p.stdout.splitlines() if l.startswith("HydraulicJoint single1:"))
    assert "1 datasets, 0 failed runs" in line, line
    assert re.search(r"hidden effect named first [01]/1", line), line
    assert re.search(r"wall mean [0-9.]+ s", line), line
    assert (tmp_path / "eval" / "results.jsonl").read_text().count("\n") == 1


def test_mismatch_friction_records_carry_the_law_where_it_acts():
    """The `mismatch` condition's friction records are made by the SciPy references with an
    extra friction law. The hook adds the torque where and with the sign a friction acts: with
    an extra law equal to a term the FMU has (TwistedString: the candidate's Coulomb + viscous law
    at the motor; HydraulicJoint: viscous friction in the joint, added to link_damping) the reference
    reproduces the FMU with that term. A drawn law of another form leaves the FMU at the
    record's truth far from the record (the mechanism is there to be found)."""
    fmu_path("HydraulicJoint")
    fmu_path("TwistedString")
    t = np.round(np.arange(0, 101) / 100.0, 12)
    rng = np.random.default_rng(7)
    cases = {"TwistedString": (lambda w: 2e-3 * math.tanh(w / 1.0) + 2e-7 * w,
                               {"motor_friction.enabled": True, "motor_friction.coulomb": 2e-3,
                                "motor_friction.viscous": 2e-7}),
             "HydraulicJoint": (lambda w: 1.5 * w, {"link_damping": 3.0 + 1.5})}
    for model, (law, fmu_sets) in cases.items():
        cols = gapgen.inputs(model, rng, t)
        ref = gapgen.reference_simulator(law)(model, t, cols, {})
        fmu = gapgen.simulate(model, t, cols, fmu_sets)
        for n in gapgen.MEASURED[model]:
            y = np.asarray(fmu[n])
            err = np.max(np.abs(ref[n] - y)) / max(np.ptp(y), 1e-300)
            assert err < 1e-5, (model, n, err)
    r = gapgen.eval_record("TwistedString", "mismatch", 3, seed0=990000, duration=1.0, rate=100.0)
    assert r["mismatch"].startswith("friction Stribeck at the motor"), r["mismatch"]
    ds = r["ds"]
    fmu = gapgen.simulate("TwistedString", ds["time"], ds["inputs"], ds["truth"])
    miss = np.sqrt(np.mean((ds["outputs"]["current"] - np.asarray(fmu["current"])) ** 2))
    assert miss > 3 * ds["noise_sigma"]["current"], (miss, ds["noise_sigma"]["current"])


def test_gap_robustness_runs_and_prints_its_table(tmp_path):
    fmu_path("HydraulicJoint")
    cli_path()
    p = subprocess.run(
        [str(REPO / "scripts" / "gap-robustness"), "--n", "1", "--models", "HydraulicJoint",
         "--duration", "1", "--rate", "100", "--seed0", "990000", "--jobs", "3",
         "--gap-args", "--rounds 1", "--out", str(tmp_path / "rob")],
        capture_output=True, text=True, timeout=600, cwd=REPO,
        env={**os.environ, "GAP_EVAL_BIN": cli_path()})
    assert p.returncode == 0, p.stderr[-2000:]
    lines = p.stdout.splitlines()
    head = next(i for i, l in enumerate(lines) if l.startswith("record "))
    assert lines[head].split()[-3:] == ["holds", "pert", "tol"], lines[head]
    rec = lines[head + 1]
    assert rec.startswith("HydraulicJoint single1 0 s990000"), rec
    assert re.search(r"pert (same|DIFFERS), tol (same|DIFFERS)", rec), rec
    # one row per fitted parameter: name, value, half-width, truth, holds, two moves
    rows = [l.split() for l in lines[head + 2:] if l.startswith(" ")]
    assert rows and all(len(r) == 7 for r in rows), rows
    summary = next(l for l in lines if l.startswith("gap-robustness: "))
    assert "1 records (0 with a failed run)" in summary, summary
    assert re.search(r"same named effects: pert [01]/1, tol [01]/1", summary), summary
    assert re.search(r"holding the truth \d+/\d+", summary), summary
    assert (tmp_path / "rob" / "results.jsonl").read_text().count("\n") == 1


def test_gap_bench_prints_its_ratio(tmp_path):
    fmu_path("HydraulicJoint")
    cli_path()
    p = subprocess.run([sys.executable, str(REPO / "scripts" / "bench_gap.py"), "--smoke"],
                       capture_output=True, text=True, timeout=600, cwd=REPO)
    assert p.returncode == 0, p.stderr[-2000:]
    m = re.search(r"gap speedup ([0-9.]+)x against the Python workflow", p.stdout)
    assert m and float(m.group(1)) > 0, p.stdout
    assert re.search(r"actuator-fmu gap: [0-9.]+ s, [0-9]+ simulations", p.stdout), p.stdout
    m = re.search(r"gap per simulation ([0-9.]+)x", p.stdout)
    assert m and float(m.group(1)) > 0, p.stdout


def test_bench_prints_the_interface_lines():
    """scripts/bench's lines of our ME FMU under FMPy's CVode against our CS FMU, and of the FMI
    3.0 CS FMU against the FMI 2.0 one (a 0.2 s run: that they run and print, not a measurement)."""
    fmu_path("HydraulicJoint")
    fmu3_path("HydraulicJoint")
    subprocess.run(["cargo", "build", "--release", "--quiet", "-p", "bench"], check=True, cwd=REPO)
    p = subprocess.run([sys.executable, str(REPO / "scripts" / "bench.py"), "--smoke", "--only",
                        "me-cvode,fmi3-cs"], capture_output=True, text=True, timeout=600, cwd=REPO)
    assert p.returncode == 0, p.stderr[-2000:]
    number = r"([0-9.]+(?:e[-+][0-9]+)?)"
    for model in ("HydraulicJoint", "TwistedString"):
        m = re.search(rf"{model} ME under FMPy CVode against CS {number}x the time .*worst output "
                      rf"RMS \(max\): ME {number} \w+ \({number} \w+\), CS {number} \w+", p.stdout)
        assert m and all(float(g) >= 0 for g in m.groups()), p.stdout
        # both run the same model: the FMU's own solver is near the truth
        assert float(m.group(4)) < 1e-4, m.group(0)
        m = re.search(rf"{model} FMI 3.0 CS against FMI 2.0 CS {number}x .*outputs differ by at "
                      rf"most {number} of their range", p.stdout)
        assert m and float(m.group(1)) > 0, p.stdout
        # the same model code under both layers
        assert float(m.group(2)) < 1e-9, m.group(0)


def test_test_long_collects_the_long_tests_that_scripts_test_skips():
    """scripts/test-long runs every test marked `long` (collected, not skipped), and the suite
    scripts/test runs skips them."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST")}
    p = subprocess.run([str(REPO / "scripts" / "test-long"), "--collect-only", "-n", "0"],
                       capture_output=True, text=True, timeout=600, cwd=REPO, env=env)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    collected = set(re.findall(r"^tests/\S+::\S+", p.stdout, flags=re.M))
    assert len(collected) >= 9, collected
    # gap runs and the rebuild of every archive: nothing else takes a minute
    long_kinds = ("tests/test_gap.py::", "tests/test_gap_records.py::", "tests/test_emps.py::",
                  "tests/test_fmi_layer.py::test_packaging")
    assert all(t.startswith(long_kinds) for t in collected), collected
    assert any("1_and_16_threads" in t for t in collected), collected
    p = subprocess.run([sys.executable, "-m", "pytest", "tests/test_gap.py", "-q", "-n", "0",
                        "-p", "no:cacheprovider", "-k", "1_and_16_threads", "-rs"],
                       capture_output=True, text=True, timeout=600, cwd=REPO, env=env)
    assert "1 skipped" in p.stdout and "scripts/test-long runs it" in p.stdout, p.stdout[-2000:]
