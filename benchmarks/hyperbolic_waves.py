"""States of n waves of the hyperbolic disc: E_h against n for two curvatures.

demos/problems/hyperbolic_disc.toml with the metric of the hyperbolic plane of curvature
K = −1/R² (``geodesic_polar_formulas(R, -1)``) for each R, started from the harmonic surface
z = r^n cos(nθ)/(2R) of n waves (projected onto the metric), n = 2, 3, 4: the flow keeps the
number of waves, or leaves it for another, and E_h compares the states. Per mesh size
(``--h``), R and n: the waves found (:func:`dgplate.measure.prestrain.edge_waves`), whether
the run converged, D_h, the flow's steps, E_h, the mean K_h and the wall time.

    python benchmarks/hyperbolic_waves.py [--h 0.1 0.05] [--radii 1 0.5] [--waves 2 3 4] [--json …]
    python benchmarks/hyperbolic_waves.py --table-only [--json …] [--page docs/prestrain.md]

The table of docs/prestrain.md between ``<!-- hyperbolic_waves:begin -->`` and
``<!-- hyperbolic_waves:end -->`` is generated from the JSON (``--table-only``: no runs).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish, run_in_scratch

from dgplate.io.output import print0
from dgplate.measure.prestrain import edge_waves
from dgplate.problems.specs import load_problem
from dgplate.reference.spherical_cap import geodesic_polar_formulas

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "hyperbolic_disc.toml"
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- hyperbolic_waves:begin -->", "<!-- hyperbolic_waves:end -->"


def harmonic(n: int, R: float) -> str:
    """z = Re((x + iy)^n)/(2R) = r^n cos(nθ)/(2R) as a formula in x, y."""
    terms = []
    for k in range(0, n + 1, 2):  # Re((x + iy)^n) = Σ_{k even} C(n, k) x^(n−k) (iy)^k
        coefficient = (-1) ** (k // 2) * math.comb(n, k)
        terms.append(f"({coefficient})*x**{n - k}*y**{k}")
    return f"({' + '.join(terms)})/(2*{R!r})"


def one_state(comm: MPI.Comm, h: float, R: float, n: int) -> dict[str, Any]:
    """The disc of curvature −1/R² from the start of n waves: its figures (module docstring)."""
    overrides = {
        "mesh.parameters.h": h,
        "output.vtx": False,
        "output.png": False,
        "output.progress": 0,
        "model.metric": geodesic_polar_formulas(R, -1),
        "model.start": {"type": "formula", "g": ["x", "y", harmonic(n, R)]},
    }
    problem = load_problem(PROBLEM, overrides)
    what = f"{PROBLEM.stem}, {n} waves, R = {R:g}, h = {h:g}"
    result, wall = run_in_scratch(comm, problem, what, "waves_")
    assert result.shape is not None  # a plate's run keeps its deformation
    s, waves = result.summary, edge_waves(result.shape)
    return {
        "h": h,
        "R": R,
        "start_waves": n,
        "waves": waves["waves"],
        "amplitudes": waves["amplitudes"],
        "cells": s["cells"],
        "converged": s["converged"],
        "steps": s["steps"],
        "energy": s["energy"],
        "isometry_defect": s["isometry_defect"],
        "gauss_mean": s["metric_gauss_curvature"]["mean"],
        "wall_s": wall,
    }


def table(record: dict[str, Any]) -> str:
    """The Markdown table of a record: one row per R and start."""
    rows = []
    for state in record["states"]:
        least = min(
            s["energy"]
            for s in record["states"]
            if (s["h"], s["R"]) == (state["h"], state["R"]) and s["converged"]
        )
        rows.append(
            f"| {state['h']:g} | {state['cells']} | {state['R']:g} | {-1 / state['R'] ** 2:g} | {state['start_waves']} "
            f"| {state['waves']} | {'yes' if state['converged'] else 'no'} "
            f"| {state['isometry_defect']:.1e} | {state['steps']} | {state['energy']:.2f} "
            f"| {'yes' if state['energy'] == least else ''} "
            f"| {state['gauss_mean']:.3f} | {state['wall_s']:.1f} |"
        )
    return "\n".join(
        [
            f"The hyperbolic disc of curvature K = −1/R² from starts of n waves, "
            "z = rⁿcos(nθ)/(2R), P2 on `polar_disc.geo`, Gauss-curvature penalty β = 10, "
            f"{record['ranks']} rank(s) (`benchmarks/hyperbolic_waves.py`, "
            "`benchmarks/results/hyperbolic_waves.json`). Waves: the strongest azimuthal mode "
            "of the final edge's height; least: the least E_h of the converged states at the "
            "level and R; K_h: the area-weighted mean of the cell-wise K_h.",
            "",
            "| h | cells | R | K | start waves | waves | converged | D_h | flow steps | E_h | least "
            "| K_h | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[0.1, 0.05])
    parser.add_argument("--radii", type=float, nargs="+", default=[1.0, 0.5])
    parser.add_argument("--waves", type=int, nargs="+", default=[2, 3, 4])
    add_page_options(parser, RESULTS / "hyperbolic_waves.json", ROOT / "docs" / "prestrain.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record: dict[str, Any] | None = None
    if not args.table_only:
        states = []
        for h in args.h:
            for R in args.radii:
                for n in args.waves:
                    states.append(one_state(comm, h, R, n))
                    print0(comm, states[-1])
        record = {"ranks": comm.size, "states": states}
    publish(comm, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main(sys.argv[1:])
