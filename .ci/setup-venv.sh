#!/usr/bin/env bash
# Create .venv for dgplate, idempotently.
#  - A system DOLFINx >= 0.9 (Debian 13, conda) is reused through a --system-site-packages venv.
#  - Otherwise a Python >= 3.12 (python3.12 on PATH, else ~/.pyenv/versions/3.12*/bin/python)
#    gets the PyPI wheel dolfinx-solver-real (extra "wheel").
# The stamp records the pyproject.toml hash and the route, so a rerun does nothing.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=.venv
STAMP="$VENV/.dgplate-stamp"

system_dolfinx_ok() {
    command -v python3 >/dev/null 2>&1 || return 1
    python3 - <<'PY' >/dev/null 2>&1
from mpi4py import MPI  # noqa: F401
import dolfinx
major, minor = (int(p) for p in dolfinx.__version__.split(".")[:2])
raise SystemExit(0 if (major, minor) >= (0, 9) else 1)
PY
}

find_python312() {
    local candidate
    for candidate in python3.14 python3.13 python3.12; do
        if command -v "$candidate" >/dev/null 2>&1 && "$candidate" -c 'import venv' 2>/dev/null; then
            command -v "$candidate"; return 0
        fi
    done
    for candidate in "$HOME"/.pyenv/versions/3.1[2-9]*/bin/python; do
        if [ -x "$candidate" ]; then echo "$candidate"; return 0; fi
    done
    return 1
}

if system_dolfinx_ok; then
    route="system:$(python3 -c 'import dolfinx; print(dolfinx.__version__)')"
    python=python3; venv_flags=(--system-site-packages); extras="test,lint"
else
    if ! python=$(find_python312); then
        echo "setup: no Python >= 3.12 found and no system DOLFINx >= 0.9." >&2
        echo "setup: install python3.12 (e.g. 'pyenv install 3.12') or Debian 13's python3-dolfinx." >&2
        exit 1
    fi
    route="wheel:$("$python" -c 'import sys; print(sys.version.split()[0])')"
    venv_flags=(); extras="wheel,test,lint"
fi

want="$(sha256sum pyproject.toml | cut -c1-16) $route"
if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ] && [ -x "$VENV/bin/python" ]; then
    exit 0
fi
echo "setup: creating $VENV ($route)"
"$python" -m venv "${venv_flags[@]}" "$VENV"
"$VENV/bin/python" -m pip install --quiet --upgrade pip
"$VENV/bin/python" -m pip install --quiet -e ".[$extras]"
"$VENV/bin/python" - <<'PY'
from mpi4py import MPI  # noqa: F401
import dolfinx
print(f"setup: dolfinx {dolfinx.__version__} ready")
PY
echo "$want" > "$STAMP"
