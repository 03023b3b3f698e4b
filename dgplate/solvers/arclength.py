"""Pseudo-arclength continuation of R(u, λ) = 0 through folds, with the stability index.

The equilibria of an energy Π(u; λ) form curves in (u, λ). Newton at fixed load factors
(:class:`dgplate.solvers.newton.LoadPath`) stops where the load factor turns (a fold, a limit
point); here the curve is parametrised by its arclength s instead (Keller 1977; in FEniCSx, the
Crisfield arc-length continuation of dolfiny). With the scaled inner product

    ⟨(a, α), (b, β)⟩ = aᵀb / σ² + αβ,    σ = ‖∂u/∂λ‖ at the start of the path

(so both parts count alike, and ``ds`` is measured in load factor), each step from a point
(u₀, λ₀) with unit tangent (t, τ) is

- the predictor (u₀ + ds t, λ₀ + ds τ),
- the corrector: Newton on R(u, λ) = 0 together with ⟨(t, τ), (u − u₀, λ − λ₀)⟩ = ds, solved
  by Keller's bordering: with one factorisation of the Jacobian J, J δu₁ = −R and
  J δu₂ = −∂R/∂λ, then δλ = −(g + ⟨t, δu₁⟩/σ²)/(⟨t, δu₂⟩/σ² + τ) and δu = δu₁ + δλ δu₂,
- the tangent at the new point: (δu₂, 1) normalised, oriented along the previous tangent.

R is the residual as the Newton solver of the load path assembles it
(:class:`dgplate.solvers.snes.NewtonSolver`: ``ufl.derivative`` of Π, Dirichlet rows u − λg₁).
∂R/∂λ is (R(u, λ + h) − R(u, λ − h))/2h, h = 1 by default: exact, because at a fixed state R is
at most quadratic in λ for every load the FvK model scales (a parameter on which R depends
otherwise, e.g. a clamp's angle, takes a small h: an error O(h²)). The terms of Π in λ² do not depend on u, so the
derivative R and the Jacobian J are affine in λ; the Dirichlet rows lift the data λg by J, and
J(λ)(λg − u) is quadratic in λ.

Step length (:class:`StepLength`): a step whose corrector converged in at most ``fast``
iterations makes the next one ``grow`` times longer (at most ``ds_max``); a failed corrector
halves the step and tries again (at least ``ds_min``).

Stability index: the number of negative eigenvalues of the Hessian on the free unknowns at each
point, from the inertia of its LDLᵀ factorisation (MUMPS,
:func:`dgplate.solvers.eigen.negative_count`). Special points between two points of the path:

- a fold (limit point) where the tangent's λ-component τ changes sign (the index changes by
  one there as well); located by the secant method (Illinois) on τ as a function of the step
  from the earlier point;
- a simple bifurcation where the index changes (k − 1 ↔ k) and τ does not; located by the
  secant method on the k-th lowest Hessian eigenvalue, the one that changes sign
  (:func:`dgplate.solvers.eigen.nearest_eigenpairs`).

Branch switching: at the first bifurcation located, the path can leave along the critical
eigenvector φ (zero on the Dirichlet unknowns): the predictor is the bifurcation point pushed by
ds along φ, the constraint holds the component along φ, so the corrector cannot return to the
branch it left.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from dgplate.errors import SolverError
from dgplate.solvers import eigen, linear
from dgplate.solvers.newton import LoadFactor
from dgplate.solvers.snes import NewtonSolver

#: The kinds of the points of a path: a regular point, the two special points, the first
#: point on a branch left from a bifurcation, the point after a special point not located.
KINDS = ("regular", "fold", "bifurcation", "switch", "fold_unlocated", "bifurcation_unlocated")


@contextlib.contextmanager
def petsc_failure(what: str) -> Iterator[None]:
    """A PETSc error inside becomes a :class:`SolverError`: "<what> failed: <PETSc's reason>".

    Args:
        what: the operation, the subject of the message.

    Returns:
        The context manager.
    """
    try:
        yield
    except PETSc.Error as err:
        raise SolverError(f"{what} failed: {linear.petsc_reason(err)}") from None


@dataclass(frozen=True)
class StepLength:
    """The arclength step control: grow after fast convergence, halve on failure, bounded.

    Attributes:
        ds: the first step (load-factor units, :mod:`dgplate.solvers.arclength`).
        ds_max: the longest step.
        ds_min: the shortest step: a corrector that fails at it ends the path.
        fast: a corrector converged in at most this many iterations grows the next step ...
        grow: ... by this factor.
    """

    ds: float
    ds_max: float
    ds_min: float = 1e-6
    fast: int = 4
    grow: float = 1.5

    def after(self, ds: float, iterations: int) -> float:
        """The step after a converged corrector.

        Args:
            ds: the step that converged.
            iterations: its corrector's iterations.

        Returns:
            ``grow`` times ``ds`` (at most ``ds_max``) after at most ``fast`` iterations, else
            ``ds``.
        """
        return min(ds * self.grow, self.ds_max) if iterations <= self.fast else ds

    def halved(self, ds: float) -> float:
        """The step after a failed corrector.

        Args:
            ds: the step that failed.

        Returns:
            ``ds``/2; a SolverError when that is below ``ds_min``.
        """
        if ds / 2 < self.ds_min:
            raise SolverError(f"the arclength step fell below ds_min = {self.ds_min:g}")
        return ds / 2


class Bordered:
    """The Newton system of R(u, λ) = 0: its residual, ∂R/∂λ and solves with J (collective).

    One MUMPS LU factorisation of J serves the two solves of each bordered iteration.

    Args:
        newton: the assembler of R and J at its state.
        load: the load factor and the Dirichlet data that grow with it.
        prefix: the PETSc options prefix of the linear solver.
        step: the step h of the central difference ∂R/∂λ.
    """

    def __init__(
        self, newton: NewtonSolver, load: LoadFactor, prefix: str, step: float = 1.0
    ) -> None:
        self.newton, self.load, self.step = newton, load, step
        comm = newton.state.function_space.mesh.comm
        self.ksp = linear.make_ksp(comm, newton.jacobian(), prefix=prefix, key="path")
        vector = newton.state.x.petsc_vec
        self._plus, self._minus = vector.duplicate(), vector.duplicate()

    def residual(self, lam: float, out: PETSc.Vec) -> None:
        """R(u, λ) of the current state u into ``out``; the load factor is left at λ.

        Args:
            lam: the load factor λ.
            out: the vector written.
        """
        self.load.set(lam)
        self.newton.residual(out)

    def load_derivative(self, lam: float, out: PETSc.Vec) -> None:
        """∂R/∂λ of the current state into ``out``: the central difference of step h.

        Exact when R is at most quadratic in λ, else an error O(h²) (the module's docstring).

        Args:
            lam: the load factor λ (the load factor is left there).
            out: the vector written.
        """
        self.residual(lam + self.step, self._plus)
        self.residual(lam - self.step, self._minus)
        self._plus.copy(out)
        out.axpy(-1.0, self._minus)
        out.scale(0.5 / self.step)
        self.load.set(lam)

    def factorise(self, lam: float) -> None:
        """Assemble J at the current state and factorise it.

        Args:
            lam: the load factor J is assembled at (the load factor is left there).
        """
        self.load.set(lam)
        self.ksp.setOperators(self.newton.jacobian())
        linear.factorise(self.ksp)

    def solve(self, rhs: PETSc.Vec, out: PETSc.Vec) -> None:
        """Solve J out = −rhs with the current factorisation.

        Args:
            rhs: the right-hand side (negated).
            out: the solution written.
        """
        linear.solve(self.ksp, rhs, out)
        out.scale(-1.0)

    def destroy(self) -> None:
        """Free the solver and the work vectors."""
        linear.destroy_ksp(self.ksp)
        for vector in (self._plus, self._minus):
            vector.destroy()


@dataclass(frozen=True)
class Multipliers:
    """The multipliers among the unknowns of a Lagrangian (:mod:`dgplate.solvers.constrained_path`).

    Attributes:
        rows: m, the negative eigenvalues its KKT Jacobian has whatever the state: the
            stability index is the negative count less m.
        weight: 1 on the state's unknowns, 0 on the multipliers': the arclength counts the
            state only (destroyed with the engine).
    """

    rows: int
    weight: PETSc.Vec


@dataclass
class Point:
    """A converged point of the path with its unit tangent (t, τ) and its stability index."""

    lam: float
    x: PETSc.Vec
    t: PETSc.Vec
    tau: float
    index: int
    iterations: int = 0

    def destroy(self) -> None:
        """Free the vectors."""
        self.x.destroy()
        self.t.destroy()


def secant_root(
    f: Callable[[float], float], a: float, fa: float, b: float, fb: float, xtol: float
) -> float:
    """A root of f in [a, b], f(a) and f(b) of opposite signs: the Illinois secant method.

    Args:
        f: the function; its evaluations may change state (the last is at the root returned).
        a: one end of the bracket ...
        fa: ... and f there.
        b: the other end ...
        fb: ... and f there.
        xtol: the bracket's width at which the iteration stops (at most 12 evaluations).

    Returns:
        The last point evaluated, the root's estimate.
    """
    s = b
    for _ in range(12):
        if fb == fa:  # both ends are roots to round-off (eigenvalues within it of 0)
            break
        s = b - fb * (b - a) / (fb - fa)
        fs = f(s)
        if fs == 0 or abs(b - a) <= xtol:
            break
        if (fs > 0) == (fb > 0):
            fa /= 2  # Illinois: the end kept twice has its value halved
        else:
            a, fa = b, fb
        b, fb = s, fs
    return s


class ArcLength:
    """Pseudo-arclength predictor, bordered corrector, tangents and stability indices.

    Args:
        newton: the residual and Jacobian of R(u, λ) at its state (the path's unknowns).
        load: the load factor and the Dirichlet data that grow with it.
        prefix: the PETSc options prefix of the bordered system's linear solver.
        derivative_step: the step h of the central difference ∂R/∂λ.
        multipliers: the multipliers of a Lagrangian among the unknowns (None: none).
        tol: the corrector stops when the scaled norm of its update is below ``tol`` ...
        stall: ... or below ``stall`` and no longer falling tenfold per iteration (round-off).
        max_iterations: corrector iterations at most.

    All methods are collective.
    """

    def __init__(
        self,
        newton: NewtonSolver,
        load: LoadFactor,
        prefix: str,
        derivative_step: float = 1.0,
        multipliers: Multipliers | None = None,
        tol: float = 1e-9,
        stall: float = 1e-6,
        max_iterations: int = 12,
    ) -> None:
        self.newton, self.load, self.state = newton, load, newton.state
        self.multipliers = multipliers
        self.system = Bordered(newton, load, prefix, derivative_step)
        self.tol, self.stall, self.max_iterations = tol, stall, max_iterations
        self.sigma = 1.0  # the scale of the state: ‖∂u/∂λ‖ at the start
        vector = self.state.x.petsc_vec
        self._r, self._r_lam, self._du1, self._du2, self._weighted = (
            vector.duplicate() for _ in range(5)
        )

    def inner(self, a: PETSc.Vec, b: PETSc.Vec) -> float:
        """The state part aᵀb/σ² of the scaled inner product (the weighted unknowns only)."""
        return self._dot(a, b) / self.sigma**2

    def _dot(self, a: PETSc.Vec, b: PETSc.Vec) -> float:
        """aᵀb over the unknowns the weight counts."""
        if self.multipliers is None:
            return float(np.real(a.dot(b)))
        self._weighted.pointwiseMult(self.multipliers.weight, b)
        return float(np.real(a.dot(self._weighted)))

    def start(self, lam: float, sigma: float | None = None) -> Point:
        """The first point: the state solved at ``lam`` by the load path's Newton solver.

        Args:
            lam: the load factor of the start.
            sigma: the scale σ of the state (a resumed path's); None: ‖∂u/∂λ‖ here.

        Returns:
            The point, its tangent towards increasing λ.
        """
        self.load.set(lam)
        reason, its = self.newton.solve()
        if reason < 0:
            raise SolverError(f"Newton failed at the start of the path (load factor {lam:g})")
        if sigma is None:
            du = self._load_tangent(lam)
            sigma = math.sqrt(self._dot(du, du)) or 1.0
        self.sigma = sigma
        return self.point(lam, None, int(its))

    def _load_tangent(self, lam: float) -> PETSc.Vec:
        """δu₂ = −J⁻¹ ∂R/∂λ at the current state (the work vector, overwritten later)."""
        with petsc_failure("the tangent's solve"):
            self.system.factorise(lam)
            self.system.load_derivative(lam, self._r_lam)
            self.system.solve(self._r_lam, self._du2)
        du: PETSc.Vec = self._du2
        return du

    def tangent(self, lam: float, along: tuple[PETSc.Vec, float] | None) -> tuple[PETSc.Vec, float]:
        """The unit tangent (t, τ) at the current state.

        Args:
            lam: the load factor of the state.
            along: the direction (t, τ) the tangent is oriented along; None: λ up.

        Returns:
            (t, τ); ``t`` is a work vector, overwritten by the next solve.
        """
        t = self._load_tangent(lam)
        norm = math.sqrt(self.inner(t, t) + 1.0)
        t.scale(1.0 / norm)
        tau = 1.0 / norm
        if along is not None and self.inner(t, along[0]) + tau * along[1] < 0:
            t.scale(-1.0)
            tau = -tau
        return t, tau

    def point(
        self, lam: float, along: tuple[PETSc.Vec, float] | None, iterations: int = 0
    ) -> Point:
        """The current state as a point, with its unit tangent and its stability index.

        Args:
            lam: the load factor of the state.
            along: the direction the tangent is oriented along; None: λ up.
            iterations: the corrector iterations that reached it.

        Returns:
            The point (copies of the state and of the tangent: destroy it).
        """
        t, tau = self.tangent(lam, along)
        return Point(lam, self.state.x.petsc_vec.copy(), t.copy(), tau, self.index(), iterations)

    def set_state(self, point: Point) -> None:
        """Set the state and the load factor to those of ``point``.

        Args:
            point: the point.
        """
        point.x.copy(self.state.x.petsc_vec)
        self.state.x.scatter_forward()
        self.load.set(point.lam)

    def index(self) -> int:
        """The stability index of the current state.

        Returns:
            The number of negative Hessian eigenvalues on the free unknowns (the inertia),
            less the rows of the multipliers.
        """
        with petsc_failure("the Hessian on the free unknowns"):
            hessian = self.newton.free_hessian()
        try:
            rows = self.multipliers.rows if self.multipliers is not None else 0
            return eigen.negative_count(hessian) - rows
        finally:
            hessian.destroy()

    def correct(
        self, base: Point, ds: float, direction: tuple[PETSc.Vec, float]
    ) -> tuple[float, int] | None:
        """The predictor ``ds`` along ``direction`` from ``base``, then the bordered corrector.

        Args:
            base: the point the step starts from (u₀, λ₀).
            ds: the step length.
            direction: the unit direction (t, τ) of the predictor and of the constraint.

        Returns:
            (λ, iterations) with the state converged, or None when the corrector failed (the
            state is then a failed iterate).
        """
        t, tau = direction
        x = self.state.x.petsc_vec
        base.x.copy(x)
        x.axpy(ds, t)
        self.state.x.scatter_forward()
        lam = base.lam + ds * tau
        previous = math.inf
        for iteration in range(1, self.max_iterations + 1):
            step = self._bordered_step(base, ds, direction, lam)
            if step is None:
                return None
            dlam, size = step
            lam += dlam
            # converged, or stalled at round-off (near a fold J is nearly singular)
            if size <= self.tol or (size <= self.stall and size > previous / 10):
                self.load.set(lam)
                return lam, iteration
            if iteration >= 4 and size > previous:
                return None
            previous = size
        return None

    def _bordered_step(
        self, base: Point, ds: float, direction: tuple[PETSc.Vec, float], lam: float
    ) -> tuple[float, float] | None:
        """One bordered Newton update of the state: (δλ, the scaled size of the update)."""
        t, tau = direction
        system, x = self.system, self.state.x.petsc_vec
        system.residual(lam, self._r)
        system.load_derivative(lam, self._r_lam)
        try:
            system.factorise(lam)
            system.solve(self._r, self._du1)
            system.solve(self._r_lam, self._du2)
        except (SolverError, PETSc.Error):
            return None
        self._r.waxpy(-1.0, base.x, x)  # u − u₀ (the residual is spent)
        g = self.inner(t, self._r) + tau * (lam - base.lam) - ds
        dlam = -(g + self.inner(t, self._du1)) / (self.inner(t, self._du2) + tau)
        self._du1.axpy(dlam, self._du2)
        x.axpy(1.0, self._du1)
        self.state.x.scatter_forward()
        size = math.sqrt(self.inner(self._du1, self._du1) + dlam**2)
        return (dlam, size) if math.isfinite(size) else None

    def destroy(self) -> None:
        """Free the solver and the work vectors."""
        self.system.destroy()
        for vector in (self._r, self._r_lam, self._du1, self._du2, self._weighted):
            vector.destroy()
        if self.multipliers is not None:
            self.multipliers.weight.destroy()
