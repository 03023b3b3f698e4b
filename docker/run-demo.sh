#!/usr/bin/env bash
# Default command of the Docker image: run the main demo on 2 MPI ranks (NPROCS overrides).
# demos/box_folding.py is the main demo; fall back to demos/biharmonic.py while it does not exist.
# Extra arguments are passed on to the demo script.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
demo=demos/box_folding.py
[[ -f $demo ]] || demo=demos/biharmonic.py
[[ -f $demo ]] || { echo "run-demo: no demo found in $PWD/demos" >&2; exit 1; }
cmd=(mpirun -n "${NPROCS:-2}" python3 "$demo" "$@")
# Debian's VTK renders through GLX only: without a display, give pyvista a virtual one (Xvfb;
# -noreset, see dgplate.io.images.start_xvfb).
if [[ -z ${DISPLAY:-} ]] && command -v xvfb-run >/dev/null; then
  cmd=(xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" "${cmd[@]}")
fi
exec "${cmd[@]}"
