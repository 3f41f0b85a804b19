# Shared helpers for the project scripts (sourced, not run).
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"
VENV="$REPO/.venv"
PY="$VENV/bin/python"

# Each line carries the minutes and seconds since the outermost script started (scripts/test's
# log then shows where CI's time goes).
export ACTUATOR_LOG_T0="${ACTUATOR_LOG_T0:-$(date +%s)}"
log() {
    local t=$(($(date +%s) - ACTUATOR_LOG_T0))
    printf '\033[1m==> [%d:%02d] %s\033[0m\n' $((t / 60)) $((t % 60)) "$*" >&2
}

# Create .venv with the pinned requirements unless it already matches them.
ensure_venv() {
    local stamp="$VENV/.requirements.sha"
    local want
    want="$(sha256sum tests/requirements.txt | cut -d' ' -f1)"
    if [[ -x "$PY" && -f "$stamp" && "$(cat "$stamp")" == "$want" ]]; then
        return 0
    fi
    log "creating Python venv in .venv (pinned: tests/requirements.txt)"
    command -v python3 >/dev/null || { echo "python3 is required" >&2; exit 2; }
    python3 -m venv "$VENV"
    "$PY" -m pip install --quiet --disable-pip-version-check -r tests/requirements.txt
    echo "$want" > "$stamp"
}

# What cross-building the shipped FMUs needs (see scripts/build): Rust targets, zig and
# cargo-zigbuild (PyPI, pinned), the mingw-w64 linker (Debian), and target/darwin-sdk with the
# macOS libSystem stubs of the ziglang package in the architecture names lld reads.
CROSS_TARGETS=(x86_64-unknown-linux-gnu aarch64-unknown-linux-gnu x86_64-pc-windows-gnu x86_64-apple-darwin aarch64-apple-darwin)
DARWIN_SDK="$REPO/target/darwin-sdk"
ensure_cross() {
    ensure_venv
    local installed missing=()
    installed="$(rustup target list --installed)"
    for t in "${CROSS_TARGETS[@]}"; do grep -qx "$t" <<< "$installed" || missing+=("$t"); done
    if ((${#missing[@]})); then log "rustup target add ${missing[*]}"; rustup target add "${missing[@]}"; fi
    if [[ ! -x "$VENV/bin/cargo-zigbuild" ]] || ! "$PY" -m ziglang version >/dev/null 2>&1; then
        log "pip install ziglang cargo-zigbuild"
        "$PY" -m pip install --quiet --disable-pip-version-check ziglang==0.17.1 cargo-zigbuild==0.24.1
    fi
    if ! command -v x86_64-w64-mingw32-gcc >/dev/null; then
        log "apt-get install gcc-mingw-w64-x86-64"
        apt_install gcc-mingw-w64-x86-64
    fi
    if [[ ! -f "$DARWIN_SDK/usr/lib/libSystem.tbd" ]]; then
        local zig
        zig="$("$PY" -c 'import ziglang, os; print(os.path.dirname(ziglang.__file__))')"
        mkdir -p "$DARWIN_SDK/usr/lib"
        # zig names its arm64 slice "arm64e.x1", which LLVM's TAPI reader does not know.
        sed -e 's/arm64e\.x1-macos/arm64-macos/g; s/arm64e\.x1-maccatalyst/arm64-maccatalyst/g' \
            "$zig/lib/libc/darwin/libSystem.tbd" > "$DARWIN_SDK/usr/lib/libSystem.tbd"
        ln -sf libSystem.tbd "$DARWIN_SDK/usr/lib/libc.tbd"
        ln -sf libSystem.tbd "$DARWIN_SDK/usr/lib/libm.tbd"
    fi
}

# Run a cargo command that links for macOS (first argument: x86_64 or aarch64) with rust-lld as
# ld64: it honours rustc's exported-symbols list, so the dylib exports the FMI functions only.
darwin_link() {
    local arch="$1" upper lld
    shift
    upper="$(tr 'a-z-' 'A-Z_' <<< "$arch")"
    lld="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/rust-lld"
    env "CARGO_TARGET_${upper}_APPLE_DARWIN_LINKER=$lld" SDKROOT="$DARWIN_SDK" "$@" \
        -C linker-flavor=ld64.lld
}

# Wine and the mingw-w64 C compiler, for the test that runs the win64 DLL.
ensure_wine() {
    command -v wine >/dev/null || { log "apt-get install wine wine64"; apt_install wine wine64; }
    command -v x86_64-w64-mingw32-gcc >/dev/null || apt_install gcc-mingw-w64-x86-64
}

# LLVM's binary tools (llvm-nm, llvm-objdump), which read the ELF, PE and Mach-O binaries the
# platform and determinism tests inspect.
ensure_llvm_tools() {
    command -v llvm-nm >/dev/null && command -v llvm-objdump >/dev/null || { log "apt-get install llvm"; apt_install llvm; }
}

# qemu-user and Debian's aarch64 glibc, for the test that runs the aarch64-linux FMI 3.0 binary.
ensure_qemu() {
    command -v qemu-aarch64 >/dev/null && [[ -f /usr/aarch64-linux-gnu/lib/ld-linux-aarch64.so.1 ]] || {
        log "apt-get install qemu-user libc6-arm64-cross"
        apt_install qemu-user libc6-arm64-cross
    }
}

# apt-get install, as root or through sudo.
apt_install() {
    local sudo=()
    [[ "$(id -u)" == 0 ]] || sudo=(sudo)
    "${sudo[@]}" apt-get install -y -q "$@" >/dev/null || {
        "${sudo[@]}" apt-get update -q >/dev/null && "${sudo[@]}" apt-get install -y -q "$@" >/dev/null
    }
}
