"""ARCHITECTURE.md stays true: every crate is on the map, dependencies point the one way the map
draws, every model crate follows the "Adding a model" checklist, and every path the map names
exists."""
import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "fmu-src"
ARCH = (ROOT / "ARCHITECTURE.md").read_text()
CRATES = sorted(p.parent.name for p in SRC.glob("*/Cargo.toml"))
MODELS = [c for c in CRATES if (SRC / c / "src" / "bin" / f"describe-{c}.rs").is_file()]

# What each kind of crate may use inside the workspace (the arrows of the map).
MAY_USE = {
    "fmi2-types": set(),
    "ode": set(),
    "packager": set(),
    "fmi2-export": {"fmi2-types"},
    "fmi3-export": {"fmi2-export"},
    "hydraulic-joint-fmi3": {"fmi3-export", "hydraulic-joint"},
    "twisted-string-fmi3": {"fmi3-export", "twisted-string"},
    "test-oscillator-fmi3": {"fmi3-export", "test-oscillator"},
    "emps-fmi3": {"fmi3-export", "emps"},
    "host": {"fmi2-types", "ode"},
    "gap": {"fmi2-types", "host"},
    "cli": {"fmi2-types", "host", "gap"},
    "bench": {"host"},
}
MODEL_MAY_USE = {"fmi2-export", "ode"}


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
    assert re.search(r"impl\s+(fmi2_export::)?Model\s+for\s+\w+", (src / "model.rs").read_text())
    assert "pub fn html() -> String" in (src / "docs.rs").read_text()
    assert "export_model!(" in (src / "lib.rs").read_text()
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
