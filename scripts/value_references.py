"""Append the variables of modelDescription/*.xml (and modelDescription/fmi3/*.xml) that are not
yet in modelDescription/value-references.tsv to it. Existing rows are never changed: the list is
the record of every value reference shipped, which tests/test_value_references.py holds the model
descriptions to."""
import csv
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TABLE = ROOT / "modelDescription" / "value-references.tsv"
HEADER = ["model", "name", "valueReference"]


def descriptions():
    """Every committed model description, FMI 2.0 first."""
    md = ROOT / "modelDescription"
    return sorted(md.glob("*.xml")) + sorted(md.glob("fmi3/*.xml"))


def variables(path):
    """(modelName, name, valueReference) of every variable of one model description (FMI 2.0
    ScalarVariable or FMI 3.0 typed element under ModelVariables)."""
    root = ET.parse(path).getroot()
    model = root.get("modelName")
    for v in root.find("ModelVariables"):
        yield model, v.get("name"), int(v.get("valueReference"))


def read_table():
    with TABLE.open(newline="") as f:
        rows = list(csv.reader(f, delimiter="\t"))
    assert rows[0] == HEADER, f"{TABLE}: header must be {HEADER}"
    return {(m, n): int(vr) for m, n, vr in rows[1:]}


def main():
    known = read_table() if TABLE.exists() else {}
    new = []
    for path in descriptions():
        for model, name, vr in variables(path):
            if (model, name) not in known:
                known[(model, name)] = vr
                new.append((model, name, vr))
    if not TABLE.exists():
        TABLE.write_text("\t".join(HEADER) + "\n")
    with TABLE.open("a", newline="") as f:
        w = csv.writer(f, delimiter="\t", lineterminator="\n")
        w.writerows(new)
    for model, name, vr in new:
        print(f"value-references.tsv: added {model} {name} = {vr}", file=sys.stderr)


if __name__ == "__main__":
    main()
