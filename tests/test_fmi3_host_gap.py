"""`gap` and `design` on an FMI 3.0 Co-Simulation FMU: the geared motor of
tests/fixtures/geared-motor/ built as FMI 3.0 (geared_motor_fmi3.c forwards each FMI 3.0 call to
the FMI 2.0 implementation; the description is the hand-written one with Real -> Float64).

The measured-style data come from FMPy running the FMI 2.0 build (tests/geared_motor.py), so the
FMI 3.0 path of the host (description, binding, runs) is what the workflow goes through, and it
must name the hidden effect as it does in the FMI 2.0 build (tests/test_foreign_fmu.py). The
FMI 3.0 Model Exchange path goes under `gap` too (the toy Dahlquist FMU calibrated).
"""
import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from conftest import REPO, cli_path

sys.path.insert(0, str(REPO / "examples"))
import gapgen  # noqa: E402
import geared_motor as gm  # noqa: E402

fmpy = pytest.importorskip("fmpy")
pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="built for x86_64-linux here")

TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String",
         "Enumeration": "Enumeration"}


def fmi3_description(fmi2_text):
    """The FMI 2.0 description as FMI 3.0: instantiationToken = guid, the independent variable
    `time` added, each ScalarVariable as its FMI 3.0 type element with the type's attributes,
    ModelStructure by value reference."""
    src = ET.fromstring(fmi2_text)
    root = ET.Element("fmiModelDescription", fmiVersion="3.0", modelName=src.get("modelName"),
                      instantiationToken=src.get("guid"), description=src.get("description"),
                      generationTool="tests/test_fmi3_host_gap.py")
    ET.SubElement(root, "CoSimulation", modelIdentifier=src.find("CoSimulation").get("modelIdentifier"),
                  canHandleVariableCommunicationStepSize="true")
    for tag in ("UnitDefinitions", "LogCategories", "DefaultExperiment"):
        if src.find(tag) is not None:
            root.append(src.find(tag))
    mv = ET.SubElement(root, "ModelVariables")
    # FMI 3.0 requires the independent variable, which FMI 2.0 left optional (the FMU never
    # sees its value reference)
    ET.SubElement(mv, "Float64", name="time", valueReference="999", causality="independent",
                  variability="continuous")
    vrs = []
    for v in src.find("ModelVariables"):
        (t,) = list(v)
        attrs = {k: v.get(k) for k in ("name", "valueReference", "description", "causality",
                                         "variability", "initial") if v.get(k) is not None}
        attrs.update(t.attrib)
        ET.SubElement(mv, TYPES[t.tag], attrs)
        vrs.append(v.get("valueReference"))
    ms = ET.SubElement(root, "ModelStructure")
    for u in src.find("ModelStructure/Outputs"):
        ET.SubElement(ms, "Output", valueReference=vrs[int(u.get("index")) - 1])
    for u in src.find("ModelStructure/InitialUnknowns") or []:
        ET.SubElement(ms, "InitialUnknown", valueReference=vrs[int(u.get("index")) - 1])
    return ET.tostring(root, encoding="unicode", xml_declaration=True)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    d = tmp_path_factory.mktemp("geared-motor-fmi3")
    lib = d / "binaries" / "x86_64-linux" / "geared_motor.so"
    lib.parent.mkdir(parents=True)
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-shared", "-fPIC", "-O2",
                    "-o", str(lib), str(gm.SRC / "geared_motor_fmi3.c"), "-lm"], check=True)
    fmu3 = d / "GearedMotor3.fmu"
    with zipfile.ZipFile(fmu3, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", fmi3_description(gm.description()))
        z.write(lib, "binaries/x86_64-linux/geared_motor.so")
    return {"fmi3": fmu3, "fmi2": gm.build(d)}


def test_the_fmi3_build_simulates_as_fmpy_runs_it(fmus, tmp_path):
    t = np.round(np.arange(0, 201) / 200.0, 12)
    u = gm.voltage_steps(np.random.default_rng(3), t)
    with open(tmp_path / "in.csv", "w") as f:
        f.write("time,voltage\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, u)))
    r = subprocess.run([cli_path(), "simulate", str(fmus["fmi3"]), "--data", str(tmp_path / "in.csv"),
                        "--set", "coulomb_friction.enabled=true", "--set", "coulomb_friction.torque=0.05",
                        "--out", str(tmp_path / "o.csv")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    ours = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)
    sig = np.zeros(len(t), dtype=[("time", float), ("voltage", float)])
    sig["time"], sig["voltage"] = t, u
    ref = fmpy.simulate_fmu(str(fmus["fmi3"]), fmi_type="CoSimulation", stop_time=1.0,
                            output_interval=0.005, input=sig,
                            start_values={"coulomb_friction.enabled": True,
                                          "coulomb_friction.torque": 0.05})
    for n in gm.OUTPUTS:
        np.testing.assert_allclose(ours[n], ref[n], rtol=1e-6, atol=1e-9 * np.ptp(ref[n]), err_msg=n)


def test_gap_names_the_hidden_effect_in_the_fmi3_build(fmus, tmp_path):
    ds = gm.make(fmus["fmi2"], 21, ("coulomb_friction",))
    gapgen.write_csv(ds, tmp_path / "d.csv")
    p = subprocess.run([cli_path(), "gap", str(fmus["fmi3"]), "--data", str(tmp_path / "d.csv"),
                        "--out", str(tmp_path / "g"), "--quiet"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    rep = json.loads((tmp_path / "g" / "report.json").read_text())
    assert rep["named"] == ["coulomb_friction"], rep["verdict"]


def test_design_proposes_the_same_experiment_for_both_builds(fmus, tmp_path):
    """Same equations, same conventions: the FMI 3.0 build gets the experiment the FMI 2.0 build
    gets (the files differ only in the FMU named on their first line)."""
    texts = []
    for kind in ("fmi2", "fmi3"):
        out = tmp_path / f"{kind}.csv"
        p = subprocess.run([cli_path(), "design", str(fmus[kind]), "--effect", "coulomb_friction",
                            "--out", str(out)], capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr
        texts.append(out.read_text().split("\n", 1)[1])
    assert texts[0] == texts[1]
    assert "coulomb_friction" in texts[1]


def test_gap_calibrates_an_fmi3_model_exchange_fmu(toy, tmp_path):
    """The FMI 3.0 Model Exchange path (the host integrating the FMU) under the gap workflow:
    Dahlquist's k recovered from the closed form x = exp(-k t) with k = 1.5 (start 1)."""
    fmu = toy("Dahlquist", 3)
    t = np.round(np.arange(0, 61) * 0.05, 12)
    with open(tmp_path / "d.csv", "w") as f:
        f.write("time,x\n" + "".join(f"{ti!r},{math.exp(-1.5 * ti)!r}\n" for ti in t.tolist()))
    p = subprocess.run([cli_path(), "gap", str(fmu), "--interface", "me", "--data", str(tmp_path / "d.csv"),
                        "--out", str(tmp_path / "g"), "--fit", "k", "--quiet"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    rep = json.loads((tmp_path / "g" / "report.json").read_text())
    assert rep["named"] == []
    assert abs(rep["parameters"]["k"]["value"] - 1.5) < 1e-3, rep["parameters"]["k"]
