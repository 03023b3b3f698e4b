"""The hyperbolic disc and the radial defect's anticone (demos/problems) at several mesh levels.

demos/problems/hyperbolic_disc.toml (the metric of the hyperbolic plane, K = −1) becomes a
saddle, demos/problems/lce_anticone.toml (a radial director, λ = 0.9, ν = 0.5: an excess angle
at the tip, K = 0 off it) an anticone. Per disc and level (``mesh.parameters.h``): the cells,
the start's projections, D_h, the flow's steps, E_h, K of G (its least and largest value) and
the mean K_h (summary.json's metric_gauss_curvature), the mean |K_h| over the cells with
|x| > 0.5 (:func:`dgplate.measure.prestrain.gauss_curvature_outside`), the edge's waves (the
strongest azimuthal mode of its height, :func:`dgplate.measure.prestrain.edge_waves`), the
amplitude of the second mode and the largest of the others, and the wall time. The anticone
is run again without the Gauss-curvature penalty (``without_gauss``: its mean |K_h| off the
tip, its waves and E_h).

    python benchmarks/prestrained_discs.py [--h 0.2 0.1 0.05] [--json …]
    python benchmarks/prestrained_discs.py --table-only [--json …] [--page docs/prestrain.md]

The table of docs/prestrain.md between ``<!-- prestrained_discs:begin -->`` and
``<!-- prestrained_discs:end -->`` is generated from the JSON (``--table-only``: no runs).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish, run_in_scratch, run_levels

from dgplate.measure.prestrain import edge_waves, gauss_curvature_outside
from dgplate.problems.specs import load_problem

ROOT = Path(__file__).resolve().parent.parent
PROBLEMS = ROOT / "demos" / "problems"
DISCS = ("hyperbolic_disc", "lce_anticone")
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- prestrained_discs:begin -->", "<!-- prestrained_discs:end -->"
INNER = 0.5  # the reference radius outside which |K_h| is averaged


def one_level(comm: MPI.Comm, h: float) -> dict[str, Any]:
    """Both discs at ``mesh.parameters.h = h``, and the anticone without the penalty.

    Args:
        comm: the runs' communicator (collective).
        h: the mesh size.

    Returns:
        ``{"h": h, disc: figures, …}`` with the figures of the module docstring.
    """
    record: dict[str, Any] = {"h": h}
    for name in DISCS:
        record[name] = _measure(comm, name, h)
    plain = _measure(comm, "lce_anticone", h, {"model.gauss_penalty": 0.0})
    record["lce_anticone"]["without_gauss"] = {
        key: plain[key] for key in ("converged", "energy", "off_tip", "waves", "amplitudes")
    }
    return record


def _measure(
    comm: MPI.Comm, name: str, h: float, settings: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The figures of one run, its outputs in a temporary folder, removed afterwards."""
    overrides = {"mesh.parameters.h": h, "output.vtx": False, "output.png": False}
    problem = load_problem(PROBLEMS / f"{name}.toml", {**overrides, "output.progress": 0,
                                                       **(settings or {})})  # fmt: skip
    result, wall = run_in_scratch(comm, problem, f"{name} at h = {h:g}", "disc_")
    assert result.shape is not None  # a plate's run keeps its deformation
    s, waves = result.summary, edge_waves(result.shape)
    return {
        "cells": s["cells"],
        "converged": s["converged"],
        "steps": s["steps"],
        "energy": s["energy"],
        "isometry_defect": s["isometry_defect"],
        "metric_start": s["metric_start"],
        "gauss": s["metric_gauss_curvature"],
        "off_tip": gauss_curvature_outside(result.shape, INNER),
        "waves": waves["waves"],
        "amplitudes": waves["amplitudes"],
        "wall_s": wall,
    }


def table(record: dict[str, Any]) -> str:
    """The Markdown table of a record: one row per disc and level."""
    rows = []
    for name in DISCS:
        for level in record["levels"]:
            disc = level[name]
            amplitudes = disc["amplitudes"]
            plain = disc.get("without_gauss")
            plain_off = f"{plain['off_tip']:.3f}" if plain else "–"
            rows.append(
                f"| {name} | {level['h']:g} | {disc['cells']} "
                f"| {disc['metric_start']['projection_steps']} "
                f"| {disc['isometry_defect']:.1e} | {disc['steps']} | {disc['energy']:.4g} "
                f"| {disc['gauss']['target_min']:.3g} | {disc['gauss']['target_max']:.3g} "
                f"| {disc['gauss']['mean']:.4f} | {disc['off_tip']:.3f} | {plain_off} "
                f"| {disc['waves']} | {amplitudes[1]:.3f} "
                f"| {max(amplitudes[:1] + amplitudes[2:]):.1e} | {disc['wall_s']:.1f} |"
            )
    return "\n".join(
        [
            f"The hyperbolic disc (K = −1) and the anticone (λ = 0.9, ν = 0.5), P2 on "
            f"`polar_disc.geo`, Gauss-curvature penalty β = 10, {record['ranks']} rank(s) "
            "(`benchmarks/prestrained_discs.py`, `benchmarks/results/prestrained_discs.json`). "
            "Start: the projections of the start of the file's `model.start`; K of G: its least "
            "and largest value at the cell midpoints; K_h: the area-weighted mean of the "
            f"cell-wise K_h; off tip: the mean |K_h| over |x| > {INNER:g}, with β = 10 and "
            "β = 0 (the anticone); waves: the strongest azimuthal mode of the edge's height, "
            "A₂ the amplitude of the second mode, next the largest of the others (m ≤ 8).",
            "",
            "| disc | h | cells | start | D_h | flow steps | E_h | K of G, min | max | K_h "
            "| off tip | off tip, β = 0 | waves | A₂ | next | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[0.2, 0.1, 0.05])
    add_page_options(parser, RESULTS / "prestrained_discs.json", ROOT / "docs" / "prestrain.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record: dict[str, Any] | None = None
    if not args.table_only:
        record = {"ranks": comm.size, "levels": run_levels(comm, args.h, one_level)}
    publish(comm, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main(sys.argv[1:])
