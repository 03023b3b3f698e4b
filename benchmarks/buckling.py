"""The compressed strip of Bonito–Nochetto–Ntogkas (M3AS 2021), §6.3, by boundary continuation.

ω = (−2, 2) × (0, 1) clamped at x₁ = ±2 with g = (x₁ − 1.4·sign(x₁), x₂, 0), f = (0, 0, 1e-2),
φ(α) = (1 − α)·id + α·g with α += δα per flow step, γ₀ = γ₁ = 1e4, τ = 0.04625 (published:
δα = 5e-5, final D_h ≈ 5.04e-3). Runs ``demos/problems/buckling_strip.toml`` with the given
mesh and δα and writes E_h, D_h, the height and its elastica value, steps and time as JSON:

    python benchmarks/buckling.py --cells 16 2 --rate 5e-5 --json benchmarks/results/buckling.json

``--max-steps 1000`` stops at α = 0.05 (the defect's growth early on the path, on finer meshes).
``--tau``, ``--load`` and ``--penalty`` change the published τ, upward force and γ₀ = γ₁ (how
D_h depends on them, docs/continuation.md).
The record also holds the pointwise norms ∫|∇yᵀ∇y − I| and ∫|∇yᵀ∇y − I|² of the final state.
``--table1 16 32 64`` instead records D_h and the same norms on the vertical-load plates of the
paper's Table 1, beside its printed D_h (which definition the paper's D_h is):

    python benchmarks/buckling.py --table1 16 32 64 --json benchmarks/results/defect_table1.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import ufl

import dgplate
from dgplate.dg.forms import integral
from dgplate.reference.bnn import BNN_TABLE1
from dgplate.reference.elastica import clamped_elastica
from dgplate.solvers.constraint import metric_tensor_defect

PROBLEM = Path(__file__).parents[1] / "demos" / "problems" / "buckling_strip.toml"
PUBLISHED_DEFECT = 5.04e-3
VERTICAL_LOAD = PROBLEM.parent / "vertical_load.toml"


def pointwise_defects(y: Any) -> dict[str, float]:
    """The defect ∇yᵀ∇y − I pointwise: ∫|·| and ∫|·|² (Frobenius norm), beside D_h.

    D_h sums the norms of the cell integrals, which the cell-mean constraint controls; these
    see also the variation inside the cells (a check of which definition a published D_h uses).
    """
    defect = metric_tensor_defect(y)
    dx = ufl.dx(metadata={"quadrature_degree": 12})  # |·| is not a polynomial
    comm = y.function_space.mesh.comm
    l1 = integral(dolfinx.fem.form(ufl.sqrt(ufl.inner(defect, defect) + 1e-300) * dx), comm)
    l2 = integral(dolfinx.fem.form(ufl.inner(defect, defect) * dx), comm)
    return {"defect_l1_pointwise": l1, "defect_l2_squared": l2}


def main() -> None:
    """Run one strip and print (and write) its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs=2, default=[16, 2])
    parser.add_argument("--rate", type=float, default=5e-5, help="δα per flow step")
    parser.add_argument("--projection-steps", type=int, default=0)
    parser.add_argument(
        "--max-steps", type=int, default=0, help="stop after this many flow steps (0: the file's)"
    )
    parser.add_argument("--tau", type=float, default=0.0, help="flow.tau (0: the published)")
    parser.add_argument("--load", type=float, default=None, help="upward force (published 1e-2)")
    parser.add_argument("--penalty", type=float, default=None, help="γ₀ = γ₁ (published 1e4)")
    parser.add_argument("--out", default="out/benchmark_buckling")
    parser.add_argument("--json", default="")
    parser.add_argument(
        "--table1", type=int, nargs="+", default=[], help="the Table 1 plates at these cells"
    )
    args = parser.parse_args()
    if args.table1:
        if unknown := sorted(set(args.table1) - set(BNN_TABLE1)):
            parser.error(f"--table1: Table 1 has no plate of {unknown} cells per side")
        _write(table1(args.table1, args.out), args.json)
        return
    overrides = {
        "mesh.cells": args.cells,
        "model.continuation": {"rate": args.rate},
        "flow.projection_steps": args.projection_steps,
        "output.vtx": False,
        "output.progress": 1000,
    }
    if args.max_steps:
        overrides["flow.max_steps"] = args.max_steps
    if args.tau:
        overrides["flow.tau"] = args.tau
    if args.load is not None:
        overrides["model.load"] = [0.0, 0.0, args.load]
    if args.penalty is not None:
        overrides["model.penalty"] = {"gamma0": args.penalty, "gamma1": args.penalty}
    problem = dgplate.load_problem(PROBLEM, overrides)
    t0 = time.perf_counter()
    result = dgplate.run(problem, out=args.out, force=True)
    height = result["bbox"][1][2]
    elastica = clamped_elastica(4.0, 2.8)["height"]
    figures = {
        "cells": args.cells,
        "rate": args.rate,
        "alpha": min(1.0, args.rate * result["steps"]),
        "projection_steps": args.projection_steps,
        "tau": problem.flow.tau,
        "load": problem.model.load,
        "penalty": problem.model.penalty,
        "ranks": MPI.COMM_WORLD.size,
        "dofs": result["dofs"],
        "steps": result["steps"],
        "converged": result["converged"],
        "energy": result["energy"],
        "isometry_defect": result["isometry_defect"],
        "published_defect": PUBLISHED_DEFECT,
        "defect_ratio": result["isometry_defect"] / PUBLISHED_DEFECT,
        "height": height,
        "elastica_height": elastica,
        "height_error": height / elastica - 1,
        "energy_increases": len(result["energy_increases"]),
        "wall_time_s": time.perf_counter() - t0,
        **pointwise_defects(result.shape),
    }
    _write(figures, args.json)


def table1(cells: list[int], out: str) -> dict[str, Any]:
    """D_h and the pointwise norms of the Table 1 plates, beside the printed D_h."""
    rows = {}
    for n in cells:
        overrides = {"mesh.cells": [n, n], "output.vtx": False, "output.png": False}
        problem = dgplate.load_problem(VERTICAL_LOAD, overrides)
        result = dgplate.run(problem, out=f"{out}/table1_{n}", force=True)
        rows[str(n)] = {
            "steps": result["steps"],
            "energy": result["energy"],
            "isometry_defect": result["isometry_defect"],
            "published_defect": BNN_TABLE1[n][1],
            **pointwise_defects(result.shape),
        }
    return {"problem": "BNN 2021, Table 1 (vertical load)", "ranks": MPI.COMM_WORLD.size, **rows}


def _write(record: dict[str, Any], path: str) -> None:
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(record, indent=1))
        if path:
            Path(path).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
