"""The BNN vertical-load plate past Table 1: 256² cells (1.97 M DoFs) to the published stop.

The run goes through dgplate's own run path (``demos/problems/vertical_load.toml`` with the
mesh refined), so it writes checkpoints as it goes: run the same command again after an
interruption and it resumes from the last one. At the end the record (E_h, D_h, steps, time
per step, factorisations, peak memory) is written as JSON for ``benchmarks/report.py``.

    mpirun -n 2 python benchmarks/bnn_large.py --cells 256 --out out/bnn256 \
        --json benchmarks/results/bnn_256_np2.json

The factors are MUMPS's LDLᵀ (the flow's default) with block low-rank compression
(``--blr``, default 1e-8, 0 for none): at 256² uncompressed factors and the step matrices
would not leave room in 24 GB.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.io.output import CHECKPOINT, print0
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import load_problem
from dgplate.reference.bnn import BNN_TABLE1

PROBLEM = Path(__file__).resolve().parent.parent / "demos" / "problems" / "vertical_load.toml"


def overrides(cells: int, blr: float) -> list[str]:
    """The problem file's keys for this run: the mesh, checkpoints, light output."""
    solver = (
        f"{{mat_mumps_icntl_35 = 2, mat_mumps_cntl_7 = {blr:g}, mat_mumps_icntl_37 = 1}}"
        if blr > 0
        else "{}"
    )
    return [
        f"mesh.cells=[{cells}, {cells}]",
        f"flow.solver={solver}",
        "flow.max_steps=2000",
        "flow.checkpoint_every=10",
        "output.every=100",
        "output.png=false",  # the picture would gather the surface on rank 0 next to the factors
        "output.progress=10",
    ]


def history_figures(path: Path) -> dict[str, Any]:
    """Time per step, factorisations and Krylov iterations from history.csv."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    seconds = [float(r["seconds"]) for r in rows]
    factor = [float(r["factor_s"]) for r in rows]
    return {
        "per_step_s": sum(seconds) / max(len(seconds), 1),
        "breakdown_per_step_s": {
            key: sum(float(r[f"{key}_s"]) for r in rows) / max(len(rows), 1)
            for key in ("assembly", "factor", "solve")
        },
        "factorisations": sum(f > 0 for f in factor),
        "mean_iterations": sum(int(r["iterations"]) for r in rows) / max(len(rows), 1),
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=256, help="cells per side (default 256)")
    parser.add_argument("--out", type=Path, default=Path("out/bnn_large"), help="run folder")
    parser.add_argument("--blr", type=float, default=1e-8, help="MUMPS BLR tolerance (0: off)")
    parser.add_argument("--json", type=Path, default=None, help="write the record here")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    problem = load_problem(PROBLEM, overrides(args.cells, args.blr))
    resume = (args.out / CHECKPOINT).exists()
    print0(comm, f"BNN {args.cells}² on {comm.size} ranks{' (resumed)' if resume else ''}")
    result = run_problem(problem, args.out, comm, resume=resume)
    summary = result.summary
    record: dict[str, Any] = {
        "problem": "BNN vertical load (M3AS 2021, Table 1), refined",
        "cells": args.cells,
        "ranks": comm.size,
        "dofs": summary.get("dofs"),
        "blr_tolerance": args.blr,
        "steps": summary["steps"],
        "converged": summary["converged"],
        "energy": summary["energy"],
        "isometry_defect": summary["isometry_defect"],
        "peak_memory_mb": summary["peak_memory_mb"],
        "wall_s_since_resume": summary["wall_time_s"],
        "published": BNN_TABLE1.get(args.cells),  # none beyond 128²
    }
    if comm.rank == 0:
        record |= history_figures(args.out / "history.csv")
        text = json.dumps(record, indent=2)
        print(text)
        if args.json:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(text + "\n")
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
