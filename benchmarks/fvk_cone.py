"""Indented FvK cone: the onset of symmetry breaking on three symmetric meshes.

Runs ``demos/fvk_cone.py --h H`` (the disc of N = 16 identical sectors, ``meshes/polar_disc.geo``,
P3 cells) for each mesh size and collects the onset δ_c (the zero crossing of the lowest Hessian
eigenvalue along the symmetric path, by regula falsi), the final bracket, the number of unknowns
and the state after the push along the unstable mode (docs/fvk_experiments.md):

    python benchmarks/fvk_cone.py --h 0.15 0.1 0.07 --json benchmarks/results/fvk_cone.json

With ``--leave A --tau T`` each mesh also leaves the unstable symmetric state at the first
unstable indentation of the first pass (push by A × the deflection scale, relax from the first
pseudo-time step T, repeat until stable): the energy drop and the angular mode of the
non-symmetric state are in each run's ``after``. The penalty length is the demo's,
``facet_normal`` (|T|/|F|); ``--penalty-length diameter`` runs dgplate's general default, the
cell diameter, which leaves the dG bending energy indefinite on this mesh
(``benchmarks/dg_coercivity.py``; the results files without ``facet_normal`` in their name).
"""

from __future__ import annotations

import argparse
import itertools
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DEMO = Path(__file__).resolve().parents[1] / "demos" / "fvk_cone.py"


def run(h: float, folder: Path, extra: list[str]) -> dict:
    """One mesh: the demo's summary, its wall time and whether its checks passed."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, str(DEMO), "--h", str(h), "--out", str(folder), *extra],
        capture_output=True,
        text=True,
    )
    summary_file = folder / "summary.json"
    summary = json.loads(summary_file.read_text()) if summary_file.exists() else {"h": h}
    summary["seconds"] = time.perf_counter() - start
    summary["checks_passed"] = done.returncode == 0
    if done.returncode:
        summary["error"] = done.stdout[-2000:] + done.stderr[-2000:]
    return summary


def main() -> None:
    """Every mesh size in turn; the relative change of δ_c between consecutive meshes."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, nargs="+", default=[0.15, 0.1, 0.07])
    parser.add_argument("--json", default="")
    parser.add_argument("--leave", type=float, default=0.0, help="the demo's --leave (0: none)")
    parser.add_argument("--tau", type=float, default=1.0, help="the demo's --tau")
    parser.add_argument(
        "--penalty-length", default="facet_normal", help="the demo's --penalty-length"
    )
    parser.add_argument("--pictures", default="", help="copy each mesh's cone.png to DIR/h<h>.png")
    args = parser.parse_args()
    extra = ["--leave", str(args.leave), "--tau", str(args.tau)] if args.leave else []
    extra += ["--penalty-length", args.penalty_length]
    runs: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        for h in args.h:
            runs.append(run(h, Path(tmp) / f"h{h}", extra))
            if args.pictures and (Path(tmp) / f"h{h}" / "cone.png").exists():
                Path(args.pictures).mkdir(parents=True, exist_ok=True)
                shutil.copy(Path(tmp) / f"h{h}" / "cone.png", Path(args.pictures) / f"h{h}.png")
            onset = runs[-1].get("onset_indentation")
            print(f"h = {h}: δ_c = {onset}  {runs[-1]['seconds']:.0f} s", flush=True)
            onsets = [r.get("onset_indentation") for r in runs]
            changes = [
                None if a is None or b is None else (b - a) / a
                for a, b in itertools.pairwise(onsets)
            ]
            if args.json:
                result = {"runs": runs, "onset_changes": changes}
                Path(args.json).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
