"""The Gaussian curvature of a prestrained plate against that of its target metric G.

By Gauss's Theorema egregium every surface with ∇yᵀ∇y = G has the Gaussian curvature K of G
alone (Brioschi's formula, :func:`dgplate.dg.geometry.metric_gauss_curvature`). The discrete
surface's K_h = det(II)/det(∇yᵀ∇y) (:func:`dgplate.measure.fields.gauss_field`) is measured
against it at each cell's midpoint: the figures of ``summary.json`` and the DG0 field
``target_gauss_curvature`` written next to ``gauss_curvature`` (docs/prestrain.md). The shapes
of prestrained discs are measured by the half-angle of a cone (:func:`cone_half_angle`), the
azimuthal Fourier modes of the free edge's height (:func:`edge_waves`: the saddles and waves of
negative curvature) and the mean |K_h| off a defect's tip (:func:`gauss_curvature_outside`).

All functions are collective and return the same numbers on every rank.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from ufl.core.expr import Expr

from dgplate import mpi
from dgplate.compat import Function, Mesh, spatial_coordinate
from dgplate.dg.geometry import metric_gauss_curvature
from dgplate.measure.analysis import cell_areas
from dgplate.measure.fields import CellField, cell_field, gauss_density

#: Name of the target Gaussian curvature's cell field in time series.
TARGET_GAUSS = "target_gauss_curvature"


def target_gauss_field(mesh: Mesh, metric: Expr) -> CellField:
    """The Gaussian curvature K of the metric G as a DG0 ``CellField`` (cell midpoints).

    Args:
        mesh: the plate's mesh.
        metric: the target metric G (a UFL 2×2 expression of the spatial coordinates).

    Returns:
        The field named ``target_gauss_curvature``.
    """
    return CellField(metric_gauss_curvature(metric), mesh, name=TARGET_GAUSS)


def gauss_curvature_figures(y: Function, metric: Expr) -> dict[str, dict[str, float]]:
    """K of G and K_h of y at the cell midpoints: means, extremes and the error |K_h − K|.

    Args:
        y: the deformation in [DG_k]³.
        metric: the target metric G.

    Returns:
        ``{"metric_gauss_curvature": {...}}``: ``target_mean``, ``target_min``,
        ``target_max`` (K), ``mean`` (K_h), ``error_mean`` (the area-weighted mean of
        |K_h − K|) and ``error_max``; means are weighted by the cell areas.
    """
    mesh = y.function_space.mesh
    comm = mesh.comm
    target = target_gauss_field(mesh, metric).values()
    measured = gauss_density(y)
    error = np.abs(measured - target)
    areas = cell_areas(mesh)
    total = mpi.global_sum(comm, float(areas.sum()))

    def mean(values: np.ndarray) -> float:
        return mpi.global_sum(comm, float(np.dot(values, areas))) / total

    figures = {
        "target_mean": mean(target),
        "target_min": mpi.global_min(comm, float(target.min(initial=np.inf))),
        "target_max": mpi.global_max(comm, float(target.max(initial=-np.inf))),
        "mean": mean(measured),
        "error_mean": mean(error),
        "error_max": mpi.global_max(comm, float(error.max(initial=0.0))),
    }
    return {"metric_gauss_curvature": figures}


def cone_half_angle(y: Function, inner: float, centre: tuple[float, float] = (0.0, 0.0)) -> float:
    """The half-angle φ of the cone that y makes of a disc about ``centre`` (+1 defects).

    The tip is y at the degree of freedom nearest ``centre``; the axis the mean of the unit
    vectors from the tip to y at the dofs with |x − centre| > ``inner``; sin φ the slope of
    the least-squares line of the distance ρ from the axis against the distance ℓ from the
    tip over those dofs (a slope: a tip that is not quite a point shifts the line, not φ).

    Args:
        y: the deformation in [DG_k]³.
        inner: the reference radius inside which the dofs are left out (the tip region).
        centre: the reference point of the defect.

    Returns:
        φ in radians.
    """
    comm = y.function_space.mesh.comm
    owned = y.function_space.dofmap.index_map.size_local
    x = y.function_space.tabulate_dof_coordinates()[:owned, :2] - np.asarray(centre)
    points = y.x.array.reshape(-1, 3)[:owned]
    r = np.linalg.norm(x, axis=1)
    nearest = (float(r.min()), points[int(np.argmin(r))].tolist()) if owned else (np.inf, [])
    tip = np.asarray(min(comm.allgather(nearest), key=lambda item: item[0])[1])
    v = points[r > inner] - tip
    ell = np.linalg.norm(v, axis=1)
    axis = mpi.sum_arrays(comm, (v / ell[:, None]).sum(axis=0))
    axis /= np.linalg.norm(axis)
    rho = np.linalg.norm(v - np.outer(v @ axis, axis), axis=1)
    n, sl, sr, sll, slr = mpi.sum_arrays(
        comm, [len(ell), ell.sum(), rho.sum(), ell @ ell, ell @ rho]
    )
    slope = (n * slr - sl * sr) / (n * sll - sl * sl)
    return float(np.arcsin(min(slope, 1.0)))


def edge_waves(y: Function, outer: float = 0.98, modes: int = 8) -> dict[str, Any]:
    """The azimuthal modes of the height of a disc's free edge above its least-squares plane.

    The edge is y at the degrees of freedom with |x| ≥ ``outer`` · max|x| (the plate centred at
    the origin); its plane passes through their mean, normal to their direction of least
    spread, and the heights h above it are fitted by least squares with
    a₀ + Σ_{m ≤ modes} (a_m cos mθ + b_m sin mθ), θ the polar angle of x. The plane takes
    modes 0 and 1 (the mean and a tilt), so the strongest mode m ≥ 1 is the number of waves
    along the edge: 2 for a saddle.

    Args:
        y: the deformation in [DG_k]³.
        outer: the fraction of the largest |x| from which a dof is on the edge.
        modes: the highest mode fitted.

    Returns:
        ``waves`` (the strongest mode), ``amplitudes`` (√(a_m² + b_m²) for m = 1 … modes) and
        ``points`` (the number of edge dofs).
    """
    comm = y.function_space.mesh.comm
    owned = y.function_space.dofmap.index_map.size_local
    x = y.function_space.tabulate_dof_coordinates()[:owned, :2]
    r = np.linalg.norm(x, axis=1)
    largest = mpi.global_max(comm, float(r.max(initial=0.0)))
    edge = r >= outer * largest
    local = np.hstack([x[edge], y.x.array.reshape(-1, 3)[:owned][edge]])
    rows = np.vstack(comm.allgather(local))
    rows = rows[np.lexsort(rows.T[::-1])]  # the same order on any number of ranks
    theta = np.arctan2(rows[:, 1], rows[:, 0])
    points = rows[:, 2:] - rows[:, 2:].mean(axis=0)
    normal = np.linalg.svd(points, full_matrices=False)[2][-1]
    m = np.arange(1, modes + 1)
    basis = np.hstack(
        [np.ones((len(theta), 1)), np.cos(np.outer(theta, m)), np.sin(np.outer(theta, m))]
    )
    coefficients = np.linalg.lstsq(basis, points @ normal, rcond=None)[0]
    amplitudes = np.hypot(coefficients[1 : modes + 1], coefficients[modes + 1 :])
    return {
        "waves": int(np.argmax(amplitudes)) + 1,
        "amplitudes": amplitudes.tolist(),
        "points": len(theta),
    }


def gauss_curvature_outside(y: Function, inner: float) -> float:
    """The area-weighted mean of |K_h| over the cells whose midpoint has |x| > ``inner``.

    Off a defect's tip a director's metric is flat (K = 0), and so must the surface be.

    Args:
        y: the deformation in [DG_k]³.
        inner: the reference radius inside which the cells are left out.

    Returns:
        ∫|K_h| / area over those cells (cell-wise K_h at the midpoints).
    """
    mesh = y.function_space.mesh
    x = spatial_coordinate(mesh)
    r = np.hypot(cell_field(x[0], mesh), cell_field(x[1], mesh))
    areas = np.where(r > inner, cell_areas(mesh), 0.0)
    total = mpi.global_sum(mesh.comm, float(areas.sum()))
    return mpi.global_sum(mesh.comm, float(np.dot(np.abs(gauss_density(y)), areas))) / total
