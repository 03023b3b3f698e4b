"""The +1 azimuthal defect of demos/problems/lce_cone.toml at several mesh levels.

A disc with the azimuthal director θ = polar angle + π/2, λ = 0.9, ν = 0.5 (free boundary,
no load) becomes a cone of half-angle φ with sin φ = λ^(1+ν) (Modes, Bhattacharya and Warner
2011). Per level (``mesh.parameters.h``): the cells, the metric start (stretching steps,
projections, its D_h), the flow's steps, E_h and its broken bending integral, the half-angle fitted over |x| > 0.3 and
|x| > 0.5 (:func:`dgplate.measure.prestrain.cone_half_angle`) and its error, the mean K_h
against K = 0, and the wall time.

    python benchmarks/lce_cone.py [--h 0.2 0.1 0.05] [--json …]
    python benchmarks/lce_cone.py --table-only [--json …] [--page docs/prestrain.md]

The table of docs/prestrain.md between ``<!-- lce_cone:begin -->`` and ``<!-- lce_cone:end -->``
is generated from the JSON (``--table-only``: no runs).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import ufl
from pages import add_page_options, publish, run_in_scratch, run_levels

from dgplate.compat import Function
from dgplate.dg.forms import hessian, metric_weighted
from dgplate.measure.prestrain import cone_half_angle
from dgplate.models.metric import target_metric
from dgplate.problems.specs import Problem, load_problem

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "lce_cone.toml"
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- lce_cone:begin -->", "<!-- lce_cone:end -->"
STRETCH, NU = 0.9, 0.5
INNER = (0.3, 0.5)


def exact_angle() -> float:
    """φ = asin(λ^(1+ν)) in radians."""
    return math.asin(STRETCH ** (1 + NU))


def one_level(comm: MPI.Comm, h: float) -> dict[str, Any]:
    """The disc at ``mesh.parameters.h = h``: its figures (module docstring).

    The run's outputs go to a temporary folder, removed afterwards.
    """
    overrides = {"mesh.parameters.h": h, "output.vtx": False, "output.png": False}
    problem = load_problem(PROBLEM, {**overrides, "output.progress": 0})
    result, wall = run_in_scratch(comm, problem, f"h = {h:g}", "cone_")
    assert result.shape is not None  # a plate's run keeps its deformation
    angles = {str(inner): cone_half_angle(result.shape, inner) for inner in INNER}
    bending = broken_bending(result.shape, problem)
    s = result.summary
    return {
        "h": h,
        "cells": s["cells"],
        "converged": s["converged"],
        "steps": s["steps"],
        "energy": s["energy"],
        "broken_bending": bending,
        "isometry_defect": s["isometry_defect"],
        "metric_start": s["metric_start"],
        "half_angle_deg": {k: math.degrees(v) for k, v in angles.items()},
        "half_angle_error": {k: v / exact_angle() - 1 for k, v in angles.items()},
        "gauss": s["metric_gauss_curvature"],
        "wall_s": wall,
    }


def broken_bending(y: Function, problem: Problem) -> float:
    """½∫|G^{-1/2} D²y G^{-1/2}|² of the broken Hessian alone (E_h without its facet terms)."""
    mesh = y.function_space.mesh
    spec = problem.model.target_metric
    D2 = hessian(y)
    weighted = ufl.inner(D2, metric_weighted(D2, target_metric(spec, mesh, "model.director")))
    form = dolfinx.fem.form(0.5 * weighted * ufl.dx(metadata={"quadrature_degree": 6}))
    return float(mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM))


def table(record: dict[str, Any]) -> str:
    """The Markdown table of a record: one row per level."""
    rows = []
    for level in record["levels"]:
        start, phi, error = (
            level["metric_start"],
            level["half_angle_deg"],
            level["half_angle_error"],
        )
        rows.append(
            f"| {level['h']:g} | {level['cells']} "
            f"| {start['stretching_steps']} + {start['projection_steps']} "
            f"| {level['isometry_defect']:.1e} | {level['steps']} | {level['energy']:.2f} "
            f"| {level['broken_bending']:.3f} "
            + "".join(f"| {phi[str(i)]:.3f} | {error[str(i)]:+.1e} " for i in INNER)
            + f"| {level['gauss']['mean']:.3f} | {level['wall_s']:.1f} |"
        )
    return "\n".join(
        [
            f"The azimuthal defect (λ = {STRETCH}, ν = {NU}), P2 on `polar_disc.geo`, "
            f"{record['ranks']} rank(s) (`benchmarks/lce_cone.py`, "
            f"`benchmarks/results/lce_cone.json`); exact φ = {record['exact_deg']:.3f}°. "
            "Start: stretching steps + projections of the metric start; bending: "
            "½∫|G^(-1/2) D²y G^(-1/2)|² of the broken Hessian alone (E_h without its facet "
            "terms); φ fitted over "
            "|x| > 0.3 and |x| > 0.5, its relative error; K_h: the area-weighted mean of the cell-wise K_h "
            "(K = 0 off the tip).",
            "",
            "| h | cells | start | D_h | flow steps | E_h | bending | φ (0.3) | error | φ (0.5) "
            "| error | K_h | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[0.2, 0.1, 0.05])
    add_page_options(parser, RESULTS / "lce_cone.json", ROOT / "docs" / "prestrain.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record: dict[str, Any] | None = None
    if not args.table_only:
        levels = run_levels(comm, args.h, one_level)
        record = {"ranks": comm.size, "exact_deg": math.degrees(exact_angle()), "levels": levels}
    publish(comm, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main(sys.argv[1:])
