"""Shape figures of a deformed plate for summaries: principal curvatures and a cylinder fit.

All functions are collective and return the same numbers on every rank.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import ufl

from dgplate.measure.fields import cell_field, dg0_dofs_to_cells


def _unit_normal(y):
    n = ufl.cross(y.dx(0), y.dx(1))
    return n / ufl.sqrt(ufl.inner(n, n))


def cell_second_fundamental_form(y) -> tuple[np.ndarray, np.ndarray]:
    """II = (∂_ij y · ν) at each owned cell's midpoint (shape (cells, 2, 2)) and cell areas."""
    mesh = y.function_space.mesh
    nu = _unit_normal(y)
    entries = {
        (i, j): cell_field(ufl.dot(y.dx(i).dx(j), nu), mesh) for i in range(2) for j in range(i, 2)
    }
    II = np.empty((entries[0, 0].size, 2, 2))
    II[:, 0, 0], II[:, 1, 1] = entries[0, 0], entries[1, 1]
    II[:, 0, 1] = II[:, 1, 0] = entries[0, 1]
    return II, cell_areas(mesh)


def cell_areas(mesh) -> np.ndarray:
    """Area of each owned cell, in owned-cell order."""
    import dolfinx.fem

    space = dolfinx.fem.functionspace(mesh, ("DG", 0))
    vec = dolfinx.fem.assemble_vector(dolfinx.fem.form(ufl.TestFunction(space) * ufl.dx))
    return dg0_dofs_to_cells(vec.array, space)


def curvature_summary(y) -> dict:
    """Principal curvatures (area-weighted means and extremes) and a fitted cylinder.

    κ₁ ≥ κ₂ are the eigenvalues of II per cell. The cylinder fit takes the direction of least
    mean curvature as the axis, projects the deformed surface onto the plane normal to it and
    fits a circle (least squares), reporting the radius, the axis and the relative RMS distance
    of the surface from that cylinder (small when the shape is a cylinder).
    """
    comm: MPI.Comm = y.function_space.mesh.comm
    II, areas = cell_second_fundamental_form(y)
    kappa = np.linalg.eigvalsh(II) if II.size else np.zeros((0, 2))  # ascending
    k1, k2 = kappa[:, 1], kappa[:, 0]
    total = comm.allreduce(float(areas.sum()), op=MPI.SUM)

    def mean(values):
        return comm.allreduce(float(np.dot(values, areas)), op=MPI.SUM) / total

    def extreme(values, op):
        local = (
            (values.max() if op is MPI.MAX else values.min())
            if values.size
            else (-np.inf if op is MPI.MAX else np.inf)
        )
        return comm.allreduce(float(local), op=op)

    mean_II = comm.allreduce(np.einsum("c,cij->ij", areas, II), op=MPI.SUM) / total
    summary = {
        "principal_curvatures": {
            "kappa1_mean": mean(k1),
            "kappa2_mean": mean(k2),
            "kappa1_max": extreme(k1, MPI.MAX),
            "kappa2_min": extreme(k2, MPI.MIN),
            "mean_curvature_mean": mean(0.5 * (k1 + k2)),
        },
        "mean_second_fundamental_form": mean_II.tolist(),
    }
    summary["cylinder_fit"] = fit_cylinder(y, mean_II, areas, total)
    return summary


def fit_cylinder(y, mean_II: np.ndarray, areas: np.ndarray, total_area: float) -> dict:
    """Least-squares cylinder through the deformed surface (see :func:`curvature_summary`)."""
    comm = y.function_space.mesh.comm
    mesh = y.function_space.mesh
    values, vectors = np.linalg.eigh(mean_II)
    d_ref = vectors[:, int(np.argmin(np.abs(values)))]  # reference direction of least bending
    tangent = ufl.dot(ufl.grad(y), ufl.as_vector(d_ref.tolist()))
    axis = np.array(
        [
            comm.allreduce(float(np.dot(cell_field(tangent[a], mesh), areas)), op=MPI.SUM)
            for a in range(3)
        ]
    )
    axis /= np.linalg.norm(axis)
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    owned = y.function_space.dofmap.index_map.size_local
    points = y.x.array.reshape(-1, 3)[:owned]
    u, v = points @ e1, points @ e2
    A = np.column_stack([u, v, np.ones_like(u)])
    rhs = -(u**2 + v**2)
    normal = comm.allreduce(A.T @ A, op=MPI.SUM)
    right = comm.allreduce(A.T @ rhs, op=MPI.SUM)
    D, E, F = np.linalg.solve(normal, right)
    cu, cv = -D / 2, -E / 2
    radius = float(np.sqrt(max(cu**2 + cv**2 - F, 0.0)))
    dist = np.sqrt((u - cu) ** 2 + (v - cv) ** 2) - radius
    count = comm.allreduce(int(u.size), op=MPI.SUM)
    rms = float(np.sqrt(comm.allreduce(float(np.dot(dist, dist)), op=MPI.SUM) / count))
    return {
        "radius": radius,
        "axis": axis.tolist(),
        "rms_residual": rms / radius if radius else float("inf"),
    }
