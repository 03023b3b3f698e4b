"""The Schur-complement step solver against the lagged LU solver, side by side in one run.

The BNN vertical-load plate (Q2, τ = h) runs a fixed number of steps with each solver, each in
its own process (so that the resident-set peak is that solver's), on the same number of ranks;
the record holds the time per step, the Krylov iterations, the MUMPS factor size and memory
and the peak resident set of each, and their ratios (schur / lagged), for each preconditioner
of the Schur complement (``--pc``, the step-solver option ``schur_pc``). For the Schur solver
it also records the time spent in applications of Σ and of its preconditioner, and from them
the time per step that would remain with a preconditioner of no cost.

    python benchmarks/schur.py --cells 32 64 --steps 5 --pc cell bfbt --json out.json
    python benchmarks/schur.py --cells 128 --ranks 2 --steps 3 --json out.json
    python benchmarks/schur.py --spectrum --cells 4 8 16 --json out.json   # dense, serial

Run it without mpirun: it launches ``mpirun -n RANKS`` itself for each solver.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
from petsc4py import PETSc

SOLVERS = ("lagged", "schur")


def child(cells: int, solver: str, steps: int, out: Path, pc: str) -> None:
    """Run ``steps`` steps with ``solver`` (``pc``: Σ's preconditioner) and write the record."""
    from dgplate import mpi
    from dgplate.models.kirchhoff import bnn_plate
    from dgplate.reference.bnn import bnn_h
    from dgplate.solvers.flow import FlowSpec, GradientFlow
    from dgplate.solvers.schur import PRECONDITIONERS

    comm = MPI.COMM_WORLD
    model = bnn_plate(comm, cells)
    settings = FlowSpec(
        tau=bnn_h(cells),
        tol=1e-30,
        max_steps=steps,
        linear_solver=solver,
        solver={"schur_pc": pc} if solver == "schur" and pc in PRECONDITIONERS else {},
    )
    flow = GradientFlow(model.facets, model.degree, model.energy, settings)
    comm.Barrier()
    t0 = time.perf_counter()
    result = flow.run(steps)
    wall = time.perf_counter() - t0
    seconds = [h.seconds for h in result.history]
    factor = _factor_matrix(flow.solver)
    memory = mpi.peak_memory_mb(comm)
    record = {
        "solver": type(flow.solver).__name__,
        "preconditioner": pc if solver == "schur" else None,
        "dofs": flow.num_dofs,
        "steps": result.steps,
        "wall_s": wall,
        "reason": result.reason,
        "per_step_s": wall / max(result.steps, 1),
        "per_step_after_first_s": float(np.mean(seconds[1:])) if len(seconds) > 1 else None,
        "first_step_s": seconds[0] if seconds else None,
        "iterations": [h.iterations for h in result.history],
        "h_factorisations": getattr(getattr(flow.solver, "aux", None), "rebuilds", None),
        "h_factor_entries": _h_factor_entries(flow.solver),
        "energy": result.energy,
        "isometry_defect": result.defect,
        "factor_entries": float(factor.getMumpsInfog(29)) if factor else None,
        "factor_memory_mb_total": float(factor.getMumpsInfog(22)) if factor else None,
        "peak_rss_mb_max_rank": memory["max_rank"],
        "peak_rss_mb_total": memory["total"],
    }
    record["all_factor_entries"] = (record["factor_entries"] or 0) + (
        record["h_factor_entries"] or 0
    )
    record |= _profile(flow.solver, record)
    flow.destroy()
    if comm.rank == 0:
        out.write_text(json.dumps(record, indent=2))


def spectrum(cells: int) -> dict:
    """Condition numbers of the preconditioned Σ, from dense matrices (serial, small meshes).

    After one step of the BNN plate (so that B is that of a bent state), Σ = Σ_c B_c A⁻¹ B_cᵀ
    and each preconditioner are formed densely: the cell blocks P, the scaled BFBᵀ P⁻¹FP⁻¹
    and the auxiliary space (P + Q)⁻¹. Returns the extreme eigenvalues of M Σ and their ratio.
    """
    from dgplate.models.kirchhoff import bnn_plate
    from dgplate.reference.bnn import bnn_h
    from dgplate.solvers.flow import FlowSpec, GradientFlow

    model = bnn_plate(MPI.COMM_SELF, cells)
    settings = FlowSpec(tau=bnn_h(cells), tol=1e-30, linear_solver="schur")
    flow = GradientFlow(model.facets, model.degree, model.energy, settings)  # 'aux' by default
    flow.run(1)

    def dense(m) -> np.ndarray:
        return m.convert("dense", PETSc.Mat()).getDenseArray().copy()

    solver = flow.solver
    A, E = dense(solver.A), dense(solver.aux.E)
    Bs = [dense(Bc) for Bc in solver.B]
    n = solver.nodes_per_cell
    D = np.zeros_like(A)
    for i in range(0, A.shape[0], n):
        D[i : i + n, i : i + n] = A[i : i + n, i : i + n]
    Ainv, Dinv, Acinv = np.linalg.inv(A), np.linalg.inv(D), np.linalg.inv(E.T @ A @ E)
    flow.destroy()
    S = sum(B @ Ainv @ B.T for B in Bs)
    P = sum(B @ Dinv @ B.T for B in Bs)
    Pinv = np.linalg.inv(P)
    F = sum(B @ Dinv @ A @ Dinv @ B.T for B in Bs)
    Q = sum(B @ E @ Acinv @ E.T @ B.T for B in Bs)
    record: dict = {"cells": cells, "multipliers": S.shape[0]}
    for name, M in (("cell", Pinv), ("bfbt", Pinv @ F @ Pinv), ("aux", np.linalg.inv(P + Q))):
        eig = np.sort(np.linalg.eigvals(M @ S).real)
        record[name] = {"min": eig[0], "max": eig[-1], "condition": eig[-1] / eig[0]}
    return record


def _profile(solver, record: dict) -> dict:
    """Where the Schur solver's time goes (rank 0's clock), and what a step would cost without
    its preconditioner: the time per step after the first, less the mean CG iterations per step
    times the mean cost of one application of the preconditioner. That is a lower bound for
    any preconditioner that keeps the iteration count."""
    sigma, pc = getattr(solver, "sigma_tally", None), getattr(solver, "pc_tally", None)
    if sigma is None or pc is None or not pc.applications:
        return {}
    per_pc = pc.seconds / pc.applications
    iterations = record["iterations"][1:] or record["iterations"]
    after_first = record["per_step_after_first_s"] or record["per_step_s"]
    return {
        "sigma_applications": sigma.applications,
        "sigma_s": sigma.seconds,
        "sigma_s_per_application": sigma.seconds / max(sigma.applications, 1),
        "pc_applications": pc.applications,
        "pc_s": pc.seconds,
        "pc_s_per_application": per_pc,
        "per_step_after_first_without_pc_s": after_first - float(np.mean(iterations)) * per_pc,
    }


def _factor_matrix(solver):
    """The MUMPS factor matrix the solver holds (None if it holds none)."""
    ksp = getattr(solver, "factor_ksp", None)
    if ksp is None:
        return None
    return ksp.getPC().getFactorMatrix()


def _h_factor_entries(solver) -> float | None:
    """The MUMPS factor entries of H of the auxiliary-space preconditioner (None if none)."""
    aux = getattr(solver, "aux", None)
    if aux is None or aux.ksp is None:
        return None
    return float(aux.ksp.getPC().getFactorMatrix().getMumpsInfog(29))


def run_one(cells: int, solver: str, steps: int, ranks: int, pc: str = "bfbt") -> dict:
    """Launch :func:`child` in a fresh process (under mpirun for ranks > 1)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "record.json"
        script = [sys.executable, "-m", "mpi4py", __file__, "--child", solver]
        script += ["--cells", str(cells), "--steps", str(steps), "--json", str(out), "--pc", pc]
        if ranks > 1:
            mpirun = shutil.which("mpirun", path=str(Path(sys.executable).parent)) or "mpirun"
            script = [mpirun, "-n", str(ranks), *script]
        subprocess.run(script, check=True, env=os.environ.copy())
        record: dict = json.loads(out.read_text())
        return record


RATIOS = (
    "per_step_s",
    "per_step_after_first_s",
    "per_step_after_first_without_pc_s",
    "factor_entries",
    "all_factor_entries",
    "factor_memory_mb_total",
    "peak_rss_mb_total",
)

#: the lagged solver's figure a Schur ratio is taken against, where the keys differ
LAGGED_KEY = {"per_step_after_first_without_pc_s": "per_step_after_first_s"}


def compare(cells: int, steps: int, ranks: int, pcs: list[str]) -> dict:
    """The lagged solver and the Schur solver with each preconditioner at one size."""
    lagged = run_one(cells, "lagged", steps, ranks)
    runs = {"lagged": lagged}
    runs |= {f"schur_{pc}": run_one(cells, "schur", steps, ranks, pc) for pc in pcs}

    def ratio(schur: dict, key: str) -> float | None:
        a, b = schur.get(key), lagged.get(LAGGED_KEY.get(key, key))
        return a / b if a is not None and b else None

    schurs = {name: run for name, run in runs.items() if name != "lagged"}
    return {
        "cells": cells,
        "ranks": ranks,
        "steps": steps,
        "dofs": lagged["dofs"],
        "runs": runs,
        "ratio_over_lagged": {
            name: {key: ratio(run, key) for key in RATIOS} for name, run in schurs.items()
        },
        "energy_rel_diff": {
            name: abs(run["energy"] / lagged["energy"] - 1) for name, run in schurs.items()
        },
    }


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[32, 64])
    parser.add_argument("--steps", type=int, default=5, help="steps per run (fixed)")
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument(
        "--pc", nargs="+", default=["aux"], help="Σ's preconditioners: cell, bfbt, aux"
    )
    parser.add_argument(
        "--spectrum", action="store_true", help="dense condition numbers instead (small meshes)"
    )
    parser.add_argument("--child", choices=SOLVERS, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.cells[0], args.child, args.steps, args.json, args.pc[0])
        return
    if args.spectrum:
        records = [spectrum(cells) for cells in args.cells]
    else:
        records = [compare(cells, args.steps, args.ranks, args.pc) for cells in args.cells]
    text = json.dumps(records, indent=2)
    print(text)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
