"""Reference results of our FMUs (FMI-LS-REF) and `actuator-fmu validate --reference`.

The bundled references (references/<Model>/, made by scripts/references from the independent
SciPy references of tests/reference/) must be current and travel in both versions' archives;
`validate --reference` must pass on them, fail naming the signal and the time where a result
leaves its tube, and read the alpha form of the Modelica Reference-FMUs (a `<Related
role="result">` CSV of the DefaultExperiment), checked on a toy FMU whose reference FMPy, an
independent importer, computes.
"""
import json
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from conftest import REPO, cli_path, fmu3_path, fmu_path

sys.path.insert(0, str(REPO / "scripts"))
import references  # noqa: E402

MODELS = references.MODELS
LS = "extra/org.fmi-standard.fmi-ls-ref"
VERSIONS = {"fmi2": fmu_path, "fmi3": fmu3_path}


def validate(fmu, *args):
    """`validate --json FMU ARGS`: (exit status, the FMU's report)."""
    out = subprocess.run([cli_path(), "validate", "--json", str(fmu), *args],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode in (0, 1), out.stdout + out.stderr
    (report,) = json.loads(out.stdout)
    return out.returncode, report


def reference_results(report):
    """(findings, notes) of the check reference-result."""
    pick = lambda items: [f for f in items if f["check"] == "reference-result"]  # noqa: E731
    return pick(report["findings"]), pick(report["notes"])


# ---- the bundled data -----------------------------------------------------------------------

@pytest.mark.parametrize("model", MODELS)
def test_references_are_not_stale(model):
    """The hash of what the references were made from (generator, reference equations, the
    parameter defaults of modelDescription/<Model>.xml) is the one recorded with them."""
    recorded = (REPO / "references" / model / "generated-from.sha256").read_text().strip()
    assert recorded == references.source_hash(model), (
        f"references/{model}/ is stale: the reference code, the generator or "
        f"modelDescription/{model}.xml changed; run scripts/references {model}")


def test_emps_references_regenerate_identically(tmp_path):
    """The cheapest model made again from the reference code: the same bytes."""
    references.generate("EMPS", str(tmp_path))
    for name in ("EMPS_in.csv", "EMPS_ref.csv", "fmi-ls-manifest.xml", "fmi-ls-ref.html"):
        assert (tmp_path / name).read_bytes() == (REPO / "references" / "EMPS" / name).read_bytes(), name


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", MODELS)
def test_archives_carry_the_references(model, version):
    src = REPO / "references" / model
    with zipfile.ZipFile(VERSIONS[version](model)) as z:
        for name in ("fmi-ls-manifest.xml", f"{model}_in.csv", f"{model}_ref.csv"):
            assert z.read(f"{LS}/{name}") == (src / name).read_bytes(), name
        assert z.read("documentation/fmi-ls-ref.html") == (src / "fmi-ls-ref.html").read_bytes()
        assert not any(n.endswith(".sha256") for n in z.namelist())
    # the manifest's root as the FMI-LS-REF schema fixes it
    from lxml import etree
    root = etree.parse(str(src / "fmi-ls-manifest.xml")).getroot()
    ns = "{http://fmi-standard.org/fmi-ls-manifest}"
    assert root.tag == "fmiReferences"
    assert root.get(f"{ns}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
    assert root.get(f"{ns}fmi-ls-version") == "1.0.0-rc.1"
    assert root.get(f"{ns}fmi-ls-description") == (
        "Layered Standard providing reference stimuli and results for an FMU.")
    (experiment,) = root.findall("Experiment")
    assert [c.tag for c in experiment] == ["Stimuli", "References"]


# ---- validate --reference ---------------------------------------------------------------------

@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", MODELS)
def test_reference_passes_on_our_fmus(model, version):
    code, report = validate(VERSIONS[version](model), "--reference")
    findings, notes = reference_results(report)
    assert findings == [] and code == 0, findings
    ref_columns = (REPO / "references" / model / f"{model}_ref.csv").read_text().split("\n")[0]
    n = len(ref_columns.split(",")) - 1
    assert len(notes) == 1 and notes[0]["message"].startswith(f"passed: {n} signal(s)"), notes
    assert "closed_loop" in notes[0]["location"]


def shifted_reference(tmp_path, model, signal, t0, fraction):
    """The bundled reference of `model` with `signal` moved by `fraction` of its range from t0 on."""
    src = REPO / "references" / model / f"{model}_ref.csv"
    header = src.read_text().split("\n")[0]
    data = np.loadtxt(src, delimiter=",", skiprows=1)
    j = header.split(",").index(signal)
    data[data[:, 0] >= t0, j] += fraction * np.ptp(data[:, j])
    path = tmp_path / f"{model}_wrong.csv"
    np.savetxt(path, data, delimiter=",", fmt="%.10g", header=header, comments="")
    return path


@pytest.mark.parametrize("version", VERSIONS)
def test_a_changed_signal_fails_naming_it_and_its_time(tmp_path, version):
    """A user's reference with `force` 1 % of its range higher from t0 = 1.5 s on (the tube is
    0.2 %): one finding, for force, at a time from t0 to t0 plus the tube's half width in time
    (0.2 % of the 3 s, 6 ms) and a step."""
    t0 = 1.5
    wrong = shifted_reference(tmp_path, "EMPS", "force", t0, 0.01)
    stimuli = REPO / "references" / "EMPS" / "EMPS_in.csv"
    code, report = validate(VERSIONS[version]("EMPS"), f"--reference={wrong}",
                            "--reference-inputs", str(stimuli))
    findings, _ = reference_results(report)
    assert code == 1 and len(findings) == 1, findings
    message = findings[0]["message"]
    assert message.startswith("'force' leaves the tube at t = "), message
    t = float(message.split("t = ")[1].split(" s")[0])
    assert t0 <= t <= t0 + 0.006 + 0.001 + 1e-9, message


def test_a_wrong_bundled_reference_fails_in_the_manifest_run(tmp_path):
    """The FMI 3.0 HydraulicJoint with its bundled theta reference 1 % of the range off from
    t0 = 2 s: the manifest's experiment fails naming theta at t0 or just after."""
    t0 = 2.0
    wrong = shifted_reference(tmp_path, "HydraulicJoint", "theta", t0, 0.01)
    fmu = tmp_path / "HydraulicJoint.fmu"
    entry = f"{LS}/HydraulicJoint_ref.csv"
    with zipfile.ZipFile(fmu3_path("HydraulicJoint")) as src, \
            zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = wrong.read_bytes() if item.filename == entry else src.read(item)
            dst.writestr(item, data)
    code, report = validate(fmu, "--reference")
    findings, _ = reference_results(report)
    assert code == 1 and len(findings) == 1, findings
    message = findings[0]["message"]
    assert message.startswith("'theta' leaves the tube at t = "), message
    t = float(message.split("t = ")[1].split(" s")[0])
    assert t0 <= t <= t0 + 0.006 + 0.005 + 1e-9, message


ALPHA = """<?xml version="1.0" encoding="UTF-8"?>
<fmiReferences xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
    fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" fmi-ls:fmi-ls-version="1.0.0-alpha.1">
    <Related type="text/csv" source="VanDerPol_out.csv" role="result" description="Output of the default experiment"/>
</fmiReferences>
"""


@pytest.mark.parametrize("version", [2, 3])
def test_alpha_manifest_of_the_default_experiment_passes(toy, tmp_path, version):
    """The toy VanDerPol with a <Related role="result"> CSV of its DefaultExperiment made by
    FMPy (Co-Simulation, the experiment's 0.01 s step): both outputs within the tube."""
    src = toy("VanDerPol", version)
    md = read_model_description(str(src))
    de = md.defaultExperiment
    res = simulate_fmu(str(src), start_time=float(de.startTime), stop_time=float(de.stopTime),
                       step_size=float(de.stepSize), output_interval=float(de.stepSize),
                       fmi_type="CoSimulation", output=["x0", "x1"])
    rows = "\n".join(",".join(repr(float(r[k])) for k in ("time", "x0", "x1")) for r in res)
    fmu = tmp_path / "VanDerPol.fmu"
    shutil.copy(src, fmu)
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as z:
        z.writestr(f"{LS}/fmi-ls-manifest.xml", ALPHA)
        z.writestr(f"{LS}/VanDerPol_out.csv", "time,x0,x1\n" + rows + "\n")
    code, report = validate(fmu, "--reference")
    findings, notes = reference_results(report)
    assert findings == [], findings
    assert len(notes) == 1 and notes[0]["message"].startswith("passed: 2 signal(s)"), notes
    assert "DefaultExperiment (VanDerPol_out.csv)" in notes[0]["location"]
    assert f"over [0, {float(de.stopTime):g}] s" in notes[0]["message"]


def test_a_reference_with_event_rows_is_read_and_passes(toy, tmp_path):
    """A reference recorded from Model Exchange writes the rows before and after each event at
    the same time (as fmusim makes the Reference-FMUs' references, and FMPy records): the toy
    BouncingBall's bounces, made by FMPy at rtol 1e-10, are read as events and our run stays in
    the tube."""
    src = toy("BouncingBall")
    res = simulate_fmu(str(src), fmi_type="ModelExchange", stop_time=3.0, output_interval=0.01,
                       relative_tolerance=1e-10, output=["h", "v"])
    assert np.any(np.diff(res["time"]) == 0), "FMPy recorded no event rows"
    rows = "\n".join(",".join(repr(float(r[k])) for k in ("time", "h", "v")) for r in res)
    fmu = tmp_path / "BouncingBall.fmu"
    shutil.copy(src, fmu)
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as z:
        z.writestr(f"{LS}/fmi-ls-manifest.xml", ALPHA.replace("VanDerPol", "BouncingBall"))
        z.writestr(f"{LS}/BouncingBall_out.csv", "time,h,v\n" + rows + "\n")
    code, report = validate(fmu, "--reference")
    findings, notes = reference_results(report)
    assert findings == [], findings
    assert len(notes) == 1 and notes[0]["message"].startswith("passed: 2 signal(s)"), notes
