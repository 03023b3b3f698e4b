"""Two costs per call that dgplate avoids, each against the call it replaces, in one process.

- **A form built again** (``dolfinx.fem.form`` of a form this process has built before): FFCx
  lists its JIT cache folder and imports the module again for each build;
  :func:`dgplate.compat.load_each_compiled_module_once` keeps the loaded module. The form is
  the bilayer's Hessian on 8 × 4 Q2 cells, a new UFL form each time (its signature computed
  again, as for a new level or step), built ``--builds`` times each way; the cache folder's
  file count is in the JSON (the listing grows with it).
- **Newton's lifting** of the Dirichlet data g, J(g − u), where u holds g exactly (it is
  zero; :class:`dgplate.solvers.snes.NewtonSolver` skips it): ``fvk_square.toml`` by
  ``dgplate.run``, with the skip and with a lifting at every residual, alternately; the
  energies are compared bit for bit.

    python benchmarks/form_reuse.py [--builds 20] [--json …]
    python benchmarks/form_reuse.py --table-only

The table of docs/performance.md between ``<!-- form_reuse:begin -->`` and
``<!-- form_reuse:end -->`` is generated from the JSON.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.jit
import ffcx.codegeneration.jit as ffcx_jit
import ufl
from pages import add_page_options, publish

import dgplate
from dgplate.compat import Function
from dgplate.mesh.tagged import rectangle
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.solvers import snes

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "form_reuse.json"
PAGE = ROOT / "docs" / "performance.md"
MARKERS = ("<!-- form_reuse:begin -->", "<!-- form_reuse:end -->")
QUIET = {"output.png": False, "output.vtx": False, "output.progress": 0}


def hessian_builds(builds: int) -> dict[str, Any]:
    """Seconds per ``dolfinx.fem.form`` of the bilayer's Hessian, with and without the memo."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [2, 1]], [8, 4])
    space = dolfinx.fem.functionspace(tagged.mesh, ("DG", 2, (3,)))
    y: Function = dolfinx.fem.Function(space)
    energy = build_bilayer(BilayerSpec(Z=1.0, clamped=["left"]), tagged).energy(y).total
    hessian = ufl.derivative(ufl.derivative(energy, y), y)
    for _ in range(2):  # compiled (a cold cache), loaded and kept: outside the timing
        dolfinx.fem.form(hessian)
    memo: Any = ffcx_jit.get_cached_module  # compat's memo; __wrapped__ is FFCx's own
    seconds = {}
    for name, loader in (("memo", memo), ("ffcx", memo.__wrapped__)):
        ffcx_jit.get_cached_module = loader
        try:
            start = time.perf_counter()
            for _ in range(builds):
                dolfinx.fem.form(ufl.derivative(ufl.derivative(energy, y), y))
            seconds[name] = (time.perf_counter() - start) / builds
        finally:
            ffcx_jit.get_cached_module = memo
    cache = Path(dolfinx.jit.get_options()["cache_dir"])
    files = sum(1 for _ in cache.iterdir()) if cache.is_dir() else 0
    return {"builds": builds, "cache_files": files, "seconds": seconds}


def newton_lifting(repeats: int) -> dict[str, Any]:
    """``fvk_square.toml`` with the lifting skipped where u holds g, and at every residual.

    The two alternate, ``repeats`` times each after an untimed run (the forms' first load);
    each keeps its fastest run.
    """
    problem = dgplate.load_problem(ROOT / "demos" / "problems" / "fvk_square.toml", QUIET)
    skip = snes.NewtonSolver._holds_dirichlet_data
    checks = {"skipped": skip, "every residual": lambda self, x: False}
    runs: dict[str, dict[str, Any]] = {name: {"seconds": [], "energy": []} for name in checks}
    with tempfile.TemporaryDirectory() as out:
        dgplate.run(problem, out=Path(out) / "warm")
        for k in range(repeats):
            for name, check in checks.items():
                snes.NewtonSolver._holds_dirichlet_data = check  # type: ignore[method-assign]
                try:
                    start = time.perf_counter()
                    result = dgplate.run(problem, out=Path(out) / f"{k}")
                    runs[name]["seconds"].append(time.perf_counter() - start)
                    runs[name]["energy"].append(result["energy"])
                finally:
                    snes.NewtonSolver._holds_dirichlet_data = skip  # type: ignore[method-assign]
    energies = {energy for run in runs.values() for energy in run["energy"]}
    return {"problem": "fvk_square.toml", "runs": runs, "same_energy": len(energies) == 1}


def table(record: dict[str, Any]) -> str:
    """The page's section from the JSON."""
    forms, newton = record["forms"], record["newton"]
    memo, ffcx = forms["seconds"]["memo"], forms["seconds"]["ffcx"]
    skipped, lifted = (min(newton["runs"][k]["seconds"]) for k in ("skipped", "every residual"))
    same = "the same bit for bit" if newton["same_energy"] else "**different**"
    return "\n".join(
        [
            "One process, serial (`benchmarks/form_reuse.py`, "
            "`benchmarks/results/form_reuse.json`).",
            "",
            "| what | dgplate | the call it replaces | ratio |",
            "|---|---|---|---|",
            f"| the bilayer's Hessian (8 × 4 Q2) built again, per build (JIT cache of "
            f"{forms['cache_files']:,} files) | {memo * 1e3:.1f} ms | {ffcx * 1e3:.1f} ms | "
            f"{memo / ffcx:.2f} |",
            f"| `{newton['problem']}` by `dgplate.run`, lifting only where u misses g "
            f"(energy {same}; fastest of {len(newton['runs']['skipped']['seconds'])}) | "
            f"{skipped:.2f} s | {lifted:.2f} s | {skipped / lifted:.2f} |",
        ]
    )


def main(argv: list[str] | None = None) -> None:
    """The command line (``argv``: sys.argv's by default)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--builds", type=int, default=20, help="builds of the form each way")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs of fvk_square each way")
    add_page_options(parser, RESULTS, PAGE)
    args = parser.parse_args(argv)
    record = None
    if not args.table_only:
        record = {"forms": hessian_builds(args.builds), "newton": newton_lifting(args.repeats)}
    publish(MPI.COMM_WORLD, args, record, MARKERS, table)


if __name__ == "__main__":
    main()
