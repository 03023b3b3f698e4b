"""PETSc linear-solver set-up shared by every solve in dgplate.

The default is a direct LU factorisation by MUMPS: the saddle-point systems of the
constrained gradient flow are indefinite, and MUMPS handles their zero block by pivoting.
Options can be overridden per solver through an options prefix (``-<prefix>ksp_type`` …).

The flow's step systems change a little from step to step;
:class:`dgplate.solvers.lagged.LaggedStepSolver` reuses one factorisation over many steps as a
preconditioner, :class:`DirectStepSolver` factorises every step (the published method).
"""

from __future__ import annotations

import itertools
import logging
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass

from mpi4py import MPI

from petsc4py import PETSc

from dgplate import compat
from dgplate.errors import InputError, SolverError

#: The value of a PETSc option (a bool is an int).
OptionValue = str | int | float
#: PETSc options without the leading '-' and the solver's prefix: ``{"ksp_type": "cg"}``.
Options = Mapping[str, OptionValue]

_OPTION_NAME = re.compile(r"^[A-Za-z0-9_]+$")


def check_option_names(options: Options, key: str) -> None:
    """Every name of ``options`` must be a PETSc option name (its values are typed by the spec).

    Args:
        options: the table of a problem file (``flow.solver``, ``newton.snes``).
        key: its dotted key, as named in the message.
    """
    for name in options:
        if not _OPTION_NAME.match(name):
            raise InputError(
                f"{key}.{name} is not a PETSc option name (letters, digits and _, without the "
                "leading '-', e.g. ksp_type)"
            )


DIRECT_MUMPS: dict[str, OptionValue] = {
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
_log = logging.getLogger(__name__)


def with_defaults(defaults: Options, options: Options | None) -> dict[str, OptionValue]:
    """``defaults`` updated by ``options``.

    Without the defaults' MUMPS options when ``options`` choose another factor package: PETSc
    would report them as never used.
    """
    given = options or {}
    merged = {**defaults, **given}
    if merged.get("pc_factor_mat_solver_type", "mumps") != "mumps":
        merged = {k: v for k, v in merged.items() if k in given or not k.startswith("mat_mumps_")}
    return merged


def make_ksp(
    comm: MPI.Comm,
    A: PETSc.Mat,
    options: Options | None = None,
    prefix: str | None = None,
    defaults: Options = DIRECT_MUMPS,
    key: str = "flow.solver",
) -> PETSc.KSP:
    """A KSP on ``A`` configured from ``defaults`` updated by ``options``.

    Options that PETSc refuses (an unknown ``ksp_type`` or ``pc_type``, a factor package it
    does not have for A) are an InputError naming ``key``, the problem-file key of ``options``;
    the KSP and its options are then gone.
    """
    prefix = prefix or f"dgplate_{next(_counter)}_"
    opts = PETSc.Options()
    merged = with_defaults(defaults, options)
    for name, value in merged.items():
        opts.setValue(f"{prefix}{name}", value)
    ksp = PETSc.KSP().create(comm)  # type: ignore[arg-type]  # an mpi4py comm is taken
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    try:
        ksp.setFromOptions()
        check_factor_package(ksp.getPC(), A)
    except PETSc.Error as err:
        ksp.destroy()
        for name in merged:
            opts.delValue(f"{prefix}{name}")
        raise refused(key, err) from None
    # The options stay in the database: the factorisation reads its MUMPS options only at the
    # first solve. The prefix is unique, so they cannot leak into another solver.
    return ksp


#: PC types that factorise the matrix with a package (``pc_factor_mat_solver_type``).
FACTOR_PCS = ("lu", "cholesky", "ilu", "icc")


def check_factor_package(pc: PETSc.PC, A: PETSc.Mat) -> None:
    """Raise PETSc's error now if ``pc`` (set up from its options) cannot factorise ``A``.

    PETSc looks the factor package up only at the first factorisation, when a run has begun
    writing: an unknown ``pc_factor_mat_solver_type``, or one without this factorisation or
    this matrix type (e.g. ``petsc`` LU of a parallel matrix, ``mumps`` ILU). The look-up alone
    (MatGetFactor on ``A`` in a throwaway PC: an empty factor matrix, no analysis) costs
    nothing and leaves ``pc`` as it was. Collective.
    """
    kind = pc.getType()
    if kind not in FACTOR_PCS:
        return
    probe = PETSc.PC().create(pc.getComm())
    try:
        probe.setOperators(A, A)
        probe.setType(kind)
        package = pc.getFactorSolverType()
        if package:
            probe.setFactorSolverType(package)
        probe.setFactorSetUpSolverType()
    finally:
        probe.destroy()


_FRAME = re.compile(r"\w+\(\) at \S+:\d+$")


def petsc_reason(err: PETSc.Error) -> str:
    """PETSc's own message of ``err`` in one short line.

    The error's text is its code, then PETSc's stack (``[0] KSPSetFromOptions() at file:line``
    lines) and message lines; the last message line is the specific one (``Unable to find
    requested PC type foo``), of which the first sentence is kept.
    """
    lines = [re.sub(r"^\[\d+\]\s*", "", line).strip() for line in str(err).splitlines()[1:]]
    messages = [line for line in lines if line and not _FRAME.search(line)]
    if not messages:
        return f"PETSc error code {getattr(err, 'ierr', '?')}"
    return messages[-1].split(". ")[0].rstrip(".")


def refused(key: str, err: PETSc.Error) -> InputError:
    """The InputError for PETSc options under ``key`` that PETSc refused with ``err``."""
    return InputError(f"{key}: PETSc refused the options: {petsc_reason(err)}")


def destroy_ksp(ksp: PETSc.KSP) -> None:
    """Destroy a KSP made by :func:`make_ksp` and drop its options from the database."""
    prefix = ksp.getOptionsPrefix() or ""
    ksp.destroy()
    if prefix.startswith("dgplate_"):
        drop_options(prefix)


def drop_options(prefix: str = "dgplate_") -> None:
    """Delete the options database's keys that start with ``prefix`` (not collective).

    With the default, every solver option dgplate set: a command that ends on an error before
    its solvers ran calls it, so that PETSc does not report them as unused at exit.
    """
    opts = PETSc.Options()
    for key in [k for k in opts.getAll() if k.startswith(prefix)]:
        opts.delValue(key)


def factorise(ksp: PETSc.KSP) -> None:
    """Factorise the KSP's preconditioning matrix now.

    MUMPS sizes its working space at the analysis, which the flow's solvers do once, on the
    first matrix (at the flat state the normal components of b_n are zero). Pivoting on a later
    matrix can then delay more pivots than foreseen (INFOG(1) = −8 or −9): the analysis is
    redone on the current matrix, with twice the extra space (ICNTL(14)), up to three times.
    """
    pc = ksp.getPC()
    pc.setUp()
    if pc.getType() not in ("lu", "cholesky") or pc.getFactorSolverType() != "mumps":
        return
    for _ in range(3):
        factor = pc.getFactorMatrix()
        if factor.getMumpsInfog(1) not in (-8, -9):
            return
        workspace = 2 * max(factor.getMumpsIcntl(14), 20)
        PETSc.Options().setValue(f"{ksp.getOptionsPrefix() or ''}mat_mumps_icntl_14", workspace)
        A, P = ksp.getOperators()
        pc.reset()
        ksp.setOperators(A, P)
        pc.setUp()


def solve(ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> int:
    """Solve and check the converged reason; returns the iteration count."""
    ksp.solve(b, x)
    reason = compat.converged_reason(ksp)
    if reason < 0:
        raise SolverError(f"linear solve failed: KSP reason {reason_name(reason)}")
    return ksp.getIterationNumber()


def reason_name(reason: int) -> str:
    """The name of a KSP converged reason, e.g. ``DIVERGED_MAX_IT``."""
    names = {v: k for k, v in PETSc.KSP.ConvergedReason.__dict__.items() if isinstance(v, int)}
    return str(names.get(reason, reason))


STEP_SOLVERS = ("lagged", "direct")


@dataclass
class SolveStats:
    """What one linear solve cost: the factorisation (if any), the solve, the iterations."""

    factorised: bool
    iterations: int
    factor_s: float
    solve_s: float
    fallbacks: int = 0  # re-solves after a failed lagged solve (fresh factors, then direct LU)


class DirectStepSolver:
    """A fresh numeric LU factorisation of K for every solve (symbolic analysis reused)."""

    def __init__(self, comm: MPI.Comm, K: PETSc.Mat, options: Options | None, prefix: str | None):
        self.K = K
        self.ksp = make_ksp(comm, K, options, prefix)
        self.ksp.setInitialGuessNonzero(True)  # see lagged.LaggedStepSolver
        self.factorisations = 0

    def solve(self, b: PETSc.Vec, x: PETSc.Vec, refactor: bool = True) -> SolveStats:
        """Solve K x = b, refactorising K first unless ``refactor`` is False (same K)."""
        t0 = time.perf_counter()
        factorised = refactor
        if refactor:
            self.ksp.setOperators(self.K)  # marks the factors stale
            factorise(self.ksp)
            self.factorisations += 1
        t1 = time.perf_counter()
        its = solve(self.ksp, b, x)
        return SolveStats(factorised, its, (t1 - t0) * factorised, time.perf_counter() - t1)

    def prefixes(self) -> list[str]:
        """The options prefix of the KSP (where ``flow.solver``'s options are read)."""
        return [self.ksp.getOptionsPrefix() or ""]

    def destroy(self) -> None:
        """Free the KSP, its factors and its options."""
        destroy_ksp(self.ksp)
