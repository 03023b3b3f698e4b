"""The bilayer O strip under refinement: each level run to its stopping criterion.

The problem of demos/self_avoiding_strip.py (demos/problems/self_avoiding_strip.toml: the 6×1
bilayer strip clamped at x₁ = 0, Z = diag(1.25, 0), ρ = 10⁻⁴, q = 4.5, τ = 0.2, started from
the arc of radius 1) on 24×2, 48×4 and 96×8 cells, each run with the problem file's flow until
its stopping test holds ((E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < tol, τ fixed). Each level's record:
I_bend + ρTP, ρTP, the least distance of points of non-neighbouring cells (final and over the
run), the gap of the O's overlap (:func:`gap`), D_h, steps, wall time, dofs and the energy at
every step. The level differences of the final figures, and of the energy at common steps (the
same flow time, as τ is the same), give an estimated order when there are three levels.

    python benchmarks/self_avoiding_convergence.py --cells 24 48 96 --json out.json
    python benchmarks/self_avoiding_convergence.py --cells 24 --set flow.adaptive_tau=true \
        --set flow.stop=stationarity --max-steps 400
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate.io.output import print0
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import load_problem

PROBLEM = Path(__file__).resolve().parent.parent / "demos" / "problems" / "self_avoiding_strip.toml"
#: Reference distance along the strip beyond which two points count as on different turns.
GAP_APART = 3.0
#: The settings of every level besides the problem file's (``--set`` adds to them).
COMMON: dict[str, Any] = {
    "flow.checkpoint_every": 0,
    "output.vtx": False,
    "output.png": False,
    "output.frames_every": 0,
    "output.progress": 0,
}


def gap(comm: MPI.Comm, shape: Any, apart: float = GAP_APART) -> float:
    """The gap of the O's overlap: the least |y(x) − y(x̃)| over nodes with |x₁ − x̃₁| ≥ apart.

    Unlike the safety net's least distance of non-neighbouring cells, which on the open arc
    is about one and a half cells and so shrinks with h, points this far apart along the
    strip meet only where the free end lies over the clamped part. Nodes of all ranks are
    gathered (collective); every rank returns the same value.
    """
    space = shape.function_space
    owned = space.dofmap.index_map.size_local
    x = space.tabulate_dof_coordinates()[:owned, 0]
    y = shape.x.array.reshape(-1, 3)[:owned]
    xs = np.concatenate(comm.allgather(x))
    ys = np.concatenate(comm.allgather(y))
    order = np.argsort(xs)
    xs, ys = xs[order], ys[order]
    least = math.inf
    for i in range(len(xs)):
        far = np.searchsorted(xs, xs[i] + apart)
        if far < len(xs):
            least = min(least, float(np.min(np.linalg.norm(ys[far:] - ys[i], axis=1))))
    return least


def level(comm: MPI.Comm, args: argparse.Namespace, cells: int) -> dict[str, Any]:
    """One level, 'cells' × cells/12 cells, run to its stop; its figures."""
    overrides = {
        **COMMON,
        "mesh.cells": [cells, max(1, cells // 12)],
        "flow.tol": args.tol,
        "flow.max_steps": args.max_steps,
    }
    extra = dict(item.split("=", 1) for item in args.set)
    texts = [f"{k}={json.dumps(v)}" for k, v in overrides.items() if k not in extra]
    texts += [f"{k}={v}" for k, v in extra.items()]
    problem = load_problem(PROBLEM, texts)
    folder = tempfile.mkdtemp(prefix="oconv_") if comm.rank == 0 else None
    folder = comm.bcast(folder, root=0)
    t0 = time.perf_counter()
    result = run_problem(problem, Path(folder) / "run", comm)  # the arc: model.start
    wall = time.perf_counter() - t0
    summary, history = result.summary, result.history
    distances = [row["min_distance"] for row in history if "min_distance" in row]
    record = {
        "cells": overrides["mesh.cells"],
        "settings": texts,
        "dofs": summary.get("dofs"),
        "converged": summary["converged"],
        "reason": summary["reason"],
        "steps": summary["steps"],
        "energy": summary["energy"],
        "energy_increases": summary["energy_increases"],
        "isometry_defect": summary["isometry_defect"],
        "gap": gap(comm, result.shape),
        "least_distance_run": min(distances) if distances else None,
        "taus": [row.get("tau") for row in history],
        "energies": [row.get("energy") for row in history],
        "min_distances": [row.get("min_distance") for row in history],
        "stationarity": [row.get("stationarity") for row in history],
        "wall_s": wall,
    }
    for key in ("self_avoidance_energy", "min_distance", "rejected_steps", "newton_steps"):
        record[key] = summary.get(key)
    record["summary_keys"] = sorted(summary)
    record["last_row"] = history[-1] if history else {}
    return record


#: Steps at which the energies of the levels are compared too (same τ: the same flow time).
COMMON_STEPS = (30, 60, 120)


def order(values: list[float]) -> dict[str, Any]:
    """Differences of a quantity between consecutive levels, and the order the last two give."""
    steps = [b - a for a, b in itertools.pairwise(values)]
    rate = None
    if len(steps) >= 2 and steps[-1] != 0 and steps[-2] != 0:
        rate = math.log2(abs(steps[-2] / steps[-1]))
    return {"values": values, "differences": steps, "estimated_order": rate}


def differences(levels: list[dict[str, Any]]) -> dict[str, Any]:
    """Level differences of the final figures and of the energy at common steps (fixed τ)."""
    record = {
        key: order([run[key] for run in levels])
        for key in ("energy", "self_avoidance_energy", "min_distance", "gap")
    }
    for step in COMMON_STEPS:
        if all(len(run["energies"]) >= step for run in levels):
            record[f"energy_step_{step}"] = order([run["energies"][step - 1] for run in levels])
    return record


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[24, 48])
    parser.add_argument("--tol", type=float, default=1e-3)
    parser.add_argument("--max-steps", type=int, default=2000)
    parser.add_argument("--set", action="append", default=[], help="key=value for every level")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    levels = []
    for cells in args.cells:
        levels.append(level(comm, args, cells))
        brief = {
            k: v for k, v in levels[-1].items() if k not in ("taus", "stationarity", "summary_keys")
        }
        print0(comm, json.dumps(brief, indent=1, default=str))
        if args.json and comm.rank == 0:
            record = {
                "problem": str(PROBLEM.name),
                "ranks": comm.size,
                "tol": args.tol,
                "levels": levels,
            }
            args.json.write_text(
                json.dumps(record | differences(levels), indent=2, default=str) + "\n"
            )
    print0(comm, json.dumps(differences(levels)))


if __name__ == "__main__":
    main(sys.argv[1:])
