# Shared helpers for the project scripts (sourced, not run).
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"
VENV="$REPO/.venv"
PY="$VENV/bin/python"

log() { printf '\033[1m==> %s\033[0m\n' "$*" >&2; }

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
