"""Numbers of a scalar field for progress lines and summaries: its value at a point, its extreme.

Both give the same number on any number of ranks (collective on the mesh communicator).
"""

from __future__ import annotations

from collections.abc import Sequence

from mpi4py import MPI

import dolfinx.fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np

from dgplate import compat, mpi


class PointProbe:
    """The value of functions at one point of the mesh.

    A discontinuous function has one value per cell that contains the point (a vertex, a
    facet): the probe returns their mean over those cells, each counted once on the rank that
    owns it. Raises ``ValueError`` when no cell contains the point.
    """

    def __init__(self, mesh: dolfinx.mesh.Mesh[np.float64], point: Sequence[float]) -> None:
        self.mesh, self.comm = mesh, mesh.comm
        tdim = mesh.topology.dim
        owned = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        tree = dolfinx.geometry.bb_tree(mesh, tdim, entities=owned)
        self.point = np.zeros((1, 3), dtype=mesh.geometry.x.dtype)
        self.point[0, : len(point)] = point
        candidates = dolfinx.geometry.compute_collisions_points(tree, self.point)
        colliding = dolfinx.geometry.compute_colliding_cells(mesh, candidates, self.point)
        self.cells = np.asarray(colliding.links(0), dtype=np.int32)
        self.count = int(self.comm.allreduce(self.cells.size, op=MPI.SUM))
        if self.count == 0:
            raise ValueError(f"the point {list(point)} lies outside the mesh")

    def __call__(self, u: dolfinx.fem.Function[np.float64], component: int | None = None) -> float:
        """U at the point (the mean over the cells that contain it).

        Args:
            u: the function (scalar unless ``component`` is given).
            component: the component of a vector-valued ``u``.

        Returns:
            The value.
        """
        local = 0.0
        if self.cells.size:
            points = np.repeat(self.point, self.cells.size, axis=0)
            values = np.reshape(u.eval(points, self.cells), (self.cells.size, -1))
            local = float(np.sum(values if component is None else values[:, component]))
        return float(self.comm.allreduce(local, op=MPI.SUM) / self.count)


def central_probe(mesh: dolfinx.mesh.Mesh[np.float64]) -> PointProbe:
    """A probe at the centre of the mesh's bounding box, or at the node nearest it (collective).

    The node when the centre lies outside the mesh (a hole there).

    Args:
        mesh: the mesh.

    Returns:
        The probe.
    """
    comm, x = mesh.comm, mesh.geometry.x[:, :2]
    lo, hi = mpi.bounding_box(comm, x)
    centre = (lo + hi) / 2
    try:
        return PointProbe(mesh, centre.tolist())
    except ValueError:  # ties go to the smaller node, whatever the partition
        distances = np.linalg.norm(x - centre, axis=1)
        order = np.lexsort((x[:, 1], x[:, 0], distances))
        local = (float(distances[order[0]]), *map(float, x[order[0]])) if len(order) else None
        best = mpi.least(comm, local)
        assert best is not None  # some rank holds nodes
        return PointProbe(mesh, list(best[1:3]))


def signed_extreme(u: dolfinx.fem.Function[np.float64]) -> float:
    """The degree-of-freedom value of largest magnitude, with its sign (scalar ``u``)."""
    space = u.function_space
    owned = u.x.array[: space.dofmap.index_map.size_local * space.dofmap.index_map_bs]
    comm = space.mesh.comm
    lo = float(comm.allreduce(float(owned.min(initial=np.inf)), op=MPI.MIN))
    hi = float(comm.allreduce(float(owned.max(initial=-np.inf)), op=MPI.MAX))
    return hi if hi >= -lo else lo


def height(y: dolfinx.fem.Function[np.float64]) -> float:
    """The span max y₃ − min y₃ of a deformation's dofs: a free plate's deflection (collective).

    Args:
        y: a deformation in [DG_k]³.

    Returns:
        The span, the same on every rank.
    """
    space = y.function_space
    owned = y.x.array.reshape(-1, 3)[: space.dofmap.index_map.size_local, 2]
    lo, hi = mpi.bounding_box(space.mesh.comm, owned.reshape(-1, 1))
    return float(hi[0] - lo[0])


class DeflectionProbes:
    """The probes hook of an FvK state (w, u): ``w_max``, ``w_center`` and ``w_<name>``.

    ``w_max`` is the signed extreme; ``w_<name>`` is w at each named point.
    """

    def __init__(
        self,
        state: dolfinx.fem.Function[np.float64],
        probe: PointProbe,
        named: dict[str, PointProbe] | None = None,
    ) -> None:
        self.state, self.probe, self.named = state, probe, named or {}
        space, self._dofs = compat.collapse(state.function_space.sub(0))
        self.w: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(space, name="w")

    def __call__(self) -> dict[str, float]:
        """The numbers of the current state (collective)."""
        self.w.x.array[:] = self.state.x.array[self._dofs]
        numbers = {"w_max": signed_extreme(self.w), "w_center": self.probe(self.w)}
        numbers.update({f"w_{name}": probe(self.w) for name, probe in self.named.items()})
        return numbers
