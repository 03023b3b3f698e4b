"""The lagged step solver: one factorisation reused over many steps as a preconditioner.

A lagged solve that fails is redone with fresh factors, then by a direct solve
(:class:`dgplate.solvers.linear.DirectStepSolver`), so the default never fails where the
direct solver succeeds.
"""

from __future__ import annotations

import logging
import math
import time
from typing import cast

from mpi4py import MPI

from petsc4py import PETSc

from dgplate import compat
from dgplate.errors import InputError
from dgplate.solvers.linear import (
    DIRECT_MUMPS,
    DirectStepSolver,
    Options,
    OptionValue,
    SolveStats,
    destroy_ksp,
    factorise,
    make_ksp,
    reason_name,
    with_defaults,
)

# the step solvers' fall-backs are logged under one name
_log = logging.getLogger("dgplate.solvers.linear")

# Lagged factorisation: FGMRES on the current matrix, preconditioned by the exact LU of an
# earlier one. The flow's matrix changes slowly (only the constraint block follows yⁿ), so the
# old factors are an excellent preconditioner: a handful of triangular solves replace a
# factorisation. Right preconditioning makes the stopping test use the true residual. FGMRES
# keeps the preconditioned directions, so the solution is their combination; right-preconditioned
# GMRES would apply the factors once more per solve to form it (about a tenth of the solve time).
LAGGED_MUMPS: dict[str, OptionValue] = {
    **{k: v for k, v in DIRECT_MUMPS.items() if not k.startswith("ksp_")},
    "ksp_type": "fgmres",
    "ksp_pc_side": "right",
    "ksp_rtol": 1e-9,  # with balanced constraint rows: E_h within ~1e-9 of direct solves
    "ksp_atol": 0.0,
    "ksp_max_it": 30,  # a failed solve wastes at most this many; it is then refactorised
    "ksp_gmres_restart": 30,
}

#: Iterations over which the lagged solver measures FGMRES's recent rate of convergence
#: (:meth:`LaggedStepSolver._hopeless`).
RATE_WINDOW = 4


def _permuted_copy(K: PETSc.Mat, numbering: PETSc.IS) -> PETSc.Mat:
    """K's rows and columns in the order of ``numbering``: ``K.createSubMatrix``, minus its cache.

    PETSc keeps a sequential copy of the local rows with the result ("SubMatrix"), so that a
    later extraction into it can skip the set-up. That copy is as large as the result: it would
    double the memory P holds (1.6 GB at 256² on 2 ranks), for a set-up that costs little.
    """
    P = K.createSubMatrix(numbering, numbering)
    for cached in ("SubMatrix", "ISAllGather"):
        P.compose(cached, None)  # type: ignore[arg-type]  # None removes it
    return P


class PermutedFactors:
    """Python PC context: the factors (LU or LDLᵀ) of P, K in another numbering of its rows.

    ``numbering`` lists, for each row of P owned here, its global index in K (see
    :func:`dgplate.solvers.ordering.cellwise_numbering`); applying the PC scatters the vector into P's
    numbering, applies the factors and scatters back.
    """

    def __init__(self, factor_ksp: PETSc.KSP, K: PETSc.Mat, numbering: PETSc.IS):
        self.factor_pc = factor_ksp.getPC()
        P = factor_ksp.getOperators()[0]
        self.xp, self.yp = P.createVecRight(), P.createVecLeft()
        first, last = self.xp.getOwnershipRange()
        here = PETSc.IS().createStride(last - first, first=first, step=1, comm=K.getComm())
        self.scatter = PETSc.Scatter().create(K.createVecRight(), numbering, self.xp, here)
        here.destroy()

    def apply(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """Apply the factors: y = P⁻¹x, with x and y in K's numbering (called by petsc4py)."""
        self.scatter.scatter(x, self.xp, compat.INSERT, compat.FORWARD)
        self.factor_pc.apply(self.xp, self.yp)
        self.scatter.scatter(self.yp, y, compat.INSERT, compat.REVERSE)

    def destroy(self, pc: PETSc.PC) -> None:
        """Called by petsc4py when the PC is destroyed."""
        for obj in (self.scatter, self.xp, self.yp):
            obj.destroy()


class LaggedStepSolver:
    """FGMRES on K preconditioned by the LU factors of a copy P of an earlier K.

    P is refreshed (and refactorised) when the previous solve needed more than
    ``refactor_its`` iterations. A solve that stalls or diverges is redone with fresh factors
    from a zero initial guess, and if that fails too, by a fresh LU solve of K as
    :class:`DirectStepSolver` does it; each fall-back is logged (rank 0) and counted in
    :attr:`SolveStats.fallbacks`. The zero guess matters: after a large rotation the previous
    step's (δy, λ) violates the new linearised constraint, whose rows are scaled by
    ~‖A_const‖/‖b_n‖, so that ‖b − K x₀‖ can exceed 10⁴‖b‖, and PETSc's default test then
    declares DIVERGED_DTOL at iteration 0, before any factors are applied.

    With a ``numbering`` (:func:`dgplate.solvers.ordering.cellwise_numbering`) and MUMPS factors
    (the default), P holds K's rows and columns in that numbering, so that MUMPS orders the same
    graph on any number of ranks; the Krylov solve itself stays in K's numbering.

    ``symmetric``: K is symmetric by construction (a Hessian, a metric and a constraint block
    paired with its transpose). The factors are then MUMPS's symmetric indefinite LDLᵀ
    (``pc_type = "cholesky"``, 2×2 pivots for the saddle point) unless the options name a
    ``pc_type`` or another factor package: they hold about half the entries of the LU factors
    (BNN 128², 2 ranks: 310 M against 567 M, peak memory 5.7 against 9.2 GB), and each
    application reads about as many bytes (L, then Lᵀ), so a solve costs about the same.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        K: PETSc.Mat,
        options: Options | None,
        prefix: str | None,
        refactor_its: int = 12,
        numbering: PETSc.IS | None = None,
        symmetric: bool = False,
    ):
        if refactor_its < 1:
            raise InputError(f"flow.refactor_its must be >= 1, got {refactor_its!r}")
        self.K, self.refactor_its = K, refactor_its
        # the direct fall-back keeps the caller's factorisation options, not the Krylov ones
        self._direct_options = {
            k: v for k, v in (options or {}).items() if not str(k).startswith("ksp_")
        }
        merged = with_defaults(LAGGED_MUMPS, options)
        # LDLᵀ only with MUMPS: other packages (SuperLU_dist, UMFPACK, ...) have no symmetric
        # indefinite factorisation, and PETSc's own Cholesky does not pivot the zero block
        if (
            symmetric
            and "pc_type" not in (options or {})
            and merged.get("pc_factor_mat_solver_type") == "mumps"
        ):
            merged["pc_type"] = "cholesky"
        permuted = (
            numbering is not None
            and merged.get("pc_type") in ("lu", "cholesky")
            and merged.get("pc_factor_mat_solver_type") == "mumps"
        )
        self.numbering = numbering if permuted else None
        if self.numbering is None:
            self.P = K.duplicate(copy=False)
            self.ksp = make_ksp(comm, K, merged, prefix, defaults={})
            self.factor_ksp = self.ksp
            self.ksp.setOperators(K, self.P)
        else:
            krylov = {k: v for k, v in merged.items() if k.startswith("ksp_")}
            factor = {k: v for k, v in merged.items() if not k.startswith("ksp_")}
            self.P = _permuted_copy(K, self.numbering)
            self.ksp = make_ksp(comm, K, krylov, prefix, defaults={})
            try:
                self.factor_ksp = make_ksp(
                    comm,
                    self.P,
                    {**factor, "ksp_type": "preonly"},
                    f"{self.ksp.getOptionsPrefix()}factor_",
                    defaults={},
                )
            except InputError:
                destroy_ksp(self.ksp)
                raise
            pc = self.ksp.getPC()
            pc.setType(PETSc.PC.Type.PYTHON)
            pc.setPythonContext(PermutedFactors(self.factor_ksp, K, self.numbering))
        # Start from the caller's x, the previous step's (δy, λ): λ changes little from step
        # to step, so the initial residual is far below ‖b‖ and the solution's absolute error,
        # which the stopping test ties to ‖b‖, becomes small next to δy even as δy → 0.
        self.ksp.setInitialGuessNonzero(True)
        # after PETSc's own test: stop a solve with old factors that cannot converge in time
        self.ksp.addConvergenceTest(self._hopeless)  # type: ignore[arg-type]  # (stub: an enum)
        self._old_factors = False
        self._target, self._max_it, self._norms = 0.0, 0, list[float]()
        self._stale = True
        self.factorisations = 0

    def prefixes(self) -> list[str]:
        """The options prefixes of the Krylov KSP and of the factors' KSP (when separate)."""
        kept = (self.ksp, self.factor_ksp)
        return list(dict.fromkeys(ksp.getOptionsPrefix() or "" for ksp in kept))

    def constant_changed(self) -> None:
        """K changed by more than its constraint block: refactorise at the next solve."""
        self._stale = True

    def _refactor(self) -> None:
        if self.numbering is None:
            self.K.copy(self.P, structure=compat.SAME_NONZERO_PATTERN)
            self.ksp.setOperators(self.K, self.P)
        else:
            # the old factors go first (a lower peak), and a new P: the analysis is redone
            # (~10 % of a factorisation), but P keeps no reuse cache (see _permuted_copy)
            self.factor_ksp.getPC().reset()
            self.P.destroy()
            self.P = _permuted_copy(self.K, self.numbering)
            self.factor_ksp.setOperators(self.P)
        factorise(self.factor_ksp)
        self.factorisations += 1
        self._stale = False

    def solve(self, b: PETSc.Vec, x: PETSc.Vec, refactor: bool = True) -> SolveStats:
        """Solve K x = b from the guess x.

        ``refactor=False`` (a re-solve with the same K) refactorises only to redo a failed
        solve.
        """
        stats = SolveStats(False, 0, 0.0, 0.0)
        if refactor and self._stale:
            self._timed_refactor(stats)
        self._old_factors = not stats.factorised
        reason = self._krylov(b, x, stats)
        self._old_factors = False
        if reason < 0:
            # old factors that no longer precondition well are the lagged method's normal
            # case (refactorise and go on); anything else is worth a line
            expected = reason == PETSc.KSP.ConvergedReason.DIVERGED_MAX_IT and not stats.factorised
            self._fall_back(
                stats, reason, "", "redone with fresh factors from a zero guess", quiet=expected
            )
            if not stats.factorised:  # factors made for this K are fresh already
                self._timed_refactor(stats)
            x.zeroEntries()
            reason = self._krylov(b, x, stats)
        if reason < 0:
            self._fall_back(stats, reason, " with fresh factors", "redone by a direct LU solve")
            self._direct_solve(b, x, stats)
            self._stale = True
            return stats
        # the count with the factors now held decides whether the next step refactorises
        self._stale = self.ksp.getIterationNumber() > self.refactor_its
        return stats

    def _hopeless(self, ksp: PETSc.KSP, its: int, rnorm: float) -> int:
        """Stop a solve with old factors whose residual falls too slowly to converge in time.

        From iteration ``refactor_its`` on (past it the next step refactorises anyway), FGMRES
        preconditioned by the factors of an earlier K is stopped (DIVERGED_MAX_IT, the lagged
        method's ordinary refactorisation) when the reduction of its last
        :data:`RATE_WINDOW` iterations, kept up, would not bring the residual to PETSc's target
        max(rtol‖b‖, atol) within ``ksp_max_it``. Factors of a K far from the current one (the
        first steps, where yⁿ moves most) make FGMRES drop fast and then stagnate: without
        this test all ``ksp_max_it`` iterations are spent before the solve is redone with
        fresh factors (30 at the third step of the BNN plate). Solves with fresh factors are
        never stopped here. Every rank computes the same from the same (global) norms.
        """
        if its == 0:
            rtol, atol, _, self._max_it = ksp.getTolerances()
            # PETSc's reference with a nonzero initial guess (KSPConvergedDefault) is ‖b‖
            self._target = max(rtol * cast(float, ksp.getRhs().norm()), atol)
            self._norms = []
        self._norms.append(rnorm)
        if not self._old_factors or its < self.refactor_its or len(self._norms) <= RATE_WINDOW:
            return 0
        before = self._norms[-1 - RATE_WINDOW]  # (a restart tests one iteration twice)
        if not 0.0 < self._target < rnorm:
            return 0
        # FGMRES's residual never grows: no decrease is stagnation, else extrapolate the rate
        if (
            rnorm >= before
            or its + RATE_WINDOW * math.log(self._target / rnorm) / math.log(rnorm / before)
            > self._max_it
        ):
            return int(PETSc.KSP.ConvergedReason.DIVERGED_MAX_IT)
        return 0

    def _timed_refactor(self, stats: SolveStats) -> None:
        t0 = time.perf_counter()
        self._refactor()
        stats.factorised = True
        stats.factor_s += time.perf_counter() - t0

    def _krylov(self, b: PETSc.Vec, x: PETSc.Vec, stats: SolveStats) -> int:
        """One FGMRES solve; adds its time and iterations to ``stats``, returns the reason."""
        t0 = time.perf_counter()
        self.ksp.solve(b, x)
        stats.solve_s += time.perf_counter() - t0
        stats.iterations += self.ksp.getIterationNumber()
        return compat.converged_reason(self.ksp)

    def _fall_back(
        self, stats: SolveStats, reason: int, which: str, action: str, quiet: bool = False
    ) -> None:
        """Count a fall-back and say why on one line (rank 0).

        ``quiet``: neither (the lagged method's ordinary refactorisation).
        """
        if quiet:
            return
        stats.fallbacks += 1
        if self.K.getComm().getRank() == 0:
            _log.warning(
                "dgplate: lagged step solve%s failed (KSP reason %s after %d iterations); %s",
                which,
                reason_name(reason),
                self.ksp.getIterationNumber(),
                action,
            )

    def _direct_solve(self, b: PETSc.Vec, x: PETSc.Vec, stats: SolveStats) -> None:
        """Solve by a fresh LU factorisation of K from a zero guess.

        Its factors are freed right away (a failure here is rare, and they would double the
        memory held).
        """
        prefix = f"{self.ksp.getOptionsPrefix()}direct_"
        comm = self.K.getComm().tompi4py()
        direct = DirectStepSolver(comm, self.K, self._direct_options, prefix)
        try:
            x.zeroEntries()
            more = direct.solve(b, x)
        finally:
            direct.destroy()
        stats.factorised = True
        stats.iterations += more.iterations
        stats.factor_s += more.factor_s
        stats.solve_s += more.solve_s

    def destroy(self) -> None:
        """Free the KSPs, the factors, their options and P."""
        if self.numbering is not None:
            # PCReset frees MUMPS's factors now: without it the 2-rank factors outlived the
            # solver (about 300 MB per 32² flow stayed allocated)
            self.factor_ksp.getPC().reset()
            destroy_ksp(self.factor_ksp)
        destroy_ksp(self.ksp)  # destroys the PC context's scatter and vectors
        self.P.destroy()


#: The flow's step solvers (``flow.linear_solver``).
StepSolver = DirectStepSolver | LaggedStepSolver
