"""Seed 000's free-boundary experiment: our levels beside the lecture's DKT table.

    python benchmarks/seed000_free_boundary.py [--cells 8 16 32 64] [--budget 600]
        [--json benchmarks/results/seed000_free_boundary.json] [--page docs/verification.md]
    python benchmarks/seed000_free_boundary.py --table-only   # the page from the JSON

Bartels [BL], "Experiment: free boundary": ω = (0, 4)², clamped flat on {0} × [0, 4] ∪
[0, 4] × {0}, f = 2.5·10⁻²·e₃, α = 1, τ = h, discrete Kirchhoff triangles at ĥ = 2⁻³ … 2⁻⁶,
with E_h, ‖δI_h‖_L¹ and ‖K_h‖_L¹. Each level runs ``demos/problems/free_boundary_seed000.toml``
(dG P2 on n × n halved squares, n = 1/ĥ) through dgplate's run path, one level after the
other, serially; a level whose predicted time (the last one's times its growth, at least 4)
does not fit in what is left of ``--budget`` seconds is not started. The JSON holds both
tables; the table between the page's markers ``<!-- seed000:begin -->`` and
``<!-- seed000:end -->`` is generated from it.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import write_between

from dgplate.io.output import print0
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import load_problem

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "free_boundary_seed000.toml"
BEGIN, END = "<!-- seed000:begin -->", "<!-- seed000:end -->"

#: The lecture's table: ĥ, N_iter, E_h, ‖δI_h‖_L¹, ‖K_h‖_L¹ (DKT, τ = h).
SEED_TABLE = [
    {"h_hat": 2**-3, "steps": 40, "energy": -9.821e-3, "defect_l1": 7.124e-3, "gauss_l1": 3.043e-3},
    {"h_hat": 2**-4, "steps": 71, "energy": -9.041e-3, "defect_l1": 5.143e-3, "gauss_l1": 2.308e-3},
    {"h_hat": 2**-5, "steps": 130, "energy": -7.666e-3, "defect_l1": 3.032e-3, "gauss_l1": 1.469e-3},
    {"h_hat": 2**-6, "steps": 272, "energy": -6.024e-3, "defect_l1": 1.511e-3, "gauss_l1": 8.656e-4},
]  # fmt: skip


def run_level(cells: int, out: Path) -> dict[str, Any]:
    """One level: the problem file on cells × cells × 2 triangles; its figures."""
    overrides = [f"mesh.cells=[{cells}, {cells}]", "output.progress=0", "output.vtx=false"]
    result = run_problem(load_problem(PROBLEM, overrides), out / f"n{cells}")
    s = result.summary
    return {
        "cells": cells,
        "h_hat": 1.0 / cells,
        "dofs": s["dofs"],
        "tau": s["tau"],
        "steps": s["steps"],
        "converged": s["converged"],
        "energy": s["energy"],
        "defect_l1": s["isometry_defect_l1"],
        "gauss_l1": s["gauss_curvature_l1"],
        "isometry_defect": s["isometry_defect"],
        "wall_s": s["wall_time_s"],
    }


def run_levels(
    cells: list[int], budget: float, out: Path
) -> tuple[list[dict[str, Any]], list[int]]:
    """Our levels in order, within ``budget`` seconds; the rows and the sizes left out."""
    comm = MPI.COMM_WORLD
    start = time.perf_counter()
    rows: list[dict[str, Any]] = []
    skipped: list[int] = []
    for n in cells:
        left = budget - (time.perf_counter() - start)
        growth = rows[-1]["wall_s"] / rows[-2]["wall_s"] if len(rows) > 1 else 4.0
        predicted = rows[-1]["wall_s"] * max(growth, 4.0) if rows else 0.0
        if skipped or predicted > left:
            skipped.append(n)
            print0(comm, f"n = {n}: predicted {predicted:.0f} s > {left:.0f} s left: not run")
            continue
        rows.append(run_level(n, out))
        r = rows[-1]
        print0(
            comm,
            f"n = {n}: {r['dofs']:,} dofs, {r['steps']} steps, {r['wall_s']:.1f} s, "
            f"E_h = {r['energy']:.4e}",
        )
    return rows, skipped


def number(x: float) -> str:
    """``-9.821e-03`` as the docs write it: −9.821e−3."""
    mantissa, exponent = f"{x:.3e}".split("e")
    return f"{mantissa}e{int(exponent)}".replace("-", "−")


def power_of_two(n: int) -> str:
    """ĥ = 1/n for n a power of two, as 2⁻ᵏ."""
    superscript = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")
    return f"2⁻{str(n.bit_length() - 1).translate(superscript)}"


def table(record: dict[str, Any]) -> str:
    """The page's section: per ĥ, our run beside the lecture's row, between the markers."""
    ours = {round(1 / r["h_hat"]): r for r in record["ours"]}
    lines = [
        BEGIN,
        "",
        "| ĥ | n | DoFs | steps (ours / DKT) | E_h (ours) | E_h (DKT) | ‖δI_h‖_L¹ (ours) "
        "| ‖δI_h‖_L¹ (DKT) | ‖K_h‖_L¹ (ours) | ‖K_h‖_L¹ (DKT) | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for seed in record["seed"]:
        n = round(1 / seed["h_hat"])
        r = ours.get(n)
        figures = ("energy", "defect_l1", "gauss_l1")
        mine = (
            [
                f"{r['dofs']:,}",
                f"{r['steps']}",
                *(number(r[k]) for k in figures),
                f"{r['wall_s']:.0f}",
            ]
            if r
            else ["–", "–", "not run", "–", "–", "–"]
        )
        lines.append(
            f"| {power_of_two(n)} | {n} | {mine[0]} | {mine[1]} / {seed['steps']} | {mine[2]} "
            f"| {number(seed['energy'])} | {mine[3]} | {number(seed['defect_l1'])} | {mine[4]} "
            f"| {number(seed['gauss_l1'])} | {mine[5]} |"
        )
    lines += ["", END]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the levels (unless ``--table-only``), write the JSON and the page's table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[8, 16, 32, 64])
    parser.add_argument("--budget", type=float, default=600.0, help="seconds for all levels")
    parser.add_argument("--out", type=Path, default=Path("out/seed000_free_boundary"))
    parser.add_argument(
        "--json", type=Path, default=ROOT / "benchmarks/results/seed000_free_boundary.json"
    )
    parser.add_argument("--page", type=Path, default=ROOT / "docs/verification.md")
    parser.add_argument("--table-only", action="store_true", help="the page from the JSON")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.table_only:
        record = json.loads(args.json.read_text())
    else:
        rows, skipped = run_levels(args.cells, args.budget, args.out)
        record = {
            "problem": PROBLEM.name,
            "discretisation": "dG P2 on n × n halved squares ('right' diagonal), n = 1/ĥ",
            "ranks": comm.size,
            "ours": rows,
            "not_run": skipped,
            "seed": SEED_TABLE,
        }
        if comm.rank == 0:
            args.json.write_text(json.dumps(record, indent=2) + "\n")
    if comm.rank == 0:
        text = table(record)
        write_between(args.page, BEGIN, END, text)
        print(text)
    return record


if __name__ == "__main__":
    main()
