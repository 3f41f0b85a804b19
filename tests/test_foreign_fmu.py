"""The gap workflow on a foreign FMU: the geared DC motor of tests/fixtures/geared-motor/, plain C
written independently of the actuator-fmu crates, built here with gcc (tests/geared_motor.py).

Data are made by simulating that FMU with FMPy (random voltage steps, base parameters drawn
around their defaults, one effect hidden at a value drawn in the part of its range that such
data reveal, white noise of 1 % of each output's range, seeded), as tests/test_gap.py does for
our own FMUs. Each `gap` run takes about a second.
"""
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from conftest import REPO, cli_path

sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402
import geared_motor as gm  # noqa: E402

START_MISS = "the record does not begin where the model begins"


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """The FMU with its initial-state parameters ([initial]) and the variant without them,
    compiled once."""
    d = tmp_path_factory.mktemp("geared-motor")
    return {"initial": gm.build(d), "at_rest": gm.build(d, initial_state=False)}


def gap(fmu, ds, tmp_path, name, *args):
    csv = tmp_path / f"{name}.csv"
    gapgen.write_csv(ds, csv)
    out = tmp_path / name
    p = subprocess.run([cli_path(), "gap", str(fmu), "--data", str(csv), "--out", str(out),
                        "--quiet", *args], capture_output=True, text=True, timeout=300)
    rep = None
    if p.returncode == 0:
        rep = json.loads((out / "report.json").read_text())
    return p, rep


def test_validate_finds_nothing_in_either_variant(fmus):
    for fmu in fmus.values():
        p = subprocess.run([cli_path(), "validate", "--json", "--effects", str(fmu)],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stdout + p.stderr
        (res,) = json.loads(p.stdout)
        assert res["findings"] == [] and res["notes"] == [], res


def reference(t, u, p, on, x0):
    """SciPy Radau (rtol 1e-10) of the equations in geared_motor.c's header comment, with the
    voltage held over each sample interval, gear_compliance on."""
    def rhs(tt, x, uk):
        i, wm, ql, wl, phi = x
        tc = p["coulomb_friction.torque"] * np.tanh(wm / 1.0) if on["coulomb"] else 0.0
        grav = p["unbalanced_load.moment"] * np.sin(ql) if on["unbalanced"] else 0.0
        n = p["gear_ratio"]
        tg = p["gear_compliance.stiffness"] * phi + p["gear_compliance.damping"] * (wm / n - wl)
        return [(uk - p["resistance"] * i - p["torque_constant"] * wm) / p["inductance"],
                (p["torque_constant"] * i - p["motor_damping"] * wm - tc - tg / n)
                / p["rotor_inertia"],
                wl,
                (tg - p["load_damping"] * wl - grav) / p["load_inertia"],
                wm / n - wl]
    xs, x = [np.array(x0, float)], np.array(x0, float)
    for k in range(len(t) - 1):
        sol = solve_ivp(rhs, (t[k], t[k + 1]), x, method="Radau", rtol=1e-10, atol=1e-12,
                        args=(u[k],))
        x = sol.y[:, -1]
        xs.append(x)
    return np.array(xs)


def test_the_c_fmu_integrates_its_documented_equations(fmus):
    """The C FMU (RK4 substeps) against an independent SciPy Radau integration of the equations
    its header documents, all three smooth effects on and a state that begins in motion: the
    outputs agree to 1e-4 of their range."""
    t = np.round(np.arange(0, 201) / 200.0, 12)
    u = gm.voltage_steps(np.random.default_rng(5), t)
    p = {k: v["start"] for k, v in gm.variables().items() if v["type"] == "Real"}
    p.update({"coulomb_friction.torque": 0.03, "unbalanced_load.moment": 1.0,
              "gear_compliance.stiffness": 20.0, "gear_compliance.damping": 0.02})
    start = {"current_start": 1.5, "motor_speed_start": 80.0, "load_angle_start": 0.7}
    sets = dict(start, **{k: p[k] for k in ("coulomb_friction.torque", "unbalanced_load.moment",
                                            "gear_compliance.stiffness",
                                            "gear_compliance.damping")})
    sets.update({"coulomb_friction.enabled": True, "unbalanced_load.enabled": True,
                 "gear_compliance.enabled": True})
    res = gm.simulate(fmus["initial"], t, u, sets)
    x0 = [1.5, 80.0, 0.7, 80.0 / p["gear_ratio"], 0.0]
    ref = reference(t, u, p, {"coulomb": True, "unbalanced": True}, x0)
    for j, name in enumerate(gm.OUTPUTS):
        span = np.ptp(ref[:, j])
        assert span > 0
        assert np.max(np.abs(res[name] - ref[:, j])) <= 1e-4 * span, name


def test_the_current_limit_holds(fmus):
    """current_saturation: the current never leaves [-limit, limit] and reaches it."""
    t = np.round(np.arange(0, 401) / 200.0, 12)
    u = gm.voltage_steps(np.random.default_rng(6), t)
    res = gm.simulate(fmus["initial"], t, u, {"current_saturation.enabled": True,
                                               "current_saturation.limit": 2.0})
    assert np.max(np.abs(res["current"])) <= 2.0 + 1e-12
    assert np.max(np.abs(res["current"])) >= 2.0 - 1e-9


def check_shrink(rep, ds):
    """The gap shrinks: each output ends within 1.2x its noise level or 5x below the base fit."""
    for n, o in rep["outputs"].items():
        s = ds["noise_sigma"][n]
        assert o["rmse_after"] <= 1.2 * s or 5 * o["rmse_after"] <= o["rmse_base_fit"], (n, o, s)


@pytest.mark.parametrize("effect,seed", [
    ("coulomb_friction", 21),
    ("current_saturation", 22),
    ("gear_compliance", 23),
    ("unbalanced_load", 24),
])
def test_the_hidden_effect_is_named(fmus, tmp_path, effect, seed):
    ds = gm.make(fmus["initial"], seed, (effect,))
    p, rep = gap(fmus["initial"], ds, tmp_path, effect)
    assert p.returncode == 0, p.stderr
    assert rep["named"] == [effect], rep["verdict"]
    check_shrink(rep, ds)
    # The drawn truth lies inside the reported 95 % interval of each effect parameter.
    for name in gm.EFFECTS[effect]:
        e = rep["parameters"][name]
        assert e["ci_low"] <= ds["truth"][name] <= e["ci_high"], (name, e, ds["truth"][name])


def test_nothing_hidden_names_nothing(fmus, tmp_path):
    ds = gm.make(fmus["initial"], 25)
    p, rep = gap(fmus["initial"], ds, tmp_path, "none")
    assert p.returncode == 0, p.stderr
    assert rep["named"] == [], rep["verdict"]
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)
    # A record from rest needs no initial state: none is estimated.
    assert not any(n in rep["parameters"] for n in gm.INITIAL)
    assert not any("does not begin at rest" in w for w in rep["warnings"])


@pytest.mark.parametrize("hidden,seed", [((), 31), (("current_saturation",), 32),
                                         (("unbalanced_load",), 33)])
def test_a_record_begun_in_motion_gets_its_initial_state_estimated(fmus, tmp_path, hidden,
                                                                   seed):
    """A record that begins 1 s into the motion (time reset to 0): the FMU's [initial]
    parameters are estimated with the base parameters (and the report says so), the hidden
    effect (or none) is named, nothing else, and the state the record began in lies inside the
    reported intervals."""
    ds = gm.make(fmus["initial"], seed, hidden, skip=1.0)
    # The record begins far from rest (more than 10 noise levels in speed or angle).
    x0, sig = ds["state_at_start"], ds["noise_sigma"]
    assert max(abs(x0["motor_speed_start"]) / sig["motor_speed"],
               abs(x0["load_angle_start"]) / sig["load_angle"]) > 10, x0
    p, rep = gap(fmus["initial"], ds, tmp_path, "moving")
    assert p.returncode == 0, p.stderr
    assert rep["named"] == list(hidden), rep["verdict"]
    assert any("does not begin at rest" in w for w in rep["warnings"]), rep["warnings"]
    check_shrink(rep, ds)
    for name, truth in ds["state_at_start"].items():
        e = rep["parameters"][name]
        assert e["ci_low"] <= truth <= e["ci_high"], (name, e, truth)


@pytest.mark.parametrize("hidden,seed", [((), 41), (("current_saturation",), 42)])
def test_a_record_begun_in_motion_without_initial_state_parameters_stops(fmus, tmp_path,
                                                                         hidden, seed):
    """The variant without [initial] parameters cannot begin in motion: gap stops with exit
    status 2 and one message that says what to do, names no effect and writes no report."""
    ds = gm.make(fmus["at_rest"], seed, hidden, skip=1.0)
    p, rep = gap(fmus["at_rest"], ds, tmp_path, "moving")
    assert p.returncode == 2, p.stdout + p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and len(lines[0]) < 1500, p.stderr
    assert START_MISS in lines[0]
    assert "[initial]" in lines[0] and "--set" in lines[0] and "at rest" in lines[0]
    assert not (tmp_path / "moving" / "report.json").exists()
    assert "named" not in p.stdout


def test_calibration_only_of_a_record_begun_in_motion_warns(fmus, tmp_path):
    """With --rounds 0 nothing can be named, so the start miss is a warning of the calibration,
    not a stop."""
    ds = gm.make(fmus["at_rest"], 41, (), skip=1.0)
    p, rep = gap(fmus["at_rest"], ds, tmp_path, "calibrate", "--rounds", "0")
    assert p.returncode == 0, p.stderr
    assert rep["named"] == []
    assert any(w.startswith(START_MISS) and "[initial]" in w for w in rep["warnings"]), rep


def test_the_variant_from_rest_is_unaffected(fmus, tmp_path):
    """From rest, the variant without [initial] parameters gets the ordinary workflow."""
    ds = gm.make(fmus["at_rest"], 43, ("unbalanced_load",))
    p, rep = gap(fmus["at_rest"], ds, tmp_path, "rest")
    assert p.returncode == 0, p.stderr
    assert rep["named"] == ["unbalanced_load"], rep["verdict"]
    assert not any(n in rep["parameters"] for n in gm.INITIAL)


def test_an_initial_state_given_with_set_is_not_estimated(fmus, tmp_path):
    """The initial state given with --set is used as given: the run works from a record begun
    in motion, and no initial-state parameter is reported as fitted."""
    ds = gm.make(fmus["initial"], 44, (), skip=1.0)
    sets = [f"--set={k}={float(v)!r}" for k, v in ds["state_at_start"].items()]
    p, rep = gap(fmus["initial"], ds, tmp_path, "given", *sets)
    assert p.returncode == 0, p.stderr
    assert rep["named"] == [], rep["verdict"]
    assert not any(n in rep["parameters"] for n in gm.INITIAL)
    for n, o in rep["outputs"].items():
        assert o["rmse_after"] <= 1.2 * ds["noise_sigma"][n], (n, o)


def with_missing_samples(csv, every, cells=("", "NaN")):
    """Blanks an output cell of every `every`-th data row of `csv` (an empty cell or `NaN` by
    turns, as loggers write a dropped sample); returns how many rows lost one."""
    lines = csv.read_text().splitlines()
    head = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    last = len(lines[head].split(",")) - 1
    holed = 0
    for k, i in enumerate(range(head + 1 + 3, len(lines), every)):
        cells_of_row = lines[i].split(",")
        cells_of_row[last] = cells[k % len(cells)]
        lines[i] = ",".join(cells_of_row)
        holed += 1
    csv.write_text("\n".join(lines) + "\n")
    return holed, lines[head].split(",")[last]


def test_rows_missing_a_sample_are_left_out_and_the_effect_still_named(fmus, tmp_path):
    ds = gm.make(fmus["initial"], 21, ("coulomb_friction",))
    csv = tmp_path / "holes.csv"
    gapgen.write_csv(ds, csv)
    holed, column = with_missing_samples(csv, 40)
    rows = len(ds["time"])
    out = tmp_path / "holes"
    p = subprocess.run([cli_path(), "gap", str(fmus["initial"]), "--data", str(csv), "--out",
                        str(out), "--quiet"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    rep = json.loads((out / "report.json").read_text())
    assert rep["named"] == ["coulomb_friction"], rep["verdict"]
    for name in gm.EFFECTS["coulomb_friction"]:
        e = rep["parameters"][name]
        assert e["ci_low"] <= ds["truth"][name] <= e["ci_high"], (name, e, ds["truth"][name])
    said = [w for w in rep["warnings"] if "miss a sample" in w]
    assert len(said) == 1 and f"{holed} of {rows} rows" in said[0] and f"{column}: {holed}" in said[0], said


def test_a_record_missing_many_samples_is_refused_naming_the_column(fmus, tmp_path):
    ds = gm.make(fmus["initial"], 21, ("coulomb_friction",))
    csv = tmp_path / "sieve.csv"
    gapgen.write_csv(ds, csv)
    holed, column = with_missing_samples(csv, 5)
    p = subprocess.run([cli_path(), "gap", str(fmus["initial"]), "--data", str(csv), "--out",
                        str(tmp_path / "sieve"), "--quiet"], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 2, p.stderr
    assert p.stderr.count("\n") == 1 and f"most in column '{column}': {holed}" in p.stderr, p.stderr
    assert not (tmp_path / "sieve" / "report.json").exists()
