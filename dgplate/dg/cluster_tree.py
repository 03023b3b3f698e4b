"""The point cloud of the tangent-point potential and its cluster tree (docs/self_avoidance.md).

Points are sorted into a binary tree of bounding boxes (cut at the middle of the longest side, so
that boxes keep a bounded aspect ratio). :func:`interactions` lists, level by level over the
frontier, which target leaves meet which source nodes exactly (near) and which through a
monopole (far); :func:`expand` turns ranges of points into index pairs in blocks of
:data:`BLOCK` pairs. The sums over the pairs are in :mod:`dgplate.dg.tp_kernel`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from dgplate.compat import Array

#: Point pairs per vectorised block (memory ~ 20 arrays of this length): small enough that the
#: temporaries stay in cache and are reused by the allocator (2^20 was 1.5–2 times slower).
BLOCK = 1 << 17
#: Leaf size of the tree: near pairs per point grow like the leaf, point–box terms shrink with
#: it; 16 was the fastest at θ = 0.5 (3·10⁴ points: 8, 16, 32 in 1.3, 1, 1.2 times the time).
LEAF = 16

IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class Cloud:
    """Points (M, 3), unit normals (M, 3), weights (M,) and their cells' vertex ids (M, k).

    ``curve``: the ``normals`` are unit tangents of a curve (r = |d|²/(2|d − (t·d)t|)).
    """

    points: Array
    normals: Array
    weights: Array
    vertices: IntArray
    curve: bool = False

    @property
    def projector(self) -> tuple[float, float]:
        """(α, β) of |P d|² = α|d|² + β(a·d)²: (0, 1) for normals, (1, −1) for tangents."""
        return (1.0, -1.0) if self.curve else (0.0, 1.0)


@dataclass(frozen=True)
class Tree:
    """A binary tree of boxes over the points; node n holds ``order[start[n]:end[n]]``."""

    order: IntArray
    start: IntArray
    end: IntArray
    children: IntArray  # (nodes, 2), −1 for leaves
    lo: Array
    hi: Array
    weight: Array
    centroid: Array

    @property
    def diameter(self) -> Array:
        """The diameter of each node's box."""
        return np.asarray(np.linalg.norm(self.hi - self.lo, axis=1))

    def is_leaf(self, nodes: IntArray) -> npt.NDArray[np.bool_]:
        """Whether ``nodes`` are leaves."""
        return np.asarray(self.children[nodes, 0] < 0)


def build_tree(points: Array, weights: Array, leaf: int = LEAF, median: bool = False) -> Tree:
    """Split boxes at the middle of their longest side until at most ``leaf`` points remain.

    ``median``: split at the median instead (leaves of ``leaf``/2 … ``leaf`` points; used on
    curves, where a box's diameter shrinks with its points either way and the larger leaves
    keep the monopoles' error down).

    The loop runs over nodes (about 2M/leaf of them), never over points or pairs; the boxes
    are reduced over the leaves' contiguous ranges and then level by level up the tree.
    """
    order = np.arange(len(points))
    starts, ends, children, depth = [0], [len(points)], [[-1, -1]], [0]
    stack = [0]
    while stack:
        node = stack.pop()
        s, e = starts[node], ends[node]
        if e - s <= leaf:
            continue
        idx = order[s:e]
        order[s:e], half = _split(points[idx], idx, median)
        kids = [len(starts), len(starts) + 1]
        starts += [s, s + half]
        ends += [s + half, e]
        children += [[-1, -1], [-1, -1]]
        depth += [depth[node] + 1] * 2
        children[node] = kids
        stack.extend(kids)
    start, end, child = np.array(starts), np.array(ends), np.array(children)
    # per-node sums over contiguous ranges of the ordered points
    p, w = points[order], weights[order]
    cw = np.concatenate([[0.0], np.cumsum(w)])
    cwp = np.vstack([np.zeros(3), np.cumsum(w[:, None] * p, axis=0)])
    weight = cw[end] - cw[start]
    safe = np.where(weight > 0, weight, 1.0)
    centroid = (cwp[end] - cwp[start]) / safe[:, None]
    lo, hi = _boxes(p, start, child, np.array(depth))
    return Tree(order, start, end, child, lo, hi, weight, centroid)


def _split(p: Array, idx: IntArray, median: bool) -> tuple[IntArray, int]:
    """``idx`` reordered into the two halves of its box, cut at the middle of its longest side.

    A cut at the middle (not at the median) keeps every box's aspect ratio bounded, so that a
    box's diameter halves every few levels and the boxes admitted as far per level stay
    bounded; both halves are non-empty because the box is the points' own. Coincident points
    (a box of size 0) are split into two halves of their order.
    """
    lo, hi = p.min(axis=0), p.max(axis=0)
    axis = int(np.argmax(hi - lo))
    if median:
        half = len(idx) // 2
        return idx[np.argpartition(p[:, axis], half)], half
    if hi[axis] <= lo[axis]:
        return idx, len(idx) // 2
    left = p[:, axis] < 0.5 * (lo[axis] + hi[axis])
    half = int(np.count_nonzero(left))
    if not 0 < half < len(idx):  # lo and hi adjacent floating-point numbers
        return idx, len(idx) // 2
    return np.concatenate([idx[left], idx[~left]]), half


def _boxes(p: Array, start: IntArray, child: IntArray, depth: IntArray) -> tuple[Array, Array]:
    """Lower and upper corners of every node's box: leaves by ``reduceat``, then parents."""
    lo, hi = np.empty((len(start), 3)), np.empty((len(start), 3))
    leaves = np.flatnonzero(child[:, 0] < 0)
    leaves = leaves[np.argsort(start[leaves])]  # the leaves partition the ordered points
    lo[leaves] = np.minimum.reduceat(p, start[leaves], axis=0)
    hi[leaves] = np.maximum.reduceat(p, start[leaves], axis=0)
    for level in range(int(depth.max()) - 1, -1, -1):
        nodes = np.flatnonzero((depth == level) & (child[:, 0] >= 0))
        a, b = child[nodes, 0], child[nodes, 1]
        lo[nodes] = np.minimum(lo[a], lo[b])
        hi[nodes] = np.maximum(hi[a], hi[b])
    return lo, hi


def _box_gap(tree: Tree, a: IntArray, b: IntArray) -> Array:
    """The distance between the boxes of nodes ``a`` and ``b`` (0 when they overlap)."""
    gap = np.maximum(0.0, np.maximum(tree.lo[a] - tree.hi[b], tree.lo[b] - tree.hi[a]))
    return np.asarray(np.linalg.norm(gap, axis=1))


def interactions(
    tree: Tree, leaves: IntArray, far: float, theta: float, reach: float
) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """Target leaves against source nodes: (near leaf, near leaf), (far leaf, far node).

    A pair is far when the box gap g satisfies g·θ > D (source diameter) and g > ``reach``;
    with θ = 0 nothing is far (exact sums). ``far`` > 0 instead prunes every pair with
    g > far (the minimum-distance query). Vectorised level by level over the frontier.
    """
    diam = tree.diameter
    t, s = leaves, np.zeros_like(leaves)
    near_t, near_s, far_t, far_s = [], [], [], []
    while t.size:
        gap = _box_gap(tree, t, s)
        if far > 0:
            admissible = gap > far
        else:
            admissible = (gap * theta > diam[s]) & (gap > reach)
        leaf = tree.is_leaf(s)
        near = ~admissible & leaf
        refine = ~admissible & ~leaf
        near_t.append(t[near])
        near_s.append(s[near])
        far_t.append(t[admissible])
        far_s.append(s[admissible])
        t = np.repeat(t[refine], 2)
        s = tree.children[s[refine]].ravel()
    return (
        np.concatenate(near_t),
        np.concatenate(near_s),
        np.concatenate(far_t),
        np.concatenate(far_s),
    )


def expand(
    a_start: IntArray, a_len: IntArray, b_start: IntArray, b_len: IntArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """All (a, b) index pairs of the ranges, in blocks of about ``BLOCK`` pairs."""
    counts = a_len * b_len
    bounds = np.searchsorted(np.cumsum(counts), np.arange(BLOCK, counts.sum() + BLOCK, BLOCK))
    first = 0
    for last in np.unique(np.minimum(bounds + 1, len(counts))):
        sl = slice(first, int(last))
        first = int(last)
        c = counts[sl]
        if not c.sum():
            continue
        owner = np.repeat(np.arange(len(c)), c)
        local = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c)
        bl = b_len[sl][owner]
        yield a_start[sl][owner] + local // bl, b_start[sl][owner] + local % bl


def ranges(tree: Tree, nodes: IntArray) -> tuple[IntArray, IntArray]:
    """First position and length of each node's points in ``tree.order``."""
    return tree.start[nodes], tree.end[nodes] - tree.start[nodes]
