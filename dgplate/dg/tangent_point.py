"""The tangent-point potential of a point cloud, exact or by a cluster tree (docs/self_avoidance.md).

For points x_i with unit normals ν_i (of a surface) and weights w_i (quadrature weights),

    TP = (2^(−q)/q) Σ_i Σ_j w_i w_j r_ij^(−q),   r_ij = |x_j − x_i|² / (2|ν_i·(x_j − x_i)|),

i.e. TP = (1/q) Σ w_i w_j |ν_i·d|^q / |d|^(2q) with d = x_j − x_i: the quadrature of the
tangent-point energy of Gonzalez–Maddocks used for plates by Bartels, Meyer and Palus
("Simulating self-avoiding isometric plate bending"). For a curve (``Cloud.curve``) the
directions are unit tangents t_i and |ν_i·d| becomes |d − (t_i·d)t_i|, the distance of x_j from
the tangent line at x_i (Strzelecki–von der Mosel; Bartels–Reiter): in both cases
|P_i d|² = α|d|² + β(a_i·d)² with the direction a_i and (α, β) = (0, 1) for normals,
(1, −1) for tangents, so one kernel serves both. Pairs of points of the same or of
neighbouring cells (cells that share a vertex) are left out of the double sum, where the
integrand is singular. The code knows nothing of meshes: a point carries the ids of its cell's
vertices (``vertices``), so that rods (two ids per segment) can use it as well.

The far field is approximated Barnes–Hut style: points are sorted into a binary tree of
bounding boxes (cut at the middle of the longest side, so that boxes keep a bounded aspect
ratio); a target point and a source box of diameter D at box distance g > D/θ (and farther
apart than ``reach``, the largest distance of neighbouring points, so no excluded pair is
approximated) interact through the box's weight and weighted centroid (a monopole). Near
pairs are summed exactly. The points are taken in tree order (every leaf a contiguous range)
and all sums are vectorised over dense blocks: a target leaf against the concatenated points
of all its near leaves (near) or against the centroids of all its far boxes (far); |d|², a·d
and the sums over sources and over targets are batched matrix products, never loops over
pairs in Python.

The code is in four modules: the cloud and its tree (:mod:`dgplate.dg.cluster_tree`), the pair
sums (:mod:`dgplate.dg.tp_kernel`), the searches over pairs: neighbours, least distance,
crossing cells (:mod:`dgplate.dg.pair_search`), and here :func:`evaluate`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from dgplate.dg.cluster_tree import LEAF, Cloud, Tree, build_tree
from dgplate.dg.pair_search import crossings, min_distance
from dgplate.dg.tp_kernel import TPResult, sums

__all__ = ["Cloud", "TPResult", "Tree", "build_tree", "crossings", "evaluate", "min_distance"]

#: Leaf size for the exact sums (θ = 0, the rods' default): only fewer, larger blocks matter.
_LEAF_EXACT = 64


def evaluate(
    cloud: Cloud,
    q: float,
    theta: float = 0.5,
    reach: float = 0.0,
    targets: npt.NDArray[np.bool_] | None = None,
    tree: Tree | None = None,
    leaf: int | None = None,
) -> TPResult:
    """TP and its derivatives, targets i restricted to ``targets`` (default: all).

    θ = 0: exact all-pairs sums. θ > 0: the far field of the tree (see the module doc).
    ``leaf``: the most points of a leaf of the tree built here (when ``tree`` is not given;
    by default :func:`_default_leaf`).
    The derivative with respect to a source x_j is returned for every point, so that ranks that
    each evaluate their own targets add their results (MPI parity).
    """
    m = len(cloud.points)
    if tree is None:
        size = leaf or _default_leaf(cloud, theta)
        tree = build_tree(cloud.points, cloud.weights, size, median=cloud.curve)
    mask = np.ones(m, dtype=bool) if targets is None else targets
    # the points in tree order: every leaf is a contiguous range, blocks read and add locally
    perm = tree.order
    cloud = Cloud(
        cloud.points[perm],
        cloud.normals[perm],
        cloud.weights[perm],
        cloud.vertices[perm],
        cloud.curve,
    )
    out = sums(cloud, replace(tree, order=np.arange(m)), mask[perm], q, theta, reach)
    for name in ("d_points", "d_normals"):
        unsorted = np.empty((m, 3))
        unsorted[perm] = getattr(out, name)
        setattr(out, name, unsorted)
    return out


def _default_leaf(cloud: Cloud, theta: float) -> int:
    """The leaf size: ``_LEAF_EXACT`` for the exact sums, ``LEAF`` for surfaces, 32 for curves.

    On a curve the monopoles are the larger error (tests/models/test_rod_self_avoidance.py), and boxes
    of 16 points admitted as far raised it at θ = 0.25 from 4.5e-4 to 1.2e-3 (TP, trefoil).
    """
    if theta == 0:
        return _LEAF_EXACT
    return 2 * LEAF if cloud.curve else LEAF
