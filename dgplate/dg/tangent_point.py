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
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from itertools import pairwise

import numpy as np
import numpy.typing as npt

from dgplate.compat import Array

#: Point pairs per vectorised block (memory ~ 20 arrays of this length): small enough that the
#: temporaries stay in cache and are reused by the allocator (2^20 was 1.5–2 times slower).
_BLOCK = 1 << 17
#: Leaf size of the tree: near pairs per point grow like the leaf, point–box terms shrink with
#: it; 16 was the fastest at θ = 0.5 (3·10⁴ points: 8, 16, 32 in 1.3, 1, 1.2 times the time).
_LEAF = 16
#: Leaf size for the exact sums (θ = 0, the rods' default): only fewer, larger blocks matter.
_LEAF_EXACT = 64

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


@dataclass
class TPResult:
    """TP and its partial derivatives with respect to every point and normal."""

    energy: float
    d_points: Array  # (M, 3)
    d_normals: Array  # (M, 3)
    pairs_exact: int = 0  # point pairs summed exactly
    pairs_far: int = 0  # point–box interactions
    #: The least distance of the pairs summed exactly: of all non-neighbouring pairs when θ = 0.
    min_distance: float = np.inf


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


def build_tree(points: Array, weights: Array, leaf: int = _LEAF, median: bool = False) -> Tree:
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


def _expand(
    a_start: IntArray, a_len: IntArray, b_start: IntArray, b_len: IntArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """All (a, b) index pairs of the ranges, in blocks of about ``_BLOCK`` pairs."""
    counts = a_len * b_len
    bounds = np.searchsorted(np.cumsum(counts), np.arange(_BLOCK, counts.sum() + _BLOCK, _BLOCK))
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


def _excluded(cloud: Cloud, i: IntArray, j: IntArray, reach: float) -> npt.NDArray[np.bool_]:
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


def _power(x: Array, q: float) -> Array:
    """x**q without overwriting x; by products and one square root when 2q is an integer.

    For q = 3 or 4.5 that is several times faster than ``pow``; other q go to ``pow``.
    """
    if q != round(2 * q) / 2 or not 0 < q <= 32:
        return np.asarray(x**q)
    k = int(q)
    out = np.sqrt(x) if q > k else None
    base = x
    while k:
        if k & 1:
            out = base.copy() if out is None else np.multiply(out, base, out=out)
        k >>= 1
        if k:
            base = base * base
    return out if out is not None else np.ones_like(x)


def _projected(cloud: Cloud, s: Array, n2: Array, q: float) -> tuple[Array, Array, Array | None]:
    """The pair value f = |P d|^q |d|^(−2q) and the factors of its derivatives, from s = a·d and n2 = |d|².

    With p² = |P d|² = α n2 + β s² and g = f/p² (0 where p = 0):
    ∂(f/q)/∂d = β g s a + (α g − 2f/n2) d and ∂(f/q)/∂a = β g s d. Returns (f, β g s, α g),
    α g as None when α = 0. For normals (α, β) = (0, 1) this is |s|^(q−2) s |d|^(−2q), as in
    the plates' formula.
    """
    alpha, beta = cloud.projector
    if alpha:
        p2 = s * s
        p2 *= beta
        p2 += alpha * n2
        np.maximum(p2, 0.0, out=p2)  # ≥ 0 up to round-off for tangents
        u = np.sqrt(p2)
    else:
        p2 = s * s
        u = np.abs(s)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # coincident: TP = inf
        u /= n2
        f = _power(u, q)
    g = np.divide(f, p2, out=np.zeros_like(f), where=p2 > 0)
    ag = g * alpha if alpha else None
    g *= s
    if beta != 1.0:
        g *= beta
    return f, g, ag


def _accumulate(target: Array, index: IntArray, values: Array) -> None:
    """target[index] += values, with repeated indices.

    Only the window of ``target`` between the least and the largest index is touched: by one
    ``bincount`` over its flattened components while the window is small (blocks of pairs of
    neighbouring leaves of points in tree order), otherwise by ``np.add.at``, whose cost does
    not grow with the target (a bincount over all of it per block would cost O(M) each).
    """
    if not index.size:
        return
    first = int(index.min())
    window = target[first : int(index.max()) + 1]
    width = values.shape[1]
    flat = ((index - first)[:, None] * width + np.arange(width)).reshape(-1)
    if window.size <= 8 * flat.size:
        window += np.bincount(flat, values.reshape(-1), minlength=window.size).reshape(window.shape)
    else:
        np.add.at(window.reshape(-1), flat, values.reshape(-1))


def _valid(padded: IntArray) -> IntArray:
    """Rows of leaf indices with the padding (−1) replaced by the row's first point.

    The padding's weights are set to 0 by the callers; pointing it into the row keeps the
    indices of a block within a narrow window (:func:`_accumulate`).
    """
    return np.where(padded >= 0, padded, padded[:, :1])


def _range(tree: Tree, nodes: IntArray) -> tuple[IntArray, IntArray]:
    """First position and length of each node's points in ``tree.order``."""
    return tree.start[nodes], tree.end[nodes] - tree.start[nodes]


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
    out = _sums(cloud, replace(tree, order=np.arange(m)), mask[perm], q, theta, reach)
    for name in ("d_points", "d_normals"):
        unsorted = np.empty((m, 3))
        unsorted[perm] = getattr(out, name)
        setattr(out, name, unsorted)
    return out


def _sums(
    cloud: Cloud, tree: Tree, mask: npt.NDArray[np.bool_], q: float, theta: float, reach: float
) -> TPResult:
    """:func:`evaluate` for a cloud in tree order (``tree.order`` the identity)."""
    m = len(cloud.points)
    leaves = np.flatnonzero(tree.children[:, 0] < 0)
    count = np.concatenate([[0], np.cumsum(mask)])
    has_target = count[tree.end[leaves]] > count[tree.start[leaves]]
    near_t, near_s, far_t, far_s = interactions(tree, leaves[has_target], 0.0, theta, reach)
    out = TPResult(0.0, np.zeros((m, 3)), np.zeros((m, 3)))
    padded = _padded_leaves(tree)
    width = padded.shape[1]
    order = np.argsort(tree.start[near_t], kind="stable")  # grouped by target, in tree order
    near_t, near_s = near_t[order], near_s[order]
    for rows, sources in _source_rows(near_t, *_range(tree, near_s), width):
        _near_block(cloud, padded[rows], sources, mask, q, reach, out)
    node_force = np.zeros((len(tree.start), 3))
    order = np.argsort(tree.start[far_t], kind="stable")
    far_t, far_s = far_t[order], far_s[order]
    for rows, nodes in _source_rows(far_t, far_s, np.ones_like(far_s), width):
        _far_block(cloud, tree, padded[rows], nodes, mask, q, out, node_force)
    _push_down(tree, node_force, cloud.weights, out.d_points)
    return out


def _source_rows(
    leaves: IntArray, first: IntArray, length: IntArray, width: int
) -> Iterator[tuple[IntArray, IntArray]]:
    """Target leaves and the lists of their sources, in blocks of about ``_BLOCK`` pairs.

    ``leaves[k]`` meets the sources ``first[k] … first[k] + length[k] − 1`` (points of a leaf
    or one far node), ``leaves`` grouped by leaf. Yields the leaves (p,) of a block and their
    sources (p, S), all ranges of a leaf concatenated into one row, padded with −1: one dense
    (p, L, S) block per row instead of one (L, L) block per pair of leaves, so that the
    matrix products are long and the padding is only at each row's end. A leaf's list longer
    than a block (the exact sums) is cut into several rows.
    """
    if not leaves.size:
        return
    per = max(1, _BLOCK // width)
    row_first = _row_starts(leaves, length, per)
    row_total = np.add.reduceat(length, row_first)
    row_first = np.append(row_first, len(leaves))
    cuts = np.searchsorted(np.cumsum(row_total), np.arange(per, row_total.sum(), per), "right")
    bounds = np.unique(np.concatenate([[0], cuts, [len(row_total)]]))
    for a, b in pairwise(bounds):
        pairs = slice(row_first[a], row_first[b])
        count, totals = length[pairs], row_total[a:b]
        k = np.arange(totals.sum())
        owner = np.repeat(np.arange(len(count)), count)
        position = first[pairs][owner] + k - (np.cumsum(count) - count)[owner]
        row = np.repeat(np.arange(b - a), totals)
        sources = np.full((b - a, int(totals.max())), -1, dtype=np.int64)
        sources[row, k - (np.cumsum(totals) - totals)[row]] = position
        yield leaves[row_first[a:b]], sources


def _row_starts(leaves: IntArray, length: IntArray, per: int) -> IntArray:
    """The first pair of every row: a new leaf, or its sources so far reaching a multiple of ``per``."""
    new_leaf = np.concatenate([[True], leaves[1:] != leaves[:-1]])
    before = np.cumsum(length) - length  # sources before each pair, over all leaves
    leaf_start = np.maximum.accumulate(np.where(new_leaf, before, 0))
    piece = (before - leaf_start) // per
    return np.flatnonzero(new_leaf | np.concatenate([[False], piece[1:] != piece[:-1]]))


def _default_leaf(cloud: Cloud, theta: float) -> int:
    """The leaf size: ``_LEAF_EXACT`` for the exact sums, ``_LEAF`` for surfaces, 32 for curves.

    On a curve the monopoles are the larger error (tests/models/test_rod_self_avoidance.py), and boxes
    of 16 points admitted as far raised it at θ = 0.25 from 4.5e-4 to 1.2e-3 (TP, trefoil).
    """
    if theta == 0:
        return _LEAF_EXACT
    return 2 * _LEAF if cloud.curve else _LEAF


def _padded_leaves(tree: Tree) -> IntArray:
    """The point indices of every node that is a leaf, padded with −1 to the largest leaf."""
    sizes = tree.end - tree.start
    leaf = tree.children[:, 0] < 0
    width = int(sizes[leaf].max(initial=1))
    padded = np.full((len(sizes), width), -1, dtype=np.int64)
    nodes = np.flatnonzero(leaf)
    owner = np.repeat(nodes, sizes[nodes])
    first = np.repeat(tree.start[nodes], sizes[nodes])
    column = np.arange(len(owner)) - np.repeat(np.cumsum(sizes[nodes]) - sizes[nodes], sizes[nodes])
    padded[owner, column] = tree.order[first + column]
    return padded


@dataclass
class _Block:
    """Pairs of a dense block (p, L, Ls): targets (p, L) against sources (p, Ls), centred.

    Coordinates are taken relative to the first target of each row, so that |d|² computed
    as |x_t|² + |x_s|² − 2 x_t·x_s (a batched matrix product instead of three (p, L, Ls)
    differences) loses only digits of the block's size over the pair's distance.
    """

    xt: Array  # (p, L, 3)
    nu: Array  # (p, L, 3) target directions
    xs: Array  # (p, Ls, 3)
    n2: Array  # (p, L, Ls) |d|²
    s: Array  # (p, L, Ls) a_t·d

    @classmethod
    def of(cls, xt: Array, nu: Array, xs: Array) -> _Block:
        """The block of targets xt (directions nu) and sources xs (both overwritten: centred)."""
        centre = xt[:, :1, :].copy()
        xt -= centre
        xs -= centre
        n2 = np.matmul(xt, xs.transpose(0, 2, 1))
        n2 *= -2.0
        n2 += np.einsum("pik,pik->pi", xt, xt)[:, :, None]
        n2 += np.einsum("pjk,pjk->pj", xs, xs)[:, None, :]
        np.maximum(n2, 0.0, out=n2)
        s = np.matmul(nu, xs.transpose(0, 2, 1))
        s -= np.einsum("pik,pik->pi", nu, xt)[:, :, None]
        return cls(xt, nu, xs, n2, s)

    def sums(self, cloud: Cloud, ww: Array, q: float) -> tuple[float, Array, Array, Array]:
        """Σ w f/q and ∂/∂x_t, ∂/∂x_s, ∂/∂a_t of it summed over the block's pairs (weights ww).

        ∂/∂d per pair = S a_t − C d with S = w β g s and C = 2 w f/|d|² − w α g; with
        d = x_s − x_t its sums over sources and over targets are matrix products.
        """
        f, sq, ag = _projected(cloud, self.s, self.n2, q)
        sq *= ww
        f *= ww
        energy = float(f.sum()) / q
        f /= self.n2
        f *= 2.0
        if ag is not None:
            ag *= ww
            f -= ag
        xt, nu, xs = self.xt, self.nu, self.xs
        s_t, c_t = sq.sum(axis=2)[:, :, None], f.sum(axis=2)[:, :, None]
        c_s = f.sum(axis=1)[:, :, None]
        on_target = nu * s_t - np.matmul(f, xs) + xt * c_t
        on_source = np.matmul(sq.transpose(0, 2, 1), nu) - xs * c_s
        on_source += np.matmul(f.transpose(0, 2, 1), xt)
        d_nu = np.matmul(sq, xs) - xt * s_t
        return energy, on_target, on_source, d_nu


def _near_block(
    cloud: Cloud,
    targets: IntArray,
    sources: IntArray,
    mask: npt.NDArray[np.bool_],
    q: float,
    reach: float,
    out: TPResult,
) -> None:
    """Exact sums over pairs of leaves as dense (pairs, L, L) blocks (padding: index −1).

    Gathering per leaf instead of per pair is what makes the near field cheap.
    """
    it, js = _valid(targets), _valid(sources)
    wt = np.where((targets >= 0) & mask[it], cloud.weights[it], 0.0)
    ws = np.where(sources >= 0, cloud.weights[js], 0.0)
    block = _Block.of(cloud.points[it], cloud.normals[it], cloud.points[js])
    n2 = block.n2
    ww = wt[:, :, None] * ws[:, None, :]
    close = np.flatnonzero((ww > 0) & (n2 <= reach * reach) if reach > 0 else ww > 0)
    shape = ww.shape
    t_of = np.broadcast_to(it[:, :, None], shape).reshape(-1)[close]
    s_of = np.broadcast_to(js[:, None, :], shape).reshape(-1)[close]
    excluded = _excluded(cloud, t_of, s_of, 0.0)
    ww.reshape(-1)[close[excluded]] = 0.0
    summed = ww > 0
    if summed.any():
        out.min_distance = min(out.min_distance, float(np.sqrt(n2[summed].min())))
    n2[~summed] = 1.0
    out.pairs_exact += int(np.count_nonzero(summed))
    energy, on_target, on_source, d_nu = block.sums(cloud, ww, q)
    out.energy += energy
    _accumulate(out.d_points, it.reshape(-1), -on_target.reshape(-1, 3))
    _accumulate(out.d_points, js.reshape(-1), on_source.reshape(-1, 3))
    _accumulate(out.d_normals, it.reshape(-1), d_nu.reshape(-1, 3))


def _far_block(
    cloud: Cloud,
    tree: Tree,
    targets: IntArray,
    nodes: IntArray,
    mask: npt.NDArray[np.bool_],
    q: float,
    out: TPResult,
    node_force: Array,
) -> None:
    """Target leaves (p, L) against the monopoles of their far nodes (p, F; padding −1).

    The nodes' centroids are sources of weight the nodes' weights in a dense block like the
    near field's (no excluded pairs). The force on a node's centroid is kept per unit weight
    in ``node_force`` (pushed down to the node's points once, by :func:`_push_down`).
    """
    it, nj = _valid(targets), _valid(nodes)
    wt = np.where((targets >= 0) & mask[it], cloud.weights[it], 0.0)
    ws = np.where(nodes >= 0, tree.weight[nj], 0.0)
    block = _Block.of(cloud.points[it], cloud.normals[it], tree.centroid[nj])
    ww = wt[:, :, None] * ws[:, None, :]
    block.n2[ww == 0] = 1.0
    out.pairs_far += int(np.count_nonzero(ww))
    energy, on_target, on_source, d_nu = block.sums(cloud, ww, q)
    out.energy += energy
    _accumulate(out.d_points, it.reshape(-1), -on_target.reshape(-1, 3))
    _accumulate(out.d_normals, it.reshape(-1), d_nu.reshape(-1, 3))
    on_source /= np.where(ws > 0, ws, 1.0)[:, :, None]
    _accumulate(node_force, nj.reshape(-1), on_source.reshape(-1, 3))


def _push_down(tree: Tree, node_force: Array, weights: Array, d_points: Array) -> None:
    """A source j in node n receives w_j·(force per unit weight on n's centroid)."""
    diff = np.zeros((len(tree.order) + 1, 3))
    np.add.at(diff, tree.start, node_force)
    np.add.at(diff, tree.end, -node_force)
    per_position = np.cumsum(diff[:-1], axis=0)
    d_points[tree.order] += weights[tree.order][:, None] * per_position


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
    for pi, pj in _expand(*_range(tree, near_t), *_range(tree, near_s)):
        i, j = tree.order[pi], tree.order[pj]
        keep = mask[i] & ~_excluded(cloud, i, j, radius)
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
    for a, b in _expand(positions, np.ones(n, dtype=np.int64), positions + 1, later):
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
