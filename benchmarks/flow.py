"""Cost of the discrete H² gradient flow on the Bonito–Nochetto–Ntogkas vertical-load plate.

The optimised flow (the library's default: constant block assembled once, only b_n each
step, one LU factorisation reused as an FGMRES preconditioner over many steps) runs first; with
``--compare-naive`` the published algorithm then runs in the same process on the same problem:
every step reassembles the whole matrix and factorises it from scratch (symbolic analysis
included). Both use τ = h and the stopping rule (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < 1e-6.

    python benchmarks/flow.py --cells 32 --compare-naive --json out.json
    mpirun -n 2 python benchmarks/flow.py --cells 128 --json out.json

Timings are wall-clock seconds of rank 0 (every step ends in a collective, so ranks agree);
``peak_memory_mb`` is the resident-set peak, the largest rank's and the sum over ranks.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx
import dolfinx.fem.petsc
import numpy as np
from petsc4py import PETSc

from dgplate import mpi
from dgplate.io.output import print0
from dgplate.io.progress import ProgressPrinter
from dgplate.models.kirchhoff import bnn_plate
from dgplate.reference.bnn import BNN_TABLE1, bnn_h
from dgplate.solvers import linear
from dgplate.solvers.flow import FlowSpec, GradientFlow
from dgplate.solvers.step_system import StepSystem
from dgplate.solvers.steps import FlowResult

PHASES = ("assembly", "factorisation", "solves", "other")


class NaiveStepSolver:
    """The published baseline: a new KSP, hence a symbolic and numeric LU, every step."""

    def __init__(self, comm, K: PETSc.Mat):
        self.comm, self.K = comm, K
        self.ksp: PETSc.KSP | None = None

    def solve(self, b: PETSc.Vec, x: PETSc.Vec, refactor: bool = True) -> linear.SolveStats:
        t0 = time.perf_counter()
        if self.ksp is not None:
            linear.destroy_ksp(self.ksp)
        self.ksp = linear.make_ksp(self.comm, self.K)
        self.ksp.getPC().setUp()
        t1 = time.perf_counter()
        its = linear.solve(self.ksp, b, x)
        return linear.SolveStats(True, its, t1 - t0, time.perf_counter() - t1)

    def destroy(self) -> None:
        if self.ksp is not None:
            linear.destroy_ksp(self.ksp)


class NaiveSystem(StepSystem):
    """The same step system, but the whole step matrix is reassembled from the full form, in
    DOLFINx's pattern, each step."""

    def _make_solver(self) -> NaiveStepSolver:  # type: ignore[override]
        self.K.destroy()
        self.K = dolfinx.fem.petsc.assemble_matrix(self.step_form)  # DOLFINx's full pattern
        self.K.assemble()
        return NaiveStepSolver(self.comm, self.K)

    def assemble(self, newton: bool = False, residual: bool = False) -> NaiveStepSolver:  # type: ignore[override]
        self.K.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(self.K, self.step_form)  # type: ignore[arg-type]
        self.K.assemble()
        with self.rhs.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(self.rhs, self.rhs_form)
        self.rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if residual:
            self.add_constraint_residual()
        assert isinstance(self.solver, NaiveStepSolver)
        return self.solver


class NaiveFlow(GradientFlow):
    """The same flow with the :class:`NaiveSystem`."""

    system_type = NaiveSystem


def bnn_flow(comm: MPI.Comm, cells: int, naive: bool = False, progress: int = 0) -> GradientFlow:
    """The plate (0, 4)² clamped on x = 0 and y = 0, f = (0, 0, 2.5e-2), Q2, τ = h."""
    model = bnn_plate(comm, cells)
    settings = FlowSpec(tau=bnn_h(cells), tol=1e-6, max_steps=2000)
    cls = NaiveFlow if naive else GradientFlow
    observers = [ProgressPrinter(comm, progress)] if progress else []
    return cls(model.facets, model.degree, model.energy, settings, observers)


def factorisation_kind(flow: GradientFlow) -> str:
    """ "LDLᵀ" or "LU": the factors the flow's step solver holds."""
    solver = flow.system.solver
    ksp = getattr(solver, "factor_ksp", None) or getattr(solver, "ksp", None)
    return "LDLᵀ" if ksp is not None and ksp.getPC().getType() == "cholesky" else "LU"


def measure(
    comm: MPI.Comm, cells: int, naive: bool, max_steps: int | None, progress: int = 0
) -> dict:
    """Build and run one flow; the per-step phase breakdown, result and costs."""
    comm.Barrier()
    t0 = time.perf_counter()
    flow = bnn_flow(comm, cells, naive, progress)
    setup = time.perf_counter() - t0
    t1 = time.perf_counter()
    result: FlowResult = flow.run(max_steps)
    wall = time.perf_counter() - t1
    steps = max(result.steps, 1)
    totals = {
        "assembly": sum(h.assembly_s for h in result.history),
        "factorisation": sum(h.factor_s for h in result.history),
        "solves": sum(h.solve_s for h in result.history),
    }
    totals["other"] = wall - sum(totals.values())
    record = {
        "dofs": flow.num_dofs,
        "setup_s": setup,
        "wall_s": wall,
        "steps": result.steps,
        "converged": result.converged,
        "per_step_s": wall / steps,
        "breakdown_per_step_s": {k: totals[k] / steps for k in PHASES},
        "factorisations": sum(h.factor_s > 0 for h in result.history),
        "mean_iterations": float(np.mean([h.iterations for h in result.history])),
        "factorisation": factorisation_kind(flow),
        "energy": result.energy,
        "isometry_defect": result.defect,
    }
    flow.destroy()
    return record


def machine() -> dict:
    return {
        "cpu": platform.processor() or platform.machine(),
        "cores": __import__("os").cpu_count(),
        "python": platform.python_version(),
        "dolfinx": dolfinx.__version__,
        "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
    }


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=16, help="cells per side (default 16)")
    parser.add_argument(
        "--compare-naive", action="store_true", help="also run the published algorithm"
    )
    parser.add_argument(
        "--naive-steps",
        type=int,
        default=None,
        help="run the naive flow for only this many steps (its per-step cost; no step count)",
    )
    parser.add_argument("--max-steps", type=int, default=None, help="step budget of both runs")
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="run the optimised flow this many times and keep the run of median wall time "
        "(a 2-core machine's timings vary by a few per cent from run to run)",
    )
    parser.add_argument("--json", type=Path, default=None, help="write the record here")
    parser.add_argument(
        "--progress", type=int, default=10, help="print every this many steps (0: quiet)"
    )
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.cells < 2:
        parser.error("--cells must be >= 2")

    if args.repeat < 1:
        parser.error("--repeat must be >= 1")

    print0(comm, f"BNN vertical load, {args.cells}² Q2 on {comm.size} rank(s): optimised flow")
    runs = [measure(comm, args.cells, False, args.max_steps, args.progress)]
    for _ in range(args.repeat - 1):
        runs.append(measure(comm, args.cells, False, args.max_steps, 0))
    optimised = sorted(runs, key=lambda run: run["wall_s"])[(len(runs) - 1) // 2]
    optimised["repeats_wall_s"] = [run["wall_s"] for run in runs]
    memory = mpi.peak_memory_mb(comm)  # before the naive run, so it is the optimised flow's
    record = {
        "problem": "BNN vertical load (M3AS 2021, Table 1)",
        "cells": args.cells,
        "ranks": comm.size,
        "dofs": optimised["dofs"],
        "tau": bnn_h(args.cells),
        "optimized": optimised,
        "steps": optimised["steps"],
        "energy": optimised["energy"],
        "isometry_defect": optimised["isometry_defect"],
        "peak_memory_mb": memory,
        "per_step_s": {"optimized": optimised["per_step_s"]},
        "published": dict(zip(("energy", "isometry_defect", "steps"), BNN_TABLE1[args.cells]))
        if args.cells in BNN_TABLE1
        else None,
        "machine": machine(),
    }
    if args.compare_naive:
        print0(comm, "naive flow (full reassembly and a fresh factorisation every step)")
        budget = args.naive_steps or args.max_steps
        naive = measure(comm, args.cells, True, budget, args.progress)
        record["naive"] = naive
        record["per_step_s"]["naive"] = naive["per_step_s"]
        record["speedup_per_step"] = naive["per_step_s"] / optimised["per_step_s"]
        if args.naive_steps is None:
            record["energy_rel_diff"] = abs(optimised["energy"] / naive["energy"] - 1)
            record["steps_agree"] = optimised["steps"] == naive["steps"]
    print0(comm, json.dumps(record, indent=2))
    if args.json and comm.rank == 0:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.json.with_suffix(".json.part")
        tmp.write_text(json.dumps(record, indent=2) + "\n")
        tmp.replace(args.json)
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
