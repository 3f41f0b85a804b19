"""The parameters' start values of a model, read from its committed FMI 2.0 model description
(modelDescription/<Model>.xml, the FMU's interface): each default is declared once, in the
model's variable table, and the references take it from the interface, not from the Rust code.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def parameter_defaults(model: str) -> dict:
    """{name: start} of every parameter of `model`: Booleans as bool, numbers as float."""
    root = ET.parse(os.path.join(REPO, "modelDescription", f"{model}.xml")).getroot()
    defaults = {}
    for variable in root.iter("ScalarVariable"):
        if variable.get("causality") != "parameter":
            continue
        kind = variable[0]
        start = kind.get("start")
        defaults[variable.get("name")] = start == "true" if kind.tag == "Boolean" else float(start)
    return defaults
