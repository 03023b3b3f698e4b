"""Six pinned unknowns that hold a free plate's rigid motions (Newton on its Lagrangian).

A free plate's energy and constraint do not change under the six rigid motions, so its
Jacobian is singular along them. Newton (:mod:`dgplate.solvers.constrained_path`) fixes them
by six Dirichlet conditions on single dG copies of y at three nodes of the reference plate:

- A, the node nearest the centre of the bounding box: y(A), all three components;
- B, the node nearest A + (r, 0) among those with |(B − A)₁| ≥ ½|B − A|: y₂(B) and y₃(B);
- C, the node nearest A + (0, r) among those at 30° or more from the line AB: y₃(C);

with r a quarter of the box's smaller side, each held at its start value. With d = B − A and
e = C − A, an infinitesimal rotation ω × (x − A) keeps the pins only if ω₃d₁ = 0 and
ω₁d₂ − ω₂d₁ = ω₁e₂ − ω₂e₁ = 0, so ω = 0 when d₁ ≠ 0 and d ∦ e, as the choice ensures: no
rigid motion but the identity keeps the pins (on the flat plate, and on a deformed one while
the chords AB and AC keep these properties). The pins carry no force at an equilibrium of the
free plate (its energy's gradient is orthogonal to the rigid motions), so the path is that of
the free plate.

A node has one dG copy per cell around it: the copy pinned is that of the cell with the
smallest centre (x₁, then x₂), chosen alike on any number of ranks; the rank that owns it
shares its global indices, and every rank that holds the copy (owned or ghost) pins it, as
DOLFINx's conditions need.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import numpy.typing as npt

from dgplate import compat, mpi, values
from dgplate.compat import Function, FunctionSpace
from dgplate.errors import InputError

#: The pinned components of y at the nodes A, B and C.
PINNED_COMPONENTS = ((0, 1, 2), (1, 2), (2,))

#: Digits (relative to the plate's size) to which node distances and coordinates are compared.
ROUND_DIGITS = 10

#: B − A must have |(B − A)₁| ≥ ALONG |B − A|; C − A must make an angle whose sine is at least
#: ALONG with B − A (30°).
ALONG = 0.5

Points = npt.NDArray[np.float64]


class NodeCopies:
    """The dG copies of y's nodes in the owned cells: where they are and their unknowns.

    Built from the state's space W (y its first subspace) and the plate's size.

    Attributes:
        points: (cells, nodes, 2) each copy's node, rounded.
        centres: (cells, 2) each cell's centre (the mean of its nodes), rounded.
        unknowns: (3, cells, nodes) each copy's unknown in the state's space, per component.
        space_map: the state's index map and block size.
    """

    def __init__(self, space: FunctionSpace, scale: float) -> None:
        y_space = space.sub(0)
        collapsed = [compat.collapse(y_space.sub(k)) for k in range(3)]
        cells = y_space.mesh.topology.index_map(y_space.mesh.topology.dim).size_local
        first = collapsed[0][0]
        x = first.tabulate_dof_coordinates()[:, :2]
        points = x[first.dofmap.list[:cells]]
        self.points = _rounded(points, scale)
        self.centres = _rounded(points.mean(axis=1), scale)
        self.unknowns = np.array([parent[V.dofmap.list[:cells]] for V, parent in collapsed])
        self.scale = scale
        self.space_map = (space.dofmap.index_map, space.dofmap.index_map_bs)

    def nearest(self, comm: MPI.Comm, target: Points, keep: Any) -> tuple[Points, list[int]]:
        """The node nearest ``target`` among those ``keep`` accepts, and its pinned copy.

        Collective. Ties go to the smaller node (x₁, then x₂), then to the smaller cell centre.

        Args:
            comm: the mesh's communicator.
            target: the point (x₁, x₂).
            keep: the nodes' filter: (n, 2) points → (n,) bools.

        Returns:
            The node, and the global indices of its copy's three unknowns in the state's space.

        Raises:
            InputError: no node passes the filter (a plate too thin or too coarse to pin).
        """
        points = self.points.reshape(-1, 2)
        centres = np.repeat(self.centres, self.points.shape[1], axis=0)
        distance = np.round(np.linalg.norm(points - target, axis=1) / self.scale, ROUND_DIGITS)
        order = np.lexsort((centres[:, 1], centres[:, 0], points[:, 1], points[:, 0], distance))
        order = order[keep(points[order])]
        best = mpi.least(comm, _key(distance, points, centres, order[0]) if len(order) else None)
        if best is None:
            raise InputError(
                "model.clamped: a free plate's path needs three nodes not in one line to hold "
                "its rigid motions (refine the mesh)"
            )
        owner = int(best[-1])
        copy = None
        if comm.rank == owner:
            cell, node = divmod(int(order[0]), self.points.shape[1])
            copy = _global(self.unknowns[:, cell, node], self.space_map)
        return np.array(best[1:3]), comm.bcast(copy, root=owner)


def _key(distance: Points, points: Points, centres: Points, i: int) -> tuple[float, ...]:
    """The order of copy ``i`` among the candidates: distance, node, cell centre."""
    return (float(distance[i]), *map(float, points[i]), *map(float, centres[i]))


def _rounded(x: Points, scale: float) -> Points:
    """``x`` rounded to :data:`ROUND_DIGITS` digits of ``scale``."""
    rounded: Points = np.round(x / scale, ROUND_DIGITS) * scale
    return rounded


def _global(local: npt.NDArray[np.int32], space_map: tuple[Any, int]) -> list[int]:
    """The global indices of the state's local unknowns ``local``."""
    index_map, bs = space_map
    blocks = index_map.local_to_global(np.asarray(local // bs, dtype=np.int32))
    return [int(b) * bs + int(c) for b, c in zip(blocks, local % bs, strict=True)]


def _local(index: int, space_map: tuple[Any, int]) -> npt.NDArray[np.int32]:
    """The local index of the state's global unknown ``index`` (owned or ghost; [] if absent)."""
    index_map, bs = space_map
    block, component = divmod(index, bs)
    start, end = index_map.local_range
    if start <= block < end:
        return np.array([(block - start) * bs + component], dtype=np.int32)
    ghost = np.flatnonzero(np.asarray(index_map.ghosts) == block)
    local = (index_map.size_local + ghost[:1]) * bs + component
    return np.asarray(local, dtype=np.int32)


def _along_x(a: Points) -> Any:
    """The filter of B: |(x − A)₁| ≥ ALONG |x − A| (x ≠ A)."""

    def keep(points: Points) -> npt.NDArray[np.bool_]:
        rel = points - a
        length = np.linalg.norm(rel, axis=1)
        accepted: npt.NDArray[np.bool_] = (length > 0) & (np.abs(rel[:, 0]) >= ALONG * length)
        return accepted

    return keep


def _off_line(a: Points, b: Points) -> Any:
    """The filter of C: at an angle whose sine is ALONG or more from the line AB."""

    def keep(points: Points) -> npt.NDArray[np.bool_]:
        along, rel = b - a, points - a
        cross = np.abs(along[0] * rel[:, 1] - along[1] * rel[:, 0])
        bound = ALONG * np.linalg.norm(along) * np.linalg.norm(rel, axis=1)
        accepted: npt.NDArray[np.bool_] = cross >= np.maximum(bound, 1e-300)
        return accepted

    return keep


def rigid_pins(state: Function) -> list[Any]:
    """Six Dirichlet conditions that hold the rigid motions of a free plate (collective).

    Args:
        state: w = (y, μ[, p]) at the start, y its first subspace; each pin keeps its value.

    Returns:
        The DirichletBCs (on the subspaces of y's components).

    Raises:
        InputError: the mesh has no three nodes to pin (:meth:`NodeCopies.nearest`).
    """
    W = state.function_space
    y_space, mesh = W.sub(0), W.mesh
    lo, hi = mpi.bounding_box(mesh.comm, mesh.geometry.x[:, :2])
    r = 0.25 * float(np.min(hi - lo))
    copies = NodeCopies(W, float(np.max(hi - lo)))
    a, at_a = copies.nearest(mesh.comm, (lo + hi) / 2, lambda p: np.ones(len(p), dtype=bool))
    b, at_b = copies.nearest(mesh.comm, a + np.array([r, 0.0]), _along_x(a))
    _, at_c = copies.nearest(mesh.comm, a + np.array([0.0, r]), _off_line(a, b))
    pins: list[Any] = []  # DirichletBC (its generic parameter differs between versions)
    for unknowns, pinned in zip((at_a, at_b, at_c), PINNED_COMPONENTS, strict=True):
        for k in pinned:
            dofs = _local(unknowns[k], copies.space_map)
            value = float(state.x.array[dofs[0]]) if len(dofs) else 0.0
            pins.append(dolfinx.fem.dirichletbc(values.constant(mesh, value), dofs, y_space.sub(k)))
    return pins


def hold_in_place(pins: Sequence[Any], state: Function) -> None:
    """Each pin's value set to the one its unknown has in ``state`` (collective).

    A path's pins keep the values of the state it starts from: after a flow to the start, or
    on a resume (the pinned unknowns do not move along a path, so these are the values of
    the first start). The ghosts of ``state`` are updated first, so that the ranks that hold
    a pinned unknown as a ghost read its owner's value.

    Args:
        pins: the DirichletBCs of :func:`rigid_pins`.
        state: w = (y, μ[, p]) where the path starts.
    """
    state.x.scatter_forward()
    for pin in pins:
        dofs = pin.dof_indices()[0]
        if len(dofs):
            pin.g.value[...] = state.x.array[dofs[0]]
