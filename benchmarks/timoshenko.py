"""Bilayer strips in physical units against Timoshenko's bimetal formula, at several mesh levels.

demos/problems/bilayer_timoshenko.toml (a 2 × 1 strip in units of ``material.length``,
clamped along one short side) with the layers of each case below. ``[material]`` derives
Z = L/R from the layers (Timoshenko's radius R, :mod:`dgplate.reference.timoshenko`); the
fitted cylinder's radius (``physical.cylinder_radius_mm``) is compared with R, and the energy
in J with the cylinder's ½Dκ²·area. A case's length L is R itself (the strip, 2R × R, rolls
through two radians: the non-dimensional problem Z = 1) unless the case gives one.

    python benchmarks/timoshenko.py [--cases equal thick_stiff] [--cells 8 16 32] [--json …]
    python benchmarks/timoshenko.py --table-only [--json …] [--page docs/units.md]

The table of docs/units.md between ``<!-- timoshenko:begin -->`` and ``<!-- timoshenko:end -->``
is generated from the JSON (``--table-only``: no runs); a run replaces the cases it ran and
keeps the others.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish, run_in_scratch

from dgplate.io.output import print0
from dgplate.problems.specs import load_problem
from dgplate.reference.timoshenko import timoshenko_curvature

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "bilayer_timoshenko.toml"
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- timoshenko:begin -->", "<!-- timoshenko:end -->"
MISFIT = 0.01

#: name: (bottom (thickness m, E Pa), top (thickness m, E Pa), length m or None: L = R, label)
CASES: dict[str, tuple[tuple[float, float], tuple[float, float], float | None, str]] = {
    "equal": ((75e-6, 2e9), (75e-6, 2e9), None, "75 µm / 75 µm, 2 GPa / 2 GPa"),
    "thick_stiff": ((50e-6, 1e9), (150e-6, 5e9), None, "50 µm / 150 µm, 1 GPa / 5 GPa"),
    "thick_stiff_short": (
        (50e-6, 1e9),
        (150e-6, 5e9),
        10e-3,
        "50 µm / 150 µm, 1 GPa / 5 GPa, L = 10 mm",
    ),
}


def radius(case: str) -> float:
    """Timoshenko's radius R (m) of a case, the bottom layer with the misfit."""
    (t1, E1), (t2, E2), _, _ = CASES[case]
    return abs(1 / timoshenko_curvature(-MISFIT, t1, t2, E1, E2))


def one_level(comm: MPI.Comm, case: str, cells: int) -> dict[str, Any]:
    """The strip of ``case`` on 2·cells × cells Q2 cells: its figures (module docstring).

    Args:
        comm: the run's communicator (collective).
        case: a key of :data:`CASES`.
        cells: the cells across the strip (per length L).

    Returns:
        The level's record: cells, DoFs, steps, the Z that ``[material]`` derived, the fitted
        radius in mm and its error, the energy error, the mean κ₂/κ₁, the wall time.

    Raises:
        SystemExit: the run was interrupted (SIGINT/SIGTERM): the study stops there.
    """
    (t1, E1), (t2, E2), length, _ = CASES[case]
    R = radius(case)
    L = R if length is None else length
    layers = [
        {"thickness": t1, "E": E1, "nu": 0.3, "misfit": MISFIT},
        {"thickness": t2, "E": E2, "nu": 0.3},
    ]
    overrides = {
        "material.length": L,
        "material.layers": layers,
        "mesh.cells": [2 * cells, cells],
        "output.vtx": False,
        "output.png": False,
        "output.progress": 0,
    }
    problem = load_problem(PROBLEM, overrides)
    result, wall = run_in_scratch(comm, problem, f"{case} at {2 * cells} × {cells}", "timoshenko_")
    s = result.summary
    physical = s["physical"]
    curvatures = s["principal_curvatures"]
    exact_energy = physical["bending_stiffness_J"] * (L / R) ** 2  # ½(L/R)²·|ω|, |ω| = 2
    return {
        "cells": [2 * cells, cells],
        "dofs": s["dofs"],
        "converged": s["converged"],
        "steps": s["steps"],
        "Z": abs(physical["spontaneous_curvature_1_per_m"]) * L,
        "radius_mm": physical["cylinder_radius_mm"],
        "radius_error": physical["cylinder_radius_m"] / R - 1,
        "energy_J": physical["energy_J"],
        "energy_error": physical["energy_J"] / exact_energy - 1,
        "kappa2_over_kappa1": curvatures["kappa2_mean"] / curvatures["kappa1_mean"],
        "wall_s": wall,
    }


def table(record: dict[str, Any]) -> str:
    """The Markdown table of a record: one row per case and level."""
    rows = []
    cases = [record["cases"][name] for name in CASES if name in record["cases"]]
    for case in cases:
        for level in case["levels"]:
            nx, ny = level["cells"]
            rows.append(
                f"| {case['label']} | {case['length_mm']:.2f} | {level['Z']:.3f} "
                f"| {nx} × {ny} | {level['dofs']:,} | {level['steps']} "
                f"| {level['radius_mm']:.3f} | {case['radius_mm']:.3f} "
                f"| {100 * level['radius_error']:+.2f} % | {100 * level['energy_error']:+.2f} % "
                f"| {level['kappa2_over_kappa1']:.3f} | {case['ranks']} | {level['wall_s']:.0f} |"
            )
    return "\n".join(
        [
            f"Bilayer strips 2L × L clamped along one short side, misfit {MISFIT:g} in the bottom "
            "layer, ν = 0.3 (`benchmarks/timoshenko.py`, `benchmarks/results/timoshenko.json`). "
            "Z: the model's, derived by `[material]`; R: Timoshenko's radius; radius: the fitted "
            "cylinder's (`cylinder_radius_mm`); energy error: `energy_J` against ½Dκ²·area; "
            "κ₂/κ₁: the mean principal curvatures' ratio (0 on a cylinder).",
            "",
            "| layers (bottom / top) | L (mm) | Z | mesh | DoFs | steps | radius (mm) "
            "| R (mm) | radius error | energy error | κ₂/κ₁ | ranks | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    parser.add_argument("--cells", type=int, nargs="+", default=[8, 16, 32])
    add_page_options(parser, RESULTS / "timoshenko.json", ROOT / "docs" / "units.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record: dict[str, Any] | None = None
    if not args.table_only:
        cases = {}
        for name in args.cases:
            levels = []
            for cells in args.cells:
                levels.append(one_level(comm, name, cells))
                print0(comm, f"{name}: {levels[-1]}")
            length = CASES[name][2] or radius(name)
            cases[name] = {
                "label": CASES[name][3],
                "length_mm": length * 1e3,
                "radius_mm": radius(name) * 1e3,
                "ranks": comm.size,
                "levels": levels,
            }
        earlier = json.loads(args.json.read_text()) if args.json.exists() else {"cases": {}}
        record = {"cases": {**earlier["cases"], **cases}}
    publish(comm, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main(sys.argv[1:])
