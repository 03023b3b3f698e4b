"""Where the time of self-avoidance goes: the cluster tree against exact sums, and TP against the step solve.

Three measurements (docs/self_avoidance.md):

* accuracy and speed-up: TP and its derivatives by the tree (θ = 0.25, 0.5, 1) against the
  exact all-pairs sums, on the cell centres of a strip rolled into a spiral of 1.5 turns
  (a bent configuration whose layers face each other), for M points up to ``--exact-max``;
* cost against M: one tree evaluation (θ = 0.5; build and sums timed apart, CPU and wall
  seconds) for M = 10³ … ``--max-m`` (10⁶), the same surface sampled finer, with interactions
  per point, the tree's depth, t/(M log M) and the slopes of log t against log M and against
  log(M log M); ``--leaf 0 32`` repeats it with leaves of 32 points;
* per step of the demo ``self_avoiding_strip`` (flow): the time of one TP evaluation against
  the step's assembly and solve.

    python benchmarks/tangent_point.py --json benchmarks/results/tangent_point.json

With ``--plot``, it measures nothing and draws the least distance of non-neighbouring points
and the energy over the flow time from the history.csv of self-avoiding runs (one curve each):

    python benchmarks/tangent_point.py --plot docs/img/self_avoiding_min_distance.png \
        --history "O strip=out/self_avoiding_strip/history.csv" ...
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any, cast

from mpi4py import MPI

import numpy as np

import dgplate
from dgplate.dg import tangent_point as tp
from dgplate.dg.self_avoidance import PlateTangentPoint
from dgplate.io.output import print0
from dgplate.problems.prepare import build_mesh
from dgplate.problems.registry import MODELS
from dgplate.solvers.flow import GradientFlow

DEMO = Path(__file__).resolve().parent.parent / "demos" / "problems" / "self_avoiding_strip.toml"


def spiral(n1: int, n2: int, turns: float = 1.5) -> tuple[tp.Cloud, float]:
    """Cell centres of an n1×n2 grid on a strip rolled into a spiral (radius 1 → 0.9).

    Returns the cloud (the vertex ids of the grid cells) and the cell length.
    """
    length = 2 * np.pi * turns
    s = (np.arange(n1) + 0.5) / n1 * length
    t = (np.arange(n2) + 0.5) / n2
    S, T = np.meshgrid(s, t, indexing="ij")
    R = 1.0 - 0.1 * S / length
    x = np.stack([R * np.sin(S), T, 1 - R * np.cos(S)], -1).reshape(-1, 3)
    tangent = np.stack([np.cos(S), 0 * S, np.sin(S)], -1).reshape(-1, 3)
    nu = np.cross(tangent, [0.0, 1.0, 0.0])
    w = np.full(len(x), length / n1 / n2)
    I, J = np.meshgrid(np.arange(n1), np.arange(n2), indexing="ij")
    corners = [
        I * (n2 + 1) + J,
        I * (n2 + 1) + J + 1,
        (I + 1) * (n2 + 1) + J,
        (I + 1) * (n2 + 1) + J + 1,
    ]
    return tp.Cloud(x, nu, w, np.stack(corners, -1).reshape(-1, 4)), length / n1


def grid(m: int) -> tuple[int, int]:
    """An n1×n2 grid of about m cells with square cells on the 3π×1 strip."""
    n2 = max(2, round(np.sqrt(m / (3 * np.pi))))
    return max(4, round(m / n2)), n2


def timed(cloud: tp.Cloud, theta: float, reach: float) -> tuple[tp.TPResult, float]:
    """One evaluation and its CPU seconds."""
    t0 = time.process_time()
    result = tp.evaluate(cloud, 4.5, theta, reach)
    return result, time.process_time() - t0


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def accuracy(sizes: list[int], thetas: list[float]) -> list[dict[str, Any]]:
    """Tree against exact sums: relative errors of TP and of its gradient, times."""
    rows = []
    for m in sizes:
        cloud, h = spiral(*grid(m))
        exact, t_exact = timed(cloud, 0.0, 3 * h)
        grad = np.concatenate([exact.d_points.ravel(), exact.d_normals.ravel()])
        for theta in thetas:
            tree, t_tree = timed(cloud, theta, 3 * h)
            approx = np.concatenate([tree.d_points.ravel(), tree.d_normals.ravel()])
            row = {
                "M": len(cloud.points),
                "theta": theta,
                "energy_error": abs(tree.energy - exact.energy) / exact.energy,
                "gradient_error": relative(approx, grad),
                "exact_s": t_exact,
                "tree_s": t_tree,
                "speedup": t_exact / t_tree,
                "pairs_exact": exact.pairs_exact,
                "tree_pairs_near": tree.pairs_exact,
                "tree_point_box": tree.pairs_far,
            }
            print0(MPI.COMM_WORLD, json.dumps(row))
            rows.append(row)
    return rows


def cost(sizes: list[int], theta: float, leaf: int | None) -> dict[str, Any]:
    """One tree evaluation against M: tree build and sums separately, the slope of log t over log M.

    ``leaf`` None: the default of :func:`tangent_point.evaluate`. Times are wall and CPU seconds
    (the machine is shared: CPU time is the steadier). ``per_MlogM`` is the total time over
    M log₂ M relative to the first row: it stays near 1 when the cost grows like M log M.
    """
    rows = []
    for m in sizes:
        cloud, h = spiral(*grid(m))
        size = leaf or tp._default_leaf(cloud, theta)
        w0, c0 = time.perf_counter(), time.process_time()
        tree = tp.build_tree(cloud.points, cloud.weights, size)
        w1, c1 = time.perf_counter(), time.process_time()
        result = tp.evaluate(cloud, 4.5, theta, 3 * h, tree=tree)
        w2, c2 = time.perf_counter(), time.process_time()
        n = len(cloud.points)
        rows.append({"M": n, "depth": depth(tree), "build_s": w1 - w0, "sums_s": w2 - w1,
                     "total_s": w2 - w0, "build_cpu_s": c1 - c0, "sums_cpu_s": c2 - c1,
                     "cpu_s": c2 - c0, "near_per_point": result.pairs_exact / n,
                     "far_per_point": result.pairs_far / n})  # fmt: skip
        first, row = rows[0], rows[-1]
        mlogm = row["M"] * np.log2(row["M"]) / (first["M"] * np.log2(first["M"]))
        row["per_MlogM"] = row["cpu_s"] / first["cpu_s"] / mlogm
        row["per_MlogM_wall"] = row["total_s"] / first["total_s"] / mlogm
        print0(MPI.COMM_WORLD, json.dumps(rows[-1]))
    return {"theta": theta, "leaf": leaf or "default", "rows": rows, **slopes(rows)}


def depth(tree: tp.Tree) -> int:
    """The number of levels below the root (the longest path to a leaf)."""
    level, nodes = 0, np.array([0])
    while True:
        nodes = tree.children[nodes[~tree.is_leaf(nodes)]].ravel()
        if not nodes.size:
            return level
        level += 1


def slopes(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Slopes of log t over log M and over log(M log M) (wall and CPU, all rows and the last two).

    A slope 1 over log(M log M) is a cost growing like M log M.
    """
    if len(rows) < 2:
        return {}
    m = np.array([r["M"] for r in rows], dtype=float)
    out = {}
    for name, x in (("", np.log(m)), ("_MlogM", np.log(m * np.log(m)))):
        for key in ("total_s", "cpu_s"):
            t = np.log([r[key] for r in rows])
            out[f"slope{name}_{key}"] = float(np.polyfit(x, t, 1)[0])
            out[f"slope{name}_{key}_last_two"] = float((t[-1] - t[-2]) / (x[-1] - x[-2]))
    return out


def flow(steps: int, cells: list[int]) -> dict[str, Any]:
    """Per step of the demo's flow: one TP evaluation against the step's assembly and solve."""
    problem = dgplate.load_problem(DEMO, {"mesh.cells": cells})
    tagged = build_mesh(problem.mesh, MPI.COMM_WORLD)
    model = MODELS[problem.model.name].build(problem.model, tagged)
    driver = model.driver(
        problem.flow, [], lambda x: np.vstack([np.sin(x[0]), x[1], 1.0 - np.cos(x[0])])
    )
    driver = cast(GradientFlow, driver)  # the bilayer's flow
    (nonlocal_term,) = driver.energy.nonlocal_terms
    term = cast(PlateTangentPoint, nonlocal_term)
    rows = []
    for _ in range(steps):
        info = driver.step()
        t0 = time.perf_counter()
        term._state = None  # force a fresh evaluation at the same state
        term.update()
        tp_s = time.perf_counter() - t0
        rows.append(
            {"tp_s": tp_s, "assembly_s": info.assembly_s, "solve_s": info.factor_s + info.solve_s}
        )
    mean = {key: float(np.mean([r[key] for r in rows[1:]])) for key in rows[0]}
    return {"cells": cells, "dofs": driver.num_dofs, "points": len(term.cloud()[0].points),
            "steps": steps, "mean": mean}  # fmt: skip


def plot_histories(histories: list[str], path: str) -> None:
    """min_distance and energy against the flow time of runs given as ``label=history.csv``.

    Redone steps (the ``redone`` column) are marked; the time axis is the flow time t.
    """
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=False)
    for entry in histories:
        label, _, csv_path = entry.rpartition("=")
        with open(csv_path, newline="") as stream:
            rows = list(csv.DictReader(stream))
        t = np.array([float(r["time"]) for r in rows])
        distance = np.array([float(r["min_distance"]) for r in rows])
        redone = np.array([float(r["redone"]) > 0 for r in rows])
        (line,) = top.plot(t, distance, label=label)
        top.plot(t[redone], distance[redone], "x", color=line.get_color())
        bottom.plot(t, [float(r["energy"]) for r in rows], label=label)
    top.set(yscale="log", ylabel="least distance (non-neighbouring points)")
    bottom.set(xlabel="flow time t", ylabel="$I_{bend} + \\rho\\,TP$ (with the data's work)")
    top.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", default=None, help="draw --history files into this PNG")
    parser.add_argument("--history", action="append", default=[], help="label=history.csv")
    parser.add_argument("--exact-max", type=int, default=10000)
    parser.add_argument("--thetas", type=float, nargs="*", default=[0.25, 0.5, 1.0])
    parser.add_argument("--max-m", type=int, default=1000000)
    parser.add_argument("--theta", type=float, default=0.5, help="θ of the cost sweep")
    parser.add_argument(
        "--leaf",
        type=int,
        nargs="*",
        default=[0],
        help="leaf sizes of the cost sweep (0: the default)",
    )
    parser.add_argument("--no-flow", action="store_true", help="skip the demo's flow")
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--cells", type=int, nargs=2, default=[48, 4])
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.plot:
        if MPI.COMM_WORLD.rank == 0:
            plot_histories(args.history, args.plot)
        return {}
    exact_sizes = [m for m in (1000, 4000, 10000) if m <= args.exact_max]
    cost_sizes = [m for m in (1000, 3000, 10000, 30000, 100000, 300000, 1000000) if m <= args.max_m]
    record = {
        "accuracy": accuracy(exact_sizes, args.thetas),
        "cost": [cost(cost_sizes, args.theta, leaf or None) for leaf in args.leaf],
        "flow": None if args.no_flow else flow(args.steps, args.cells),
        "ranks": MPI.COMM_WORLD.size,
    }
    if record["flow"]:
        print0(MPI.COMM_WORLD, json.dumps(record["flow"]))
    if args.json and MPI.COMM_WORLD.rank == 0:
        Path(args.json).write_text(json.dumps(record, indent=1))
    return record


if __name__ == "__main__":
    main()
