"""Smoke tests of `actuator-fmu gap`: effects named on data made by the FMUs, verdicts, reports.

Data are generated here with examples/gapgen.py: FMPy simulates the packaged FMU with our own
random inputs and parameter draws, one effect hidden or none, plus Gaussian noise of 1 % of each
output's range. The traces are short (3 s at 200 Hz) so the suite stays fast; the statistical
evaluation over many datasets is scripts/gap-eval.
"""
import json
import os
import zipfile
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO, cli_path, fmu_path

sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402
import regenerate  # noqa: E402

DURATION, RATE = 3.0, 200.0
FAR_WARNING = "The final model is still far from the data"
ROUGH_WARNING = "The fit's sum of squares is rough"
DISAGREEMENT_WARNING = "A disagreement remains that no candidate explains"
NOISE_NOTE = "The measurement noise is correlated"


def generate(tmp_path, model, name, seed, hidden=(), **kw):
    fmu_path(model)
    ds = gapgen.make(model, seed, hidden, duration=DURATION, rate=RATE, **kw)
    path = tmp_path / f"{name}.csv"
    gapgen.write_csv(ds, path, comment=f"test data: {model}, hidden {list(hidden)}, seed {seed}")
    return ds, path


def gap(model, csv, out, *args, env=None):
    cmd = [cli_path(), "gap", fmu_path(model), "--data", str(csv), "--out", str(out), "--quiet",
           *args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
    return p


def run_ok(model, csv, out, *args, env=None):
    p = gap(model, csv, out, *args, env=env)
    assert p.returncode == 0, p.stderr + p.stdout
    with open(out / "report.json") as f:
        return json.load(f)


@pytest.mark.parametrize("row", regenerate.manifest(), ids=lambda r: r[0])
def test_bundled_examples_match_the_fmu(row):
    """Each bundled record is the current FMU's output at the recorded truth plus noise of the
    recorded level: the RMSE between the record and FMPy's re-simulation is that noise level
    (ratio 1 up to sampling error, about 1 +- 0.02 for 2,000 samples). A physics change that
    leaves a stale showcase behind fails here; `python examples/regenerate.py` renews them."""
    model, data, _gap_args, generator_args = row
    fmu_path(model)
    assert generator_args, f"{data}: manifest.tsv gives no gapgen.py arguments to remake it"
    ratios = regenerate.misfit(data)
    stale = {n: round(r, 2) for n, r in ratios.items() if r > 1.5}
    assert not stale, f"{data} no longer matches dist/{model}.fmu at its truth: {stale}"


@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_simulate_and_gap_step_a_grid_identically(tmp_path, jitter):
    """`simulate` and `gap` step one CSV at the same sample interval: on a grid written as
    k / rate (differences off by an ulp) and on one with jitter of +-20 % of a sample (a
    logger's clock). `simulate`'s outputs, at the data's times (linear interpolation between its
    communication points, as `gap` does off a uniform grid), give the RMSE `gap` reports for
    the model as given: exactly on the uniform grid, to rounding on the jittered one."""
    model = "HydraulicJoint"
    fmu_path(model)
    ds = gapgen.make(model, 4242, (), duration=1.0, rate=200.0, draw_base=False)
    if jitter:
        rng = np.random.default_rng(7)
        ds["time"] = ds["time"] + rng.uniform(-jitter, jitter, len(ds["time"])) / 200.0
        ds["time"][0] = 0.0
    csv = tmp_path / "grid.csv"
    gapgen.write_csv(ds, csv)
    p = subprocess.run([cli_path(), "simulate", fmu_path(model), "--data", str(csv), "--out",
                        str(tmp_path / "sim.csv")], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    sim = np.genfromtxt(tmp_path / "sim.csv", delimiter=",", names=True, comments="#")
    rep = run_ok(model, csv, tmp_path / "gap", "--rounds", "0")
    for name, y in ds["outputs"].items():
        at_data = np.interp(ds["time"], sim["time"], sim[name])
        rmse = float(np.sqrt(np.mean((at_data - y) ** 2)))
        assert rmse == pytest.approx(rep["outputs"][name]["rmse_before"],
                                     rel=1e-9 if jitter else 1e-13, abs=0), name


@pytest.mark.parametrize("rho", [0.9, 0.97])
def test_correlated_noise_alone_is_neither_refused_nor_named(tmp_path, rho):
    """A clean HydraulicJoint record (no hidden effect) with AR(1) noise of 1 % of each range: the
    noise level estimated from the data's differences is then the fast part's (a quarter of the
    marginal level at 0.9), which made the start test refuse the record (exit 2). gap estimates
    the coefficient from the calibrated residual and reports it; nothing is named."""
    fmu_path("HydraulicJoint")
    # 4 s at 250 Hz, as scripts/gap-eval's records: at 0.97 a shorter record holds too few
    # effective samples to tell the noise's coefficient from its differences.
    ds = gapgen.make("HydraulicJoint", 1, (), ar=rho, duration=4.0, rate=250.0)
    csv = tmp_path / "ar.csv"
    gapgen.write_csv(ds, csv)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out")
    assert rep["named"] == []
    for name, o in rep["outputs"].items():
        assert o["noise_ar1"] == pytest.approx(rho, abs=0.06), name
        # The marginal level, as generated (sampling error of a 4 s record at this rho).
        assert o["noise_sigma"] == pytest.approx(ds["noise_sigma"][name], rel=0.35), name
    assert any("noise is correlated" in w for w in rep["warnings"])


def test_a_sensor_gain_error_is_reported_as_a_disagreement_no_candidate_explains(tmp_path):
    """A mechanism outside the candidate list (the theta sensor reads 6 % high): the report must
    not say that nothing is missing or that the residuals are noise; it says that a disagreement
    remains, on which output, and that its shape is a gain error of about +6 %."""
    fmu_path("HydraulicJoint")
    ds = gapgen.make("HydraulicJoint", 7, (), duration=4.0, rate=250.0)
    ds["outputs"]["theta"] = ds["outputs"]["theta"] + 0.06 * ds["clean"]["theta"]
    csv = tmp_path / "gain.csv"
    gapgen.write_csv(ds, csv)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out")
    for text in (rep["verdict"], rep["in_short"]):
        assert "no missing effect found" not in text and "consistent with noise" not in text, text
    assert "disagreement remains" in rep["verdict"], rep["verdict"]
    d = rep["disagreement"]
    assert [o["output"] for o in d["outputs"]] == ["theta"], d
    shape = d["outputs"][0]["shapes"][0]
    assert shape["kind"] == "gain" and shape["value"] == pytest.approx(0.06, abs=0.015), shape
    assert d["outputs"][0]["windows"], d
    assert any("gain error of +" in w for w in rep["warnings"]), rep["warnings"]


def test_a_gain_error_on_a_sensor_away_from_zero_at_rest_is_no_record_begun_in_motion(tmp_path):
    """TwistedString's 'p' read 6 % low: at rest 'p' is far from zero, so the model misses the
    first samples by hundreds of noise levels, and the start test once refused the record
    (exit 2, "does not begin where the model begins"). The misfit follows the measured output
    over the whole trace, so the start says nothing about where the record begins: the run goes
    on and reports the disagreement that remains on 'p', with a gain's shape."""
    fmu_path("TwistedString")
    ds = gapgen.make("TwistedString", 8, (), duration=DURATION, rate=RATE)
    ds["outputs"]["p"] = ds["outputs"]["p"] - 0.06 * ds["clean"]["p"]
    csv = tmp_path / "gain.csv"
    gapgen.write_csv(ds, csv)
    rep = run_ok("TwistedString", csv, tmp_path / "out")
    assert not any("does not begin" in w for w in rep["warnings"]), rep["warnings"]
    for text in (rep["verdict"], rep["in_short"]):
        assert "no missing effect found" not in text and "consistent with noise" not in text, text
    assert "disagreement remains" in rep["verdict"], rep["verdict"]
    d = {o["output"]: o for o in rep["disagreement"]["outputs"]}
    assert "p" in d and d["p"]["windows"], rep["disagreement"]
    assert d["p"]["shapes"][0]["kind"] == "gain", d["p"]


def test_a_start_missed_within_correlated_noise_is_no_record_begun_in_motion(tmp_path):
    """HydraulicJoint, hidden seal friction, AR(1) noise of coefficient 0.9 (scripts/gap-eval
    single1 --ar 0.9, seed 3100003). The base fit's residual holds the friction's misfit, so the
    noise of 'p1_left' looks white and is counted at its second-difference level, a quarter of
    the marginal one: the start, missed by 11 of those levels, stopped the run (exit 2) after
    seal friction was named. Counted under the noise model of the final residual, the start
    lies within the noise: the run names seal friction and ends."""
    fmu_path("HydraulicJoint")
    ds = gapgen.make("HydraulicJoint", 3100003, ("seal_friction",), ar=0.9, duration=4.0,
                     rate=250.0)
    csv = tmp_path / "seal.csv"
    gapgen.write_csv(ds, csv)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out")
    assert rep["named"] == ["seal_friction"], rep["verdict"]
    assert not any("does not begin" in w for w in rep["warnings"]), rep["warnings"]


def check_report_shape(rep, ds):
    for key in ("named", "candidates", "parameters", "outputs", "timing", "redone_rounds",
                "calibration"):
        assert key in rep
    # The kept base calibration is the one with the lower sum of squares.
    cal = rep["calibration"]
    if cal["horizons"] and cal["horizons"][-1][0] == rep["train_samples"]:
        growing = cal["horizons"][-1][1]
        assert cal["chosen"] == ("growing horizons" if growing < cal["direct_chi2"] else "direct")
    else:
        # No continuation, or one stopped after a first horizon the model misses by more than
        # sqrt(2) x the noise (chi-square per sample and output above 2).
        assert cal["chosen"] == "direct"
        if cal["horizons"]:
            ((n, chi2),) = cal["horizons"]
            assert chi2 > 2 * n * len(rep["outputs"])
    # A warning names each parameter that ended on a bound of its range, and only those.
    on_bound = sorted(k for k, e in rep["parameters"].items() if e["at_bound"])
    # (Warnings about an output, such as a constant offset, start with the output's name.)
    bound_warnings = [w for w in rep["warnings"]
                      if not w.startswith((FAR_WARNING, ROUGH_WARNING, DISAGREEMENT_WARNING,
                                           NOISE_NOTE))
                      and w.split(":")[0] not in rep["outputs"]]
    assert sorted(w.split()[0] for w in bound_warnings) == on_bound
    # A disagreement is reported for every output above 1.5x its noise (and for outputs above
    # 1.2x whose residual is not white), never below 1.2x; and then the verdict never says that
    # nothing is missing.
    ratios = {k: o["rmse_after"] / o["noise_sigma"] for k, o in rep["outputs"].items()}
    flagged = {o["output"] for o in (rep["disagreement"] or {"outputs": []})["outputs"]}
    assert {k for k, r in ratios.items() if r > 1.5} <= flagged, (ratios, flagged)
    assert all(ratios[k] > 1.2 for k in flagged), (ratios, flagged)
    if flagged:
        assert "no missing effect found" not in rep["verdict"] + rep["in_short"]
        assert any(w.startswith(DISAGREEMENT_WARNING) for w in rep["warnings"])
    # The far-from-data warning is there exactly when some output ends above 3x its noise.
    far = any(o["rmse_after"] > 3 * o["noise_sigma"] for o in rep["outputs"].values())
    assert far == any(w.startswith(FAR_WARNING) for w in rep["warnings"])
    assert set(rep["outputs"]) == set(ds["outputs"])
    for o in rep["outputs"].values():
        for k in ("rmse_before", "rmse_after", "max_before", "max_after"):
            assert o[k] >= 0
    for k in ("total_s", "simulate_s", "fit_s"):
        assert rep["timing"][k] >= 0
    for e in rep["named"]:
        assert rep["candidates"], "a named effect comes from a candidate round"


def resimulate_rmse(model, ds, rep):
    """RMSE per output of an FMPy simulation with the report's parameters, named effects and
    --set values, on the CSV's inputs at its sample interval."""
    start = {k: v["value"] for k, v in rep["parameters"].items()}
    for e in rep["named"]:
        start[e + ".enabled"] = True
    for k, v in rep.get("fixed", {}).items():
        start[k] = v
    vs = gapgen.variables(model)
    for k in list(start):
        if vs[k]["type"] == "Boolean":
            start[k] = bool(start[k])
    res = gapgen.simulate(model, ds["time"], ds["inputs"], start, outputs=list(ds["outputs"]))
    return {n: float(np.sqrt(np.mean((np.asarray(res[n]) - ds["outputs"][n]) ** 2)))
            for n in ds["outputs"]}


@pytest.mark.parametrize("model,effect,seed", [
    ("HydraulicJoint", "seal_friction", 11),
    ("HydraulicJoint", "internal_leakage", 12),
    ("TwistedString", "string_compliance", 13),
    ("TwistedString", "motor_friction", 14),
])
def test_hidden_effect_is_named(tmp_path, model, effect, seed):
    ds, csv = generate(tmp_path, model, effect, seed, (effect,))
    rep = run_ok(model, csv, tmp_path / "out", "--rounds", "1")
    check_report_shape(rep, ds)
    assert rep["named"] == [effect], rep["verdict"]
    assert rep["candidates"][0][0]["effect"] == effect
    # Every parameter of the named effect is reported with an interval.
    for p in gapgen.effects(model)[effect]:
        e = rep["parameters"][p]
        assert e["ci_low"] <= e["value"] <= e["ci_high"]
    # The gap shrinks: each output to within 1.2x its noise or by 5x.
    for n, o in rep["outputs"].items():
        s = ds["noise_sigma"][n]
        assert o["rmse_after"] <= 1.2 * s or o["rmse_after"] * 5 <= o["rmse_base_fit"], (n, o, s)
    # The named effect was visible in these data: its scanned visibility reaches what naming
    # needs, and the scan is reported in range order.
    top = rep["candidates"][0][0]
    assert top["visibility"] >= top["visibility_needed"] > 10.0
    assert top["detectable_from"] is not None
    fr = [p["fraction"] for p in top["visibility_scan"]]
    assert len(fr) >= 2 and fr == sorted(fr)
    # Plots and the human report exist.
    out = tmp_path / "out"
    assert (out / "report.md").stat().st_size > 500
    assert (out / "outputs.png").stat().st_size > 1000
    assert (out / "residuals.png").stat().st_size > 1000
    if model == "HydraulicJoint" and effect == "seal_friction":
        # Re-simulating the report with FMPy gives its rmse_after.
        rm = resimulate_rmse(model, ds, rep)
        for n, o in rep["outputs"].items():
            assert rm[n] == pytest.approx(o["rmse_after"], rel=1e-3), n


@pytest.mark.long
def test_same_report_with_1_and_16_threads(tmp_path):
    """The same data give the same report.json whatever the number of worker threads: the
    parallel simulations and finite-difference columns are collected in index order and reduced
    sequentially (rayon map + collect, never a parallel sum or min). Only the
    `timing` block (wall-clock seconds and the thread count itself) is excluded; every verdict,
    candidate score, estimate and interval must be bit-identical."""
    ds, csv = generate(tmp_path, "TwistedString", "motor_friction", 14, ("motor_friction",))
    reps = []
    for threads in (1, 16):
        env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
        rep = run_ok("TwistedString", csv, tmp_path / f"t{threads}", "--rounds", "1", env=env)
        assert rep["timing"]["threads"] == threads
        del rep["timing"]
        reps.append(json.dumps(rep, sort_keys=True))
    assert reps[0] == reps[1]


NO_FMA = "glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX512F"


def test_same_report_with_1_thread_and_with_2_threads_on_glibc_without_fma(tmp_path):
    """report.json (but for `timing`) is bit-identical between a run on 1 worker thread and a
    run on 2 worker threads with glibc told to take the code paths of a CPU without FMA and AVX2
    (GLIBC_TUNABLES): the FMUs and the workflow compute their transcendental functions with the
    `libm` crate, not with the platform's libm, which glibc picks by CPU (the FMUs' outputs
    differed in their last bits under this setting, and the fit's answer with them). Either
    difference alone breaks the equality; `test_same_report_with_1_and_16_threads` (long) takes
    the thread count alone. A short TwistedString trace with motor friction hidden; the two runs
    go in parallel."""
    fmu_path("TwistedString")
    ds = gapgen.make("TwistedString", 15, ("motor_friction",), duration=2.0, rate=200.0)
    csv = tmp_path / "data.csv"
    gapgen.write_csv(ds, csv)
    runs = {"t1": {"RAYON_NUM_THREADS": "1"},
            "t2_nofma": {"RAYON_NUM_THREADS": "2", "GLIBC_TUNABLES": NO_FMA}}
    procs = {name: subprocess.Popen(
        [cli_path(), "gap", fmu_path("TwistedString"), "--data", str(csv), "--out",
         str(tmp_path / name), "--quiet", "--rounds", "1"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, **env})
        for name, env in runs.items()}
    reps = {}
    for name, p in procs.items():
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
        rep = json.loads((tmp_path / name / "report.json").read_text())
        assert rep["timing"]["threads"] == int(runs[name]["RAYON_NUM_THREADS"])
        del rep["timing"]
        reps[name] = json.dumps(rep, sort_keys=True)
    assert reps["t1"] == reps["t2_nofma"]


def holds(e, truth, z=3.0):
    """Whether the truth lies within `z` standard errors of the estimate: the reported 95 %
    interval (±1.96 standard errors, asymmetric when fitted in logarithm) widened by z / 1.96.
    A single dataset's 95 % interval misses the truth one time in twenty by design, and which
    time turns on numerical noise: a 1 % change of the FMU solver's tolerance moved the return
    spring's interval on seed 940513 from [0, 2733] to [16, 1354] N/m. The rate is what
    scripts/gap-eval measures (coverage over 40 datasets per condition); a test on one dataset
    asserts the gross misses it was written for (ends tens of half-widths off) with a margin."""
    c, lo, hi = e["value"], e["ci_low"], e["ci_high"]
    f = z / 1.96
    return c - f * (c - lo) <= truth <= c + f * (hi - c)


def eval_dataset(tmp_path, model, seed, hidden, duration=4.0):
    """A dataset as scripts/gap-eval makes it (4 s unless told, 250 Hz, 1 % noise)."""
    ds = gapgen.make(model, seed, hidden, duration=duration, rate=250.0)
    path = tmp_path / "data.csv"
    gapgen.write_csv(ds, path)
    return ds, path


@pytest.mark.long
def test_named_model_is_refitted_on_the_whole_trace(tmp_path):
    """Seal friction (five parameters) fits the first 70 % of this trace to the noise with
    coulomb 66 N against a true 11 N, which the held-out end contradicts (pressures 3-4x the
    noise over the whole trace). After the effect is chosen, the model is refitted on the whole
    trace: every output ends at the noise level and every interval holds the true value (the
    generator's draw, independent of the workflow). Dataset: scripts/gap-eval seed 500009."""
    ds, csv = eval_dataset(tmp_path, "HydraulicJoint", 500009, ("seal_friction",))
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out")
    assert rep["named"] == ["seal_friction"], rep["verdict"]
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.1 * ds["noise_sigma"][n], (n, o)
    for p in gapgen.effects("HydraulicJoint")["seal_friction"]:
        e = rep["parameters"][p]
        assert holds(e, ds["truth"][p]), (p, e, ds["truth"][p])
    # The reported parameters are the ones the "after" errors come from (FMPy re-simulation).
    rm = resimulate_rmse("HydraulicJoint", ds, rep)
    for n, o in rep["outputs"].items():
        assert rm[n] == pytest.approx(o["rmse_after"], rel=1e-3), n


@pytest.mark.long
def test_an_oscillating_loop_is_calibrated_over_growing_horizons(tmp_path):
    """A base-parameter draw (valve flow x1.24, bulk modulus x0.81) that puts the 40 Hz loop near
    its stability limit: by t = 10 s the joint swings +-0.6 rad about its set point. A direct fit
    of the base parameters over the 7 s training part locks onto the wrong phase of the
    oscillation (measured: chi-square 24 500 against 15 100, pressures twice the noise); fitted
    over growing horizons (1.75 s, 3.5 s, 7 s) it reaches the noise level. No effect hidden,
    base calibration only (--rounds 0). Dataset: scripts/gap-eval seed 800004 (no effect), 10 s."""
    ds, csv = eval_dataset(tmp_path, "HydraulicJoint", 800004, (), duration=10.0)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out", "--rounds", "0")
    cal = rep["calibration"]
    assert cal["chosen"] == "growing horizons", cal
    n_train = rep["train_samples"]
    assert [h[0] for h in cal["horizons"]] == [n_train // 4, n_train // 2, n_train], cal
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)
    assert "growing horizons" in (tmp_path / "out" / "report.md").read_text()
    # The direct fit alone (the workflow before growing horizons) stays off the data.
    rep = run_ok("HydraulicJoint", csv, tmp_path / "direct", "--rounds", "0", "--no-horizons")
    assert rep["calibration"]["chosen"] == "direct" and rep["calibration"]["horizons"] == []
    assert max(o["rmse_after"] / ds["noise_sigma"][n] for n, o in rep["outputs"].items()) > 1.5


def test_valve_dynamics_is_named_whichever_base_calibration_is_used(tmp_path):
    """A trace whose direct base calibration is poor (chi-square 53 700 against 8 300 over
    growing horizons): with either calibration the user sees valve_dynamics named, its true
    frequency and damping ratio inside their intervals and every output at its noise level.
    Which internal path got there (a redone round or a single pass) may differ between machines
    and is not asserted. Dataset: scripts/gap-eval seed 500028."""
    ds, csv = eval_dataset(tmp_path, "HydraulicJoint", 500028, ("valve_dynamics",))

    def named_at_truth(rep):
        assert rep["named"] == ["valve_dynamics"], rep["verdict"]
        for p in gapgen.effects("HydraulicJoint")["valve_dynamics"]:
            e = rep["parameters"][p]
            assert holds(e, ds["truth"][p]), (p, e, ds["truth"][p])
        for n, o in rep["outputs"].items():
            assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)

    rep = run_ok("HydraulicJoint", csv, tmp_path / "out", "--rounds", "1")
    named_at_truth(rep)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "direct", "--rounds", "1", "--no-horizons")
    named_at_truth(rep)


@pytest.mark.long
def test_a_growth_the_base_fit_imitates_with_a_stiffer_spring_is_still_named(tmp_path):
    """TwistedString with a string radius that grows 0.91 % per turn: the base fit imitates the
    growth with a spring about three times too stiff, and the radius_growth refit from there
    descends to the bottom of the growth's range (ΔBIC -2.4, nothing named; measured with
    --no-profile). Fitting the base parameters with the growth held at each scanned setting
    finds the valley's other end; refitted from there, radius_growth is named at its true size.
    Only the outcome is asserted (named, size within three standard errors and above half the
    truth, residuals at noise), not which path reached it. Dataset: scripts/gap-eval seed 700537 at 4 s; truth from the generator's draw."""
    ds, csv = eval_dataset(tmp_path, "TwistedString", 700537, ("radius_growth",))
    rep = run_ok("TwistedString", csv, tmp_path / "out", "--rounds", "1")
    assert rep["named"] == ["radius_growth"], rep["verdict"]
    (c,) = [c for c in rep["candidates"][0] if c["effect"] == "radius_growth"]
    assert c["delta_bic"] >= 10, c
    true = ds["truth"]["radius_growth.per_turn"]
    growth = rep["parameters"]["radius_growth.per_turn"]
    assert holds(growth, true) and growth["value"] > 0.5 * true, (growth, true)
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)


@pytest.mark.long
def test_the_growth_record_moved_by_1e_8_of_its_range_gives_the_same_answer(tmp_path):
    """The record of the test above, and the same with every output sample moved by 1e-8 of
    the output's range (random signs; the noise is 1 %). The radius_growth refit stops where a
    step gains less than its stopping tolerance, which along the valley the stiffer spring
    makes can be anywhere: it stopped after thirteen steps on one record and after one on the
    other, and only the second, short of the naming threshold, was restarted from the profile.
    Measured before: growth 0.00747 [0.00629, 0.00889] against 0.00939 [0.00816, 0.01079],
    1.5 half-widths apart, truth 0.00906. Asserted: the same effect named and every estimate
    within a fifth of its half-width of the other's (scripts/gap-robustness's criterion)."""
    ds, csv = eval_dataset(tmp_path, "TwistedString", 700537, ("radius_growth",))
    moved = tmp_path / "moved.csv"
    gapgen.write_csv(gapgen.perturbed(ds, 700537, 1e-8), moved)
    procs = [subprocess.Popen([cli_path(), "gap", fmu_path("TwistedString"), "--data", str(c),
                               "--out", str(tmp_path / name), "--quiet", "--rounds", "1"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for name, c in (("a", csv), ("b", moved))]
    reps = []
    for name, p in zip("ab", procs):
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
        reps.append(json.loads((tmp_path / name / "report.json").read_text()))
    a, b = reps
    assert a["named"] == b["named"] == ["radius_growth"], (a["verdict"], b["verdict"])
    assert a["parameters"].keys() == b["parameters"].keys()
    for k, e in a["parameters"].items():
        half = (e["ci_high"] - e["ci_low"]) / 2
        assert abs(b["parameters"][k]["value"] - e["value"]) < 0.2 * half, (k, e, b["parameters"][k])


@pytest.mark.long
def test_intervals_of_a_rough_fit_hold_the_truth(tmp_path):
    """TwistedString closes its position loop on the encoder count, so a 0.1 % parameter change
    flips counts and moves the sum of squares by jumps no slope explains. On this trace
    (scripts/gap-eval seed 940513, hidden string_compliance) the final fit ends with the return
    spring at 904 N/m against a true 108 and a finite-difference Jacobian gave it ±1.6 N/m: four
    of seven intervals missed the truth, one by 490 half-widths. The roughness is now measured,
    the slopes taken over steps above it and the intervals widened by it: every interval holds
    the generator's true value, the effect's leading terms stay resolved, and a warning says why
    the intervals are wide. Since TwistedString samples its position loop at the start of a
    step, the same record's final fit slid along the spring's valley to 1124 N/m (108
    chi-square above the truth's sum) from both of its starts; the final fit now also starts
    with the wandered parameters held at their starts."""
    ds, csv = eval_dataset(tmp_path, "TwistedString", 940513, ("string_compliance",))
    rep = run_ok("TwistedString", csv, tmp_path / "out")
    assert rep["named"] == ["string_compliance"], rep["verdict"]
    for k, e in rep["parameters"].items():
        assert holds(e, ds["truth"][k]), (k, e, ds["truth"][k])
    # the leading terms stay resolved (intervals are a factor, as the parameters are fitted
    # in logarithm: within 1.5 end to end)
    for k in ("string_compliance.a1", "string_compliance.a3"):
        e = rep["parameters"][k]
        assert 0 < e["ci_low"] and e["ci_high"] < 1.5 * e["ci_low"], (k, e)
    assert any(w.startswith(ROUGH_WARNING) for w in rep["warnings"]), rep["warnings"]


def test_an_interval_in_a_flat_bent_valley_holds_the_truth(tmp_path):
    """A TwistedString trace with no effect hidden (scripts/gap-eval seed 982534): the return
    spring's sum of squares is flat from 0 to beyond 1000 N/m (the guide damping and load
    follow it), the fit ends at 420 N/m against a true 97, and the linearised interval, ±20 N/m,
    missed the truth by sixteen half-widths. The ends are now checked against the profile (fits
    of the others with the spring held there): every interval holds the truth."""
    ds, csv = eval_dataset(tmp_path, "TwistedString", 982534, ())
    rep = run_ok("TwistedString", csv, tmp_path / "out")
    assert rep["named"] == [], rep["verdict"]
    for k, e in rep["parameters"].items():
        assert holds(e, ds["truth"][k]), (k, e, ds["truth"][k])


@pytest.mark.long
def test_a_final_fit_stuck_where_the_spring_wandered_is_restarted(tmp_path):
    """string_compliance and motor_friction hidden (scripts/gap-eval seed 985513): both are
    named, but the final fit ended with the return spring at 2389 N/m against a true 104, its
    sum of squares 1500 chi-square units above the truth's, and two intervals missed. The final
    fit now also starts from the calibration's start when a base parameter wandered that far:
    the outputs are fitted to the noise and every interval holds the truth."""
    hidden = ("string_compliance", "motor_friction")
    ds, csv = eval_dataset(tmp_path, "TwistedString", 985513, hidden)
    rep = run_ok("TwistedString", csv, tmp_path / "out")
    assert sorted(rep["named"]) == sorted(hidden), rep["verdict"]
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.1 * ds["noise_sigma"][n], (n, o)
    for k, e in rep["parameters"].items():
        assert holds(e, ds["truth"][k]), (k, e, ds["truth"][k])


@pytest.mark.long
def test_two_missing_effects_are_not_taken_for_a_record_begun_in_motion(tmp_path):
    """A record from rest with string_compliance and motor_friction both hidden: the base fit
    misses everything by about 20 noise levels, the first samples by 8, which once stopped the
    run as a record not beginning at rest. A candidate's start is now judged against its misfit
    elsewhere while another effect is still missing; both effects are named (scripts/gap-eval
    seed 945513)."""
    ds, csv = eval_dataset(tmp_path, "TwistedString", 945513,
                           ("string_compliance", "motor_friction"))
    rep = run_ok("TwistedString", csv, tmp_path / "out")
    assert sorted(rep["named"]) == ["motor_friction", "string_compliance"], rep["verdict"]
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)


def follow_design(tmp_path, model, seed, hidden, ds, cmd, tag):
    """Run a design command from a report, simulate its experiment with the same truth and the
    same absolute noise, run gap on it: its report."""
    words = cmd.split()
    assert words[:2] == ["actuator-fmu", "design"] and words[-2] == "--out", cmd
    design_csv = tmp_path / f"{tag}.csv"
    p = subprocess.run([cli_path(), *words[1:-1], str(design_csv)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr + p.stdout
    t, cols = gapgen.read_inputs_csv(design_csv)
    ds2 = gapgen.make(model, seed, hidden, given_inputs=(t, cols), noise_sigma=ds["noise_sigma"])
    assert ds2["truth"] == ds["truth"]
    csv2 = tmp_path / f"{tag}ed.csv"
    gapgen.write_csv(ds2, csv2, comment="test data: the designed experiment, same truth")
    return run_ok(model, csv2, tmp_path / f"{tag}-out")


@pytest.mark.long
@pytest.mark.parametrize("seed,hidden", [
    (965531, ("motor_friction", "twist_hysteresis")),
])
def test_a_second_effect_the_first_absorbs_is_settled_by_the_experiment_proposed(tmp_path, seed,
                                                                                hidden):
    """Motor friction and strand hysteresis both hidden: a fitted motor friction mimics most of
    the hysteresis, leaving a rest at about the noise level. gap names motor_friction and either
    names twist_hysteresis too or, as the data do not settle it, gives the design command; data
    of the proposed experiment (same truth, same absolute noise) get it named. Nothing else is
    named (scripts/gap-eval 'two' datasets of seed0 960000, where twist_hysteresis once went
    unreported). Its twin, seed 965529, hides a hysteresis just above the weakest of its range
    (friction coefficient 0.0228 against 0.02) behind a final fit whose spring wandered along its
    flat valley (1567 N/m against a true 84): there the design command comes or not with a 1 %
    change of the solver's tolerance, on the FMU of then as now, so it is no test of the
    method; that case is open (the closing screen trusts a linearised screen from such a fit)."""
    model = "TwistedString"
    ds, csv = eval_dataset(tmp_path, model, seed, hidden)
    rep = run_ok(model, csv, tmp_path / "out")
    assert "motor_friction" in rep["named"] and set(rep["named"]) <= set(hidden), rep["verdict"]
    if "twist_hysteresis" not in rep["named"]:
        assert "twist_hysteresis" in rep["design_commands"], (rep["in_short"], rep["verdict"])
        assert "twist_hysteresis" in rep["in_short"], rep["in_short"]
        rep2 = follow_design(tmp_path, model, seed, hidden, ds,
                             rep["design_commands"]["twist_hysteresis"], "design")
        assert "twist_hysteresis" in rep2["named"], rep2["verdict"]


def test_an_effect_the_data_cannot_show_is_reported_as_such(tmp_path, monkeypatch):
    """TwistedString strokes kept at 800-1100 motor rad: the strings never untwist near zero
    twist, the gearhead flank in contact never changes after the first engagement from rest, so
    backlash is only a constant offset of the twist that string_radius absorbs (see the model
    documentation, section 7.1). The report must say that these data cannot reveal gear_backlash
    (its visibility is below half the threshold at every setting in range: 0.14 of it, from that
    first engagement) rather than only that it was not found, and still call the strong effects
    visible."""
    monkeypatch.setattr(gapgen, "inputs", large_strokes)
    model = "TwistedString"
    ds, csv = generate(tmp_path, model, "large_strokes", 31, ())
    rep = run_ok(model, csv, tmp_path / "out", "--rounds", "1")
    assert rep["named"] == [], rep["verdict"]
    cands = {c["effect"]: c for c in rep["candidates"][0]}
    bl = cands["gear_backlash"]
    assert bl["visibility"] < 0.5 * bl["visibility_needed"], bl
    assert bl["detectable_from"] is None
    assert "cannot reveal gear_backlash" in rep["verdict"]
    for e in ("motor_friction", "string_compliance", "twist_hysteresis"):
        assert cands[e]["visibility"] > 10 * cands[e]["visibility_needed"], (e, cands[e])
        assert e not in rep["verdict"].split("cannot reveal")[-1]
    md = (tmp_path / "out" / "report.md").read_text()
    assert "none in range" in md and "Visibility" in md
    # Plain words first; visibility as a multiple of what naming needs.
    assert rep["in_short"].startswith("no missing effect found."), rep["in_short"]
    assert "cannot show gear_backlash" in rep["in_short"], rep["in_short"]
    assert md.index("**In short:**") < md.index("**Verdict:**")
    assert "× what naming needs; none in range" in md
    # The visible candidates were not refitted: the verdict says so and why, never a bare
    # "no missing effect found" while they were only screened.
    screened = [c["effect"] for c in rep["candidates"][0] if not c["refit"]
                and c["visibility"] >= c["visibility_needed"]]
    assert screened, rep["candidates"][0]  # these data: residuals like noise, nothing refitted
    for e in screened:
        assert e in rep["verdict"].split("Only screened, not refitted:")[-1], rep["verdict"]


def large_strokes(model, rng, t, family="reaches"):
    """TwistedString strokes kept at 800-1100 motor rad (see the test below)."""
    return {"theta_motor_ref": gapgen.reaches(rng, t, 800.0, 1100.0, (1.0, 2.0), (0.3, 0.8)),
            "F_load": gapgen.steps(rng, t, 0.0, 40.0, (1.0, 2.5))}


@pytest.mark.long
def test_an_unrevealable_effect_is_named_on_the_experiment_design_proposes(tmp_path,
                                                                          monkeypatch):
    """The loop an engineer follows: gap says the data cannot show gear_backlash (large strokes
    never reverse the gearhead's torque) and gives the `actuator-fmu design` command; that
    command proposes an input within the FMU's input ranges with the predicted visibility; data
    simulated from that input, with the same hidden backlash, the same base parameters and the
    same sensor noise (absolute), get gear_backlash named."""
    monkeypatch.setattr(gapgen, "inputs", large_strokes)
    model = "TwistedString"
    ds, csv = generate(tmp_path, model, "large_strokes", 31, ("gear_backlash",))
    monkeypatch.undo()
    rep = run_ok(model, csv, tmp_path / "out", "--rounds", "1")
    assert rep["named"] == [], rep["verdict"]
    assert "cannot show gear_backlash" in rep["in_short"], rep["in_short"]
    cmd = rep["design_commands"]["gear_backlash"].split()
    md = (tmp_path / "out" / "report.md").read_text()
    assert rep["design_commands"]["gear_backlash"] in md
    assert cmd[:2] == ["actuator-fmu", "design"] and cmd[-2] == "--out"
    design_csv = tmp_path / "design.csv"
    p = subprocess.run([cli_path(), *cmd[1:-1], str(design_csv)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr + p.stdout
    # The prediction: invisible in the data, visible at the weakest backlash in the design.
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("gear_backlash at its weakest"))
    ratios = [float(x.split("×")[0].split()[-1]) for x in line.split("what naming needs")[:-1]]
    assert ratios[0] < 1.0 < ratios[1], line
    t, cols = gapgen.read_inputs_csv(design_csv)
    ranges = {n: (v["min"], v["max"]) for n, v in gapgen.variables(model).items()
              if v["causality"] == "input"}
    for n, v in cols.items():
        lo, hi = ranges[n]
        assert lo <= v.min() and v.max() <= hi, (n, v.min(), v.max(), lo, hi)
    ds2 = gapgen.make(model, 31, ("gear_backlash",), given_inputs=(t, cols),
                      noise_sigma=ds["noise_sigma"])
    assert ds2["truth"] == ds["truth"]
    csv2 = tmp_path / "designed.csv"
    gapgen.write_csv(ds2, csv2, comment="test data: the designed experiment, same truth")
    rep2 = run_ok(model, csv2, tmp_path / "out2", "--rounds", "1")
    assert rep2["named"] == ["gear_backlash"], rep2["verdict"]
    o = rep2["outputs"]
    assert sum(v["rmse_after"] / v["rmse_base_fit"] for v in o.values()) < len(o), o


def test_design_refuses_what_it_cannot_do(tmp_path):
    """Bad requests get exit status 2 and one line naming the problem."""
    fmu = fmu_path("TwistedString")
    out = tmp_path / "d.csv"
    cases = [
        (["--effect", "no_such_effect"], "no candidate effect 'no_such_effect'"),
        (["--range", "theta_motor_ref=5:1"], "--range 'theta_motor_ref=5:1'"),
        (["--range", "p=0:1"], "no Real input 'p'"),
        (["--duration", "0.01"], "needs 20 to"),
        (["--outputs", "nope"], "no output named 'nope'"),
    ]
    for args, msg in cases:
        p = subprocess.run([cli_path(), "design", fmu, "--out", str(out), *args],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 2, (args, p.stderr)
        assert msg in p.stderr and len(p.stderr.splitlines()) == 1, (args, p.stderr)
        assert not out.exists()


def test_clean_data_wrong_load_mass_is_calibrated_not_named(tmp_path):
    model = "HydraulicJoint"
    true_mass = 1.3 * gapgen.variables(model)["load_mass"]["start"]
    ds, csv = generate(tmp_path, model, "clean", 21, (), draw_base=False,
                       base_overrides={"load_mass": true_mass})
    rep = run_ok(model, csv, tmp_path / "out")
    check_report_shape(rep, ds)
    assert rep["named"] == [], rep["verdict"]
    assert "no missing effect found" in rep["verdict"]
    m = rep["parameters"]["load_mass"]
    assert m["value"] == pytest.approx(true_mass, rel=0.05), m
    assert m["ci_low"] <= m["value"] <= m["ci_high"]
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)
    rm = resimulate_rmse(model, ds, rep)
    for n, o in rep["outputs"].items():
        assert rm[n] == pytest.approx(o["rmse_after"], rel=1e-3), n


def edited_fmu(tmp_path, model, name, edits):
    """A copy of the packaged FMU whose modelDescription.xml has the (old, new) text edits
    applied (the binary is unchanged: names, ranges and descriptions are read by the host)."""
    src, dst = fmu_path(model), tmp_path / f"{name}.fmu"
    with zipfile.ZipFile(src) as zi, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zo:
        for item in zi.infolist():
            data = zi.read(item)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                for old, new in edits:
                    assert old in text, old
                    text = text.replace(old, new)
                data = text.encode()
            zo.writestr(item, data)
    return dst


def test_convention_departures_are_warnings_naming_the_variable(tmp_path):
    """A [calibrate] tag moved to the end of a description and an effect parameter without a
    range are each reported as a warning naming the variable (stdout and report.json); with
    no tag left and no effect switch, nothing is left to do: exit 2 with the reason."""
    ds, csv = generate(tmp_path, "TwistedString", "conv", 41, ())
    fmu = edited_fmu(tmp_path, "TwistedString", "tagged", [
        ('description="[calibrate] Viscous friction of the 4 linear guides and bearings"',
         'description="Viscous friction of the 4 linear guides and bearings [calibrate]"'),
        ('min="0.008726646259971648" max="0.05235987755982988" ', ''),
    ])
    cmd = [cli_path(), "gap", str(fmu), "--data", str(csv), "--out", str(tmp_path / "out"),
           "--quiet", "--rounds", "0"]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr + p.stdout
    warn = [l for l in p.stdout.splitlines() if l.startswith("warning: ")]
    assert any(l.startswith("warning: guide_damping: ") and "[calibrate]" in l for l in warn), warn
    assert any(l.startswith("warning: gear_backlash.angle: ") and "min < max" in l
               for l in warn), warn
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert "guide_damping" not in rep["parameters"]
    assert any(w.startswith("gear_backlash.angle: ") for w in rep["convention_warnings"])

    edits = [('description="[calibrate] ', 'description="')]
    edits += [(f'name="{e}.enabled"', f'name="{e}_on"') for e in gapgen.effects("TwistedString")]
    bare = edited_fmu(tmp_path, "TwistedString", "bare", edits)
    p = subprocess.run([cli_path(), "gap", str(bare), "--data", str(csv), "--out",
                        str(tmp_path / "bare"), "--quiet"], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 2, p.stderr + p.stdout
    assert "nothing to do" in p.stderr and "[calibrate]" in p.stderr, p.stderr


def test_set_and_missing_input_column(tmp_path):
    """tau_ext has no column (keeps its start value 0); load_mass is known (--set) and so is not
    fitted; --fit chooses the calibrated parameters."""
    model = "HydraulicJoint"
    ds, csv = generate(tmp_path, model, "set", 31, (), keep_inputs=["theta_ref"])
    header = [l for l in csv.read_text().splitlines() if not l.startswith("#")][0]
    assert "tau_ext" not in header
    mass = ds["truth"]["load_mass"]
    rep = run_ok(model, csv, tmp_path / "out", "--set", f"load_mass={mass!r}",
                 "--fit", "link_damping,bulk_modulus,valve_flow_scale", "--rounds", "1")
    assert rep["fixed"]["load_mass"] == pytest.approx(mass)
    assert "load_mass" not in rep["parameters"]
    assert set(rep["parameters"]) >= {"link_damping", "bulk_modulus", "valve_flow_scale"}
    assert rep["named"] == []
    rm = resimulate_rmse(model, ds, rep)
    for n, o in rep["outputs"].items():
        assert rm[n] == pytest.approx(o["rmse_after"], rel=1e-3), n


def test_a_wrong_fixed_parameter_leaves_a_warning(tmp_path):
    """string_radius fixed (--set) at 0.8x its true value and not fitted: no base parameter or
    candidate can make up for it, so p stays far from the data, and the report says so rather
    than presenting what it named as the explanation."""
    model = "TwistedString"
    ds, csv = generate(tmp_path, model, "wrong_radius", 41, ())
    r = 0.8 * ds["truth"]["string_radius"]
    rep = run_ok(model, csv, tmp_path / "out", "--set", f"string_radius={r!r}",
                 "--fit", "load_mass", "--rounds", "1")
    check_report_shape(rep, ds)
    assert rep["outputs"]["p"]["rmse_after"] > 3 * rep["outputs"]["p"]["noise_sigma"]
    far = [w for w in rep["warnings"] if w.startswith(FAR_WARNING)]
    assert len(far) == 1 and "p " in far[0], rep["warnings"]
    assert FAR_WARNING in (tmp_path / "out" / "report.md").read_text()


def test_bad_csv_exits_2_with_location(tmp_path):
    model = "HydraulicJoint"
    bad = tmp_path / "bad.csv"
    bad.write_text("time,theta_ref,theta\n0,0,0\n0.01,0,abc\n0.02,0,0\n")
    p = gap(model, bad, tmp_path / "out")
    assert p.returncode == 2
    assert "bad.csv:3:3" in p.stderr, p.stderr
    unknown = tmp_path / "unknown.csv"
    unknown.write_text("time,theta_ref,nonsense\n0,0,0\n0.01,0,0\n")
    p = gap(model, unknown, tmp_path / "out")
    assert p.returncode == 2 and "unknown.csv:1:3" in p.stderr, p.stderr
    p = gap(model, bad, tmp_path / "out", "--set", "no_such_parameter=1")
    assert p.returncode == 2 and "no_such_parameter" in p.stderr, p.stderr
    nooutput = tmp_path / "noout.csv"
    nooutput.write_text("time,theta_ref\n" + "".join(f"{i*0.01},0\n" for i in range(30)))
    p = gap(model, nooutput, tmp_path / "out")
    assert p.returncode == 2 and "noout.csv:1" in p.stderr, p.stderr


def theta_offset_data(tmp_path):
    """HydraulicJoint data without any effect, the joint angle read 5 noise levels too high (a
    sensor zero error). Returns the CSV and theta's noise level."""
    fmu_path("HydraulicJoint")
    ds = gapgen.make("HydraulicJoint", 910001, (), duration=DURATION, rate=RATE)
    sigma = ds["noise_sigma"]["theta"]
    ds["outputs"]["theta"] = np.asarray(ds["outputs"]["theta"]) + 5 * sigma
    csv = tmp_path / "offset.csv"
    gapgen.write_csv(ds, csv, comment="test data: HydraulicJoint, no effect, theta offset +5 sigma")
    return csv, sigma


def test_a_sensor_offset_is_reported_as_such_never_as_an_effect(tmp_path):
    """HydraulicJoint data without any effect, the joint angle read 5 noise levels too high (a
    sensor zero error): nothing is named, and a warning names the output and the offset (the
    mean of model − data, about −5σ), telling the user what to do."""
    csv, sigma = theta_offset_data(tmp_path)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out")
    assert rep["named"] == [], rep["verdict"]
    warned = [w for w in rep["warnings"] if w.startswith("theta:") and "offset" in w]
    assert warned, rep["warnings"]
    mean = rep["outputs"]["theta"]["mean_after"]
    assert -6 * sigma < mean < -4 * sigma, (mean, sigma)
    # the other outputs carry no such warning
    assert not [w for w in rep["warnings"]
                if "offset" in w and not w.startswith(("theta:", DISAGREEMENT_WARNING))]


def test_a_sensor_offset_asked_for_is_estimated_with_its_interval(tmp_path):
    """The data of the test above with `--offset theta`: the offset is estimated with the
    parameters (its 95 % interval holds the true +5 noise levels), nothing is named, no offset
    warning remains and theta's error after the fit is at its noise level. A name that is not a
    measured output is refused."""
    csv, sigma = theta_offset_data(tmp_path)
    rep = run_ok("HydraulicJoint", csv, tmp_path / "out", "--offset", "theta")
    assert rep["named"] == [], rep["verdict"]
    b = rep["offsets"]["theta"]
    assert b["ci_low"] <= 5 * sigma <= b["ci_high"], (b, 5 * sigma)
    assert b["ci_high"] - b["ci_low"] < 2 * sigma, b
    assert list(rep["offsets"]) == ["theta"]
    assert not [w for w in rep["warnings"] if "offset" in w], rep["warnings"]
    assert rep["outputs"]["theta"]["rmse_after"] < 1.2 * rep["outputs"]["theta"]["noise_sigma"]
    assert "theta" in rep["in_short"] and "offset" in rep["in_short"], rep["in_short"]
    p = gap("HydraulicJoint", csv, tmp_path / "bad", "--offset", "theta_ref")
    assert p.returncode == 2 and "--offset theta_ref" in p.stderr, p.stderr


def test_the_white_noise_level_and_the_unexplained_misfit_are_two_numbers(tmp_path):
    """A HydraulicJoint record with white noise of known level and cable friction switched on,
    gap given only candidates that cannot explain it (seal friction, valve overlap): whatever
    the noise model makes of the misfit, the report keeps the white level that no model
    explains (within 20 % of the level the record was made with) apart from the misfit the
    final model leaves beyond it, which is reported where the final model misses."""
    model = "HydraulicJoint"
    fmu_path(model)
    ds = gapgen.make(model, 1, ("cable_friction",), duration=4.0, rate=250.0)
    csv = tmp_path / "cable.csv"
    gapgen.write_csv(ds, csv)
    rep = run_ok(model, csv, tmp_path / "out", "--effects", "seal_friction,valve_overlap")
    assert "cable_friction" not in rep["named"]
    for name, o in rep["outputs"].items():
        true = ds["noise_sigma"][name]
        assert o["noise_white"] == pytest.approx(true, rel=0.2), name
        beyond = np.sqrt(max(0.0, o["rmse_after"] ** 2 - o["noise_white"] ** 2))
        assert o["unexplained_rms"] == pytest.approx(beyond, rel=1e-9, abs=1e-300), name
    missed = [n for n, o in rep["outputs"].items() if o["rmse_after"] > 1.5 * ds["noise_sigma"][n]]
    assert missed, rep["outputs"]
    for name in missed:
        assert rep["outputs"][name]["unexplained_rms"] > ds["noise_sigma"][name], name
