"""`actuator-fmu validate` on FMI 3.0 and Model Exchange FMUs built to break one rule each.

The FMU is BouncingBall3 (tests/fixtures/bouncing-ball-fmi3/bouncing_ball.c: Model Exchange and
Co-Simulation, a state event, directional derivatives, FMU state), compiled here once per
defect with a -D switch (tests/bouncing_ball3.py). The conforming build has no finding and no
note; each defect gives the finding of the rule it breaks, at its probe step, citing its FMI
3.0.2 clause. The expected findings follow from the standard's text and the defect's
construction (e.g. d der(h) / d v = 1 for der(h) = v, so a directional derivative of 2 is wrong),
not from the validator's output. Rules of modelDescription.xml alone are broken by a patch of
the built FMU's description (tests/test_validate_fmi3.py breaks the others on the fixtures).
"""
import json
import subprocess
import sys
import zipfile

import pytest

from bouncing_ball3 import build
from conftest import cli_path

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="builds an x86_64-linux binary")

DEFECTS = ["NAN_DERIVATIVES", "ENDLESS_EVENT_ITERATION", "CRASH_DERIVATIVES",
           "HANG_DERIVATIVES", "CRASH_DO_STEP",
           "HANG_DO_STEP", "LENIENT", "SILENT", "WRONG_DIRECTIONAL", "NO_RESTORE",
           "BAD_SERIALIZE", "NO_VALUES_CHANGED", "NO_SET_TIME", "RESET_FAILS"]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """label -> the FMU built with that defect ("conforming": none)."""
    d = tmp_path_factory.mktemp("bouncing-ball3")
    fmus = {"conforming": build(d, "conforming")}
    for defect in DEFECTS:
        fmus[defect] = build(d, defect, defect)
    # a time event at t = 0.1 s that drops the ball again: conforming, and with the flag wrong
    fmus["TIME_EVENT"] = build(d, "TIME_EVENT", "TIME_EVENT")
    fmus["TIME_EVENT_NO_VALUES_CHANGED"] = build(d, "TIME_EVENT_NO_VALUES_CHANGED", "TIME_EVENT",
                                                 "NO_VALUES_CHANGED")
    return fmus


def report(fmu, *options):
    res = subprocess.run([cli_path(), "validate", "--json", *options, str(fmu)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode in (0, 1), (res.returncode, res.stderr)
    [r] = json.loads(res.stdout)
    assert (res.returncode == 1) == bool(r["findings"]), r
    for f in r["findings"] + r["notes"]:
        assert f["clause"].startswith("FMI 3.0.2 §"), f
    return r


def test_the_conforming_build_has_no_finding_and_no_note(built):
    r = report(built["conforming"])
    assert r["findings"] == [] and r["notes"] == [], r


# defect -> (check, probe step, fragment of the message, fragment of the clause)
RUNTIME = {
    # der(v) NaN: the normal Model Exchange run reads non-finite derivatives
    "NAN_DERIVATIVES": ("probe-normal-run", "fmi3-me-normal-run", "derivative 1 is NaN", "§3.2"),
    # fmi3UpdateDiscreteStates never ends the event iteration
    "ENDLESS_EVENT_ITERATION": ("probe-normal-run", "fmi3-me-normal-run",
                                "still needs iterations after 1000 calls", "§3.2"),
    # a crash in fmi3GetContinuousStateDerivatives: every call must return a status
    "CRASH_DERIVATIVES": ("probe-crash", "fmi3-me-normal-run", "SIGSEGV", "§2.2.4"),
    "HANG_DERIVATIVES": ("probe-timeout", "fmi3-me-normal-run", "did not return within 2 s",
                         "§2.2.4"),
    "CRASH_DO_STEP": ("probe-crash", "fmi3-normal-run", "SIGSEGV", "§2.2.4"),
    "HANG_DO_STEP": ("probe-timeout", "fmi3-normal-run", "did not return within 2 s", "§2.2.4"),
    # d der(h) / d v is 1 (der(h) = v); the FMU says 2
    "WRONG_DIRECTIONAL": ("probe-directional-derivative", "fmi3-me-directional-derivatives",
                          "d der(x0) / d x1", "§2.2.12.1"),
    # the bounce re-initializes v and h but reports valuesOfContinuousStatesChanged = false
    "NO_VALUES_CHANGED": ("probe-event", "fmi3-me-state-event",
                          "valuesOfContinuousStatesChanged = false", "§2.3.5"),
}


@pytest.mark.parametrize("defect", RUNTIME)
def test_a_runtime_rule_broken_in_the_binary_is_found(built, defect):
    check, step, fragment, clause = RUNTIME[defect]
    r = report(built[defect], "--timeout", "2")
    assert [(f["check"], f["location"]) for f in r["findings"]] == [(check, f"probe {step}")], r
    assert fragment in r["findings"][0]["message"], r
    assert clause in r["findings"][0]["clause"], r


def test_states_re_initialized_at_a_time_event_must_be_signalled(built):
    # nextEventTime = 0.1 s: the probe steps onto it, and h := 1 there must come with
    # valuesOfContinuousStatesChanged = true (FMI 3.0.2 section 2.3.5)
    r = report(built["TIME_EVENT"])
    assert r["findings"] == [] and r["notes"] == [], r
    r = report(built["TIME_EVENT_NO_VALUES_CHANGED"])
    assert [(f["check"], f["location"]) for f in r["findings"]] == [
        ("probe-event", "probe fmi3-me-state-event")], r
    assert "at the time or step event at t = 0.1," in r["findings"][0]["message"], r


def test_reset_failing_after_terminate_is_a_note(built):
    # FMI 3.0.2 section 2.2.4: any call may return fmi3Error ("The call failed"); section 2.3.1
    # describes what fmi3Reset does without requiring it to succeed
    r = report(built["RESET_FAILS"])
    assert r["findings"] == [], r
    [n] = [n for n in r["notes"] if n["check"] == "probe-reset"]
    assert n["location"] == "probe fmi3-normal-run", n
    assert "fmi3Reset after fmi3Terminate" in n["message"] and "§2.2.4" in n["clause"], n


def test_a_directional_derivative_is_compared_with_finite_differences(built):
    [f] = report(built["WRONG_DIRECTIONAL"])["findings"]
    # the FMU's 2 against the central difference of der(h) = v: exactly 1
    assert "is 2 from the directional derivative but 1.000000e0 from central" in f["message"], f


def test_a_state_not_restored_is_found_for_both_interfaces(built):
    r = report(built["NO_RESTORE"])
    assert [(f["check"], f["location"]) for f in r["findings"]] == [
        ("probe-fmu-state", "probe fmi3-fmu-state"),
        ("probe-fmu-state", "probe fmi3-me-fmu-state")], r
    assert all("§2.2.7.4" in f["clause"] for f in r["findings"]), r


def test_a_deserialized_state_not_restoring_is_found_for_both_interfaces(built):
    # canSerializeFMUState: the state serialized and deserialized restores as the saved one
    r = report(built["BAD_SERIALIZE"])
    assert [(f["check"], f["location"]) for f in r["findings"]] == [
        ("probe-fmu-state", "probe fmi3-fmu-state"),
        ("probe-fmu-state", "probe fmi3-me-fmu-state")], r
    assert all("fmi3DeserializeFMUState" in f["message"] for f in r["findings"]), r


def test_calls_in_the_wrong_state_answered_ok_are_notes(built):
    # FMI 3.0.2 section 2.3: the importer must not make these calls; the FMU's answer is its own
    r = report(built["LENIENT"])
    assert r["findings"] == [], r
    assert [n["location"] for n in r["notes"]] == [
        "probe fmi3-do-step-before-init", "probe fmi3-negative-step",
        "probe fmi3-do-step-after-terminate", "probe fmi3-wrong-communication-point",
        "probe fmi3-unknown-value-reference", "probe fmi3-fixed-parameter-after-init",
        "probe fmi3-me-derivatives-before-init", "probe fmi3-me-set-states-in-event-mode"], r
    assert all(n["check"] == "probe-wrong-call" and "returned fmi3OK" in n["message"]
               for n in r["notes"]), r


def test_an_error_without_a_logged_message_is_no_note(built):
    # The host instantiates with loggingOn = fmi3False, with which the FMU must not call the
    # logger (FMI 3.0.2 section 2.3.1): silence is conforming.
    r = report(built["SILENT"])
    assert r["findings"] == [] and r["notes"] == [], r


def test_a_model_exchange_function_not_exported_is_found(built):
    r = report(built["NO_SET_TIME"])
    symbols = [f for f in r["findings"] if f["check"] == "symbols"]
    assert len(symbols) == 1 and "fmi3SetTime" in symbols[0]["message"], r
    assert symbols[0]["location"] == "binaries/x86_64-linux/BouncingBall3.so", r
    # the Model Exchange probe cannot open it either, and says so; Co-Simulation still runs
    assert {f["check"] for f in r["findings"]} == {"symbols", "binary"}, r


def patched(fmu, tmp_path, old, new):
    """A copy of `fmu` with `old` replaced by `new` in its modelDescription.xml."""
    dst = tmp_path / "patched.fmu"
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            if info.filename == "modelDescription.xml":
                text = data.decode()
                assert old in text, old
                data = text.replace(old, new, 1).encode()
            zout.writestr(info.filename, data)
    return dst


# XML rules the fixture tests do not break: (old, new, check, message fragment, clause fragment)
DESCRIPTION = {
    "fmi-version": ('fmiVersion="3.0"', 'fmiVersion="3"', "fmi-version",
                    'fmiVersion is "3"', "§2.4.1"),
    "model-name": ('modelName="BouncingBall3"', 'modelName=" "', "model-name",
                   "modelName is missing or empty", "§2.4.1"),
    "model-identifier": ('<CoSimulation\n    modelIdentifier="BouncingBall3"',
                         '<CoSimulation\n    modelIdentifier="Bouncing Ball3"',
                         "model-identifier", "not a valid C identifier", "§2.4.1"),
    "unique-units": ('<Unit name="m/s2">', '<Unit name="m/s">', "unique-units",
                     "unit 'm/s' is already defined", "§2.4.3"),
    "variability-type": ('<Float64 name="g"', '<Int32 name="n" valueReference="7" '
                         'causality="local" variability="continuous"/>\n    <Float64 name="g"',
                         "variability-type", "a Int32 variable cannot be continuous", "§2.4.7"),
    "variable-name": ('name="e"', 'name=""', "variable-name", "empty variable name", "§2.4.7"),
    "unique-types": ('<LogCategories>', '<TypeDefinitions><Float64Type name="Height"/>'
                     '<Float64Type name="Height"/></TypeDefinitions>\n  <LogCategories>',
                     "unique-types", "type 'Height' is already defined", "§2.4.4"),
    # display units (FMI 3.0.2 section 2.4.3): names unique per unit, inverse only with offset 0,
    # a displayUnit names a <DisplayUnit> of the variable's unit, which must be given
    "display-unit-twice": ('<DisplayUnit name="cm" factor="100"/>',
                           '<DisplayUnit name="cm" factor="100"/><DisplayUnit name="cm"/>',
                           "display-unit", "display unit 'cm' of unit 'm' is already defined",
                           "§2.4.3"),
    "display-unit-inverse-offset": ('<DisplayUnit name="s/m" inverse="true"/>',
                                    '<DisplayUnit name="s/m" inverse="true" offset="1"/>',
                                    "display-unit", "inverse is only allowed with offset 0",
                                    "§2.4.3"),
    "display-unit-of-another-unit": ('displayUnit="cm"', 'displayUnit="km/h"',
                                     "display-unit-declared",
                                     "displayUnit 'km/h' is not a <DisplayUnit> of unit 'm'",
                                     "§2.4.7.5"),
    "display-unit-without-unit": ('name="e" valueReference="6"',
                                  'name="e" valueReference="6" displayUnit="cm"',
                                  "display-unit-declared", "given without a unit", "§2.4.7.5"),
}


def test_an_fmu_without_an_interface_is_found(built, tmp_path):
    text = zipfile.ZipFile(built["conforming"]).read("modelDescription.xml").decode()
    start, end = text.index("  <ModelExchange"), text.index("  <UnitDefinitions>")
    r = report(patched(built["conforming"], tmp_path, text[start:end], ""))
    assert [f["check"] for f in r["findings"]] == ["interfaces"], r
    assert "no <ModelExchange>, <CoSimulation> or <ScheduledExecution>" in \
        r["findings"][0]["message"], r


@pytest.mark.parametrize("case", DESCRIPTION)
def test_a_description_rule_broken_on_the_built_fmu_is_found(built, tmp_path, case):
    old, new, check, fragment, clause = DESCRIPTION[case]
    r = report(patched(built["conforming"], tmp_path, old, new))
    hits = [f for f in r["findings"] if f["check"] == check and fragment in f["message"]]
    assert hits, r
    assert clause in hits[0]["clause"], hits
