"""Searches over pairs of a point cloud: neighbouring cells, the least distance, crossing cells.

Pairs of points of the same or of neighbouring cells (cells that share a vertex) are left out of
the tangent-point sums and of the least distance; :func:`crossings` finds the cells of a surface
that pass through each other (a start that no self-avoiding flow can repair).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from dgplate.compat import Array
from dgplate.dg.cluster_tree import Cloud, IntArray, Tree, build_tree, expand, interactions, ranges


def neighbours(cloud: Cloud, i: IntArray, j: IntArray, reach: float) -> npt.NDArray[np.bool_]:
    """Whether the cells of points i and j share a vertex (same cell included).

    Only pairs closer than ``reach`` (0: all) can be neighbours, so only those are compared.
    """
    out = np.zeros(len(i), dtype=bool)
    close = np.arange(len(i))
    if reach > 0:
        d = cloud.points[j] - cloud.points[i]
        close = np.flatnonzero(np.einsum("ij,ij->i", d, d) <= reach * reach)
    out[close] = _share_vertex(cloud.vertices[i[close]], cloud.vertices[j[close]])
    return out


def _share_vertex(a: IntArray, b: IntArray) -> npt.NDArray[np.bool_]:
    """Whether the cells with vertex ids a[p] and b[p] have a vertex in common."""
    return np.asarray((a[:, :, None] == b[:, None, :]).any(axis=(1, 2)))


def min_distance(cloud: Cloud, bound: float, targets: npt.NDArray[np.bool_] | None = None) -> float:
    """The least distance of two points of non-neighbouring cells (inf: there is no such pair).

    ``bound``: a first guess of the search radius (e.g. a few cell diameters); boxes farther
    apart are pruned, and the radius grows until a pair is found.
    """
    tree = build_tree(cloud.points, cloud.weights)
    mask = np.ones(len(cloud.points), dtype=bool) if targets is None else targets
    leaves = np.flatnonzero(tree.children[:, 0] < 0)
    size = float(tree.diameter[0])
    radius = max(bound, 1e-300)
    while True:
        best = _closest(cloud, tree, leaves, radius, mask)
        if best <= radius or radius > size:
            return best
        radius *= 4.0


def _closest(
    cloud: Cloud, tree: Tree, leaves: IntArray, radius: float, mask: npt.NDArray[np.bool_]
) -> float:
    """The least distance of non-neighbouring pairs in boxes less than ``radius`` apart."""
    near_t, near_s, _, _ = interactions(tree, leaves, radius, 0.0, 0.0)
    best = np.inf
    for pi, pj in expand(*ranges(tree, near_t), *ranges(tree, near_s)):
        i, j = tree.order[pi], tree.order[pj]
        keep = mask[i] & ~neighbours(cloud, i, j, radius)
        if keep.any():
            dist = np.linalg.norm(cloud.points[j[keep]] - cloud.points[i[keep]], axis=1)
            best = min(best, float(dist.min()))
    return float(best)


def crossings(triangles: Array, vertices: IntArray) -> IntArray:
    """Pairs (i, j), i < j, of triangles that cross each other transversally.

    ``triangles`` (T, 3, 3): corner coordinates; ``vertices`` (T, k): the ids of the vertices of
    each triangle's cell, so that triangles of the same or of neighbouring cells (a common id)
    are not tested. Two non-coplanar triangles cross iff an edge of one passes through the
    other (the ends of their common segment lie on such edges). Candidate pairs are those
    whose bounding boxes overlap (a sweep along x); the tests are vectorised over pairs.
    """
    lo, hi = triangles.min(axis=1), triangles.max(axis=1)
    order = np.argsort(lo[:, 0], kind="stable")
    ends = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
    found: list[IntArray] = []
    n = len(order)
    positions = np.arange(n)
    later = np.maximum(ends - positions - 1, 0)  # sorted candidates b in (a, ends[a])
    for a, b in expand(positions, np.ones(n, dtype=np.int64), positions + 1, later):
        i, j = order[a], order[b]
        keep = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
        keep &= ~_share_vertex(vertices[i], vertices[j])
        i, j = i[keep], j[keep]
        hit = _edges_through(triangles[i], triangles[j]) | _edges_through(
            triangles[j], triangles[i]
        )
        found.append(np.sort(np.stack([i[hit], j[hit]], axis=1), axis=1))
    return np.concatenate(found) if found else np.zeros((0, 2), dtype=np.int64)


def _edges_through(a: Array, b: Array) -> npt.NDArray[np.bool_]:
    """Whether an edge of triangle a[p] passes through triangle b[p] (Möller–Trumbore)."""
    e1, e2 = b[:, 1] - b[:, 0], b[:, 2] - b[:, 0]
    hit = np.zeros(len(a), dtype=bool)
    for k in range(3):
        p0, d = a[:, k], a[:, (k + 1) % 3] - a[:, k]
        h = np.cross(d, e2)
        det = np.einsum("pi,pi->p", e1, h)
        ok = np.abs(det) > 1e-14 * np.linalg.norm(d, axis=1) * np.linalg.norm(e1, axis=1) ** 2
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = p0 - b[:, 0]
        u = inv * np.einsum("pi,pi->p", s, h)
        q = np.cross(s, e1)
        v = inv * np.einsum("pi,pi->p", d, q)
        t = inv * np.einsum("pi,pi->p", e2, q)
        hit |= ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)
    return hit
