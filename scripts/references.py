"""Reference results bundled in our FMUs (FMI-LS-REF): one closed-loop experiment per model,
its stimuli and its outputs computed by the independent SciPy references of tests/reference/
(the documented equations, not the Rust code), written to references/<Model>/:

    <Model>_in.csv         time and the inputs on the communication grid (held over each step)
    <Model>_ref.csv        time and the outputs the reference reproduces
    fmi-ls-manifest.xml    the FMI-LS-REF 1.0.0-rc.1 manifest naming the two files
    fmi-ls-ref.html        the experiment and its expected deviation (documentation/ of the FMU)
    generated-from.sha256  the hash of what the files were made from (see `source_hash`);
                           tests/test_ls_ref.py fails when it no longer matches

    python scripts/references.py [Model ...]     (scripts/references wraps it)
"""
from __future__ import annotations

import hashlib
import math
import os
import sys
from dataclasses import dataclass

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFDIR = os.path.join(REPO, "tests", "reference")
sys.path.insert(0, REFDIR)

import emps_ref  # noqa: E402
import hydraulic_joint_ref  # noqa: E402
import twisted_string_ref  # noqa: E402
from model_description import parameter_defaults  # noqa: E402

MODELS = ["HydraulicJoint", "TwistedString", "EMPS"]
# The files whose content decides the references: the generator, the reference equations and
# the parameter defaults they take from the committed model descriptions.
SOURCES = {
    "HydraulicJoint": ["tests/reference/hydraulic_joint_ref.py"],
    "TwistedString": ["tests/reference/twisted_string_ref.py"],
    "EMPS": ["tests/reference/emps_ref.py"],
}
COMMON = ["scripts/references.py", "tests/reference/model_description.py"]
LS_DESCRIPTION = "Layered Standard providing reference stimuli and results for an FMU."


@dataclass
class Experiment:
    """One experiment: what it shows, its grid, stimuli and reference outputs."""
    description: str
    t_end: float
    dt: float
    inputs: dict    # name -> values on the grid
    outputs: dict   # name -> values on the grid


def source_hash(model: str) -> str:
    """sha256 over the generator, the model's reference code and modelDescription/<Model>.xml."""
    h = hashlib.sha256()
    for rel in COMMON + SOURCES[model] + [f"modelDescription/{model}.xml"]:
        with open(os.path.join(REPO, rel), "rb") as fh:
            h.update(rel.encode() + b"\0" + fh.read() + b"\0")
    return h.hexdigest()


def grid(t_end: float, dt: float) -> np.ndarray:
    return np.arange(int(round(t_end / dt)) + 1) * dt


def hydraulic_joint() -> Experiment:
    """Sinusoidal tracking, 0.5 rad at 0.7 Hz, by the 40 Hz co-contraction controller."""
    t_end, dt = 3.0, 5e-3
    t = grid(t_end, dt)
    theta_ref = 0.5 * np.sin(2 * np.pi * 0.7 * t)
    out = hydraulic_joint_ref.simulate({}, {"theta_ref": (t, theta_ref)}, t_end, dt)
    return Experiment(
        "Closed loop: theta_ref = 0.5 sin(2 pi 0.7 t) rad tracked by the internal controller",
        t_end, dt, {"theta_ref": theta_ref},
        {k: out[k] for k in hydraulic_joint_ref.OUTPUTS})


def twisted_string() -> Experiment:
    """Position loop twisting the strings to 400 rad and back, default load."""
    t_end, dt = 2.0, 1e-3
    t = grid(t_end, dt)
    ref = np.interp(t, [0.0, 0.05, 0.8, 1.2, 1.9], [0.0, 0.0, 400.0, 400.0, 0.0])
    out = twisted_string_ref.simulate({}, {"theta_motor_ref": (t, ref)}, t_end, dt)
    return Experiment(
        "Closed loop: theta_motor_ref ramps 0 -> 400 rad (0.05-0.8 s), holds, returns to 0 "
        "(1.2-1.9 s)", t_end, dt, {"theta_motor_ref": ref},
        {k: out[k] for k in twisted_string_ref.OUTPUTS})


def min_jerk(t, t0, t1, a, b):
    """Minimum-jerk move a -> b over [t0, t1], held outside."""
    s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return a + (b - a) * (10 * s**3 - 15 * s**4 + 6 * s**5)


def emps() -> Experiment:
    """The logged 1 kHz position loop on a forward and a partial return move."""
    d = parameter_defaults("EMPS")
    assert not any(v for k, v in d.items() if k.endswith(".enabled")), "effects on by default"
    ts = d["controller_period"]
    t_end = 3.0
    t = grid(t_end, ts)
    qg = min_jerk(t, 0.2, 1.2, 0.0, 0.1) + min_jerk(t, 1.8, 2.6, 0.0, -0.05)
    p = emps_ref.Params(mass=d["mass"], viscous_friction=d["viscous_friction"],
                        offset=d["offset"], kp=d["controller_kp"], kv=d["controller_kv"],
                        gtau=d["drive_gain"], v_sat=d["voltage_limit"])
    assert math.isclose(ts, emps_ref.TS)
    out = emps_ref.simulate(qg, p, q0=d["q0"], v0=d["v0"], friction="exact")
    return Experiment(
        "Closed loop: qg moves 0 -> 0.1 m (0.2-1.2 s) and back to 0.05 m (1.8-2.6 s), "
        "minimum-jerk profiles", t_end, ts,
        {"qg": qg}, {k: out[k] for k in ("qm", "force", "velocity")})


def write_csv(path: str, t: np.ndarray, columns: dict) -> None:
    """`time` and the columns, 10 significant digits (far below the comparison's tolerance)."""
    data = np.column_stack([t] + list(columns.values()))
    with open(path, "w", newline="\n") as fh:
        fh.write(",".join(["time"] + list(columns)) + "\n")
        np.savetxt(fh, data, delimiter=",", fmt="%.10g")


def manifest(model: str, e: Experiment) -> str:
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiReferences
    xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
    fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref"
    fmi-ls:fmi-ls-version="1.0.0-rc.1"
    fmi-ls:fmi-ls-description="{LS_DESCRIPTION}">
  <Experiment name="closed_loop" description="{e.description}"
      startTime="0" stopTime="{e.t_end:g}" stepSize="{e.dt:g}" tolerance="1e-06">
    <Stimuli source="{model}_in.csv"/>
    <References source="{model}_ref.csv"/>
  </Experiment>
</fmiReferences>
"""


# The largest |FMU - reference| / (range of the signal) over the experiment, measured with the
# FMUs of both FMI versions (Co-Simulation, tolerance 1e-6) when the references were made.
MEASURED = {"HydraulicJoint": "6.9e-7 (v_right)", "TwistedString": "1.8e-6 (current)",
            "EMPS": "8.0e-8 (force)"}

DOC = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{model}: reference results (FMI-LS-REF)</title></head>
<body>
<h1>{model}: reference results</h1>
<p>This FMU carries one experiment of the layered standard FMI-LS-REF 1.0.0-rc.1 in
<code>extra/org.fmi-standard.fmi-ls-ref/</code> (manifest <code>fmi-ls-manifest.xml</code>):
<b>closed_loop</b>, {description}, from {start} to {stop} s with communication step {step} s
and tolerance 1e-6, every parameter at its start value.</p>
<ul>
<li><code>{model}_in.csv</code>: the inputs ({inputs}) at every communication point; a
Co-Simulation importer sets each row's values at its time and holds them over the step.</li>
<li><code>{model}_ref.csv</code>: the outputs ({n_out} columns) at the communication points,
computed by an independent implementation of the equations of this FMU's documentation
(SciPy <code>solve_ivp</code> Radau at relative tolerance 1e-10, the sampled controller at its
sample instants), not by the FMU's code.</li>
</ul>
<h2>Expected deviation</h2>
<p>The FMU's own integrator (relative and absolute tolerance 1e-6) keeps every output within
1e-5 of the signal's range (max - min over the experiment) of the reference; measured when the
references were made: at most {measured} of the range. A tolerance tube as the Modelica
csv-compare tool draws it (0.002 of the range in value and of the duration in time) therefore
passes with a wide margin, and a result outside it means a changed model, not solver noise.
<code>actuator-fmu validate FMU --reference</code> runs this comparison.</p>
</body></html>
"""

BUILDERS = {"HydraulicJoint": hydraulic_joint, "TwistedString": twisted_string, "EMPS": emps}


def generate(model: str, out_dir: str) -> None:
    e = BUILDERS[model]()
    os.makedirs(out_dir, exist_ok=True)
    t = grid(e.t_end, e.dt)
    write_csv(os.path.join(out_dir, f"{model}_in.csv"), t, e.inputs)
    write_csv(os.path.join(out_dir, f"{model}_ref.csv"), t, e.outputs)
    with open(os.path.join(out_dir, "fmi-ls-manifest.xml"), "w", newline="\n") as fh:
        fh.write(manifest(model, e))
    with open(os.path.join(out_dir, "fmi-ls-ref.html"), "w", newline="\n") as fh:
        fh.write(DOC.format(model=model, description=e.description[0].lower() + e.description[1:],
                            start=0, stop=f"{e.t_end:g}", step=f"{e.dt:g}",
                            inputs=", ".join(e.inputs), n_out=len(e.outputs),
                            measured=MEASURED[model]))
    with open(os.path.join(out_dir, "generated-from.sha256"), "w", newline="\n") as fh:
        fh.write(source_hash(model) + "\n")


def main(argv: list[str]) -> int:
    for model in argv or MODELS:
        if model not in BUILDERS:
            print(f"unknown model {model}; known: {' '.join(MODELS)}", file=sys.stderr)
            return 2
        generate(model, os.path.join(REPO, "references", model))
        print(f"wrote references/{model}/", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
