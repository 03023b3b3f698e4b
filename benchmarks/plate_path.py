"""Path following on a constrained plate: the turned strip as an isometric plate (an elastica).

demos/problems/turned_strip.toml: a strip of span 1 and width 0.05, its ends pushed together by
Δ = 0.01 and started buckled down, whose clamps turn by ±0.25λ against the buckle. Being
isometric, the plate is an inextensible elastica: its inverted state bifurcates and folds at the
clamp angles of :func:`dgplate.reference.turned_elastica.turned_strip_elastica_thresholds` at
t = 0. The study follows the path on n × 1 cells for each level, locates both, and writes their
errors and observed orders to ``benchmarks/results/plate_path.json`` and the table of
docs/path_following.md between ``<!-- plate_path_turned:begin -->`` and its end marker::

    python benchmarks/plate_path.py [--levels 16 32 64 128 256]
    python benchmarks/plate_path.py --table-only [--json …] [--page …]
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, write_between
from path_following import markdown_table, orders, runs

import dgplate
from dgplate.io.output import print0
from dgplate.reference.turned_elastica import turned_strip_elastica_thresholds

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
PROBLEM = ROOT / "demos" / "problems" / "turned_strip.toml"
#: The end shortening and the full clamp angle of the problem file (λ = 1: α = 0.25).
DELTA, ALPHA = 0.01, 0.25


@functools.cache
def exact() -> tuple[float, float]:
    """The bifurcation and the fold in load factor: the elastica's angles over the full angle.

    Computed at the first call, not at import (2.5 s of shooting, which every pytest process
    that collects tests/solvers/test_constrained_path.py paid).
    """
    thresholds = turned_strip_elastica_thresholds(DELTA)
    return thresholds["bifurcation"] / ALPHA, thresholds["fold"] / ALPHA


LEVELS = [16, 32, 64, 128, 256]
QUIET = {"output.vtx": False, "output.png": False, "output.progress": 0}


def level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The bifurcation and the fold of the strip on n × 1 cells (collective)."""
    folder = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0)
    problem = dgplate.load_problem(PROBLEM, {**QUIET, "mesh.cells": [n, 1]})
    t0 = time.perf_counter()
    branch = dgplate.follow(problem, out=Path(folder) / "path", comm=comm)
    wall = time.perf_counter() - t0
    found = (branch.bifurcations[0], branch.folds[0])
    return {
        "n": n,
        "dofs": branch.result["dofs"],
        "bifurcation": found[0],
        "fold": found[1],
        "errors": [f / e - 1 for f, e in zip(found, exact(), strict=True)],
        "indices": runs(branch.stability_indices),
        "defect": max(point["isometry_defect"] for point in branch.points),
        "wall_s": wall,
    }


def measure(comm: MPI.Comm, levels: list[int]) -> dict[str, Any]:
    """The study at its levels (collective): the record of the JSON."""
    study = [level(comm, n) for n in levels]
    for k in range(2):
        for lv, order in zip(study, orders([lv["errors"][k] for lv in study]), strict=True):
            lv.setdefault("orders", []).append(order)
    return {"ranks": comm.size, "exact": list(exact()), "delta": DELTA, "turned": study}


def _cells(value: float, error: float, order: float | None) -> str:
    """λ, its error and its order as three table cells."""
    shown = "" if order is None else f"{order:.2f}"
    return f"{value:.6f} | {error:+.3%} | {shown}"


def table(record: dict[str, Any]) -> str:
    """The Markdown table of the strip's bifurcation and fold."""
    rows = [
        f"| {lv['n']} × 1 | {lv['dofs']} | "
        f"{_cells(lv['bifurcation'], lv['errors'][0], lv['orders'][0])} | "
        f"{_cells(lv['fold'], lv['errors'][1], lv['orders'][1])} | "
        f"{' → '.join(map(str, lv['indices']))} | {lv['defect']:.1e} | {lv['wall_s']:.1f} |"
        for lv in record["turned"]
    ]
    bifurcation, fold = record["exact"]
    return markdown_table(
        (
            f"Exact (the inextensible elastica at Δ = {record['delta']:g}): λ = "
            f"{bifurcation:.6f} (bifurcation) and {fold:.6f} (fold); order: log₂ of successive "
            "error ratios; indices: along the path; defect: the largest isometry defect of its "
            f"points ({record['ranks']} rank(s), `benchmarks/plate_path.py`, "
            "`benchmarks/results/plate_path.json`)."
        ),
        (
            "| cells | dofs | bifurcation λ | error | order | fold λ | error | order | indices "
            "| defect | wall s |"
        ),
        rows,
    )


def main(argv: list[str]) -> dict[str, Any]:
    """Run the study (or only rewrite the table) and write the JSON and the page's table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", type=int, nargs="+", default=LEVELS, help="cells along")
    add_page_options(parser, RESULTS / "plate_path.json", ROOT / "docs" / "path_following.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.table_only:
        record = json.loads(args.json.read_text())
    else:
        record = measure(comm, args.levels)
        print0(comm, json.dumps(record))
        if comm.rank == 0:
            args.json.write_text(json.dumps(record, indent=2) + "\n")
    if comm.rank == 0:
        begin, end = "<!-- plate_path_turned:begin -->", "<!-- plate_path_turned:end -->"
        write_between(args.page, begin, end, f"{begin}\n{table(record)}\n{end}")
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
