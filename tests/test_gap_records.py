"""`actuator-fmu gap` on several records at once (`--data A --data B`) and on records it does not
fit (`--validate C`).

Records are made here from our own FMUs (examples/gapgen.py: FMPy simulation with a known truth
plus noise) and cut from the EMPS benchmark records (../shared/data/emps/, converted by
scripts/emps_csv.py; those tests skip without the data). Every record is short (3 s) so that
each test takes seconds; the whole EMPS records are the example's (examples/emps/) and the
bench's.
"""
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO, cli_path, fmu_path

sys.path.insert(0, str(REPO / "examples"))
sys.path.insert(0, str(REPO / "tests"))
import gapgen  # noqa: E402
from test_gap import DURATION, RATE, holds, large_strokes  # noqa: E402

EMPS_DATA = REPO.parent / "shared" / "data" / "emps"
needs_emps = pytest.mark.skipif(
    not (EMPS_DATA / "DATA_EMPS.mat").exists() or not (EMPS_DATA / "DATA_EMPS_PULSES.mat").exists(),
    reason=f"EMPS records not found in {EMPS_DATA} (EMPS.zip of nonlinearbenchmark.org)")


def gap(model_fmu, datas, out, *args, validate=()):
    cmd = [cli_path(), "gap", model_fmu, "--out", str(out), "--quiet", *args]
    for d in datas:
        cmd += ["--data", str(d)]
    for v in validate:
        cmd += ["--validate", str(v)]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr + p.stdout
    return json.loads((out / "report.json").read_text()), p.stdout


@pytest.mark.long
def test_the_designed_experiment_fitted_with_the_record_that_asked_for_it(tmp_path,
                                                                         monkeypatch):
    """The loop with two records: strokes of 800-1100 motor rad never reverse the gearhead's
    torque, so on that record alone gap names nothing and says it cannot show gear_backlash; it
    gives the `design` command. The designed experiment's record (our FMU simulated with the
    same hidden backlash, base parameters and absolute sensor noise) fitted together with the
    original (`--data original --data designed`, one parameter set) names gear_backlash, and
    every fitted interval holds the generator's truth."""
    monkeypatch.setattr(gapgen, "inputs", large_strokes)
    model = "TwistedString"
    ds = gapgen.make(model, 31, ("gear_backlash",), duration=DURATION, rate=RATE)
    monkeypatch.undo()
    orig = tmp_path / "original.csv"
    gapgen.write_csv(ds, orig, comment="test data: large strokes, hidden gear_backlash")
    rep, _ = gap(fmu_path(model), [orig], tmp_path / "alone", "--rounds", "1")
    assert rep["named"] == [], rep["verdict"]
    assert "cannot show gear_backlash" in rep["in_short"], rep["in_short"]
    cmd = rep["design_commands"]["gear_backlash"].split()
    design_csv = tmp_path / "design.csv"
    p = subprocess.run([cli_path(), *cmd[1:-1], str(design_csv)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr + p.stdout
    t, cols = gapgen.read_inputs_csv(design_csv)
    ds2 = gapgen.make(model, 31, ("gear_backlash",), given_inputs=(t, cols),
                      noise_sigma=ds["noise_sigma"])
    assert ds2["truth"] == ds["truth"]
    designed = tmp_path / "designed.csv"
    gapgen.write_csv(ds2, designed, comment="test data: the designed experiment, same truth")
    # Only the effect in question is a candidate: the run on the original alone had them all.
    rep2, out = gap(fmu_path(model), [orig, designed], tmp_path / "both", "--rounds", "1",
                    "--effects", "gear_backlash")
    assert rep2["named"] == ["gear_backlash"], rep2["verdict"]
    assert f"{orig} + {designed}" in out
    for k, e in rep2["parameters"].items():
        assert holds(e, ds["truth"][k]), (k, e, ds["truth"][k])
    recs = rep2["records"]
    assert [r["data"] for r in recs] == [str(orig), str(designed)]
    assert [r["samples"] for r in recs] == [len(ds["time"]), len(ds2["time"])]
    # Each record's noise level is its own: the generator's absolute level, the same in both,
    # within the estimator's spread on the record holding no fast motion.
    for name, s in recs[0]["noise_white"].items():
        assert 0.7 < s / ds["noise_sigma"][name] < 1.3, (name, s, ds["noise_sigma"][name])
    # traces.csv holds every sample of both records, each with its record and own time.
    rows = list(csv.DictReader(open(tmp_path / "both" / "traces.csv")))
    assert len(rows) == len(ds["time"]) + len(ds2["time"])
    for r in (1, 2):
        t_rec = sorted(float(x["record_time"]) for x in rows if x["record"] == str(r))
        assert np.allclose(t_rec, ds["time"] if r == 1 else ds2["time"], atol=1e-9)


def emps_records(tmp_path):
    """The converted EMPS records (scripts/emps_csv.py)."""
    out = tmp_path / "emps"
    subprocess.run([sys.executable, str(REPO / "scripts" / "emps_csv.py"), "--out-dir", str(out)],
                   check=True, capture_output=True)
    return out / "emps_estimation.csv", out / "emps_pulses.csv"


def cut(src, dst, first, last):
    """Rows first..last (0-based data rows) of a converted record, with its comment lines."""
    lines = src.read_text().splitlines(keepends=True)
    head = [ln for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if not ln.startswith("#")]
    dst.write_text("".join(head + [body[0]] + body[1 + first:1 + last]))
    return np.genfromtxt(body[1 + first:1 + last], delimiter=",",
                         names=body[0].strip().split(","))


@needs_emps
def test_emps_records_each_begin_in_their_own_state(tmp_path):
    """Two 3 s pieces of the EMPS estimation record, one from t = 0 and one from t = 12.5 s (each
    in motion where it begins, at its own position and velocity, on its own time axis), fitted
    together with the symmetric friction model: each record's initial position (`q0`, and the
    second record's own `q0@2`) is estimated at the position the encoder measured at its first
    sample (within 10 µm), the second record's velocity `v0@2` at the controller's logged
    velocity there (within 15 %: the logged one is a filtered difference), and the one mass
    fitted to both lies within 1 % of the published 95.15 kg (benchmark description, Janot et
    al. 2019)."""
    est, _ = emps_records(tmp_path)
    a = cut(est, tmp_path / "a.csv", 0, 3000)
    b = cut(est, tmp_path / "b.csv", 12500, 15500)
    rep, _ = gap(fmu_path("EMPS"), [tmp_path / "a.csv", tmp_path / "b.csv"], tmp_path / "g",
                 "--rounds", "0", "--set", "coulomb_friction.enabled=true", "--fit",
                 "mass,viscous_friction,offset,coulomb_friction.force")
    p = rep["parameters"]
    assert abs(p["q0"]["value"] - a["qm"][0]) < 1e-5, (p["q0"], a["qm"][0])
    assert abs(p["q0@2"]["value"] - b["qm"][0]) < 1e-5, (p["q0@2"], b["qm"][0])
    assert abs(p["v0@2"]["value"] / b["velocity"][0] - 1) < 0.15, (p["v0@2"], b["velocity"][0])
    assert abs(p["mass"]["value"] / 95.15 - 1) < 0.01, p["mass"]
    assert np.allclose(rep["records"][1]["record_s"], [b["time"][0], b["time"][-1]])
    assert rep["records"][1]["initial_parameters"] == ["q0@2", "v0@2"]


@needs_emps
def test_emps_pulse_record_not_fitted_is_reported(tmp_path):
    """3 s of the estimation record fitted, 3 s of the pulse record (force pulses the fit never
    saw) in --validate: the report gives, per output, the RMS error of the base fit and of the
    final model on it and when the largest error occurs (within the record's own time), in
    report.json, report.md, validation-1.csv and a plot. With friction named on the estimation
    record, the final model's force error on the pulse record is below the base fit's."""
    est, pul = emps_records(tmp_path)
    cut(est, tmp_path / "est.csv", 0, 3000)
    v = cut(pul, tmp_path / "pulses.csv", 0, 3000)
    rep, out = gap(fmu_path("EMPS"), [tmp_path / "est.csv"], tmp_path / "g", "--rounds", "1",
                   "--effects", "coulomb_friction,asymmetric_friction",
                   validate=[tmp_path / "pulses.csv"])
    assert rep["named"], rep["verdict"]
    [val] = rep["validation"]
    assert val["data"] == str(tmp_path / "pulses.csv") and val["samples"] == 3000
    f = val["outputs"]["force"]
    assert f["rmse_final"] < f["rmse_base"], f
    assert v["time"][0] <= f["max_final_at_s"] <= v["time"][-1]
    # The RMS error reported is the error of the traces written (an independent recomputation).
    rows = np.genfromtxt(tmp_path / "g" / "validation-1.csv", delimiter=",", names=True)
    assert np.allclose(rows["time"], v["time"])
    assert np.allclose(rows["forcemeasured"], v["force"])
    rms = np.sqrt(np.mean((rows["forcefinal"] - rows["forcemeasured"]) ** 2))
    assert abs(rms / f["rmse_final"] - 1) < 1e-9
    md = (tmp_path / "g" / "report.md").read_text()
    assert "## Records not fitted" in md and "validation-1.png" in md
    assert (tmp_path / "g" / "validation-1.png").stat().st_size > 0
    assert "(not fitted) force" in out


def test_records_must_measure_the_same_outputs(tmp_path):
    """Records fitted together with different output columns: exit 2, one line naming both."""
    model = "TwistedString"
    ds = gapgen.make(model, 5, (), duration=1.0, rate=RATE)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    gapgen.write_csv(ds, a)
    lines = a.read_text().splitlines()
    body = [ln for ln in lines if not ln.startswith("#")]
    head = body[0].split(",")
    keep = [i for i, h in enumerate(head) if h != "current"]
    b.write_text("\n".join(",".join(r.split(",")[i] for i in keep) for r in body) + "\n")
    p = subprocess.run([cli_path(), "gap", fmu_path(model), "--data", str(a), "--data", str(b),
                        "--out", str(tmp_path / "g"), "--quiet"], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 2, p.stderr
    assert "same output columns" in p.stderr and len(p.stderr.splitlines()) == 1, p.stderr
