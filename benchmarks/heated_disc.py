"""The heated disc's bifurcation from the bowl to a cylinder, over mesh levels.

    python benchmarks/heated_disc.py [--levels 4 8 16] [--table-only]

Runs demos/problems/fvk_heated_disc.toml (the free disc with natural curvature λκ₀, followed by
pseudo-arclength continuation and switched at its bifurcation) on the quarter-disc O-grid with
n = 4, 8, 16 (``mesh.parameters.n``), and records per level: the dofs, the located
bifurcation's κ₀R²/t, the largest relative error of the bowl's rim height against the exact
axisymmetric state (:func:`dgplate.reference.heated_disc.sphere`), the stability indices, and the
wall time. The bifurcation is set beside the exact one
(:func:`dgplate.reference.heated_disc.bifurcation`), extrapolated (Richardson, with the observed
order of the last three levels), and set beside the uniform-curvature model's
8/(1 + ν)^{3/2}. Writes benchmarks/results/heated_disc.json and the table of docs/path_following.md between its
``heated_disc`` markers.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish, run_in_scratch

import dgplate
from dgplate.measure.richardson import extrapolate
from dgplate.reference.heated_disc import bifurcation, sphere, uniform_bifurcation

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "demos" / "problems" / "fvk_heated_disc.toml"
RESULTS = ROOT / "benchmarks" / "results" / "heated_disc.json"
PAGE = ROOT / "docs" / "path_following.md"
MARKERS = ("<!-- heated_disc:begin -->", "<!-- heated_disc:end -->")
T, NU, KAPPA0 = 0.01, 0.3, 0.1  # as in the problem file


def level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The path on the n-level quarter disc: its bifurcation, the bowl's error, the indices."""
    problem = dgplate.load_problem(PROBLEM, {"mesh.parameters.n": n})
    result, wall = run_in_scratch(comm, problem, f"n = {n}", "heated_disc_")
    rows = result.history
    at = next(i for i, row in enumerate(rows) if row["kind"] == "bifurcation")
    errors = [
        row["w_center"] / sphere(row["load_factor"] * KAPPA0, T, nu=NU).rim_height - 1
        for row in rows[1 : at + 1]
    ]
    return {
        "n": n,
        "dofs": result["dofs"],
        "bifurcation": rows[at]["load_factor"] * KAPPA0 / T,
        "bowl_error": max(errors, key=abs),
        "indices": [row["stability_index"] for row in rows],
        "kinds": [row["kind"] for row in rows if row["kind"] != "regular"],
        "wall_s": wall,
    }


def measure(comm: MPI.Comm, levels: list[int]) -> dict[str, Any]:
    """Every level, the extrapolated bifurcation and the uniform-curvature model's."""
    records = [level(comm, n) for n in levels]
    values = [r["bifurcation"] for r in records]
    model, _ = uniform_bifurcation(T, 1.0, NU)
    exact = bifurcation(T, nu=NU) / T
    for r in records:
        r["error"] = r["bifurcation"] / exact - 1
    return {
        "exact": exact,
        "thickness": T,
        "nu": NU,
        "levels": records,
        "extrapolated": extrapolate(values).as_dict(),
        "uniform_model": model / T,
        "ranks": comm.size,
    }


def _order(coarse: float, fine: float) -> str:
    """The observed order of two errors on meshes h and h/2, or blank."""
    if coarse <= 0 or fine <= 0:
        return ""
    return f"{math.log2(coarse / fine):.2f}"


def table(record: dict[str, Any]) -> str:
    """The levels' Markdown table, with the extrapolation and the model below it."""
    levels = record["levels"]
    rows = [
        "| n | dofs | κ₀R²/t at the bifurcation | error | order | bowl's rim height: largest "
        "error | indices | wall s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for i, r in enumerate(levels):
        order = _order(*(abs(x["error"]) for x in levels[i - 1 : i + 1])) if i else ""
        rows.append(
            f"| {r['n']} | {r['dofs']:,} | {r['bifurcation']:.5f} | {r['error']:+.3%} | {order} "
            f"| {r['bowl_error']:+.3%} | {''.join(map(str, r['indices']))} | {r['wall_s']:.1f} |"
        )
    limit = record["extrapolated"]
    model = record["uniform_model"]
    lines = [
        f"Exact: κ₀R²/t = {record['exact']:.5f} (`dgplate.reference.heated_disc.bifurcation`); "
        f"t = {record['thickness']}, ν = {record['nu']} ({record['ranks']} rank(s), "
        "`benchmarks/heated_disc.py`, `benchmarks/results/heated_disc.json`).",
        "",
        *rows,
    ]
    if limit["limit"] is not None:
        lines += [
            "",
            f"Extrapolated from the three finest: κ₀R²/t = {limit['limit']:.5f} (order "
            f"{limit['order']:.2f}), {limit['limit'] / record['exact'] - 1:+.4%} from the exact "
            f"value. The uniform-curvature model: 8/(1 + ν)^{{3/2}} = {model:.4f}, "
            f"{model / record['exact'] - 1:+.2%}.",
        ]
    return "\n".join(lines)


def main(argv: list[str]) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[4, 8, 16], help="n per level")
    add_page_options(parser, RESULTS, PAGE)
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record = None if args.table_only else measure(comm, args.levels)
    publish(comm, args, record, MARKERS, table)
    return record or {}


if __name__ == "__main__":
    main(sys.argv[1:])
