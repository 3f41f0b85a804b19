"""The bundled outputs of examples/emps/ (report, figures, table) are made by examples/emps/run.py
from records that are not in the repository; stamp.json records the hashes of what made them.
When the EMPS FMU's model description, the records or the script change, the outputs are stale:
rerun `examples/emps/run.py`. Skipped without the records (../shared/data/emps/)."""
import json
import re
import sys

import pytest

from conftest import REPO, fmu_path

sys.path.insert(0, str(REPO / "examples" / "emps"))
import run as emps_example  # noqa: E402

HERE = REPO / "examples" / "emps"
DATA = REPO.parent / "shared" / "data" / "emps"
needs_data = pytest.mark.skipif(
    not all((DATA / r).exists() for r in emps_example.RECORDS),
    reason=f"EMPS records not found in {DATA} (EMPS.zip of nonlinearbenchmark.org)")


@needs_data
def test_bundled_emps_outputs_are_not_stale():
    from pathlib import Path
    recorded = json.loads((HERE / "stamp.json").read_text())
    now = emps_example.stamp(Path(fmu_path("EMPS")), DATA)
    stale = [k for k in now if now[k] != recorded.get(k)]
    assert not stale, f"examples/emps outputs are stale ({', '.join(stale)} changed): rerun " \
                      "examples/emps/run.py"


def test_bundled_emps_outputs_are_complete():
    """The README shows the table run.py wrote (the same as results.md) and the figures it
    names exist; no file holding the records' samples is committed."""
    readme = (HERE / "README.md").read_text()
    results = (HERE / "results.md").read_text()
    table = readme.split("<!-- results: written by run.py -->")[1].split("<!-- /results -->")[0]
    assert table.strip() and table.strip() in results
    for fig in re.findall(r"\]\(([^)]+\.png)\)", readme):
        assert (HERE / fig).exists(), fig
    for f in emps_example.COMMITTED_FIGURES:
        assert (HERE / f).exists(), f
    assert not list(HERE.glob("*.csv")) and not list(HERE.glob("*.mat"))
