"""The rod flow's forms, constraint defects and stationarity measure (:mod:`dgplate.solvers.rod_flow`, docs/rods.md).

The derivative along the rod, the C⁰ interior-penalty product of u″ and its Nitsche terms at a
clamp, the flow's metric, the vertex rule of the nodal constraint, the defects of the three
constraints and the τ-independent measure of the stop.
"""

from __future__ import annotations

import math
from typing import Any

import basix.ufl
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc
from ufl.core.expr import Expr

from dgplate import compat, mpi, values
from dgplate.compat import Function, FunctionSpace, Mesh
from dgplate.dg.forms import integral
from dgplate.solvers.linear import DirectStepSolver, OptionValue

__all__ = [
    "Defects",
    "RodStationarity",
    "ip_jumps",
    "ip_product",
    "metric",
    "nitsche_slope",
    "nodal",
    "tangent",
]


def tangent(u: Expr) -> Expr:
    """u′ = du/ds on the 1D mesh (a 3-vector).

    On an interval of ℝ, d/dx. On a closed polygon in ℝ² (a closed rod), the derivative along
    the unit tangent T = J/|J| of each cell; the cells are numbered around the polygon, so T
    turns one way and u′ is continuous where u is smooth.
    """
    domain = ufl.domain.extract_unique_domain(u)
    if ufl.SpatialCoordinate(domain).ufl_shape[0] == 1:
        out: Expr = u.dx(0)
        return out
    J = ufl.Jacobian(domain)
    column = ufl.as_vector([J[0, 0], J[1, 0]])
    along: Expr = ufl.dot(ufl.grad(u), column / ufl.sqrt(ufl.dot(column, column)))
    return along


def nodal(mesh: Mesh) -> ufl.Measure:
    """The measure dx with the vertex rule: ∫ f q becomes Σ_nodes w_z f(z) q(z) for P₁ functions."""
    return ufl.Measure(
        "dx", domain=mesh, metadata={"quadrature_rule": "vertex", "quadrature_degree": 1}
    )


class Defects:
    """The constraint defects of (u, b) (collective).

    ∫ ||u′|² − 1| and ∫ |u′·b| over the rod, the largest nodal ||b|² − 1|, and the largest
    ||u′|² − 1| and |u′·b| at the two Gauss points of each cell. For k = 2 the latter are the
    constraints the flow imposes: (|u′|² − 1)q and (u′·b)q are cubics for q ∈ DG₁, which the
    two-point Gauss rule integrates exactly, so the two moments vanish exactly when the values
    at the two points do.
    """

    def __init__(self, u: Function, b: Function):
        mesh = u.function_space.mesh
        t = tangent(u)
        self.u, self.b = u, b
        self.forms = {
            "defect_tangent": dolfinx.fem.form(abs(ufl.dot(t, t) - 1.0) * ufl.dx(domain=mesh)),
            "defect_orthogonality": dolfinx.fem.form(abs(ufl.dot(t, b)) * ufl.dx(domain=mesh)),
        }
        gauss = basix.ufl.quadrature_element(mesh.basix_cell(), value_shape=(2,), degree=3)
        self._at_points: Function = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, gauss))
        space = self._at_points.function_space
        self._points: compat.Expression = dolfinx.fem.Expression(
            ufl.as_vector([ufl.dot(t, t) - 1.0, ufl.dot(t, b)]),
            compat.interpolation_points(space.element),
        )
        self._dofs = space.dofmap.list[: mesh.topology.index_map(1).size_local].ravel()

    def __call__(self) -> dict[str, float]:
        """The five defects now."""
        comm = self.u.function_space.mesh.comm
        out = {key: integral(form, comm) for key, form in self.forms.items()}
        owned = self.b.function_space.dofmap.index_map.size_local
        nodes = self.b.x.array.reshape(-1, 3)[:owned]
        local = float(np.max(np.abs(np.sum(nodes**2, axis=1) - 1.0), initial=0.0))
        out["defect_frame"] = mpi.global_max(comm, local)
        self._at_points.interpolate(self._points)
        values = np.abs(self._at_points.x.array.reshape(-1, 2)[self._dofs])
        for column, key in enumerate(("max_defect_tangent", "max_defect_orthogonality")):
            out[key] = mpi.global_max(comm, float(np.max(values[:, column], initial=0.0)))
        return out


class RodStationarity:
    """‖P DE[u, b]‖_*': the KKT residual of the rod's constrained problem, free of τ.

    With M the metric (its L² parts included), g solves M g + B_n(·, μ) = −DE[uⁿ, bⁿ],
    B_n(g, q) = 0, and the measure is ‖g‖_M = (−DE[uⁿ, bⁿ](g))^½, as the plates'
    :class:`dgplate.solvers.stationarity.Stationarity`. One assembly and one LU solve per call,
    compiled at the first.
    """

    def __init__(
        self,
        space: FunctionSpace,
        form: ufl.Form,
        bcs: list[Any],
        rhs: PETSc.Vec,
        gradient: compat.Form,
        options: dict[str, OptionValue],
    ):
        """The measure on the flow's mixed ``space`` with the matrix ``form`` (M + B_n + B_nᵀ).

        ``bcs``: the flow's end conditions; ``gradient`` is the compiled −DE, assembled into the flow's vector ``rhs``; ``options``
        the PETSc options of the solve (``flow.solver``).
        """
        self._ufl, self._bcs, self._rhs, self._gradient = form, bcs, rhs, gradient
        self._options = options
        self._built: tuple[compat.Form, PETSc.Mat, DirectStepSolver] | None = None
        self._g: Function = dolfinx.fem.Function(space)

    def __call__(self) -> float:
        """The measure at the current state (collective)."""
        if self._built is None:
            form = dolfinx.fem.form(self._ufl)
            matrix = dolfinx.fem.petsc.create_matrix(form)
            comm = self._g.function_space.mesh.comm
            self._built = form, matrix, DirectStepSolver(comm, matrix, self._options, None)
        form, matrix, solver = self._built
        matrix.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(matrix, form, self._bcs)  # type: ignore[arg-type]
        matrix.assemble()
        compat.assemble_vector_into(self._rhs, self._gradient)
        dolfinx.fem.petsc.set_bc(self._rhs, self._bcs)
        g = self._g.x.petsc_vec
        g.set(0.0)
        solver.solve(self._rhs, g)
        return math.sqrt(max(float(self._rhs.dot(g).real), 0.0))

    def destroy(self) -> None:
        """Free the solver and the matrix (if built)."""
        if self._built is not None:
            self._built[2].destroy()
            self._built[1].destroy()


def ip_product(x: Expr, y: Expr, mesh: Mesh, penalty: Expr) -> ufl.Form:
    """∫x″·y″ by C⁰ interior penalty: symmetric and penalised jumps of the slopes at the nodes.

    The cell integrals Σ_T∫_T x″·y″ plus :func:`ip_jumps`.
    """
    cells: ufl.Form = ufl.dot(tangent(tangent(x)), tangent(tangent(y))) * ufl.dx(domain=mesh)
    form: ufl.Form = cells + ip_jumps(x, y, mesh, penalty)
    return form


def ip_jumps(x: Expr, y: Expr, mesh: Mesh, penalty: Expr) -> ufl.Form:
    """The node terms of the C⁰-IP product: −{x″}·[[y′]] − {y″}·[[x′]] + (σ/h)[[x′]]·[[y′]].

    In 1D a facet is a node, n = ±1 and [[x′]] = x′⁺n⁺ + x′⁻n⁻; ``penalty``/h is the
    stability term (σ ≳ 1 for k = 2). They vanish for a C¹ function.
    """
    h = ufl.avg(ufl.CellDiameter(mesh))
    n = ufl.FacetNormal(mesh)

    def jump(w: Expr) -> Expr:
        """[[∂_n w]] = ∇w⁺n⁺ + ∇w⁻n⁻ (n = ±T: the jump of w′ up to its sign)."""
        out: Expr = ufl.dot(ufl.grad(w)("+"), n("+")) + ufl.dot(ufl.grad(w)("-"), n("-"))
        return out

    def avg2(w: Expr) -> Expr:
        out: Expr = ufl.avg(tangent(tangent(w)))
        return out

    form: ufl.Form = (
        -ufl.dot(avg2(x), jump(y))
        - ufl.dot(avg2(y), jump(x))
        + penalty / h * ufl.dot(jump(x), jump(y))
    ) * ufl.dS(domain=mesh)
    return form


def nitsche_slope(u: Expr, datum: Expr, mesh: Mesh, penalty: Expr, ds: ufl.Measure) -> ufl.Form:
    """½·(the C⁰-IP boundary terms) imposing u′ = ``datum`` weakly at the nodes of ``ds``."""
    h = ufl.CellDiameter(mesh)
    n = ufl.FacetNormal(mesh)
    gap = tangent(u) - datum
    form: ufl.Form = (
        -ufl.dot(tangent(tangent(u)), gap) * n[0] + 0.5 * penalty / h * ufl.dot(gap, gap)
    ) * ds
    return form


def metric(du: Expr, db: Expr, v: Expr, c: Expr, mesh: Mesh, l2: bool) -> ufl.Form:
    """m((δu, δb), (v, c)): the C⁰-IP H² product of u + H¹ of b (+ L² of both if ``l2``)."""
    dx = ufl.dx(domain=mesh)
    penalty = values.constant(mesh, 10.0)
    form: ufl.Form = ip_product(du, v, mesh, penalty) + ufl.dot(tangent(db), tangent(c)) * dx
    if l2:
        form += (ufl.dot(du, v) + ufl.dot(db, c)) * dx
    return form
