"""Value references are an interface: every variable of the committed model descriptions keeps
the value reference recorded in modelDescription/value-references.tsv (the record of every
reference shipped; scripts/update-model-descriptions appends new variables, never changes a row).
"""
import csv
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MD = ROOT / "modelDescription"
DESCRIPTIONS = sorted(MD.glob("*.xml")) + sorted(MD.glob("fmi3/*.xml"))


def recorded():
    with (MD / "value-references.tsv").open(newline="") as f:
        rows = list(csv.reader(f, delimiter="\t"))
    assert rows[0] == ["model", "name", "valueReference"]
    table = {}
    for model, name, vr in rows[1:]:
        assert (model, name) not in table, f"{model} {name} listed twice"
        table[(model, name)] = int(vr)
    return table


def declared(path):
    root = ET.parse(path).getroot()
    return root.get("modelName"), [
        (v.get("name"), int(v.get("valueReference"))) for v in root.find("ModelVariables")
    ]


@pytest.mark.parametrize("path", DESCRIPTIONS, ids=lambda p: str(p.relative_to(MD)))
def test_every_variable_keeps_its_recorded_value_reference(path):
    table = recorded()
    model, variables = declared(path)
    for name, vr in variables:
        assert (model, name) in table, (
            f"{model}.{name} is not in value-references.tsv: run scripts/update-model-descriptions"
        )
        assert vr == table[(model, name)], (
            f"{model}.{name} has value reference {vr}, shipped as {table[(model, name)]}: "
            "an existing variable never changes its value reference"
        )


@pytest.mark.parametrize("path", DESCRIPTIONS, ids=lambda p: str(p.relative_to(MD)))
def test_value_references_are_unique(path):
    _, variables = declared(path)
    vrs = [vr for _, vr in variables]
    assert len(vrs) == len(set(vrs))


def test_no_recorded_variable_disappears():
    present = set()
    for path in DESCRIPTIONS:
        model, variables = declared(path)
        present |= {(model, name) for name, _ in variables}
    missing = sorted(set(recorded()) - present)
    assert not missing, f"variables removed or renamed (an interface change): {missing}"


def test_a_moved_reference_is_caught(tmp_path):
    """The check itself can fail: a copy of a description with one reference changed."""
    src = MD / "HydraulicJoint.xml"
    text = src.read_text().replace('name="theta" valueReference="', 'name="theta" valueReference="9', 1)
    assert text != src.read_text()
    moved = tmp_path / "moved.xml"
    moved.write_text(text)
    with pytest.raises(AssertionError, match="theta has value reference"):
        test_every_variable_keeps_its_recorded_value_reference(moved)
