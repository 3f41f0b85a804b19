"""ARCHITECTURE.md stays true: every crate is on the map, dependencies point the one way the map
draws (one version-neutral core, the FMI 2.0 and FMI 3.0 layers as siblings over it, model crates
that know no FMI version, one binary crate and no per-model wrapper), every model crate follows
the "Adding a model" checklist, and every path the map names exists."""
import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "fmu-src"
ARCH = (ROOT / "ARCHITECTURE.md").read_text()
CRATES = sorted(p.parent.name for p in SRC.glob("*/Cargo.toml"))
BINARY = tomllib.loads((SRC / "fmu-binary" / "Cargo.toml").read_text())
VERSION_LAYERS = {"fmi2": "fmi2-export", "fmi3": "fmi3-export"}
# The models are what fmu-binary's features pick besides the FMI version and `model`, the
# internal feature every model feature sets.
MODELS = sorted(f for f in BINARY["features"] if f not in VERSION_LAYERS and f != "model")

# What each kind of crate may use inside the workspace (the arrows of the map).
MAY_USE = {
    "fmi-types": set(),
    "effects": {"fmi-types"},
    "ode": set(),
    "packager": set(),
    "table-macros": set(),
    "fmu-core": {"fmi-types", "effects", "table-macros"},
    "fmi2-export": {"fmu-core", "fmi-types"},
    "fmi3-export": {"fmu-core", "fmi-types"},
    "fmu-binary": {"fmu-core", "fmi2-export", "fmi3-export", *MODELS},
    "host": {"fmi-types", "effects", "ode"},
    "gap": {"fmi-types", "effects", "host"},
    "validate": {"fmi-types", "effects", "host"},
    "cli": {"fmi-types", "host", "gap", "validate"},
    "bench": {"host"},
}
MODEL_MAY_USE = {"fmu-core", "ode"}


def workspace_deps(crate):
    manifest = tomllib.loads((SRC / crate / "Cargo.toml").read_text())
    names = set()
    for table in ("dependencies", "build-dependencies"):
        names |= set(manifest.get(table, {}))
    return names & set(CRATES)


def test_every_crate_is_on_the_map():
    for c in CRATES:
        assert f"| `{c}` |" in ARCH, f"{c} is missing from the crate table of ARCHITECTURE.md"


@pytest.mark.parametrize("crate", CRATES)
def test_dependencies_point_one_way(crate):
    allowed = MODEL_MAY_USE if crate in MODELS else MAY_USE.get(crate)
    assert allowed is not None, f"{crate}: add it to ARCHITECTURE.md and to MAY_USE here"
    extra = workspace_deps(crate) - allowed
    assert not extra, f"{crate} uses {sorted(extra)}, against the direction in ARCHITECTURE.md"


def test_the_shipped_models_and_the_test_model_are_crates():
    assert {"hydraulic-joint", "twisted-string", "test-oscillator"} <= set(MODELS)


@pytest.mark.parametrize("crate", MODELS)
def test_model_follows_the_checklist(crate):
    src = SRC / crate / "src"
    assert "declare_variables!" in (src / "vars.rs").read_text()
    assert re.search(r"impl\s+(fmu_core::)?Model\s+for\s+\w+", (src / "model.rs").read_text())
    assert "pub fn html() -> String" in (src / "docs.rs").read_text()
    assert "table_problems::<" in (src / "lib.rs").read_text()
    assert BINARY["features"][crate] == [f"dep:{crate}", "model"]
    build = (ROOT / "scripts" / "build").read_text()
    m = re.search(rf'"{crate}:(\w+):(dist|target/fmus)"', build)
    assert m, f"{crate} is not in MODELS of scripts/build"
    ident, dest = m.groups()
    if dest == "dist":
        assert (ROOT / "modelDescription" / f"{ident}.xml").is_file()
        assert ident in (ROOT / "scripts" / "update-model-descriptions").read_text()
        assert (ROOT / "tests" / f"test_{crate.replace('-', '_')}.py").is_file()


def test_the_models_have_the_same_files():
    """The same modules in every actuator crate; `me.rs` (the Model Exchange side) in exactly
    those whose model offers Model Exchange."""
    files = {c: sorted(p.name for p in (SRC / c / "src").glob("*.rs") if p.name != "me.rs")
             for c in MODELS}
    actuators = [c for c in MODELS if c != "test-oscillator"]
    assert len({tuple(files[c]) for c in actuators}) == 1, files
    for c in actuators:
        offers = "fn model_exchange()" in (SRC / c / "src" / "model.rs").read_text()
        assert (SRC / c / "src" / "me.rs").is_file() == offers, c


def test_every_path_on_the_map_exists():
    for path in re.findall(r"`((?:fmu-src|tests|scripts)/[\w./-]+)`", ARCH):
        if "<" in path or "*" in path:
            continue
        assert (ROOT / path).exists(), f"ARCHITECTURE.md names {path}, which does not exist"


def test_one_core_under_two_sibling_layers():
    """Both FMI layers stand on the one core and never on each other."""
    for layer in VERSION_LAYERS.values():
        assert "fmu-core" in workspace_deps(layer), layer
    assert "fmi3-export" not in workspace_deps("fmi2-export")
    assert "fmi2-export" not in workspace_deps("fmi3-export")
    assert [c for c in CRATES if "core" in c] == ["fmu-core"]


@pytest.mark.parametrize("crate", MODELS)
def test_model_crates_know_no_fmi_version(crate):
    """A model is a plain library: no FMI layer, no version feature, no C exports, no binaries."""
    manifest = tomllib.loads((SRC / crate / "Cargo.toml").read_text())
    assert not set(VERSION_LAYERS.values()) & workspace_deps(crate)
    assert "features" not in manifest, f"{crate} has features {manifest.get('features')}"
    assert "cdylib" not in manifest.get("lib", {}).get("crate-type", [])
    assert not (SRC / crate / "src" / "bin").exists()
    for f in (SRC / crate / "src").glob("*.rs"):
        text = f.read_text()
        assert "export_model!" not in text and "export_fmi3!" not in text, f


def test_no_per_model_wrapper_crates():
    """Only fmu-binary links a model into an FMU binary, for either version."""
    assert not [c for c in CRATES if c.endswith(("-fmi2", "-fmi3"))]
    for c in CRATES:
        if c != "fmu-binary":
            assert not set(MODELS) & workspace_deps(c), c
