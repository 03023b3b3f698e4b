"""Geometry that several layers need, written once: cell sizes and areas, deformed surfaces.

The UFL expressions here are those of the differential geometry of a deformed plate
y: ω → ℝ³ (its unit normal ν, its second fundamental form II, the image ∇y·d of a reference
direction d); the NumPy functions measure the reference mesh.
"""

from __future__ import annotations

from collections.abc import Sequence

import dolfinx.fem
import numpy as np
import ufl
from ufl.constantvalue import Zero
from ufl.core.expr import Expr

from dgplate import mpi
from dgplate.compat import Array, Function, FunctionSpace, Mesh


def max_cell_diameter(mesh: Mesh) -> float:
    """The largest cell diameter over all ranks (τ = 'h' in problem files, as published)."""
    tdim = mesh.topology.dim
    num_owned = mesh.topology.index_map(tdim).size_local
    local = mesh.h(tdim, np.arange(num_owned, dtype=np.int32))
    return mpi.global_max(mesh.comm, float(local.max(initial=0.0)))


def cell_areas(space: FunctionSpace) -> Array:
    """|T| at the degree of freedom of each cell T of the DG0 ``space`` (owned dofs first).

    Ghost entries are zero: only owned cells are integrated.
    """
    form = dolfinx.fem.form(ufl.TestFunction(space) * ufl.dx)
    areas: Array = dolfinx.fem.assemble_vector(form).array.copy()
    return areas


def surface(u: Function) -> Expr:
    """The deformed surface as a UFL 3-vector: y itself, or (x₁, x₂, w) for a deflection w."""
    if u.ufl_shape == (3,):
        return u
    if u.ufl_shape == ():
        x = ufl.SpatialCoordinate(u.function_space.mesh)
        embedded: Expr = ufl.as_vector([x[0], x[1], u])
        return embedded
    raise ValueError(f"expected a deformation with 3 components or a scalar, got {u.ufl_shape}")


def unit_normal(y: Expr) -> Expr:
    """ν(y) = ∂₁y × ∂₂y / |∂₁y × ∂₂y|, the unit normal of the deformed surface (cell-wise)."""
    n = ufl.cross(y.dx(0), y.dx(1))
    nu: Expr = n / ufl.sqrt(ufl.inner(n, n))
    return nu


def second_fundamental_form(y: Expr) -> Expr:
    """II_ij = ∂_ij y · ν (broken, cell-wise): a 2×2 UFL matrix."""
    nu = unit_normal(y)
    II: Expr = ufl.as_matrix([[ufl.dot(y.dx(i).dx(j), nu) for j in range(2)] for i in range(2)])
    return II


def gauss_curvature(y: Expr) -> Expr:
    """K = det(II) / det(∇yᵀ∇y), the Gaussian curvature of the deformed surface (cell-wise).

    The determinant of the shape operator I⁻¹II; zero for a developable surface (an isometry
    of the plane), 1/R² for a sphere of radius R.
    """
    metric = ufl.grad(y).T * ufl.grad(y)
    K: Expr = ufl.det(second_fundamental_form(y)) / ufl.det(metric)
    return K


def metric_gauss_curvature(metric: Expr) -> Expr:
    """K of a metric G = [[E, F], [F, G₂₂]] of x₁, x₂ by Brioschi's formula (a UFL scalar).

    The intrinsic Gaussian curvature, from G and its first and second derivatives alone
    (Theorema egregium): that of every surface y with ∇yᵀ∇y = G. Zero for a constant G, 1/R²
    for the metric of a sphere of radius R.

    Args:
        metric: a symmetric positive definite 2×2 UFL expression of the spatial coordinates.

    Returns:
        K = (det A − det B)/(EG₂₂ − F²)² with Brioschi's 3×3 matrices A and B.
    """
    E, F, G = metric[0, 0], metric[0, 1], metric[1, 1]
    E_u, E_v, F_u, F_v, G_u, G_v = (_d(f, i) for f in (E, F, G) for i in (0, 1))
    corner = -_d(E_v, 1) / 2 + _d(F_u, 1) - _d(G_u, 0) / 2
    A = ufl.as_matrix([[corner, E_u / 2, F_u - E_v / 2], [F_v - G_u / 2, E, F], [G_v / 2, F, G]])
    B = ufl.as_matrix([[0.0, E_v / 2, G_u / 2], [E_v / 2, E, F], [G_u / 2, F, G]])
    K: Expr = (ufl.det(A) - ufl.det(B)) / (E * G - F * F) ** 2
    return K


def christoffel(metric: Expr) -> Expr:
    """Γᵐᵢⱼ = ½ Gᵐˡ(∂ᵢGⱼₗ + ∂ⱼGᵢₗ − ∂ₗGᵢⱼ) of a metric G of x₁, x₂, as a tensor [m, i, j].

    Args:
        metric: a symmetric positive definite 2×2 UFL expression of the spatial coordinates.

    Returns:
        The Christoffel symbols of the second kind, shape (2, 2, 2).
    """
    dG = ufl.as_tensor(
        [[[_d(metric[i, j], k) for j in range(2)] for i in range(2)] for k in range(2)]
    )  # dG[k, i, j] = ∂ₖGᵢⱼ
    inverse = ufl.inv(metric)
    m, i, j, ell = ufl.indices(4)
    gamma: Expr = ufl.as_tensor(
        0.5 * inverse[m, ell] * (dG[i, j, ell] + dG[j, i, ell] - dG[ell, i, j]), (m, i, j)
    )
    return gamma


def trace_excess(metric: Expr) -> Expr:
    """Σₖ tr(AD²yₖA)² − Σₖ |AD²yₖA|², A = G^{-1/2}, on every y with ∇yᵀ∇y = G: G's alone.

    On such y, D²yₖ = Γᵐ ∂ₘyₖ + II νₖ (∂ₘy ⊥ ν), so with tᵐ = G⁻¹ : Γᵐ the difference is
    tᵐtⁿGₘₙ − (G⁻¹ΓᵐG⁻¹) : Γⁿ Gₘₙ + tr(G⁻¹II)² − |A II A|², and the last two give
    2 det(G⁻¹II) = 2K (Gauss). Zero for a constant G.

    Args:
        metric: a symmetric positive definite 2×2 UFL expression of the spatial coordinates.

    Returns:
        The difference, a UFL scalar.
    """
    gamma = christoffel(metric)
    inverse = ufl.inv(metric)
    m, n, i, j, a, b = ufl.indices(6)
    t = ufl.as_vector(inverse[i, j] * gamma[m, i, j], m)
    full = inverse[i, a] * inverse[j, b] * gamma[m, i, j] * gamma[n, a, b] * metric[m, n]
    excess: Expr = t[m] * t[n] * metric[m, n] - full + 2 * metric_gauss_curvature(metric)
    return excess


def _d(f: Expr, i: int) -> Expr:
    """∂f/∂x_i; a zero (the derivative of a constant) stays zero."""
    derivative: Expr = f if isinstance(f, Zero) else f.dx(i)
    return derivative


def pointwise_norm(a: Expr) -> Expr:
    """|a| at each point: the absolute value of a scalar, the Frobenius norm of a tensor."""
    norm: Expr = ufl.sqrt(ufl.inner(a, a))
    return norm


def image_of_direction(y: Expr, direction: Sequence[float]) -> Expr:
    """∇y·d: where y maps the reference direction d (a tangent of the deformed surface)."""
    image: Expr = ufl.dot(ufl.grad(y), ufl.as_vector([float(d) for d in direction]))
    return image


def oriented_normal(tangent: Array, start: Array, end: Array) -> Array:
    """The unit normal of a straight facet along ``tangent``, on the side of ``end`` from ``start``.

    In the plane; from a cell's midpoint to the midpoint of one of its facets, it is the
    cell's outward normal.
    """
    normal: Array = np.array([tangent[1], -tangent[0]]) / np.linalg.norm(tangent)
    return normal if np.dot(normal, end - start) >= 0 else -normal
