"""`actuator-fmu validate` on FMI 3.0 FMUs: clean on the toy FMUs built as FMI 3.0
(tests/fixtures/toy-fmus/) and on our own FMI 3.0 FMUs (dist/fmi3/); each rule of
the FMI 3.0.2 standard it checks found in a copy of a fixture broken to violate it (its
modelDescription.xml patched, or its binaries moved, dropped or with an export renamed).

The expected findings come from the standard's text (FMI 3.0.2 sections 2.4.1, 2.4.7, 2.4.8 and
2.5), not from the validator's output: each broken copy violates one rule by construction.
"""
import json
import re
import subprocess
import zipfile

import pytest

from conftest import cli_path, fmu3_path

TOKEN = "{8c4e810f-3df3-4a00-8276-176fa3c9f001}"  # VanDerPol's
FIXTURES = ["Clocks", "Dahlquist", "Resource", "Stair", "StateSpace", "VanDerPol"]


def validate_json(*fmus):
    res = subprocess.run([cli_path(), "validate", "--json", *map(str, fmus)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode in (0, 1), (res.returncode, res.stderr)
    reports = json.loads(res.stdout)
    assert (res.returncode == 1) == any(r["findings"] for r in reports), res.stdout
    return reports


def broken(toy, tmp_path, name, md=lambda x: x, member=lambda n, d: d, suffix="broken"):
    """A copy of fixture `name` with its modelDescription.xml passed through md(text) and every
    other member through member(name, bytes) (None drops it, a (name, bytes) renames it)."""
    dst = tmp_path / f"{name}-{suffix}.fmu"
    with zipfile.ZipFile(toy(name, 3)) as zin, \
            zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            if info.filename == "modelDescription.xml":
                zout.writestr(info.filename, md(data.decode()))
                continue
            out = member(info.filename, data)
            if out is None:
                continue
            if isinstance(out, tuple):
                zout.writestr(*out)
            else:
                zout.writestr(info.filename, out)
    return dst


def replace(old, new):
    def md(text):
        assert old in text, old
        return text.replace(old, new, 1)
    return md


def findings(toy, tmp_path, name="VanDerPol", **kw):
    [report] = validate_json(broken(toy, tmp_path, name, **kw))
    return report["findings"]


def test_fixtures_and_our_fmi3_fmus_have_no_findings(toy):
    fmus = [toy(n, 3) for n in FIXTURES]
    fmus += [fmu3_path(n) for n in ("HydraulicJoint", "TwistedString")]
    reports = validate_json(*fmus)
    for r in reports:
        assert r["findings"] == [], r
        # the binary of this platform was read, with its exports
        assert any(b["entry"].startswith("binaries/x86_64-linux/") for b in r["binaries"]), r


# (fixture, patch of modelDescription.xml, expected check, fragment of its message)
DESCRIPTION_CASES = {
    "instantiation-token": ("VanDerPol", replace(
        f'instantiationToken="{TOKEN}"', 'instantiationToken=" "'),
        "instantiation-token", "instantiationToken is missing or empty"),
    "no-independent": ("VanDerPol", replace(
        '<Float64 name="time" valueReference="0" causality="independent" '
        'variability="continuous"/>', ""),
        "independent", "0 variables with causality=\"independent\""),
    "two-independents": ("VanDerPol", replace(
        '<Float64 name="mu"',
        '<Float64 name="t2" valueReference="9" causality="independent" '
        'variability="continuous"/>\n<Float64 name="mu"'),
        "independent", "2 variables with causality=\"independent\""),
    "unique-names": ("VanDerPol", replace('name="x1"', 'name="x0"'),
                     "unique-names", "name 'x0' is already used"),
    "unique-value-references": ("VanDerPol", replace(
        '<Float64 name="mu" valueReference="5"',
        '<Float64 name="mu" valueReference="5"/>\n<Float64 name="mu2" valueReference="5"'
        ' causality="parameter" variability="fixed" start="1"/>\n<Float64 name="unused"'
        ' valueReference="6"'),
        "unique-value-references", "valueReference 5 is shared by mu, mu2"),
    "causality-variability": ("VanDerPol", replace(
        'causality="parameter" variability="fixed"', 'causality="parameter" variability="continuous"'),
        "causality-variability", "causality parameter with variability continuous"),
    "initial": ("VanDerPol", replace(
        'variability="fixed" initial="exact" start="1"', 'variability="fixed" initial="calculated"'),
        "initial", 'initial="calculated" is not allowed'),
    "start-required": ("VanDerPol", replace('initial="exact" start="2"', 'initial="exact"'),
                       "start", "start is required"),
    "start-forbidden": ("VanDerPol", replace(
        'initial="calculated" derivative="1"', 'initial="calculated" start="0" derivative="1"'),
        "start", "start is not allowed"),
    "unit-declared": ("VanDerPol", replace('name="mu" valueReference="5"',
                                          'name="mu" valueReference="5" unit="m"'),
                      "unit-declared", "unit 'm' is not defined in <UnitDefinitions>"),
    "declared-type": ("VanDerPol", replace('name="mu" valueReference="5"',
                                          'name="mu" valueReference="5" declaredType="Mass"'),
                      "declared-type", "declaredType 'Mass' is not defined"),
    "dimension-not-uint64": ("StateSpace", replace(
        '<Dimension valueReference="2"/>\n      <Dimension valueReference="2"/>',
        '<Dimension valueReference="5"/>\n      <Dimension valueReference="2"/>'),
        "dimension", "valueReference 5 is 'B', a Float64, not a scalar UInt64"),
    "dimension-missing": ("StateSpace", replace(
        '<Dimension valueReference="2"/>\n      <Dimension valueReference="2"/>',
        '<Dimension valueReference="99"/>\n      <Dimension valueReference="2"/>'),
        "dimension", "valueReference 99 is not a variable"),
    "derivative": ("VanDerPol", replace('initial="calculated" derivative="1"',
                                        'initial="calculated" derivative="5"'),
                   "derivative", "derivative=\"5\" is 'mu', not a continuous Float"),
    "output-not-output": ("VanDerPol", replace(
        '<Output valueReference="3"/>',
        '<Output valueReference="3"/>\n<Output valueReference="5"/>'),
        "outputs-listed", "'mu' is listed in <Output> but its causality is parameter"),
    "output-missing": ("VanDerPol", replace('<Output valueReference="3"/>', ""),
                       "outputs-listed", "output 'x1' (valueReference 3) is missing"),
    "state-derivative": ("VanDerPol", replace(
        '<ContinuousStateDerivative valueReference="2"/>',
        '<ContinuousStateDerivative valueReference="1"/>'),
        "model-structure", "'x0' is listed in <ContinuousStateDerivative> but has no derivative"),
    "initial-unknown": ("VanDerPol", replace(
        '<InitialUnknown valueReference="2"/>',
        '<InitialUnknown valueReference="2"/>\n<InitialUnknown valueReference="42"/>'),
        "model-structure", "valueReference 42 is not a variable"),
    # FMI 3.0.2 section 2.4.8: state derivatives with initial calculated are initial unknowns
    "initial-unknown-derivative-missing": ("VanDerPol", replace(
        '<InitialUnknown valueReference="4"/>', ""),
        "initial-unknowns", "'der(x1)' (valueReference 4) must be listed in <InitialUnknown>"),
    # an output (and state) with initial approx is one
    "initial-unknown-output-missing": ("VanDerPol", replace(
        'initial="exact" start="2"', 'initial="approx" start="2"'),
        "initial-unknowns", "'x0' (valueReference 1) must be listed in <InitialUnknown>"),
}


@pytest.mark.parametrize("case", DESCRIPTION_CASES)
def test_a_broken_description_rule_is_found(toy, case, tmp_path):
    name, md, check, fragment = DESCRIPTION_CASES[case]
    found = findings(toy, tmp_path, name, md=md)
    hits = [f for f in found if f["check"] == check and fragment in f["message"]]
    assert hits, found
    # only this rule; the runtime probe may find what follows from it (an empty token refused)
    assert all(f["check"] == check for f in found if not f["check"].startswith("probe-")), found
    assert all(f["clause"].startswith("FMI 3.0.2 §") for f in found), found


SO = "binaries/x86_64-linux/VanDerPol.so"


def rename_export(old, new):
    """Renames the exported symbol `old` in the ELF string table (same length): the binary no
    longer exports it."""
    assert len(old) == len(new)

    def member(name, data):
        if name != SO:
            return data
        needle = old.encode() + b"\0"
        assert needle in data
        return data.replace(needle, new.encode() + b"\0")
    return member


BINARY_CASES = {
    # A function of a declared interface (Co-Simulation) not exported.
    "cs-export": (rename_export("fmi3DoStep", "fmi3DoStap"), "symbols", "fmi3DoStep"),
    # A Model Exchange function (the FMU declares <ModelExchange>) not exported.
    "me-export": (rename_export("fmi3SetTime", "fmi3SetTame"), "symbols", "fmi3SetTime"),
    # The library in its platform directory under a name other than the modelIdentifier.
    "misnamed": (lambda n, d: ("binaries/x86_64-linux/vanderpol.so", d) if n == SO else d,
                 "binary", "no VanDerPol.so"),
    # Only an FMI 2.0 platform directory (a vendor's name) and no sources: nothing under a
    # platform tuple, so nothing an importer runs.
    "fmi2-platform-only": (lambda n, d: None if n.startswith("sources/") else
                           (n.replace("x86_64-linux", "linux64"), d)
                           if n.startswith("binaries/x86_64-linux") else d,
                           "binary", "nothing to run"),
    # Entries with '\\' as path separator (APPNOTE.TXT 4.4.17).
    "backslash": (lambda n, d: (n.replace("/", "\\"), d) if n == SO else d,
                  "zip-path", "binaries\\x86_64-linux\\VanDerPol.so"),
    # A Linux library where the Windows tuple needs a PE file.
    "wrong-format": (lambda n, d: ("binaries/x86_64-windows/VanDerPol.dll", d) if n == SO else d,
                     "binary-format", "x86_64-windows needs PE"),
    # Neither binaries nor sources.
    "nothing-to-run": (lambda n, d: None if n.startswith(("binaries/", "sources/")) else d,
                       "binary", "nothing to run"),
}


@pytest.mark.parametrize("case", BINARY_CASES)
def test_a_broken_binary_rule_is_found(toy, case, tmp_path):
    member, check, fragment = BINARY_CASES[case]
    found = findings(toy, tmp_path, member=member)
    hits = [f for f in found if f["check"] == check and fragment in f["message"]]
    assert hits, found
    assert all(f["clause"].startswith("FMI 3.0.2 §") for f in found), found


def test_a_library_not_named_after_an_invalid_model_identifier_is_reported_missing(toy, tmp_path):
    """FMI 3.0.2 section 2.5: the library is binaries/<platformTuple>/<modelIdentifier>.so. An
    identifier that is not a C identifier is a finding of its own, and still names the file an
    importer looks for: the library named otherwise is missing too."""
    invalid = replace('modelIdentifier="VanDerPol"', 'modelIdentifier="van-der-pol"')
    found = findings(toy, tmp_path, md=invalid)
    checks = {f["check"] for f in found}
    assert "model-identifier" in checks, found
    assert any(f["check"] == "binary" and "no van-der-pol.so" in f["message"] for f in found), found


def test_an_exact_continuous_input_is_no_finding(toy, tmp_path):
    """FMI 3.0.2 section 2.4.7.5 gives an input initial="exact" (its default and only value),
    where FMI 2.0.4 gives an input no initial attribute: no finding in FMI 3.0."""
    exact = replace('name="u" valueReference="9" causality="input"',
                    'name="u" valueReference="9" causality="input" initial="exact"')
    assert [f for f in findings(toy, tmp_path, "StateSpace", md=exact) if f["check"] == "initial"] == []
    calculated = replace('name="u" valueReference="9" causality="input"',
                         'name="u" valueReference="9" causality="input" initial="calculated"')
    checks = [f["check"] for f in findings(toy, tmp_path, "StateSpace", md=calculated)]
    assert "initial" in checks, checks


def test_states_of_a_co_simulation_fmu_without_directional_derivatives_are_not_demanded(
        toy, tmp_path):
    """FMI 3.0.2 section 2.4.8: "For Co-Simulation, elements ContinuousStateDerivative are
    ignored if capability flag providesDirectionalDerivatives has a value of false", so its state
    derivatives need not be initial unknowns; with the flag they must."""
    def cs_only(flag):
        def md(text):
            text = drop_model_exchange(text)
            text = text.replace('<InitialUnknown valueReference="2"/>', "")
            return text.replace('<InitialUnknown valueReference="4"/>', "").replace(
                'canHandleVariableCommunicationStepSize="true"',
                f'canHandleVariableCommunicationStepSize="true" '
                f'providesDirectionalDerivatives="{flag}"')
        return md
    found = findings(toy, tmp_path, md=cs_only("false"), suffix="no-dd")
    assert [f for f in found if f["check"] == "initial-unknowns"] == [], found
    found = findings(toy, tmp_path, md=cs_only("true"), suffix="dd")
    names = sorted(f["message"].split("'")[1] for f in found if f["check"] == "initial-unknowns")
    assert names == ["der(x0)", "der(x1)"], found


def test_sources_without_binaries_are_no_finding(toy, tmp_path):
    assert findings(toy, tmp_path, member=lambda n, d: None if n.startswith("binaries/") else d) == []


def test_a_vendor_folder_beside_the_platform_tuples_is_a_note(toy, tmp_path):
    """FMI 3.0.2 section 2.5.1.4: "Further names can be introduced by vendors"; a darwin64
    folder beside x86_64-linux is no finding, only a note that importers do not look in it."""
    fmu = broken(toy, tmp_path, "VanDerPol")
    with zipfile.ZipFile(fmu, "a") as z:
        z.writestr("binaries/darwin64/VanDerPol.dylib", b"vendor")
    [report] = validate_json(fmu)
    assert report["findings"] == [], report["findings"]
    notes = [n for n in report["notes"] if n["check"] == "platform-folder"]
    assert len(notes) == 1 and "darwin64" in notes[0]["location"], report["notes"]
    assert notes[0]["clause"].startswith("FMI 3.0.2 §2.5.1.4"), notes


def test_no_binary_for_this_host_is_a_note(toy, tmp_path):
    """The library for another platform tuple only: "at least one implementation" holds (FMI
    3.0.2 section 2.5), the FMU is not probed here."""
    def member(name, data):
        return (name.replace("x86_64-linux", "x86_64-windows").replace(".so", ".dll"), data) \
            if name.startswith("binaries/x86_64-linux") else data
    [report] = validate_json(broken(toy, tmp_path, "VanDerPol", member=member))
    # (the ELF file under the Windows tuple is a binary-format finding of its own)
    assert [f for f in report["findings"] if f["check"] == "binary"] == [], report["findings"]
    notes = [n for n in report["notes"] if n["check"] == "binary-not-probed"]
    assert len(notes) == 1 and "not probed here" in notes[0]["message"], report["notes"]


def test_effects_convention_is_checked_on_fmi3_fmus(toy):
    args = [cli_path(), "validate", "--json", "--effects"]
    ours = [fmu3_path(n) for n in ("HydraulicJoint", "TwistedString")]
    res = subprocess.run([*args, *ours], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
    # VanDerPol has no parameter described "[calibrate] ...": not a gap-workflow FMU
    res = subprocess.run([*args, str(toy("VanDerPol", 3))], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 1, res.stdout + res.stderr
    [report] = json.loads(res.stdout)
    assert [f["check"] for f in report["findings"]] == ["effect-convention"], report
    assert "[calibrate]" in report["findings"][0]["message"], report


def test_the_co_simulation_probe_runs_the_fmu(toy, tmp_path):
    # A well-formed instantiationToken that is not the binary's: the description alone is
    # conforming, the probe's normal run finds that the binary refuses to instantiate.
    found = findings(toy, tmp_path, md=replace(TOKEN, "{00000000-0000-0000-0000-000000000000}"))
    # VanDerPol declares both interfaces: both probes' normal runs fail
    assert [f["check"] for f in found] == ["probe-normal-run"] * 2, found
    assert [f["location"] for f in found] == ["probe fmi3-normal-run",
                                              "probe fmi3-me-normal-run"], found
    assert "fmi3InstantiateCoSimulation" in found[0]["message"], found
    assert "fmi3InstantiateModelExchange" in found[1]["message"], found
    assert all(f["clause"].startswith("FMI 3.0.2 §") for f in found), found


def drop_model_exchange(text):
    return re.sub(r"\s*<ModelExchange\b[^>]*/>", "", text, count=1)


def drop_co_simulation(text):
    start = text.index("<CoSimulation")
    end = text.index("/>", start) + 2
    return text[:start] + text[end:]


def test_the_model_exchange_probe_runs_the_fmu(toy, tmp_path):
    # VanDerPol as a Model Exchange-only FMU: conforming, and the ME probe's run is legal
    assert findings(toy, tmp_path, md=drop_co_simulation, suffix="me-only") == []
    # with an instantiationToken the binary does not know, the ME probe cannot instantiate
    wrong = replace(TOKEN, "{00000000-0000-0000-0000-000000000000}")
    found = findings(toy, tmp_path, md=lambda t: wrong(drop_co_simulation(t)), suffix="me-token")
    assert [f["check"] for f in found] == ["probe-normal-run"], found
    assert found[0]["location"] == "probe fmi3-me-normal-run", found
    assert "fmi3InstantiateModelExchange" in found[0]["message"], found


# Clocks (FMI 3.0.2 section 2.4.7.4), broken in the Clocks fixture: (patch, fragment)
CLOCK_CASES = {
    "clocks-not-a-clock": (replace('valueReference="2001" causality="output" clocks="1001"',
                                   'valueReference="2001" causality="output" clocks="2002"'),
                           "clocks lists valueReference 2002, 'inClock2Ticks', a Int32 and "
                           "not a Clock"),
    "clocks-unknown": (replace('valueReference="2001" causality="output" clocks="1001"',
                               'valueReference="2001" causality="output" clocks="9999"'),
                       "clocks lists valueReference 9999, which is not a variable"),
    "clock-variability": (replace('valueReference="1002" causality="input"',
                                  'valueReference="1002" causality="input" variability="tunable"'),
                          "a Clock has variability discrete, not tunable"),
    "clocked-variability": (replace(
        'valueReference="2001" causality="output" clocks="1001"',
        'valueReference="2001" causality="output" variability="constant" start="0" '
        'clocks="1001"'),
        "a clocked variable has variability discrete or tunable, not constant"),
}


@pytest.mark.parametrize("case", CLOCK_CASES)
def test_a_broken_clock_rule_is_found(toy, case, tmp_path):
    md, fragment = CLOCK_CASES[case]
    found = findings(toy, tmp_path, "Clocks", md=md)
    hits = [f for f in found if f["check"] == "clocks" and fragment in f["message"]]
    assert hits, found
    assert hits[0]["clause"].startswith("FMI 3.0.2 §2.4.7.4"), hits


def test_an_fmu_the_probe_does_not_run_gets_a_note(toy):
    # Clocks offers Scheduled Execution only: its description and binary are checked, the probe
    # does not run it, and the report says so (a note: exit 0)
    [r] = validate_json(toy("Clocks", 3))
    assert r["findings"] == [], r
    assert [n["check"] for n in r["notes"]] == ["probe-not-run"], r
    assert "Scheduled Execution" in r["notes"][0]["message"], r
