"""Folds and simple bifurcations between two points of an arclength path, and branch switching.

The special points of :mod:`dgplate.solvers.arclength`: a fold where the tangent's λ-component
changes sign, a simple bifurcation where the stability index changes and it does not, both
located by the secant method on the step from the earlier point; the switch leaves a
bifurcation along the critical eigenvector.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np
from petsc4py import PETSc

from dgplate import compat
from dgplate.errors import SolverError
from dgplate.solvers import eigen
from dgplate.solvers.arclength import ArcLength, Point, StepLength, petsc_failure, secant_root

#: Hessian eigenvalues within ROUNDOFF · ε · ‖K‖_∞ of 0 count as zero (round-off): the
#: constant of a backward error of size O(ε‖K‖). Small enough to keep the sign of every
#: eigenvalue the secant needs on the plates of benchmarks/path_following.py (≥ 45 ε‖K‖_∞).
ROUNDOFF = 10.0
#: A special point is located when its corrector fails closer to it than this: a point
#: corrected before, whose |τ| or eigenvalue is below NEAR_ROOT times its values at the ends
#: of the step, is taken as the special point.
NEAR_ROOT = 2e-3


class CorrectorFailed(SolverError):
    """The corrector did not converge at a step tried while locating a special point."""


class SpecialPoints:
    """Folds and simple bifurcations between two points of a path, and the switch at one.

    Args:
        engine: the continuation's predictor, corrector, tangents and indices.
        step: the step control (the switch halves its step as a path step does).

    All methods are collective.
    """

    def __init__(self, engine: ArcLength, step: StepLength) -> None:
        self.engine, self.step = engine, step

    @staticmethod
    def kind(base: Point, new: Point) -> str:
        """The special point between two points of a path.

        Args:
            base: the earlier point.
            new: the later point.

        Returns:
            "fold" (τ changed sign), "bifurcation" (the index changed, τ did not) or "" (none).
        """
        if (base.tau > 0) != (new.tau > 0):
            return "fold"
        return "bifurcation" if base.index != new.index else ""

    def locate(self, kind: str, base: Point, new: Point, ds: float) -> Point:
        """The special point between ``base`` and ``new`` (the secant method on the step).

        Args:
            kind: "fold" (the root of τ) or "bifurcation" (the root of the eigenvalue whose
                sign changes).
            base: the point before it.
            new: the point after it, ``ds`` from ``base``.
            ds: the step from ``base`` to ``new``.

        Returns:
            The located point, the state at it; a SolverError when a corrector fails.
        """
        direction = (base.t, base.tau)
        best = [math.inf, 0.0]  # the smallest |f| corrected so far, and its step

        def corrected(s: float) -> float:
            result = self.engine.correct(base, s, direction)
            if result is None:
                raise CorrectorFailed(f"the corrector failed while locating a {kind}")
            if kind == "fold":
                value = self.engine.tangent(result[0], direction)[1]
            else:
                value = self._crossing_eigenvalue(max(base.index, new.index))
            if abs(value) < best[0]:
                best[:] = [abs(value), s]
            return value

        if kind == "fold":
            ends = base.tau, new.tau
        else:
            ends = corrected(0.0), corrected(ds)
        try:
            secant_root(corrected, 0.0, ends[0], ds, ends[1], xtol=1e-6 * ds)
        except CorrectorFailed:
            # at a simple bifurcation the bordered Jacobian is singular as well, so correctors
            # very near it can fail: a point already found close to it stands for it
            near = best[0] <= NEAR_ROOT * min(abs(ends[0]), abs(ends[1]))
            if kind != "bifurcation" or not near:
                raise
            corrected(best[1])
        special = self.engine.point(self.engine.load.value, direction, 0)
        # the Hessian is singular there: its zero eigenvalue is not negative, and the inertia
        # of the factorisation would count it either way
        special.index = min(base.index, new.index)
        return special

    def _crossing_eigenvalue(self, k: int) -> float:
        """The k-th lowest Hessian eigenvalue (free unknowns), for an index that changes k−1 ↔ k.

        With the index n of the state, it is the negative eigenvalue nearest 0 if n ≥ k, else the
        non-negative one nearest 0 (exactly the k-th lowest when n is k − 1 or k). At the
        crossing itself the eigenvalue's sign is round-off and may contradict the inertia. The
        round-off of the eigensolver and of the LDLᵀ factorisation acts as a perturbation of K of
        size O(ε‖K‖₂), which moves an eigenvalue by as much (Weyl): an eigenvalue within
        :data:`ROUNDOFF` · ε · ‖K‖_∞ of 0 (‖K‖_∞ ≥ ‖K‖₂, K symmetric) is 0, the root.
        """
        negative = self.engine.index()
        pairs, norm = self._eigenpairs()
        try:
            values = pairs.values
            if len(values) and np.abs(values).min() <= ROUNDOFF * np.finfo(float).eps * norm:
                return 0.0
            below, above = values[values < 0], values[values >= 0]
            nearest = below[-1:] if negative >= k else above[:1]
            if not len(nearest):
                raise SolverError("no Hessian eigenvalue of the crossing sign near 0")
            return float(nearest[0])
        finally:
            pairs.destroy()

    def _eigenpairs(self) -> tuple[eigen.Eigenpairs, float]:
        """The 3 eigenpairs of the Hessian on the free unknowns nearest 0, and its ‖K‖_∞."""
        with petsc_failure("the Hessian on the free unknowns"):
            hessian = self.engine.newton.free_hessian()
        try:
            norm = cast(float, hessian.norm(compat.NORM_INFINITY))  # a tuple only for NORM_1_AND_2
            return eigen.nearest_eigenpairs(hessian, 3, 0.0), norm
        finally:
            hessian.destroy()

    def switch(self, at: Point, ds: float) -> Point:
        """The first point on the branch that leaves ``at`` along the critical eigenvector.

        Args:
            at: the bifurcation point.
            ds: the push along the eigenvector (halved while the corrector fails).

        Returns:
            The point, ds from ``at`` along the eigenvector, on the bifurcating branch.
        """
        self.engine.set_state(at)
        mode = self._critical_mode()
        try:
            direction = (mode, 0.0)
            step = ds
            while True:
                corrected = self.engine.correct(at, step, direction)
                if corrected is not None:
                    return self.engine.point(corrected[0], direction, corrected[1])
                step = self.step.halved(step)
        finally:
            mode.destroy()

    def _critical_mode(self) -> PETSc.Vec:
        """The eigenvector of the eigenvalue nearest 0, unit in the scaled norm.

        On all unknowns: 0 on the Dirichlet ones.
        """
        pairs, _ = self._eigenpairs()
        try:
            nearest = int(np.argmin(np.abs(pairs.values)))
            mode: PETSc.Vec = self.engine.state.x.petsc_vec.duplicate()
            mode.set(0.0)
            with mode.localForm() as local:
                local.array[self.engine.newton.free[1]] = eigen.values_of(pairs.vectors[nearest])
            mode.scale(1.0 / np.sqrt(self.engine.inner(mode, mode)))
            return mode
        finally:
            pairs.destroy()
