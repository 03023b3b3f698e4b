"""Linear clamped biharmonic problem Δ²u = f, the verification case of the dG core.

The discrete problem minimises ½ a_h(u, u) − (f, u) with Nitsche data (docs/design.md §2); the
matrix and right-hand side are the second and first derivatives of that functional, so this
module exercises exactly the code that the nonlinear plate models use.
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from ufl.core.expr import Expr

from dgplate import compat
from dgplate.compat import Function
from dgplate.dg.forms import FacetSets, Penalty, bending_energy, broken_norms
from dgplate.solvers import linear


@dataclass
class BiharmonicResult:
    """The discrete solution, its broken H², H¹ and L² errors, and the number of unknowns."""

    u: Function
    errors: dict[str, float]
    dofs: int


def solve_biharmonic(
    facets: FacetSets,
    degree: int,
    exact: Expr,
    penalty: Penalty,
    shape: tuple[int, ...] = (),
) -> BiharmonicResult:
    """Solve the clamped biharmonic problem whose solution is the UFL expression ``exact``.

    The load is f = Δ²(exact) and the clamped data are g = exact, Φ = ∇exact on the clamped
    facets; ``shape=(3,)`` solves the same problem component-wise for a vector unknown, as the
    plate models do. Returns the discrete solution and its broken H², H¹, L² errors.
    """
    mesh = facets.mesh
    V = dolfinx.fem.functionspace(mesh, ("DG", degree, shape) if shape else ("DG", degree))
    u: Function = dolfinx.fem.Function(V, name="u")
    f = ufl.div(ufl.grad(ufl.div(ufl.grad(exact))))
    energy = bending_energy(u, facets, penalty, g=exact, Phi=ufl.grad(exact))
    energy -= ufl.inner(f, u) * facets.dx
    v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
    residual = ufl.derivative(energy, u, v)
    jacobian = ufl.derivative(residual, u, du)
    # u = 0 here, so the solution of J δ = −F(0) is u itself (the problem is linear)
    A = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(jacobian))
    A.assemble()
    b = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(-residual))
    compat.accumulate_ghosts(b)
    ksp = linear.make_ksp(mesh.comm, A)
    linear.solve(ksp, b, u.x.petsc_vec)
    u.x.scatter_forward()
    errors = broken_norms(u - exact, facets, degree=2 * degree + 6)
    dofs = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
    ksp.destroy()
    A.destroy()
    b.destroy()
    return BiharmonicResult(u, errors, dofs)
