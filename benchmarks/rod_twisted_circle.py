"""The flat but twisted circle with self-avoidance (docs/rods.md, experiment 1; [BL]'s settings).

A closed rod of length L = 1 starts as the circle whose frame turns ``--turns`` times about
the tangent, perturbed by the small saddle a = ``--saddle`` (``model.saddle``), and flows with
the published settings c_b = 2, c_t = 1, ρ = 0.1, τ = h (Bartels and Reiter, *Stability of a simple
scheme for the approximation of elastic knots and self-avoiding inextensible curves*, Math.
Comp. 90 (2021)). [BL] does not give the twist: by Michell's criterion the ring is unstable
for c_t·k > √3 c_b, i.e. k > 3.46 turns here. The default k = 5 (1.44 times the threshold) with
the saddle a = 10⁻² buckles within the pseudo-time 60; k = 4 with a = 10⁻³ at 50 cells had
writhed only to Wr = 3·10⁻⁵ after the pseudo-time 40 (its P₁ frame turns 3.82 times).
The published ε = h has no counterpart (the constraints are linearised, not penalised).

Recorded per step (history.csv of the run): the twist Tw = (1/2π)∫b′·d, the writhe Wr of the
centreline polygon, their sum Lk (Călugăreanu: conserved while the rod does not pass through
itself; a crossing changes Wr, hence Lk, by ±2), the least distance of non-neighbouring
quadrature points and the steps redone by the safety net.

    python benchmarks/rod_twisted_circle.py --cells 50 --json benchmarks/results/rod_twisted_circle_50.json

``--gif PATH --frames K`` runs the same flow instead in K pieces of steps/K steps, each started
from the last (``RodStart``: u and b, which continues the flow exactly), and makes their final
pictures (a tube with a stripe along b) into an animation.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import dgplate
from dgplate.io.images import frames_to_gif
from dgplate.io.output import print0
from dgplate.models.rod.start import RodStart

CLOSED = Path(__file__).resolve().parent.parent / "demos" / "problems" / "rod_closed.toml"


def settings(args: argparse.Namespace) -> dict[str, object]:
    """The published experiment at ``args.cells`` cells: h = τ = 1/cells (L = 1)."""
    h = 1.0 / args.cells
    return {
        "model.c_b": 2.0,
        "model.c_t": 1.0,
        "model.cells": args.cells,
        "model.twist": 2.0 * math.pi * args.turns,
        "model.saddle": args.saddle,
        "model.self_avoidance": {"rho": args.rho, "q": args.q},
        "flow.tau": h,
        "flow.tol": args.tol,
        "flow.max_steps": args.steps,
        "output.progress": 0,
        "output.vtx": False,
        "output.png": False,
    }


def series(history: list[dict[str, float]]) -> dict[str, list[float]]:
    """Time, Tw, Wr, Lk, least distance, energy and redone steps of every step."""
    keys = ("time", "energy", "min_distance", "redone", "writhe")
    out = {key: [float(row[key]) for row in history] for key in keys}
    out["twist"] = [row["twist_angle"] / (2.0 * math.pi) for row in history]
    out["link"] = [tw + wr for tw, wr in zip(out["twist"], out["writhe"], strict=True)]
    return out


def thinned(run: dict[str, list[float]], rows: int = 500) -> dict[str, list[float]]:
    """Every k-th step of the series (and the last), at most about ``rows`` of them."""
    size = len(run["time"])
    keep = sorted({*range(0, size, max(1, size // rows)), size - 1})
    return {key: [values[i] for i in keep] for key, values in run.items()}


def figures(run: dict[str, list[float]]) -> dict[str, float]:
    """The largest one-step change of Wr, the drift of Lk and the range of the other series."""
    jumps = [abs(b - a) for a, b in itertools.pairwise(run["writhe"])]
    return {
        "max_writhe_jump": max(jumps, default=0.0),
        "link_start": run["link"][0],
        "link_end": run["link"][-1],
        "link_drift_max": max(abs(x - run["link"][0]) for x in run["link"]),
        "twist_start": run["twist"][0],
        "twist_end": run["twist"][-1],
        "writhe_end": run["writhe"][-1],
        "min_distance_least": min(run["min_distance"]),
        "min_distance_start": run["min_distance"][0],
        "steps_redone": sum(1 for r in run["redone"] if r > 0),
        "energy_start": run["energy"][0],
        "energy_end": run["energy"][-1],
    }


def animation(args: argparse.Namespace, problem_settings: dict[str, object]) -> None:
    """The flow in ``args.frames`` pieces, each picture a frame of the GIF ``args.gif``."""
    comm, gif = MPI.COMM_WORLD, Path(args.gif)
    per_piece = max(1, args.steps // args.frames)
    overrides = {**problem_settings, "flow.max_steps": per_piece, "output.png": True}
    initial, frames = None, []
    for piece in range(args.frames):
        problem = dgplate.load_problem(CLOSED, overrides)
        problem.name = f"twisted circle, t = {(piece + 1) * per_piece / args.cells:.1f}"
        out = gif.parent / f"{gif.stem}_frames" / f"{piece:03d}"
        result = dgplate.run(problem, out=out, comm=comm, initial=initial, force=True)
        frames.append(out / "final.png")
        initial = RodStart(result.fields)
        print0(comm, f"{problem.name}: Wr = {result['writhe']:.3f}")
    frames_to_gif(frames, gif, fps=4.0, comm=comm)


def main() -> None:
    """Run the experiment, print its figures and write JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=50, help="1/h ([BL]: 200)")
    parser.add_argument("--turns", type=float, default=5.0)
    parser.add_argument("--saddle", type=float, default=1e-2)
    parser.add_argument("--rho", type=float, default=0.1)
    parser.add_argument("--q", type=float, default=3.0)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--tol", type=float, default=1e-6)
    parser.add_argument("--json", default=None)
    parser.add_argument("--gif", default=None, help="an animation of the run instead (PATH)")
    parser.add_argument("--frames", type=int, default=30, help="frames of --gif")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    if args.gif:
        animation(args, settings(args))
        return
    problem = dgplate.load_problem(CLOSED, settings(args))
    wall = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        out = comm.bcast(scratch if comm.rank == 0 else None)
        result = dgplate.run(problem, out=Path(out) / "run", comm=comm)
    wall = time.perf_counter() - wall
    run = series(result.history)
    summary = {
        **{k: v for k, v in vars(args).items() if k != "json"},
        "c_b": 2.0,
        "c_t": 1.0,
        "h": 1.0 / args.cells,
        "tau": 1.0 / args.cells,
        "michell_turns": math.sqrt(3.0) * 2.0 / 1.0,
        "steps_done": result["steps"],
        "converged": result["converged"],
        "reason": result["reason"],
        "energy_increases": result["energy_increases"],
        "length": result["length"],
        "defect_tangent": result["defect_tangent"],
        "energy_bending": result["energy_bending"],
        "energy_torsion": result["energy_torsion"],
        "energy_self_avoidance": result["energy_self_avoidance"],
        **figures(run),
        "ranks": comm.size,
        "wall_time_s": wall,
    }
    print0(comm, json.dumps(summary, indent=1))
    if args.json and comm.rank == 0:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        data = {**summary, "series": thinned(run)}
        Path(args.json).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
