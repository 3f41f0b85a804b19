"""Driver of scripts/bench (see there). Prints one line per model:
`<Model> speedup <N>x (...)`, then the cost of the deterministic math per model, the host's
Model Exchange run per model (`<Model> ME speedup <N>x`), our ME FMU under FMPy's CVode against
our CS FMU per model, FMI 3.0 CS against FMI 2.0 CS per model, one line per Model Exchange
fixture: `<Fixture> ME speedup <N>x (...)`, then the gap workflow lines.
`--only NAME[,NAME...]` runs the named benchmarks only (see BENCHES)."""
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests" / "reference"))
QUICK = "--quick" in sys.argv
# --smoke (the tests): that the benchmarks run and print, on 0.2 s; not a measurement
SMOKE = "--smoke" in sys.argv
QUICK = QUICK or SMOKE
T_END = 0.2 if SMOKE else 2.0 if QUICK else 10.0
DT = 1e-3


def min_jerk(t, amplitude, t0, duration):
    s = np.clip((t - t0) / duration, 0.0, 1.0)
    return amplitude * (10 * s**3 - 15 * s**4 + 6 * s**5)


def scenario(model):
    """Inputs (name -> (times, values)) of the benchmark run: a realistic closed-loop task."""
    t = np.arange(0.0, T_END + DT / 2, DT)
    if model == "HydraulicJoint":
        ref = min_jerk(t, math.radians(45), 0.0, 1.0) - min_jerk(t, math.radians(45), T_END / 2, 1.0)
        return {"theta_ref": (t, ref)}
    ref = min_jerk(t, 1500.0, 0.0, 1.0) - min_jerk(t, 1000.0, T_END / 2, 1.0)
    return {"theta_motor_ref": (t, ref)}


def run_fmu(model, inputs, out_csv, repeat, rtol, fmu=None, me=False):
    with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
        names = list(inputs)
        f.write(",".join(["time"] + names) + "\n")
        t = inputs[names[0]][0]
        for k in range(len(t)):
            f.write(",".join(repr(float(x)) for x in [t[k]] + [inputs[n][1][k] for n in names]) + "\n")
    fmu = fmu or REPO / f"dist/{model}.fmu"
    cmd = [str(REPO / "target/release/fmu-bench"), str(fmu), "--inputs", f.name,
           "--stop", str(T_END), "--step", str(DT), "--repeat", str(repeat), "--out", str(out_csv),
           "--set", f"rtol={rtol}", "--set", f"atol={rtol}"]
    if me:
        # the host integrates: its tolerance; the FMU's own solver parameters are not used
        cmd = cmd[:-4] + ["--me", "--tolerance", str(rtol)]
    timing = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
    data = np.genfromtxt(out_csv, delimiter=",", names=True)
    return timing["median_s"], {n: data[n] for n in data.dtype.names if n != "time"}


def run_scipy(model, inputs, rtol):
    if model == "HydraulicJoint":
        import hydraulic_joint_ref as ref
        kwargs = {"rtol": rtol, "atol": rtol}
    else:
        import twisted_string_ref as ref
        kwargs = {"rtol": rtol, "atol_scale": rtol}
    t0 = time.perf_counter()
    out = ref.simulate({}, inputs, T_END, DT, **kwargs)
    return time.perf_counter() - t0, out


_TRUTH = {}


def scipy_truth(model):
    """The SciPy reference at rtol 1e-10 on the bench scenario (computed once per model)."""
    if model not in _TRUTH:
        _TRUTH[model] = run_scipy(model, scenario(model), rtol=1e-10)[1]
    return _TRUTH[model]


def rel_errors(result, truth):
    """(worst RMS error, its output, worst max error, its output) over all outputs, each relative
    to the output's range in the truth. The verdict uses the RMS error: the models' discrete
    decisions (encoder quantisation, the +-2 deg band, dead bands) can flip on a near-tie in either
    implementation, which moves the max error of a few samples but hardly the RMS."""
    rms, rms_at, mx, mx_at = 0.0, "", 0.0, ""
    for name, x in truth.items():
        if name not in result:
            continue
        x = np.asarray(x)
        span = float(np.ptp(x)) or max(1e-12, float(np.max(np.abs(x))))
        d = np.abs(np.asarray(result[name])[: len(x)] - x) / span
        r, m = float(np.sqrt(np.mean(d * d))), float(np.max(d))
        if r > rms:
            rms, rms_at = r, name
        if m > mx:
            mx, mx_at = m, name
    return rms, rms_at, mx, mx_at


def bench_model(model):
    """The FMU's rtol and atol are tightened (1e-6 ... 1e-10) until its error is no larger than the
    SciPy peer's, so the speedup is always at equal or better accuracy. On the TwistedString run
    both the FMU at 1e-7..1e-8 and SciPy at 1e-6 flip one or two encoder-count decisions of the
    position loop against the truth (a near-tie at a sample; each flip leaves a 2e-5 blip in the
    current), so which of the two has the lower RMS error there is luck; from rtol 1e-9 the FMU
    reproduces the truth's decisions and its error falls to ~1e-10."""
    inputs = scenario(model)
    t_py, out_py = run_scipy(model, inputs, rtol=1e-6)
    truth = scipy_truth(model)
    e_py, w_py, m_py, mw_py = rel_errors(out_py, truth)
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        with tempfile.TemporaryDirectory() as d:
            t_fmu, out_fmu = run_fmu(model, inputs, Path(d) / "fmu.csv", 3 if QUICK else 5, rtol)
        e_fmu, w_fmu, m_fmu, mw_fmu = rel_errors(out_fmu, truth)
        if e_fmu <= e_py:
            break
    verdict = "equal or better accuracy" if e_fmu <= e_py else "LOWER accuracy even at rtol 1e-10"
    print(f"{model} speedup {t_py / t_fmu:.0f}x (FMU from Rust at rtol {rtol:g}: {t_fmu * 1e3:.1f} ms; "
          f"SciPy Radau rtol 1e-6: {t_py:.2f} s; {T_END:g} s simulated at {DT * 1e3:g} ms steps; "
          f"error vs SciPy rtol 1e-10 relative to range, worst output RMS (max): "
          f"FMU {e_fmu:.1e} {w_fmu} ({m_fmu:.1e} {mw_fmu}), SciPy {e_py:.1e} {w_py} "
          f"({m_py:.1e} {mw_py}): {verdict})", flush=True)


def bench_math(model):
    """The cost of the deterministic math (the `libm` crate, `ode::math`): the same FMU built
    twice on this machine, once as shipped and once with the feature `platform-math` (the
    platform's libm), run alternately on the same inputs at rtol 1e-6."""
    fmus = {kind: REPO / f"target/bench-math/{model}-{kind}.fmu" for kind in ("libm", "platform")}
    if not all(p.exists() for p in fmus.values()):
        print(f"{model} deterministic math: peer FMUs missing (scripts/bench builds them)")
        return
    inputs = scenario(model)
    times = {kind: [] for kind in fmus}
    outputs = {}
    with tempfile.TemporaryDirectory() as d:
        for _ in range(2 if QUICK else 3):
            for kind, fmu in fmus.items():
                t, outputs[kind] = run_fmu(model, inputs, Path(d) / f"{kind}.csv", 3, 1e-6, fmu)
                times[kind].append(t)
    t_libm, t_platform = min(times["libm"]), min(times["platform"])
    diff = max(float(np.max(np.abs(outputs["libm"][n] - outputs["platform"][n])))
               / (float(np.ptp(outputs["platform"][n])) or 1.0) for n in outputs["platform"])
    print(f"{model} deterministic math cost {t_libm / t_platform:.3f}x (libm crate "
          f"{t_libm * 1e3:.1f} ms against the platform's libm {t_platform * 1e3:.1f} ms, the same "
          f"{T_END:g} s run at rtol 1e-6, best of alternating runs; outputs differ by at most "
          f"{diff:.1e} of their range)", flush=True)


ME_FIXTURES = (("VanDerPol", 20.0, 0.01), ("BouncingBall", 3.0, 0.01))
ME_RTOL = 1e-6


def fmpy_me(fmu, stop, step, rtol, repeat=5):
    """Median time of FMPy's ModelExchange run (CVode) on one instance reused between runs, as
    fmu-bench reuses its instance, and the last result."""
    import fmpy
    from fmpy.fmi2 import FMU2Model
    md = fmpy.read_model_description(fmu)
    unzipped = fmpy.extract(fmu)
    instance = FMU2Model(guid=md.guid, unzipDirectory=unzipped,
                         modelIdentifier=md.modelExchange.modelIdentifier, instanceName="bench")
    instance.instantiate()
    times, res = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = fmpy.simulate_fmu(unzipped, model_description=md, fmi_type="ModelExchange",
                                stop_time=stop, output_interval=step, relative_tolerance=rtol,
                                record_events=False, fmu_instance=instance)
        times.append(time.perf_counter() - t0)
        instance.reset()
    instance.freeInstance()
    return sorted(times)[len(times) // 2], res


def bench_me(model, stop, step):
    """The host's Model Exchange run (Rodas5P over the FMU's derivatives, events located) of a
    toy FMU (tests/fixtures/toy-fmus, built here with gcc) against FMPy's CVode run of the same
    FMU at the same relative tolerance, both scored against FMPy at rtol 1e-10 (worst max error
    relative to range)."""
    sys.path.insert(0, str(REPO / "tests"))
    import toy_fmus
    with tempfile.TemporaryDirectory() as d:
        fmu = str(toy_fmus.build(Path(d), model))
        t_py, out_py = fmpy_me(fmu, stop, step, ME_RTOL)
        _, truth = fmpy_me(fmu, stop, step, 1e-10, repeat=1)
        out_csv = Path(d) / "me.csv"
        cmd = [str(REPO / "target/release/fmu-bench"), fmu, "--me", "--tolerance", str(ME_RTOL),
               "--stop", str(stop), "--step", str(step), "--repeat", "5", "--out", str(out_csv)]
        timing = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
        ours = np.genfromtxt(out_csv, delimiter=",", names=True)
    names = [n for n in truth.dtype.names if n != "time"]
    tr = {n: truth[n] for n in names}
    _, _, e_me, w_me = rel_errors({n: ours[n] for n in names}, tr)
    _, _, e_py, w_py = rel_errors({n: out_py[n] for n in names}, tr)
    t_me = timing["median_s"]
    print(f"{model} ME speedup {t_py / t_me:.0f}x (host Model Exchange, Rodas5P rtol {ME_RTOL:g}: "
          f"{t_me * 1e3:.2f} ms; FMPy CVode rtol {ME_RTOL:g}: {t_py * 1e3:.1f} ms; {stop:g} s at "
          f"{step:g} s output steps; max error vs FMPy rtol 1e-10 relative to range: host "
          f"{e_me:.1e} {w_me}, CVode {e_py:.1e} {w_py})", flush=True)


def has_model_exchange(model):
    import zipfile
    with zipfile.ZipFile(REPO / f"dist/{model}.fmu") as z:
        return b"<ModelExchange" in z.read("modelDescription.xml")


def bench_model_me(model):
    """The host's Model Exchange run of the shipped FMU (fmu-bench --me) against FMPy's CVode
    run of the same FMU at the same relative tolerance, both scored against the SciPy truth of
    bench_model. FMPy's ME run sets continuous inputs only at its output points (1 ms here).
    Both traces hold the value after an event at a grid point (the host writes one row per grid
    point, after the event), where the truth holds the one before it: a controller output
    differs there (HydraulicJoint's u_valve_*) in both alike."""
    if not has_model_exchange(model):
        print(f"{model} ME: the FMU has no <ModelExchange>, skipped")
        return
    inputs = scenario(model)
    truth = scipy_truth(model)
    t_py, out_py = fmpy_scenario(model, "ModelExchange", list(truth), left=False)
    with tempfile.TemporaryDirectory() as d:
        t_me, out_me = run_fmu(model, inputs, Path(d) / "me.csv", 3 if QUICK else 5, ME_RTOL,
                               me=True)
    e_me, w_me, m_me, mw_me = rel_errors(out_me, truth)
    e_py, w_py, m_py, mw_py = rel_errors(out_py, truth)
    print(f"{model} ME speedup {t_py / t_me:.0f}x (host Model Exchange, Rodas5P rtol {ME_RTOL:g}: "
          f"{t_me * 1e3:.1f} ms; FMPy CVode rtol {ME_RTOL:g}: {t_py:.2f} s; both after the event "
          f"at a grid point; error vs SciPy rtol 1e-10 relative to range, worst output RMS (max): host {e_me:.1e} {w_me} ({m_me:.1e} "
          f"{mw_me}), CVode {e_py:.1e} {w_py} ({m_py:.1e} {mw_py}))", flush=True)


def bench_fmi3_cs(model):
    """The FMI 3.0 Co-Simulation FMU (dist/fmi3/) against the FMI 2.0 one (dist/) of the same
    model: the same scenario, tolerance (the FMU's rtol = atol = 1e-6) and 1 ms output grid, both
    driven by fmu-bench (one instance, reset between runs), run alternately; both scored against
    the SciPy truth of bench_model. Same model code under two thin FMI layers: ratio about 1."""
    fmus = {"FMI 3.0": REPO / f"dist/fmi3/{model}.fmu", "FMI 2.0": REPO / f"dist/{model}.fmu"}
    if not all(p.exists() for p in fmus.values()):
        print(f"{model} FMI 3.0 CS: dist/fmi3/{model}.fmu or dist/{model}.fmu missing, skipped")
        return
    inputs = scenario(model)
    truth = scipy_truth(model)
    times = {v: [] for v in fmus}
    outputs = {}
    with tempfile.TemporaryDirectory() as d:
        for _ in range(2 if QUICK else 3):
            for v, fmu in fmus.items():
                t, outputs[v] = run_fmu(model, inputs, Path(d) / "cs.csv", 3, 1e-6, fmu)
                times[v].append(t)
    t3, t2 = min(times["FMI 3.0"]), min(times["FMI 2.0"])
    a, b = outputs["FMI 3.0"], outputs["FMI 2.0"]
    diff = max(float(np.max(np.abs(a[n] - b[n]))) / (float(np.ptp(b[n])) or 1.0) for n in b)
    e3, w3, m3, mw3 = rel_errors(a, truth)
    e2, w2, m2, mw2 = rel_errors(b, truth)
    print(f"{model} FMI 3.0 CS against FMI 2.0 CS {t3 / t2:.2f}x (FMI 3.0 {t3 * 1e3:.1f} ms, "
          f"FMI 2.0 {t2 * 1e3:.1f} ms: the same {T_END:g} s run at rtol 1e-6, {DT * 1e3:g} ms "
          f"steps, best of alternating runs; outputs differ by at most {diff:.1e} of their range; "
          f"error vs SciPy rtol 1e-10 relative to range, worst output RMS (max): FMI 3.0 "
          f"{e3:.1e} {w3} ({m3:.1e} {mw3}), FMI 2.0 {e2:.1e} {w2} ({m2:.1e} {mw2}))", flush=True)


_FMPY_RUNS = {}


def fmpy_scenario(model, fmi_type, output, left=True):
    """FMPy's run of dist/<model>.fmu on the bench scenario as `fmi_type` (ModelExchange: CVode
    at ME_RTOL; CoSimulation: the FMU's own solver with ME_RTOL as the experiment's tolerance),
    1 ms output grid, inputs set at the output points: (time of one run, outputs). Model
    Exchange at the grid's left limits (`left_limits`), or with `left` false as FMPy records
    without events, the value after an event at a grid point. Kept for the other bench line
    that uses the same run."""
    key = (model, fmi_type, left)
    if key not in _FMPY_RUNS:
        import fmpy
        inputs = scenario(model)
        fmu = str(REPO / f"dist/{model}.fmu")
        names = list(inputs)
        sig = np.zeros(len(inputs[names[0]][0]),
                       dtype=[("time", float)] + [(n, float) for n in names])
        sig["time"] = inputs[names[0]][0]
        for n in names:
            sig[n] = inputs[n][1]
        unzipped, md = fmpy.extract(fmu), fmpy.read_model_description(fmu)
        known = {v.name for v in md.modelVariables}
        me = fmi_type == "ModelExchange" and left
        t0 = time.perf_counter()
        out = fmpy.simulate_fmu(unzipped, model_description=md, fmi_type=fmi_type,
                                relative_tolerance=ME_RTOL, input=sig, stop_time=T_END,
                                output_interval=DT, record_events=me,
                                output=[n for n in output if n in known])
        elapsed = time.perf_counter() - t0
        if me:
            out = left_limits(out)
        _FMPY_RUNS[key] = (elapsed, {n: out[n] for n in out.dtype.names if n != "time"})
    return _FMPY_RUNS[key]


def left_limits(out):
    """FMPy's Model Exchange trace on the output grid at each point's left limit, as the
    Co-Simulation trace and the SciPy truth hold it: recorded with its events, at a time event
    on the grid (a controller tick) the first row of the repeated time is the value before the
    event, the later ones after it; rows of events between grid points are dropped."""
    t = np.round(out["time"], 9)
    _, first = np.unique(t, return_index=True)
    out = out[first]
    k = np.round(out["time"] / DT)
    on_grid = np.abs(out["time"] - k * DT) <= 1e-9
    out = out[on_grid]
    expected = int(round(T_END / DT)) + 1
    assert len(out) == expected, (len(out), expected)
    return out


def bench_me_cvode_against_cs(model):
    """Our Model Exchange FMU under FMPy's CVode against our Co-Simulation FMU, both run by FMPy
    on the same scenario and 1 ms output grid at the same tolerance (1e-6), each with its error
    against the SciPy truth of bench_model: what an importer's own solver costs and gives
    against the FMU's internal one. The ME trace is compared at its left limits (`left_limits`):
    without events recorded FMPy holds the value after a controller tick at a grid point, the
    others the value before it."""
    if not has_model_exchange(model):
        print(f"{model} ME under CVode: the FMU has no <ModelExchange>, skipped")
        return
    truth = scipy_truth(model)
    t_me, out_me = fmpy_scenario(model, "ModelExchange", list(truth))
    t_cs, out_cs = fmpy_scenario(model, "CoSimulation", list(truth))
    e_me, w_me, m_me, mw_me = rel_errors(out_me, truth)
    e_cs, w_cs, m_cs, mw_cs = rel_errors(out_cs, truth)
    print(f"{model} ME under FMPy CVode against CS {t_me / t_cs:.1f}x the time (FMPy "
          f"ModelExchange, CVode rtol {ME_RTOL:g}: {t_me:.2f} s; FMPy CoSimulation, the FMU's "
          f"Rodas5P at tolerance {ME_RTOL:g}: {t_cs:.2f} s; {T_END:g} s at {DT * 1e3:g} ms output "
          f"steps; the ME trace at its left limits, events recorded and the first of repeated "
          f"times kept, as CS and SciPy hold them; error vs SciPy rtol 1e-10 relative to range, "
          f"worst output RMS (max): ME {e_me:.1e} {w_me} ({m_me:.1e} {mw_me}), CS {e_cs:.1e} "
          f"{w_cs} ({m_cs:.1e} {mw_cs}))", flush=True)


def bench_gap():
    script = REPO / "scripts" / "bench_gap.py"
    if script.exists():
        args = sys.argv[1:]
        if "--only" in args:
            i = args.index("--only")
            del args[i:i + 2]
        subprocess.run([sys.executable, str(script)] + args, check=True)
    else:
        print("gap: scripts/bench_gap.py not present, gap benchmark skipped")


MODELS = ("HydraulicJoint", "TwistedString")
# --only NAME[,NAME...] runs these benchmarks only (default: all, in this order).
BENCHES = {
    "model": lambda: [bench_model(m) for m in MODELS],
    "math": lambda: [bench_math(m) for m in MODELS],
    "me": lambda: [bench_model_me(m) for m in MODELS],
    "me-cvode": lambda: [bench_me_cvode_against_cs(m) for m in MODELS],
    "fmi3-cs": lambda: [bench_fmi3_cs(m) for m in MODELS],
    "me-fixtures": lambda: [bench_me(*f) for f in ME_FIXTURES],
    "gap": bench_gap,
    "gap-emps": lambda: subprocess.run(
        [sys.executable, str(REPO / "scripts" / "bench_gap.py"), "--emps"], check=True),
}


def selected():
    """The benchmarks named by --only (all when absent)."""
    if "--only" not in sys.argv:
        return list(BENCHES)
    names = sys.argv[sys.argv.index("--only") + 1].split(",")
    unknown = [n for n in names if n not in BENCHES]
    if unknown:
        sys.exit(f"bench: unknown benchmark {', '.join(unknown)} (known: {', '.join(BENCHES)})")
    return names


if __name__ == "__main__":
    for name in selected():
        BENCHES[name]()
