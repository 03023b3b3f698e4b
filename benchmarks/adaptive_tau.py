"""Adaptive τ against fixed τ = h, both with projection and to the τ-independent stop.

Both runs of a problem file stop when ‖P DE_h[yⁿ]‖_*' < tol (``flow.stop = 'stationarity'``)
and start from τ = h (the largest cell diameter); the record holds the accepted and rejected
steps, the step solves (each attempted step and its projections; each accepted step adds one
stationarity solve), the τ changes put into the step matrix (``refactorisations``), the step
solver's factorisations, E_h, D_h and the wall time of each run.

    python benchmarks/adaptive_tau.py --problem bnn --cells 32 --json out.json
    python benchmarks/adaptive_tau.py --problem cylinder --cells 32 16 --tol 1e-5
    python benchmarks/adaptive_tau.py --problem bnn --cells 32 --set flow.tau_growth=4

``bnn``: the BNN vertical-load plate (demos/problems/vertical_load.toml) with one projection
step; ``cylinder``: the bilayer cylinder (demos/problems/bilayer_cylinder.toml, two projection
steps, edge constraint, degree-1 multipliers). ``--set`` keys apply to the adaptive runs only: adaptive τ without and with the SQP finish
(``flow.newton_finish``); ``--skip-fixed FILE`` reuses the fixed run of an earlier record
(and ``--reuse-adaptive`` its adaptive run).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.io.output import print0
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import load_problem

PROBLEMS = Path(__file__).resolve().parent.parent / "demos" / "problems"
RUNS = ("fixed", "adaptive", "newton")
FILES = {"bnn": "vertical_load.toml", "cylinder": "bilayer_cylinder.toml"}
#: The settings both runs share besides the problem file's.
COMMON = {"bnn": {"flow.projection_steps": 1}, "cylinder": {}}


def run(
    comm: MPI.Comm, args: argparse.Namespace, adaptive: bool, newton: bool = False
) -> dict[str, Any]:
    """One run of the problem to the stationarity stop; its counts and result.

    ``newton``: adaptive τ with the SQP finish (``flow.newton_finish``).
    """
    overrides: dict[str, Any] = {
        "mesh.cells": list(args.cells),
        "flow.tau": "h",
        "flow.tol": args.tol,
        "flow.stop": "stationarity",
        "flow.max_steps": args.max_steps,
        "flow.adaptive_tau": adaptive,
        "flow.newton_finish": newton,
        # the control of the tables of docs/performance.md (the trust region: benchmarks/rollup.py)
        "flow.step_control": "defect_bound",
        "flow.checkpoint_every": 0,
        "output.vtx": False,
        "output.png": False,
        "output.progress": 0,
        **COMMON[args.problem],
    }
    extra = dict(item.split("=", 1) for item in args.set) if adaptive else {}
    texts = [f"{k}={json.dumps(v)}" for k, v in overrides.items() if k not in extra]
    texts += [f"{k}={v}" for k, v in extra.items()]
    problem = load_problem(PROBLEMS / FILES[args.problem], texts)
    folder = tempfile.mkdtemp(prefix="adaptive_tau_") if comm.rank == 0 else None
    folder = comm.bcast(folder, root=0)
    t0 = time.perf_counter()
    result = run_problem(problem, Path(folder) / "run", comm)
    wall = time.perf_counter() - t0
    summary = result.summary
    return {
        "adaptive_tau": adaptive,
        "settings": texts,
        "converged": summary["converged"],
        "steps": summary["steps"],
        "rejected_steps": summary["rejected_steps"],
        "newton_steps": summary["newton_steps"],
        "newton_rejections": summary["newton_rejections"],
        # every solve with a step or SQP matrix: attempted steps and their corrections
        "step_solves": summary["step_solves"],
        "stationarity_solves": summary["steps"],
        "refactorisations": summary["refactorisations"],
        "factorisations": summary["factorisations"],
        "energy": summary["energy"],
        "isometry_defect": summary["isometry_defect"],
        "energy_increases": summary["energy_increases"],
        "taus": [row["tau"] for row in result.history],
        "stationarity": [row["stationarity"] for row in result.history],
        "wall_s": wall,
    }


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problem", choices=sorted(FILES), default="bnn")
    parser.add_argument("--cells", type=int, nargs="+", default=[16])
    parser.add_argument("--tol", type=float, default=1e-5)
    parser.add_argument("--max-steps", type=int, default=5000)
    parser.add_argument("--set", action="append", default=[], help="key=value, adaptive runs")
    parser.add_argument("--skip-fixed", type=Path, default=None, help="reuse this JSON's run")
    parser.add_argument(
        "--reuse-adaptive",
        action="store_true",
        help="with --skip-fixed: reuse its adaptive run too",
    )
    parser.add_argument("--no-fixed", action="store_true", help="skip the fixed-τ run")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    if len(args.cells) == 1:
        args.cells = args.cells * 2
    comm = MPI.COMM_WORLD
    old = json.loads(args.skip_fixed.read_text()) if args.skip_fixed else {}
    if args.no_fixed:
        fixed = None
    else:
        fixed = old["fixed"] if old else run(comm, args, False)
    adaptive = old["adaptive"] if old and args.reuse_adaptive else run(comm, args, True)
    newton = run(comm, args, True, newton=True)
    record = make_record(comm, args, fixed, adaptive, newton)
    brief = {k: v for k, v in record.items() if k not in RUNS}
    for key in RUNS:
        if record[key] is not None:
            brief[key] = {k: v for k, v in record[key].items() if k not in ("taus", "stationarity")}
    print0(comm, json.dumps(brief, indent=1))
    if args.json and comm.rank == 0:
        args.json.write_text(json.dumps(record, indent=2) + "\n")


def make_record(
    comm: MPI.Comm,
    args: argparse.Namespace,
    fixed: dict[str, Any] | None,
    adaptive: dict[str, Any],
    newton: dict[str, Any],
) -> dict[str, Any]:
    """The benchmark's record: the three runs and the ratios of their step solves to fixed τ."""
    record = {
        "problem": f"{FILES[args.problem]}, Q2, stop = stationarity, initial τ = h",
        "cells": args.cells,
        "ranks": comm.size,
        "tol": args.tol,
        "fixed": fixed,
        "adaptive": adaptive,
        "newton": newton,
    }
    if fixed is not None:
        record["step_solves_ratio_fixed_over_adaptive"] = (
            fixed["step_solves"] / adaptive["step_solves"]
        )
        record["energy_rel_diff"] = abs(adaptive["energy"] / fixed["energy"] - 1)
        record["step_solves_ratio_fixed_over_newton"] = fixed["step_solves"] / newton["step_solves"]
        record["energy_rel_diff_newton"] = abs(newton["energy"] / fixed["energy"] - 1)
    record["energy_rel_diff_newton_adaptive"] = abs(newton["energy"] / adaptive["energy"] - 1)
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
