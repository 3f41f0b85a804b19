#!/usr/bin/env python3
"""The gap workflow on real measurements: the EMPS benchmark records (examples/emps/README.md).

1. Converts DATA_EMPS.mat (estimation) and DATA_EMPS_PULSES.mat (validation, force pulses) of the
   benchmark's EMPS.zip into the CSV `actuator-fmu` reads (scripts/emps_csv.py), into --work.
2. Runs `actuator-fmu gap dist/EMPS.fmu --data <estimation> --validate <pulses>`: the
   estimation record is fitted, the pulse record only checked.
3. Writes into this folder what is committed: report.md and its figures (measured, model as
   given, base fit and final model of every output on the estimation record: outputs.png; on
   the pulse record: validation-1.png; residuals), results.md (the fitted values with their
   95 % intervals beside the published ones, the errors on the pulse record), the same table in
   README.md between its markers, and stamp.json (the hashes of what made them: the FMU's
   model description, the records, this script), which tests/test_emps_example.py compares.
   The records and every file holding their samples (traces.csv, validation-1.csv) stay in
   --work: the licence of EMPS.zip is not stated.

Usage: examples/emps/run.py [--data-dir ../shared/data/emps] [--work target/emps-example]
                            [--cli target/release/actuator-fmu] [--fmu dist/EMPS.fmu]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
RECORDS = ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")
# Janot, Gautier, Brunot 2019, IDIM-LS on DATA_EMPS (data README): symmetric model (eq. 1) and
# asymmetric friction (eq. 12). Our parameter: (symmetric, asymmetric).
PUBLISHED = {
    "mass": ("M [kg]", 95.1089, 95.1540),
    "viscous_friction": ("Fv, Fv+ [N·s/m]", 203.5034, 166.7061),
    "asymmetric_friction.viscous_negative": ("Fv− [N·s/m]", None, 240.4236),
    "coulomb_friction.force": ("Fc, Fc+ [N]", 20.3935, 20.1440),
    "asymmetric_friction.coulomb_negative": ("Fc− [N]", None, 20.6277),
    "offset": ("offset [N]", -3.1648, None),
}
COMMITTED_FIGURES = ("outputs.png", "residuals.png", "validation-1.png")


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def stamp(fmu: Path, data_dir: Path) -> dict:
    """What the committed outputs were made from (tests/test_emps_example.py compares it)."""
    with zipfile.ZipFile(fmu) as z:
        md = z.read("modelDescription.xml")
    return {
        "modelDescription.xml": sha256(md),
        "records": {r: sha256((data_dir / r).read_bytes()) for r in RECORDS},
        "script": sha256(Path(__file__).read_bytes()),
    }


def g(x) -> str:
    return "–" if x is None else f"{x:.4g}"


def within(e, ref) -> str:
    if ref is None:
        return ""
    return " ✓" if e["ci_low"] <= ref <= e["ci_high"] else " ✗"


def table(rep: dict) -> str:
    """Fitted values with their 95 % intervals beside the published ones; errors on the pulse
    record."""
    named = rep["named"]
    lines = [f"Named: {', '.join(named) or 'none'}. ✓/✗: the published value lies inside/outside "
             "the 95 % interval.", "",
             "| parameter | gap: value [95 % interval] | published symmetric | published asymmetric |",
             "|---|---|---|---|"]
    for name, (label, sym, asym) in PUBLISHED.items():
        e = rep["parameters"].get(name)
        fit = "not fitted" if e is None else f"{g(e['value'])} [{g(e['ci_low'])}, {g(e['ci_high'])}]"
        lines.append(f"| `{name}` ({label}) | {fit} | {g(sym)}{within(e, sym) if e else ''} | "
                     f"{g(asym)}{within(e, asym) if e else ''} |")
    lines += ["", "| record | output | RMSE base fit | RMSE final | largest final error (at t) |",
              "|---|---|---|---|---|"]
    for name, o in rep["outputs"].items():
        lines.append(f"| estimation (fitted) | {name} | {g(o['rmse_base_fit'])} | "
                     f"{g(o['rmse_after'])} | {g(o['max_after'])} |")
    for v in rep.get("validation", []):
        for name, o in v["outputs"].items():
            lines.append(f"| pulses (not fitted) | {name} | {g(o['rmse_base'])} | "
                         f"{g(o['rmse_final'])} | {g(o['max_final'])} ({o['max_final_at_s']:.3f} s) |")
    return "\n".join(lines) + "\n"


def replace_between(text: str, body: str) -> str:
    a, b = "<!-- results: written by run.py -->", "<!-- /results -->"
    i, j = text.index(a) + len(a), text.index(b)
    return text[:i] + "\n" + body + text[j:]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, default=ROOT.parent / "shared" / "data" / "emps")
    ap.add_argument("--work", type=Path, default=ROOT / "target" / "emps-example")
    ap.add_argument("--cli", type=Path, default=ROOT / "target" / "release" / "actuator-fmu")
    ap.add_argument("--fmu", type=Path, default=ROOT / "dist" / "EMPS.fmu")
    a = ap.parse_args()
    missing = [r for r in RECORDS if not (a.data_dir / r).exists()]
    if missing:
        print(f"{a.data_dir}: {', '.join(missing)} missing: get EMPS.zip from "
              "nonlinearbenchmark.org (see examples/emps/README.md)", file=sys.stderr)
        return 2
    csv = a.work / "csv"
    subprocess.run([sys.executable, str(ROOT / "scripts" / "emps_csv.py"), "--data-dir",
                    str(a.data_dir), "--out-dir", str(csv)], check=True)
    out = a.work / "report"
    # Run in the records' folder so that the report and its figures name them by file name.
    est, pul = "emps_estimation.csv", "emps_pulses.csv"
    cmd = [str(a.cli.resolve()), "gap", str(a.fmu.resolve()), "--data", est, "--validate", pul,
           "--out", str(out.resolve()), "--quiet"]
    subprocess.run(cmd, check=True, cwd=csv)
    rep = json.loads((out / "report.json").read_text())
    for f in COMMITTED_FIGURES:
        shutil.copy(out / f, HERE / f)
    # report.md with the paths of this repository, not of the machine that ran it.
    md = (out / "report.md").read_text()
    md = md.replace(str(a.fmu.resolve()), "dist/EMPS.fmu")
    (HERE / "report.md").write_text(md)
    results = table(rep)
    (HERE / "results.md").write_text("# EMPS: gap's fit beside the published values\n\n"
                                     "Written by examples/emps/run.py.\n\n" + results)
    readme = HERE / "README.md"
    readme.write_text(replace_between(readme.read_text(), results))
    (HERE / "stamp.json").write_text(json.dumps(stamp(a.fmu, a.data_dir), indent=1) + "\n")
    print(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
