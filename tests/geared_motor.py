"""The foreign C FMU of tests/fixtures/geared-motor/: build it with gcc and make measured-style
data from it with FMPy.

`build(dir)` compiles geared_motor.c with `gcc -shared -fPIC -O2` into
binaries/linux64/geared_motor.so and zips it with the hand-written modelDescription.xml into
dir/GearedMotor.fmu. `build(dir, initial_state=False)` makes the variant without initial-state
parameters (compiled with -DGEARED_MOTOR_NO_INITIAL_STATE, its description without the
variables tagged [initial]): an FMU that can only start at rest.

`make(fmu, seed, hidden)` simulates it with FMPy (independent of the Rust host `gap` uses) under
random voltage steps, with the base parameters drawn around their defaults and each hidden
effect's parameters drawn in their ranges, and adds white Gaussian noise of 1 % of each output's
range (examples/gapgen.py's noise model).
"""
import contextlib
import io
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SRC = REPO / "tests" / "fixtures" / "geared-motor"
sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402

OUTPUTS = ["current", "motor_speed", "load_angle"]
EFFECTS = {
    "coulomb_friction": ["coulomb_friction.torque"],
    "current_saturation": ["current_saturation.limit"],
    "gear_compliance": ["gear_compliance.stiffness", "gear_compliance.damping"],
    "unbalanced_load": ["unbalanced_load.moment"],
}
INITIAL = ["current_start", "motor_speed_start", "load_angle_start"]
# Where in its range each effect parameter is drawn for the tests: the part where 3 s of random
# voltage steps reveal the effect (Coulomb torque and gravity moment in their upper decade, the
# current limit and the gear stiffness in their lower ones). Weaker settings exist, and the gap
# report calls them unrevealable by such data.
REVEALING = {
    "coulomb_friction.torque": (0.01, 0.1),
    "current_saturation.limit": (0.5, 5.0),
    "gear_compliance.stiffness": (5.0, 50.0),
    "gear_compliance.damping": (0.005, 0.2),
    "unbalanced_load.moment": (0.2, 5.0),
}


def description(initial_state=True):
    """The hand-written modelDescription.xml; without the [initial] variables (the last ones,
    so ModelStructure's indices stay valid) for the variant without initial-state parameters."""
    text = (SRC / "modelDescription.xml").read_text()
    if initial_state:
        return text
    root = ET.fromstring(text)
    mv = root.find("ModelVariables")
    for v in list(mv):
        if (v.get("description") or "").startswith("[initial]"):
            mv.remove(v)
    return ET.tostring(root, encoding="unicode", xml_declaration=True)


def build(out_dir, initial_state=True):
    """Compile and zip the FMU into out_dir; returns its path."""
    out_dir = Path(out_dir)
    stage = out_dir / ("stage" if initial_state else "stage-no-initial")
    lib = stage / "binaries" / "linux64" / "geared_motor.so"
    lib.parent.mkdir(parents=True, exist_ok=True)
    cmd = ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-O2",
           "-o", str(lib), str(SRC / "geared_motor.c"), "-lm"]
    if not initial_state:
        cmd.insert(1, "-DGEARED_MOTOR_NO_INITIAL_STATE")
    subprocess.run(cmd, check=True)
    fmu = out_dir / ("GearedMotor.fmu" if initial_state else "GearedMotorAtRest.fmu")
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", description(initial_state))
        z.write(lib, "binaries/linux64/geared_motor.so")
        z.write(SRC / "geared_motor.c", "sources/geared_motor.c")
    return fmu


def variables(initial_state=True):
    """Parameter table: name -> dict(type, start, min, max, description)."""
    root = ET.fromstring(description(initial_state))
    out = {}
    for v in root.iter("ScalarVariable"):
        t = list(v)[0]
        num = (lambda k: None if t.get(k) is None else float(t.get(k)))
        start = t.get("start")
        start = (start == "true") if t.tag == "Boolean" else (None if start is None
                                                             else float(start))
        out[v.get("name")] = dict(type=t.tag, causality=v.get("causality"), start=start,
                                  min=num("min"), max=num("max"),
                                  description=v.get("description") or "")
    return out


def calibrated():
    return [n for n, v in variables().items() if v["description"].startswith("[calibrate]")]


def voltage_steps(rng, t, u_max=20.0, hold=(0.08, 0.35)):
    """Random voltage steps: a new level, uniform in [-u_max, u_max], every `hold` seconds;
    0 V for the first 0.05-0.15 s."""
    u = np.zeros_like(t)
    tc = t[0] + rng.uniform(0.05, 0.15)
    while tc < t[-1]:
        u[t >= tc] = rng.uniform(-u_max, u_max)
        tc += rng.uniform(*hold)
    return u


def simulate(fmu, t, voltage, start_values, outputs=OUTPUTS):
    """FMPy simulation on the grid t (communication step = sample interval)."""
    from fmpy import simulate_fmu
    sig = np.zeros(len(t), dtype=[("time", np.float64), ("voltage", np.float64)])
    sig["time"], sig["voltage"] = t, voltage
    dt = float(t[1] - t[0])
    with contextlib.redirect_stdout(io.StringIO()):
        res = simulate_fmu(str(fmu), start_time=float(t[0]), stop_time=float(t[-1]),
                           output_interval=dt, step_size=dt, start_values=dict(start_values),
                           input=sig, output=list(outputs), validate=False)
    return {n: np.asarray(res[n], dtype=float) for n in outputs}


def draw(rng, hidden=(), values=None, revealing=True):
    """Parameter draw: each [calibrate] parameter its default times a log-uniform factor in
    [0.75, 1.33]; each hidden effect on with its parameters log-uniform in their REVEALING
    part (`revealing`) or whole range, unless given in `values`."""
    vs = variables()
    truth = {}
    for n in calibrated():
        f = math.exp(rng.uniform(math.log(0.75), math.log(1.33)))
        truth[n] = float(np.clip(vs[n]["start"] * f, vs[n]["min"], vs[n]["max"]))
    for e in hidden:
        truth[e + ".enabled"] = True
        for p in EFFECTS[e]:
            v = dict(vs[p])
            if revealing:
                v["min"], v["max"] = REVEALING[p]
            truth[p] = gapgen.draw_in_range(rng, v)
    truth.update(values or {})
    return truth


def make(fmu, seed, hidden=(), duration=3.0, rate=200.0, skip=0.0, values=None, u_max=20.0,
         noise=0.01, revealing=True):
    """One dataset: dict(time, inputs, outputs, truth, noise_sigma, clean).

    `skip` > 0 simulates skip + duration seconds and drops the first `skip`, time reset to 0:
    a record that begins mid-motion."""
    rng = np.random.default_rng(seed)
    truth = draw(rng, hidden, values, revealing)
    n_skip = int(round(skip * rate))
    t_all = np.round(np.arange(0, int(round((duration + skip) * rate)) + 1) / rate, 12)
    u = voltage_steps(rng, t_all, u_max)
    clean = simulate(fmu, t_all, u, truth)
    t = t_all[n_skip:] - t_all[n_skip]
    outs, sig = {}, {}
    for n in OUTPUTS:
        outs[n], sig[n] = gapgen.noisy(rng, clean[n][n_skip:], noise, 0.0)
    return dict(time=np.round(t, 12), inputs={"voltage": u[n_skip:]}, outputs=outs,
                truth=truth, noise_sigma=sig, clean={n: clean[n][n_skip:] for n in OUTPUTS},
                state_at_start={"current_start": float(clean["current"][n_skip]),
                                "motor_speed_start": float(clean["motor_speed"][n_skip]),
                                "load_angle_start": float(clean["load_angle"][n_skip])})
