"""`actuator-fmu validate` catches deliberately broken copies of our FMUs and
passes the clean ones.

Broken copies are made in a temporary directory:
- an output removed from <ModelStructure><Outputs> of modelDescription.xml;
- the binary replaced by tests/drivers/broken/crash_shim.c (compiled here with gcc), which
  forwards every call to the real binary but dereferences NULL in fmi2DoStep on an instance that
  is not initialized: correct call sequences still simulate, a wrong call order crashes.
Each must give exit status 1 with the finding on its own line and in --json; clean FMUs exit 0.
"""
import json
import re
import shutil
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import REPO, cli_path, fmu_path

ALL = ["HydraulicJoint", "TwistedString", "Oscillator"]


def validate(*fmus, json_out=False):
    args = [cli_path(), "validate", *(["--json"] if json_out else []), *map(str, fmus)]
    return subprocess.run(args, capture_output=True, text=True, timeout=300)


def rewrite_fmu(src, dst, replace):
    """Copy the FMU `src` to `dst`, passing each member's bytes through replace(name, data)
    (return None to drop the member, or a list of (name, data) to add several)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            out = replace(info.filename, zin.read(info.filename))
            if out is None:
                continue
            if isinstance(out, bytes):
                out = [(info.filename, out)]
            for name, data in out:
                zout.writestr(name, data)
    return dst


def test_clean_fmus_pass_with_exit_0():
    fmus = [fmu_path(n) for n in ALL]
    r = validate(*fmus)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("OK (no findings)") == 3, r.stdout
    r = validate(*fmus, json_out=True)
    assert r.returncode == 0
    report = json.loads(r.stdout)
    assert len(report) == 3 and all(entry["findings"] == [] for entry in report), report


@pytest.mark.parametrize("name", ALL)
def test_missing_output_in_model_structure_is_found(name, tmp_path):
    with zipfile.ZipFile(fmu_path(name)) as z:
        xml = z.read("modelDescription.xml").decode()
    names = re.findall(r'<ScalarVariable name="([^"]+)"', xml)
    outputs = re.search(r"<Outputs>(.*?)</Outputs>", xml, re.S).group(1)
    indices = re.findall(r'<Unknown index="(\d+)"', outputs)
    assert len(indices) >= 2
    victim_index = indices[len(indices) // 2]
    victim = names[int(victim_index) - 1]
    pattern = re.compile(rf'\s*<Unknown index="{victim_index}"[^>]*/>')
    new_outputs, n = pattern.subn("", outputs, count=1)
    assert n == 1
    broken_xml = xml.replace(outputs, new_outputs)

    def replace(member, data):
        return broken_xml.encode() if member == "modelDescription.xml" else data

    broken = rewrite_fmu(fmu_path(name), tmp_path / f"{name}.fmu", replace)
    r = validate(broken)
    assert r.returncode == 1, r.stdout + r.stderr
    lines = [line for line in r.stdout.splitlines() if victim in line]
    assert lines, f"no finding line names the output '{victim}':\n{r.stdout}"
    r = validate(broken, json_out=True)
    assert r.returncode == 1
    findings = json.loads(r.stdout)[0]["findings"]
    assert any(victim in f["message"] for f in findings), findings


def _crashing_copy(name, tmp_path, *defines):
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    so = tmp_path / f"{name}.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", f'-DMODEL_ID="{name}"', *defines, "-o",
                    str(so), str(REPO / "tests" / "drivers" / "broken" / "crash_shim.c"), "-ldl"],
                   check=True)
    binary = f"binaries/linux64/{name}.so"

    def replace(member, data):
        if member == binary:
            return [(binary, so.read_bytes()), (f"binaries/linux64/real_{name}.so", data)]
        return data

    return rewrite_fmu(fmu_path(name), tmp_path / f"{name}.fmu", replace)


@pytest.mark.parametrize("name", ["HydraulicJoint", "Oscillator"])
def test_binary_crashing_on_wrong_call_order_is_a_note(name, tmp_path):
    """fmi2DoStep before initialization or after fmi2Terminate is a call sequence the state
    machine does not allow (FMI 2.0.4 section 4.2.4 binds the importer); the standard leaves the
    outcome undefined, so a crash there is a note."""
    broken = _crashing_copy(name, tmp_path)
    # the copy is otherwise sound: a correct call sequence simulates exactly like the original
    a = simulate_fmu(fmu_path(name), stop_time=0.05, output_interval=1e-3)
    b = simulate_fmu(str(broken), stop_time=0.05, output_interval=1e-3)
    for col in a.dtype.names:
        assert np.array_equal(a[col], b[col]), col
    r = validate(broken, json_out=True)
    assert r.returncode == 0, r.stdout + r.stderr
    [report] = json.loads(r.stdout)
    assert report["findings"] == [], report
    crashes = {n["location"]: n for n in report["notes"] if "SIGSEGV" in n["message"]}
    assert set(crashes) == {"probe do-step-before-init", "probe do-step-after-terminate"}, report
    assert all(n["check"] == "probe-wrong-call" and "§4.2.4" in n["clause"]
               for n in crashes.values()), crashes
    r = validate(broken)
    assert r.returncode == 0
    assert any(line.startswith(f"{broken}: note [probe-wrong-call]") and "SIGSEGV" in line
               for line in r.stdout.splitlines()), r.stdout


def test_binary_crashing_in_a_legal_run_is_found(tmp_path):
    """A crash in fmi2DoStep of a correct run (from t = 0.005 s on) stays a finding (FMI 2.0.4
    section 2.1.3: every call returns a status)."""
    broken = _crashing_copy("Oscillator", tmp_path, "-DFAIL_AT=0.005")
    r = validate(broken, json_out=True)
    assert r.returncode == 1, r.stdout + r.stderr
    findings = json.loads(r.stdout)[0]["findings"]
    assert [(f["check"], f["location"]) for f in findings][:1] == \
        [("probe-crash", "probe normal-run")], findings
    assert "SIGSEGV" in findings[0]["message"], findings
    # a clean FMU given alongside is still reported clean
    r = validate(fmu_path("Oscillator"), broken)
    assert r.returncode == 1 and "OK (no findings)" in r.stdout


# Model Exchange (FMI 2.0.4 chapter 3): broken copies of the FMI 2.0 toy FMU VanDerPol
# (tests/fixtures/toy-fmus), which declares <ModelExchange> and <CoSimulation> with one binary
# for both.
VDP_SO = "binaries/linux64/VanDerPol.so"
# an interface element, self-closing or with content
CS_ELEMENT = re.compile(r"\s*<CoSimulation\b(?:[^>]*/>|.*?</CoSimulation>)", re.S)
ME_ELEMENT = re.compile(r"\s*<ModelExchange\b(?:[^>]*/>|.*?</ModelExchange>)", re.S)


@pytest.fixture
def vdp_copy(toy):
    """vdp_copy(tmp_path, label, md, so): a copy of VanDerPol with its description passed
    through md(text) and its binary through so(bytes)."""
    return lambda *args, **kw: _vdp_copy(toy("VanDerPol"), *args, **kw)


def _vdp_copy(src, tmp_path, label, md=lambda x: x, so=lambda b: b):
    def replace(member, data):
        if member == "modelDescription.xml":
            text = data.decode()
            out = md(text)
            assert out != text, "the patch changed nothing"
            return out.encode()
        return so(data) if member == VDP_SO else data

    return rewrite_fmu(src, tmp_path / f"{label}.fmu", replace)


def drop(pattern):
    def md(text):
        out, n = pattern.subn("", text, count=1)
        assert n == 1
        return out
    return md


def rename_export(old, new):
    """The binary with the exported symbol `old` renamed in its string table: no longer exported."""
    def so(data):
        needle = old.encode() + b"\0"
        assert needle in data and len(old) == len(new)
        return data.replace(needle, new.encode() + b"\0")
    return so


def validate_args(fmu, *options):
    r = subprocess.run([cli_path(), "validate", "--json", *options, str(fmu)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 1, r.stdout + r.stderr
    return json.loads(r.stdout)[0]["findings"]


def findings_of(fmu):
    r = validate(fmu, json_out=True)
    assert r.returncode in (0, 1), r.stderr
    report = json.loads(r.stdout)[0]
    assert (r.returncode == 1) == bool(report["findings"]), report
    return report["findings"]


def test_a_model_exchange_fmu_without_states_is_not_asked_for_them(toy, tmp_path):
    """FMI 2.0.4 section 2.2.8: "The number of Unknown elements in the Derivatives element
    uniquely defines the number of continuous time state variables". Feedthrough has none; built
    to refuse state calls with nx = 0 (as some exporters do), it still passes: the probe does not
    make them."""
    so = tmp_path / "Feedthrough.so"
    subprocess.run(["gcc", "-std=c99", "-shared", "-fPIC", "-O2", "-DREFUSE_EMPTY_STATE_CALLS",
                    "-o", str(so), str(REPO / "tests" / "fixtures" / "toy-fmus" / "feedthrough.c"),
                    "-lm"], check=True)
    binary = "binaries/linux64/Feedthrough.so"
    fmu = rewrite_fmu(toy("Feedthrough"), tmp_path / "Feedthrough.fmu",
                      lambda n, d: so.read_bytes() if n == binary else d)
    assert findings_of(fmu) == []


def test_a_model_exchange_only_fmu_is_no_finding(vdp_copy, tmp_path):
    assert findings_of(vdp_copy(tmp_path, "me-only", md=drop(CS_ELEMENT))) == []


def test_a_derivative_of_a_non_state_is_found(vdp_copy, tmp_path):
    # der(x0) names mu (index 6, a fixed parameter) as its state instead of x0 (index 2)
    fmu = vdp_copy(tmp_path, "bad-derivative",
                   md=lambda t: t.replace('<Real derivative="2"/>', '<Real derivative="6"/>'))
    found = findings_of(fmu)
    # the probe, taking mu for the state, may find what follows (derivatives that disagree)
    assert [f["check"] for f in found if not f["check"].startswith("probe-")] == ["derivative"]
    assert "'der(x0)' is the derivative of 'mu'" in found[0]["message"], found
    assert "2.2.8" in found[0]["clause"], found


def test_a_negative_number_of_event_indicators_is_found(vdp_copy, tmp_path):
    fmu = vdp_copy(tmp_path, "negative-indicators",
                   md=lambda t: t.replace('numberOfEventIndicators="0"',
                                          'numberOfEventIndicators="-1"'))
    found = findings_of(fmu)
    # the description cannot be read, and the schema (xs:unsignedInt) says why
    assert [f["check"] for f in found] == ["model-description-xml", "schema"], found
    assert "numberOfEventIndicators" in found[0]["message"], found
    assert 'numberOfEventIndicators="-1"' in found[1]["message"], found
    assert "xs:unsignedInt" in found[1]["message"], found
    assert found[1]["clause"].endswith("fmi2ModelDescription.xsd"), found


def test_a_model_exchange_function_not_exported_is_found_only_when_declared(vdp_copy, tmp_path):
    so = rename_export("fmi2SetTime", "fmi2SetTame")
    found = findings_of(vdp_copy(tmp_path, "me-no-settime", md=drop(CS_ELEMENT), so=so))
    assert "symbols" in [f["check"] for f in found], found
    # the probe cannot open the FMU as Model Exchange either, and says why
    assert all(f["check"] in ("symbols", "binary") and "fmi2SetTime" in f["message"]
               for f in found), found
    # Co-Simulation alone does not need fmi2SetTime
    found = findings_of(vdp_copy(tmp_path, "cs-no-settime", md=drop(ME_ELEMENT), so=so))
    assert not [f for f in found if f["check"] == "symbols"], found


@pytest.fixture
def me_shim_copy(toy):
    """me_shim_copy(tmp_path, label, *defines, model="VanDerPol"): see _me_shim_copy."""
    return lambda *args, **kw: _me_shim_copy(toy, *args, **kw)


def _me_shim_copy(toy, tmp_path, label, *defines, model="VanDerPol"):
    """A Model Exchange-only copy of the FMI 2.0 toy FMU `model` whose binary is
    crash_shim.c forwarding to the real one, built with `defines` (ME_FAIL_AT: fmi2GetDerivatives
    fails from that time on; the Model Exchange defects listed in crash_shim.c)."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    so = tmp_path / f"{label}.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", f'-DMODEL_ID="{model}"', *defines,
                    "-o", str(so), str(REPO / "tests" / "drivers" / "broken" / "crash_shim.c"),
                    "-ldl"], check=True)
    binary = f"binaries/linux64/{model}.so"

    def replace(member, data):
        if member == "modelDescription.xml":
            return drop(CS_ELEMENT)(data.decode()).encode()
        if member == binary:
            return [(binary, so.read_bytes()), (f"binaries/linux64/real_{model}.so", data)]
        return data

    return rewrite_fmu(toy(model), tmp_path / f"{label}.fmu", replace)


def test_the_model_exchange_probe_runs_the_fmu(me_shim_copy, tmp_path):
    # the shim alone (forwarding every call) is clean: the probe's calls are a legal sequence
    assert findings_of(me_shim_copy(tmp_path, "me-shim")) == []
    # fmi2GetDerivatives answering fmi2Error in a legal sequence: the normal run fails
    found = findings_of(me_shim_copy(tmp_path, "me-error", "-DME_FAIL_AT=0", "-DME_ERROR"))
    assert [f["check"] for f in found] == ["probe-normal-run"], found
    assert found[0]["location"] == "probe me-normal-run", found
    assert "fmi2GetDerivatives" in found[0]["message"], found
    # fmi2GetDerivatives never returning: a timeout finding at that probe step
    r = validate_args(me_shim_copy(tmp_path, "me-hang", "-DME_FAIL_AT=0", "-DHANG"),
                      "--timeout", "2")
    assert [(f["check"], f["location"]) for f in r] == [("probe-timeout", "probe me-normal-run")]
    # fmi2GetDerivatives crashing: a finding naming the probe step and the signal
    found = findings_of(me_shim_copy(tmp_path, "me-crash", "-DME_FAIL_AT=0"))
    assert [f["check"] for f in found] == ["probe-crash"], found
    assert found[0]["location"] == "probe me-normal-run", found
    assert "SIGSEGV" in found[0]["message"], found


def test_a_wrong_directional_derivative_is_found(me_shim_copy, tmp_path):
    # VanDerPol provides directional derivatives; the shim doubles them. The first column
    # (states in order) with a nonzero entry: d der(x1) / d x0 = -2 mu x0 x1 - 1 (der(x1) =
    # mu (1 - x0^2) x1 - x0), which the FMU gives twice. FMI 2.0.4 section 2.1.9.
    assert findings_of(me_shim_copy(tmp_path, "me-shim")) == []
    found = findings_of(me_shim_copy(tmp_path, "me-dd", "-DWRONG_DIRECTIONAL"))
    assert [(f["check"], f["location"]) for f in found] == [
        ("probe-directional-derivative", "probe me-directional-derivatives")], found
    m = re.search(r"d der\(x1\) / d x0 .* is (\S+) from the directional derivative but (\S+) "
                  r"from central differences .* at x = \[(\S+), (\S+)\]", found[0]["message"])
    assert m, found
    dd, fd, x0, x1 = map(float, m.groups())
    assert fd == pytest.approx(-2 * x0 * x1 - 1, rel=1e-6)  # mu = 1
    assert dd == pytest.approx(2 * fd, rel=1e-6)
    assert "FMI 2.0.4 §2.1.9" in found[0]["clause"], found


def test_states_re_initialized_without_telling_the_importer_is_found(me_shim_copy, tmp_path):
    # BouncingBall re-initializes v at the bounce; the shim reports
    # valuesOfContinuousStatesChanged = false (FMI 2.0.4 section 3.2.2)
    assert findings_of(me_shim_copy(tmp_path, "bb-shim", model="BouncingBall")) == []
    found = findings_of(me_shim_copy(tmp_path, "bb-event", "-DNO_VALUES_CHANGED",
                                      model="BouncingBall"))
    assert [(f["check"], f["location"]) for f in found] == [
        ("probe-event", "probe me-state-event")], found
    assert "valuesOfContinuousStatesChanged = false" in found[0]["message"], found
    assert "FMI 2.0.4 §3.2.2" in found[0]["clause"], found


def test_a_model_exchange_call_in_the_wrong_state_answered_ok_is_a_note(me_shim_copy, tmp_path):
    fmu = me_shim_copy(tmp_path, "me-lenient", "-DLENIENT_ME")
    r = validate(fmu, json_out=True)
    assert r.returncode == 0, r.stdout + r.stderr
    [report] = json.loads(r.stdout)
    assert report["findings"] == [], report
    notes = [(n["check"], n["location"]) for n in report["notes"] if "me-" in n["location"]]
    assert notes == [("probe-wrong-call", "probe me-derivatives-before-init"),
                     ("probe-wrong-call", "probe me-set-states-in-event-mode")], report
    # the ME state machine is FMI 2.0.4 section 3.2.3 (not the Co-Simulation one)
    assert all("§3.2.3" in n["clause"] for n in report["notes"]
               if n["location"].startswith("probe me-")), report


def test_a_model_exchange_error_without_a_message_is_a_note(me_shim_copy, tmp_path):
    # FMI 2.0.4 section 2.1.5: the logger "should" be called; loggingOn only switches debug
    # logging, so an error without a message is a note (FMI 3.0 differs: tests/test_validate_built)
    r = validate(me_shim_copy(tmp_path, "me-silent", "-DSILENT_ME"), json_out=True)
    assert r.returncode == 0, r.stdout + r.stderr
    [report] = json.loads(r.stdout)
    notes = [(n["check"], n["location"]) for n in report["notes"] if "me-" in n["location"]]
    assert notes == [("probe-log", "probe me-derivatives-before-init")], report
    assert all("FMI 2.0.4 §2.1.5" in n["clause"] for n in report["notes"]
               if n["check"] == "probe-log"), report


def test_a_model_exchange_state_not_restored_is_found(me_shim_copy, tmp_path):
    # VanDerPol declares canGetAndSetFMUstate in <ModelExchange>; the shim's fmi2SetFMUstate
    # restores nothing (FMI 2.0.4 section 2.1.8)
    found = findings_of(me_shim_copy(tmp_path, "me-no-restore", "-DNO_RESTORE"))
    assert [(f["check"], f["location"]) for f in found] == [
        ("probe-fmu-state", "probe me-fmu-state")], found
    assert "after fmi2SetFMUstate the continuous states" in found[0]["message"], found
    assert "FMI 2.0.4 §2.1.8" in found[0]["clause"], found
