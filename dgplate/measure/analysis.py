"""Shape figures of a deformed plate for summaries: curvatures, a cylinder fit, L¹ norms.

The principal curvatures and a fitted cylinder; the L¹ norms of the Gaussian curvature and of
the isometry defect, which every isometric plate model reports.

All functions are collective and return the same numbers on every rank.
"""

from __future__ import annotations

import math
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, mpi
from dgplate.compat import Array, Function, Mesh
from dgplate.dg import geometry
from dgplate.measure.fields import cell_field, dg0_dofs_to_cells


def cell_second_fundamental_form(y: Function) -> tuple[Array, Array]:
    """II = (∂_ij y · ν) at each owned cell's midpoint (shape (cells, 2, 2)) and cell areas."""
    mesh = y.function_space.mesh
    II_form = geometry.second_fundamental_form(y)
    entries = {(i, j): cell_field(II_form[i, j], mesh) for i in range(2) for j in range(i, 2)}
    II = np.empty((entries[0, 0].size, 2, 2))
    II[:, 0, 0], II[:, 1, 1] = entries[0, 0], entries[1, 1]
    II[:, 0, 1] = II[:, 1, 0] = entries[0, 1]
    return II, cell_areas(mesh)


def cell_areas(mesh: Mesh) -> Array:
    """Area of each owned cell, in owned-cell order."""
    space = dolfinx.fem.functionspace(mesh, ("DG", 0))
    return dg0_dofs_to_cells(geometry.cell_areas(space), space)


def l1_norms(y: Function, metric: Expr | None = None) -> dict[str, float]:
    """‖K_h‖_L¹ = ∫|K_h| and ‖δI_h‖_L¹ = ∫|∇yᵀ∇y − G| (Frobenius norm) of a deformation y.

    K_h = det(II)/det(∇yᵀ∇y) is the Gaussian curvature of the discrete surface (broken,
    cell-wise): an isometry's limit is developable, K = 0. Both integrals use a quadrature of
    degree 2k + 2 for y of degree k (their integrands are not polynomials).

    Args:
        y: a deformation in [DG_k]³ (or [P_k]³) on a plate mesh.
        metric: the target metric G (None: I₂).

    Returns:
        ``gauss_curvature_l1`` and ``isometry_defect_l1``, the same on every rank.
    """
    from dgplate.solvers.constraint import metric_tensor_defect

    mesh = y.function_space.mesh
    degree = compat.ufl_element(y.function_space).embedded_superdegree
    dx = ufl.dx(domain=mesh, metadata={"quadrature_degree": 2 * degree + 2})
    integrands = {
        "gauss_curvature_l1": geometry.pointwise_norm(geometry.gauss_curvature(y)),
        "isometry_defect_l1": geometry.pointwise_norm(metric_tensor_defect(y, metric)),
    }
    forms = {name: dolfinx.fem.form(f * dx) for name, f in integrands.items()}
    return {
        name: float(mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM))
        for name, form in forms.items()
    }


def curvature_summary(y: Function) -> dict[str, Any]:
    """Principal curvatures (area-weighted means and extremes) and a fitted cylinder.

    κ₁ ≥ κ₂ are the eigenvalues of II per cell. The cylinder fit takes the direction of least
    mean curvature as the axis, projects the deformed surface onto the plane normal to it and
    fits a circle (least squares), reporting the radius, the axis and the relative RMS distance
    of the surface from that cylinder (small when the shape is a cylinder).
    """
    comm = y.function_space.mesh.comm
    II, areas = cell_second_fundamental_form(y)
    kappa = np.linalg.eigvalsh(II) if II.size else np.zeros((0, 2))  # ascending
    k1, k2 = kappa[:, 1], kappa[:, 0]
    total = mpi.global_sum(comm, float(areas.sum()))

    def mean(values: Array) -> float:
        return mpi.global_sum(comm, float(np.dot(values, areas))) / total

    mean_II = mpi.sum_arrays(comm, np.einsum("c,cij->ij", areas, II)) / total
    summary: dict[str, Any] = {
        "principal_curvatures": {
            "kappa1_mean": mean(k1),
            "kappa2_mean": mean(k2),
            "kappa1_max": mpi.global_max(comm, float(k1.max(initial=-np.inf))),
            "kappa2_min": mpi.global_min(comm, float(k2.min(initial=np.inf))),
            "mean_curvature_mean": mean(0.5 * (k1 + k2)),
        },
        "mean_second_fundamental_form": mean_II.tolist(),
    }
    summary["cylinder_fit"] = fit_cylinder(y, mean_II, areas, total)
    return summary


def fit_cylinder(y: Function, mean_II: Array, areas: Array, total_area: float) -> dict[str, Any]:
    """Least-squares cylinder through the deformed surface (see :func:`curvature_summary`)."""
    comm = y.function_space.mesh.comm
    mesh = y.function_space.mesh
    eigenvalues, vectors = np.linalg.eigh(mean_II)
    d_ref = vectors[:, int(np.argmin(np.abs(eigenvalues)))]  # direction of least bending
    # the axis is the mean of ∇y·d_ref: the mean of ∇y, times d_ref (∇y compiles once; d_ref
    # in the expression would compile anew for each shape)
    columns = [geometry.image_of_direction(y, e) for e in ([1.0, 0.0], [0.0, 1.0])]  # ∂ⱼy
    local = [[np.dot(cell_field(column[a], mesh), areas) for column in columns] for a in range(3)]
    axis = mpi.sum_arrays(comm, np.array(local)) @ d_ref
    axis /= np.linalg.norm(axis)
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    owned = y.function_space.dofmap.index_map.size_local
    points = y.x.array.reshape(-1, 3)[:owned]
    u, v = points @ e1, points @ e2
    A = np.column_stack([u, v, np.ones_like(u)])
    rhs = -(u**2 + v**2)
    normal = mpi.sum_arrays(comm, A.T @ A)  # the same on every rank: so is the branch below
    right = mpi.sum_arrays(comm, A.T @ rhs)
    try:
        D, E, F = np.linalg.solve(normal, right)
    except np.linalg.LinAlgError:  # the points lie on a line of (u, v): a plane, radius ∞
        return {"radius": math.inf, "axis": axis.tolist(), "rms_residual": 0.0}
    cu, cv = -D / 2, -E / 2
    radius = float(np.sqrt(max(cu**2 + cv**2 - F, 0.0)))
    dist = np.sqrt((u - cu) ** 2 + (v - cv) ** 2) - radius
    count = mpi.global_count(comm, int(u.size))
    rms = float(np.sqrt(mpi.global_sum(comm, float(np.dot(dist, dist))) / count))
    return {
        "radius": radius,
        "axis": axis.tolist(),
        "rms_residual": rms / radius if radius else float("inf"),
    }


def fit_sphere(y: Function) -> dict[str, float]:
    """Least-squares sphere through the nodal values of y (owned dofs, collective).

    The algebraic fit |p|² + D·p + F = 0 (Kåsa's), as :func:`fit_cylinder`'s circle.

    Args:
        y: a deformation in [DG_k]³ (a Lagrange space: its dofs are points of the surface).

    Returns:
        ``radius`` and ``rms``, the root-mean-square distance of the points from the sphere
        relative to its radius (the same on every rank).
    """
    comm = y.function_space.mesh.comm
    owned = y.function_space.dofmap.index_map.size_local
    points = y.x.array.reshape(-1, 3)[:owned]
    A = np.column_stack([points, np.ones(len(points))])
    rhs = -np.einsum("ij,ij->i", points, points)
    solution = np.linalg.solve(mpi.sum_arrays(comm, A.T @ A), mpi.sum_arrays(comm, A.T @ rhs))
    centre = -solution[:3] / 2
    radius = float(np.sqrt(max(float(centre @ centre) - solution[3], 0.0)))
    dist = np.linalg.norm(points - centre, axis=1) - radius
    count = mpi.global_count(comm, len(points))
    rms = float(np.sqrt(mpi.global_sum(comm, float(dist @ dist)) / count))
    return {"radius": radius, "rms": rms / radius}
