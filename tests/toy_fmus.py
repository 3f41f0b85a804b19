"""Builds the toy FMUs of tests/fixtures/toy-fmus/ (plain C models with our own FMI 2.0 and
FMI 3.0 frames, and hand-written descriptions) with gcc into a directory.

`build(directory, name, version)` compiles `<source>.c` (with -DFMI3 for FMI 3.0) into
binaries/<platform>/<name>.so and zips it with `<name>.fmi<version>.xml` as
modelDescription.xml (and the model's resources; for FMI 3.0 also its sources with a
buildDescription.xml) into directory/<name>.fmu, or directory/<name>-fmi3.fmu for FMI 3.0.
tests/conftest.py's session fixture `toy` builds each one once per session.
"""
import os
import shutil
import subprocess
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

SOURCE = REPO / "tests" / "fixtures" / "toy-fmus"
MODELS = {  # name -> (C source, {FMI version: flags}, resources)
    "Dahlquist": ("dahlquist.c", {2: [], 3: []}, {}),
    "VanDerPol": ("van_der_pol.c", {2: [], 3: []}, {}),
    "BouncingBall": ("bouncing_ball.c", {2: []}, {}),
    "Stair": ("stair.c", {2: [], 3: []}, {}),
    "Resource": ("resource.c", {2: [], 3: []}, {"resources/y.txt": "y.txt"}),
    "Feedthrough": ("feedthrough.c", {2: []}, {}),
    "StateSpace": ("state_space.c", {3: []}, {}),
    "Clocks": ("clocks.c", {3: []}, {}),
    "Alias": ("alias.c", {2: [], 3: []}, {}),
    "Sampler": ("sampler.c", {3: []}, {}),
    "Ticker": ("ticker.c", {3: []}, {}),
    "Trigger": ("sampler.c", {3: ["-DTRIGGERED"]}, {}),
    "Relay": ("relay.c", {2: []}, {}),
    # variants: another build of a model above, with its description (XML_OF) renamed
    "BouncingBallTwoPass": ("bouncing_ball.c", {2: ["-DTWO_PASS_EVENTS"]}, {}),
    "CrashInFree": ("dahlquist.c", {2: ["-DABORT_IN_FREE"]}, {}),
    "TickerNoStepMode": ("ticker.c", {3: ["-DNO_ENTER_STEP_MODE"]}, {}),
    "ForeignLogEnv": ("dahlquist.c", {2: ["-DFOREIGN_LOG_ENV"], 3: ["-DFOREIGN_LOG_ENV"]}, {}),
    "Dahlquist-c": ("dahlquist.c", {2: [], 3: []}, {}),
}
# variant -> the model whose modelDescription.xml it uses (modelIdentifier renamed)
XML_OF = {"BouncingBallTwoPass": "BouncingBall", "CrashInFree": "Dahlquist",
          "TickerNoStepMode": "Ticker", "ForeignLogEnv": "Dahlquist", "Dahlquist-c": "Dahlquist"}
PLATFORM = {2: "linux64", 3: "x86_64-linux"}


def fmi3_header_check():
    """-DFMI3_HEADERS and FMPy's copy of the FMI 3.0 headers when FMPy is installed: the
    compiler then checks every exported signature against the standard's."""
    try:
        import fmpy
    except ImportError:
        return []
    return ["-DFMI3_HEADERS", "-I", os.path.join(os.path.dirname(fmpy.__file__), "c-code")]


def build(directory, name, version=2):
    """directory/<name>.fmu (FMI 2.0) or directory/<name>-fmi3.fmu, built from the sources."""
    if shutil.which("gcc") is None:
        raise RuntimeError("gcc is needed to build the toy FMUs")
    source, flags, resources = MODELS[name]
    if version not in flags:
        raise ValueError(f"{name} has no FMI {version}.0 build")
    if version == 3:
        flags = {3: ["-DFMI3", *flags[3], *fmi3_header_check()]}
    stem = name if version == 2 else f"{name}-fmi{version}"
    lib = directory / f"{stem}.so"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-O2",
                    *flags[version], "-o", str(lib),
                    str(SOURCE / source), "-lm"], check=True)
    fmu = directory / f"{stem}.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        # directory entries too, as FMU packers write them: a copy without the library keeps
        # its platform directory
        folders = ["binaries/", f"binaries/{PLATFORM[version]}/"]
        folders += ["resources/"] * bool(resources) + ["sources/"] * (version == 3)
        for folder in folders:
            z.writestr(folder, b"")
        base = XML_OF.get(name, name)
        md = (SOURCE / f"{base}.fmi{version}.xml").read_text()
        md = md.replace(f'modelIdentifier="{base}"', f'modelIdentifier="{name}"')
        z.writestr("modelDescription.xml", md)
        z.write(lib, f"binaries/{PLATFORM[version]}/{name}.so")
        for entry, file in resources.items():
            z.write(SOURCE / file, entry)
        if version == 3:  # FMI 3.0.2 section 2.5.1: the sources and how to build them
            for file in (source, "model.h", "fmi3_frame.h"):
                z.write(SOURCE / file, f"sources/{file}")
            z.writestr("sources/buildDescription.xml", BUILD_DESCRIPTION.format(name, source))
    return fmu


BUILD_DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiBuildDescription fmiVersion="3.0">
  <BuildConfiguration modelIdentifier="{0}">
    <SourceFileSet language="C99">
      <SourceFile name="{1}"/>
      <PreprocessorDefinition name="FMI3"/>
    </SourceFileSet>
    <Library name="m"/>
  </BuildConfiguration>
</fmiBuildDescription>
"""
