"""Write the licences of everything compiled into an FMU's binaries into a directory (the FMU's
documentation/licenses/): every crate the library of CRATE built with FEATURES links (normal
dependencies, not build-time proc-macros), each as <name>-<version>.txt with its SPDX
expression, repository and the licence files the crate ships, plus the Rust standard library's
licence texts and an index.

usage: python scripts/licenses.py CRATE OUT_DIR [FEATURES]    (run from the repository root)
e.g.   python scripts/licenses.py fmu-binary OUT hydraulic-joint,fmi3
Deterministic: the same Cargo.lock gives the same files."""
import json
import subprocess
import sys
from pathlib import Path

LICENSE_NAMES = ("LICENSE", "LICENCE", "COPYING", "COPYRIGHT", "UNLICENSE", "NOTICE")


def linked_packages(crate, features):
    qualified = ",".join(f"{crate}/{f}" for f in features.split(",") if f)
    meta = json.loads(subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--locked",
         "--filter-platform", "x86_64-unknown-linux-gnu"]
        + (["--features", qualified] if qualified else []),
        check=True, capture_output=True, text=True).stdout)
    packages = {p["id"]: p for p in meta["packages"]}
    nodes = {n["id"]: n for n in meta["resolve"]["nodes"]}
    (root,) = [p["id"] for p in meta["packages"] if p["name"] == crate]
    seen, stack = set(), [root]
    while stack:
        pid = stack.pop()
        if pid in seen:
            continue
        kinds = {k for t in packages[pid]["targets"] for k in t["kind"]}
        if "proc-macro" in kinds:  # runs in the compiler, not linked into the binary
            continue
        seen.add(pid)
        for dep in nodes[pid]["deps"]:
            if any(k["kind"] is None for k in dep["dep_kinds"]):
                stack.append(dep["pkg"])
    members = set(meta["workspace_members"])
    return sorted((packages[p] for p in seen), key=lambda p: (p["name"], p["version"])), members


def licence_files(package):
    root = Path(package["manifest_path"]).parent
    return sorted(f for f in root.iterdir()
                  if f.is_file() and f.name.upper().startswith(LICENSE_NAMES))


def main(crate, out, features=""):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    packages, members = linked_packages(crate, features)
    built = f"{crate} with {features}" if features else crate
    index = [f"Licences of the software compiled into the binaries of this FMU ({built}).", ""]
    repo_licence = Path("LICENSE")
    for p in packages:
        name = f"{p['name']}-{p['version']}.txt"
        expr = p.get("license") or "(no SPDX expression given)"
        files = [repo_licence] if p["id"] in members else licence_files(p)
        text = [f"{p['name']} {p['version']}", f"License: {expr}"]
        if p.get("repository"):
            text.append(f"Repository: {p['repository']}")
        for f in files:
            text += ["", f"===== {f.name} =====", f.read_text(errors="replace").rstrip()]
        if not files:
            text += ["", "The crate ships no licence file; its licence is the SPDX expression above."]
        (out / name).write_text("\n".join(text) + "\n")
        index.append(f"{name}: {expr}")
    sysroot = subprocess.run(["rustc", "--print", "sysroot"], check=True, capture_output=True,
                             text=True).stdout.strip()
    std = Path(sysroot) / "share" / "doc" / "rust" / "licenses"
    parts = ["Rust standard library (std, core, alloc), linked statically: MIT OR Apache-2.0"]
    for f in ("MIT.txt", "Apache-2.0.txt"):
        if (std / f).is_file():
            parts += ["", f"===== {f} =====", (std / f).read_text().rstrip()]
    (out / "rust-std.txt").write_text("\n".join(parts) + "\n")
    index.append("rust-std.txt: MIT OR Apache-2.0")
    (out / "README.txt").write_text("\n".join(index) + "\n")


if __name__ == "__main__":
    main(*sys.argv[1:])
