#!/usr/bin/env python3
"""Convert the EMPS benchmark records (DATA_EMPS.mat, DATA_EMPS_PULSES.mat of the Nonlinear System
Identification Benchmarks' EMPS.zip) into the CSV files `actuator-fmu simulate` and `gap` read:
`time` first, then columns named as the EMPS FMU's variables, SI units.

Columns (one row per 1 kHz controller sample k, time k * 1 ms):
  inputs   qg              reference position [m] (logged `qg`)
           force_pulse     force pulse added to the controller output [N]: gtau * a * pulses_N,
                           a fitted here (see `pulse_gain`); 0 in the estimation record
           force_measured  applied force gtau * vir [N] (the input of the open-loop mode)
  outputs  qm              measured position [m] (logged `qm`, motor encoder on the load side)
           force           applied force gtau * vir [N] (pulses included: `vir` holds them)
           velocity        the controller's velocity (qfm(k) - qfm(k-1)) / dt with
                           qfm(k) = (qm(k) + qm(k-1)) / 2 (benchmark description, sec. 2.2)

Pitfalls of the files handled here (data README):
  - `vir` is in volts although the description calls it a force: force = gtau * vir.
  - In DATA_EMPS_PULSES.mat `vir` already contains the pulses, so `force` and `force_measured`
    are gtau * vir unchanged; `force_pulse` is the pulse the controller added, for the
    closed-loop model, never to be added to `force` again.
  - `pulses_N` is stored as uint8 (0 or 5): converted to float before any arithmetic. It enters
    `vir` before the +-10 V saturation as a * pulses_N volts; `pulse_gain` fits a by least
    squares (1.0138 on the file of the benchmark).
  - The logged time stamps carry rounding of up to 3.2e-8 s; the dSPACE loop runs at exactly
    1 kHz, so the rows are written at k * 1 ms.
  - The records begin in motion (the controller ran before the first sample): the controller's
    velocity at samples 0 and 1, which need qm(-1) and qm(-2), is recovered by inverting the
    logged law, velocity = kp (qg - qm) - vir / kv (exact while |vir| < 10 V).

Time stamping of the controller outputs (`--stamp`):
  held    (default) `force` and `velocity` of sample k are written at row k + 1, the end of the
          interval [t_k, t_k+1) over which the controller held them; row 0 has sample 0's. This is
          what the EMPS FMU's outputs show at a communication point in Co-Simulation (the values
          held over the step just ended, before the sample at that point, which needs the inputs
          set there), and what `gap` and `simulate` read after each step.
  sample  `force` and `velocity` of sample k at row k, as logged (a Model Exchange importer's
          right limits after the time event).
The inputs are stamped at their sample (the FMU holds them over the step from there) either way.

Usage:
  scripts/emps_csv.py [--data-dir ../shared/data/emps] [--out-dir target/emps] [--stamp held]
writes <out-dir>/emps_estimation.csv and <out-dir>/emps_pulses.csv. The .mat files and the
CSVs are never committed (the licence of EMPS.zip is not stated); get EMPS.zip from
nonlinearbenchmark.org.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.io

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "emps"
RECORDS = {"estimation": "DATA_EMPS.mat", "pulses": "DATA_EMPS_PULSES.mat"}
TS = 1e-3          # controller sample period [s] (description sec. 2.2: 1 kHz)
V_SAT = 10.0       # controller output saturation [V] (Simulation_EMPS.m: viradm = 10)
COLUMNS = ["time", "qg", "force_pulse", "force_measured", "qm", "force", "velocity"]


class RecordError(Exception):
    """A record that is not the benchmark's: missing variable, wrong shape or sampling."""


def load(path: Path) -> dict:
    """The variables of one .mat record as float 1-D arrays (constants as floats)."""
    if not Path(path).is_file():
        raise RecordError(f"{path}: not found (get EMPS.zip from nonlinearbenchmark.org)")
    try:
        mat = scipy.io.loadmat(path)
    except (OSError, ValueError) as e:
        raise RecordError(f"{path}: not a readable .mat file ({e})") from e
    rec = {}
    for key in ("t", "qg", "qm", "vir", "gtau", "kp", "kv", "pulses_N"):
        if key in mat:
            rec[key] = np.asarray(mat[key], dtype=float).ravel()
        elif key != "pulses_N":
            raise RecordError(f"{path}: variable '{key}' missing")
    for key in ("gtau", "kp", "kv"):
        rec[key] = float(rec[key][0])
    n = rec["t"].size
    if any(rec[k].size != n for k in ("qg", "qm", "vir")):
        raise RecordError(f"{path}: t, qg, qm, vir differ in length")
    jitter = np.abs(rec["t"] - TS * np.arange(n)).max()
    if jitter > 1e-6:
        raise RecordError(f"{path}: time stamps leave the 1 kHz grid by {jitter:.3g} s")
    return rec


def controller_velocity(rec: dict) -> np.ndarray:
    """The logged controller's velocity (qfm(k) - qfm(k-1)) / dt, qfm(k) = (qm(k) + qm(k-1)) / 2,
    i.e. (qm(k) - qm(k-2)) / (2 dt); samples 0 and 1 from the logged law inverted."""
    qm = rec["qm"]
    v = np.empty_like(qm)
    v[2:] = (qm[2:] - qm[:-2]) / (2.0 * TS)
    implied = rec["kp"] * (rec["qg"][:2] - qm[:2]) - rec["vir"][:2] / rec["kv"]
    v[:2] = implied
    return v


def controller_law(rec: dict, velocity: np.ndarray) -> np.ndarray:
    """nu(k) = kv (kp (qg(k) - qm(k)) - velocity(k)) [V], before saturation (description eq. 6)."""
    return rec["kv"] * (rec["kp"] * (rec["qg"] - rec["qm"]) - velocity)


def pulse_gain(rec: dict, velocity: np.ndarray) -> float:
    """a in vir = sat(nu + a pulses_N), least squares over the samples where neither side
    saturates; 0 for a record without pulses."""
    p = rec.get("pulses_N")
    if p is None or not p.any():
        return 0.0
    nu = controller_law(rec, velocity)
    free = (np.abs(rec["vir"]) < V_SAT) & (np.abs(nu) < V_SAT)
    free[:2] = False
    resid = rec["vir"][free] - nu[free]
    return float(p[free] @ resid / (p[free] @ p[free]))


def held(x: np.ndarray) -> np.ndarray:
    """Sample k's value at row k + 1 (row 0 keeps sample 0's)."""
    return np.concatenate([x[:1], x[:-1]])


def columns(rec: dict, stamp: str) -> tuple[np.ndarray, float]:
    """The CSV columns (in COLUMNS order) and the fitted pulse gain."""
    n = rec["t"].size
    velocity = controller_velocity(rec)
    a = pulse_gain(rec, velocity)
    force = rec["gtau"] * rec["vir"]
    pulses = rec.get("pulses_N", np.zeros(n))
    out_force, out_velocity = (held(force), held(velocity)) if stamp == "held" else (force, velocity)
    table = np.column_stack([TS * np.arange(n), rec["qg"], rec["gtau"] * a * pulses, force,
                             rec["qm"], out_force, out_velocity])
    return table, a


def write(path: Path, table: np.ndarray, header_lines: list[str]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="ascii") as f:
        for line in header_lines:
            f.write(f"# {line}\n")
        f.write(",".join(COLUMNS) + "\n")
        np.savetxt(f, table, delimiter=",", fmt="%.12g")


def convert(data_dir: Path, out_dir: Path, stamp: str) -> list[Path]:
    written = []
    for name, file in RECORDS.items():
        rec = load(data_dir / file)
        table, a = columns(rec, stamp)
        path = out_dir / f"emps_{name}.csv"
        write(path, table, [
            f"EMPS benchmark record {file} converted by scripts/emps_csv.py --stamp {stamp}",
            f"gtau = {rec['gtau']!r} N/V, kp = {rec['kp']!r} 1/s, kv = {rec['kv']!r} V.s/m, "
            f"pulse gain a = {a:.6f} V per pulses_N unit",
        ])
        print(f"{path}: {table.shape[0]} rows, pulse gain {a:.6f}")
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out-dir", type=Path, default=ROOT / "target" / "emps")
    ap.add_argument("--stamp", choices=("held", "sample"), default="held")
    args = ap.parse_args(argv)
    try:
        convert(args.data_dir, args.out_dir, args.stamp)
    except RecordError as e:
        print(f"emps_csv.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
