"""The SQP (Newton) step of the constrained flow: the step matrix with the Lagrangian's curvature.

The flow's step matrix (1/τ)(·,·)_* + D²E_impl + b_n lacks two second derivatives of the
Lagrangian L(y, λ) = E_h[y] + Σ_T ∫_T λ : (∇yᵀ∇y − I): the explicit terms' D²E_expl[yⁿ] and
the constraint's curvature λ : (∇δyᵀ∇v + ∇vᵀ∇δy). At large τ the metric term hardly acts, the
step is an SQP step with an incomplete Hessian and converges only linearly. With both terms
added, at the multipliers λⁿ of the previous step solve,

    (1/τ)(δy, v)_* + D²E_impl(δy, v) + D²E_expl[yⁿ](δy, v) + λⁿ : (∇δyᵀ∇v + ∇vᵀ∇δy)
        + b_n(v, λ) = −DE_h[yⁿ](v),        b_n(δy, q) = 0,

is Newton's method on the KKT system of the discrete constrained problem, damped by the
metric term (1/τ)(·,·)_*: it converges quadratically near a non-degenerate minimiser. The
Hessian of the Lagrangian may be indefinite away from one, so the flow accepts such a step
only when it lowers E_h (:meth:`dgplate.solvers.tau.TauController._adaptive_step`).

The curvature terms couple the components of y and have facet terms (D²E_expl), so this
matrix has DOLFINx's own sparsity pattern and its own LU factorisation at every step.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from petsc4py import PETSc

from dgplate import compat
from dgplate.compat import Constant, Function
from dgplate.solvers import linear
from dgplate.solvers.constraint import EdgeConstraint, metric_tensor_defect, symmetric
from dgplate.solvers.linear import Options


def lagrangian_curvature(
    y: Function,
    multipliers: Function,
    explicit: ufl.Form | None,
    edge: EdgeConstraint | None,
    scale: Constant,
    directions: tuple[ufl.Argument, ufl.Argument],
) -> ufl.Form:
    """D²_y [E_expl + s Σ_T ∫_T λ : (∇yᵀ∇y − I) (+ the edge moments)] at y in (δy, v).

    ``multipliers`` is the mixed step solution (δy, λ/s[, edge λ/s]): the constraint rows of
    the step are scaled by s, so its multiplier components are λ/s (their sign is that of the
    step: DE_h + b_n(·, λ) = 0 at a critical point). ``directions`` are (trial δy, test v).
    A target metric G (``model.metric``) leaves this curvature as it is: G does not depend on y,
    so D²_y ∫ λ : (∇yᵀ∇y − G) = D²_y ∫ λ : (∇yᵀ∇y − I).
    """
    dy, v = directions
    _, mu, *edge_mu = ufl.split(multipliers)
    constraint = ufl.inner(metric_tensor_defect(y), symmetric(mu)) * ufl.dx
    if edge is not None:
        constraint += edge.residual(y, edge_mu[0])
    lagrangian = scale * constraint
    if explicit is not None:
        lagrangian += explicit
    form: ufl.Form = ufl.derivative(ufl.derivative(lagrangian, y, v), y, dy)
    return form


class NewtonStep:
    """The SQP step matrix K_N = K + H (step matrix plus Lagrangian curvature) and its solver.

    Only the curvature H is a form of its own (the step matrix K is the flow's, assembled
    already): it is compiled and its matrices allocated at the first use, so runs that never
    reach the Newton phase pay nothing. K_N has the union of the two sparsity patterns, made
    at the first :meth:`assemble`; later ones add K and H into it.
    """

    def __init__(self, comm: MPI.Comm, curvature: ufl.Form, options: Options):
        self.comm, self._ufl, self._options = comm, curvature, options
        self._form: compat.Form | None = None
        self._H: PETSc.Mat | None = None
        self._K: PETSc.Mat | None = None
        self._solver: linear.DirectStepSolver | None = None

    def assemble(self, K: PETSc.Mat) -> linear.DirectStepSolver:
        """K_N = K + H at the current state (collective); returns the solver that factorises it."""
        if self._form is None:
            self._form = dolfinx.fem.form(self._ufl)
            self._H = dolfinx.fem.petsc.assemble_matrix(self._form)
            self._H.assemble()
        assert self._H is not None
        compat.assemble_matrix_into(self._H, self._form)
        if self._K is None:
            self._K = K.duplicate(copy=True)
            self._K.axpy(1.0, self._H, structure=compat.DIFFERENT_NONZERO_PATTERN)
            self._solver = linear.DirectStepSolver(self.comm, self._K, self._options, prefix=None)
        else:
            self._K.zeroEntries()
            self._K.axpy(1.0, K, structure=compat.SUBSET_NONZERO_PATTERN)
            self._K.axpy(1.0, self._H, structure=compat.SUBSET_NONZERO_PATTERN)
        assert self._solver is not None
        return self._solver

    @property
    def factorisations(self) -> int:
        """LU factorisations of K_N so far."""
        return self._solver.factorisations if self._solver is not None else 0

    def destroy(self) -> None:
        """Free the solver and the matrix."""
        if self._solver is not None:
            self._solver.destroy()
        for matrix in (self._H, self._K):
            if matrix is not None:
                matrix.destroy()


__all__ = ["NewtonStep", "lagrangian_curvature"]
