"""Folds and simple bifurcations between two points of an arclength path, and branch switching.

The special points of :mod:`dgplate.solvers.arclength`: a fold where the tangent's λ-component
changes sign, a simple bifurcation where the stability index changes and it does not, both
located by the secant method on the step from the earlier point and interpolated between the
nearest corrected points on the two sides of the root; the switch leaves a bifurcation along
the critical eigenvector.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, cast

import numpy as np
from petsc4py import PETSc

from dgplate import compat
from dgplate.errors import SolverError
from dgplate.solvers import eigen
from dgplate.solvers.arclength import ArcLength, Point, StepLength, petsc_failure, secant_root

if TYPE_CHECKING:
    from dolfinx.fem import Function

#: Hessian eigenvalues within ROUNDOFF · ε · ‖K‖_∞ of 0 count as zero (round-off) when their
#: sign contradicts the inertia: the constant of a backward error of size O(ε‖K‖). The band
#: is a bound, often far wider than the error: an eigenvalue in it whose sign the inertia
#: confirms is kept (the FvK turned strip on 256 cells, the constrained one on 128 and 256).
ROUNDOFF = 10.0
#: A special point is located when its corrector fails closer to it than this: when a point
#: corrected before has its |τ| or eigenvalue below NEAR_ROOT times its values at the ends of
#: the step, the bracket found stands for the special point.
NEAR_ROOT = 2e-3
#: ... or when the bracket already has a point on each side of the root, neither more than
#: twice as far from it as the other, and is at most BALANCED_WIDTH of the step wide: the
#: interpolated root is then within about its width squared (the heated disc on n = 4: a
#: corrector failed 3.8·10⁻³ of a step from the bifurcation, whose eigenvalue there was
#: 7·10⁻³ of its values at the step's ends).
BALANCED_WIDTH = 1e-2
#: The secant stops when its bracket is SECANT_WIDTH of the step wide (or after 12 values).
SECANT_WIDTH = 1e-6
#: A bracket still wider than this part of the step after the secant and the balancing point
#: locates nothing: the interpolated root would be off by about the bracket's width squared.
LOCATED_WIDTH = 1e-3


class CorrectorFailed(SolverError):
    """The corrector did not converge at a step tried while locating a special point."""


def _balance(bracket: _Bracket, corrected: Callable[[float], float], ds: float) -> None:
    """Correct a point across the root from the bracket's nearer side, as near it, if one fails.

    The secant may close in on the root from one side while its other end stays far; the
    interpolation is then only as good as the far end. A point as far beyond the root as the
    nearer side is evens it; while the corrector fails there, or the bracket is still lopsided
    about the root it gives, a point twice, then four times as far is tried.
    """
    for factor in (1.0, 2.0, 4.0):
        lopsided = bracket.lopsided()
        if lopsided is None:
            return
        root, near, far, far_step = lopsided
        distance = factor * max(near, 1e-9 * ds)
        if distance >= far:  # it would widen the bracket
            return
        try:
            corrected(root + math.copysign(distance, far_step - root))
        except CorrectorFailed:
            continue


class _Bracket:
    """The corrected points nearest a root on each side of it: step, value, state and λ."""

    def __init__(self) -> None:
        self.sides: dict[bool, tuple[float, float, PETSc.Vec, float]] = {}

    def record(self, s: float, value: float, x: PETSc.Vec, lam: float) -> None:
        """Keep (s, value, a copy of x, λ) as the nearest point on the side of value's sign.

        The secant's iterates lie inside the bracket, so each is nearer the root than the
        earlier ones of its sign.
        """
        side = value > 0
        if side in self.sides:
            x.copy(self.sides[side][2])
            self.sides[side] = (s, value, self.sides[side][2], lam)
        else:
            self.sides[side] = (s, value, x.copy(), lam)

    def root(self) -> tuple[float, float]:
        """The step at the interpolated root and the weight θ of the positive side there."""
        (s0, f0, _, _), (s1, f1, _, _) = self.sides[False], self.sides[True]
        theta = f0 / (f0 - f1)  # f0 ≤ 0 < f1
        return s0 + theta * (s1 - s0), theta

    def width(self) -> float:
        """The distance between the two sides (infinite while one has no point)."""
        if len(self.sides) < 2:
            return math.inf
        return abs(self.sides[True][0] - self.sides[False][0])

    def exact(self) -> tuple[float, float, PETSc.Vec, float] | None:
        """A recorded point whose value is exactly 0 (an eigenvalue within round-off), if any."""
        return next((side for side in self.sides.values() if side[1] == 0.0), None)

    def balanced(self, width: float) -> bool:
        """Whether both sides have a point, at most ``width`` apart, neither side lopsided."""
        return len(self.sides) == 2 and self.width() <= width and self.lopsided() is None

    def lopsided(self) -> tuple[float, float, float, float] | None:
        """The root, its distances to the nearer and the farther side, and that side's step.

        Returns:
            Those four when the farther side is more than twice as far as the nearer, else None
            (also with no bracket, or a root found exactly).
        """
        if len(self.sides) < 2 or self.exact() is not None:
            return None
        root = self.root()[0]
        (near, _), (far, far_step) = sorted(
            (abs(side[0] - root), side[0]) for side in self.sides.values()
        )
        return (root, near, far, far_step) if far > 2 * near else None

    def interpolate(self, state: Function[np.float64]) -> float:
        """Set ``state`` to the linear interpolant at the root between the two sides.

        A point whose value is exactly 0 is the root itself.

        Returns:
            λ there; a SolverError when one side has no point.
        """
        vec = state.x.petsc_vec
        exact = self.exact()
        if exact is not None:
            exact[2].copy(vec)
            state.x.scatter_forward()
            return exact[3]
        if len(self.sides) < 2:
            raise SolverError("the special point's root has no corrected point on one side")
        (_, _, x0, lam0), (_, _, x1, lam1) = self.sides[False], self.sides[True]
        theta = self.root()[1]
        x0.copy(vec)
        vec.axpy(theta, x1)
        vec.axpy(-theta, x0)
        state.x.scatter_forward()
        return lam0 + theta * (lam1 - lam0)

    def destroy(self) -> None:
        """Free the copies."""
        for side in self.sides.values():
            side[2].destroy()


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
        best = [math.inf]  # the smallest |f| corrected so far
        bracket = _Bracket()

        def corrected(s: float) -> float:
            result = self.engine.correct(base, s, direction)
            if result is None:
                raise CorrectorFailed(f"the corrector failed while locating a {kind}")
            if kind == "fold":
                value = self.engine.tangent(result[0], direction)[1]
            else:
                value = self._crossing_eigenvalue(max(base.index, new.index))
            bracket.record(s, value, self.engine.state.x.petsc_vec, result[0])
            best[0] = min(best[0], abs(value))
            return value

        try:
            if kind == "fold":
                bracket.record(0.0, base.tau, base.x, base.lam)
                bracket.record(ds, new.tau, new.x, new.lam)
                ends = base.tau, new.tau
            else:
                ends = corrected(0.0), corrected(ds)
            try:
                secant_root(corrected, 0.0, ends[0], ds, ends[1], xtol=SECANT_WIDTH * ds)
            except CorrectorFailed:
                # the Hessian is singular at a fold and at a simple bifurcation, and the bordered
                # Jacobian at a bifurcation as well, so correctors very near the root can fail:
                # the bracket already found close to it stands for it
                near = best[0] <= NEAR_ROOT * min(abs(ends[0]), abs(ends[1]))
                if not near and not bracket.balanced(BALANCED_WIDTH * abs(ds)):
                    raise
                _balance(bracket, corrected, ds)
            else:
                self._close_in(bracket, corrected, ds)
            # the root by linear interpolation between the nearest corrected points on its two
            # sides: within O(h²) of it for a bracket h wide, where the last secant iterate (or
            # the nearest point) is within O(h)
            self.engine.load.set(bracket.interpolate(self.engine.state))
        finally:
            bracket.destroy()
        special = self.engine.point(self.engine.load.value, direction, 0)
        # the Hessian is singular there: its zero eigenvalue is not negative, and the inertia
        # of the factorisation would count it either way
        special.index = min(base.index, new.index)
        return special

    @staticmethod
    def _close_in(bracket: _Bracket, corrected: Callable[[float], float], ds: float) -> None:
        """After a secant that spent its values with its bracket still wide: even it, or fail.

        Raises:
            SolverError: the bracket is still wider than :data:`LOCATED_WIDTH` of the step.
        """
        if bracket.exact() is not None or bracket.width() <= 2 * SECANT_WIDTH * abs(ds):
            return
        _balance(bracket, corrected, ds)
        if bracket.width() > LOCATED_WIDTH * abs(ds):
            raise SolverError(
                f"the secant left the special point's bracket {bracket.width():.2g} wide "
                f"(the step: {ds:.3g})"
            )

    def _crossing_eigenvalue(self, k: int) -> float:
        """The k-th lowest Hessian eigenvalue (free unknowns), for an index that changes k−1 ↔ k.

        With the index n of the state, it is the negative eigenvalue nearest 0 if n ≥ k, else the
        non-negative one nearest 0 (exactly the k-th lowest when n is k − 1 or k). At the
        crossing itself the eigenvalue's sign is round-off and may contradict the inertia. The
        round-off of the eigensolver and of the LDLᵀ factorisation acts as a perturbation of K of
        size O(ε‖K‖₂), which moves an eigenvalue by as much (Weyl): an eigenvalue within
        :data:`ROUNDOFF` · ε · ‖K‖_∞ of 0 (‖K‖_∞ ≥ ‖K‖₂, K symmetric) whose sign contradicts
        the inertia is 0, the root; one whose sign the inertia confirms is kept (on fine meshes
        the penalties make ‖K‖ so large that this band holds eigenvalues the secant still
        needs: the turned strip on 256 cells of a constrained plate, ε‖K‖_∞ = 6·10⁻⁵).
        """
        negative = self.engine.index()
        pairs, norm = self._eigenpairs()
        try:
            values = pairs.values
            below, above = values[values < 0], values[values >= 0]
            nearest = below[-1:] if negative >= k else above[:1]
            roundoff = ROUNDOFF * np.finfo(float).eps * norm
            if len(values) and np.abs(values).min() <= roundoff:
                smallest = values[np.argmin(np.abs(values))]
                if not len(nearest) or nearest[0] != smallest:
                    return 0.0  # the eigenvalue nearest 0 has the sign the inertia denies
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
