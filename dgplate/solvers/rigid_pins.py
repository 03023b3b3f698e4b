"""Six pinned unknowns that hold a free plate's rigid motions (Newton on its Lagrangian).

A free plate's energy and constraint do not change under the six rigid motions, so its
Jacobian is singular along them. Newton (:mod:`dgplate.solvers.constrained_path`) fixes them
by six Dirichlet conditions on single dG copies of y at three nodes of the reference plate:

- A, the node nearest the centre of the bounding box: y(A), all three components;
- B, the node nearest A + (r, 0): y₂(B) and y₃(B);
- C, the node nearest A + (0, r), not on the line AB: y₃(C);

with r a quarter of the box's smaller side, each held at its start value. The infinitesimal
rotations ω × (x − A) that keep them are zero when B − A has an x₁ part and C − A is not
parallel to it. The pins carry no force at an equilibrium of the free plate (its energy's
gradient is orthogonal to the rigid motions), so the path is that of the free plate.

A node has one dG copy per cell around it: the copy pinned is that of the cell with the
smallest centre (x₁, then x₂), chosen alike on any number of ranks; its ghost copies are pinned
too, as DOLFINx's conditions need.
"""

from __future__ import annotations

from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import numpy.typing as npt

from dgplate import compat, mpi, values
from dgplate.compat import Function, FunctionSpace

#: The pinned components of y at the nodes A, B and C.
PINNED_COMPONENTS = ((0, 1, 2), (1, 2), (2,))

#: Relative size below which two node coordinates or distances count as equal.
ROUND_DIGITS = 10

Points = npt.NDArray[np.float64]


class NodeCopies:
    """The dG copies of the nodes of one scalar component of y: positions and their cells.

    Attributes:
        space: the component's subspace of the state's space.
        to_parent: the collapsed dof → the state's dof.
        points: each collapsed dof's node (x₁, x₂), rounded.
        centres: each collapsed dof's cell centre, rounded.
        owned: the number of collapsed dofs of owned cells.
    """

    def __init__(self, space: FunctionSpace, scale: float) -> None:
        collapsed, self.to_parent = compat.collapse(space)
        self.space = space
        x = collapsed.tabulate_dof_coordinates()[:, :2]
        cells = collapsed.dofmap.list
        centres = np.empty_like(x)
        centres[cells.ravel()] = np.repeat(x[cells].mean(axis=1), cells.shape[1], axis=0)
        self.points, self.centres = _rounded(x, scale), _rounded(centres, scale)
        self.owned = collapsed.dofmap.index_map.size_local * collapsed.dofmap.index_map_bs

    def nearest(self, comm: MPI.Comm, target: Points, away: list[Points]) -> tuple[Points, Points]:
        """The node nearest ``target`` and the centre of its pinned copy's cell (collective).

        Args:
            comm: the mesh's communicator.
            target: the point (x₁, x₂).
            away: points the node must not be (one) or lie on the line through (two).

        Returns:
            The node and the cell centre, the same on every rank.
        """
        points, centres = self.points[: self.owned], self.centres[: self.owned]
        keep = _off(points, away)
        distance = np.round(np.linalg.norm(points - target, axis=1), ROUND_DIGITS)
        order = np.lexsort((centres[:, 1], centres[:, 0], points[:, 1], points[:, 0], distance))
        order = order[keep[order]]
        mine = [(distance[i], *points[i], *centres[i]) for i in order[:1]]
        best = min(entry for entries in comm.allgather(mine) for entry in entries)
        return np.array(best[1:3]), np.array(best[3:5])

    def copies(self, node: Points, centre: Points) -> npt.NDArray[np.int32]:
        """The state's dofs of this component's copy of ``node`` in the cell of ``centre``.

        Owned and ghost ones; none on a rank without that cell.
        """
        at = np.all(self.points == node, axis=1) & np.all(self.centres == centre, axis=1)
        dofs: npt.NDArray[np.int32] = np.asarray(self.to_parent, dtype=np.int32)[at]
        return dofs


def _rounded(x: Points, scale: float) -> Points:
    """``x`` rounded to :data:`ROUND_DIGITS` digits of ``scale``."""
    rounded: Points = np.round(x / scale, ROUND_DIGITS) * scale
    return rounded


def _off(points: Points, away: list[Points]) -> npt.NDArray[np.bool_]:
    """Which ``points`` are not ``away[0]`` (one point) or off the line through two."""
    if not away:
        return np.ones(len(points), dtype=bool)
    a = away[0]
    if len(away) == 1:
        apart: npt.NDArray[np.bool_] = np.linalg.norm(points - a, axis=1) > 0
        return apart
    along, rel = away[1] - a, points - a
    cross = along[0] * rel[:, 1] - along[1] * rel[:, 0]
    off: npt.NDArray[np.bool_] = np.abs(cross) > 1e-6 * float(np.dot(along, along))
    return off


def rigid_pins(state: Function) -> list[Any]:
    """Six Dirichlet conditions that hold the rigid motions of a free plate (collective).

    Args:
        state: w = (y, μ[, p]) at the start, y its first subspace; each pin keeps its value.

    Returns:
        The DirichletBCs, on the subspaces of y's components.
    """
    y_space = state.function_space.sub(0)
    mesh = y_space.mesh
    lo, hi = mpi.bounding_box(mesh.comm, mesh.geometry.x[:, :2])
    scale = float(np.max(hi - lo))
    r = 0.25 * float(np.min(hi - lo))
    components = [NodeCopies(y_space.sub(k), scale) for k in range(3)]
    nodes: list[Points] = []
    pins: list[Any] = []  # DirichletBC (its generic parameter differs between versions)
    for offset, pinned in zip(([0.0, 0.0], [r, 0.0], [0.0, r]), PINNED_COMPONENTS, strict=True):
        target = (nodes[0] if nodes else (lo + hi) / 2) + np.asarray(offset)
        node, centre = components[0].nearest(mesh.comm, target, nodes)
        nodes.append(node)
        for k in pinned:
            dofs = components[k].copies(node, centre)
            value = float(state.x.array[dofs[0]]) if len(dofs) else 0.0
            bc = dolfinx.fem.dirichletbc(values.constant(mesh, value), dofs, y_space.sub(k))
            pins.append(bc)
    return pins
