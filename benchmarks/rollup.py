"""Roll-ups through ¼, ½ and 1 turn: the steps of adaptive τ against the roll-up angle.

A 12 × 1 strip clamped on its short side x₁ = 0, bilayer Z = diag(κ, 0) with κ·12 = 2π·turns,
rolls into a cylinder of radius 1/κ; the exact minimiser has II = Z, E = 0. The settings are
those of demos/problems/bilayer_cylinder.toml (Q2, penalties, two projection steps, edge
constraint, degree-1 multipliers) with adaptive τ from τ = h, the SQP finish and the
stationarity stop ‖P DE_h‖_*' < ``--tol``. Each angle runs with both step controls
(``flow.step_control``): ``defect_bound`` (plain steps below the defect bound, SQP steps from
τ ≥ 100 h) and ``trust_region`` (SQP steps from the first step, τ a trust radius).

Per run the record holds the steps, the attempts (accepted and refused steps), the step solves
(every solve with a step or SQP matrix, corrections included), the factorisations, the wall
time, E_h and D_h.

    python benchmarks/rollup.py --cells 96 8 [--json benchmarks/results/rollup.json]
    python benchmarks/rollup.py --controls trust_region --keep --note "…"
    python benchmarks/rollup.py --table-only [--json …] [--page docs/performance.md]

``--keep`` keeps the JSON's runs of the angles and controls not run now (same cells and
tolerance), e.g. the long defect-bound runs when only the trust region changed; ``--note``
says where the rows come from.

The table of docs/performance.md between ``<!-- rollup:begin -->`` and ``<!-- rollup:end -->``
is generated from the JSON (``--table-only``: no runs).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish

from dgplate.io.output import print0
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import Problem, load_problem

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "bilayer_cylinder.toml"
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- rollup:begin -->", "<!-- rollup:end -->"
TURNS = (0.25, 0.5, 1.0)
CONTROLS = ("defect_bound", "trust_region")
LENGTH = 12.0


def problem(turns: float, cells: list[int], control: str, tol: float = 1e-6) -> Problem:
    """The strip rolling through ``turns`` turns on ``cells`` Q2 cells with ``control``.

    Args:
        turns: the roll-up angle in turns (κ·12 = 2π·turns).
        cells: cells along and across the strip.
        control: ``flow.step_control``.
        tol: the stationarity tolerance.

    Returns:
        The validated problem.
    """
    kappa = 2 * math.pi * turns / LENGTH
    overrides: dict[str, Any] = {
        "mesh.corners": [[0.0, 0.0], [LENGTH, 1.0]],
        "mesh.cells": cells,
        "model.Z": [[kappa, 0.0], [0.0, 0.0]],
        "flow.tau": "h",
        "flow.tol": tol,
        "flow.stop": "stationarity",
        "flow.adaptive_tau": True,
        "flow.step_control": control,
        "flow.max_steps": 1000,
        "flow.checkpoint_every": 0,
        "output.vtx": False,
        "output.png": False,
        "output.progress": 0,
    }
    return load_problem(PROBLEM, [f"{k}={json.dumps(v)}" for k, v in overrides.items()])


def one_run(comm: MPI.Comm, turns: float, cells: list[int], control: str, tol: float) -> dict:
    """One roll-up to the stationarity stop; its counts and result."""
    folder = comm.bcast(tempfile.mkdtemp(prefix="rollup_") if comm.rank == 0 else None, root=0)
    t0 = time.perf_counter()
    result = run_problem(problem(turns, cells, control, tol), Path(folder) / "run", comm)
    wall = time.perf_counter() - t0
    s = result.summary
    return {
        "turns": turns,
        "control": control,
        "converged": s["converged"],
        "steps": s["steps"],
        "attempts": s["steps"] + s["rejected_steps"] + s["newton_rejections"],
        "rejected_steps": s["rejected_steps"],
        "newton_steps": s["newton_steps"],
        "newton_rejections": s["newton_rejections"],
        "step_solves": s["step_solves"],
        "factorisations": s["factorisations"],
        "newton_factorisations": s["newton_factorisations"],
        "energy": s["energy"],
        "isometry_defect": s["isometry_defect"],
        "wall_s": wall,
    }


def table(record: dict[str, Any]) -> str:
    """The Markdown table of a record: per angle, the two controls side by side."""
    runs = {(r["turns"], r["control"]): r for r in record["runs"]}
    rows = []
    for turns in sorted({t for t, _ in runs}):
        old, new = runs.get((turns, CONTROLS[0])), runs.get((turns, CONTROLS[1]))
        for run in (old, new):
            if run is None:
                continue
            rows.append(
                f"| {turns:g} | {run['control']} | {run['steps']} | {run['attempts']} "
                f"| {run['step_solves']} | {run['newton_factorisations']} "
                f"| {run['wall_s']:.1f} | {run['energy']:.10e} | {run['isometry_defect']:.1e} |"
            )
        if old and new:
            rows.append(
                f"| {turns:g} | difference | | | | | | {new['energy'] - old['energy']:+.1e} "
                f"| {new['isometry_defect'] - old['isometry_defect']:+.1e} |"
            )
    cells = "×".join(str(c) for c in record["cells"])
    return "\n".join(
        [
            f"Roll-up of a 12 × 1 strip, Z = diag(κ, 0), {cells} Q2 cells, {record['ranks']} "
            f"rank(s), stop ‖P DE_h‖_*' < {record['tol']:g} "
            "(`benchmarks/rollup.py`, `benchmarks/results/rollup.json`). Attempts: accepted and "
            "refused steps; step solves: every solve with a step or SQP matrix, corrections "
            "included; SQP LU: factorisations of the SQP matrix."
            + (f" Runs: {record['note']}." if record.get("note") else ""),
            "",
            "| turns | step control | steps | attempts | step solves | SQP LU | wall s | E_h | D_h |",
            "|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def kept_runs(previous: dict[str, Any], record: dict[str, Any]) -> list[dict[str, Any]]:
    """``previous``'s runs of the angles and controls ``record`` has not, if comparable."""
    same = all(previous.get(key) == record[key] for key in ("cells", "ranks", "tol"))
    done = {(run["turns"], run["control"]) for run in record["runs"]}
    if not same:
        return []
    return [run for run in previous["runs"] if (run["turns"], run["control"]) not in done]


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs=2, default=[96, 8])
    parser.add_argument("--turns", type=float, nargs="+", default=list(TURNS))
    parser.add_argument("--controls", nargs="+", choices=CONTROLS, default=list(CONTROLS))
    parser.add_argument("--tol", type=float, default=1e-6, help="stationarity tolerance")
    parser.add_argument("--keep", action="store_true", help="keep the JSON's other runs")
    parser.add_argument("--note", default="", help="where the runs come from (in the JSON)")
    add_page_options(parser, RESULTS / "rollup.json", ROOT / "docs" / "performance.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    record: dict[str, Any] | None = None
    if not args.table_only:
        runs = []
        for turns in args.turns:
            for control in args.controls:
                runs.append(one_run(comm, turns, args.cells, control, args.tol))
                print0(comm, json.dumps(runs[-1]))
        record = {"cells": args.cells, "ranks": comm.size, "tol": args.tol, "runs": runs}
        if args.keep and args.json.exists():
            record["runs"] = kept_runs(json.loads(args.json.read_text()), record) + runs
        if args.note:
            record["note"] = args.note
    publish(comm, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main(sys.argv[1:])
