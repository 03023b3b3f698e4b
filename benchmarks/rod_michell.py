"""Michell's instability of a twisted elastic ring: the critical torsional rigidity by bisection.

A closed rod of length L whose frame turns k times about its tangent (``model.twist`` = 2πk)
is a circle with the uniform twist density 2πk/L. Michell (1889–1890) showed that this ring
is stable exactly when c_t·k < √3·c_b (docs/rods.md; Goriely, J. Elasticity 84 (2006)
281–299, reviews the criterion and its rediscoveries). At fixed k = 3 and c_b = 1 the
classical threshold is c_t* = √3/3 = 0.57735.

Each run starts from the ring perturbed by the small saddle a = 10⁻³ (``model.saddle``: the
mode 2 out of the plane, the mode that Michell's ring loses stability to) and flows for a
fixed pseudo-time. The out-of-plane extent z(t) = max u₃ − min u₃ is recorded; the ring is
unstable when z grows between the half-time and the end (the decaying parts of the start are
gone by then), stable when it shrinks. c_t is bisected between a stable and an unstable value
until the bracket is narrower than ``--rel`` of its midpoint.

    python benchmarks/rod_michell.py --cells 64 --json benchmarks/results/rod_michell_64.json
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import cast

from mpi4py import MPI

import numpy as np

import dgplate
from dgplate import mpi
from dgplate.io.output import print0
from dgplate.problems.registry import MODELS
from dgplate.solvers.rod_flow import RodFlow

CLOSED = Path(__file__).resolve().parent.parent / "demos" / "problems" / "rod_closed.toml"


def extent_z(u: dgplate.compat.Function) -> float:
    """max u₃ − min u₃ over the nodes (collective)."""
    owned = u.function_space.dofmap.index_map.size_local
    z = u.x.array.reshape(-1, 3)[:owned, 2]
    comm = u.function_space.mesh.comm
    return mpi.global_max(comm, float(np.max(z))) - mpi.global_min(comm, float(np.min(z)))


def growth(c_t: float, turns: int, cells: int, tau: float, steps: int, comm: MPI.Comm) -> dict:
    """z at the start, half-time and end of a run of ``steps`` steps from the perturbed ring."""
    problem = dgplate.load_problem(
        CLOSED,
        {
            "model.c_t": c_t,
            "model.twist": 2.0 * math.pi * turns,
            "model.cells": cells,
            "model.saddle": 1e-3,
            "flow.tau": tau,
        },
    )
    entry = MODELS["rod"]
    assert entry.mesh is not None
    model = entry.build(problem.model, entry.mesh(problem.model, comm))
    driver = cast(RodFlow, model.driver(problem.flow, [], None))
    z = [extent_z(driver.u)]
    energies = [driver.evaluate_energy()]
    for _ in range(steps):
        info = driver.step()
        z.append(extent_z(driver.u))
        energies.append(info.energy)
    driver.destroy()
    half = z[steps // 2]
    return {
        "c_t": c_t,
        "z_start": z[0],
        "z_half": half,
        "z_end": z[-1],
        "rate": math.log(z[-1] / half) / (tau * (steps - steps // 2)),
        "unstable": z[-1] > half,
        "energy_increases": int(np.sum(np.diff(energies) > 1e-12 * np.abs(energies[1:]))),
    }


def main() -> None:
    """Bisect c_t; print each run and the threshold, write JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--turns", type=int, default=3)
    parser.add_argument("--cells", type=int, default=64)
    parser.add_argument("--tau", type=float, default=0.1)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--low", type=float, default=0.4, help="a stable c_t")
    parser.add_argument("--high", type=float, default=0.8, help="an unstable c_t")
    parser.add_argument("--rel", type=float, default=0.01)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    wall = time.perf_counter()
    runs = []

    def judge(c_t: float) -> bool:
        run = growth(c_t, args.turns, args.cells, args.tau, args.steps, comm)
        runs.append(run)
        print0(comm, json.dumps(run))
        return bool(run["unstable"])

    low, high = args.low, args.high
    if judge(low) or not judge(high):
        raise SystemExit("the bracket does not hold the threshold: widen --low/--high")
    while high - low > args.rel * 0.5 * (low + high):
        middle = 0.5 * (low + high)
        low, high = (low, middle) if judge(middle) else (middle, high)
    classical = math.sqrt(3.0) / args.turns  # c_b = 1
    measured = 0.5 * (low + high)
    result = {
        "turns": args.turns,
        "c_b": 1.0,
        "cells": args.cells,
        "tau": args.tau,
        "steps": args.steps,
        "bracket": [low, high],
        "c_t_critical": measured,
        "c_t_classical": classical,
        "relative_error": measured / classical - 1.0,
        "runs": runs,
        "ranks": comm.size,
        "wall_time_s": time.perf_counter() - wall,
    }
    print0(
        comm,
        f"k = {args.turns}: critical c_t in [{low:.5f}, {high:.5f}], midpoint {measured:.5f}; "
        f"Michell √3 c_b/k = {classical:.5f} ({100 * result['relative_error']:+.2f} %)",
    )
    if args.json and comm.rank == 0:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
