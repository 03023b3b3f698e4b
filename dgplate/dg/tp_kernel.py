"""The tangent-point pair sums: the kernel of one pair and the dense blocks of pairs.

For the pairs listed by :func:`dgplate.dg.cluster_tree.interactions`, :func:`sums` adds TP and
its derivatives over dense (rows, targets, sources) blocks: a target leaf against the points of
all its near leaves, or against the centroids of all its far boxes (see
:mod:`dgplate.dg.tangent_point`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import numpy.typing as npt

from dgplate.compat import Array
from dgplate.dg.cluster_tree import BLOCK, Cloud, IntArray, Tree, interactions, ranges
from dgplate.dg.pair_search import neighbours


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


def sums(
    cloud: Cloud, tree: Tree, mask: npt.NDArray[np.bool_], q: float, theta: float, reach: float
) -> TPResult:
    """TP and its derivatives for a cloud in tree order (``tree.order`` the identity).

    The sums of :func:`dgplate.dg.tangent_point.evaluate`, which puts the cloud in that order.
    """
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
    for rows, sources in _source_rows(near_t, *ranges(tree, near_s), width):
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
    """Target leaves and the lists of their sources, in blocks of about ``BLOCK`` pairs.

    ``leaves[k]`` meets the sources ``first[k] … first[k] + length[k] − 1`` (points of a leaf
    or one far node), ``leaves`` grouped by leaf. Yields the leaves (p,) of a block and their
    sources (p, S), all ranges of a leaf concatenated into one row, padded with −1: one dense
    (p, L, S) block per row instead of one (L, L) block per pair of leaves, so that the
    matrix products are long and the padding is only at each row's end. A leaf's list longer
    than a block (the exact sums) is cut into several rows.
    """
    if not leaves.size:
        return
    per = max(1, BLOCK // width)
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
    excluded = neighbours(cloud, t_of, s_of, 0.0)
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
