"""`actuator-fmu validate` against the FMI XML schemas: its verdict on many mutated model
descriptions equals the verdict of an independent validator, lxml's XMLSchema (libxml2) with the
schema files the installed FMPy package ships (fmpy/schema/fmi2, fmpy/schema/fmi3; read at test
time, never copied here).

The descriptions start from valid ones of our own: the committed descriptions of our FMUs
(modelDescription/*.xml, modelDescription/fmi3/*.xml) and of our C fixtures (tests/fixtures). Each
mutation breaks, or keeps to, one kind of schema rule: an attribute the element does not have, a
value outside an enumeration, a swapped pair of siblings, a removed attribute, a value that is not
a number of the attribute's type, an element given twice, a removed element, text in element-only
content, and free content inside the annotations the schemas leave open. Which mutation is invalid
is not decided here: lxml decides, and ours must agree. A description is invalid for ours when it
gets a finding of the check `schema`.
"""
import copy
import json
import pathlib
import random
import subprocess

import pytest

from conftest import cli_path

fmpy = pytest.importorskip("fmpy")
etree = pytest.importorskip("lxml.etree")

REPO = pathlib.Path(__file__).resolve().parent.parent
SEEDS = sorted(
    list((REPO / "modelDescription").glob("*.xml"))
    + list((REPO / "modelDescription" / "fmi3").glob("*.xml"))
    + list((REPO / "tests" / "fixtures" / "toy-fmus").glob("*.xml"))
    + list((REPO / "tests" / "fixtures").glob("*/modelDescription.xml"))
)
PER_KIND = 6  # mutations of each kind per seed

ENUMS = {"causality", "variability", "initial", "variableNamingConvention", "dependenciesKind",
         "intervalVariability"}
NUMBERS = {"valueReference", "start", "min", "max", "nominal", "index", "startTime", "stopTime",
           "stepSize", "tolerance", "derivative", "factor", "offset", "value", "kg", "m", "s",
           "maxOutputDerivativeOrder", "numberOfEventIndicators", "dependencies", "priority",
           "intervalDecimal", "shiftDecimal", "resolution", "intervalCounter", "shiftCounter",
           "recommendedIntermediateInputSmoothness", "fixedInternalStepSize", "clocks", "previous"}
BOOLEANS = {"canHandleVariableCommunicationStepSize", "canGetAndSetFMUstate",
            "canGetAndSetFMUState", "providesDirectionalDerivative", "reinit",
            "canBeDeactivated", "relativeQuantity", "unbounded", "needsExecutionTool"}
NOT_NUMBERS = ["abc", "1,5", "", "4294967296", "-1", "1.5", "0x10", "1e400", " 7 ", "+3", "NaN",
               "9223372036854775808", "256", "-129", "1 2", "INF"]
NOT_BOOLEANS = ["yes", "TRUE", "1", "0", " true ", ""]


def schema_of(version):
    root = pathlib.Path(fmpy.__file__).parent / "schema" / f"fmi{version}"
    return etree.XMLSchema(file=str(root / f"fmi{version}ModelDescription.xsd"))


def elements(doc):
    return [e for e in doc.iter() if isinstance(e.tag, str)]


def with_attrs(doc, names, rng):
    """(element, attribute) pairs of `doc` whose attribute is in `names`, shuffled."""
    pairs = [(e, a) for e in elements(doc) for a in e.attrib if a in names]
    rng.shuffle(pairs)
    return pairs


def mutations(doc, version, rng):
    """(kind, mutated copy) pairs of the description `doc`."""
    out = []

    def emit(kind, change):
        for _ in range(PER_KIND):
            d = copy.deepcopy(doc)
            if change(d):
                out.append((kind, d))

    def unknown_attribute(d):
        rng.choice(elements(d)).set("vendorExtra", "1")
        return True

    def enum_value(d):
        pairs = with_attrs(d, ENUMS, rng)
        if not pairs:
            return False
        e, a = pairs[0]
        e.set(a, rng.choice(["bogus", e.get(a).capitalize(), e.get(a) + " ", "exact approx"]))
        return True

    def swap_order(d):
        parents = [e for e in elements(d)
                   if len({c.tag for c in e if isinstance(c.tag, str)}) >= 2]
        if not parents:
            return False
        kids = [c for c in rng.choice(parents) if isinstance(c.tag, str)]
        i = rng.randrange(len(kids) - 1)
        while kids[i].tag == kids[i + 1].tag:
            i = rng.randrange(len(kids) - 1)
        kids[i].addprevious(kids[i + 1])
        return True

    def remove_attribute(d):
        # fmiVersion stays: it picks the schema
        pairs = [(e, a) for e in elements(d) for a in e.attrib if a != "fmiVersion"]
        e, a = rng.choice(pairs)
        del e.attrib[a]
        return True

    def non_numeric(d):
        pairs = with_attrs(d, NUMBERS, rng)
        e, a = pairs[0]
        e.set(a, rng.choice(NOT_NUMBERS))
        return True

    def non_boolean(d):
        pairs = with_attrs(d, BOOLEANS, rng)
        if not pairs:
            return False
        e, a = pairs[0]
        e.set(a, rng.choice(NOT_BOOLEANS))
        return True

    def duplicate(d):
        e = rng.choice(elements(d)[1:])
        e.addnext(copy.deepcopy(e))
        return True

    def remove_element(d):
        e = rng.choice(elements(d)[1:])
        e.getparent().remove(e)
        return True

    def text(d):
        e = rng.choice(elements(d))
        e.text = (e.text or "") + "stray"
        return True

    def free_content(d):
        shape = rng.randrange(4)
        if version == "2":
            vendor = etree.Element("VendorAnnotations")
            tool = etree.SubElement(vendor, "Tool", name="org.example")
            inner = etree.SubElement(tool, "Anything", attr="x")
            etree.SubElement(inner, "Deeper", more="1").text = "free text"
            if shape == 1:
                etree.SubElement(tool, "Second")  # xs:any has maxOccurs 1
            if shape == 2:
                del tool.attrib["name"]
            if shape == 3:
                tool.text = "text"  # <Tool> is element-only
            d.find("ModelVariables").addprevious(vendor)
        else:
            anns = d.find("Annotations")
            if anns is None:
                anns = etree.SubElement(d, "Annotations")
            ann = etree.SubElement(anns, "Annotation", type="org.example")
            ann.text = "mixed text"
            etree.SubElement(ann, "Anything", attr="x").tail = "more text"
            if shape == 1:
                ann.set("version", "1")
            if shape == 2:
                etree.SubElement(ann, "Annotations")  # a global element, checked laxly
            if shape == 3:
                var = next(iter(d.find("ModelVariables")))
                var.insert(0, copy.deepcopy(anns))
        return True

    for kind, change in [("unknown-attribute", unknown_attribute), ("enum-value", enum_value),
                         ("swap-order", swap_order), ("remove-attribute", remove_attribute),
                         ("non-numeric", non_numeric), ("non-boolean", non_boolean),
                         ("duplicate", duplicate), ("remove-element", remove_element),
                         ("text", text), ("free-content", free_content)]:
        emit(kind, change)
    return out


def our_verdicts(dirs):
    """dir -> whether ours gives a schema finding (one validate run for all)."""
    res = subprocess.run([cli_path(), "validate", "--json", "--timeout", "5", *map(str, dirs)],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode in (0, 1), res.stderr
    return {r["fmu"]: any(f["check"] == "schema" for f in r["findings"])
            for r in json.loads(res.stdout)}


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    """(label, dir holding modelDescription.xml, lxml's verdict: invalid?) of every seed and
    every mutation of it."""
    tmp = tmp_path_factory.mktemp("schema")
    schemas = {v: schema_of(v) for v in "23"}
    out = []
    for seed in SEEDS:
        doc = etree.parse(str(seed)).getroot()
        version = doc.get("fmiVersion")[0]
        rng = random.Random(f"{seed.parent.name}/{seed.name}")
        variants = [("seed", doc)] + mutations(doc, version, rng)
        for k, (kind, d) in enumerate(variants):
            label = f"{seed.parent.name}/{seed.name}#{k}:{kind}"
            where = tmp / f"{seed.parent.name}-{seed.stem}-{k}"
            where.mkdir()
            xml = etree.tostring(d, xml_declaration=True, encoding="UTF-8")
            (where / "modelDescription.xml").write_bytes(xml)
            invalid = not schemas[version].validate(etree.fromstring(xml))
            out.append((label, where, invalid))
    return out


def test_the_seeds_are_valid_descriptions(cases):
    assert len(SEEDS) >= 15
    seeds = [(label, invalid) for label, _, invalid in cases if label.endswith(":seed")]
    assert len(seeds) == len(SEEDS) and not any(invalid for _, invalid in seeds), seeds


def test_our_schema_verdict_equals_lxml_with_the_fmi_schema_files(cases):
    ours = our_verdicts([where for _, where, _ in cases])
    differ = [(label, "lxml invalid" if invalid else "lxml valid")
              for label, where, invalid in cases if ours[str(where)] != invalid]
    assert differ == [], differ
    # the mutations are not vacuous: both verdicts occur, for every kind of mutation
    kinds = {label.split(":")[-1] for label, _, _ in cases} - {"seed"}
    for kind in kinds:
        verdicts = {invalid for label, _, invalid in cases if label.endswith(":" + kind)}
        if kind in ("unknown-attribute", "enum-value", "non-boolean", "text"):
            assert True in verdicts, kind
        else:
            assert verdicts == {True, False}, kind
    assert sum(invalid for _, _, invalid in cases) >= 500
