"""The prestrained disc of demos/problems/spherical_disc.toml at several mesh levels.

The disc |x| < 1 with the metric of a sphere of radius R = 2 (free boundary, no load) becomes
the spherical cap (dgplate.reference.spherical_cap). Per level (``mesh.parameters.h``): the
cells, the energy E_h and its error against the cap's, E_h of the interpolated cap, the radius of the least-squares sphere
through the nodal values and its error, the metric start (stretching steps, projections, its
D_h and time), the flow's steps, K_h against K = 1/R² (summary.json's metric_gauss_curvature)
and the wall time. The observed orders take the mesh size as
(cells)^(-1/2) (the polar mesh's h is a target, not the cells' size). Each level is run three
times: with the problem file's Gauss-curvature penalty (``model.gauss_penalty``), without it
(``without_gauss``: the energy, radius and K_h figures and the wall time), and with the
penalty and the trace term of Poisson's ratio ``POISSON`` (``with_poisson``: the energy
against the cap's with that ν, the radius, the wall time).

    python benchmarks/spherical_cap.py [--h 0.2 0.1 0.05 0.025] [--json …]
    python benchmarks/spherical_cap.py --table-only [--json …] [--page docs/prestrain.md]

The table of docs/prestrain.md between ``<!-- spherical_cap:begin -->`` and
``<!-- spherical_cap:end -->`` is generated from the JSON (``--table-only``: no runs).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish, run_in_scratch, run_levels

from dgplate.measure.analysis import fit_sphere
from dgplate.problems.prepare import build_model
from dgplate.problems.specs import Problem, load_problem
from dgplate.reference.spherical_cap import cap, energy
from dgplate.solvers.driver import EnergyFlow

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "spherical_disc.toml"
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- spherical_cap:begin -->", "<!-- spherical_cap:end -->"
RADIUS = 2.0


#: The comparison run of each level: the file's problem without the Gauss-curvature penalty.
WITHOUT_GAUSS = {"model.gauss_penalty": 0.0}
#: Poisson's ratio of the third run of each level (the energy's trace term, ``model.poisson``).
POISSON = 0.3


def one_level(comm: MPI.Comm, h: float) -> dict[str, Any]:
    """The disc at ``mesh.parameters.h = h``: its figures, and those without the penalty.

    Args:
        comm: the runs' communicator (collective).
        h: the mesh size ``mesh.parameters.h``.

    Returns:
        The figures of the module docstring; ``without_gauss`` those of the run with
        ``model.gauss_penalty = 0`` (no interpolant, no metric start).
    """
    record = _measure(comm, h)
    baseline = _measure(comm, h, WITHOUT_GAUSS, interpolant=False)
    record["without_gauss"] = {
        key: baseline[key]
        for key in ("converged", "steps", "energy", "energy_error", "radius_error", "wall_s")
    }
    record["without_gauss"]["gauss"] = baseline["gauss"]
    exact = energy(RADIUS, poisson=POISSON)
    # the trace term scales the bending energy by 1 + c = 1/(1 − ν), and its gradient with it:
    # the file's stationarity tolerance is scaled alike (at h = 0.025 the unscaled one sits at
    # the round-off floor of ‖P DE_h‖: 8.2e-9 against 1e-8 with ν = 0)
    tol = load_problem(PROBLEM).flow.tol / (1 - POISSON)
    settings = {"model.poisson": POISSON, "flow.tol": tol}
    trace = _measure(comm, h, settings, interpolant=False, exact=exact)
    record["with_poisson"] = {
        key: trace[key]
        for key in ("converged", "steps", "energy", "energy_error", "radius_error", "wall_s")
    }
    return record


def _measure(
    comm: MPI.Comm,
    h: float,
    settings: dict[str, Any] | None = None,
    interpolant: bool = True,
    exact: float | None = None,
) -> dict[str, Any]:
    """The figures of one run (``exact``: the energy to compare, None: the cap's with ν = 0)."""
    overrides = {"mesh.parameters.h": h, "output.vtx": False, "output.png": False}
    problem = load_problem(PROBLEM, {**overrides, "output.progress": 0, **(settings or {})})
    result, wall = run_in_scratch(comm, problem, f"h = {h:g}", "cap_")
    assert result.shape is not None  # a plate's run keeps its deformation
    fit = fit_sphere(result.shape)
    s = result.summary
    exact = energy(RADIUS) if exact is None else exact
    return {
        "h": h,
        "cells": s["cells"],
        "converged": s["converged"],
        "steps": s["steps"],
        "energy": s["energy"],
        "energy_error": (s["energy"] - exact) / exact,
        "interpolant_energy": cap_energy(problem, comm) if interpolant else None,
        "radius": fit["radius"],
        "radius_error": (fit["radius"] - RADIUS) / RADIUS,
        "rms": fit["rms"],
        "isometry_defect": s["isometry_defect"],
        "metric_start": s["metric_start"],
        "gauss": s["metric_gauss_curvature"],
        "wall_s": wall,
    }


def cap_energy(problem: Problem, comm: MPI.Comm) -> float:
    """E_h of the exact cap interpolated on the problem's mesh (collective)."""
    _, model = build_model(problem, comm)
    flow = model.driver(problem.flow, [], lambda x: cap(x, RADIUS))
    assert isinstance(flow, EnergyFlow)  # the kirchhoff plate's gradient flow
    value = flow.evaluate_energy()
    flow.destroy()
    return value


def _order(errors: list[float], cells: list[int], i: int) -> str:
    """The observed order between levels i − 1 and i (mesh size ∝ cells^(-1/2))."""
    if i == 0 or errors[i] == 0 or errors[i - 1] == 0:
        return ""
    ratio = math.log(abs(errors[i - 1]) / abs(errors[i]))
    return f"{ratio / (0.5 * math.log(cells[i] / cells[i - 1])):.2f}"


def table(record: dict[str, Any]) -> str:
    """The Markdown tables of a record: one row per level, with and without the penalty."""
    return "\n\n".join([_main_table(record), _comparison_table(record), _poisson_table(record)])


def _main_table(record: dict[str, Any]) -> str:
    """The levels with the file's settings: radius, energy, metric start, K_h, time."""
    levels = record["levels"]
    cells = [level["cells"] for level in levels]
    radius = [level["radius_error"] for level in levels]
    energies = [level["energy_error"] for level in levels]
    rows = []
    for i, level in enumerate(levels):
        start = level["metric_start"]
        rows.append(
            f"| {level['h']:g} | {level['cells']} | {level['radius']:.6f} "
            f"| {level['radius_error']:+.2e} | {_order(radius, cells, i)} "
            f"| {level['energy']:.6f} | {level['energy_error']:+.2%} "
            f"| {_order(energies, cells, i)} | {level['interpolant_energy']:.6f} "
            f"| {start['stretching_steps']} + {start['projection_steps']} "
            f"| {start['defect']:.1e} | {start['seconds']:.1f} | {level['steps']} "
            f"| {level['gauss']['mean']:.4f} | {level['gauss']['error_mean']:.4f} "
            f"| {level['gauss']['error_max']:.3f} | {level['wall_s']:.1f} |"
        )
    return "\n".join(
        [
            f"The disc with the metric of a sphere of radius 2, P2 on `polar_disc.geo`, "
            f"Gauss-curvature penalty β = {record['gauss_penalty']:g}, "
            f"{record['ranks']} rank(s) (`benchmarks/spherical_cap.py`, "
            f"`benchmarks/results/spherical_cap.json`); exact E = {record['exact_energy']:.6f}. "
            "Start: stretching steps + projections of the metric start, its D_h and seconds; "
            "order: observed, with the mesh size ∝ cells^(-1/2); I_h cap: E_h of the exact cap "
            "interpolated; K_h: the area-weighted mean of the cell-wise K_h, the mean and the "
            "largest |K_h − K| (K = 1/4).",
            "",
            "| h | cells | radius | error | order | E_h | error | order | I_h cap | start | D_h "
            "| start s | flow steps | K_h | mean err | max err | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def _comparison_table(record: dict[str, Any]) -> str:
    """The levels with β against β = 0: energy and radius errors, largest |K_h − K|, time."""
    beta = f"{record['gauss_penalty']:g}"
    rows = []
    for level in record["levels"]:
        plain = level["without_gauss"]
        rows.append(
            f"| {level['h']:g} | {plain['energy_error']:+.2%} | {level['energy_error']:+.2%} "
            f"| {plain['radius_error']:+.2e} | {level['radius_error']:+.2e} "
            f"| {plain['gauss']['error_max']:.3f} | {level['gauss']['error_max']:.3f} "
            f"| {plain['wall_s']:.1f} | {level['wall_s']:.1f} |"
        )
    return "\n".join(
        [
            f"The same levels without the Gauss-curvature penalty (β = 0) and with it "
            f"(β = {beta}): the errors of E_h and of the fitted radius, the largest |K_h − K| "
            "and the wall time.",
            "",
            f"| h | E_h error, β = 0 | β = {beta} | radius error, β = 0 | β = {beta} "
            f"| max K_h error, β = 0 | β = {beta} | wall s, β = 0 | β = {beta} |",
            "|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def _poisson_table(record: dict[str, Any]) -> str:
    """The levels with the trace term of Poisson's ratio ν: energy and radius errors, orders."""
    levels = record["levels"]
    cells = [level["cells"] for level in levels]
    runs = [level["with_poisson"] for level in levels]
    energies = [run["energy_error"] for run in runs]
    radius = [run["radius_error"] for run in runs]
    rows = [
        f"| {level['h']:g} | {run['energy']:.6f} | {run['energy_error']:+.3%} "
        f"| {_order(energies, cells, i)} | {run['radius_error']:+.2e} "
        f"| {_order(radius, cells, i)} | {run['steps']} | {run['wall_s']:.1f} |"
        for i, (level, run) in enumerate(zip(levels, runs, strict=True))
    ]
    nu = record["poisson"]
    return "\n".join(
        [
            f"The same levels with the trace term, `model.poisson = {nu:g}` (β = "
            f"{record['gauss_penalty']:g}; `flow.tol` divided by 1 − ν, as the energy is): exact "
            f"E = {record['exact_energy_poisson']:.6f} (`spherical_cap.energy(2, poisson={nu:g})`).",
            "",
            "| h | E_h | error | order | radius error | order | flow steps | wall s |",
            "|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[0.2, 0.1, 0.05, 0.025])
    add_page_options(parser, RESULTS / "spherical_cap.json", ROOT / "docs" / "prestrain.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record: dict[str, Any] | None = None
    if not args.table_only:
        levels = run_levels(comm, args.h, one_level)
        beta = load_problem(PROBLEM).model.gauss_penalty
        record = {
            "ranks": comm.size,
            "exact_energy": energy(RADIUS),
            "gauss_penalty": beta,
            "poisson": POISSON,
            "exact_energy_poisson": energy(RADIUS, poisson=POISSON),
            "levels": levels,
        }
    publish(comm, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main(sys.argv[1:])
