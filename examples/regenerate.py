"""Regenerate every bundled example from the current FMUs (dist/<Model>.fmu).

Each line of examples/manifest.tsv names the model, the data file, the extra arguments of
`actuator-fmu gap` and the arguments of examples/gapgen.py that make the file (with its
`.truth.json`). Running this after a physics change keeps the showcase true; tests/test_gap.py
(test_bundled_examples_match_the_fmu) fails when a record no longer matches the FMU at its truth.

Command line:  python examples/regenerate.py [--check]
  --check   regenerate nothing; print, per example and output, the RMSE between the record and
            the FMU simulated at the recorded truth, as a multiple of the recorded noise level.
"""
import json
import shlex
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
import gapgen  # noqa: E402


def manifest():
    """(model, data path relative to the repository, gap arguments, gapgen arguments) per line."""
    rows = []
    for line in (HERE / "manifest.tsv").read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.split("\t") + ["", ""]
        rows.append((fields[0], fields[1], fields[2], fields[3]))
    return rows


def misfit(data):
    """{output: RMSE(record - FMU at the recorded truth) / recorded noise level} of one example.

    The record is re-simulated with FMPy on its own time grid with its own input columns, so a
    ratio near 1 means the record is the current FMU's output plus its noise."""
    path = REPO / data
    truth = json.loads(path.with_suffix(".truth.json").read_text())
    model = truth["model"]
    t, cols = gapgen.read_inputs_csv(path)
    inputs = {k: v for k, v in cols.items() if k not in gapgen.MEASURED[model]}
    sim = gapgen.simulate(model, t, inputs, truth["truth"])
    return {n: float(np.sqrt(np.mean((np.asarray(sim[n]) - cols[n]) ** 2))
                     / truth["noise_sigma"][n]) for n in gapgen.MEASURED[model]}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    for model, data, _gap_args, gen_args in manifest():
        if "--check" in argv:
            ratios = misfit(data)
            print(data + ": " + ", ".join(f"{n} {r:.2f}" for n, r in ratios.items()))
            continue
        args = [model, data] + shlex.split(gen_args)
        print("python examples/gapgen.py " + " ".join(args))
        gapgen.main(args)


if __name__ == "__main__":
    main()
