"""PETSc linear-solver set-up shared by every solve in dgplate.

The default is a direct LU factorisation by MUMPS: the saddle-point systems of the
constrained gradient flow are indefinite, and MUMPS handles their zero block by pivoting.
Options can be overridden per solver through an options prefix (``-<prefix>ksp_type`` …).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

from petsc4py import PETSc

from dgplate.errors import SolverError

DIRECT_MUMPS: dict[str, str | int | float] = {
    # one step of iterative refinement after the LU solve: the saddle-point systems are
    # ill-conditioned (h⁻³ penalties), and refinement makes the results agree between
    # partitions (different pivot orders) to ~1e-12 instead of ~1e-10
    "ksp_type": "richardson",
    "ksp_max_it": 2,
    "ksp_norm_type": "none",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
    # more working space: saddle-point pivoting fills in beyond MUMPS's estimate
    "mat_mumps_icntl_14": 80,
    # stricter threshold pivoting (default 0.01): the results then agree between 1, 2 and 3
    # ranks to ~5e-11 instead of ~2e-10 (16×16 BNN problem, isometry defect)
    "mat_mumps_cntl_1": 0.5,
}

_counter = itertools.count()


def make_ksp(
    comm, A: PETSc.Mat, options: Mapping[str, object] | None = None, prefix: str | None = None
) -> PETSc.KSP:
    """A KSP on ``A`` configured from ``DIRECT_MUMPS`` updated by ``options``."""
    prefix = prefix or f"dgplate_{next(_counter)}_"
    opts = PETSc.Options()
    for key, value in {**DIRECT_MUMPS, **(options or {})}.items():
        opts[f"{prefix}{key}"] = value
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setFromOptions()
    # The options stay in the database: the factorisation reads its MUMPS options only at the
    # first solve. The prefix is unique, so they cannot leak into another solver.
    return ksp


def solve(ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> int:
    """Solve and check the converged reason; returns the iteration count."""
    ksp.solve(b, x)
    reason = ksp.getConvergedReason()
    if reason < 0:
        name = {v: k for k, v in PETSc.KSP.ConvergedReason.__dict__.items() if isinstance(v, int)}
        raise SolverError(f"linear solve failed: KSP reason {name.get(reason, reason)}")
    return ksp.getIterationNumber()
