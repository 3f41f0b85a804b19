"""Acceptance tests of the EMPS FMU on the benchmark's measured records.

The FMU is simulated with FMPy (Co-Simulation, 1 ms steps). Expected values come from the
independent SciPy reference (tests/reference/emps_ref.py), the benchmark files themselves and the
published numbers of the description (Janot, Gautier, Brunot 2019), never from the FMU's own
output. The records are read from ../shared/data/emps/ (relative to the repository) and never
committed; without them the tests that need them are skipped.
"""
import os
import subprocess
import sys

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from conftest import REPO, fmu3_path, fmu_path

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "reference"))
sys.path.insert(0, str(REPO / "scripts"))
import emps_csv  # noqa: E402
import emps_ref as ref  # noqa: E402

DATA = REPO.parent / "shared" / "data" / "emps"
ESTIMATION = DATA / "DATA_EMPS.mat"
PULSES = DATA / "DATA_EMPS_PULSES.mat"
needs_data = pytest.mark.skipif(
    not (ESTIMATION.exists() and PULSES.exists()),
    reason=f"EMPS records not found in {DATA} (DATA_EMPS.mat, DATA_EMPS_PULSES.mat of the "
           "benchmark's EMPS.zip, nonlinearbenchmark.org)")
OUTPUTS = ["qm", "force", "velocity", "voltage"]
SYM = ref.PUBLISHED_SYMMETRIC
ASYM = ref.PUBLISHED_ASYMMETRIC


def fmu():
    return fmu_path("EMPS")


def record(path):
    """The record, the start state (q0 = qm(0); v0 from the logged law inverted at sample 0)."""
    rec = ref.load_record(path)
    v0 = ref.KP * (rec["qg"][0] - rec["qm"][0]) - rec["vir"][0] / ref.KV
    return rec, rec["qm"][0], v0


def held(x):
    """Sample k's value at row k + 1 (the FMU's Co-Simulation stamping)."""
    return np.concatenate([x[:1], x[:-1]])


def sim(params, qg, force_pulse=None, force_measured=None, path=None):
    """FMPy Co-Simulation at the controller's 1 ms over len(qg) samples."""
    n = len(qg)
    t = 1e-3 * np.arange(n)
    zeros = np.zeros(n)
    cols = [t, qg, zeros if force_pulse is None else force_pulse,
            zeros if force_measured is None else force_measured]
    inp = np.array(list(zip(*cols)), dtype=[("time", float), ("qg", float),
                                            ("force_pulse", float), ("force_measured", float)])
    return simulate_fmu(path or fmu(), stop_time=t[-1], step_size=1e-3, output_interval=1e-3,
                        start_values=params, input=inp, output=OUTPUTS)


def symmetric_start(q0, v0, **extra):
    return {"mass": SYM["mass"], "viscous_friction": SYM["viscous_friction"],
            "offset": SYM["offset"], "coulomb_friction.enabled": True,
            "coulomb_friction.force": SYM["coulomb"], "q0": q0, "v0": v0, **extra}


def symmetric_ref(**extra):
    return ref.Params(mass=SYM["mass"], viscous_friction=SYM["viscous_friction"],
                      offset=SYM["offset"], coulomb=SYM["coulomb"], **extra)


def read_csv(path):
    """A converted record as a structured array (comment lines skipped)."""
    lines = [ln for ln in open(path) if not ln.startswith("#")]
    return np.genfromtxt(lines, delimiter=",", names=True)


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.fixture(scope="module")
def estimation_symmetric():
    """The FMU and both references on the whole estimation record, published symmetric set."""
    rec, q0, v0 = record(ESTIMATION)
    res = sim(symmetric_start(q0, v0), rec["qg"])
    exact = ref.simulate(rec["qg"], symmetric_ref(), q0=q0, v0=v0, friction="exact")
    smooth = ref.simulate(rec["qg"], symmetric_ref(), q0=q0, v0=v0, friction="smooth")
    return rec, res, exact, smooth


# ---- the data and the logged controller -------------------------------------------------------

@needs_data
def test_logged_controller_reproduces_vir():
    """The law of the description (eq. 6, sec. 2.2) gives the logged vir from the logged qg, qm:
    3.7 mV RMS (data README: about 4 mV) with no delay; the validation record with the pulses
    added before the saturation at the converter's fitted gain: 4.7 mV."""
    rec, _, _ = record(ESTIMATION)
    err = ref.logged_controller(rec["qg"], rec["qm"])[2:] - rec["vir"][2:]
    assert rms(err) < 0.005, rms(err)
    delayed = ref.logged_controller(rec["qg"], rec["qm"])[2:-1] - rec["vir"][3:]
    assert rms(delayed) > 10 * rms(err)  # one sample of delay does not fit
    rec = ref.load_record(PULSES)
    raw = emps_csv.load(PULSES)
    gain = emps_csv.pulse_gain(raw, emps_csv.controller_velocity(raw))
    assert abs(gain - 1.0139) < 1e-3, gain
    err = ref.logged_controller(rec["qg"], rec["qm"], rec["pulses_N"], gain)[2:] - rec["vir"][2:]
    assert rms(err) < 0.006, rms(err)


@needs_data
def test_csv_conversion(tmp_path):
    """Columns named as the FMU's variables, SI, the controller's outputs at the end of the
    interval they were held over; the uint8 pulses converted before arithmetic."""
    paths = emps_csv.convert(DATA, tmp_path, "held")
    md = read_model_description(fmu())
    names = {v.name for v in md.modelVariables}
    for path in paths:
        header = [ln for ln in open(path) if not ln.startswith("#")][0].strip().split(",")
        assert header[0] == "time" and set(header[1:]) <= names, header
    table = read_csv(paths[1])
    rec = ref.load_record(PULSES)
    assert np.allclose(table["time"], 1e-3 * np.arange(rec["t"].size))
    assert np.allclose(table["force"][1:], ref.GTAU * rec["vir"][:-1], rtol=1e-10)
    assert np.allclose(table["force_measured"], ref.GTAU * rec["vir"], rtol=1e-10)
    v = (rec["qm"][2:-1] - rec["qm"][:-3]) / 2e-3  # sample k - 1's at row k
    assert np.allclose(table["velocity"][3:], v, rtol=1e-9, atol=1e-12)
    pulses = table["force_pulse"]
    assert set(np.round(np.unique(pulses), 1)) == {0.0, 178.2}, np.unique(pulses)
    sample = emps_csv.convert(DATA, tmp_path / "s", "sample")[0]
    est = read_csv(sample)
    assert np.allclose(est["force"], est["force_measured"])
    assert not est["force_pulse"].any()


def test_csv_conversion_refuses_what_is_not_the_benchmark(tmp_path):
    """A missing record names where to get it; a record off the 1 kHz grid is refused."""
    with pytest.raises(emps_csv.RecordError, match="EMPS.zip"):
        emps_csv.load(tmp_path / "DATA_EMPS.mat")
    import scipy.io
    bad = tmp_path / "bad.mat"
    t = np.arange(10) * 2e-3
    scipy.io.savemat(bad, {"t": t, "qg": t, "qm": t, "vir": t, "gtau": 35.0, "kp": 1.0, "kv": 1.0})
    with pytest.raises(emps_csv.RecordError, match="1 kHz"):
        emps_csv.load(bad)
    assert emps_csv.main(["--data-dir", str(tmp_path / "none"), "--out-dir", str(tmp_path)]) == 1


# ---- the FMU against the reference ------------------------------------------------------------

@needs_data
def test_fmu_matches_reference_with_the_same_smooth_sign(estimation_symmetric):
    """The same equations (smooth sign, v_s = 0.1 mm/s) integrated by SciPy's LSODA at rtol 1e-11:
    agreement at solver accuracy over the 24.84 s record. The FMU's rtol = atol = 1e-6 bounds each
    1 ms interval's position error near 1e-9 m (positions integrated relative to the interval's
    start, nominal 1 mm); through the loop's stiffness gtau kv kp = 1.37e6 N/m that is 1e-3 N.
    Measured: 3.6e-6 N RMS, 7.6e-5 N at most; qm 1.8e-11 m."""
    _, res, _, smooth = estimation_symmetric
    assert np.abs(res["qm"] - smooth["qm"]).max() < 1e-9
    assert rms(res["force"] - smooth["force"]) < 1e-3
    assert np.abs(res["force"] - smooth["force"]).max() < 1e-2
    assert np.abs(res["velocity"] - smooth["velocity"]).max() < 1e-6


@needs_data
def test_fmu_near_event_exact_reference(estimation_symmetric):
    """Against the event-exact sign with sticking: the smoothing acts only within a few v_s of a
    reversal (tanh(v / v_s) departs from sign(v) by > 0.1 % below 0.38 mm/s), where the force
    differs by up to Fc for well under a sample before the loop corrects it. Measured 0.13 N RMS
    (0.25 % of the force's 54 N RMS), 1.4 N at most, qm 74 nm RMS; bounds 0.5 N RMS, Fc / 4 at
    most, 0.5 um."""
    _, res, exact, _ = estimation_symmetric
    assert rms(res["force"] - exact["force"]) < 0.5
    assert np.abs(res["force"] - exact["force"]).max() < SYM["coulomb"] / 4
    assert rms(res["qm"] - exact["qm"]) < 0.5e-6


@needs_data
def test_published_symmetric_force_error(estimation_symmetric):
    """Eq. 11 on the estimation record with the published symmetric set. The description's
    closed-loop simulation (sec. 3.5, a Simulink model with one sample of delay) reports 5.848 %
    for the force; the delay is this FMU's controller_delay at 1 ms: within 0.15 points of it
    (measured 5.77 %, the event-exact reference 5.86 %: the smooth sign moves it by about 0.1
    point, section 4 of the documentation). As logged (no delay) the error is 4.51 %, near the
    inverse model's 4.08 % (sec. 3.4): between 4 and 5 %."""
    rec, res, _, _ = estimation_symmetric
    measured = held(ref.GTAU * rec["vir"])
    as_logged = ref.relative_error(measured, res["force"])
    assert 4.0 < as_logged < 5.0, as_logged
    _, q0, v0 = record(ESTIMATION)
    delayed = sim(symmetric_start(q0, v0, **{"controller_delay.enabled": True,
                                             "controller_delay.time": 1e-3}), rec["qg"])
    err = ref.relative_error(measured, delayed["force"])
    assert abs(err - 5.848) < 0.15, err
    # the position hardly depends on the parameters (the loop holds it): description 0.0138 %
    assert ref.relative_error(rec["qm"], res["qm"]) < 0.02


@needs_data
def test_published_asymmetric_set_fits_better():
    """The asymmetric friction of eq. 12 lowers the inverse model's error from 4.08 to 3.11 %
    (sec. 4.2); in closed-loop simulation the force error falls likewise (measured 4.51 -> 3.65 %)."""
    rec, q0, v0 = record(ESTIMATION)
    start = {"mass": ASYM["mass"], "viscous_friction": ASYM["viscous_friction"], "offset": 0.0,
             "coulomb_friction.enabled": True, "coulomb_friction.force": ASYM["coulomb"],
             "asymmetric_friction.enabled": True,
             "asymmetric_friction.viscous_negative": ASYM["viscous_negative"],
             "asymmetric_friction.coulomb_negative": ASYM["coulomb_negative"], "q0": q0, "v0": v0}
    res = sim(start, rec["qg"])
    measured = held(ref.GTAU * rec["vir"])
    err = ref.relative_error(measured, res["force"])
    assert 3.2 < err < 4.2, err
    exact = ref.simulate(rec["qg"], ref.Params(**ASYM), q0=q0, v0=v0, friction="exact")
    assert rms(res["force"] - exact["force"]) < 0.5


# ---- effects, pulses and the open loop against the reference (first seconds) ------------------

EFFECTS = {
    "controller_delay": ({"controller_delay.enabled": True, "controller_delay.time": 1.5e-3},
                         {"delay": 1.5e-3}),
    "position_friction": ({"position_friction.enabled": True, "position_friction.change": 0.3},
                          {"friction_gradient": 0.3 / 0.125}),
    "flexibility": ({"flexibility.enabled": True, "flexibility.stiffness": 2e6,
                     "flexibility.damping_ratio": 0.05}, {"stiffness": 2e6, "load_mass": 10.0}),
    "backlash": ({"backlash.enabled": True, "backlash.width": 50e-6},
                 {"backlash": 50e-6, "load_mass": 10.0}),
}


@needs_data
@pytest.mark.parametrize("effect", sorted(EFFECTS))
def test_effect_against_reference(effect):
    """Each effect's equations against the smooth reference over the first 1.5 s of the
    validation record (pulses included: the first at 0.344 s), at the base model's tolerances
    (1 nm, 10 mN). Backlash: the contact switches the coupling force's slope and its damping on
    and off, and an error-controlled step across such a switch is only as accurate as its
    error estimate there: at the default rtol = atol = 1e-6 the FMU is 0.15 um and 0.9 N from
    the reference at the impacts of the first pulse (bounds 0.5 um, 2 N), converging with the
    tolerance (1e-8: 5.8 nm; 1e-10: 0.06 nm, 0.3 mN), so it is compared at 1e-10."""
    fmu_extra, ref_extra = EFFECTS[effect]
    rec, q0, v0 = record(PULSES)
    n = 1500
    pulse = ref.GTAU * 1.0139 * rec["pulses_N"][:n]
    out = ref.simulate(rec["qg"][:n], symmetric_ref(**ref_extra), force_pulse=pulse, q0=q0,
                       v0=v0, friction="smooth")
    res = sim(symmetric_start(q0, v0, **fmu_extra), rec["qg"][:n], force_pulse=pulse)
    if effect == "backlash":
        assert np.abs(res["qm"] - out["qm"]).max() < 0.5e-6
        assert np.abs(res["force"] - out["force"]).max() < 2.0
        tight = symmetric_start(q0, v0, rtol=1e-10, atol=1e-10, **fmu_extra)
        res = sim(tight, rec["qg"][:n], force_pulse=pulse)
    assert np.abs(res["qm"] - out["qm"]).max() < 1e-9
    assert np.abs(res["force"] - out["force"]).max() < 1e-2
    base = sim(symmetric_start(q0, v0), rec["qg"][:n], force_pulse=pulse)
    assert rms(res["force"] - base["force"]) > 0.1  # the effect acts


@needs_data
def test_open_loop_follows_the_measured_force():
    """Open loop: the measured force drives the axis; the same through the reference. The pure
    integrator drifts from the measured position (description sec. 1.3), the model from its
    reference does not."""
    rec, q0, v0 = record(ESTIMATION)
    n = 2000
    force = ref.GTAU * rec["vir"][:n]
    start = symmetric_start(q0, v0, internal_controller=False)
    res = sim(start, rec["qg"][:n], force_measured=force)
    out = ref.simulate(rec["qg"][:n], symmetric_ref(), q0=q0, v0=v0, friction="smooth",
                       open_loop_force=force)
    assert np.abs(res["qm"] - out["qm"]).max() < 1e-9
    assert np.allclose(res["force"][1:], force[:-1])
    assert np.abs(res["velocity"] - out["velocity"]).max() < 1e-6


@needs_data
def test_fmi3_archive_gives_the_same_outputs():
    """The FMI 3.0 archive holds the same model code: bit-identical outputs."""
    rec, q0, v0 = record(PULSES)
    n = 1000
    pulse = ref.GTAU * 1.0139 * rec["pulses_N"][:n]
    a = sim(symmetric_start(q0, v0), rec["qg"][:n], force_pulse=pulse)
    b = sim(symmetric_start(q0, v0), rec["qg"][:n], force_pulse=pulse, path=fmu3_path("EMPS"))
    for name in OUTPUTS:
        assert np.array_equal(a[name], b[name]), name


@needs_data
@pytest.mark.parametrize("archive", ["fmi2", "fmi3"])
@pytest.mark.parametrize("effect", ["base", "controller_delay", "flexibility"])
def test_model_exchange_matches_co_simulation(archive, effect):
    """Model Exchange (FMPy's CVode at relative tolerance 1e-8, the controller's samples and the
    delayed force changes as time events) against Co-Simulation over the first 2 s of the
    validation record, at each grid point's left limit (the Co-Simulation stamping). The
    difference is CVode's error: measured qm 2e-8 m, force 0.04 N at most (delay 1.5 ms: 5e-8 m,
    0.10 N; flexibility: 2e-9 m, 4 mN); bounds 2e-7 m and 0.5 N."""
    extra = {"base": {}, "controller_delay": EFFECTS["controller_delay"][0],
             "flexibility": EFFECTS["flexibility"][0]}[effect]
    path = fmu() if archive == "fmi2" else fmu3_path("EMPS")
    rec, q0, v0 = record(PULSES)
    n = 2000
    pulse = ref.GTAU * 1.0139 * rec["pulses_N"][:n]
    t = 1e-3 * np.arange(n)
    inp = np.array(list(zip(t, rec["qg"][:n], pulse, np.zeros(n))),
                   dtype=[("time", float), ("qg", float), ("force_pulse", float),
                          ("force_measured", float)])
    start = symmetric_start(q0, v0, **extra)
    cs = sim(start, rec["qg"][:n], force_pulse=pulse, path=path)
    me = simulate_fmu(path, stop_time=t[-1], step_size=1e-3, output_interval=1e-3,
                      start_values=start, input=inp, output=OUTPUTS,
                      fmi_type="ModelExchange", relative_tolerance=1e-8)
    _, first = np.unique(np.round(me["time"], 9), return_index=True)
    me = me[first]  # the row before an event at a repeated time: the left limit
    me = me[np.abs(me["time"] * 1e3 - np.round(me["time"] * 1e3)) < 1e-6]
    assert np.allclose(me["time"], cs["time"])
    assert np.abs(me["qm"] - cs["qm"]).max() < 2e-7
    assert np.abs(me["force"] - cs["force"]).max() < 0.5


@needs_data
@pytest.mark.parametrize("interface", ["cs", "me"])
def test_gap_simulates_the_closed_loop_as_simulate_does(tmp_path, interface):
    """gap's simulation of the model as given (its traces.csv, `force.nominal`) is
    `actuator-fmu simulate`'s output on the same record and settings, sample for sample: in
    Co-Simulation the values after the step that ends at each sample (the force held over it,
    FMI 3.0.2 section 4: no direct feedthrough across a step), in Model Exchange the values
    after the events at each sample (simulate's last row at that time, the controller's sample
    taken with that time's reference). 1.5 s of the estimation record, `sample` stamping."""
    from conftest import cli_path
    out = tmp_path / "csv"
    subprocess.run([sys.executable, str(REPO / "scripts" / "emps_csv.py"), "--out-dir", str(out),
                    "--stamp", "sample"], check=True, capture_output=True)
    lines = (out / "emps_estimation.csv").read_text().splitlines(keepends=True)
    body = [ln for ln in lines if not ln.startswith("#")]
    csv = tmp_path / "short.csv"
    csv.write_text("".join(body[:1501]))
    _, q0, v0 = record(ESTIMATION)
    sets = [f"q0={float(q0)!r}", f"v0={float(v0)!r}", "coulomb_friction.enabled=true",
            f"coulomb_friction.force={SYM['coulomb']}"]
    sim_out = tmp_path / "sim.csv"
    set_args = [a for s in sets for a in ("--set", s)]
    p = subprocess.run([cli_path(), "simulate", fmu(), "--data", str(csv), "--out", str(sim_out),
                        "--interface", interface, *set_args], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    p = subprocess.run([cli_path(), "gap", fmu(), "--data", str(csv), "--out", str(tmp_path / "g"),
                        "--interface", interface, "--quiet", "--rounds", "0", "--fit", "mass",
                        *set_args], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr + p.stdout
    ours = read_csv(tmp_path / "g" / "traces.csv")
    theirs = read_csv(sim_out)
    # the last row at each time (Model Exchange writes one before and one after an event)
    keep = np.append(theirs["time"][1:] != theirs["time"][:-1], True)
    theirs = theirs[keep]
    # simulate's communication points are start + k h, the data's times k / 1000
    assert np.allclose(ours["time"], theirs["time"], rtol=0, atol=1e-12)
    for name in ("qm", "force", "velocity"):
        diff = np.abs(ours[f"{name}nominal"] - theirs[name])
        assert diff.max() <= 1e-12 * np.abs(theirs[name]).max(), (name, diff.max())


@pytest.fixture(scope="module")
def estimation_gap(tmp_path_factory):
    """`actuator-fmu gap` on the whole estimation record (held stamping), default candidates."""
    from conftest import cli_path
    tmp = tmp_path_factory.mktemp("emps_gap")
    subprocess.run([sys.executable, str(REPO / "scripts" / "emps_csv.py"), "--out-dir", str(tmp)],
                   check=True, capture_output=True)
    p = subprocess.run([cli_path(), "gap", fmu(), "--data", str(tmp / "emps_estimation.csv"),
                        "--out", str(tmp / "g"), "--quiet"], capture_output=True, text=True,
                       timeout=1200)
    assert p.returncode == 0, p.stderr + p.stdout
    import json
    return json.loads((tmp / "g" / "report.json").read_text())


@needs_data
@pytest.mark.long
def test_a_named_effect_is_never_called_invisible(estimation_gap):
    """On the estimation record gap names friction effects with a ΔBIC in the hundreds, while
    the scan about a base fit on which an effect is inert called them invisible. A refit
    reaching the naming threshold shows the effect: every named candidate's visibility reaches
    what naming needs, with a setting where the data show it, and no verdict lists it among
    the effects these data cannot reveal."""
    rep = estimation_gap
    assert rep["named"], rep["verdict"]
    named = [c for rnd in rep["candidates"] for c in rnd if c["decision"]["kind"] == "named"]
    assert {c["effect"] for c in named} == set(rep["named"])
    for c in named:
        assert c["visibility"] >= c["visibility_needed"], c
        assert c["detectable_from"], c
    for rnd in rep["candidates"]:
        for c in rnd:
            reach = c["decision"].get("unrevealable")
            assert not (reach and c["effect"] in rep["named"]), c
    open_ = rep["decision"].get("open") or {}
    assert not {u["effect"] for u in open_.get("unrevealable", [])} & set(rep["named"])


@needs_data
def test_without_the_friction_candidates_no_decoy_is_named(tmp_path):
    """The benchmark's authors name asymmetric Coulomb friction as what a viscous-only model
    leaves out. With Coulomb and asymmetric friction taken out of the candidates, no other
    (controller delay, flexibility, friction along the screw, backlash) is what is missing:
    some pass ΔBIC 10 on a model this far from the record, yet none is named as the
    explanation; the run reports (exit 0, no refusal of the record) that a disagreement
    remains, with where."""
    from conftest import cli_path
    import json
    subprocess.run([sys.executable, str(REPO / "scripts" / "emps_csv.py"), "--out-dir",
                    str(tmp_path)], check=True, capture_output=True)
    p = subprocess.run([cli_path(), "gap", fmu(), "--data", str(tmp_path / "emps_estimation.csv"),
                        "--out", str(tmp_path / "g"), "--quiet", "--effects",
                        "controller_delay,flexibility,position_friction,backlash"],
                       capture_output=True, text=True, timeout=1200)
    assert p.returncode == 0, p.stderr + p.stdout
    rep = json.loads((tmp_path / "g" / "report.json").read_text())
    assert rep["named"] == [], rep["verdict"]
    assert rep["decision"]["kind"] != "named", rep["decision"]
    # The disagreement is reported where it is: the force, located in time.
    dis = rep["disagreement"]
    assert dis is not None, rep
    force = next(o for o in dis["outputs"] if o["output"] == "force")
    assert force["rmse_over_noise"] > 1.5 and force["windows"], force
    for rnd in rep["candidates"]:
        for c in rnd:
            assert c["decision"]["kind"] != "named", c
