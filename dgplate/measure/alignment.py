"""Rigid alignment of a measured point cloud to a computed surface, and the distances left.

The scan's points q are moved by the rigid motion q ↦ Rq + t that brings them closest to the
surface. :func:`align` starts from the four proper rotations that take the scan's principal
axes to the surface's (the signs of the axes are unknown), takes point-to-point steps first
(:func:`kabsch`: the best rotation for given pairs, from an SVD; W. Kabsch, Acta Cryst. A32,
922, 1976), which converge from afar but slowly (:data:`SCREENING` of them from each start, then more
from those within :data:`CONTENDERS` of the best), then Gauss–Newton steps on the sum of squared distances (point-to-plane inside, as in
Y. Chen, G. Medioni, Image Vision Comput. 10, 145, 1992; point-to-edge beside the boundary),
halved until the distances fall, which converge fast near the optimum. The pairs are each point and its closest point on the surface, given by the caller
(``closest``): the distances are to the surface, not to its vertices, so that a scan's noise
is measured and not the spacing of the mesh.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeAlias

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

Array: TypeAlias = "npt.NDArray[np.float64]"
#: The point-to-point steps from each of the four starts before the best ones are refined.
SCREENING = 10
#: Starts whose screened mean square distance is within this factor of the least are refined
#: (a nearly symmetric surface, e.g. a uniformly rolled rectangle, has two starts that the
#: screening cannot tell apart: 2.45·10⁻⁴ against 2.70·10⁻⁴ for the wrong one and the right).
CONTENDERS = 10.0
#: points (k, 3) → (their closest points on the surface (k, 3), its unit normals there (k, 3))
Closest: TypeAlias = Callable[[Array], tuple[Array, Array]]


@dataclass(frozen=True)
class Alignment:
    """The rigid motion q ↦ Rq + t and each moved point's distance to the surface."""

    rotation: Array
    translation: Array
    distances: Array
    steps: int

    @property
    def rms(self) -> float:
        """The root mean square of the distances."""
        return float(np.sqrt(np.mean(self.distances**2)))


def kabsch(source: Array, target: Array, comm: MPI.Comm | None = None) -> tuple[Array, Array]:
    """(R, t) with det R = 1 that minimise Σ|R sᵢ + t − tᵢ|² (pairs of rows).

    Args:
        source: the points to move, (k, 3).
        target: the points they should reach, (k, 3).
        comm: the sums run over the rows of all its ranks (collective); None: these rows.

    Returns:
        The rotation R (3, 3) and the translation t (3,), the same on every rank.
    """
    count, sums = len(source), np.vstack([source.sum(axis=0), target.sum(axis=0)])
    if comm is not None:
        count, sums = comm.allreduce(count), comm.allreduce(sums)
    a, b = sums / count
    covariance = (source - a).T @ (target - b)
    if comm is not None:
        covariance = comm.allreduce(covariance)
    u, _, vt = np.linalg.svd(covariance)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    motion = (rotation, b - rotation @ a)
    return motion if comm is None else comm.bcast(motion, root=0)  # the same bits everywhere


def _rotation_of(omega: Array) -> Array:
    """exp([ω]×): the rotation by |ω| about ω (Rodrigues)."""
    angle = float(np.linalg.norm(omega))
    if angle == 0.0:
        return np.eye(3)
    k = omega / angle
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    rotation: Array = np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross
    return rotation


def _gauss_newton(moved: Array, closest: Closest) -> tuple[Array, Array]:
    """The step (ω, t) of Gauss–Newton on Σ dᵢ², dᵢ the distance of point i to the surface.

    dᵢ changes by −uᵢ·(ω × qᵢ + t) to first order, uᵢ the unit vector to the closest point:
    the surface's normal inside (point-to-plane), the way to the edge beside the boundary.
    """
    near, normal = closest(moved)
    gap = near - moved
    length = np.linalg.norm(gap, axis=1)
    inside = length <= 1e-12 * (1.0 + np.abs(moved).max())
    towards = np.where(inside[:, None], normal, gap / np.where(inside, 1.0, length)[:, None])
    rows = np.hstack([np.cross(moved, towards), towards])
    rhs = np.einsum("ij,ij->i", gap, towards)
    step = np.linalg.lstsq(rows, rhs, rcond=None)[0]
    return step[:3], step[3:]


def _descend(
    scan: Array, closest: Closest, rotation: Array, translation: Array
) -> tuple[Array, Array, float, float]:
    """One Gauss–Newton step, halved until the mean square distance falls (at most 20 times).

    Returns:
        The new motion, the size of the step taken and the relative fall of the mean square
        distance (both 0: no step lowers the distances).
    """
    moved = scan @ rotation.T + translation
    omega, shift = _gauss_newton(moved, closest)
    before = float(np.mean(_distances(scan, closest, rotation, translation) ** 2))
    for _ in range(20):
        R = _rotation_of(omega)
        new_rotation, new_translation = R @ rotation, R @ translation + shift
        after = float(np.mean(_distances(scan, closest, new_rotation, new_translation) ** 2))
        if after < before:
            size = float(np.linalg.norm(omega) + np.linalg.norm(shift))
            return new_rotation, new_translation, size, (before - after) / before
        omega, shift = omega / 2, shift / 2
    return rotation, translation, 0.0, 0.0


def _point_to_point(
    scan: Array, closest: Closest, rotation: Array, translation: Array, steps: int
) -> tuple[Array, Array, int]:
    """Up to ``steps`` Kabsch steps to the closest points, until a step turns by < 10⁻³."""
    taken = 0
    while taken < steps:
        moved = scan @ rotation.T + translation
        R, t = kabsch(moved, closest(moved)[0])
        rotation, translation, taken = R @ rotation, R @ translation + t, taken + 1
        if np.linalg.norm(R - np.eye(3)) < 1e-3:
            break
    return rotation, translation, taken


def _newton(
    scan: Array, closest: Closest, rotation: Array, translation: Array, steps: int, tol: float
) -> tuple[Array, Array, int]:
    """Up to ``steps`` Gauss–Newton steps, until one is shorter than ``tol``.

    Or until one lowers the mean square distance by less than a part in 10¹⁰ (none: 0).
    """
    taken = 0
    while taken < steps:
        rotation, translation, size, fall = _descend(scan, closest, rotation, translation)
        taken += 1
        if size < tol or fall < 1e-10:
            break
    return rotation, translation, taken


def _distances(scan: Array, closest: Closest, rotation: Array, translation: Array) -> Array:
    moved = scan @ rotation.T + translation
    distances: Array = np.linalg.norm(closest(moved)[0] - moved, axis=1)
    return distances


def align(
    scan: Array, surface: Array, closest: Closest, steps: int = 100, tol: float = 1e-12
) -> Alignment:
    """The rigid motion that brings ``scan`` closest to the surface (module docstring).

    Args:
        scan: the measured points, (k, 3).
        surface: the surface's points (vertices), (n, 3), for the principal axes.
        closest: the closest points on the surface and its normals there, for given points.
        steps: the most steps after the starts' screening.
        tol: stop when a step moves by less (rotation and translation, in norm).

    Returns:
        The closest of the alignments refined from the starts whose :data:`SCREENING`
        point-to-point steps end within :data:`CONTENDERS` of the closest; ``steps`` counts
        the steps of all.
    """
    a, b = scan.mean(axis=0), surface.mean(axis=0)
    axes_scan = np.linalg.eigh(np.cov((scan - a).T))[1]
    axes_surface = np.linalg.eigh(np.cov((surface - b).T))[1]
    starts = []
    for signs in itertools.product((1.0, -1.0), repeat=2):
        flip = np.diag([*signs, signs[0] * signs[1]])
        start = axes_surface @ flip @ axes_scan.T
        start = start * np.sign(np.linalg.det(start))  # proper, whatever the eigh bases
        starts.append(_point_to_point(scan, closest, start, b - start @ a, SCREENING))
    screened = [float(np.mean(_distances(scan, closest, R, t) ** 2)) for R, t, _ in starts]
    if not np.isfinite(screened).any():
        raise ValueError("no start of the alignment has finite distances (points not finite?)")
    taken = sum(n for _, _, n in starts)
    refined = []
    for (R, t, _), distance in zip(starts, screened, strict=True):
        if distance <= CONTENDERS * np.nanmin(screened):
            R, t, second = _point_to_point(scan, closest, R, t, steps // 2)
            R, t, third = _newton(scan, closest, R, t, steps // 2, tol)
            taken += second + third
            refined.append((R, t, _distances(scan, closest, R, t)))
    R, t, distances = min(refined, key=lambda r: float(np.mean(r[2] ** 2)))
    return Alignment(R, t, distances, taken)
