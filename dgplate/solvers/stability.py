"""The stability of a load path: Hessian eigenvalues after each converged load step.

After each converged load step the eigenvalues of the Hessian D²Π nearest a shift (default 0)
are computed, i.e. of the Jacobian at the converged state restricted to the free unknowns (the
rows and columns of the Dirichlet unknowns removed), by
:func:`dgplate.solvers.eigen.nearest_eigenpairs` (SLEPc when importable, else Lanczos with a
MUMPS factorisation). The lowest of them is the record's ``lowest_eigenvalue``; where it
changes sign from one step to the next, the load factor of the crossing is interpolated
linearly (``critical_load_factors`` in the summary). An unstable state may then be left
(:class:`dgplate.solvers.branch.BranchLeaving`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any, Protocol

from petsc4py import PETSc

from dgplate.errors import SolverError
from dgplate.solvers import eigen
from dgplate.solvers.path_options import Leave, Stability
from dgplate.solvers.snes import NewtonSolver

#: The record field of the lowest Hessian eigenvalue.
LOWEST = "lowest_eigenvalue"

_log = logging.getLogger("dgplate.solvers.newton")  # the name it had before the split


class Leaving(Protocol):
    """What leaves an unstable state (:class:`dgplate.solvers.branch.BranchLeaving`)."""

    def leave_branch(
        self, factor: float, stability: Stability, leave: Leave, pairs: eigen.Eigenpairs
    ) -> tuple[float, int]:
        """Push–relax rounds from an unstable state: (the final lowest eigenvalue, Newton its)."""
        ...

    def leave_unstable(
        self, factor: float, stability: Stability, mode: PETSc.Vec
    ) -> tuple[float, int]:
        """Push the state along ``mode`` and solve again: (amplitude, Newton its)."""
        ...


class Path(Protocol):
    """The load path as the observer sees it (:class:`dgplate.solvers.newton.LoadPath`)."""

    newton: NewtonSolver
    branches: Leaving

    @property
    def history(self) -> Sequence[Any]:
        """The records of the converged load steps (``load_factor``, :data:`LOWEST`)."""
        ...


class StabilityObserver:
    """The lowest Hessian eigenvalues along a load path, its crossings and the pushes off it."""

    def __init__(self, path: Path, solver: str | None):
        """The observer of ``path``; ``solver``: the eigensolver asked for (None: no check)."""
        self.path = path
        self.eigensolver = eigen.resolve_solver(solver) if solver else None
        self.crossings: list[float] = []  # interpolated load factors where the lowest turns < 0
        self.perturbations: list[dict[str, float]] = []  # pushes off unstable states

    def lowest_eigenpairs(self, stability: Stability) -> eigen.Eigenpairs:
        """The Hessian eigenpairs of the current state nearest ``stability.shift`` (free dofs).

        The eigenvectors live on the free unknowns; destroy them after use.
        """
        with self._free_hessian() as free:
            return eigen.nearest_eigenpairs(
                free, stability.modes, stability.shift, stability.solver, stability.tol
            )

    def negative_eigenvalues(self) -> int:
        """The number of negative Hessian eigenvalues of the current state (free dofs; inertia).

        Zero for a stable state; unlike :meth:`lowest_eigenpairs` it cannot miss a negative
        eigenvalue far from the shift (:func:`dgplate.solvers.eigen.negative_count`).
        """
        with self._free_hessian() as free:
            return eigen.negative_count(free)

    @contextmanager
    def _free_hessian(self) -> Iterator[PETSc.Mat]:
        """The Hessian of the current state on the free unknowns (destroyed on exit)."""
        free = self.path.newton.free_hessian()
        try:
            yield free
        finally:
            free.destroy()

    def check(self, factor: float, stability: Stability) -> tuple[float, int]:
        """The lowest eigenvalue after the step (and after a perturbation), Newton its spent.

        NaN when the eigensolver fails (a singular Hessian at the shift): the run goes on.
        """
        try:
            pairs = self.lowest_eigenpairs(stability)
        except SolverError as err:
            _log.warning("no lowest eigenvalue at load factor %g: %s", factor, err)
            return math.nan, 0
        lowest = float(pairs.values[0]) if len(pairs.values) else math.nan
        history = self.path.history
        previous = getattr(history[-1], LOWEST) if history else math.nan
        if previous >= 0 > lowest:
            f0 = history[-1].load_factor
            self.crossings.append(f0 + (factor - f0) * previous / (previous - lowest))
        its = 0
        branches = self.path.branches
        if stability.leave and lowest < -self.stable_tol(stability.leave, lowest):
            return branches.leave_branch(factor, stability, stability.leave, pairs)
        if stability.perturb and lowest < 0 and not previous < 0:
            amplitude, its = branches.leave_unstable(factor, stability, pairs.vectors[0])
            self.perturbations.append(
                {"load_factor": factor, "eigenvalue": lowest, "amplitude": amplitude}
            )
            pairs.destroy()
            pairs = self.lowest_eigenpairs(stability)
            lowest = float(pairs.values[0]) if len(pairs.values) else math.nan
        pairs.destroy()
        return lowest, its

    def stable_tol(self, leave: Leave, lowest: float) -> float:
        """−tol is the least lowest eigenvalue of a stable state (:class:`Leave`)."""
        met = [
            abs(getattr(r, LOWEST)) for r in self.path.history if math.isfinite(getattr(r, LOWEST))
        ]
        return float(leave.eig_rtol * max([abs(lowest), *met]))

    def checkpoint_state(self) -> dict[str, Any]:
        """The crossings and the perturbations so far."""
        return {"crossings": self.crossings, "perturbations": self.perturbations}

    def restore_state(self, state: Mapping[str, Any]) -> None:
        """Take back :meth:`checkpoint_state` (missing keys: none)."""
        self.crossings = [float(f) for f in state.get("crossings", [])]
        self.perturbations = [dict(p) for p in state.get("perturbations", [])]

    def summary(self) -> dict[str, Any]:
        """The lowest eigenvalue per step, the crossings, the pushes and the eigensolver.

        The first crossing is ``critical_load_factor`` (None if none).
        """
        return {
            "lowest_eigenvalues": [getattr(record, LOWEST) for record in self.path.history],
            "critical_load_factors": self.crossings,
            "critical_load_factor": self.crossings[0] if self.crossings else None,
            "perturbations": self.perturbations,
            "eigensolver": self.eigensolver,
        }
