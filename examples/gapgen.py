"""Generator of measured-style data for the gap workflow (issue 7).

A dataset is made by simulating the packaged FMU with FMPy (an implementation independent of
the Rust host that `actuator-fmu gap` uses) with
  - our own random inputs (minimum-jerk reaches of the set point, steps of the disturbance),
  - our own random draws of the base parameters the model calibrates by default,
  - zero, one or two candidate effects switched on, each parameter drawn in its [min, max]
    range (log-uniform where min > 0),
and adding Gaussian noise of `noise` times each output's range (white, or AR(1) with the given
coefficient and the same marginal standard deviation).

Used by examples/README.md (the bundled examples), tests/test_gap.py and scripts/gap-eval.
Command line:  python examples/gapgen.py MODEL OUT.csv [--effect E ...] [--seed S] [--noise F]
               [--ar RHO] [--duration T] [--rate HZ] [--no-draw] [--set NAME=VALUE ...]
               [--inputs reaches|sines|steps]
"""
import argparse
import json
import math
import os
import sys
from pathlib import Path
import xml.etree.ElementTree as ET
import zipfile

import numpy as np

REPO = Path(__file__).resolve().parent.parent

# Outputs "measured" on the bench, per model (what sensors such a rig has).
MEASURED = {
    "HydraulicJoint": ["theta", "x_left", "x_right", "p1_left", "p2_left", "p1_right",
                       "p2_right", "T_left", "T_right"],
    "TwistedString": ["p", "theta_motor", "omega_motor", "current"],
}


def fmu_file(model):
    return str(REPO / "dist" / f"{model}.fmu")


def variables(model):
    """Parameter table of the FMU: name -> dict(type, start, min, max, description)."""
    with zipfile.ZipFile(fmu_file(model)) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    out = {}
    for v in root.iter("ScalarVariable"):
        t = list(v)[0]
        def num(key):
            x = t.get(key)
            return None if x is None else float(x)
        start = t.get("start")
        if t.tag == "Boolean":
            start = start == "true"
        elif start is not None:
            start = float(start)
        out[v.get("name")] = dict(type=t.tag, causality=v.get("causality"), start=start,
                                  min=num("min"), max=num("max"),
                                  description=v.get("description") or "")
    return out


def effects(model):
    """Candidate effects: name -> list of their Real parameters."""
    vs = variables(model)
    eff = {}
    for name, v in vs.items():
        if v["type"] == "Boolean" and name.endswith(".enabled"):
            prefix = name[: -len(".enabled")]
            eff[prefix] = [n for n, w in vs.items()
                           if n.startswith(prefix + ".") and w["type"] == "Real"]
    return eff


def calibrated(model):
    vs = variables(model)
    return [n for n, v in vs.items()
            if v["type"] == "Real" and v["description"].lstrip().startswith("[calibrate]")
            and "." not in n]


def draw_in_range(rng, v):
    lo, hi = v["min"], v["max"]
    if lo is not None and hi is not None and lo > 0 and hi / lo >= 3:
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
    if lo is not None and hi is not None:
        return float(rng.uniform(lo, hi))
    return float(v["start"])


def min_jerk(t, t0, t1, a, b):
    s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return a + (b - a) * (10 * s**3 - 15 * s**4 + 6 * s**5)


def reaches(rng, t, lo, hi, dur, hold, start=0.0):
    """Piecewise minimum-jerk moves between random targets in [lo, hi]."""
    y = np.full_like(t, start)
    cur, tc = start, t[0] + rng.uniform(0.1, 0.4)
    while tc < t[-1]:
        d = rng.uniform(*dur)
        tgt = rng.uniform(lo, hi)
        m = t >= tc
        y[m] = min_jerk(t[m], tc, tc + d, cur, tgt)
        cur, tc = tgt, tc + d + rng.uniform(*hold)
    return y


def steps(rng, t, lo, hi, period):
    y = np.zeros_like(t)
    tc = t[0] + rng.uniform(*period)
    level = 0.0
    while tc < t[-1]:
        level = rng.uniform(lo, hi)
        y[t >= tc] = level
        tc += rng.uniform(*period)
    return y


def sines(rng, t, lo, hi, f_lo, f_hi, n=3):
    """Sum of `n` sines of random frequency in [f_lo, f_hi] Hz and random phase, scaled to span
    [lo, hi] over the grid (starts wherever the sum starts)."""
    y = np.zeros_like(t)
    for _ in range(n):
        y += rng.uniform(0.5, 1.0) * np.sin(2 * math.pi * rng.uniform(f_lo, f_hi) * t
                                            + rng.uniform(0, 2 * math.pi))
    return lo + (hi - lo) * (y - y.min()) / (y.max() - y.min())


INPUT_FAMILIES = ("reaches", "sines", "steps")
HJ_ANGLE_RANGE = (math.radians(-30), math.radians(60))


def stroke_amplitude(rng):
    """TwistedString stroke amplitude, drawn per dataset (log-uniform, motor angle 150..1100 rad):
    small twists are where gear_backlash shows (its offset of half the backlash is a larger part
    of the twist, and the noise, 1 % of each signal's range, is smaller), large ones where
    radius_growth does; one fixed range would hide one of them."""
    return math.exp(rng.uniform(math.log(150.0), math.log(1100.0)))


def inputs(model, rng, t, family="reaches"):
    """Random input columns for `model` on the time grid t.

    family "reaches" (the default, used for the bundled examples, the tests and the rates in
    examples/README.md): minimum-jerk moves between random set points with holds, load steps.
    "sines": sums of three sines for set point and load (no holds). "steps": set-point steps
    without shaping, load steps. The other two families check that the workflow does not depend
    on one input shape (held-out inputs)."""
    if family not in INPUT_FAMILIES:
        raise ValueError(f"unknown input family {family!r}; one of {INPUT_FAMILIES}")
    if family != "reaches":
        return _other_inputs(model, rng, t, family)
    if model == "HydraulicJoint":
        ref = reaches(rng, t, *HJ_ANGLE_RANGE, (0.5, 1.0), (0.3, 0.9))
        tau = steps(rng, t, -3.0, 3.0, (0.8, 2.0))
        return {"theta_ref": ref, "tau_ext": tau}
    if model == "TwistedString":
        amp = stroke_amplitude(rng)
        ref = reaches(rng, t, 0.1 * amp, amp, (1.0, 2.0), (0.3, 0.8))
        f = steps(rng, t, 0.0, 40.0, (1.0, 2.5))
        return {"theta_motor_ref": ref, "F_load": f}
    raise ValueError(model)


def _other_inputs(model, rng, t, family):
    if model == "HydraulicJoint":
        lo, hi = HJ_ANGLE_RANGE
        if family == "sines":
            return {"theta_ref": sines(rng, t, lo, hi, 0.1, 1.0),
                    "tau_ext": sines(rng, t, -3.0, 3.0, 0.05, 0.5)}
        return {"theta_ref": steps(rng, t, lo, hi, (0.6, 1.5)),
                "tau_ext": steps(rng, t, -3.0, 3.0, (0.8, 2.0))}
    if model == "TwistedString":
        amp = stroke_amplitude(rng)
        if family == "sines":
            return {"theta_motor_ref": sines(rng, t, 0.1 * amp, amp, 0.05, 0.4),
                    "F_load": sines(rng, t, 0.0, 40.0, 0.05, 0.4)}
        return {"theta_motor_ref": steps(rng, t, 0.1 * amp, amp, (1.0, 2.5)),
                "F_load": steps(rng, t, 0.0, 40.0, (1.0, 2.5))}
    raise ValueError(model)


def simulate(model, t, cols, start_values, outputs=None):
    """Simulate the FMU with FMPy at the grid's sample interval; returns a structured array."""
    from fmpy import simulate_fmu
    names = list(cols)
    sig = np.zeros(len(t), dtype=[("time", np.float64)] + [(n, np.float64) for n in names])
    sig["time"] = t
    for n in names:
        sig[n] = cols[n]
    dt = float(t[1] - t[0])
    import contextlib
    import io
    with contextlib.redirect_stdout(io.StringIO()):  # FMPy warns about inputs left at start
        return simulate_fmu(fmu_file(model), start_time=float(t[0]), stop_time=float(t[-1]),
                            output_interval=dt, step_size=dt, start_values=dict(start_values),
                            input=sig, output=outputs or MEASURED[model], validate=False)


def noisy(rng, y, frac, ar):
    s = frac * (np.max(y) - np.min(y))
    w = rng.standard_normal(len(y))
    if ar > 0:
        e = np.empty_like(w)
        e[0] = w[0]
        c = math.sqrt(1 - ar * ar)
        for i in range(1, len(w)):
            e[i] = ar * e[i - 1] + c * w[i]
        w = e
    return y + s * w, s


def make(model, seed, hidden=(), noise=0.01, ar=0.0, duration=10.0, rate=1000.0,
         draw_base=True, base_overrides=None, sets=None, keep_inputs=None, input_family="reaches",
         given_inputs=None, noise_sigma=None, simulator=None):
    """One dataset. Returns dict(time, inputs, outputs, truth, noise_sigma).

    given_inputs: (time, {input: values}) to use instead of drawn inputs (an experiment
    `actuator-fmu design` proposed); noise_sigma: {output: sigma} absolute noise levels instead
    of `noise` times each output's range (the same sensors as an earlier dataset); simulator:
    a function like `simulate` (model, t, cols, start_values) -> {output: values} to use instead
    of FMPy on the FMU (a simulator with a mechanism the FMU does not have)."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(0, int(round(duration * rate)) + 1) / rate, 12)
    if given_inputs is not None:
        t = np.asarray(given_inputs[0], dtype=float)
    vs = variables(model)
    truth = {}
    if draw_base:
        for n in calibrated(model):
            f = math.exp(rng.uniform(math.log(0.75), math.log(1.33)))
            v = vs[n]
            truth[n] = float(np.clip(v["start"] * f, v["min"], v["max"]))
    for n, x in (base_overrides or {}).items():
        truth[n] = x
    eff = effects(model)
    for e in hidden:
        truth[e + ".enabled"] = True
        for p in eff[e]:
            truth[p] = draw_in_range(rng, vs[p])
    for n, x in (sets or {}).items():
        truth[n] = x
    cols = inputs(model, rng, t, input_family)
    if given_inputs is not None:
        cols = {k: np.asarray(v, dtype=float) for k, v in given_inputs[1].items()}
    if keep_inputs is not None:
        cols = {k: v for k, v in cols.items() if k in keep_inputs}
    res = (simulator or simulate)(model, t, cols, truth)
    outs, sig = {}, {}
    for n in MEASURED[model]:
        y = np.asarray(res[n], dtype=float)
        if noise_sigma is not None:
            # The same white noise draw as `noisy`, at the given absolute level.
            frac = noise_sigma[n] / max(float(np.max(y) - np.min(y)), 1e-300)
            outs[n], sig[n] = noisy(rng, y, frac, ar)
        else:
            outs[n], sig[n] = noisy(rng, y, noise, ar)
    return dict(time=t, inputs=cols, outputs=outs, truth=truth, noise_sigma=sig,
                clean={n: np.asarray(res[n], dtype=float) for n in MEASURED[model]})


EVAL_CONDITIONS = ["single1", "single5", "clean", "ar", "mass", "two", "mismatch"]

# Mechanisms outside the candidate list of the `mismatch` condition, per model, taken in turn by
# the record index: a first-order lag on one sensor, a gain error on one sensor, a fixed
# parameter set wrong, and a friction law the candidates do not have (made by the SciPy
# reference with that law, not by the FMU): TwistedString's motor friction of another form
# than the candidate `motor_friction`, HydraulicJoint's friction in the joint bearing (its
# candidates have friction at the piston seals and in the Bowden cables only).
MISMATCH_KINDS = {"HydraulicJoint": ("lag", "gain", "fixed", "friction"),
                  "TwistedString": ("lag", "gain", "fixed", "friction")}

# Fixed (not calibrated) parameters the `mismatch` condition sets wrong in the "user's" model:
# the record is made with the parameter 15 % off its default, which gap keeps.
MISMATCH_FIXED = {"HydraulicJoint": ["load_radius", "pulley_radius"],
                  "TwistedString": ["string_length", "torque_constant"]}


def first_order_lag(t, y, tau):
    """Output of a first-order lag tau m' + m = y, exact for y linear between samples."""
    m = np.empty_like(y)
    m[0] = y[0]
    for i in range(1, len(y)):
        h = t[i] - t[i - 1]
        a = math.exp(-h / tau)
        slope = (y[i] - y[i - 1]) / h
        m[i] = y[i] - tau * slope + a * (m[i - 1] - y[i - 1] + tau * slope)
    return m


def mismatch_kind(model, i):
    """The mechanism outside the candidate list of `mismatch` record i, and the index of the
    record among those of its kind (which sensor, which parameter, which law)."""
    kinds = MISMATCH_KINDS[model]
    return kinds[i % len(kinds)], i // len(kinds)


def _log_uniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def stribeck(tc, ts, ws, width):
    """Stribeck friction torque (Armstrong-Helouvry, Dupont, Canudas de Wit 1994):
    tau(omega) = (T_c + (T_s - T_c) exp(-(omega/omega_s)^2)) tanh(omega/width)."""
    def law(w):
        return (tc + (ts - tc) * math.exp(-(w / ws) ** 2)) * math.tanh(w / width)
    return law


def friction_law(model, rng, j):
    """A friction torque law tau(omega) [N.m] outside the candidate list, for `mismatch` record j
    of its kind. Returns (description, law).

    TwistedString, at the motor shaft, of another form than the candidate `motor_friction`
    (tau_c tanh(omega/1 rad/s) + b omega) and with magnitudes within its ranges (Coulomb
    0.2-5 mN.m; b 2e-7..1e-5 N.m.s/rad, 0.1-5 mN.m at 500 rad/s), by j % 2:
      - Stribeck, T_c 0.3-3 mN.m log-uniform, a static excess T_s - T_c of 0.5-2 T_c, Stribeck
        speed omega_s 20-100 rad/s log-uniform, sign width 1 rad/s as the candidate's;
      - speed-squared drag (churning of the gearhead's lubricant), tau = c omega |omega|, of
        0.5-3 mN.m at 300 rad/s (log-uniform).
    HydraulicJoint, in the joint bearing (acting on the link, where no candidate acts: the
    candidates' friction sits at the piston seals and in the cables, so pressures and cable
    tensions no longer balance as there): Stribeck with T_c 0.2-1.5 N.m log-uniform (the seal
    candidate's 5-200 N is 0.15-6 N.m at the 3 cm pulley), a static excess of 0-2 T_c, omega_s
    0.05-0.3 rad/s log-uniform, sign width 0.01 rad/s."""
    if model == "HydraulicJoint":
        tc = _log_uniform(rng, 0.2, 1.5)
        ts = tc * (1.0 + float(rng.uniform(0.0, 2.0)))
        ws = _log_uniform(rng, 0.05, 0.3)
        return (f"friction Stribeck in the joint T_c {tc:.2f} N.m, T_s {ts:.2f} N.m, "
                f"omega_s {ws:.2f} rad/s", stribeck(tc, ts, ws, 0.01))
    if j % 2 == 0:
        tc = _log_uniform(rng, 0.3e-3, 3e-3)
        ts = tc * (1.0 + float(rng.uniform(0.5, 2.0)))
        ws = _log_uniform(rng, 20.0, 100.0)
        return (f"friction Stribeck at the motor T_c {tc * 1e3:.2f} mN.m, T_s {ts * 1e3:.2f} mN.m, "
                f"omega_s {ws:.0f} rad/s", stribeck(tc, ts, ws, 1.0))
    c = _log_uniform(rng, 0.5e-3, 3e-3) / 300.0 ** 2

    def drag(w):
        return c * w * abs(w)
    return f"friction drag at the motor {c * 300.0 ** 2 * 1e3:.2f} mN.m at 300 rad/s (c omega|omega|)", drag


def reference_simulator(extra_friction):
    """A `simulate` replacement: the model's SciPy reference (tests/reference/, the documented
    equations written again, independent of the FMU) with an extra friction torque law (at the
    motor shaft of TwistedString, in the joint of HydraulicJoint), at the grid's sample
    interval."""
    def run(model, t, cols, start_values):
        sys.path.insert(0, str(REPO / "tests" / "reference"))
        inputs = {k: (t, v) for k, v in cols.items()}
        kw = dict(t_end=float(t[-1] - t[0]), dt=float(t[1] - t[0]))
        if model == "TwistedString":
            import twisted_string_ref
            out = twisted_string_ref.simulate(dict(start_values), inputs,
                                              extra_motor_friction=extra_friction, **kw)
        elif model == "HydraulicJoint":
            import hydraulic_joint_ref
            out = hydraulic_joint_ref.simulate(dict(start_values), inputs,
                                               extra_joint_friction=extra_friction, **kw)
        else:
            raise ValueError(f"no reference simulator for {model}")
        return {n: out[n] for n in MEASURED[model]}
    return run


def mismatch(model, ds, i, rng):
    """Sensor mechanisms of record i (see mismatch_kind): a first-order lag (10-40 ms) or a gain
    error (+-3..8 %) on one sensor, the sensor's noise kept as drawn. The other kinds are made in
    eval_record. Returns a description (kind first)."""
    kind, j = mismatch_kind(model, i)
    if kind not in ("lag", "gain"):
        return kind
    sensor = MEASURED[model][j % len(MEASURED[model])]
    clean, noise = ds["clean"][sensor], ds["outputs"][sensor] - ds["clean"][sensor]
    if kind == "lag":
        tau = float(rng.uniform(0.01, 0.04))
        ds["outputs"][sensor] = first_order_lag(ds["time"], clean, tau) + noise
        return f"lag {tau * 1000:.0f} ms on {sensor}"
    g = float(rng.choice([-1, 1]) * rng.uniform(0.03, 0.08))
    ds["outputs"][sensor] = (1 + g) * clean + noise
    return f"gain {100 * g:+.1f} % on {sensor}"


def eval_record(model, cond, i, seed0=100000, duration=4.0, rate=250.0, input_family="reaches",
                ar=None):
    """Dataset `i` of condition `cond` of scripts/gap-eval (and scripts/gap-robustness): one
    hidden effect at 1 % or 5 % noise (single1, single5), none (clean), none with AR(1) noise of
    coefficient 0.9 (ar), none with the load mass 30 % off its default (mass), two effects (two),
    none but a mechanism outside the candidate list (mismatch, MISMATCH_KINDS).
    Seeds are seed0 + 1000 x the condition's index + i (+ 500 for TwistedString). `ar`: the
    AR(1) coefficient of the noise in every condition (None: white, and 0.9 for `ar`).
    Returns dict(ds, seed, hidden, noise, ar, kw, mismatch): the dataset and how it was made."""
    eff = sorted(effects(model))
    seed = seed0 + 1000 * EVAL_CONDITIONS.index(cond) + i + (0 if model == "HydraulicJoint" else 500)
    kw = dict(duration=duration, rate=rate, input_family=input_family)
    hidden, noise, ar_all = (), 0.01, ar
    ar = ar_all or 0.0
    simulator, what = None, None
    if cond in ("single1", "single5"):
        hidden = (eff[i % len(eff)],)
        noise = 0.01 if cond == "single1" else 0.05
    elif cond == "ar":
        ar = 0.9 if ar_all is None else ar_all
    elif cond == "mass":
        v = variables(model)["load_mass"]
        kw.update(draw_base=False, base_overrides={"load_mass": v["start"] * (1.3 if i % 2 else 0.7)})
    elif cond == "two":
        j = i % len(eff)
        k = (j + 1 + (i // len(eff)) % (len(eff) - 1)) % len(eff)
        hidden = (eff[j], eff[k])
    elif cond == "mismatch":
        kind, j = mismatch_kind(model, i)
        if kind == "fixed":
            name = MISMATCH_FIXED[model][j % len(MISMATCH_FIXED[model])]
            kw.update(sets={name: variables(model)[name]["start"] * (1.15 if (j // 2) % 2 else 0.85)})
            what = "fixed " + ", ".join(f"{k}={v:.4g}" for k, v in kw["sets"].items())
        elif kind == "friction":
            what, law = friction_law(model, np.random.default_rng(seed + 7), j)
            simulator = reference_simulator(law)
    ds = make(model, seed, hidden, noise=noise, ar=ar, simulator=simulator, **kw)
    if cond == "mismatch" and what is None:
        what = mismatch(model, ds, i, np.random.default_rng(seed + 7))
    return dict(ds=ds, seed=seed, hidden=hidden, noise=noise, ar=ar, kw=kw, mismatch=what)


def perturbed(ds, seed, eps):
    """The dataset with every output sample moved by `eps` times the output's range, with a
    pseudo-random sign drawn from `seed` (scripts/gap-robustness: changes far below the noise
    must not change gap's answer)."""
    rng = np.random.default_rng([seed, 38])
    outs = {}
    for n, y in ds["outputs"].items():
        s = np.where(rng.random(len(y)) < 0.5, -1.0, 1.0)
        outs[n] = y + eps * float(np.max(y) - np.min(y)) * s
    return dict(ds, outputs=outs)


def read_inputs_csv(path):
    """(time, {input: values}) of an input CSV (`actuator-fmu design --out`; '#' comments)."""
    with open(path) as f:
        lines = [ln for ln in f if ln.strip() and not ln.startswith("#")]
    header = lines[0].strip().split(",")
    a = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    cols = {n: a[:, j] for j, n in enumerate(header)}
    return cols.pop("time"), cols


def write_csv(ds, path, comment=None):
    names = list(ds["inputs"]) + list(ds["outputs"])
    cols = [ds["time"]] + [ds["inputs"][n] for n in ds["inputs"]] + \
           [ds["outputs"][n] for n in ds["outputs"]]
    with open(path, "w") as f:
        if comment:
            for line in comment.splitlines():
                f.write(f"# {line}\n")
        f.write(",".join(["time"] + names) + "\n")
        for row in zip(*cols):
            f.write(",".join(repr(float(x)) for x in row) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model")
    ap.add_argument("out")
    ap.add_argument("--effect", action="append", default=[])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--ar", type=float, default=0.0)
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--no-draw", action="store_true", help="base parameters at their defaults")
    ap.add_argument("--inputs", default="reaches", choices=INPUT_FAMILIES,
                    help="input family (default: minimum-jerk reaches with holds)")
    ap.add_argument("--set", action="append", default=[], help="NAME=VALUE applied to the truth")
    a = ap.parse_args(argv)
    sets = {}
    for s in a.set:
        k, v = s.split("=", 1)
        sets[k] = v == "true" if v in ("true", "false") else float(v)
    ds = make(a.model, a.seed, a.effect, a.noise, a.ar, a.duration, a.rate,
              draw_base=not a.no_draw, sets=sets, input_family=a.inputs)
    comment = (f"Generated by examples/gapgen.py {' '.join(sys.argv[1:] if argv is None else argv)}\n"
               f"FMPy simulation of dist/{a.model}.fmu; Gaussian noise {a.noise:g} x range"
               f"{'' if a.ar == 0 else f', AR(1) {a.ar:g}'}\n"
               f"truth: {json.dumps(ds['truth'])}")
    write_csv(ds, a.out, comment)
    truth_path = os.path.splitext(a.out)[0] + ".truth.json"
    with open(truth_path, "w") as f:
        json.dump(dict(model=a.model, hidden=a.effect, truth=ds["truth"], seed=a.seed,
                       noise=a.noise, ar=a.ar,
                       noise_sigma={k: float(v) for k, v in ds["noise_sigma"].items()}), f,
                  indent=1)


if __name__ == "__main__":
    main()
