"""Adaptive τ against fixed τ = h on the BNN vertical-load plate, both to the τ-independent stop.

Both runs use one projection step and stop when ‖P DE_h[yⁿ]‖_*' < tol (``flow.stop =
'stationarity'``); the record holds the accepted and rejected steps, the linear solves (each
step, its projections and its stationarity check), E_h, D_h and the wall time of each.

    python benchmarks/adaptive_tau.py --cells 16 --tol 1e-5 --json out.json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from mpi4py import MPI

from dgplate.io.output import print0
from dgplate.mesh.tagged import rectangle
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.solvers.flow import FlowSpec, GradientFlow


def run(comm: MPI.Comm, cells: int, tol: float, adaptive: bool) -> dict:
    """One flow to the stationarity stop; its counts and result."""
    tagged = rectangle(comm, [[0, 0], [4, 4]], [cells, cells])
    spec = KirchhoffSpec(degree=2, clamped=["left", "bottom"], load=[0, 0, 2.5e-2])
    model = build_kirchhoff(spec, tagged)
    settings = FlowSpec(
        tau=math.sqrt(2) * 4 / cells,
        tol=tol,
        stop="stationarity",
        projection_steps=1,
        max_steps=5000,
        adaptive_tau=adaptive,
    )
    flow = GradientFlow(model.facets, model.degree, model.energy, settings)
    t0 = time.perf_counter()
    result = flow.run()
    wall = time.perf_counter() - t0
    attempts = result.steps + flow.rejected_steps
    record = {
        "adaptive_tau": adaptive,
        "converged": result.converged,
        "steps": result.steps,
        "rejected_steps": flow.rejected_steps,
        "step_solves": attempts * (1 + settings.projection_steps),
        "stationarity_solves": result.steps,
        "energy": result.energy,
        "isometry_defect": result.defect,
        "energy_increases": result.energy_increases,
        "final_tau": result.history[-1].tau if result.history else None,
        "wall_s": wall,
    }
    flow.destroy()
    return record


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=16)
    parser.add_argument("--tol", type=float, default=1e-5)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    fixed, adaptive = (run(comm, args.cells, args.tol, flag) for flag in (False, True))
    record = {
        "problem": "BNN vertical load, Q2, projection_steps = 1, stop = stationarity",
        "cells": args.cells,
        "ranks": comm.size,
        "tol": args.tol,
        "fixed": fixed,
        "adaptive": adaptive,
        "step_solves_ratio_fixed_over_adaptive": fixed["step_solves"] / adaptive["step_solves"],
        "energy_rel_diff": abs(adaptive["energy"] / fixed["energy"] - 1),
    }
    print0(comm, json.dumps(record, indent=2))
    if args.json and comm.rank == 0:
        args.json.write_text(json.dumps(record, indent=2) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
